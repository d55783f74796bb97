"""The forward-kinematics fast path of mechanisms of length legs (pkmstiff.mechanisms.reduced) against the full
link-and-joint path (``PKMSTIFF_FULL_FK=1``): same statuses, ranks and controlled-output κ, the same configuration
to 1e-10 (both converge to 1e-13 × length scale; the leg frames follow from the output frame in closed form)."""

from __future__ import annotations

import numpy as np
import pytest

import pkmstiff.mechanisms as mm
from pkmstiff.mechanisms import reduced
from pkmstiff.mechanisms.constraints import fk_system
from pkmstiff.mechanisms.linalg import singular_values
from pkmstiff.mechanisms.solver import forward

#: configurations of two Newton solves to 1e-13 × length scale (≈ 1.5e-13 m) of a regular pose differ by
#: ~κ·1e-13; 1e-10 leaves a factor of ~10 for κ up to 10² (the workspace's κ is ≤ 10)
Q_TOL = 1e-10


def _both(monkeypatch, mech, drives, **kw):
    monkeypatch.setenv("PKMSTIFF_FULL_FK", "1")
    full = forward(mech, drives, **kw)
    monkeypatch.setenv("PKMSTIFF_FULL_FK", "0")
    fast = forward(mech, drives, **kw)
    return full, fast


def _agree(full, fast):
    assert (full.status == fast.status).all(), (full.summary(), fast.summary())
    assert (full.rank == fast.rank).all()
    ok = full.ok
    assert np.abs(full.q[ok] - fast.q[ok]).max() <= Q_TOL
    kf, kr = full.output_kappa[ok], fast.output_kappa[ok]
    # κ of the same 6 × 6 matrix by two SVDs (LAPACK / Jacobi, rounding ~1e-15·κ) at configurations that differ by
    # up to ~κ·1e-13 (both solves stop at 1e-13 × length scale), which moves κ by ~κ²·1e-13 relative: 1e-10 in
    # the workspace (κ ≲ 10), more only near a singularity
    assert (np.abs(kr / kf - 1.0) <= 1e-10 + 1e-13 * kf**2).all()


REDUCIBLE = ["hexapod_6ups", "hexapod_6x_generic", "hexaglide_generic", "hexa_6rus"]
#: random-pose span (m, degrees) inside each workspace
SPAN = {"hexa_6rus": (0.04, 5.0)}


@pytest.mark.parametrize("name", REDUCIBLE)
def test_reducible(name):
    mech = mm.load_mechanism(name)
    lp = reduced.leg_plan(mech)
    assert lp is not None and len(set(lp.leg_links.tolist())) == 6
    assert (lp.crank >= 0).all() == (name == "hexa_6rus")
    assert mm.info(mech).forward_path == "length_legs"


@pytest.mark.parametrize("name", ["hybrid_tripod_wrist", "five_bar", "slider_crank", "biglide_generic",
                                  "bipod_generic"])
def test_not_reducible_keeps_full_path(name, monkeypatch):
    mech = mm.load_mechanism(name)
    assert reduced.leg_plan(mech) is None and mm.info(mech).forward_path == "full"

    def boom(*a, **k):
        raise AssertionError("reduced path used")

    monkeypatch.setattr(reduced, "solve", boom)
    sol = forward(mech, [j.drive.offset for j in mech.drives])
    assert sol.converged.all()


def _poses(mech, n, rng, span=0.2, deg=10.0):
    return mech.home_output_pose + np.column_stack([rng.uniform(-span, span, (n, 3)),
                                                   np.radians(rng.uniform(-deg, deg, (n, 3)))])


@pytest.mark.parametrize("name", REDUCIBLE)
def test_random_and_unreachable_poses_agree(name, monkeypatch):
    mech = mm.load_mechanism(name)
    rng = np.random.default_rng(3)
    ik = mm.inverse(mech, _poses(mech, 120, rng, *SPAN.get(name, (0.1, 5.0))))
    d = ik.drives[ik.ok]
    d[:12] += rng.uniform(-0.6, 0.6, (12, 6))  # many of these are unreachable
    d[12:16] += 2.5  # far outside (m or rad): no_solution / max_iter
    full, fast = _both(monkeypatch, mech, d)
    assert (~full.converged[:16]).sum() >= 3
    _agree(full, fast)


def test_near_singular_poses_agree(monkeypatch):
    """The 6-UPS is singular at a 90° turn about z (κ → ∞): FK from a start at 85° of drive values 1e-9° … 1° from
    it (and at it) gives the full path's statuses (the fast path hands these poses over)."""
    mech = mm.load_mechanism("hexapod_6ups")
    off = np.concatenate([[0.0], 10.0 ** np.arange(-9, 1), -(10.0 ** np.arange(-9, 1))])
    P = np.zeros((off.size, 6))
    P[:, 2] = 1.2
    P[:, 5] = np.radians(90.0 + off)
    d = mm.inverse(mech, P, steps=20).drives
    start = mm.inverse(mech, [0, 0, 1.2, 0, 0, np.radians(85.0)], steps=20)
    full, fast = _both(monkeypatch, mech, d, start=start)
    assert (full.status == "singular").sum() >= 3
    _agree(full, fast)


def test_start_and_continuation_agree(monkeypatch):
    """A start Solution (per pose) and targets far from home (several continuation steps) give the same
    configurations on both paths."""
    mech = mm.load_mechanism("hexapod_6ups")
    rng = np.random.default_rng(5)
    P = _poses(mech, 40, rng)
    near = P + np.concatenate([np.full(3, 1e-3), np.full(3, np.radians(0.1))])
    start = mm.inverse(mech, near)
    full, fast = _both(monkeypatch, mech, mm.inverse(mech, P).drives, start=start)
    _agree(full, fast)
    far = mm.inverse(mech, [0.3, -0.2, 1.7, 0.3, -0.2, 0.4], steps=8).drives
    full, fast = _both(monkeypatch, mech, far, steps=3)
    assert fast.converged.all()
    _agree(full, fast)


@pytest.mark.parametrize("name", REDUCIBLE)
def test_certified_poses_are_regular_in_the_full_system(name):
    """The full system's exact σ_min/σ_max is ≥ 0.01 × the reduced path's lower bound ``rcond`` over a wide
    workspace, so that REGULAR_SCREEN certifies ≥ 100 × the full path's ``singular_tol`` (1e-7)."""
    mech = mm.load_mechanism(name)
    rng = np.random.default_rng(7)
    span, deg = SPAN.get(name, (0.25, 20.0))
    ik = mm.inverse(mech, _poses(mech, 300, rng, span, 2 * deg), steps=4)
    sol = forward(mech, ik.drives[ik.ok], steps=4)
    cert = np.flatnonzero(sol.converged & np.isnan(sol.sigma_ratio) & (sol.rcond >= reduced.REGULAR_SCREEN))
    assert cert.size > 100
    _, J = fk_system(mech).evaluate(sol.q[cert], sol.drives[cert], reduced=True, omega=True)
    s = singular_values(np.ascontiguousarray(J))
    ratio = s[:, -1] / s[:, 0]
    assert (ratio / sol.rcond[cert]).min() >= 0.01
    assert 0.01 * reduced.REGULAR_SCREEN >= 100 * 1e-7
