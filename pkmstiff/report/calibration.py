"""Calibration report (issue 17 item 5): ``pkmstiff calibrate report`` — the plan, identifiability, the identified
parameters with σ, residuals before/after (statistics and ball-bar polar plots per circle), cross-validation on
further measurement files and the deflection contribution, rendered by :func:`pkmstiff.report.render.write_report`
to a self-contained HTML page and a Markdown twin like the design reports.

Three steps, each usable on its own:

* :func:`run_calibration` — identification (:func:`~pkmstiff.calibration.identification.identify`), uncertainty
  (:func:`~pkmstiff.calibration.uncertainty.uncertainty`, Szatmári §5.4), identifiability of the measured poses
  (:func:`~pkmstiff.calibration.identifiability.identifiability`, Szatmári §4.4.2) and the residuals of the nominal
  and the calibrated machine on every validation file (:func:`~pkmstiff.calibration.compensation.check`); with
  ``deflection="gravity"`` the gravity deflection is subtracted first and its contribution recorded
  (:mod:`pkmstiff.calibration.deflection`);
* :func:`calibration_report` — figures and tables from those results (the deflection section from a plain dict).

Ball-bar circles are found in the measurement itself (:func:`circle_runs`): runs of consecutive samples with one
direction whose ball centres lie in one plane; the ccw and cw runs of one circle are evaluated together
(Szatmári §4.5, :func:`~pkmstiff.calibration.ballbar.evaluate_circular_test`) on the residuals before (nominal
model) and after (calibrated model) identification. Non-planar paths (a hemisphere) are shown in the path figure
and enter the statistics, but get no polar plot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from pkmstiff.calibration.ballbar import BallbarEvaluation, ball_positions, evaluate_circular_test, plane_frame
from pkmstiff.calibration.compensation import check, file_sha256, measurement_plan
from pkmstiff.calibration.deflection import deflection_analysis, subtract_deflection
from pkmstiff.calibration.identifiability import Identifiability, identifiability
from pkmstiff.calibration.identification import Identification, identify, residual_stats
from pkmstiff.calibration.measurement_file import BallbarMeasurement, read_measurement
from pkmstiff.calibration.parameters import ParameterSet
from pkmstiff.calibration.perturb import perturbed_machine
from pkmstiff.calibration.plans import Plan, read_plan
from pkmstiff.calibration.uncertainty import Uncertainty, uncertainty
from pkmstiff.errors import BallbarError, CalibrationInputError
from pkmstiff.io.atomic import atomic_path
from pkmstiff.machine import Machine
from pkmstiff.report.model import Figure, Report, Table

__all__ = ["CalibrationRun", "CircleRun", "Validation", "calibration_report", "circle_runs",
           "run_calibration", "write_calibration_report", "DEFLECTION_LOADS", "REPORT_FILES"]

#: files ``calibrate report`` writes into its output directory (``--force`` to overwrite)
REPORT_FILES = ("report.html", "report.md")
#: ``--deflection`` values ("none": the section says "not computed"), as ``calibrate identify --deflection``
DEFLECTION_LOADS = ("none", "gravity")

#: a run of samples is a circle when its ball centres leave their best-fit plane by less than this fraction of the
#: run's extent (its diameter): 1e-3 of the radius, the ball-bar evaluation's own planarity limit. The simulator
#: interpolates between plan nodes on the bar's sphere, which bends a circle that is not centred on the fixed ball
#: out of its plane by ~1.4e-4 of its extent; a hemisphere leaves it by ~0.3.
PLANE_TOL = 5e-4


# ------------------------------------------------------------------------------------------------------- circles
@dataclass(frozen=True)
class CircleRun:
    """One ball-bar circle of a measurement: sample indices (time order, both directions), its label, and the
    ball-bar evaluations of the residuals before and after identification."""

    label: str
    index: np.ndarray
    before: BallbarEvaluation
    after: BallbarEvaluation


def _pieces(P: np.ndarray, direction: np.ndarray | None) -> list[np.ndarray]:
    """Runs of consecutive samples: split where the direction label changes or the ball jumps (> 20 median steps)."""
    n = len(P)
    cut = np.zeros(n, dtype=bool)
    if direction is not None:
        d = np.asarray(direction).astype(str)
        cut[1:] |= d[1:] != d[:-1]
    step = np.linalg.norm(np.diff(P, axis=0), axis=1)
    if step.size:
        med = float(np.median(step[step > 0])) if np.any(step > 0) else 0.0
        cut[1:] |= step > 20 * med if med > 0 else False
    return np.split(np.arange(n), np.flatnonzero(cut))


def _plane(P: np.ndarray) -> tuple[np.ndarray, np.ndarray, float] | None:
    """(centroid, unit normal, largest distance from the plane) of points, or None for fewer than 8 points."""
    if len(P) < 8:
        return None
    c = P.mean(axis=0)
    _, _, Vt = np.linalg.svd(P - c, full_matrices=False)
    n = Vt[-1]
    return c, n, float(np.max(np.abs((P - c) @ n)))


def circle_runs(P: np.ndarray, direction: np.ndarray | None) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Circles of a ball-bar measurement: (sample indices, plane point, unit normal) per circle. Runs of consecutive
    samples (:func:`_pieces`) whose ball centres ``P`` (N, 3) lie in a plane (within :data:`PLANE_TOL` of their
    extent) are circles;
    consecutive planar runs in the same plane (e.g. ccw then cw) are one circle."""
    out: list[tuple[list[np.ndarray], np.ndarray, np.ndarray]] = []
    for idx in _pieces(P, direction):
        pl = _plane(P[idx])
        if pl is None:
            continue
        c, n, _ = pl
        size = float(np.max(np.ptp(P[idx], axis=0)))
        if pl[2] > PLANE_TOL * size:
            continue
        if out:
            idx0, c0, n0 = out[-1]
            if abs(abs(float(n @ n0)) - 1.0) < 1e-6 and abs(float((c - c0) @ n0)) < PLANE_TOL * size:
                out[-1] = (idx0 + [idx], c0, n0)
                continue
        out.append(([idx], c, n))
    return [(np.concatenate(parts), c, n) for parts, c, n in out]


