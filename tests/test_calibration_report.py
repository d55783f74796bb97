"""``pkmstiff calibrate report`` (issue 17 item 5) on a small simulated Felix measurement: sections, numbers equal
to the identification's, well-formed HTML, figures; the deflection section from a plain dict; circle detection."""

from __future__ import annotations

import json
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from pkmstiff.cli import main

PLAN = """
[plan]
name = "small felix hemisphere + circle"
instrument = "ballbar"

[setup]
fixed_ball = ["0 mm", "0 mm", "0 mm"]
bar_length = "300 mm"
measuring_range = "15 mm"   # errors at the Tab. 5.2 scale (example:felix_errors.toml) need a long-stroke bar

[[paths]]
kind = "hemisphere"
points = 120
turns = 2
tilt = "20 deg"
torsion = "15 deg"

[[paths]]
kind = "circle"
plane = "XY"
centre = ["0 mm", "0 mm", "150 mm"]
radius = "259.808 mm"
points = 48
"""

VALIDATION = """
[plan]
name = "felix validation circle"
instrument = "ballbar"

[setup]
fixed_ball = ["100 mm", "0 mm", "100 mm"]
bar_length = "150 mm"
measuring_range = "15 mm"

[[paths]]
kind = "circle"
plane = "XZ"
points = 48
"""

