"""``pkmstiff calibrate identify`` / ``check`` on a simulated ball-bar measurement file (issue 17 items 1–3)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pkmstiff import load_machine
from pkmstiff.calibration import default_plan, error_model, identifiability, simulate_readings
from pkmstiff.calibration.measurement_file import BallbarMeasurement, write_measurement
from pkmstiff.cli import main


def _run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def measurement(tmp_path_factory):
    """Felix's default hemisphere with 0.1 mm base-parameter errors and 0.2 µm noise, as a measurement CSV."""
    m = load_machine("felix")
    plan = default_plan(m, "ballbar")
    params = error_model(m, setup=plan.setup)
    base = params.indices(identifiability(m, params, plan).base_parameters)
    d = np.zeros(params.n)
    d[base] = np.random.default_rng(1).uniform(-1e-4, 1e-4, base.size)
    y = simulate_readings(m, params, d, plan)[:, 0] + np.random.default_rng(2).normal(0, 2e-7, plan.n_poses)
    st = plan.setup
    meas = BallbarMeasurement(bar_length=st.bar_length, fixed_ball=st.fixed_ball, ball_offset=st.target,
                              t=np.arange(plan.n_poses) * 0.004, reading=y - st.bar_length, poses=plan.poses,
                              machine="felix")
    path = tmp_path_factory.mktemp("meas") / "felix.csv"
    write_measurement(path, meas)
    return path


def test_identify_writes_a_calibrated_machine_that_check_confirms(measurement, tmp_path, capsys):
    out = tmp_path / "felix_cal.toml"
    code, text, _ = _run(capsys, "calibrate", "identify", "felix", "--measurements", str(measurement), "--out",
                         str(out), "--json")
    assert code == 0
    rep = json.loads(text)
    assert rep["rank"] == 36 and rep["residual_after"]["rms_um"] < 0.3  # 0.2 µm noise left, errors removed
    assert rep["residual_before"]["rms_um"] > 20  # 0.1 mm errors seen by the bar
    assert rep["uncertainty"]["parameters"][0]["sigma_um"] > 0
    cal = load_machine(out)
    assert cal.calibration["method"] == "lm" and len(cal.calibration["measurement_sha256"]) == 64
    code, text, _ = _run(capsys, "calibrate", "check", str(out), "--measurements", str(measurement), "--json")
    chk = json.loads(text)
    # the calibrated machine reproduces the identification's residual (same model, same data: 1e-3 µm)
    assert abs(chk["rms_um"] - rep["residual_after"]["rms_um"]) < 1e-3
    code, text, _ = _run(capsys, "calibrate", "check", "felix", "--measurements", str(measurement), "--json")
    assert abs(json.loads(text)["rms_um"] - rep["residual_before"]["rms_um"]) < 1e-3
    code, text, _ = _run(capsys, "calibrate", "identify", "felix", "--measurements", str(measurement))
    assert code == 0 and "held fixed (gauge freedoms)" in text and "scaling" in text


@pytest.mark.parametrize("argv, needle", [
    (("hexaglide",), "felix"),  # measurement of another machine
    (("felix", "--instrument", "tracker"), "ballbar"),  # another instrument
])
def test_bad_input_is_one_line(measurement, capsys, argv, needle):
    code, _, err = _run(capsys, "calibrate", "identify", argv[0], "--measurements", str(measurement), *argv[1:])
    assert code == 2 and len(err.strip().splitlines()) == 1 and needle in err
