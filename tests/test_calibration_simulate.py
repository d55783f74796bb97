"""Simulated measurements (issue 16 item 1): nominal readings along every plan kind, the instrument model (noise,
quantisation, Tab. 4.5), backlash and thermal drift against closed forms and the forward kinematics."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import pkmstiff
from pkmstiff.calibration import Setup, circle_plan, error_model, grid_plan, hemisphere_plan, simulate_readings
from pkmstiff.calibration.instruments import BallbarDevice
from pkmstiff.calibration.instruments.ball_bar import TAB_4_5_FEED, TAB_4_5_UNCERTAINTY
from pkmstiff.calibration.simulation import (
    SimulationOptions,
    backlash_offsets,
    range_error,
    sample_plan,
    simulate,
)
from pkmstiff.errors import CalibrationInputError

FAST = 5000.0 / 60e3  # 5000 mm/min keeps the sample counts small in tests


@pytest.fixture(scope="module")
def machines():
    return {name: pkmstiff.load_machine(name) for name in ("felix", "hexaglide")}


def _setup(m, bar):
    from pkmstiff.calibration import workspace_centre
    return Setup("ballbar", target=m.tool.tip(), fixed_ball=workspace_centre(m), bar_length=bar)


def _plans(m):
    bar = 0.15 if m.name.lower().startswith("felix") else 0.1
    s = _setup(m, bar)
    return [circle_plan(s, "XY", 36), circle_plan(s, "XZ", 36, tilt=np.radians(5), tilt_azimuth=np.radians(90)),
            circle_plan(s, "YZ", 36, torsion=np.radians(3)),
            hemisphere_plan(s, n=60, turns=1.0, tilt=np.radians(5), torsion=np.radians(5)),
            grid_plan(s, s.fixed_ball, 0.02, points=2, tilt=np.radians(3), torsion=np.radians(3))]


@pytest.mark.parametrize("name", ["felix", "hexaglide"])
def test_nominal_machine_reads_the_bar_length_on_every_plan_kind(machines, name):
    m = machines[name]
    opts = SimulationOptions(feed=FAST, noise="none", quantise=False)
    for plan in _plans(m):
        params = error_model(m, setup=plan.setup)
        res = simulate(m, params, np.zeros(params.n), plan, options=opts)
        r = res.readings[:, 0]
        if plan.segments[0].kind == "points":  # grid: the target is not on the sphere; compare with the geometry
            ref = simulate_readings(m, params, np.zeros(params.n), plan)[:, 0]
            assert np.max(np.abs(r - ref)) <= 1e-12  # 1e-12 m: the done-when criterion
        else:
            # 1e-12 m (done-when); the samples are put on the sphere, only rounding (~1e-16 m) remains
            assert np.max(np.abs(r - plan.setup.bar_length)) <= 1e-12
            assert len(r) > plan.n_poses  # resampled at the instrument rate


def test_nominal_tracker_reads_the_commanded_target(machines):
    m = machines["felix"]
    s = Setup("tracker", target=m.tool.tip())
    plan = grid_plan(s, np.zeros(3), 0.05, points=2)
    params = error_model(m, setup=s)
    res = simulate(m, params, np.zeros(params.n), plan, options=SimulationOptions(noise="none", quantise=False))
    from pkmstiff.kinematics.rotation import cardan_matrix
    x = plan.poses
    tgt = x[:, :3] + np.einsum("nij,j->ni", cardan_matrix(x[:, 3], x[:, 4], x[:, 5]), s.target)
    assert np.max(np.abs(res.readings - tgt)) <= 1e-12  # 1e-12 m: rounding only


def test_sampling_at_the_instrument_rate_and_feed(machines):
    m = machines["felix"]
    plan = circle_plan(_setup(m, 0.15), "XY", 72)
    inst = BallbarDevice()
    smp = sample_plan(plan, inst, SimulationOptions(feed=FAST))
    ccw = smp.direction == "ccw"
    dt = np.diff(smp.t[ccw])
    assert np.allclose(dt, 1 / 250.0, rtol=1e-9, atol=1e-12)  # 250 samples/s (Tab. 4.3), rounding only
    poly = 72 * 2 * 0.15 * np.sin(np.pi / 72)  # the 72-gon's perimeter
    assert abs(smp.t[ccw][-1] - poly / FAST) <= 1 / 250.0 + 1e-9  # one sample period of the closing step
    # cw run: same positions in the opposite order, starting at the same point
    cw = smp.poses[~ccw]
    assert np.allclose(cw[0, :3], smp.poses[0, :3], atol=1e-12)
    assert _turn(smp.poses[:3, :2]) > 0 and _turn(cw[:3, :2]) < 0


def _turn(p):
    a, b = p[1] - p[0], p[2] - p[1]
    return a[0] * b[1] - a[1] * b[0]


def test_noise_quantisation_and_seed(machines):
    m = machines["felix"]
    plan = circle_plan(_setup(m, 0.15), "XY", 36)
    params = error_model(m, setup=plan.setup)
    opts = SimulationOptions(feed=FAST, noise=2e-6, seed=7)
    a = simulate(m, params, np.zeros(params.n), plan, options=opts)
    b = simulate(m, params, np.zeros(params.n), plan, options=opts)
    assert np.array_equal(a.readings, b.readings)  # same seed, same readings
    q = a.deviation / 0.1e-6
    assert np.max(np.abs(q - np.round(q))) < 1e-6  # multiples of the 0.1 µm resolution (float rounding only)
    e = a.deviation
    # σ = 2 µm: relative standard error of a sample std over N ≈ 2400 samples is 1/√(2N) ≈ 1.5 %; 8 % is > 5 s.e.
    assert abs(e.std() / 2e-6 - 1) < 0.08
    c = simulate(m, params, np.zeros(params.n), plan, options=SimulationOptions(feed=FAST, noise=2e-6, seed=8))
    assert not np.array_equal(a.readings, c.readings)


def test_procedure_uncertainty_follows_tab_4_5():
    inst = BallbarDevice()
    assert np.allclose(inst.uncertainty(TAB_4_5_FEED), TAB_4_5_UNCERTAINTY, rtol=0, atol=1e-15)  # table nodes
    # midway 1000 -> 2000 mm/min: (36 + 54) / 2 µm; σ = U / 2 (k = 2 reading)
    assert inst.sigma("procedure", 1500 / 60e3) == pytest.approx(45e-6 / 2, rel=1e-12)
    assert inst.sigma("instrument", 0.01) == pytest.approx(0.25e-6, rel=1e-12)
    with pytest.raises(CalibrationInputError):
        inst.sigma("loud", 0.01)


@settings(max_examples=30, deadline=None)
@given(st.floats(0.2, 3.0), st.floats(0.1, 5.0))
def test_backlash_is_half_the_lash_against_the_motion(phase, b_um):
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    q = np.c_[np.sin(t + phase), np.cos(2 * t)]
    b = b_um * 1e-6
    dq = backlash_offsets(q, np.zeros(len(t), int), np.full(len(t), "ccw"), b)
    v = np.c_[np.cos(t + phase), -2 * np.sin(2 * t)]  # analytic velocities
    clear = np.abs(v) > 0.05  # away from the reversals the sign of a finite difference equals the sign of q̇
    assert np.all(np.abs(dq) == pytest.approx(b / 2))
    assert np.array_equal(np.sign(dq[clear]), -np.sign(v[clear]))


@pytest.mark.parametrize("name,param", [("felix", "strut_offset"), ("hexaglide", "strut_length")])
def test_thermal_drift_equals_strut_growth_through_the_forward_kinematics(machines, name, param):
    """Drift is first order through J_C⁻¹: compare with the FK of a machine whose struts grew by α l ΔT."""
    m = machines[name]
    plan = _plans(m)[0]
    params = error_model(m, setup=plan.setup)
    dT, alpha = 5.0, 11.5e-6
    opts = SimulationOptions(feed=FAST, noise="none", quantise=False, drift_dT=dT, drift_tau=0.0, alpha=alpha,
                             directions=("ccw",))
    res = simulate(m, params, np.zeros(params.n), plan, options=opts)
    idx = np.arange(0, len(res.readings), 97)
    sub = type(plan)(plan.name, plan.setup, res.samples.poses[idx])
    from pkmstiff.kinematics import inverse_kinematics
    L = inverse_kinematics(m, sub.poses).length  # (N, n) strut lengths
    for k in range(3):  # one pose at a time: strut growth depends on the pose's strut lengths
        delta = np.zeros(params.n)
        for i in range(m.n_chains):
            delta[params.index(f"chain{i + 1}.{param}")] = alpha * dT * L[k, i]
        one = type(plan)(plan.name, plan.setup, sub.poses[k:k + 1])
        ref = simulate_readings(m, params, delta, one)[0, 0]
        # growth up to α l ΔT ≈ 115 µm (Felix, l ≈ 2 m); the first-order frame motion errs by O(growth² / l) ≈ 7e-9 m
        # at most (observed 5e-10 m); the reading itself is exact
        assert abs(res.readings[idx[k], 0] - ref) < 5e-9
        # the drift is visible at all (> 2 × the tolerance; a uniform growth moves the platform mostly along z,
        # normal to an XY circle, so the ball bar sees it in second order on the Hexaglide: ≈ 3e-8 m)
        assert abs(res.readings[idx[k], 0] - plan.setup.bar_length) > 1e-8


def test_range_violations_are_reported(machines):
    m = machines["felix"]
    plan = circle_plan(_setup(m, 0.15), "XY", 36)
    params = error_model(m, setup=plan.setup, setup_blocks=("bar_offset",))
    delta = params.vector({"bar_offset": 1.5e-3})
    res = simulate(m, params, delta, plan, options=SimulationOptions(feed=FAST, noise="none"))
    assert res.violations.size == len(res.readings)
    msg = range_error(plan, res, BallbarDevice())
    assert "outside the QC10 range [-1, 1] mm, first at sample 1" in msg and "\n" not in msg