SECTIONS = ("Plan", "Identifiability", "Identified parameters", "Residuals before and after", "Ball-bar diagnostics",
            "Model-fit diagnostics",
            "Cross-validation", "Deflection contribution")


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Identification and validation measurements of Felix with the example errors (≤ 1.75 mm) and QC10 noise."""
    d = tmp_path_factory.mktemp("calreport")
    (d / "plan.toml").write_text(PLAN)
    (d / "val.toml").write_text(VALIDATION)
    for plan, out in (("plan.toml", "meas.csv"), ("val.toml", "val.csv")):
        code = main(["calibrate", "simulate", "felix", "--plan", str(d / plan), "--errors", "example:felix_errors.toml",
                     "--seed", "1", "--feed", "3000", "--sample-rate", "5", "--out", str(d / out)])
        assert code == 0
    return d


@pytest.fixture(scope="module")
def report(files):
    out = files / "rep"
    code = main(["calibrate", "report", "felix", "--measurements", str(files / "meas.csv"), "--plan",
                 str(files / "plan.toml"), "--validate", str(files / "val.csv"), "--out", str(out),
                 "--tolerance", "20um"])
    assert code == 0
    return out


def test_report_has_every_section(report):
    md = (report / "report.md").read_text(encoding="utf-8")
    for s in SECTIONS:
        assert f"\n## {s}\n" in md, s
    assert "Not computed — run with --deflection gravity." in md
    assert "base frame rotation about the fixed-ball centre" in md  # gauge freedoms named
    assert "observability O5" in md and "condition number" in md


def test_ballbar_diagnostics_section_lists_the_sources_with_their_share(report):
    md = (report / "report.md").read_text(encoding="utf-8")
    sec = md.split("\n## Ball-bar diagnostics\n")[1].split("\n## ")[0]
    rows = _md_rows(sec)
    for label in ("scale mismatch", "squareness", "servo mismatch", "backlash X", "reversal spikes Y"):
        assert label in rows, (label, list(rows))
    assert "Tolerance on G: 20 µm." in sec and "tolerance." in sec
    assert "circle1_diagnosis.png" in sec


def _md_rows(md: str) -> dict[str, list[str]]:
    rows = {}
    for line in md.splitlines():
        if line.startswith("| ") and not line.startswith("| Metric"):
            cells = [c.strip() for c in line.strip("|").split(" | ")]
            rows[cells[0]] = cells[1:]
    return rows


def test_numbers_match_the_identification(files, report):
    from pkmstiff.cli.calibrate_identify import identify_report

    rep = identify_report("felix", str(files / "meas.csv"))
    rows = _md_rows((report / "report.md").read_text(encoding="utf-8"))
    sig = {p["name"]: p["sigma_um"] for p in rep["uncertainty"]["parameters"]}
    assert rep["identified"]
    for p in rep["identified"]:
        unit, value, sigma = rows[p["name"]][:3]
        assert unit == "mm"
        # the report prints 6 significant digits: relative rounding error ≤ 5e-6
        assert float(value) == pytest.approx(p["value_mm"], rel=1e-5)
        assert float(sigma) == pytest.approx(sig[p["name"]] * 1e-3, rel=1e-5)
    # 4 significant digits in the residual table: relative rounding error ≤ 5e-4
    assert float(rows["RMS"][1]) == pytest.approx(rep["residual_before"]["rms_um"], rel=1e-3)
    assert float(rows["RMS"][2]) == pytest.approx(rep["residual_after"]["rms_um"], rel=1e-3)
    assert rows["rank (identified base parameters)"][1] == str(rep["rank"])
    # the example errors (≤ 1.75 mm) are seen by the bar; QC10 noise (σ 0.25 µm) is what remains
    assert rep["residual_before"]["rms_um"] > 100 and rep["residual_after"]["rms_um"] < 0.5


def test_cross_validation_numbers_match_check(files, report):
    from pkmstiff.calibration.compensation import calibrated_machine_text  # noqa: F401 (the file check reads)
    from pkmstiff.cli.calibrate_identify import check_report, identify_report

    cal = files / "cal.toml"
    identify_report("felix", str(files / "meas.csv"), out=str(cal))
    after = check_report(str(cal), str(files / "val.csv"))["rms_um"]
    before = check_report("felix", str(files / "val.csv"))["rms_um"]
    rows = _md_rows((report / "report.md").read_text(encoding="utf-8"))
    nominal, calibrated = rows["val.csv: RMS"][1:3]
    # the report's calibrated machine is the in-memory twin of the written file (values printed to 9 digits in mm):
    # equal to the 4 digits shown
    assert float(nominal) == pytest.approx(before, rel=1e-3)
    assert float(calibrated) == pytest.approx(after, rel=1e-3)
    assert after < before / 10


class _Checker(HTMLParser):
    VOID = {"meta", "img", "br", "hr", "link", "input"}

    def __init__(self):
        super().__init__()
        self.stack, self.errors = [], []

    def handle_starttag(self, tag, attrs):
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.stack[-1:] or 'nothing'}")
        else:
            self.stack.pop()


def test_html_is_well_formed_and_self_contained(report):
    text = (report / "report.html").read_text(encoding="utf-8")
    c = _Checker()
    c.feed(text)
    c.close()
    assert not c.errors and not c.stack, (c.errors[:3], c.stack)
    assert text.count("<section") == len(SECTIONS) + 3  # + assumptions, settings, run
    assert text.count('src="data:image/png;base64,') == 7
    assert "<script" not in text


def test_figures_exist_and_are_pngs(report):
    md = (report / "report.md").read_text(encoding="utf-8")
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    # path, parameters, one circle before/after + its diagnostics page in the measurement, one in the validation file
    assert len(links) == 7
    for rel in links:
        data = (report / rel).read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 5000, rel


def test_existing_report_needs_force(files, report, capsys):
    before = (report / "report.md").stat().st_mtime_ns
    code, _, err = _run(capsys, "calibrate", "report", "felix", "--measurements", files / "meas.csv", "--out", report)
    assert code == 2 and "--force" in err and len(err.strip().splitlines()) == 1
    assert (report / "report.md").stat().st_mtime_ns == before


def _count_identifiability(monkeypatch) -> list:
    """Count the identifiability analyses of the workflow and of the identification."""
    import pkmstiff.calibration.identification as identification
    import pkmstiff.calibration.workflow as workflow

    calls = []
    real = workflow.identifiability

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(workflow, "identifiability", counted)
    monkeypatch.setattr(identification, "identifiability", counted)
    return calls


def test_workflow_computes_identifiability_once(files, monkeypatch):
    """One identifiability analysis per calibration run (the report shows it, the identification uses its base
    parameters), and the typed result carries the identification's numbers."""
    from pkmstiff.calibration.workflow import run_calibration
    from pkmstiff.machine import load_machine

    calls = _count_identifiability(monkeypatch)
    run = run_calibration(load_machine("felix"), str(files / "meas.csv"), validate=[str(files / "val.csv")])
    assert len(calls) == 1
    assert run.res.rank == run.ident.rank and run.run.after.rms < run.run.before.rms
    assert run.run.after.rms == pytest.approx(np.sqrt(np.mean(run.res.residual_after ** 2)), rel=1e-15)
    assert len(run.validations) == 1 and run.validations[0].after_stats.rms < run.validations[0].before_stats.rms


