"""Issue 26 item 3: several set-ups (fixed-ball positions, ball offsets) in one identification, set-up parameters per
set-up, and a fixed ball placed by the machine itself."""

import dataclasses
import itertools
from functools import cache

import numpy as np
import pytest

import pkmstiff
from pkmstiff.calibration import hemisphere_plan, identifiability, identification_jacobian, read_plan, simulate_readings
from pkmstiff.calibration.examples import resolve
from pkmstiff.calibration.identification import identify, jacobian_at
from pkmstiff.calibration.setups import PlanSet, moved_plan, part_parameters, setups_error_model
from pkmstiff.errors import InputError

BALLS = ((0.0, 0.0, 0.0), (0.1, 0.0, -0.1), (0.0, 0.1, -0.1))


@cache
def _felix():
    return pkmstiff.load_machine("felix")


@cache
def _planset(n: int, placed: bool = False) -> PlanSet:
    base = hemisphere_plan(read_plan("example:felix_setups_plan.toml").parts[0].setup, n=120)
    return PlanSet("felix", tuple(moved_plan(base, np.array(b), placed) for b in BALLS[:n]))


def _gauges(res):
    return sorted((g.name, g.dof) for g in res.gauge_freedoms)


def test_more_fixed_balls_identify_more_parameters():
    """One fixed ball: 36 of 42 (rotations about both balls lost); two: the base turns only about the line through
    them (38); three not on a line: the base rotation is gone (39). The platform rotation about the moving ball
    stays: every set-up has the same moving ball."""
    m = _felix()
    ranks = {}
    for n in (1, 2, 3):
        ps = _planset(n)
        res = identifiability(m, setups_error_model(m, ps), ps)
        ranks[n] = res.rank
        if n == 2:
            g = next(g for g in res.gauge_freedoms if g.name.startswith("base frame rotation"))
            axis = np.subtract(BALLS[1], BALLS[0]) / np.linalg.norm(np.subtract(BALLS[1], BALLS[0]))
            named = np.array([float(v) for v in g.detail.removeprefix("along (").removesuffix(")").split(",")])
            assert g.dof == 1 and abs(named @ axis) == pytest.approx(1.0, abs=2e-3)  # printed to 3 decimals
    assert ranks == {1: 36, 2: 38, 3: 39}
    assert _gauges(res) == [("platform frame rotation about the moving-ball centre", 3)]


def test_a_second_ball_offset_removes_the_platform_rotation():
    """Two more set-ups with other moving-ball positions on the platform (longer tools) leave nothing unseen."""
    m = _felix()
    st = _planset(3).parts[0].setup
    parts = list(_planset(3).parts)
    for tg in ((0.0, 0.0, 0.1), (0.05, 0.0, 0.05)):
        parts.append(hemisphere_plan(dataclasses.replace(st, target=np.array(tg), fixed_ball=np.array([0, 0, -0.15])),
                                     n=120))
    ps = PlanSet("felix", tuple(parts))
    res = identifiability(m, setups_error_model(m, ps), ps)
    assert res.rank == 42 and res.gauge_freedoms == ()


def test_machine_placed_balls_move_with_the_machine_frame():
    """A fixed ball the machine places moves with the machine's own frame: the base translation becomes a gauge
    freedom too, and the base rotation stays however many balls are placed."""
    m = _felix()
    ps = _planset(3, placed=True)
    res = identifiability(m, setups_error_model(m, ps), ps)
    assert res.rank == 33
    assert _gauges(res) == [("base frame rotation about the fixed-ball centre of set-up 1", 3),
                            ("base frame translation", 3),
                            ("platform frame rotation about the moving-ball centre", 3)]


@pytest.mark.parametrize("placed", [False, True])
def test_stacked_jacobian_matches_finite_differences(placed):
    """The stacked Jacobian (machine columns shared, set-up columns per set-up, the machine-placed ball's motion)
    against central differences of the simulated readings, at the nominal and at a perturbed geometry. Step 1e-7
    (scaled 1e-4 mm): truncation ~ h² |y'''| ≈ 1e-14 and rounding ~ 1e-16 m / h ≈ 1e-9 of the column size, so
    a relative tolerance of 1e-6 leaves both far behind."""
    m = _felix()
    ps = _planset(2, placed)
    params = setups_error_model(m, ps, setup_blocks=("bar_offset", "ball_offset", "fixed_ball"))
    assert "setup2.bar_offset" in params.names and "bar_offset" not in params.names
    rng = np.random.default_rng(3)
    for d in (np.zeros(params.n), rng.uniform(-1, 1, params.n) * 1e-4):
        J = identification_jacobian(m, params, ps).J if not d.any() else jacobian_at(m, params, ps, d)
        h = 1e-7
        cols = np.arange(0, params.n, 3)
        fd = np.stack([(simulate_readings(m, params, d + h * e, ps) - simulate_readings(m, params, d - h * e, ps))
                       .ravel() / (2 * h) for e in np.eye(params.n)[cols]], 1)
        assert np.abs(fd - J[:, cols]).max() <= 1e-6 * np.abs(J).max()


