"""Measurement CSV (issue 16 item 5): round trip, malformed files with one-line errors, and ``pkmstiff ballbar``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from pkmstiff.calibration.ballbar import evaluate_measurement
from pkmstiff.calibration.measurement_file import (BallbarMeasurement, range_violations, read_measurement,
                                                   write_measurement)
from pkmstiff.cli import main
from pkmstiff.errors import BallbarError, MeasurementFileError
from tests.ballbar_synth import QC10_NOISE, QC10_RESOLUTION, circle_run, measurement_from_runs

R = 0.15


def _meas(n=600, **kw):
    ccw = circle_run(R, n, offset=(10e-6, -4e-6), ellipse=3e-6, noise=QC10_NOISE, resolution=QC10_RESOLUTION, seed=1)
    cw = circle_run(R, n, offset=(10e-6, -4e-6), ellipse=3e-6, radius_error=-2e-6, noise=QC10_NOISE,
                    resolution=QC10_RESOLUTION, seed=2, direction=-1)
    return measurement_from_runs({"ccw": ccw, "cw": cw}, machine="felix", notes=["synthetic test data"], **kw)


def test_round_trip(tmp_path):
    m = _meas(plane="XY")
    m.poses[:, 3:] = np.radians([1.5, -2.0, 30.0])  # non-zero orientation exercises the degree columns
    m.ball_offset = np.array([0.0, 0.001, 0.065])
    path = write_measurement(tmp_path / "m.csv", m)
    back = read_measurement(path)
    # values are written with 15 significant digits in mm/deg: relative rounding ≤ 5e-15, plus one unit conversion
    for name in ("t", "reading", "poses", "feed", "temperature", "fixed_ball", "ball_offset"):
        assert np.allclose(getattr(back, name), getattr(m, name), rtol=1e-14, atol=1e-18), name
    assert back.bar_length == pytest.approx(m.bar_length, rel=1e-15)
    assert list(back.direction) == list(m.direction)
    assert (back.machine, back.device, back.plane, back.notes) == ("felix", "QC10", "XY", ["synthetic test data"])
    assert back.range == pytest.approx(m.range, rel=1e-15) and back.resolution == pytest.approx(1e-7, rel=1e-15)
    assert back.lines[0] == 2  # the column row, then the samples (the header is m.json beside the CSV)
    assert path.with_suffix(".json").is_file() and path.read_text().startswith("t_s,")


def test_round_trip_drives_and_tiny_readings(tmp_path):
    n = 5
    m = BallbarMeasurement(bar_length=0.3, fixed_ball=np.zeros(3), t=np.arange(n) * 0.004,
                           reading=np.array([1e-12, -1e-12, 0.0, 3e-13, 5e-4]),
                           drives=np.column_stack([np.linspace(1.5, 1.6, n), np.radians(np.linspace(0, 10, n))]),
                           drive_units=("mm", "deg"))
    back = read_measurement(write_measurement(tmp_path / "d.csv", m))
    # a nominal machine's 1e-12 m readings survive the file (issue 16: nominal bar length to 1e-12 m)
    assert np.allclose(back.reading, m.reading, rtol=1e-14, atol=1e-25)
    assert np.allclose(back.drives, m.drives, rtol=1e-14) and back.drive_units == ("mm", "deg")
    assert back.poses is None and back.direction is None
    with pytest.raises(BallbarError, match="no commanded pose"):
        evaluate_measurement(back)


def test_writer_reports_range_violations(tmp_path):
    m = _meas(n=100)
    m.reading[[10, 20, 30]] = [1.2e-3, -1.5e-3, 2e-3]
    assert list(range_violations(m)) == [10, 20, 30]
    with pytest.raises(MeasurementFileError, match=r"3 reading\(s\) outside .* first at sample 10"):
        write_measurement(tmp_path / "x.csv", m)
    write_measurement(tmp_path / "x.csv", m, allow_out_of_range=True)
    with pytest.raises(MeasurementFileError) as exc:
        read_measurement(tmp_path / "x.csv")
    msg = str(exc.value)
    # sample 10 is on file line 1 + 11 = 12 (column row 1; the header is in x.json)
    assert "line 12, column 8 (reading_mm)" in msg and "3 readings out of range" in msg
    assert read_measurement(tmp_path / "x.csv", check_range=False).n_samples == 200


GOOD = """# pkmstiff ball-bar measurement
# bar_length_mm: 150
# fixed_ball_mm: 0, 0, 0
t_s,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,reading_mm,direction
0,150,0,0,0,0,0,0.001,ccw
0.004,0,150,0,0,0,0,0.002,ccw
0.008,-150,0,0,0,0,0,0.001,ccw
"""


def _replace(old, new):
    assert old in GOOD
    return GOOD.replace(old, new, 1)


MALFORMED = [
    (_replace("# fixed_ball_mm", "# colour: red\n# fixed_ball_mm"), "line 3", "unknown header key 'colour'"),
    (_replace("150\n", "15o\n"), "line 2", "'bar_length_mm': expected a number"),
    (_replace("0, 0, 0", "0, 0"), "line 3", "3 comma-separated numbers"),
    (_replace("# bar_length_mm: 150\n", ""), None, "missing header key 'bar_length_mm'"),
    (_replace("# bar_length_mm: 150", "# bar_length_mm: -150"), "line 2", "positive length"),
    (_replace("reading_mm,direction", "reading_mm,colour"), "line 4, column 9 (colour)", "unknown column"),
    (_replace("reading_mm,", ""), "line 4", "missing column 'reading_mm'"),
    (_replace("z_mm,", ""), "line 4", "missing z_mm"),
    (_replace("t_s,x_mm", "t_s,t_s,x_mm"), "line 4, column 2 (t_s)", "duplicate column"),
    (_replace("0.004,0,150", "0.004,0,15O"), "line 6, column 3 (y_mm)", "expected a number, found '15O'"),
    (_replace("0.004,0,150", "0.004,0,nan"), "line 6, column 3 (y_mm)", "finite number"),
    (_replace("0.002,ccw", "0.002"), "line 6", "expected 9 values"),
    (_replace("0.002,ccw", "0.002,up"), "line 6, column 9 (direction)", "'ccw' or 'cw'"),
    (_replace("0.008,", "0.002,"), "line 7, column 1 (t_s)", "time must not decrease"),
    (_replace("0.002,ccw", "1.5,ccw"), "line 6, column 8 (reading_mm)", "outside the instrument range"),
    ("# bar_length_mm: 150\n# fixed_ball_mm: 0,0,0\n", None, "no column row"),
    (GOOD.split("0,150")[0], "line 4", "no data rows"),
    (_replace("# pkmstiff ball-bar measurement", "# format_version: 2"), "line 1", "format_version"),
    (_replace("# bar_length_mm: 150", "# bar_length_mm: 150\n# bar_length_mm: 100"), "line 3", "repeated"),
]


@pytest.mark.parametrize("text,where,what", MALFORMED)
def test_malformed_files_give_one_line_errors(tmp_path, text, where, what):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(MeasurementFileError) as exc:
        read_measurement(path)
    msg = str(exc.value)
    assert "\n" not in msg and str(path) in msg and what in msg
    if where is not None:
        assert where in msg


def test_good_file_reads(tmp_path):
    path = tmp_path / "good.csv"
    path.write_text(GOOD)
    m = read_measurement(path)
    assert m.n_samples == 3 and m.range == pytest.approx((-1e-3, 1e-3))  # QC10 default range (Tab. 4.3)
    assert m.poses[1, 1] == pytest.approx(0.15, rel=1e-15) and m.reading[1] == pytest.approx(2e-6, rel=1e-15)


def test_missing_file():
    with pytest.raises(MeasurementFileError, match="file not found"):
        read_measurement("/nonexistent/x.csv")


def test_cli_text_json_and_plots(tmp_path, capsys):
    path = write_measurement(tmp_path / "run.csv", _meas(n=2000))
    assert main(["ballbar", "analyse", str(path), "--json", "--plot", str(tmp_path / "plots")]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert set(rep["runs"]) == {"ccw", "cw"} and rep["bar_length_mm"] == pytest.approx(150.0)
    ccw = rep["runs"]["ccw"]
    # offset 10.77 µm and ellipse 3 µm in the synthetic data; noise 0.5 µm on 2000 samples → ±0.05 µm
    assert ccw["harmonics"]["amplitude_um"][1] == pytest.approx(math.hypot(10, 4), abs=0.1)
    assert ccw["harmonics"]["amplitude_um"][2] == pytest.approx(3.0, abs=0.1)
    assert ccw["harmonics"]["n"] == 2 and rep["hysteresis_H_um"] > 0
    for p in rep["plots"]:
        assert (tmp_path / "plots" / p.split("/")[-1]).stat().st_size > 10_000
    assert main(["ballbar", "analyse", str(path), "--harmonics", "3"]) == 0
    out = capsys.readouterr().out
    assert "harmonics: n = 3 (fixed)" in out and "hysteresis H" in out


@pytest.mark.parametrize("args,what", [(["--harmonics", "many"], "--harmonics"), (["--alpha", "2"], "--alpha")])
def test_cli_bad_arguments(tmp_path, capsys, args, what):
    path = write_measurement(tmp_path / "run.csv", _meas(n=100))
    assert main(["ballbar", "analyse", str(path), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert what in err and "\n" not in err


def test_cli_malformed_file_exit_2(tmp_path, capsys):
    path = tmp_path / "bad.csv"
    path.write_text(MALFORMED[9][0])
    assert main(["ballbar", "analyse", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "line 6, column 3 (y_mm)" in err and "\n" not in err and "Traceback" not in err


def test_blank_and_comment_lines_keep_line_numbers(tmp_path):
    text = GOOD.replace("0.004,0,150,0,0,0,0,0.002,ccw\n", "\n# a comment between rows\n0.004,0,150,0,0,0,0,0.002,ccw\n")
    text = text.replace("-150,0,0,0,0,0,0.001", "-150,0,0,0,0,0,x")
    path = tmp_path / "c.csv"
    path.write_text(text)
    with pytest.raises(MeasurementFileError, match=r"line 9, column 8 \(reading_mm\)"):
        read_measurement(path)


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

_finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


@settings(max_examples=40, deadline=None)
@given(pose=st.lists(_finite, min_size=6, max_size=6), reading=st.floats(-1e-3, 1e-3),
       offset=st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3), bar=st.floats(1e-3, 2.0))
def test_round_trip_property(tmp_path_factory, pose, reading, offset, bar):
    m = BallbarMeasurement(bar_length=bar, fixed_ball=np.array(offset), ball_offset=np.array(offset[::-1]),
                           t=np.array([0.0, 0.5]), reading=np.array([reading, -reading]),
                           poses=np.array([pose, pose[::-1]]))
    path = write_measurement(tmp_path_factory.mktemp("rt") / "p.csv", m)
    back = read_measurement(path)
    # 15 significant digits in the file unit plus one unit conversion: relative error ≤ 1e-14;
    # absolute floor 1e-300 for values that underflow to ~0 in either direction
    for name in ("reading", "poses", "fixed_ball", "ball_offset"):
        assert np.allclose(getattr(back, name), getattr(m, name), rtol=1e-14, atol=1e-300), name
    assert back.bar_length == pytest.approx(bar, rel=1e-14)


def test_drive_only_file_via_forward_kinematics(tmp_path, capsys):
    from pkmstiff import load_machine
    from pkmstiff.kinematics import inverse_kinematics

    machine = load_machine("hexaglide")
    centre = np.array([0.0, 0.3, -1.0])  # inside the Hexaglide workspace (benchmarks/bench_kinematics.py)
    run = circle_run(R, 720, offset=(20e-6, 5e-6), ellipse=4e-6, fixed_ball=tuple(centre))
    poses = np.zeros((720, 6))
    poses[:, :3] = run.positions
    with_poses = measurement_from_runs({"ccw": run}, fixed_ball=centre, machine="hexaglide")
    with_poses.poses = poses
    drives_only = measurement_from_runs({"ccw": run}, fixed_ball=centre, machine="hexaglide")
    drives_only.poses, drives_only.drives = None, inverse_kinematics(machine, poses).drive
    path = write_measurement(tmp_path / "drives.csv", drives_only)
    ref = evaluate_measurement(with_poses).runs["ccw"]
    ev = evaluate_measurement(read_measurement(path), machine=machine, start_pose=[*centre, 0, 0, 0]).runs["ccw"]
    # FK converges to ‖Δq‖ ≤ 1e-12 m (pose error ~1e-12 m) and the file keeps 15 digits of ~1.5 m drive values
    # (~1e-15 m): the figures agree far below the 0.1 µm instrument resolution; 1e-10 m leaves margin
    assert ev.circular_deviation == pytest.approx(ref.circular_deviation, abs=1e-10)
    assert np.allclose(ev.centre_offset, ref.centre_offset, atol=1e-10)
    assert np.allclose(ev.harmonics.amplitude[:5], ref.harmonics.amplitude[:5], atol=1e-10)
    assert main(["ballbar", "analyse", str(path), "--start-pose", "0,300,-1000,0,0,0", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["runs"]["ccw"]["circular_deviation_G_um"] == pytest.approx(ref.circular_deviation * 1e6, abs=1e-4)
    assert main(["ballbar", "analyse", str(path)]) == 2
    assert "--start-pose" in capsys.readouterr().err
