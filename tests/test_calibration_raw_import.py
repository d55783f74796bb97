"""Issue 26 items 1, 2, 6: backlash parameters, the NC program of a ball-bar plan, raw ball-bar series and their
import; the end-to-end check raw series -> import -> identify."""

import math

import numpy as np
import pytest

from pkmstiff.calibration import circle_plan, error_model, hemisphere_plan, identifiability
from pkmstiff.calibration.backlash import held_signs, run_starts_of_samples
from pkmstiff.calibration.compensation import measurement_plan
from pkmstiff.calibration.identification import identify, jacobian_at
from pkmstiff.calibration.instruments import Setup, instrument
from pkmstiff.calibration.instruments.ball_bar import BallbarDevice
from pkmstiff.calibration.measurement import simulate_readings
from pkmstiff.calibration.nc_program import NCOptions, node_poses, parse_program, program_runs, program_text
from pkmstiff.calibration.raw_import import import_raw, simulate_raw
from pkmstiff.calibration.raw_series import raw_text, read_raw
from pkmstiff.calibration.simulation import SimulationOptions, sample_plan, simulate, to_measurement
from pkmstiff.calibration.uncertainty import uncertainty
from pkmstiff.cli import main
from pkmstiff.errors import InputError
from pkmstiff.machine import load_machine

FEED = 2000 / 60e3  # m/s
RAMP = 5e-3  # m: 7.5 samples on the feed-in ramp at 50 Hz


@pytest.fixture(scope="module")
def felix():
    return load_machine("felix")


@pytest.fixture(scope="module")
def plan():
    st = Setup(instrument("ballbar"), fixed_ball=np.zeros(3), bar_length=0.15)
    return hemisphere_plan(st, n=90, turns=2).concat(circle_plan(st, "XZ", n=36))


@pytest.fixture(scope="module")
def runs(plan):
    return program_runs(plan, NCOptions(feed=FEED, ramp=RAMP))


@pytest.fixture(scope="module")
def truth(felix, plan):
    """Errors of ±50 µm on the plan's base parameters (the rest are gauge directions no reading sees, held at 0 by
    the identification) and a backlash of 20-60 µm per drive."""
    params = error_model(felix, setup=plan.setup, setup_blocks=("backlash",))
    base = params.indices(identifiability(felix, params, plan).base_parameters)
    rng = np.random.default_rng(3)
    delta = np.zeros(params.n)
    delta[base] = rng.uniform(-50e-6, 50e-6, base.size)
    bl = params.mask("backlash")
    delta[bl] = rng.uniform(20e-6, 60e-6, bl.sum())
    return params, delta


# ------------------------------------------------------------------------------------------------------ backlash


def test_held_signs_follow_the_motion_and_hold_through_standstill():
    q = np.array([[0.0], [0.0], [1.0], [2.0], [2.0], [1.0], [3.0], [3.0], [2.0]])
    s = held_signs(q, [6])  # second run starts at sample 6
    assert s[:, 0].tolist() == [1, 1, 1, 1, 1, -1, -1, -1, -1]  # leading standstill: the first motion's sign


@pytest.mark.parametrize("name", ["felix", "hexaglide"])
def test_backlash_columns_match_finite_differences(name):
    from pkmstiff.calibration import default_plan

    m = load_machine(name)
    pl = default_plan(m, instrument("ballbar"))
    params = error_model(m, setup=pl.setup, setup_blocks=("backlash",))
    d = np.random.default_rng(5).uniform(-1, 1, params.n) * 50e-6
    J = jacobian_at(m, params, pl, d)
    h = 1e-8  # central difference: truncation O(h²) ≪ 1e-7 relative; round-off ~1e-16 m / 1e-8 = 1e-8
    for k in np.flatnonzero(params.mask("backlash")):
        dp, dm = d.copy(), d.copy()
        dp[k] += h
        dm[k] -= h
        fd = (simulate_readings(m, params, dp, pl) - simulate_readings(m, params, dm, pl)).ravel() / (2 * h)
        # analytic J is exact for pods; for glides first order in the guide tilts (identification.py docstring):
        # relative error ~ the tilts, 5e-5 rad here
        rel = 1e-6 if m.kind == "pod" else 1e-4
        assert np.max(np.abs(fd - J[:, k])) <= rel * np.max(np.abs(J[:, k])) + 1e-7


def test_backlash_adds_one_identifiable_parameter_per_drive(felix):
    from pkmstiff.calibration import default_plan

    pl = default_plan(felix, instrument("ballbar"))
    without = identifiability(felix, error_model(felix, setup=pl.setup), pl)
    with_ = identifiability(felix, error_model(felix, setup=pl.setup, setup_blocks=("backlash",)), pl)
    assert with_.rank == without.rank + 6
    assert sum("backlash" in b for b in with_.base_parameters) == 6