def test_part_parameters_are_the_one_setup_model():
    m = _felix()
    ps = _planset(3)
    params = setups_error_model(m, ps, setup_blocks=("bar_offset",))
    sub, idx = part_parameters(params, 2)
    assert sub.names[-1] == "bar_offset" and params.names[idx[-1]] == "setup3.bar_offset"
    assert sub.n == 43 and np.all(sub.chain[-1:] == -1)


@pytest.mark.parametrize("placed", [False, True])
def test_stacked_identification_recovers_the_errors(placed):
    """Noise-free readings of three set-ups (with per-set-up bar offsets) of a perturbed Felix: the stacked
    identification fits them to the forward kinematics' tolerance, and the errors outside the gauge freedoms are
    recovered."""
    m = _felix()
    ps = _planset(3, placed)
    params = setups_error_model(m, ps, setup_blocks=("bar_offset",))
    rng = np.random.default_rng(5)
    true = rng.uniform(-1, 1, params.n) * 1e-3
    true[params.chain < 0] = rng.uniform(-1, 1, int(np.sum(params.chain < 0))) * 2e-5
    res = identify(m, params, ps, simulate_readings(m, params, true, ps))
    assert np.max(np.abs(res.residual_after)) < 1e-9
    assert np.allclose(res.delta[params.chain < 0], true[params.chain < 0], atol=1e-9)
    # what is left unseen (the platform rotation about the moving ball; placed balls: the base frame) changes no
    # reading of the same moving ball about any other fixed ball: the identified machine predicts a new set-up
    other = moved_plan(_planset(1).parts[0], np.array([-0.05, -0.05, -0.05]), placed)
    sub = setups_error_model(m, other)
    pred = [simulate_readings(m, sub, d[params.chain >= 0], other)
            for d in (res.delta, true)]
    assert np.max(np.abs(pred[0] - pred[1])) < 1e-9  # m; the forward kinematics solves to 1e-13


def test_plan_file_with_setups_and_errors(tmp_path):
    ps = read_plan("example:felix_setups_plan.toml")
    assert isinstance(ps, PlanSet) and ps.n_setups == 3
    assert np.allclose([p.setup.fixed_ball for p in ps.parts], BALLS)
    assert ps.parts[0].n_poses == 360
    bad = tmp_path / "bad.toml"
    bad.write_text('[plan]\ninstrument = "ballbar"\n[setup]\nbar_length = "300 mm"\n[[setups]]\n'
                   'fixed_ball = [0, 0, 0]\n[[setups]]\nfixed_ball = [0, 0]\n[[paths]]\nkind = "hemisphere"\n')
    with pytest.raises(InputError, match=r"setups\[2\]\.fixed_ball"):
        read_plan(bad)
    bad.write_text(bad.read_text().replace("fixed_ball = [0, 0]\n", "fixed_ball = [0, 0, 0]\nplaced_by_machine = 1\n"))
    with pytest.raises(InputError, match=r"setups\[2\]\.placed_by_machine"):
        read_plan(bad)
    placed = bad.read_text().replace("placed_by_machine = 1", "placed_by_machine = true")
    bad.write_text(placed)
    ps = read_plan(bad)
    assert ps.parts[0].setup.placing_pose is None and np.allclose(ps.parts[1].setup.placing_pose, 0.0)


def test_machine_placed_ball_round_trip_on_the_command_line(tmp_path, capsys):
    """A plan whose balls the machine places: the measurement files record the placing pose, identify reads it
    (the readings fit to the noise only if the ball is modelled where the perturbed machine put it), and check
    predicts it for the calibrated machine."""
    from pkmstiff.calibration.measurement_file import read_measurement
    from pkmstiff.cli import main

    plan = tmp_path / "placed.toml"
    text = resolve("example:felix_setups_plan.toml").read_text(encoding="utf-8")
    text = text.replace('fixed_ball = ["100 mm", "0 mm", "-100 mm"]',
                        'fixed_ball = ["100 mm", "0 mm", "-100 mm"]\nplaced_by_machine = true')
    plan.write_text(text.replace("points = 360", "points = 120"), encoding="utf-8")
    out = tmp_path / "m.csv"
    assert main(["calibrate", "simulate", "felix", "--plan", str(plan), "--errors", "example:felix_errors.toml",
                 "--seed", "1", "--feed", "2000", "--sample-rate", "5", "--out", str(out)]) == 0
    files = [tmp_path / f"m_setup{k}.csv" for k in (1, 2, 3)]
    assert read_measurement(files[0]).placing_pose is None
    assert np.allclose(read_measurement(files[1]).placing_pose, [0.1, 0.0, -0.1, 0.0, 0.0, 0.0], atol=1e-12)
    cal = tmp_path / "cal.toml"
    assert main(["calibrate", "identify", "felix", "--measurements", *map(str, files), "--out", str(cal)]) == 0
    capsys.readouterr()
    assert main(["calibrate", "check", str(cal), "--measurements", str(files[1]), "--json"]) == 0
    import json

    rep = json.loads(capsys.readouterr().out)
    assert rep["rms_um"] < 0.35 and rep["diagnostics"]["consistent"]  # 0.25 µm noise + 0.1 µm quantisation