def _ideal_circle(P: np.ndarray, fixed_ball: np.ndarray, bar_length: float, source: str) -> np.ndarray:
    """The samples' ball centres moved onto the exact circle of the bar (same in-plane angle): the sphere of radius
    ``bar_length`` about the fixed ball cut by the samples' plane. The polar plots then show the residuals alone,
    not the few µm by which a sampled path (chords between plan nodes) leaves the ideal circle."""
    frame = plane_frame(P, fixed_ball, "auto", source=source)
    h = float((frame.origin - np.asarray(fixed_ball, dtype=float)) @ frame.normal)
    R = math.sqrt(max(bar_length ** 2 - h * h, 0.0))
    uv = frame.coordinates(P)
    th = np.arctan2(uv[:, 1], uv[:, 0])
    return frame.origin + frame.to_space(R * np.c_[np.cos(th), np.sin(th)])


def _circles(P: np.ndarray, direction: np.ndarray | None, fixed_ball: np.ndarray, bar_length: float,
             before: np.ndarray, after: np.ndarray, source: str) -> list[CircleRun]:
    """Ball-bar evaluations of the residuals before/after on every circle found in the samples."""
    runs = []
    for k, (idx, _c, _n) in enumerate(circle_runs(P, direction), 1):
        d = None if direction is None else np.asarray(direction)[idx]
        try:
            Q = _ideal_circle(P[idx], fixed_ball, bar_length, source)
            ev0 = evaluate_circular_test(Q, before[idx], fixed_ball, bar_length, direction=d, source=source)
            ev1 = evaluate_circular_test(Q, after[idx], fixed_ball, bar_length, direction=d, source=source)
        except BallbarError:  # an arc, not a full circle (gaps): no circular-test figures
            continue
        centre = P[idx].mean(axis=0) * 1e3
        label = (f"circle {k}: {ev0.plane.name} plane, centre ({', '.join(f'{v:.0f}' for v in centre)}) mm, "
                 f"{idx.size} samples")
        runs.append(CircleRun(label, idx, ev0, ev1))
    return runs


