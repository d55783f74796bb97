"""Set-up parameters on identify/check/report (issue 26 item 4) and model-fit diagnostics (issue 26 item 5), on
simulated ball-bar measurements of Felix (example plan and errors: 2000 samples, CCW then CW, 0.25 µm noise)."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

from pkmstiff.calibration.diagnostics import ALPHA, added_variable, diagnose
from pkmstiff.calibration.examples import resolve
from pkmstiff.calibration.measurement_file import read_measurement, write_measurement
from pkmstiff.cli import main


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def _simulate(out: Path, errors: str = "example:felix_errors.toml", *extra) -> Path:
    assert main(["calibrate", "simulate", "felix", "--plan", "example:felix_plan.toml", "--errors", errors, "--seed",
                 "1", "--feed", "2000", "--sample-rate", "5", "--out", str(out), *extra]) == 0
    return out


def _scaled(text: str, factor: float) -> str:
    return re.sub(r'"(-?[0-9.]+) (mm|mrad)"', lambda m: f'"{float(m.group(1)) * factor:.6f} {m.group(2)}"', text)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """clean: the example errors; offset: the same with a 10 µm bar-length offset the file does not state;
    small: the example errors / 20 (up to 88 µm), and from it the misfit cases of issue 26: reversed (the CW run's
    readings stored in CCW order), drift (+5 µm linear in time over the measurement), outlier (+50 µm at sample
    1001)."""
    d = tmp_path_factory.mktemp("fit")
    errors = resolve("example:felix_errors.toml").read_text(encoding="utf-8")
    (d / "offset.toml").write_text(errors.replace("[errors]", '[errors]\n"bar_offset" = "0.010 mm"'),
                                   encoding="utf-8")
    (d / "small.toml").write_text(_scaled(errors, 1 / 20), encoding="utf-8")
    out = {"dir": d, "clean": _simulate(d / "clean.csv"), "offset": _simulate(d / "offset.csv", str(d / "offset.toml")),
           "small": _simulate(d / "small.csv", str(d / "small.toml"))}
    m = read_measurement(out["small"])
    y = m.reading
    cw = np.flatnonzero(m.direction.astype(str) == "cw")
    a, b = cw[0], cw[0] + np.flatnonzero(np.diff(cw) != 1)[0] + 1  # the first CW run (samples a..b-1)
    reversed_ = y.copy()
    reversed_[a:b] = y[a:b][::-1]
    outlier = y.copy()
    outlier[1000] += 50e-6
    for name, reading in (("reversed", reversed_), ("drift", y + 5e-6 * (m.t - m.t[0]) / np.ptp(m.t)),
                          ("outlier", outlier)):
        out[name] = d / f"{name}.csv"
        write_measurement(out[name], dataclasses.replace(m, reading=reading))
    return out


def _identify(capsys, path, *extra) -> tuple[int, dict, str]:
    code, out, err = _run(capsys, "calibrate", "identify", "felix", "--measurements", path, "--json", *extra)
    return code, (json.loads(out) if out.strip() else {}), err


def _values(rep: dict) -> dict[str, float]:
    return {p["name"]: p.get("value_mm", p.get("value_mrad")) for p in rep["identified"]}


def _sigmas(rep: dict) -> dict[str, float]:  # in the unit of the value (mm, mrad)
    return {p["name"]: p.get("sigma_um", p.get("sigma_urad")) * 1e-3 for p in rep["uncertainty"]["parameters"]}


def test_bar_offset_biases_parameters_unless_identified(files, capsys):
    """A 10 µm bar offset the file does not state biases the base parameters by many σ; with ``--with bar-offset``
    they agree with the identification of the offset-free file (same noise draw) within 3 σ and the offset is
    found within 3 σ of 10 µm."""
    _, clean, _ = _identify(capsys, files["clean"])
    code, biased, _ = _identify(capsys, files["offset"])
    assert code == 4  # the misfit is detected (test_each_misfit_is_detected_and_named)
    code, fixed, _ = _identify(capsys, files["offset"], "--with", "bar-offset")
    assert code == 0
    ref, sig0 = _values(clean), _sigmas(biased)
    z0 = max(abs(v - ref[k]) / sig0[k] for k, v in _values(biased).items())
    err0 = max(abs(v - ref[k]) for k, v in _values(biased).items())
    assert z0 > 10 and err0 > 0.1  # measured: 34 σ, 0.27 mm
    vals, sig = _values(fixed), _sigmas(fixed)
    assert max(abs(v - ref[k]) / sig[k] for k, v in vals.items() if k in ref) < 3  # measured: 0.65 σ
    assert abs(vals["bar_offset"] - 0.010) < 3 * sig["bar_offset"]


def test_check_with_fits_the_setup_of_the_measurement(files, capsys, tmp_path):
    """The machine calibrated with ``--with bar-offset`` leaves the offset in the residual of a plain check; ``check
    --with bar-offset`` fits it to the measurement and the residual falls to the noise (0.25 µm)."""
    cal = tmp_path / "cal.toml"
    code, _, err = _run(capsys, "calibrate", "identify", "felix", "--measurements", files["offset"], "--with",
                        "bar-offset", "--out", cal)
    assert code == 0, err
    code, out, _ = _run(capsys, "calibrate", "check", cal, "--measurements", files["offset"], "--json")
    plain = json.loads(out)
    code, out, _ = _run(capsys, "calibrate", "check", cal, "--measurements", files["offset"], "--with",
                        "bar-offset", "--json")
    fitted = json.loads(out)
    assert plain["rms_um"] > 5  # the 10 µm offset, not in the machine
    assert fitted["rms_um"] < 0.3  # noise 0.25 µm + 0.1 µm quantisation
    (row,) = fitted["setup_fitted"]
    assert row["name"] == "bar_offset" and abs(row["value_mm"] - 0.010) < 2e-4


def test_with_token_of_another_instrument_is_one_line(files, capsys):
    code, _, err = _run(capsys, "calibrate", "check", "felix", "--measurements", files["clean"], "--with",
                        "target-offset")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "target-offset" in err


@pytest.mark.parametrize("case, key, needle", [
    ("reversed", "reversed-run", "run 2 (cw, samples 756-1510"),
    ("drift", "drift", "drift of r over the measurement +5"),
    ("offset", "setup:bar-offset", "identify with --with bar-offset"),
    ("outlier", "outliers", "first sample 1001"),
])
def test_each_misfit_is_detected_and_named(files, capsys, tmp_path, case, key, needle):
    """Each misfit of issue 26 makes identify exit 4 with one line naming the cause, first, and write nothing;
    --accept-misfit writes the calibrated machine and exits 0."""
    out = tmp_path / "cal.toml"
    code, rep, err = _identify(capsys, files[case], "--out", out)
    assert code == 4 and not out.exists()
    assert len(err.strip().splitlines()) == 1 and needle in err
    failed = [f for f in rep["diagnostics"]["findings"] if f["failed"] is True]
    assert failed and key in [f["key"] for f in failed]
    assert err.index(needle) < err.index("chi2: residual")  # the named cause before the symptom
    if case == "drift":
        (eff,) = next(f for f in failed if f["key"] == "drift")["effects"]
        assert abs(eff["value_um"] - 5.0) < 0.3  # the 5 µm drift, within the noise of a 2000-sample fit
    if case == "outlier":
        (o,) = rep["diagnostics"]["outliers"]
        assert o["sample"] == 1001 and abs(o["residual_um"] - 50) < 2  # the fit absorbs a little of it
    if case == "reversed":
        f = next(f for f in failed if f["key"] == "reversed-run")
        assert f["rms_um"] > 50 and f["rms_reversed_um"] < 0.3  # 0.25 µm noise once the run is put back
    code, _, err = _identify(capsys, files[case], "--out", out, "--accept-misfit")
    assert code == 0 and out.exists() and "accepted" in err


def test_a_consistent_fit_passes_every_diagnostic(files, capsys):
    code, rep, _ = _identify(capsys, files["small"])
    assert code == 0 and rep["diagnostics"]["consistent"], rep["diagnostics"]["summary"]
    keys = {f["key"] for f in rep["diagnostics"]["findings"]}
    assert {"chi2", "drift", "setup:bar-offset", "cw-ccw", "run", "outliers"} <= keys


def test_added_variable_recovers_an_effect_outside_the_span():
    """r = (I - P_J) C beta exactly: the test returns beta and ΔRSS = ‖r‖²/s²; a column in span(J) is not
    testable (q = 0)."""
    rng = np.random.default_rng(3)
    J = rng.normal(size=(200, 5))
    C = rng.normal(size=(200, 2))
    beta = np.array([0.3, -1.2])
    Q, _ = np.linalg.qr(J)
    r = C @ beta - Q @ (Q.T @ (C @ beta))
    stat, q, b, bias = added_variable(J, r, C, 1.0)
    assert q == 2 and np.allclose(b, beta, atol=1e-12) and np.isclose(stat, r @ r, rtol=1e-12)
    assert np.allclose(J @ bias, Q @ (Q.T @ (C @ beta)), atol=1e-10)  # J⁺ C β reproduces the absorbed part
    assert added_variable(J, r, J @ rng.normal(size=(5, 1)), 1.0)[1] == 0


def test_false_alarm_rate_of_a_correct_model():
    """A linear model with the stated noise: over 400 draws each test fails with probability ALPHA (1e-3); with
    ~5 tests per draw a handful of false alarms at most (expected 2; P(more than 8) < 1e-3)."""
    rng = np.random.default_rng(7)
    n, nb = 300, 6
    t = np.arange(n) * 0.2
    direction = np.where(np.arange(n) < n // 2, "ccw", "cw")
    J = rng.normal(size=(n, nb)) * 1e-3
    Q, _ = np.linalg.qr(J)
    alarms = 0
    for _ in range(400):
        e = rng.normal(0.0, 0.25e-6, n)
        r = e - Q @ (Q.T @ e)
        d = diagnose(J, r, np.array([0.25e-6]), np.ones(1), np.full(nb, 1e-6), reading_names=("r",),
                     reading_units=("m",), t=t, direction=direction)
        alarms += not d.consistent
    assert alarms <= 8, alarms
    assert ALPHA == 1e-3


def test_report_shows_every_diagnostic_and_the_outliers(files, capsys, tmp_path):
    code, out, err = _run(capsys, "calibrate", "report", "felix", "--measurements", files["outlier"], "--out",
                          tmp_path / "rep", "--json")
    assert code == 0, err
    rep = json.loads(out)
    md = (tmp_path / "rep" / "report.md").read_text(encoding="utf-8")
    assert "## Model-fit diagnostics" in md and "sample 1001 (r)" in md
    for f in rep["diagnostics"]["findings"]:
        assert f["title"] in md


def test_report_with_bar_offset_identifies_and_fits_it_on_validation(files, capsys, tmp_path):
    """``report --with bar-offset``: the offset is identified (the fit is consistent) and fitted anew on the
    validation file, whose residual then falls to the noise although the calibrated machine carries no set-up."""
    code, out, err = _run(capsys, "calibrate", "report", "felix", "--measurements", files["offset"], "--validate",
                          files["offset"], "--with", "bar-offset", "--out", tmp_path / "rep", "--json")
    assert code == 0, err
    rep = json.loads(out)
    assert rep["diagnostics"]["consistent"], rep["diagnostics"]["summary"]
    (v,) = rep["validation"]
    assert v["rms_calibrated_um"] < 0.3  # 0.25 µm noise + quantisation; without the fit the 10 µm offset stays
    assert "bar-offset" in (tmp_path / "rep" / "report.md").read_text(encoding="utf-8")  # in the settings


@pytest.mark.parametrize("kind", ["huber", "tukey"])
def test_robust_weights_remove_the_outlier_with_an_honest_sigma(files, capsys, kind):
    """``--robust``: the +50 µm reading gets a weight near 0 and is listed with it, the fit is consistent (exit 0),
    the parameters agree with those of the outlier-free file within 1 σ and σ is that file's within 10 % — while
    plain least squares inflates σ (s grows with the outlier) and fails the diagnostics."""
    _, small, _ = _identify(capsys, files["small"])
    code, plain, _ = _identify(capsys, files["outlier"])
    assert code == 4
    code, rob, err = _identify(capsys, files["outlier"], "--robust", kind)
    assert code == 0, err
    (o,) = rob["diagnostics"]["outliers"]
    assert o["sample"] == 1001 and o["weight"] < 0.02  # Huber: c ŝ / 50 µm ≈ 0.007; Tukey: 0
    assert rob["robust"] == kind and rob["down_weighted"] >= 1
    ref, sig = _values(small), _sigmas(small)
    # on the same noise an M-estimate differs from least squares by ≈ √(1/0.95 − 1) ≈ 0.23 σ RMS per parameter
    # (its 95 % efficiency): the largest of 36 stays below 1 σ (measured 0.53 Huber)
    z_rob = max(abs(v - ref[k]) / sig[k] for k, v in _values(rob).items())
    assert z_rob < 1.0 and z_rob < max(abs(v - ref[k]) / sig[k] for k, v in _values(plain).items())
    assert all(0.9 < _sigmas(rob)[k] / sig[k] < 1.1 for k in sig)  # the efficiency loss is a few per cent
    assert plain["uncertainty"]["s_um"] > 1.5 * small["uncertainty"]["s_um"]


def test_robust_covariance_is_honest_under_contamination():
    """Monte Carlo on a linear model with 2 % gross errors (20 σ): the spread of the IRLS estimates over 300 draws
    matches the σ of Huber's covariance within 15 % (300 draws: the spread's own relative error is ≈ 4 %), for
    both weight functions; plain s²(JᵀJ)⁻¹ of the same residuals overstates it by more than 2×."""
    from pkmstiff.calibration.identification import irls, robust_covariance
    from pkmstiff.calibration.uncertainty import covariance

    rng = np.random.default_rng(11)
    m, p = 400, 4
    J = rng.normal(size=(m, p))
    for kind in ("huber", "tukey"):
        est, sig, plain = [], [], []
        for _ in range(300):
            e = rng.normal(0.0, 1.0, m)
            bad = rng.random(m) < 0.02
            e[bad] += 20.0 * rng.choice([-1.0, 1.0], bad.sum())
            rw = np.ones(m)

            def set_w(v, rw=rw):
                rw[:] = v

            def solve(x, rw=rw, e=e):
                return np.linalg.lstsq(rw[:, None] * J, rw * (e - J @ x), rcond=None)[0] + x, 1

            x0 = np.linalg.lstsq(J, e, rcond=None)[0]
            x, _, scale, _ = irls(lambda x, e=e: e - J @ x, set_w, solve, x0, kind)
            est.append(x)
            sig.append(np.sqrt(np.diag(robust_covariance(J, e - J @ x, scale, kind)[0])))
            plain.append(np.sqrt(np.diag(covariance(J, e - J @ x0)[0])))
        ratio = np.std(est, axis=0, ddof=1) / np.mean(sig, axis=0)
        assert np.all(np.abs(ratio - 1.0) < 0.15), (kind, ratio)
        assert np.all(np.mean(plain, axis=0) / np.std(est, axis=0, ddof=1) > 2.0)


def test_check_runs_the_model_fit_diagnostics(files, capsys, tmp_path):
    """``calibrate check`` prints and returns the same diagnostics: a machine calibrated on the file fits it; the
    same machine on the file with an unstated 10 µm bar offset fails and names the offset (``check --with
    bar-offset`` then fits it and passes)."""
    cal = tmp_path / "cal.toml"
    assert _run(capsys, "calibrate", "identify", "felix", "--measurements", files["clean"], "--out", cal)[0] == 0
    code, out, _ = _run(capsys, "calibrate", "check", cal, "--measurements", files["clean"], "--json")
    assert code == 0 and json.loads(out)["diagnostics"]["consistent"]
    code, out, _ = _run(capsys, "calibrate", "check", cal, "--measurements", files["offset"])
    assert code == 0 and "model fit: INCONSISTENT" in out and "set-up parameter bar-offset not fitted" in out
    code, out, _ = _run(capsys, "calibrate", "check", cal, "--measurements", files["offset"], "--with", "bar-offset",
                        "--json")
    rep = json.loads(out)
    assert rep["diagnostics"]["consistent"], rep["diagnostics"]["summary"]