def _simulate_setups(tmp_path, *extra: str):
    from pkmstiff.cli import main

    plan = tmp_path / "plan.toml"
    text = resolve("example:felix_setups_plan.toml").read_text(encoding="utf-8")
    plan.write_text(text.replace("points = 360", "points = 60"), encoding="utf-8")
    out = tmp_path / ("one.csv" if extra else "m.csv")
    assert main(["calibrate", "simulate", "felix", "--plan", str(plan), "--errors", "example:felix_errors.toml",
                 "--noise", "0", "--no-quantise", "--feed", "2000", "--sample-rate", "5", "--out", str(out),
                 *extra]) == 0
    return out


def test_one_file_with_several_setups_round_trip(tmp_path):
    """``calibrate simulate --one-file``: one CSV with a 'setup' column and the set-ups in its header; it reads back
    as the three set-ups, identifies noise-free to the residual floor and gives what the three files give."""
    from pkmstiff.calibration.measurement_file import read_measurement, read_measurement_setups
    from pkmstiff.calibration.workflow import identify_file

    one = _simulate_setups(tmp_path, "--one-file")
    _simulate_setups(tmp_path)
    files = [str(tmp_path / f"m_setup{k}.csv") for k in (1, 2, 3)]
    metas = read_measurement_setups(one)
    assert [tuple(m.fixed_ball) for m in metas] == [tuple(read_measurement(f).fixed_ball) for f in files]
    for a, f in zip(metas, files):
        b = read_measurement(f)
        assert np.array_equal(a.reading, b.reading) and np.array_equal(a.poses, b.poses)  # same text, same parse
    with pytest.raises(InputError, match="several set-ups"):
        read_measurement(one)
    m = _felix()
    r1 = identify_file(m, str(one), with_="fixed-ball")
    r3 = identify_file(m, files, with_="fixed-ball")
    assert r1.params.names == r3.params.names and r1.plan.n_setups == 3
    # the same readings and plan: the same iterations, equal up to round-off (1e-12 m ≪ the 1e-9 m floor)
    assert np.allclose(r1.res.delta, r3.res.delta, rtol=0, atol=1e-12)
    # noise-free, not quantised: the model reproduces the readings to LM's convergence floor
    assert np.sqrt(np.mean(r1.res.residual_after ** 2)) < 1e-9
    bad = tmp_path / "one.csv"
    bad.write_text(bad.read_text().replace("\n3,", "\n4,", 1))
    with pytest.raises(InputError, match="set-up number 1 … 3"):
        read_measurement_setups(bad)