# --------------------------------------------------------------------------------------------------- computation
@dataclass
class Validation:
    """Residuals of the nominal and the calibrated machine on one further measurement file (m)."""

    path: str
    before: np.ndarray
    after: np.ndarray
    circles: list[CircleRun] = field(default_factory=list)


@dataclass
class CalibrationRun:
    """Everything the report shows (SI): the measurement, its plan (commanded poses + set-up), the optional plan
    file, the identifiability of the measured poses, the identification, its uncertainty, the calibrated machine,
    the circles found, and the validations."""

    machine: Machine
    measurements: str
    meas: BallbarMeasurement
    plan: Plan
    measured: np.ndarray
    params: ParameterSet
    ident: Identifiability
    res: Identification
    unc: Uncertainty
    calibrated: Machine
    circles: list[CircleRun]
    validations: list[Validation]
    plan_file: Plan | None = None
    plan_path: str | None = None
    frame: str = "cartesian"
    deflection: dict | None = None  #: deflection contribution (``--deflection gravity``), else None


def _ball_points(meas: BallbarMeasurement, plan: Plan) -> np.ndarray:
    return ball_positions(plan.poses, meas.ball_offset)


def _ballbar_file(path: str) -> BallbarMeasurement:
    """A ball-bar measurement file; another instrument's file is a one-line error (the report's plan, circle and
    polar-plot parts are ball-bar specific)."""
    meas = read_measurement(path)
    kind = getattr(meas, "kind", "ballbar")
    if kind != "ballbar":
        raise CalibrationInputError(path, "instrument", "a ball-bar measurement file (calibrate report evaluates "
                                    "ball-bar circles; use calibrate identify / check for this file)", kind)
    return meas


def run_calibration(machine: Machine, measurements: str, *, plan_path: str | None = None,
                    validate: Sequence[str] = (), method: str = "lm", loss: str = "linear",
                    frame: str = "cartesian", monte_carlo: int = 0, deflection: str = "none") -> CalibrationRun:
    """Identify ``machine``'s base parameters from the ball-bar file ``measurements`` and check the result on every
    ``validate`` file (see the module docstring). ``plan_path`` (a plan file) is only described and drawn; the
    identification uses the commanded poses of the measurement.  ``deflection="gravity"`` does what
    ``calibrate identify/check --deflection gravity`` do: the predicted gravity deflection is subtracted from the
    readings before identification and validation, and the bias without it is recorded
    (:func:`pkmstiff.calibration.deflection.deflection_analysis`, issue 17 item 4)."""
    from pkmstiff.calibration import error_model

    plan_file = read_plan(plan_path) if plan_path else None
    if plan_file is not None and plan_file.instrument != "ballbar":
        raise CalibrationInputError(plan_path, "plan.instrument", "a ball-bar plan (the measurement is a ball-bar "
                                    "file)", plan_file.instrument)
    meas = _ballbar_file(measurements)
    plan, y = measurement_plan(meas, machine.name, measurements)
    vals = []
    for v in validate:  # read every file before the (slower) identification: bad input fails fast
        vm = _ballbar_file(v)
        vals.append((v, vm, *measurement_plan(vm, machine.name, v)))
    params = error_model(machine, frame=frame, setup=plan.setup)
    ident = identifiability(machine, params, plan)
    contribution = None
    if deflection == "gravity":
        analysis = deflection_analysis(machine, params, plan, y, method, loss=loss, source=measurements)
        res, contribution = analysis.corrected, analysis.to_dict()
    else:
        res = identify(machine, params, plan, y, method, loss=loss, source=measurements)
    unc = uncertainty(res, monte_carlo=monte_carlo)
    delta = res.delta.copy()
    delta[params.chain < 0] = 0.0  # set-up errors belong to the measurement, not to the machine (compensation.py)
    calibrated = perturbed_machine(machine, params, delta)
    P = _ball_points(meas, plan)
    circles = _circles(P, meas.direction, meas.fixed_ball, meas.bar_length, res.residual_before,
                       res.residual_after, measurements)
    validations = []
    for v, vm, vplan, vy in vals:
        y0 = y1 = vy
        if deflection == "gravity":  # each machine's own deflection at the poses it reaches
            y0, _ = subtract_deflection(machine, machine, vplan, vy)
            y1, _ = subtract_deflection(calibrated, machine, vplan, vy)
        r0 = check(machine, machine, vplan, y0).residual
        r1 = check(calibrated, machine, vplan, y1).residual
        validations.append(Validation(v, r0, r1, _circles(_ball_points(vm, vplan), vm.direction, vm.fixed_ball,
                                                          vm.bar_length, r0, r1, v)))
    return CalibrationRun(machine=machine, measurements=measurements, meas=meas, plan=plan, measured=y,
                          params=params, ident=ident, res=res, unc=unc, calibrated=calibrated, circles=circles,
                          validations=validations, plan_file=plan_file, plan_path=plan_path, frame=frame,
                          deflection=contribution)


