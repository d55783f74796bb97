"""Solver correctness of the generic mechanism kinematics (issue 27, item 4): revolute drives without spurious roots,
path continuation for large drive steps."""

from __future__ import annotations

import numpy as np
import pytest

import pkmstiff.mechanisms as mm
from pkmstiff.mechanisms.constraints import fk_system
from pkmstiff.mechanisms.solver import MAX_ANGLE_STEP, path_steps


@pytest.fixture(scope="module")
def hybrid():
    return mm.load_mechanism("hybrid_tripod_wrist")


@pytest.mark.parametrize("v1", [80.0, 90.0, 150.0, 179.0, -179.0])
def test_large_revolute_drive_step_from_home_gives_the_connected_configuration(hybrid, v1):
    d = np.array([[0.0, 0.0, 0.0, np.radians(v1), np.radians(40.0)]])
    fk = mm.forward(hybrid, d)  # default steps=1: the continuation subdivides the 80…179° step itself
    assert fk.status[0] == "converged"
    # the drive residual is the angle difference itself: solved to the Newton tolerance (1e-13·1 m scale)
    assert np.abs(fk.drives - d).max() < 1e-11
    # the same configuration as a 1°-per-step path (an independent continuation)
    ref = mm.forward(hybrid, d, steps=int(abs(v1)) + 1)
    assert np.abs(fk.poses - ref.poses).max() < 1e-10
    # round trip IK(FK(d)) = d from home: carriages unique; the wrist (V1, V2) is unique within V2's 5–80° limits.
    # Tolerance: poses are solved to 1e-13 m and the drive/pose sensitivity of this wrist is O(1–10) (κ at V2 = 40°)
    ik = mm.inverse(hybrid, fk.poses)
    assert ik.status[0] == "converged"
    err = ik.drives - d
    err[:, 3] = (err[:, 3] + np.pi) % (2.0 * np.pi) - np.pi  # V1 = ±180° are the same angle
    assert np.abs(err).max() < 1e-9


def test_revolute_drive_residual_has_no_root_half_a_turn_away(hybrid):
    d = np.array([[0.0, 0.0, 0.0, np.radians(30.0), np.radians(40.0)]])
    fk = mm.forward(hybrid, d)
    system = fk_system(hybrid)
    row = next(b.row0 for b in system.blocks if b.kind == "drive_rot")  # V1 comes first among the revolute drives
    r0, _ = system.evaluate(fk.q, d)
    r1, _ = system.evaluate(fk.q, d + np.array([0, 0, 0, np.pi, 0]))
    assert abs(r0[0, row]) < 1e-12
    # sin(θ − θ*) vanished here; the wrapped difference is ±π (float rounding of π + 30° − 30°)
    assert abs(abs(r1[0, row]) - np.pi) < 1e-12
    # compiled kernel and numpy reference agree on the wrapped residual and its Jacobian
    rr, Jr = system.evaluate_reference(fk.q, d + np.array([0, 0, 0, 2.5, 0]))
    rk, Jk = system.evaluate(fk.q, d + np.array([0, 0, 0, 2.5, 0]))
    assert np.abs(rr - rk).max() < 1e-14 and np.abs(Jr - Jk).max() < 1e-13


def test_path_steps_bound_the_change_per_step():
    delta = np.array([[np.radians(179.0), 0.0], [0.01, 0.01], [0.0, 1.0]])
    n = path_steps(delta, np.array([True, False]), 1.0, 1)
    # 179° / 15° → 12 → next power of two; small changes keep one step; 1 m at 0.25 m per step → 4
    assert n.tolist() == [16, 1, 4]
    assert (np.abs(delta[:, 0]) / n <= MAX_ANGLE_STEP).all()
    # steps=3: multiples 3·2^i (179° → 12 steps of 14.9°, 1 m → 6)
    assert path_steps(delta, np.array([True, False]), 1.0, 3).tolist() == [12, 3, 6]
