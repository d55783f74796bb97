"""Simulated measurements along every plan kind and instrument (issue 16 items 1, 2, 5): ball bar, laser tracker
and 6-D pose files, the nominal round trip through the measurement CSV, simulate → identify, refusal of plans
whose sampled poses leave the admissible region, and one-line errors for malformed tracker / pose files."""

import numpy as np
import pytest

import pkmstiff
from pkmstiff.calibration import Plan, Segment, Setup, circle_plan, error_model, grid_plan, hemisphere_plan
from pkmstiff.calibration.compensation import measurement_plan
from pkmstiff.calibration.identifiability import identifiability
from pkmstiff.calibration.identification import identify
from pkmstiff.calibration.instruments import target_points
from pkmstiff.calibration.measurement_file import PointMeasurement, read_measurement, write_measurement
from pkmstiff.calibration.instruments import BallbarDevice, TrackerDevice
from pkmstiff.calibration.simulation import (
    SimulationOptions,
    check_samples,
    sample_plan,
    simulate,
    to_measurement,
)
from pkmstiff.cli import main
from pkmstiff.errors import CalibrationError, CalibrationInputError, MeasurementFileError
from pkmstiff.kinematics.rotation import cardan_matrix

FAST = 5000.0 / 60e3  # 5000 mm/min: few samples per path
NOMINAL = SimulationOptions(feed=FAST, noise="none", quantise=False, directions=("ccw",))


@pytest.fixture(scope="module")
def felix():
    return pkmstiff.load_machine("felix")


def _commanded_target(setup, poses):
    return target_points(setup.state(), poses[:, :3], cardan_matrix(poses[:, 3], poses[:, 4], poses[:, 5]))


def _plans(m):
    """One plan of every kind: ball-bar circle and hemisphere paths, tracker grid, pose list and circle path, and a
    6-D grid (the pose instrument)."""
    tip = m.tool.tip()
    bb = Setup("ballbar", target=tip, fixed_ball=np.zeros(3), bar_length=0.15)
    tr = Setup("tracker", target=tip)
    po = Setup("pose", target=tip)
    poses = np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.05, -0.03, 0.02, 0.05, -0.04, 0.1]])
    return [circle_plan(bb, "XY", 36), hemisphere_plan(bb, n=40, turns=1.0, tilt=0.05, torsion=0.05),
            grid_plan(tr, np.zeros(3), 0.05, points=2, tilt=np.radians(5), torsion=np.radians(5)),
            Plan("tracker poses", tr, poses, (Segment("poses", 0, 2, "points"),)),
            circle_plan(tr, "XZ", 24, centre=np.zeros(3), radius=0.08),
            grid_plan(po, np.zeros(3), 0.05, points=2, tilt=np.radians(5), torsion=np.radians(5))]


def test_nominal_machine_reads_the_commanded_values_on_every_plan_kind_through_the_file(felix, tmp_path):
    """Done-when: a nominal machine reads the nominal bar length (ball bar) / the commanded target position and a
    zero orientation error (tracker, 6-D) to 1e-12 m along every plan kind, here after the round trip through the
    measurement CSV (15 significant digits in mm / µrad: ≤ 1e-15 m, 1e-15 µrad of rounding)."""
    for plan in _plans(felix):
        params = error_model(felix, setup=plan.setup)
        inst = plan.instrument.default_device()
        res = simulate(felix, params, np.zeros(params.n), plan, inst, NOMINAL)
        path = write_measurement(tmp_path / f"{plan.instrument}.csv", to_measurement(felix, plan, res, inst))
        back = read_measurement(path)
        p2, y = measurement_plan(back, "felix", str(path))
        assert p2.instrument == plan.instrument and y.shape == (len(res.readings), plan.setup.n_readings)
        if plan.instrument.kind == "ballbar":
            ref = np.full(len(y), plan.setup.bar_length) if plan.segments[0].kind == "path" else None
            assert np.max(np.abs(y[:, 0] - ref)) <= 1e-12  # 1e-12 m: the done-when criterion
            continue
        cmd = _commanded_target(plan.setup, back.poses)
        assert np.max(np.abs(y[:, :3] - cmd)) <= 1e-12  # m: the done-when criterion (rounding ~1e-16 m)
        if plan.instrument.kind == "pose":
            assert np.max(np.abs(y[:, 3:])) <= 1e-12  # rad: R R_cᵀ = I up to rounding
        if plan.segments[0].kind == "path":
            assert len(y) > plan.n_poses  # a tracker path is sampled at the instrument rate, too


