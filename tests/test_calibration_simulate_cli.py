"""``pkmstiff calibrate simulate``: a measurement CSV the ball-bar evaluation reads, one-line errors for bad input."""

import numpy as np
import pytest

from pkmstiff.calibration.ballbar import evaluate_measurement
from pkmstiff.calibration.measurement_file import read_measurement
from pkmstiff.cli import main

PLAN = """
[plan]
name = "felix XY circle"
instrument = "ballbar"

[setup]
fixed_ball = ["0 mm", "0 mm", "0 mm"]
bar_length = "150 mm"

[[paths]]
kind = "circle"
plane = "XY"
points = 72
"""


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def _files(tmp_path, plan=PLAN, errors=None):
    p = tmp_path / "plan.toml"
    p.write_text(plan)
    e = tmp_path / "errors.toml"
    e.write_text(errors or '[errors]\n"bar_offset" = "4 um"\n"ball_offset.x" = "20 um"\n')
    return p, e


def test_simulated_csv_round_trips_into_the_ballbar_evaluation(tmp_path, capsys):
    p, e = _files(tmp_path)
    out = tmp_path / "m.csv"
    code, text, _ = _run(capsys, "calibrate", "simulate", "felix", "--plan", p, "--errors", e, "--seed", 3,
                         "--feed", 3000, "--out", out)
    assert code == 0 and "samples" in text
    meas = read_measurement(out)
    assert meas.machine == "felix" and meas.bar_length == pytest.approx(0.15, rel=1e-15)
    assert set(np.unique(meas.direction)) == {"ccw", "cw"}
    assert np.all(np.diff(meas.t) > 0)
    res = evaluate_measurement(meas)
    # bar offset 4 µm -> radius deviation 4 µm; noise σ = 0.25 µm and 0.1 µm quantisation over ~1100 samples per
    # run average to ≪ 0.1 µm; the ball offset x moves the ball by 20 µm with the platform orientation fixed, i.e.
    # a pure centre offset of 20 µm (A1), which the fit returns to 0.1 µm
    for run in res.runs.values():
        assert run.radius_deviation == pytest.approx(4e-6, abs=0.1e-6)
        assert np.hypot(*run.centre_offset) == pytest.approx(20e-6, abs=0.1e-6)


def test_same_seed_same_file(tmp_path, capsys):
    p, e = _files(tmp_path)
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    for f in (a, b):
        _run(capsys, "calibrate", "simulate", "felix", "--plan", p, "--errors", e, "--seed", 5, "--feed", 5000,
             "--out", f)
    assert a.read_text() == b.read_text()


def test_readings_outside_the_range_are_one_line_errors(tmp_path, capsys):
    p, e = _files(tmp_path, errors='[errors]\n"bar_offset" = "1.2 mm"\n')
    code, _, err = _run(capsys, "calibrate", "simulate", "felix", "--plan", p, "--errors", e, "--feed", 5000,
                        "--out", tmp_path / "m.csv")
    assert code == 2 and err.count("\n") == 1 and "outside the QC10 range [-1, 1] mm, first at sample 1" in err
    assert not (tmp_path / "m.csv").exists()
    code, _, _ = _run(capsys, "calibrate", "simulate", "felix", "--plan", p, "--errors", e, "--feed", 5000,
                      "--saturate", "--out", tmp_path / "m.csv")
    assert code == 0 and np.all(read_measurement(tmp_path / "m.csv").reading == pytest.approx(1e-3, abs=1e-15))


@pytest.mark.parametrize("plan,errors,needle", [
    (PLAN.replace('"0 mm", "0 mm", "0 mm"', '"0 mm", "0 mm", "2500 mm"'), None, "not admissible on felix"),
    (PLAN, '[errors]\n"chain9.strut_offset" = "1 um"\n', "chain9.strut_offset"),
    (PLAN, '[errors]\n"bar_offset" = "2 deg"\n', "bar_offset"),
    # a tracker plan is simulated now (tests/test_calibration_simulate_points.py); a ball-bar set-up error is not
    # one of its parameters
    ('[plan]\ninstrument = "tracker"\n[[paths]]\nkind = "poses"\npositions = [[0, 0, 0]]\n', None,
     "'bar_offset'"),
])
def test_bad_input_gives_one_line_errors(tmp_path, capsys, plan, errors, needle):
    p, e = _files(tmp_path, plan, errors)
    code, _, err = _run(capsys, "calibrate", "simulate", "felix", "--plan", p, "--errors", e, "--out",
                        tmp_path / "m.csv")
    assert code == (3 if "admissible" in needle else 2)  # 3: a plan the machine cannot reach
    assert err.count("\n") == 1 and needle in err and "Traceback" not in err


def test_bad_noise_option(tmp_path, capsys):
    p, _ = _files(tmp_path)
    code, _, err = _run(capsys, "calibrate", "simulate", "felix", "--plan", p, "--noise", "loud", "--out",
                        tmp_path / "m.csv")
    assert code == 2 and "--noise" in err and err.count("\n") == 1
