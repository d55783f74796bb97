"""Issue 26 items 1, 3, 6: synchronisation refined against the identified machine (``import --refine``), the
identifiability of backlash counted as the NC program runs the plan, ``check``/``report`` with ``--with backlash``."""

import json

import numpy as np
import pytest

from pkmstiff.calibration import error_model, identifiability
from pkmstiff.calibration.compensation import measurement_plan
from pkmstiff.calibration.identification import identify
from pkmstiff.calibration.nc_program import NCOptions, program_runs, programmed_plan
from pkmstiff.calibration.raw_import import import_raw, simulate_raw
from pkmstiff.calibration.sync_refine import import_refined
from pkmstiff.calibration.uncertainty import uncertainty
from pkmstiff.calibration.workflow import fit_diagnostics
from tests.test_calibration_raw_import import FEED, PLAN, _run, felix, plan, runs, truth  # noqa: F401 (fixtures)


def _fit(machine, params, meas):
    mp, y = measurement_plan(meas, "felix", "raw")
    res = identify(machine, params, mp, y)
    unc = uncertainty(res)
    return res, unc, fit_diagnostics(machine, meas, mp, params, res, unc)


@pytest.fixture(scope="module")
def noisy(felix, plan, truth):  # noqa: F811 (fixture imported above)
    """25 Hz, σ = 0.25 µm, a 10 mm ramp (7.5 samples): the feed-in ramp alone fixes t₀ to ≈ 0.1-1 ms."""
    params, delta = truth
    runs10 = program_runs(plan, NCOptions(feed=FEED, ramp=10e-3))
    raws = simulate_raw(felix, params, delta, plan, runs10, sample_rate=25, sigma=0.25e-6, resolution=0.1e-6, seed=11)
    true = np.random.default_rng(11).uniform(0.2, 1.2, len(runs10))  # simulate_raw's delays for this seed
    before = import_raw(felix, plan, runs10, raws)
    after = import_refined(felix, plan, runs10, raws, lambda m: _fit(felix, params, m)[0].delta, params)
    return params, delta, true, before, after


def test_refined_starts_are_closer_and_their_sigma_honest(noisy):
    _params, _delta, true, (_m0, s0), (_m1, s1, rounds) = noisy
    assert rounds <= 5
    e0 = np.abs([s.start for s in s0] - true)
    e1 = np.abs([s.start for s in s1] - true)
    sig = np.array([s.sigma for s in s1])
    # the whole run (ramps included) against the identified machine: σ 0.04 ms against the ramp fit's 0.1-1 ms
    assert np.all(sig < 0.5 * np.array([s.sigma for s in s0]))
    assert np.max(e1 / sig) < 4.0  # 4 starts: P(any |z| > 4) ≈ 3e-4
    assert np.max(e1) < np.max(e0)


def test_refined_import_fits_the_model_without_outliers(noisy, felix):  # noqa: F811 (fixture imported above)
    params, delta, _true, (_m0, _s0), (m1, _s1, _k) = noisy
    res, unc, diag = _fit(felix, params, m1)
    assert diag.consistent, diag.summary()
    assert not any(f.key == "outliers" and f.failed for f in diag.findings)
    # χ²/dof of ~2600 readings: consistent range 1 ± 4 √(2/dof) ≈ 1 ± 0.11
    chi = next(f for f in diag.findings if f.key == "chi2").statistic
    assert abs(chi - 1.0) < 0.11
    z = np.abs(res.delta[res.base] - delta[res.base]) / unc.sigma
    assert np.max(z) < 3.5 and np.mean(z ** 2) < 2.0
    bl = params.mask("backlash")
    assert np.max(np.abs(res.delta[bl] - delta[bl]) / unc.sigma[np.isin(res.base, np.flatnonzero(bl))]) < 3.5


