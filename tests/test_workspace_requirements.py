"""Requirement parser, quantity hook and the staged admissibility oracle (spec models.md §7.1, §7.3, §8)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pkmstiff import load_machine
from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.errors import ArgumentError
from pkmstiff.evaluation.quantities import Quantity, register_quantity
from pkmstiff.kinematics import transmission_quality
from pkmstiff.workspace.oracle import PoseOracle, staged_admissible
from pkmstiff.workspace.requirements import parse_requirement
from tests.conftest import BUNDLED, CENTRE


def _poses_around(name: str, n: int, seed: int = 0, rot: float = 0.15, span: float = 0.5) -> np.ndarray:
    rng = np.random.default_rng(seed)
    c = np.asarray(CENTRE[name])
    x = np.empty((n, 6))
    x[:, :3] = c[:3] + rng.uniform(-span, span, (n, 3))
    x[:, 3:] = c[3:] + rng.uniform(-rot, rot, (n, 3))
    return x


def test_parse_dimensionless_and_si_conversion():
    r = parse_requirement("U>=0.2")
    assert (r.quantity, r.op, r.limit_si) == ("U", ">=", 0.2)
    r = parse_requirement("  kappa <= 100 ")
    assert (r.quantity, r.op, r.limit_si) == ("kappa", "<=", 100.0)
    r = parse_requirement("tilt_drive_max=<40 deg")
    assert r.op == "<=" and r.limit_si == pytest.approx(math.radians(40), rel=1e-15)
    r = parse_requirement("drive_load_max<1.5 kN")
    assert r.limit_si == pytest.approx(1500.0, rel=1e-15)


def test_registered_structure_quantity_takes_units():
    # the hook the structure model will use; N/um -> N/m and Hz stay SI
    register_quantity(Quantity("kx_test", "test stiffness", "N/um", "N/m", lambda ctx: np.full(len(ctx.ev.poses), 3.0e7)))
    r = parse_requirement("kx_test>=20 N/um")
    assert r.limit_si == pytest.approx(2.0e7, rel=1e-12)
    assert parse_requirement("kx_test > 0.02 N/nm").limit_si == pytest.approx(2.0e7, rel=1e-12)
    with pytest.raises(ArgumentError, match="N/um"):
        parse_requirement("kx_test>=20 Hz")
    with pytest.raises(ArgumentError, match="needs a unit"):
        parse_requirement("kx_test>=20")


@pytest.mark.parametrize("text,match", [("kx=>", "expected 'NAME OP VALUE"), ("no_such_quantity>=1", "unknown"),
                                        ("U>=abc", "U"), ("U==0.2", "expected 'NAME OP VALUE"),
                                        ("tilt_drive_max<=40 mm", "deg")])
def test_bad_requirements_are_explained(text, match):
    with pytest.raises(ArgumentError, match=match):
        parse_requirement(text)


def test_requirement_on_structure_quantity_filters_poses():
    m = load_machine("hexaglide")
    register_quantity(Quantity("kz_test", "test stiffness", "N/um", "N/m", lambda ctx: 1e7 * (1.0 - ctx.ev.poses[:, 2])))  # fake: stiffer lower
    x = _poses_around("hexaglide", 400, seed=3)
    base = evaluate_poses(m, x).ok
    got = staged_admissible(m, x, requirements=[parse_requirement("kz_test>=19 N/um")])
    assert np.array_equal(got, base & (1.0 - x[:, 2] >= 1.9))


@pytest.mark.parametrize("name", BUNDLED)
def test_staged_oracle_equals_full_pipeline(name):
    m = load_machine(name)
    x = _poses_around(name, 1500, seed=1)
    ref = evaluate_poses(m, x)
    assert 0 < ref.ok.sum() < len(x)  # both outcomes occur
    assert np.array_equal(staged_admissible(m, x), ref.ok)


def test_kinematic_requirements_match_direct_computation():
    m = load_machine("hexaglide")
    x = _poses_around("hexaglide", 1000, seed=2)
    ev = evaluate_poses(m, x)
    u = transmission_quality(m, ev.jinv)
    thr_u, thr_k = float(np.median(u[ev.ok])), float(np.median(ev.kappa[ev.ok]))
    got_u = staged_admissible(m, x, requirements=[parse_requirement(f"U>={thr_u!r}")])
    got_k = staged_admissible(m, x, requirements=[parse_requirement(f"kappa<={thr_k!r}")])
    # U goes through the same condition-number routine with rtol 1e-4: compare away from the threshold
    away = np.abs(u / thr_u - 1) > 1e-3
    assert np.array_equal(got_u[away], (ev.ok & (u >= thr_u))[away])
    assert np.array_equal(got_k, ev.ok & (ev.kappa <= thr_k))
    with np.errstate(invalid="ignore"):  # unreachable poses: all-NaN rows (not admissible anyway)
        tilt = np.max(np.where(np.isnan(ev.angles["platform_tilt"]), -np.inf, ev.angles["platform_tilt"]), axis=1)
    lim = float(np.median(tilt[ev.ok]))
    got_t = staged_admissible(m, x, requirements=[parse_requirement(f"tilt_platform_max<={math.degrees(lim)!r} deg")])
    close = np.abs(tilt - lim) < 1e-12
    assert np.array_equal(got_t[~close], (ev.ok & (tilt <= lim))[~close])


def test_orientation_range_all_and_any_match_brute_force():
    m = load_machine("hexaglide")
    rng = np.random.default_rng(4)
    pts = np.column_stack([rng.uniform(-0.5, 0.5, 300), rng.uniform(0.0, 0.8, 300), rng.uniform(-1.2, -0.6, 300)])
    lo, hi, step = math.radians(-20), math.radians(20), math.radians(5)
    samples = np.linspace(lo, hi, 9)
    ok = np.stack([evaluate_poses(m, np.column_stack([pts, np.zeros((300, 2)), np.full(300, c)])).ok
                   for c in samples], axis=1)
    o_all = PoseOracle(m, orientation_range=("c", lo, hi), range_step=step, range_mode="all")
    o_any = PoseOracle(m, orientation_range=("c", lo, hi), range_step=step, range_mode="any")
    assert np.array_equal(o_all(pts), ok.all(axis=1))
    assert np.array_equal(o_any(pts), ok.any(axis=1))
    assert ok.all(axis=1).sum() < ok.any(axis=1).sum()  # the two definitions differ here
    # samples are evaluated only while undecided
    assert o_all.stats.poses < 300 * 9 and o_any.stats.poses < 300 * 9


def test_oracle_rejects_bad_settings():
    m = load_machine("hexaglide")
    with pytest.raises(ArgumentError, match="base_pose"):
        PoseOracle(m, base_pose=(0, 0, 0))
    with pytest.raises(ArgumentError, match="orientation_range"):
        PoseOracle(m, orientation_range=("x", 0.0, 1.0))
    with pytest.raises(ArgumentError, match="free coordinate"):
        PoseOracle(m, free=(3, 4, 5), orientation_range=("c", 0.0, 1.0))
    with pytest.raises(ArgumentError, match="checks"):
        PoseOracle(m, checks=("nope",))