def test_parameter_backlash_agrees_with_the_simulations_scalar_backlash(felix, plan):
    """The exact per-drive model (parameters) and the first-order scalar option of the simulation agree to the
    second-order term (b/2)² / strut length ~ 1e-10 m."""
    params = error_model(felix, setup=plan.setup, setup_blocks=("backlash",))
    b = 40e-6
    dev = BallbarDevice(sample_rate=5.0)
    opts = SimulationOptions(feed=FEED, noise="none", quantise=False, backlash=b)
    smp = sample_plan(plan, dev, opts)
    first = simulate(felix, params, np.zeros(params.n), plan, dev, opts, samples=smp)
    delta = np.where(params.mask("backlash"), b, 0.0)
    exact = simulate(felix, params, delta, plan, dev,
                     SimulationOptions(feed=FEED, noise="none", quantise=False), samples=smp)
    assert np.max(np.abs(first.readings - exact.readings)) < 1e-8
    assert np.max(np.abs(exact.readings - plan.setup.bar_length)) > 1e-6  # the backlash is visible at all


def test_simulated_backlash_is_identified_from_a_measurement_file(felix, plan, truth, tmp_path):
    from pkmstiff.calibration.measurement_file import read_measurement, write_measurement

    params, delta = truth
    dev = BallbarDevice(sample_rate=10.0)
    opts = SimulationOptions(feed=FEED, noise="none", quantise=False)
    res = simulate(felix, params, delta, plan, dev, opts)
    path = write_measurement(tmp_path / "m.csv", to_measurement(felix, plan, res, dev))
    mp, y = measurement_plan(read_measurement(path), "felix", str(path))
    ide = identify(felix, params, mp, y)
    bl = params.mask("backlash")
    # noise-free and written with round-trip digits: the model is exact to the FK tolerance (1e-13 m) times the
    # condition number (~4e4)
    assert np.max(np.abs(ide.delta[bl] - delta[bl])) < 1e-9
    assert np.max(np.abs(ide.delta - delta)) < 1e-8


def test_run_starts_of_a_measurement():
    t = np.r_[np.arange(5) * 0.1, 2 + np.arange(5) * 0.1]  # a gap of 20 steps
    d = np.array(["ccw"] * 3 + ["cw"] * 7)
    assert run_starts_of_samples(t, d) == (3, 5)
    assert run_starts_of_samples(t, d, feed=np.zeros(10)) == (3,)  # static poses: no cut at time gaps


# ------------------------------------------------------------------------------------------------- NC program


def test_nc_program_round_trip_recovers_the_plan_poses(plan, runs, tmp_path):
    text = program_text(plan, runs, NCOptions(feed=FEED, ramp=RAMP), "felix")
    back = parse_program(text)
    assert [(r.number, r.segment, r.direction) for r in back] == [(r.number, r.segment, r.direction) for r in runs]
    for a, b in zip(runs, back):
        assert b.path == a.path and np.array_equal(b.nodes, a.nodes) and b.feed == pytest.approx(FEED, rel=1e-12)
        got = node_poses(b, plan.setup.target)
        want = plan.poses[b.node_ids]
        # the program prints 6 decimals of mm and deg: rounding leaves ≤ 5e-7 mm / deg (+ one ulp of parsing)
        assert np.max(np.abs(got[:, :3] - want[:, :3])) * 1e3 <= 1e-6
        dang = np.angle(np.exp(1j * (got[:, 3:] - want[:, 3:])))
        assert np.max(np.abs(np.degrees(dang))) <= 1e-6
        # the runs are built rounded to the program's digits: program and runs are the same path
        assert np.max(np.abs(b.tcp - a.tcp)) < 1e-15 and np.max(np.abs(b.angles - a.angles)) < 1e-15


def test_nc_program_feed_in_and_out_arcs(plan, runs):
    opts = NCOptions(feed=FEED, ramp=RAMP)
    for r in runs:
        rad = np.linalg.norm(r.tcp - plan.setup.fixed_ball, axis=1)
        assert rad[0] == pytest.approx(0.15 - opts.depth, abs=1e-9) and rad[-1] == pytest.approx(0.15 - opts.depth,
                                                                                                   abs=1e-9)
        # on the path the chords leave the sphere by at most the chord tolerance (1 µm) + rounding
        p = rad[r.path[0]:r.path[1] + 1]
        assert np.max(np.abs(p - 0.15)) < 1e-9
        mid = 0.5 * (r.tcp[r.path[0]:r.path[1]] + r.tcp[r.path[0] + 1:r.path[1] + 1])
        assert np.max(0.15 - np.linalg.norm(mid - plan.setup.fixed_ball, axis=1)) <= opts.chord * 1.01