# ------------------------------------------------------------------------------------------ deflection (hook)
# --------------------------------------------------------------------------------------------------- rendering
_SUFFIX_UNITS = (("_m_s2", "m/s²"), ("_n_m", "N m"), ("_um", "µm"), ("_urad", "µrad"), ("_mrad", "mrad"), ("_mm", "mm"),
                 ("_deg", "deg"), ("_rad", "rad"), ("_m", "m"), ("_n", "N"), ("_s", "s"), ("_percent", "%"),
                 ("_pct", "%"))  # longest first: "load_N_m" is N m, not m


def _key_unit(key: str) -> tuple[str, str]:
    """('rms reading', 'µm') for 'rms_reading_um': a key's label and the unit its suffix names ('–' if none)."""
    for suf, unit in _SUFFIX_UNITS:
        if key.lower().endswith(suf) and len(key) > len(suf):
            return key[: -len(suf)].replace("_", " "), unit
    return key.replace("_", " "), "–"


def _number(v: Any) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        return None
    return float(v)


def _param_rows(value: Any) -> list[tuple[str, dict]] | None:
    """Per-parameter entries of a deflection dict: a list of dicts with a 'name' or 'parameter', or a dict of
    dicts keyed by parameter name."""
    if isinstance(value, list) and value and all(isinstance(x, dict) for x in value):
        key = "name" if "name" in value[0] else "parameter" if "parameter" in value[0] else None
        if key is None:
            return None
        return [(str(x.get(key, "")), {k: v for k, v in x.items() if k != key}) for x in value]
    if isinstance(value, dict) and value and all(isinstance(x, dict) for x in value.values()):
        return [(str(k), x) for k, x in value.items()]
    return None


def _vector(value: Any) -> list[float] | None:
    """A short numeric vector (list/array of 2–6 numbers), e.g. a mean TCP displacement (x, y, z)."""
    if isinstance(value, (list, tuple, np.ndarray)) and 2 <= len(value) <= 6:
        nums = [_number(v) for v in value]
        if all(v is not None for v in nums):
            return nums  # type: ignore[return-value]
    return None


#: SI unit of a per-parameter entry ("unit": "m" | "rad") -> report unit and factor (bias values are small: µm, µrad)
_ENTRY_UNITS = {"m": ("µm", 1e6), "rad": ("µrad", 1e6)}


def _param_table(key: str, rows: list[tuple[str, dict]]) -> Table | None:
    """Table of per-parameter entries: columns = their numeric keys. Entries with ``"unit": "m"|"rad"`` hold SI
    values (shown in µm / µrad); otherwise the unit comes from the column keys' suffixes (one unit for the table)."""
    cols: list[str] = []
    for _, entry in rows:
        cols += [c for c, v in entry.items() if c != "unit" and _number(v) is not None and c not in cols]
    if not cols:
        return None
    suffix_units = {_key_unit(c)[1] for c in cols}
    common = suffix_units.pop() if len(suffix_units) == 1 else "see column"
    labels = [_key_unit(c)[0] if common != "see column" else c for c in cols]
    t = Table(key.replace("_", " "), labels, digits=4)
    for name, entry in rows:
        unit, f = common, 1.0
        if entry.get("unit") in _ENTRY_UNITS and common == "–":
            unit, f = _ENTRY_UNITS[entry["unit"]]
        t.add(name, unit, [None if _number(entry.get(c)) is None else _number(entry.get(c)) * f for c in cols])
    return t