# ------------------------------------------------------------------------------------------------ deflection
def test_deflection_section_renders_the_typed_summary(tmp_path):
    """A :class:`~pkmstiff.calibration.deflection.DeflectionSummary` (SI) becomes tables in the report's units."""
    from pkmstiff.calibration.deflection import DeflectionSummary, ParameterBias
    from pkmstiff.report.calibration import deflection_section
    from pkmstiff.report.model import Report
    from pkmstiff.report.render import write_report

    rep = Report("t")
    deflection_section(rep, DeflectionSummary(
        gravity=np.array([0.0, 0.0, -9.81]), force=np.array([0.0, 0.0, -50.0]), moment=np.array([0.0, 0.0, 2.0]),
        n_readings=2000, rms_reading=1.25e-6, max_reading=3.5e-6, rms_reading_angle=None, max_reading_angle=None,
        tcp_max=13e-6, tcp_mean=np.array([0.5e-6, -0.25e-6, -12e-6]), tcp_rotation_max=4e-6,
        bias=(ParameterBias("chain1.strut_offset", "m", 2.0e-6, 2.04e-6),
              ParameterBias("chain1.guide_direction.t1", "rad", 1.5e-6, 1.5e-6)),
        bias_relative_deviation=0.012, rms_after_corrected=0.2e-6, rms_after_uncorrected=0.9e-6,
        notes=("readings corrected by the predicted deflection",)))
    deflection_section(rep, None)
    paths = write_report(rep, tmp_path, run={"date": "x"})
    md = paths["md"].read_text(encoding="utf-8")
    for row in ("| rms reading | µm | 1.250 |", "| max reading | µm | 3.500 |", "| n readings | count | 2000 |",
                "| gravity z | m/s² | -9.810 |", "| load z | N | -50.00 |", "| load (N m) z | N m | 2.000 |", "| tcp mean z | µm | -12.00 |",
                "| bias relative deviation | – | 0.01200 |", "| chain1.strut_offset | µm | 2.000 | 2.040 |",
                "| chain1.guide_direction.t1 | µrad | 1.500 | 1.500 |"):
        assert row in md, row
    assert "rms reading (µrad)" not in md  # no orientation readings
    assert "model: gravity" in md and "notes: readings corrected by the predicted deflection" in md
    assert "Not computed — run with --deflection gravity." in md


def test_deflection_gravity_subtracts_and_reports(tmp_path, capsys, monkeypatch):
    """``--deflection gravity`` on the Hexapod 6X (has stiffness data): the readings simulated with the gravity
    deflection are explained after identification (noise-free, so the residual is round-off: < 1 nm), the
    validation file is corrected the same way, and the section shows the contribution instead of "Not computed"."""
    from pkmstiff.calibration import default_plan
    from pkmstiff.calibration.planning import plan_toml
    from pkmstiff.machine import load_machine

    m = load_machine("hexapod_6x")
    plan = default_plan(m, "ballbar")
    (tmp_path / "plan.toml").write_text(plan_toml(plan, plan.name, "default"))
    (tmp_path / "err.toml").write_text('[errors]\n"chain2.strut_offset" = "0.3 mm"\n"chain5.base_joint.z" = "0.2 mm"\n')
    meas = tmp_path / "m.csv"
    assert _run(capsys, "calibrate", "simulate", "hexapod_6x", "--plan", tmp_path / "plan.toml", "--errors",
                tmp_path / "err.toml", "--noise", "none", "--no-quantise", "--sample-rate", "2", "--directions", "ccw",
                "--deflection", "gravity", "--out", meas)[0] == 0
    out = tmp_path / "rep"
    calls = _count_identifiability(monkeypatch)
    code, text, err = _run(capsys, "calibrate", "report", "hexapod_6x", "--measurements", meas, "--validate", meas,
                           "--out", out, "--deflection", "gravity", "--json")
    assert code == 0, err
    assert len(calls) == 1  # shared by the corrected identification, its refinements and the uncorrected one
    doc = json.loads(text)
    assert doc["rms_after_um"] < 1e-3 and doc["rms_before_um"] > 1.0
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "Not computed" not in md and "| rms reading | µm |" in md and "bias relative deviation" in md