# ----------------------------------------------------------------------------------------------- end to end


@pytest.fixture(scope="module")
def noise_free(felix, plan, runs, truth):
    params, delta = truth
    raws = simulate_raw(felix, params, delta, plan, runs, sample_rate=50, seed=4)
    meas, syncs = import_raw(felix, plan, runs, raws)
    mp, y = measurement_plan(meas, "felix", "raw")
    return raws, syncs, identify(felix, params, mp, y)


def test_end_to_end_noise_free_recovers_errors_and_backlash(truth, noise_free):
    params, delta = truth
    raws, syncs, res = noise_free
    true_start = np.random.default_rng(4).uniform(0.2, 1.2, len(raws))
    # the feed-in signature fits to the model's floor (the program's 1 µm chords kink the errors' signal)
    assert max(s.residual for s in syncs) < 1e-9
    assert np.max(np.abs([s.start for s in syncs] - true_start)) < 1e-6  # s: < 33 nm along the path
    assert np.max(np.abs(res.delta - delta)) <= 1e-9
    bl = params.mask("backlash")
    assert np.max(np.abs(res.delta[bl] - delta[bl])) <= 1e-9


def test_end_to_end_with_noise_within_three_sigma(felix, plan, runs, truth):
    params, delta = truth
    raws = simulate_raw(felix, params, delta, plan, runs, sample_rate=50, sigma=0.25e-6, resolution=0.1e-6, seed=7)
    meas, syncs = import_raw(felix, plan, runs, raws)
    # the noise σ = 0.25 µm (the RMS of a fit of ~10 terms to 12-13 samples is below it), no model misfit
    assert all(s.residual < 0.5e-6 and s.sigma < 1e-3 for s in syncs)
    mp, y = measurement_plan(meas, "felix", "raw")
    res = identify(felix, params, mp, y)
    unc = uncertainty(res)
    z = np.abs(res.delta[res.base] - delta[res.base]) / unc.sigma
    assert np.max(z) < 3.5  # 48 parameters: P(max |z| > 3.5) ≈ 2 %; a sync bias of one sample would give z ≫ 10
    assert np.mean(z ** 2) < 2.0


# ------------------------------------------------------------------------------------- wrong feed, rate, path


def test_wrong_feed_sample_rate_or_path_is_a_one_line_error(felix, plan, runs, noise_free):
    raws = noise_free[0]
    r = raws[0]
    wrong_feed = program_runs(plan, NCOptions(feed=FEED * 1.01, ramp=RAMP))
    with pytest.raises(InputError, match="run1: key .feed_mm_min.: expected the program.s feed 2020 mm/min, found 2000 mm/min"):
        import_raw(felix, plan, wrong_feed, raws[:1])  # the file's header says 2000
    bare = type(r)(r.path, r.t, r.deviation, sample_rate=50.0, run=1)  # no feed in the file: the timing tells
    with pytest.raises(InputError, match=r"run1: the feed-out ramp is [+-]0\.\d+ s from where it belongs .*the "
                                         r"machine moved at 0\.9899\d* x the feed.*wrong feed"):
        import_raw(felix, plan, wrong_feed, [bare])
    slow = type(r)(r.path, r.t * 50 / 51, r.deviation, sample_rate=51.0, run=1)
    with pytest.raises(InputError, match="wrong feed, sample rate"):
        import_raw(felix, plan, runs, [slow])
    o = raws[2]
    other = type(r)(o.path, o.t, o.deviation, sample_rate=50.0, run=1)  # run 3 (the circle) taken as run 1
    with pytest.raises(InputError, match="wrong feed, sample rate or path"):
        import_raw(felix, plan, runs, [other])
    late = type(r)(r.path, r.t[100:], r.deviation[100:], sample_rate=50.0, run=1)  # capture after the feed-in
    with pytest.raises(InputError):
        import_raw(felix, plan, runs, [late])


def test_given_start_offset_is_checked(felix, plan, runs, noise_free):
    raws, syncs = noise_free[0], noise_free[1]
    r = raws[0]
    good = type(r)(r.path, r.t, r.deviation, sample_rate=50.0, run=1, start_offset=syncs[0].start)
    _meas, s = import_raw(felix, plan, runs, [good])
    assert s[0].given and s[0].residual < 1e-9
    bad = type(r)(r.path, r.t, r.deviation, sample_rate=50.0, run=1, start_offset=syncs[0].start + 0.02)
    with pytest.raises(InputError, match="signature does not fit"):
        import_raw(felix, plan, runs, [bad])


# ---------------------------------------------------------------------------------------------- raw files