def deflection_section(report: Report, d: dict | None) -> None:
    """The "Deflection contribution" section from a plain dict
    (:func:`pkmstiff.calibration.deflection.deflection_contribution`): numbers and short
    vectors become a table (units from the key suffixes: ``_um`` µm, ``_urad`` µrad, ``_N`` N, ...; ``n_*`` counts),
    per-parameter entries (a list of ``{"name", "unit", "predicted", "actual"}``, SI) a second table in µm / µrad,
    strings and lists of strings (notes) the text. ``None``: the section says it was not computed."""
    sec = report.section("Deflection contribution")
    if d is None:
        sec.text = ("Not computed — run with --deflection gravity.\n\nThe elastic deflection of the machine under the "
                    "gravity of platform, spindle and struts biases a geometric calibration; with --deflection "
                    "gravity the structure model predicts the deflection at every measured pose, how much of the "
                    "readings it explains and how large the bias of each identified parameter would be.")
        return
    scal = Table("Deflection at the measured poses", ["value"], digits=4)
    texts = []
    tables = []
    used: set[str] = set()
    for k, v in d.items():
        num, vec, rows = _number(v), _vector(v), _param_rows(v)
        label, unit = _key_unit(k)
        if label in used:  # e.g. load_N and load_N_m: the unit tells them apart
            label = f"{label} ({unit})"
        used.add(label)
        if num is not None:
            if k.startswith("n_") and float(num).is_integer():
                unit = "count"
            scal.add(label, unit, [num])
        elif vec is not None:
            axes = "xyz" if len(vec) == 3 else [str(i + 1) for i in range(len(vec))]
            for ax, x in zip(axes, vec):
                scal.add(f"{label} {ax}", unit, [x])
        elif rows is not None:
            t = _param_table(k, rows)
            if t is not None:
                tables.append(t)
        elif isinstance(v, str):
            texts.append(f"{k.replace('_', ' ')}: {v}")
        elif isinstance(v, (list, tuple)) and all(isinstance(x, str) for x in v):
            texts += [f"{k.replace('_', ' ')}: {x}" for x in v]
    sec.text = "\n\n".join(["Deflection of the structure model at the measured poses and its effect on the "
                             "identified parameters (bias = identified without − with the deflection subtracted)."]
                            + texts)
    if scal.rows:
        sec.tables.append(scal)
    sec.tables.extend(tables)


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


def _stats_rows(t: Table, before: np.ndarray, after: np.ndarray, prefix: str = "") -> None:
    b, a = residual_stats(before), residual_stats(after)
    for key, lab in (("rms_um", "RMS"), ("max_abs_um", "max |r|"), ("mean_um", "mean"), ("std_um", "std")):
        t.add(prefix + lab, "µm", [b[key], a[key]])


def _plan_section(report: Report, run: CalibrationRun, fig_dir: Path) -> None:
    from pkmstiff.plots.calibration import path_figure

    meas, plan = run.meas, run.plan
    sec = report.section("Plan")
    P = _ball_points(meas, plan)
    circle_of = np.full(len(P), -1)
    for k, c in enumerate(run.circles):
        circle_of[c.index] = k
    labels = ["other paths (hemisphere, arcs)"] + [c.label.split(":")[0] + f" ({c.before.plane.name})"
                                                   for c in run.circles]
    groups = circle_of + 1
    if not np.any(groups == 0):
        labels[0] = "(none)"
    text = [f"Instrument: ball bar ({meas.instrument}), measurement file {Path(run.measurements).name} "
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
    fig = path_figure(P, groups, labels, meas.fixed_ball,
                      title=f"{run.machine.name}: moving-ball path of {Path(run.measurements).name}")
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
                + ", ".join(ident.base_parameters) + ".\n\nCondition numbers and observability indices O1–O5 "
                "refer to the scaled Jacobian (readings in m per parameter scale of 1 mm / 1 mrad).")
    t = Table("Identifiability of the measured poses", ["value"], digits=5)
    t.add("parameters", "count", [ident.n_parameters])
    t.add("readings", "count", [ident.n_readings])
    t.add("rank (identified base parameters)", "count", [ident.rank])
    t.add("gauge freedoms (DOF held fixed)", "count", [ident.null_dimension])
    t.add("singular-value gap ratio", "–", [ident.gap_ratio if math.isfinite(ident.gap_ratio) else None])
    t.add("condition number (identifiable part)", "–",
          [ident.condition_number if math.isfinite(ident.condition_number) else None])
    t.add("condition number (base-parameter columns)", "–",
          [ident.condition_number_base if math.isfinite(ident.condition_number_base) else None])
    t.add(f"largest orthogonality entry ({' / '.join(ident.max_orthogonality_pair)})", "–",
          [ident.max_orthogonality])
    for k, v in ident.observability.items():
        t.add(f"observability {k}", "scaled" if k != "O2" else "–", [v])
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
    t = Table(f"Residuals of {Path(run.measurements).name} ({res.n_readings} readings)", ["before", "after"],
              digits=4)
    _stats_rows(t, res.residual_before, res.residual_after)
    _circle_rows(t, run.circles)
    sec.tables.append(t)
    for k, c in enumerate(run.circles, 1):
        _polar_pair(sec, c, fig_dir, f"circle{k}", "identification measurement")


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
        _stats_rows(t, v.before, v.after, prefix=f"{name}: ")
        _circle_rows(t, v.circles, prefix=f"{name}: ")
    sec.tables.append(t)
    for j, v in enumerate(run.validations, 1):
        for k, c in enumerate(v.circles, 1):
            _polar_pair(sec, c, fig_dir, f"validation{j}_circle{k}", Path(v.path).name)