@pytest.mark.parametrize("kind", ["tracker", "pose"])
def test_simulate_identify_round_trip_recovers_the_base_errors(felix, tmp_path, kind):
    """Noise-free simulate → CSV → identify on a tracker / 6-D pose set: random errors of ±50 µm on the plan's base
    parameters (the gauge freedoms held at zero) come back to ≤ 1e-9 m. Budget: readings through the file to
    ~1e-16 m, forward kinematics to 1e-13 m, times the condition number of the scaled Jacobian (≤ 7e4 here)
    gives ≤ 1e-9 m."""
    s = Setup(kind, target=felix.tool.tip())
    plan = grid_plan(s, np.zeros(3), 0.08, points=3, tilt=np.radians(10), torsion=np.radians(10))
    params = error_model(felix, setup=s)
    base = np.array([params.index(n) for n in identifiability(felix, params, plan).base_parameters])
    delta = np.zeros(params.n)
    delta[base] = np.random.default_rng(0).uniform(-50e-6, 50e-6, base.size)
    inst = TrackerDevice()
    res = simulate(felix, params, delta, plan, inst, SimulationOptions(noise="none", quantise=False))
    path = write_measurement(tmp_path / "m.csv", to_measurement(felix, plan, res, inst))
    p2, y = measurement_plan(read_measurement(path), "felix", str(path))
    # the base set is passed: a pivoted QR may break a tie between equivalent parameters differently on poses
    # that differ by the file's rounding (the readings would still match, the names not)
    out = identify(felix, error_model(felix, setup=p2.setup), p2, y, "lm", base=base)
    assert np.max(np.abs(out.delta - delta)) <= 1e-9
    assert np.max(np.abs(out.residual_after)) <= 1e-12  # m: the readings are reproduced to the FK tolerance


def test_tracker_noise_quantisation_and_instrument_figures(felix):
    m = TrackerDevice()
    # Assumption figures: MPE 15 µm + 6 µm/m at 2 m = 27 µm, σ = MPE / 2 (k = 2)
    assert m.accuracy == pytest.approx(27e-6, rel=1e-12)
    assert m.sigma("instrument", 0.0) == pytest.approx(13.5e-6, rel=1e-12)
    with pytest.raises(CalibrationInputError, match="procedure"):
        m.sigma("procedure", 0.0)
    s = Setup("pose", target=felix.tool.tip())
    plan = grid_plan(s, np.zeros(3), 0.05, points=3, tilt=np.radians(5), torsion=np.radians(5))
    params = error_model(felix, setup=s)
    inst = TrackerDevice()
    res = simulate(felix, params, np.zeros(params.n), plan, inst, SimulationOptions(seed=3))
    pos = res.readings[:, :3] / inst.resolution
    rot = res.readings[:, 3:] / inst.angle_resolution
    assert np.max(np.abs(pos - np.round(pos))) < 1e-6 and np.max(np.abs(rot - np.round(rot))) < 1e-6  # on the grid
    err = res.readings - res.clean
    # 243 position / 243 angle samples: the sample σ is within ±25 % of the model σ with probability > 0.9999
    # (relative standard error of σ̂: 1/√(2·243) = 4.5 %; 25 % = 5.5 standard errors)
    assert np.std(err[:, :3]) == pytest.approx(13.5e-6, rel=0.25)
    assert np.std(err[:, 3:]) == pytest.approx(87.5e-6, rel=0.25)


def test_instrument_must_match_the_plan(felix):
    s = Setup("tracker", target=np.zeros(3))
    plan = grid_plan(s, np.zeros(3), 0.05, points=2)
    params = error_model(felix, setup=s)
    with pytest.raises(CalibrationInputError, match="tracker"):
        simulate(felix, params, np.zeros(params.n), plan, BallbarDevice())


# ------------------------------------------------------------------------------ sampled poses leave the region

