"""Calibration report (issue 17 item 5): ``pkmstiff calibrate report`` — the plan, identifiability, the identified
parameters with σ, residuals before/after (statistics and ball-bar polar plots per circle), cross-validation on
further measurement files and the deflection contribution, rendered by :func:`pkmstiff.report.render.write_report`
to a self-contained HTML page and a Markdown twin like the design reports.

The numbers come from :func:`pkmstiff.calibration.workflow.run_calibration` (a typed
:class:`~pkmstiff.calibration.workflow.CalibrationRun`, SI); this module only turns them into figures and tables in
the report's units: :func:`calibration_report` builds the report, :func:`write_calibration_report` writes it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from pkmstiff.calibration.circles import PLANE_TOL, CircleRun
from pkmstiff.calibration.compensation import file_sha256
from pkmstiff.calibration.deflection import DeflectionSummary
from pkmstiff.calibration.diagnostics import ALPHA
from pkmstiff.calibration.identification import ResidualStats
from pkmstiff.calibration.workflow import CalibrationRun
from pkmstiff.io.atomic import atomic_path
from pkmstiff.report.model import Figure, Report, Table

__all__ = ["REPORT_FILES", "calibration_report", "deflection_section", "write_calibration_report"]

#: files ``calibrate report`` writes into its output directory (``--force`` to overwrite)
REPORT_FILES = ("report.html", "report.md")


# --------------------------------------------------------------------------------------------------- rendering
def deflection_section(report: Report, d: DeflectionSummary | None) -> None:
    """The "Deflection contribution" section (:class:`~pkmstiff.calibration.deflection.DeflectionSummary`): the
    figures in a table (µm, µrad, N, N m, m/s²), the per-parameter biases in a second one (µm / µrad), the notes as
    text. ``None``: the section says it was not computed."""
    sec = report.section("Deflection contribution")
    if d is None:
        sec.text = ("Not computed — run with --deflection gravity.\n\nThe elastic deflection of the machine under the "
                    "gravity of platform, spindle and struts biases a geometric calibration; with --deflection "
                    "gravity the structure model predicts the deflection at every measured pose, how much of the "
                    "readings it explains and how large the bias of each identified parameter would be.")
        return
    t = Table("Deflection at the measured poses", ["value"], digits=4)
    for label, unit, vec in (("gravity", "m/s²", d.gravity), ("load", "N", d.force), ("load (N m)", "N m", d.moment)):
        for ax, x in zip("xyz", vec):
            t.add(f"{label} {ax}", unit, [float(x)])
    t.add("n readings", "count", [float(d.n_readings)])
    t.add("rms reading", "µm", [d.rms_reading * 1e6])
    t.add("max reading", "µm", [d.max_reading * 1e6])
    t.add("tcp max", "µm", [d.tcp_max * 1e6])
    for ax, x in zip("xyz", d.tcp_mean):
        t.add(f"tcp mean {ax}", "µm", [float(x) * 1e6])
    t.add("tcp rotation max", "µrad", [d.tcp_rotation_max * 1e6])
    t.add("bias relative deviation", "–", [d.bias_relative_deviation])
    t.add("rms after corrected", "µm", [d.rms_after_corrected * 1e6])
    t.add("rms after uncorrected", "µm", [d.rms_after_uncorrected * 1e6])
    if d.rms_reading_angle is not None:
        t.add("rms reading (µrad)", "µrad", [d.rms_reading_angle * 1e6])
        t.add("max reading (µrad)", "µrad", [d.max_reading_angle * 1e6])
    sec.text = "\n\n".join(["Deflection of the structure model at the measured poses and its effect on the "
                             "identified parameters (bias = identified without − with the deflection subtracted).",
                             "model: gravity"] + [f"notes: {x}" for x in d.notes])
    sec.tables.append(t)
    if d.bias:
        b = Table("bias", ["predicted", "actual"], digits=4)
        for e in d.bias:
            b.add(e.name, "µm" if e.unit == "m" else "µrad", [e.predicted * 1e6, e.actual * 1e6])
        sec.tables.append(b)


def _fmt(v: float, digits: int = 4) -> str:
    from pkmstiff.report.render import format_value

    return format_value(v, digits)


def _value_unit(unit: str) -> tuple[float, str]:
    """Report units at the edge: lengths in mm, angles in µrad."""
    return (1e3, "mm") if unit == "m" else (1e6, "µrad")


def _save(fig, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100)
    return path


def _polar_pair(sec, circle: CircleRun, fig_dir: Path, stem: str, what: str) -> None:
    from pkmstiff.plots.ballbar import polar_deviation_figure

    for tag, ev, when in (("before", circle.before, "nominal model"), ("after", circle.after, "calibrated model")):
        title = f"{what}, {circle.label.split(':')[0]}, {tag} calibration: radial deviation [µm]"
        p = _save(polar_deviation_figure(ev, title=title), fig_dir / f"{stem}_{tag}.png")
        sec.figures.append(Figure(p, f"{what}, {circle.label}: residual of the {when} ({tag} calibration)"))


def _circle_rows(t: Table, circles: list[CircleRun], prefix: str = "") -> None:
    for c in circles:
        name = prefix + c.label.split(":")[0]
        for d in c.before.runs:
            if d in c.after.runs:
                t.add(f"{name} circular deviation G ({d})", "µm",
                      [c.before.runs[d].circular_deviation * 1e6, c.after.runs[d].circular_deviation * 1e6])
        if c.before.hysteresis is not None and c.after.hysteresis is not None:
            t.add(f"{name} hysteresis H", "µm", [c.before.hysteresis * 1e6, c.after.hysteresis * 1e6])


def _stats_rows(t: Table, b: ResidualStats, a: ResidualStats, prefix: str = "") -> None:
    for key, lab in (("rms", "RMS"), ("max_abs", "max |r|"), ("mean", "mean"), ("std", "std")):
        t.add(prefix + lab, "µm", [getattr(b, key) * 1e6, getattr(a, key) * 1e6])


def _plan_section(report: Report, run: CalibrationRun, fig_dir: Path) -> None:
    from pkmstiff.plots.calibration import path_figure

    meas, plan = run.meas, run.plan
    sec = report.section("Plan")
    P = run.ball_points()
    circle_of = np.full(len(P), -1)
    for k, c in enumerate(run.circles):
        circle_of[c.index] = k
    labels = ["other paths (hemisphere, arcs)"] + [c.label.split(":")[0] + f" ({c.before.plane.name})"
                                                   for c in run.circles]
    groups = circle_of + 1
    if not np.any(groups == 0):
        labels[0] = "(none)"
    balls = meas.fixed_ball
    if run.setups:  # several set-ups: the samples outside circles coloured by set-up, every fixed ball drawn
        k = len(run.setups)
        groups = np.where(circle_of >= 0, circle_of + k, 0)
        for j, s in enumerate(run.setups):
            groups[s.rows] = np.where(circle_of[s.rows] >= 0, groups[s.rows], j)
        labels = [f"set-up {j + 1}" for j in range(k)] + labels[1:]
        balls = np.array([s.meas.fixed_ball for s in run.setups])
    text = [f"Instrument: ball bar ({meas.device}), measurement file {run.file_names} "
            f"({meas.n_samples} samples over {float(meas.t[-1] - meas.t[0]):.1f} s)."]
    if run.plan_file is not None:
        kinds = "; ".join(f"{s.label} ({getattr(s, 'kind', 'path')}, {s.stop - s.start} poses)"
                          for s in run.plan_file.segments)
        text.append(f"Plan file {Path(run.plan_path).name}: '{run.plan_file.name}', {run.plan_file.n_poses} poses; "
                    f"paths: {kinds}.")
    else:
        text.append("No plan file given (--plan): the plan is the measurement's commanded poses.")
    text.append(f"Circles found in the measurement (runs of samples in one plane): {len(run.circles)}"
                + ("" if not run.circles else "; " + "; ".join(c.label for c in run.circles)) + ".")
    sec.text = "\n\n".join(text)
    t = Table("Measurement set-up and samples", ["value"], digits=6)
    t.add("samples", "count", [meas.n_samples])
    t.add("duration", "s", [float(meas.t[-1] - meas.t[0])])
    if meas.feed is not None and np.any(meas.feed > 0):
        t.add("feed (median of moving samples)", "mm/min", [float(np.median(meas.feed[meas.feed > 0])) * 60e3])
    t.add("bar length", "mm", [meas.bar_length * 1e3])
    for ax, v in zip("xyz", meas.fixed_ball):
        t.add(f"fixed ball {ax}", "mm", [float(v) * 1e3])
    for ax, v in zip("xyz", meas.ball_offset):
        t.add(f"ball offset {ax} (platform frame)", "mm", [float(v) * 1e3])
    t.add("instrument range (lower)", "mm", [meas.range[0] * 1e3])
    t.add("instrument range (upper)", "mm", [meas.range[1] * 1e3])
    t.add("resolution", "µm", [meas.resolution * 1e6])
    sec.tables.append(t)
    fig = path_figure(P, groups, labels, balls,
                      title=f"{run.machine.name}: moving-ball path of {run.file_names}")
    sec.figures.append(Figure(_save(fig, fig_dir / "path.png"), "Measured path of the moving ball (mm) with the "
                              "fixed ball; circles coloured separately"))


def _identifiability_section(report: Report, run: CalibrationRun) -> None:
    ident = run.ident
    sec = report.section("Identifiability")
    gauges = "\n".join(f"- {g.label()}" for g in ident.gauge_freedoms) or "none"
    sec.text = (f"Error model: {ident.n_parameters} parameters ({run.frame} joint coordinates). The measured poses "
                f"identify {ident.rank} of them (numerical rank from the singular-value gap, Szatmári §4.4.2); the "
                f"other {ident.null_dimension} directions are gauge freedoms, held fixed at zero in the "
                f"identification:\n\n{gauges}\n\nBase parameters ({len(ident.base_parameters)}): "
                + ", ".join(ident.base_parameters) + ".\n\nκ, the condition number used throughout this report, is "
                "σ_max/σ_min of the base-parameter columns of the scaled Jacobian (readings in m per parameter scale "
                "of 1 mm / 1 mrad); the observability indices O1–O5 refer to the same scaled Jacobian. Here it is "
                "evaluated at the nominal parameters; the summary gives it at the identified ones.")
    t = Table("Identifiability of the measured poses", ["value"], digits=5)
    t.add("parameters", "count", [ident.n_parameters])
    t.add("readings", "count", [ident.n_readings])
    t.add("rank (identified base parameters)", "count", [ident.rank])
    t.add("gauge freedoms (DOF held fixed)", "count", [ident.null_dimension])
    t.add("singular-value gap ratio", "–", [ident.gap_ratio if math.isfinite(ident.gap_ratio) else None])
    t.add("κ (base-parameter columns, nominal parameters)", "–",
          [ident.condition_number_base if math.isfinite(ident.condition_number_base) else None])
    t.add(f"largest orthogonality entry ({' / '.join(ident.max_orthogonality_pair)})", "–",
          [ident.max_orthogonality])
    for k, v in ident.observability.items():
        t.add(f"observability {k}", "scaled" if k != "O2" else "–", [v])
    sec.tables.append(t)


def _setups_section(report: Report, run: CalibrationRun) -> None:
    """Several set-ups (issue 26 item 3): each set-up's instrument placement, its residuals before and after the
    joint identification, and what it would identify alone against the stacked set-ups (the identifiability
    gain)."""
    parts, ident = run.setups, run.ident
    best = max(s.ident.rank for s in parts)
    sec = report.section("Set-ups")
    sec.text = (f"{len(parts)} set-ups identified together: the machine's parameters once, the set-up parameters "
                f"(--with) per set-up. Alone, the best set-up identifies {best} parameters; together they "
                f"identify {ident.rank} of {ident.n_parameters} (gain {ident.rank - best}). The residuals are those "
                "of the joint identification, split by set-up.\n\n"
                + "\n".join(f"- set-up {k}: {Path(s.label).name}" for k, s in enumerate(parts, 1)))
    t = Table("Set-ups: placement, identifiability alone and residuals of the joint fit",
              [f"set-up {k}" for k in range(1, len(parts) + 1)] + ["together"], digits=5)
    t.add("readings", "count", [s.rows.stop - s.rows.start for s in parts] + [run.res.n_readings])
    t.add("bar length", "mm", [s.meas.bar_length * 1e3 for s in parts] + [None])
    for j, ax in enumerate("xyz"):
        t.add(f"fixed ball {ax}", "mm", [float(s.meas.fixed_ball[j]) * 1e3 for s in parts] + [None])
    t.add("parameters", "count", [s.ident.n_parameters for s in parts] + [ident.n_parameters])
    t.add("rank (identified base parameters)", "count", [s.ident.rank for s in parts] + [ident.rank])
    t.add("κ (base-parameter columns, nominal parameters)", "–",
          [v if math.isfinite(v) else None for v in [s.ident.condition_number_base for s in parts]
           + [ident.condition_number_base]])
    for key, lab in (("residual_before", "residual RMS before"), ("residual_after", "residual RMS after")):
        r = getattr(run.res, key)
        t.add(lab, "µm", [float(np.sqrt(np.mean(r[s.rows] ** 2))) * 1e6 for s in parts]
              + [float(np.sqrt(np.mean(r ** 2))) * 1e6])
    sec.tables.append(t)


def _parameters_section(report: Report, run: CalibrationRun, fig_dir: Path) -> None:
    from pkmstiff.plots.calibration import parameter_figure

    res, unc = run.res, run.unc
    sec = report.section("Identified parameters")
    c, a, b = unc.max_correlation()
    sec.text = (f"Method {res.method} (loss {res.loss}), {res.iterations} model evaluations; scaling: {res.scaling}."
                f"\n\nσ from Σ = s²(JᵀJ)⁻¹ on the base parameters, s = {unc.s * 1e6:.4g} µm with {unc.dof} degrees "
                f"of freedom (Szatmári §5.4); the 95 % half-width is Student-t. Largest correlation: {c:.3f} "
                f"({a} / {b}). Lengths in mm, angles in µrad.")
    cols = ["identified", "σ", "95 % ±"]
    if unc.mc_sigma is not None:
        cols.append(f"σ Monte-Carlo ({unc.mc_runs} runs)")
    t = Table("Identified base parameters with standard deviation", cols, digits=6)
    half = unc.interval(0.95)
    for k, (nm, i) in enumerate(zip(res.base_names, res.base)):
        f, unit = _value_unit(run.params.units[i])
        row = [float(res.delta[i]) * f, float(unc.sigma[k]) * f, float(half[k]) * f]
        if unc.mc_sigma is not None:
            row.append(float(unc.mc_sigma[k]) * f)
        t.add(nm, unit, row)
    sec.tables.append(t)
    units = [run.params.units[i] for i in res.base]
    fig = parameter_figure(list(res.base_names), res.delta[res.base], unc.sigma, units)
    sec.figures.append(Figure(_save(fig, fig_dir / "parameters.png"), "Identified base parameters with ±2σ"))


def _residual_section(report: Report, run: CalibrationRun, fig_dir: Path) -> None:
    res = run.res
    sec = report.section("Residuals before and after")
    sec.text = ("Residuals r = measured − predicted reading of the identification measurement: before = the nominal "
                "machine, after = the calibrated machine (the same model, at the identified parameters). Polar "
                "plots: the ball-bar evaluation (Szatmári §4.5) of these residuals on every circle of the "
                "measurement, before and after; the radial scale of each plot is its own."
                + ("" if run.circles else "\n\nThe measurement holds no full circle (e.g. only a hemisphere): no "
                                          "polar plots."))
    t = Table(f"Residuals of {run.file_names} ({res.n_readings} readings)", ["before", "after"],
              digits=4)
    _stats_rows(t, run.run.before, run.run.after)
    _circle_rows(t, run.circles)
    sec.tables.append(t)
    for k, c in enumerate(run.circles, 1):
        _polar_pair(sec, c, fig_dir, f"circle{k}", "identification measurement")


def _ballbar_section(report: Report, run: CalibrationRun, fig_dir: Path, tolerance: float | None) -> None:
    """Per identification circle: the error sources of ball-bar software (classic circle error model,
    :func:`pkmstiff.calibration.ballbar_diagnosis.diagnose`) in the residuals before and after, with their share of
    G, and the diagnostics page of the residual before calibration (tolerance band when ``tolerance`` [m] is set)."""
    from pkmstiff.calibration.ballbar_diagnosis import diagnose
    from pkmstiff.plots.ballbar import diagnosis_figure

    if not run.circles:
        return
    sec = report.section("Ball-bar diagnostics")
    sec.text = ("The residual of each circle split into the error sources ball-bar software names (classic circle "
                "error model, Kakino et al. 1993; docs/theory/calibration.md): one least-squares fit of scale "
                "mismatch, squareness, servo mismatch, backlash, lateral play, reversal spikes (and cyclic error when "
                "the screw lead is known) with the centre offset and radius of each run. Share of G = peak-to-valley "
                "of the source alone / G of its run: the shares do not add up to 100 %. On a parallel machine the "
                "'axes' are the plane's axes, not drives: a source names the pattern, not the drive that causes it."
                + ("" if tolerance is None else f"\n\nTolerance on G: {tolerance * 1e6:g} µm."))
    feed = run.meas.feed
    for k, c in enumerate(run.circles, 1):
        f = None if feed is None else float(np.median(feed[c.index]))
        before = diagnose(c.before, tolerance=tolerance, feed=f)
        after = {s.name: s for s in diagnose(c.after, tolerance=tolerance, feed=f).sources}
        name = c.label.split(":")[0]
        t = Table(f"{name}: diagnosed error sources (± σ)", ["before", "σ before", "% of G before", "after",
                                                             "σ after", "% of G after"], digits=3)
        for s in before.sources:
            a = after.get(s.name)
            t.add(s.label, s.unit, [s.value, s.sigma, s.share * 100] + ([a.value, a.sigma, a.share * 100] if a
                                                                         else [None, None, None]))
        sec.tables.append(t)
        if before.passed:
            sec.text += f"\n\n{name} before calibration: " + ", ".join(
                f"{lab.upper()} G = {before.G[lab] * 1e6:.2f} µm {'≤' if ok else '>'} tolerance"
                for lab, ok in before.passed.items()) + "."
        fig = diagnosis_figure(c.before, before, title=f"{name}, before calibration: deviation from the "
                                                         "least-squares circle [µm]")
        sec.figures.append(Figure(_save(fig, fig_dir / f"circle{k}_diagnosis.png"),
                                  f"{c.label}: diagnostics of the residual before calibration"))


def _diagnostics_section(report: Report, run: CalibrationRun) -> None:
    """Every model-fit diagnostic (:class:`~pkmstiff.calibration.diagnostics.FitDiagnostics`) and the outliers."""
    d = run.run.diagnostics
    sec = report.section("Model-fit diagnostics")
    sigma = ", ".join(f"{v * 1e6:.4g} {'µm' if u == 'm' else 'µrad'}" for v, u in zip(d.sigma, d.reading_units))
    sec.text = (f"Does the model explain the readings? Each test below has a false-alarm probability of "
                f"{ALPHA:g} when the model and the instrument's stated noise (σ = {sigma}: its accuracy read as a "
                "2σ bound) are right (pkmstiff.calibration.diagnostics). Statistics: χ²/dof (χ² test), χ² of the "
                "added column (drift, set-up, CW/CCW), variance ratio F (runs), robust z (outliers). Result: "
                + d.summary() + ".")
    t = Table("Diagnostics", ["statistic", "limit", "failed (1 = yes)"], digits=4)
    for f in d.findings:
        t.add(f.title, "–", [f.statistic, f.threshold, float(f.failed)])
    sec.tables.append(t)
    if d.outliers:
        o = Table("Outliers", ["t (s)", "residual", "robust z"], digits=4)
        for row in d.outliers:
            key = "residual_um" if "residual_um" in row else "residual_urad"
            o.add(f"sample {row['sample']} ({row['reading']})", "µm" if key == "residual_um" else "µrad",
                  [row["t_s"], row[key], row["robust_z"]])
        sec.tables.append(o)


def _validation_section(report: Report, run: CalibrationRun, fig_dir: Path) -> None:
    sec = report.section("Cross-validation")
    if not run.validations:
        sec.text = ("No validation measurement given (--validate FILE ...): the calibrated machine is only checked "
                    "on the data it was identified from. Szatmári §5.4 validates on circles in other regions and "
                    "planes.")
        return
    sec.text = ("Residuals of the nominal and of the calibrated machine on measurements not used for the "
                "identification (the readings predicted for the drive values the nominal controller commanded, "
                "calibrate check). What remains is noise, errors along the gauge freedoms that the identification "
                "set-up cannot see but these set-ups can, and the uncertainty of the identified parameters.")
    t = Table("Residuals on the validation measurements", ["nominal", "calibrated"], digits=4)
    for j, v in enumerate(run.validations, 1):
        name = Path(v.path).name
        t.add(f"{name}: readings", "count", [v.before.size, v.after.size])
        _stats_rows(t, v.before_stats, v.after_stats, prefix=f"{name}: ")
        _circle_rows(t, v.circles, prefix=f"{name}: ")
    sec.tables.append(t)
    for j, v in enumerate(run.validations, 1):
        for k, c in enumerate(v.circles, 1):
            _polar_pair(sec, c, fig_dir, f"validation{j}_circle{k}", Path(v.path).name)


def calibration_report(run: CalibrationRun, out_dir: str | Path, tolerance: float | None = None) -> Report:
    """The report of a calibration run (figures written to ``out_dir/figures``); ``tolerance`` [m] on the circular
    deviation G of the ball-bar diagnostics."""
    out = Path(out_dir)
    fig_dir = out / "figures"
    res, unc = run.res, run.unc
    b, a = run.run.before, run.run.after
    rep = Report(f"Calibration of {run.machine.title or run.machine.name}")
    summary = [f"Machine {run.machine.name}, ball-bar measurement {run.file_names} "
               f"({res.n_readings} readings), method {res.method}: residual RMS {_fmt(b.rms * 1e6)} µm before, "
               f"{_fmt(a.rms * 1e6)} µm after; {res.rank} of {run.params.n} parameters identified "
               f"({run.params.n - res.rank} gauge DOF held fixed), κ = {_fmt(res.condition_number)} at the identified "
               f"parameters (κ: the report's one condition number, defined under Identifiability)."]
    if run.validations:
        summary.append("Cross-validation: " + "; ".join(
            f"{Path(v.path).name} RMS {_fmt(v.before_stats.rms * 1e6)} → "
            f"{_fmt(v.after_stats.rms * 1e6)} µm" for v in run.validations) + ".")
    units = np.array([run.params.units[i] for i in res.base])
    parts = []
    for u, f, name in (("m", 1e3, "mm (lengths)"), ("rad", 1e6, "µrad (angles)")):
        sel = unc.sigma[units == u]
        if sel.size:
            parts.append(f"{_fmt(float(sel.min()) * f)} … {_fmt(float(sel.max()) * f)} {name}")
    summary.append("σ of the identified parameters: " + ", ".join(parts) + ".")
    summary.append("Model fit: " + run.run.diagnostics.summary() + ".")
    rep.summary = "\n\n".join(summary)
    _plan_section(rep, run, fig_dir)
    _identifiability_section(rep, run)
    if run.setups:
        _setups_section(rep, run)
    _parameters_section(rep, run, fig_dir)
    _residual_section(rep, run, fig_dir)
    _ballbar_section(rep, run, fig_dir, tolerance)
    _diagnostics_section(rep, run)
    _validation_section(rep, run, fig_dir)
    deflection = run.deflection
    deflection_section(rep, deflection)
    rep.assumptions = {
        "uncertainty": "linearised at the solution: Σ = s²(JᵀJ)⁻¹, s² = ‖r‖²/(m − rank) (Szatmári §5.4)",
        "gauge freedoms": "directions no reading sees are held at zero; the identified values are one "
                          "representative of the equivalent parameter sets",
        "set-up parameters": "ball offset, fixed ball and bar offset belong to the measurement; the calibrated "
                             "machine carries only the chain geometry",
        "circles": f"a run of samples is a circle when its ball centres leave their plane by < {PLANE_TOL:g} of the "
                   "run's extent",
    }
    rep.settings = {"machine": run.machine.name, "measurements": str(run.measurements),
                    "measurement sha256": ", ".join(file_sha256(f) for f in (run.files or [run.measurements])), "plan": run.plan_path or "(none)",
                    "validate": [str(v.path) for v in run.validations], "method": res.method, "loss": res.loss,
                    "frame": run.frame, "with": run.with_ or "(none)", "deflection": "(not computed)" if deflection is None else "computed"}
    return rep


def write_calibration_report(run: CalibrationRun, out_dir: str | Path,
                             run_info: dict[str, str] | None = None, tolerance: float | None = None) -> dict[str, Path]:
    """Build and write ``report.html`` / ``report.md`` (+ ``figures/``) into ``out_dir``."""
    from pkmstiff.report.render import write_report

    rep = calibration_report(run, out_dir, tolerance)
    paths = write_report(rep, out_dir, run=run_info)
    paths["figures"] = [f.path for s in rep.sections for f in s.figures]
    return paths
