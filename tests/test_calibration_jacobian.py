"""Calibration 1: analytic identification Jacobian against central differences of the FK-based measurement model."""

import numpy as np
import pytest

import pkmstiff
from pkmstiff.calibration import Plan, default_plan, error_model, identification_jacobian, parse_with, simulate_readings

#: finite-difference step (m, rad): central differences err by ~f''' h²/6 ≈ 3e-9 relative at 1e-5 (measured: 2.8e-7
#: at 1e-4, 2.8e-9 at 1e-5, i.e. h²); rounding (FK solved to 1e-13 m) adds ~1e-8 absolute per unit sensitivity
H = 1e-5

CASES = [("felix", "ballbar", "ball-offset,fixed-ball,bar-offset", "cartesian"),
         ("felix", "pose", "target-offset,instrument-frame", "cylindrical"),
         ("hexapod_6x", "ballbar", "ball-offset", "cylindrical"),
         ("hexapod_6x", "tracker", "target-offset,instrument-frame", "cartesian"),
         ("hexaglide", "ballbar", "ball-offset,fixed-ball,bar-offset", "cartesian"),
         ("hexaglide", "pose", "target-offset", "cartesian"),
         ("linapod", "tracker", "instrument-frame", "cylindrical"),
         ("linapod", "ballbar", "bar-offset", "cartesian")]


def _fd_jacobian(m, params, plan):
    J = np.zeros((plan.n_readings, params.n))
    for k in range(params.n):
        e = np.zeros(params.n)
        e[k] = H
        yp = simulate_readings(m, params, e, plan).ravel()
        e[k] = -H
        ym = simulate_readings(m, params, e, plan).ravel()
        J[:, k] = (yp - ym) / (2 * H)
    return J


@pytest.mark.parametrize("name, instrument, with_, frame", CASES)
def test_analytic_jacobian_matches_central_differences(name, instrument, with_, frame):
    m = pkmstiff.load_machine(name)
    full = default_plan(m, instrument)
    step = max(1, full.n_poses // 12)  # 12 poses spread over the default plan keep the test fast
    plan = Plan(full.name, full.setup, full.poses[::step])
    params = error_model(m, frame=frame, setup=plan.setup, setup_blocks=parse_with(with_, instrument))
    Ja = identification_jacobian(m, params, plan).J
    Jf = _fd_jacobian(m, params, plan)
    # issue acceptance: 1e-7 relative (to the largest sensitivity); see H for the expected FD error
    assert np.abs(Ja - Jf).max() <= 1e-7 * np.abs(Jf).max()
    # and column by column for every column that is not negligibly small
    big = np.linalg.norm(Jf, axis=0) > 1e-3 * np.linalg.norm(Jf, axis=0).max()
    col = np.linalg.norm(Ja - Jf, axis=0)[big] / np.linalg.norm(Jf, axis=0)[big]
    assert col.max() <= 1e-6


def test_jacobian_shape_and_row_layout():
    m = pkmstiff.load_machine("felix")
    plan = default_plan(m, "pose")
    jac = identification_jacobian(m, error_model(m), plan)
    assert jac.J.shape == (6 * plan.n_poses, 42)
    assert jac.reading_units == ("m", "m", "m", "rad", "rad", "rad")
    # orientation rows weighted by the mean platform-joint radius (600 mm for Felix; file coordinates to 1e-9 m)
    np.testing.assert_allclose(jac.row_scale[:6], [1, 1, 1, 0.6, 0.6, 0.6], rtol=1e-8)