def _outside_circle(m):
    """A 300 mm circle about (−600, 0, 0) mm on Felix given by three nodes: every node is admissible, but the
    circle the samples follow between them (at constant feed) leaves the drive range of chain 6."""
    st = Setup("ballbar", target=m.tool.tip(), fixed_ball=np.array([-0.6, 0.0, 0.0]), bar_length=0.3)
    return circle_plan(st, "XY", 3)


def test_plan_whose_sampled_poses_leave_the_admissible_region_is_refused(felix):
    from pkmstiff.calibration import check_plan

    plan = _outside_circle(felix)
    check_plan(felix, plan)  # the nodes pass ...
    smp = sample_plan(plan, BallbarDevice(), SimulationOptions(feed=FAST))
    with pytest.raises(CalibrationError) as exc:  # ... the sampled poses do not
        check_samples(felix, plan, smp)
    msg = str(exc.value)
    assert "\n" not in msg and "sampled poses not admissible on felix" in msg
    assert msg.count("sample ") >= 3 and "(t = " in msg and "deg)" in msg  # three poses listed with time and pose
    assert "drive position / strut length outside its range (chain 6)" in msg  # with the failing check


def test_cli_refuses_the_plan_before_simulating(tmp_path, capsys):
    plan = tmp_path / "p.toml"
    plan.write_text('[plan]\nname = "wide"\ninstrument = "ballbar"\n[setup]\nfixed_ball = ["-600 mm", "0 mm", '
                    '"0 mm"]\nbar_length = "300 mm"\n[[paths]]\nkind = "circle"\nplane = "XY"\npoints = 3\n')
    code = main(["calibrate", "simulate", "felix", "--plan", str(plan), "--out", str(tmp_path / "m.csv")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "sampled poses not admissible" in err and "chain 6" in err
    assert not (tmp_path / "m.csv").exists()


# ---------------------------------------------------------------------------------------- CLI and bad files

TRACKER_PLAN = """
[plan]
name = "felix tracker grid"
instrument = "{kind}"

[setup]
target = ["0 mm", "0 mm", "0 mm"]

[[paths]]
kind = "grid"
centre = ["0 mm", "0 mm", "0 mm"]
half_width = "60 mm"
points = 2
tilt = "5 deg"
torsion = "5 deg"
"""


@pytest.mark.parametrize("kind", ["tracker", "pose"])
def test_cli_simulate_identify_check_on_tracker_and_pose_files(tmp_path, capsys, kind):
    p = tmp_path / "plan.toml"
    p.write_text(TRACKER_PLAN.format(kind=kind))
    e = tmp_path / "errors.toml"
    e.write_text('[errors]\n"chain1.strut_offset" = "20 um"\n')
    out = tmp_path / "m.csv"
    assert main(["calibrate", "simulate", "felix", "--plan", str(p), "--errors", str(e), "--noise", "none",
                 "--no-quantise", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "position error up to" in text
    meas = read_measurement(out)
    assert isinstance(meas, PointMeasurement) and meas.instrument.kind == kind and meas.n_samples == 24
    assert main(["calibrate", "check", "felix", "--measurements", str(out)]) == 0
    assert "residual RMS" in capsys.readouterr().out
    other = "pose" if kind == "tracker" else "tracker"
    code = main(["calibrate", "identify", "felix", "--measurements", str(out), "--instrument", other])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and f"holds {kind} readings" in err


def _good(tmp_path, kind="tracker"):
    """The lines of a valid file in the earlier form (``# key: value`` header lines, still read): the written CSV
    with its JSON header turned back into those lines."""
    m = PointMeasurement(instrument=kind, t=np.arange(1.0, 4.0), position=np.array([[0.1, 0.2, 0.3]] * 3),
                         rotation=np.zeros((3, 3)) if kind == "pose" else None,
                         poses=np.zeros((3, 6)), machine="felix", device="test")
    path = write_measurement(tmp_path / f"{kind}.csv", m)
    return _old_form(path.with_suffix(".json")) + path.read_text().splitlines()


def _old_form(sidecar) -> list[str]:
    import json

    meta = json.loads(sidecar.read_text(encoding="utf-8"))
    lines = [f"# {meta.pop('file')}"]
    for key, value in meta.items():
        for v in (value if key == "note" else [value]):
            lines.append(f"# {key}: {', '.join(map(str, v)) if isinstance(v, list) else v}")
    return lines


def _bad(tmp_path, lines):
    p = tmp_path / "bad.csv"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(MeasurementFileError) as exc:
        read_measurement(p)
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


def test_tracker_file_round_trip(tmp_path):
    for kind in ("tracker", "pose"):
        lines = _good(tmp_path, kind)
        back = read_measurement(tmp_path / f"{kind}.csv")
        assert back.instrument.kind == kind and back.position[2, 2] == pytest.approx(0.3, abs=1e-15)  # 15 digits in mm
        assert (back.rotation is None) == (kind == "tracker")
        assert back.target.shape == (3,) and back.volume_radius == pytest.approx(20.0, abs=1e-12)
        assert lines[2] == f"# instrument_type: {kind}"
        assert lines[len(lines) - 4].startswith("t_s,") and not (tmp_path / f"{kind}.csv").read_text().startswith("#")
        # the old form reads as the new one
        old = tmp_path / f"old_{kind}.csv"
        old.write_text("\n".join(lines) + "\n")
        np.testing.assert_array_equal(read_measurement(old).position, back.position)


def test_malformed_tracker_and_pose_files_name_line_and_column(tmp_path):
    lines = _good(tmp_path)
    col = lines.index(next(ln for ln in lines if ln.startswith("t_s")))
    header = lines[col].split(",")
    j = header.index("py_mm")
    row = lines[col + 2].split(",")
    row[j] = "abc"
    msg = _bad(tmp_path, lines[:col + 2] + [",".join(row)] + lines[col + 3:])
    assert f"line {col + 3}" in msg and f"column {j + 1} (py_mm)" in msg and "'abc'" in msg
    msg = _bad(tmp_path, lines[:col] + [lines[col].replace("pz_mm", "reading_mm")] + lines[col + 1:])
    assert f"line {col + 1}" in msg and "column" in msg and "reading_mm" in msg and "ballbar file" in msg
    msg = _bad(tmp_path, [ln.replace("# instrument_type: tracker", "# instrument_type: sonar") for ln in lines])
    assert "line 3" in msg and "instrument_type" in msg and "sonar" in msg
    msg = _bad(tmp_path, lines[:3] + ["# bar_length_mm: 150"] + lines[3:])
    assert "line 4" in msg and "bar_length_mm" in msg and "tracker" in msg
    msg = _bad(tmp_path, lines[:3] + ["# angle_accuracy_urad: 100"] + lines[3:])
    assert "line 4" in msg and "pose file" in msg
    far = lines[col + 1].split(",")
    far[header.index("px_mm")] = "25000"
    msg = _bad(tmp_path, lines[:col + 1] + [",".join(far)] + lines[col + 2:])
    assert f"line {col + 2}" in msg and "column" in msg and "measuring volume" in msg
    pose = _good(tmp_path, "pose")
    pc = pose.index(next(ln for ln in pose if ln.startswith("t_s")))
    msg = _bad(tmp_path, pose[:pc] + [pose[pc].replace(",rz_urad", ",rz_mrad")] + pose[pc + 1:])
    assert f"line {pc + 1}" in msg and "rz_mrad" in msg
    msg = _bad(tmp_path, lines[:col] + [lines[col] + ",rx_urad"] + [r + ",0" for r in lines[col + 1:]])
    assert "rx_urad" in msg and "pose file" in msg


def test_ballbar_files_unchanged(tmp_path):
    """Backward compatibility: a ball-bar file has no instrument_type key and its columns are as before."""
    from pkmstiff.calibration.measurement_file import BallbarMeasurement

    m = BallbarMeasurement(bar_length=0.15, fixed_ball=np.zeros(3), t=np.arange(3.0), reading=np.zeros(3),
                           poses=np.zeros((3, 6)))
    text = write_measurement(tmp_path / "b.csv", m).read_text()
    header = (tmp_path / "b.json").read_text()
    assert "instrument_type" not in header and text.startswith("t_s,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,reading_mm\n")
    assert isinstance(read_measurement(tmp_path / "b.csv"), BallbarMeasurement)