def test_raw_file_round_trip_and_errors(tmp_path, noise_free):
    r = noise_free[0][0]
    p = tmp_path / "run1.txt"
    p.write_text(raw_text(r))
    back = read_raw(p)
    assert back.sample_rate == 50.0 and back.run == 1 and back.direction == "ccw"
    # shortest round-trip digits in mm, back to m: one unit in the last place
    assert back.deviation == pytest.approx(r.deviation, rel=1e-15) and back.t == pytest.approx(r.t, abs=1e-12)
    two = tmp_path / "two.txt"
    two.write_text("t_s, deviation_um\n0, 1.5\n0.004, 1.6\n0.008, 1.7\n")
    s = read_raw(two)
    assert s.sample_rate == pytest.approx(250.0) and s.deviation[0] == pytest.approx(1.5e-6, rel=1e-12)
    with pytest.raises(InputError, match=r"line 3.*expected a number, found 'x'"):
        (tmp_path / "a.txt").write_text("# sample_rate_hz: 250\n0.1\nx\n")
        read_raw(tmp_path / "a.txt")
    with pytest.raises(InputError, match="expected 2 numbers per line"):
        (tmp_path / "b.txt").write_text("0, 0.1\n0.004\n")
        read_raw(tmp_path / "b.txt")
    with pytest.raises(InputError, match="sample_rate_hz.*header gives 50 Hz, the command line 250 Hz"):
        read_raw(p, {"sample_rate": 250.0})
    with pytest.raises(InputError, match="sample_rate_hz.*time column's rate 250 Hz.*found 500 Hz"):
        (tmp_path / "c.txt").write_text("# sample_rate_hz: 500\n0, 1\n0.004, 1\n0.008, 1\n")
        read_raw(tmp_path / "c.txt")
    with pytest.raises(InputError, match="expected the sample rate"):
        (tmp_path / "d.txt").write_text("0.1\n0.2\n")
        read_raw(tmp_path / "d.txt")


# ------------------------------------------------------------------------------------------------- command line


PLAN = """
[plan]
name = "felix hemisphere + XZ circle"
instrument = "ballbar"

[setup]
fixed_ball = ["0 mm", "0 mm", "0 mm"]
bar_length = "150 mm"

[[paths]]
kind = "hemisphere"
points = 90
turns = 2

[[paths]]
kind = "circle"
plane = "XZ"
points = 36
"""


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_command_line_session(tmp_path, capsys):
    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN)
    errors = tmp_path / "errors.toml"
    errors.write_text('[errors]\n"chain1.strut_offset" = "30 um"\n"chain2.backlash" = "40 um"\n'
                      '"chain5.backlash" = "25 um"\n')
    nc = tmp_path / "circle.nc"
    code, out, _ = _run(capsys, "calibrate", "plan", "felix", "--plan", plan, "--nc", nc, "--feed", 2000,
                          "--ramp", 5)
    assert code == 0 and "4 runs" in out and nc.read_text().startswith("%\n(pkmstiff ball-bar measuring program")
    code, _, err = _run(capsys, "calibrate", "plan", "felix", "--plan", plan, "--nc", nc)
    assert code == 2 and "exists; use --force" in err
    raw = tmp_path / "raw"
    code, out, _ = _run(capsys, "calibrate", "simulate", "felix", "--plan", plan, "--errors", errors, "--feed", 2000,
                        "--ramp", 5, "--sample-rate", 50, "--raw", raw, "--seed", 1, "--noise", "none", "--no-quantise")
    assert code == 0 and (raw / "run2.txt").is_file()
    csv = tmp_path / "m.csv"
    code, out, _ = _run(capsys, "calibrate", "import", "felix", *sorted(raw.glob("run*.txt")), "--plan", plan,
                        "--nc", nc, "--out", csv)
    assert code == 0 and "synchronisation residual" in out and csv.is_file()
    code, _, err = _run(capsys, "calibrate", "import", "felix", raw / "run1.txt", "--plan", plan, "--out", csv)
    assert code == 2 and "exists; use --force" in err
    code, _, err = _run(capsys, "calibrate", "import", "felix", raw / "run1.txt", "--plan", plan, "--out",
                        tmp_path / "w.csv", "--feed", 1900, "--ramp", 5)
    assert code == 2 and "feed_mm_min" in err and "1900" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "w.csv").exists()
    code, out, _ = _run(capsys, "calibrate", "identify", "felix", "--measurements", csv, "--with", "backlash",
                        "--json")
    assert code == 0
    import json

    rep = json.loads(out)
    got = {r["name"]: r["value_mm"] for r in rep["identified"]}
    # noise-free: the identifiable combinations are exact; the backlash of drives 2 and 5 is seen directly
    assert got["chain2.backlash"] == pytest.approx(0.040, abs=1e-6)
    assert got["chain5.backlash"] == pytest.approx(0.025, abs=1e-6)
    assert math.isclose(rep["residual_after"]["rms_um"], 0.0, abs_tol=1e-3)