def test_deflection_loads_match_the_library():
    from pkmstiff.cli.calibrate_report import DEFLECTION_LOADS as cli
    from pkmstiff.calibration.workflow import DEFLECTION_LOADS as lib

    assert cli == lib


def test_deflection_without_stiffness_data_is_one_line(files, tmp_path, capsys):
    """Felix has no stiffness data: --deflection gravity fails before the identification, nothing written."""
    out = tmp_path / "rep"
    code, _, err = _run(capsys, "calibrate", "report", "felix", "--measurements", files / "meas.csv", "--out", out,
                        "--deflection", "gravity")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--deflection" in err
    assert not out.exists()


# --------------------------------------------------------------------------------------------------- circles
def test_circle_runs_finds_planar_runs_and_merges_directions():
    from pkmstiff.calibration.circles import circle_runs

    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    xy = np.c_[0.15 * np.cos(t), 0.15 * np.sin(t), np.zeros_like(t)]  # XY circle, ccw then cw
    xz = np.c_[0.1 + 0.15 * np.cos(t), np.full_like(t, 0.3), 0.15 * np.sin(t)]  # XZ circle elsewhere
    helix = np.c_[0.3 * np.cos(3 * t), 0.3 * np.sin(3 * t), np.linspace(0, 0.2, t.size)]  # not planar
    P = np.vstack([helix, xy, xy[::-1], xz])
    d = np.array(["ccw"] * 200 + ["ccw"] * 200 + ["cw"] * 200 + ["ccw"] * 200)
    runs = circle_runs(P, d)
    assert [len(r[0]) for r in runs] == [400, 200]
    assert abs(abs(runs[0][2][2]) - 1) < 1e-12 and abs(abs(runs[1][2][1]) - 1) < 1e-12  # normals z and y


def test_example_files_resolve_and_their_plans_are_admissible():
    from pkmstiff import load_machine
    from pkmstiff.calibration import check_plan, read_plan
    from pkmstiff.calibration.examples import example_names, resolve
    from pkmstiff.errors import InputError

    names = example_names()
    assert {"felix_plan.toml", "felix_errors.toml", "hexaglide_plan.toml", "hexaglide_validation.toml"} <= set(names)
    for m in ("felix", "hexaglide"):
        machine = load_machine(m)
        for kind in ("plan", "validation"):
            check_plan(machine, read_plan(f"example:{m}_{kind}.toml"))  # raises if a pose is not admissible
    assert Path(resolve("example:felix_errors.toml")).is_file()
    assert resolve("example:felix_errors") == resolve("example:felix_errors.toml")  # the suffix may be left out
    assert resolve("plain.toml") == "plain.toml"
    with pytest.raises(InputError, match="example:felix_plan.toml"):
        resolve("example:nope.toml")


def test_report_is_valid_html_without_markdown_or_absolute_paths(report):
    # issue 28: html5lib parse, no leaked Markdown (the gauge list was "<p>- base frame rotation…<br>- …</p>"),
    # no absolute paths, assumptions once, one condition-number definition named where it appears
    from tests.report_checks import check_report

    html_text = (report / "report.html").read_text(encoding="utf-8")
    md = (report / "report.md").read_text(encoding="utf-8")
    check_report(html_text, md)
    assert "<li>base frame rotation" in html_text
    assert html_text.count("σ_max/σ_min") == 1 and "identifiable part" not in html_text  # defined once
    assert "κ (base-parameter columns, nominal parameters)" in html_text and "defined under Identifiability" in html_text