def calibration_report(run: CalibrationRun, out_dir: str | Path, deflection: dict | None = None) -> Report:
    """The report of a calibration run (figures written to ``out_dir/figures``); ``deflection`` is the plain dict
    of the deflection contribution or None (the section then says it was not computed)."""
    out = Path(out_dir)
    fig_dir = out / "figures"
    res, unc = run.res, run.unc
    b, a = residual_stats(res.residual_before), residual_stats(res.residual_after)
    rep = Report(f"Calibration of {run.machine.title or run.machine.name}")
    summary = [f"Machine {run.machine.name}, ball-bar measurement {Path(run.measurements).name} "
               f"({res.n_readings} readings), method {res.method}: residual RMS {_fmt(b['rms_um'])} µm before, "
               f"{_fmt(a['rms_um'])} µm after; {res.rank} of {run.params.n} parameters identified "
               f"({run.params.n - res.rank} gauge DOF held fixed), condition number {_fmt(res.condition_number)}."]
    if run.validations:
        summary.append("Cross-validation: " + "; ".join(
            f"{Path(v.path).name} RMS {_fmt(residual_stats(v.before)['rms_um'])} → "
            f"{_fmt(residual_stats(v.after)['rms_um'])} µm" for v in run.validations) + ".")
    units = np.array([run.params.units[i] for i in res.base])
    parts = []
    for u, f, name in (("m", 1e3, "mm (lengths)"), ("rad", 1e6, "µrad (angles)")):
        sel = unc.sigma[units == u]
        if sel.size:
            parts.append(f"{_fmt(float(sel.min()) * f)} … {_fmt(float(sel.max()) * f)} {name}")
    summary.append("σ of the identified parameters: " + ", ".join(parts) + ".")
    rep.summary = "\n\n".join(summary)
    _plan_section(rep, run, fig_dir)
    _identifiability_section(rep, run)
    _parameters_section(rep, run, fig_dir)
    _residual_section(rep, run, fig_dir)
    _validation_section(rep, run, fig_dir)
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
                    "measurement sha256": file_sha256(run.measurements), "plan": run.plan_path or "(none)",
                    "validate": [str(v.path) for v in run.validations], "method": res.method, "loss": res.loss,
                    "frame": run.frame, "deflection": "(not computed)" if deflection is None else "computed"}
    return rep


def write_calibration_report(run: CalibrationRun, out_dir: str | Path, deflection: dict | None = None,
                             run_info: dict[str, str] | None = None) -> dict[str, Path]:
    """Build and write ``report.html`` / ``report.md`` (+ ``figures/``) into ``out_dir``."""
    from pkmstiff.report.render import write_report

    rep = calibration_report(run, out_dir, deflection)
    paths = write_report(rep, out_dir, run=run_info)
    paths["figures"] = [f.path for s in rep.sections for f in s.figures]
    return paths