def test_report_of_several_setups(tmp_path, capsys):
    """``calibrate report`` of a file with three set-ups: a Set-ups section whose per-set-up residuals are the joint
    fit's residuals split by set-up and whose identifiability gain is the stacked rank over the best set-up alone;
    the three-file route gives the same summary numbers."""
    import json

    from pkmstiff.calibration.workflow import run_calibration
    from pkmstiff.cli import main
    from tests.report_checks import check_report

    one = _simulate_setups(tmp_path, "--one-file")
    _simulate_setups(tmp_path)
    out = tmp_path / "rep"
    capsys.readouterr()
    assert main(["calibrate", "report", "felix", "--measurements", str(one), "--out", str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["n_setups"] == 3
    html = (out / "report.html").read_text(encoding="utf-8")
    md = (out / "report.md").read_text(encoding="utf-8")
    check_report(html, md)
    assert "Set-ups" in md and "set-up 3" in md
    files = [str(tmp_path / f"m_setup{k}.csv") for k in (1, 2, 3)]
    assert main(["calibrate", "report", "felix", "--measurements", *files, "--out", str(tmp_path / "rep3"),
                 "--json"]) == 0
    rep3 = json.loads(capsys.readouterr().out)
    # the same readings: the same fit, equal up to round-off (1e-6 µm ≪ the quantities compared)
    for key in ("rank", "n_parameters", "n_readings"):
        assert rep3[key] == rep[key]
    assert rep3["rms_before_um"] == pytest.approx(rep["rms_before_um"], abs=1e-6)
    run = run_calibration(_felix(), str(one))
    ends = np.cumsum([0] + [s.meas.n_samples for s in run.setups])
    assert [s.rows for s in run.setups] == [slice(int(a), int(b)) for a, b in itertools.pairwise(ends)]
    assert ends[-1] == run.res.n_readings
    gain = run.ident.rank - max(s.ident.rank for s in run.setups)
    assert gain > 0  # balls at other places see directions one ball cannot (test_more_fixed_balls_...)
    assert f"(gain {gain})" in md


def test_tracker_stations_are_set_ups(tmp_path):
    """A laser tracker moved to two stations: each station its own instrument frame (``--with instrument-frame``
    per set-up), the machine once. Noise-free readings of a perturbed Felix fit to the forward kinematics' floor,
    the second station adds exactly its own six frame parameters to the rank, and the one-file route (a 'setup'
    column in a tracker file) gives the same identification."""
    from pkmstiff.calibration.instruments import TRACKER
    from pkmstiff.calibration.measurement_file import read_measurement_setups, write_measurement_setups
    from pkmstiff.calibration.plans import default_plan
    from pkmstiff.calibration.simulation import SimulationOptions, simulate, to_measurement
    from pkmstiff.calibration.workflow import identify_file

    m = _felix()
    base = default_plan(m, TRACKER)
    station2 = dataclasses.replace(base, name="station 2", poses=base.poses[::-1].copy())
    ps = PlanSet("two stations", (base, station2))
    params = setups_error_model(m, ps, setup_blocks=("instrument_frame",))
    assert params.n == setups_error_model(m, ps).n + 12 and set(params.chain[params.chain < 0]) == {-1, -2}
    one = identifiability(m, setups_error_model(m, base, setup_blocks=("instrument_frame",)), base)
    both = identifiability(m, params, ps)
    assert both.rank == one.rank + 6  # the second station's frame is seen (relative to the first), nothing else
    rng = np.random.default_rng(7)
    true = rng.uniform(-1, 1, params.n) * 1e-4
    res = identify(m, params, ps, simulate_readings(m, params, true, ps))
    assert np.max(np.abs(res.residual_after)) < 1e-9  # m; the forward kinematics solves to 1e-13
    # the same through the files: one tracker file holding both stations
    opts = SimulationOptions(noise="none", quantise=False)
    metas = []
    for k, part in enumerate(ps.parts):
        sub, idx = part_parameters(params, k)
        inst = TRACKER.device(part.setup)
        metas.append(to_measurement(m, part, simulate(m, sub, true[idx], part, inst, opts), inst))
    path = tmp_path / "tracker.csv"
    write_measurement_setups(path, metas)
    back = read_measurement_setups(path)
    assert len(back) == 2 and all(b.instrument == TRACKER for b in back)
    run = identify_file(m, str(path), with_="instrument-frame")
    assert run.params.names == params.names
    assert np.sqrt(np.mean(run.res.residual_after ** 2)) < 1e-9


def test_check_of_a_file_with_several_setups_is_the_check_of_each_setup(tmp_path, capsys):
    """``calibrate check`` of a one-file measurement of three set-ups: each set-up is checked as its own file is
    (same readings, same plan: equal statistics up to round-off), and the overall statistics are those of all
    readings together."""
    import json

    from pkmstiff.cli import main

    one = _simulate_setups(tmp_path, "--one-file")
    _simulate_setups(tmp_path)
    capsys.readouterr()
    assert main(["calibrate", "check", "felix", "--measurements", str(one), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert [p["setup"] for p in rep["setups"]] == [1, 2, 3]
    singles = []
    for k in (1, 2, 3):
        assert main(["calibrate", "check", "felix", "--measurements", str(tmp_path / f"m_setup{k}.csv"),
                     "--json"]) == 0
        singles.append(json.loads(capsys.readouterr().out))
    for part, single in zip(rep["setups"], singles):
        assert part["n_readings"] == single["n_readings"]
        # the same arithmetic on the same parsed numbers; 1e-9 µm absorbs any summation-order round-off
        assert part["rms_um"] == pytest.approx(single["rms_um"], abs=1e-9)
        assert part["diagnostics"]["consistent"] == single["diagnostics"]["consistent"]
    assert rep["n_readings"] == sum(s["n_readings"] for s in singles)
    ms = sum(s["rms_um"] ** 2 * s["n_readings"] for s in singles) / rep["n_readings"]
    assert rep["rms_um"] == pytest.approx(np.sqrt(ms), rel=1e-12)  # RMS of all readings from the parts' RMS
    assert main(["calibrate", "check", "felix", "--measurements", str(one)]) == 0
    text = capsys.readouterr().out
    assert text.count("set-up ") >= 3 and "model fit" in text
