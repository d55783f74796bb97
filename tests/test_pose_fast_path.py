"""The small-N fast path of the pose pipeline (one fused compiled kernel, issue 12 item 6) gives the results of the
general path for every field of PoseEvaluation."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import pkmstiff.admissibility.fastpath as fastpath
from pkmstiff.admissibility.pipeline import evaluate_chunk, evaluate_poses
from pkmstiff.admissibility.checks import ALL_CHECKS
from pkmstiff.kinematics.inverse import IK_ARRAYS
from pkmstiff.machine.loader import load_machine


def _poses(n: int, seed: int) -> np.ndarray:
    """Random poses around each machine's workspace, some inadmissible, plus degenerate and unreachable ones."""
    rng = np.random.default_rng(seed)
    p = rng.uniform([-0.6, -0.6, -1.4, -0.4, -0.4, -0.4], [0.6, 0.9, -0.6, 0.4, 0.4, 0.4], size=(n, 6))
    p[0] = [0.0, 0.3, -0.9, 0.0, 0.0, 0.0]
    p[1] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # platform in the drive plane (glide: degenerate J_C^-1 rows)
    p[2] = [0.0, 5.0, -1.0, 0.0, 0.0, 0.0]  # unreachable chains (NaN joint points)
    p[3] = [0.0, 0.0, 1.2, 0.0, 0.0, 0.0]  # pod machines: above the frame
    return p


def _assert_same(a, b) -> None:
    """Every field equal bit for bit (NaN where NaN), except the static drive loads: the general path sums
    R · CoG with einsum's (possibly vectorised) order, the kernel left to right, so they may differ by a few
    ulp; 1e-12 of the largest |tau_g| is ~1e4 ulp of slack and far below any force resolution."""
    for name in ("poses", "drive", "strut_length", "drive_point", "platform_point", "jinv", "jc", "kappa"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.ik.kind == b.ik.kind and a.checks == b.checks
    for name in IK_ARRAYS:  # the whole inverse kinematics travels with the evaluation (the structure model reuses it)
        np.testing.assert_array_equal(getattr(a.ik, name), getattr(b.ik, name), err_msg=f"ik.{name}")
    assert list(a.angles) == list(b.angles)
    for key in a.angles:
        np.testing.assert_array_equal(a.angles[key], b.angles[key], err_msg=key)
    if a.drive_loads is None:
        assert b.drive_loads is None
    else:
        scale = np.nanmax(np.abs(b.drive_loads), initial=1.0)
        np.testing.assert_allclose(a.drive_loads, b.drive_loads, rtol=0, atol=1e-12 * scale, equal_nan=True)
    np.testing.assert_array_equal(a.admissibility.ok, b.admissibility.ok)
    np.testing.assert_array_equal(a.admissibility.reasons, b.admissibility.reasons)
    assert a.admissibility.reasons.dtype == b.admissibility.reasons.dtype
    assert list(a.admissibility.checks) == list(b.admissibility.checks)
    for key, ca in a.admissibility.checks.items():
        cb = b.admissibility.checks[key]
        assert (ca.reason, ca.labels, ca.skipped) == (cb.reason, cb.labels, cb.skipped), key
        np.testing.assert_array_equal(ca.ok, cb.ok, err_msg=key)
        if ca.detail is None:
            assert cb.detail is None, key
        else:
            np.testing.assert_array_equal(ca.detail, cb.detail, err_msg=key)
    assert a.extra.keys() == b.extra.keys()


def _both(m, poses, monkeypatch, **kw):
    monkeypatch.setenv("PKMSTIFF_JIT", "1")  # the fast path runs only with the compiled kernels
    assert fastpath.usable(m, len(poses))
    fast = evaluate_poses(m, poses, **kw)
    monkeypatch.setattr(fastpath, "SMALL_N", 0)
    general = evaluate_poses(m, poses, **kw)
    return fast, general


@pytest.mark.parametrize("name", ["hexaglide", "hexapod_6x", "felix"])
def test_fast_path_equals_general_path(name, monkeypatch):
    m = load_machine(name)
    p = _poses(40, 11)
    fast, general = _both(m, p, monkeypatch)
    monkeypatch.undo()
    _assert_same(fast, general)
    assert fast.admissibility.ok.any() and not fast.admissibility.ok.all()  # both outcomes are exercised
    for i in range(6):  # one pose at a time: the benchmarked case
        f1, g1 = _both(m, p[i:i + 1], monkeypatch)
        monkeypatch.undo()
        _assert_same(f1, g1)


@pytest.mark.parametrize("name", ["hexaglide", "linapod"])
def test_fast_path_options(name, monkeypatch):
    """Check subsets, no drive-load data and a requirement take the fast path with the general path's results."""
    m = load_machine(name)
    p = _poses(12, 5)
    req = [lambda ev: ev.drive[:, 0] > np.nanmedian(ev.drive[:, 0])]
    for kw in ({"checks": ("singularity", "drive_load", "frame")}, {"drive_load_data": None},
               {"requirements": req}, {"checks": ALL_CHECKS[:3], "requirements": req}):
        fast, general = _both(m, p, monkeypatch, **kw)
        monkeypatch.undo()
        _assert_same(fast, general)


def test_fast_path_not_taken(monkeypatch):
    """Interpreted kernels keep the general path; the fast path declines large N."""
    m = load_machine("hexaglide")
    monkeypatch.setenv("PKMSTIFF_JIT", "0")
    assert not fastpath.usable(m, 1)
    monkeypatch.setenv("PKMSTIFF_JIT", "1")
    assert fastpath.usable(m, fastpath.SMALL_N) and not fastpath.usable(m, fastpath.SMALL_N + 1)
    ev = evaluate_chunk(m, _poses(4, 1), ("singularity",))
    assert ev.checks == ("singularity",) and len(ev.angles) == 10


def test_fast_path_hands_back_near_threshold(monkeypatch):
    """A pose whose certified κ bounds straddle the singularity threshold needs an exact κ: the fast path declines
    and the general path decides (same result either way)."""
    m = load_machine("hexaglide")
    p = _poses(4, 2)
    kappa = evaluate_poses(m, p[:1]).kappa[0]
    m2 = dataclasses.replace(m, limits=dataclasses.replace(m.limits, singularity_threshold=float(kappa)))
    monkeypatch.setenv("PKMSTIFF_JIT", "1")
    assert fastpath.evaluate_small(m2, p, ALL_CHECKS, None) is None
    fast, general = _both(m2, p, monkeypatch)
    _assert_same(fast, general)


def test_fast_path_machine_variants(monkeypatch):
    """Drive offsets (calibrated machines), Table B.2 strut distances and a set platform-end exclusion."""
    m = load_machine("felix")
    m2 = dataclasses.replace(
        m, chains=dataclasses.replace(m.chains, drive_offset=np.linspace(-0.01, 0.02, m.n_chains)),
        limits=dataclasses.replace(m.limits, strut_collision_mode="table_B2", platform_end_exclusion=0.01))
    fast, general = _both(m2, _poses(20, 9), monkeypatch)
    _assert_same(fast, general)