def test_refinement_keeps_a_noise_free_import_exact(felix, plan, runs, truth):  # noqa: F811 (fixture imported above)
    params, delta = truth
    raws = simulate_raw(felix, params, delta, plan, runs, sample_rate=50, seed=4)
    meas, syncs, _k = import_refined(felix, plan, runs, raws, lambda m: _fit(felix, params, m)[0].delta, params,
                                     max_rounds=2)
    true = np.random.default_rng(4).uniform(0.2, 1.2, len(raws))
    assert np.max(np.abs([s.start for s in syncs] - true)) < 1e-6
    res = _fit(felix, params, meas)[0]
    assert np.max(np.abs(res.delta - delta)) <= 1e-9  # as the unrefined noise-free import


def test_identifiability_with_backlash_counts_both_directions(felix, plan):  # noqa: F811 (fixture imported above)
    both = programmed_plan(plan)
    assert both.n_poses == 2 * plan.n_poses + 2  # each run of the closed circle ends at its first point
    params = error_model(felix, setup=plan.setup, setup_blocks=("backlash",))
    one = identifiability(felix, params, plan)
    two = identifiability(felix, params, both)
    assert two.rank >= one.rank
    bl = params.mask("backlash")
    # one direction only: a drive reverses only where its path turns; both directions: every drive is seen moving
    # both ways at the same poses, which separates its backlash from its offset
    assert sum("backlash" in b for b in two.base_parameters) == int(bl.sum())


def test_identifiability_command_line_runs_the_program(capsys):
    code, out, _ = _run(capsys, "calibrate", "identifiability", "felix", "--instrument", "ballbar", "--with",
                        "backlash", "--json")
    rep = json.loads(out)
    assert code == 0 and rep["plan"]["runs"] == "as programmed"
    code, out, _ = _run(capsys, "calibrate", "identifiability", "felix", "--instrument", "ballbar", "--json")
    assert json.loads(out)["plan"]["runs"] == "as given" and json.loads(out)["plan"]["n_poses"] * 2 == \
        rep["plan"]["n_poses"]


def test_check_and_report_with_backlash(tmp_path, capsys):
    plan_file = tmp_path / "plan.toml"
    plan_file.write_text(PLAN)
    errors = tmp_path / "errors.toml"
    errors.write_text('[errors]\n"chain1.strut_offset" = "30 um"\n"chain2.backlash" = "40 um"\n'
                      '"chain5.backlash" = "25 um"\n')
    raw = tmp_path / "raw"
    code, _, _ = _run(capsys, "calibrate", "simulate", "felix", "--plan", plan_file, "--errors", errors, "--feed", 2000,
                      "--ramp", 5, "--sample-rate", 50, "--raw", raw, "--seed", 1, "--noise", "none", "--no-quantise")
    assert code == 0
    csv = tmp_path / "m.csv"
    code, out, _ = _run(capsys, "calibrate", "import", "felix", *sorted(raw.glob("run*.txt")), "--plan", plan_file,
                        "--feed", 2000, "--ramp", 5, "--out", csv, "--refine", "--with", "backlash")
    assert code == 0 and "refined" in out
    cal = tmp_path / "cal.toml"
    code, _, err = _run(capsys, "calibrate", "identify", "felix", "--measurements", csv, "--with", "backlash",
                        "--out", cal)
    assert code == 0, err
    # check holds the machine fixed and fits set-up parameters only: backlash is a one-line error (gap, see report)
    code, out, err = _run(capsys, "calibrate", "check", cal, "--measurements", csv, "--with", "backlash", "--json")
    assert code == 2 and "backlash" in err and len(err.strip().splitlines()) == 1
    code, out, err = _run(capsys, "calibrate", "report", "felix", "--measurements", csv, "--with", "backlash",
                          "--out", tmp_path / "rep", "--json")
    assert code == 0, err
    text = (tmp_path / "rep" / "report.md").read_text()
    assert "chain2.backlash" in text and "chain5.backlash" in text
