"""Evaluating a report spec for every variant and assembling the comparison report (``pkmstiff report``).

Every evaluation goes through the request model (:mod:`pkmstiff.evaluation.requests`,
:mod:`pkmstiff.workspace.requests`) and the one statistics function :func:`~pkmstiff.evaluation.requests.statistic`.
"""

from __future__ import annotations

import contextlib
import math
import re
import threading
import time
from concurrent.futures import Future
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from pkmstiff.admissibility.checks import checks_left_out, checks_without, left_out_text
from pkmstiff.errors import InputError
from pkmstiff.evaluation import parallel
from pkmstiff.evaluation.cost import (
    FIGURE_3D_BYTES,
    FIGURE_3D_LIBRARY_SECONDS,
    FIGURE_3D_SECONDS,
    PLOT_LIBRARY_SECONDS,
    Cost,
    total,
)
from pkmstiff.evaluation.quantities import get_quantity
from pkmstiff.evaluation.requests import STATISTICS, PointRequest, SectionRequest, statistic
from pkmstiff.evaluation.sections import SectionResult
from pkmstiff.io.atomic import atomic_open
from pkmstiff.machine.frames import frame_origin, frame_text
from pkmstiff.machine.model import Machine
from pkmstiff.report import tasks
from pkmstiff.report.model import Figure, Report, Table
from pkmstiff.report.spec import MACHINE_ROWS, PointSpec, ReportSpec, SectionSpec, Variant, fast_spec, load_spec
from pkmstiff.workspace.requests import WorkspaceRequest
from pkmstiff.workspace.translational import WorkspaceResult

__all__ = ["build_report", "check_evaluation", "comparison_labels", "report_plan", "run_spec", "spec_cost"]


def _load_variant(v: Variant) -> Machine:
    from pkmstiff.machine.variants import machine_with

    return machine_with(v.machine, v.overrides, v.options)


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "x"


def _section_label(sec: SectionSpec, q: str, stat: str, multi: bool) -> str:
    return f"{q} {STATISTICS[stat][0]}" + (f" ({sec.name})" if multi else "")


def _workspace_label(method: str) -> str:
    return f"workspace volume ({method.replace('_', ' ')})"


def _point_label(pt: PointSpec, q: str) -> str:
    return f"{q} at {pt.name}"


def comparison_labels(spec: ReportSpec) -> list[str]:
    """The row labels of the comparison table :func:`build_report` fills, in order, from the spec alone (the same
    label functions fill the table)."""
    multi = len(spec.sections) > 1
    return ([_workspace_label(m) for m in spec.workspace.methods] if spec.workspace is not None else []) + \
        [_section_label(sec, q, stat, multi) for sec in spec.sections for q in sec.quantities
         for stat in sec.statistics] + \
        [_point_label(pt, q) for pt in spec.points for q in pt.quantities] + \
        [MACHINE_ROWS[key][0] for key in spec.machine_rows]


def check_evaluation(spec: ReportSpec) -> None:
    """One line (:class:`InputError`) for an ``[[evaluation]]`` metric that is no row of the comparison table:
    raised before anything is evaluated."""
    labels = comparison_labels(spec)
    for i, c in enumerate(spec.evaluation):
        if c.metric not in labels:
            raise InputError(spec.source, f"evaluation[{i + 1}].metric",
                             f"a row label of the comparison table ({', '.join(repr(k) for k in labels)})", c.metric)


def _section_rows(sec: SectionSpec, results: list, table: Table, multi: bool) -> None:
    stats = [res.statistics() for res in results]
    for q in sec.quantities:
        unit = get_quantity(q).unit
        for stat in sec.statistics:
            vals = [statistic(st[q], stat) for st in stats]
            table.add(_section_label(sec, q, stat, multi), STATISTICS[stat][1] or unit,
                      [None if v != v else v for v in vals])


def _fmt_deg(o: Sequence[float]) -> str:
    return ", ".join(f"{math.degrees(a):g}" for a in o)


def _tool_mm(machine: Machine, tl: float | None) -> float:
    return 1e3 * float(machine.tool.length if tl is None else tl)


def build_report(spec: ReportSpec, out_dir: str | Path, *, fast: bool = False, n_jobs: int | None = None,
                 log: Callable[[str], None] | None = None, scheduler: Any = None,
                 machines: Sequence[Machine] | None = None) -> Report:
    """Evaluate a spec for every variant and assemble the report; figures are written to ``out_dir``.

    ``fast`` applies :func:`~pkmstiff.report.spec.fast_spec`; ``n_jobs`` (default: the spec's ``options.jobs``)
    local workers or ``scheduler`` (a Dask address or client) run the evaluations and figures by the
    :func:`report_plan` (:mod:`pkmstiff.report.tasks`; the numbers and files are the same). ``log`` receives one
    progress line per step. ``machines``: the variants' machines if already loaded (:func:`run_spec`).
    """
    log = log or (lambda msg: None)
    check_evaluation(spec)
    if fast:
        spec = fast_spec(spec)
    jobs = spec.jobs if n_jobs is None else n_jobs
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    machines = list(machines or [])
    for i, v in enumerate(spec.variants):
        if i == len(machines):
            machines.append(_load_variant(v))
        log(f"variant {v.name}: {machines[i].title}")
    pairs = list(zip(spec.variants, machines))

    report = Report(spec.title)
    report.summary = spec.summary
    base = f"; baseline: {spec.baseline}" if spec.baseline else ""
    variants_text = "\n\n".join(_variant_text(v, m) for v, m in pairs)
    frames = "; ".join(sorted({f"{v.name}: {frame_text(m, spec.frame)}" for v, m in pairs}))
    comparison = report.section("Comparison", f"Variants compared{base}.\n\n{variants_text}\n\n"
                                              f"Positions are given in the {spec.frame} frame ({frames}).")
    table = Table(spec.title if len(spec.title) < 80 else "Comparison of the variants", [v.name for v in spec.variants],
                  baseline=spec.baseline, digits=spec.digits)
    comparison.tables.append(table)
    notes: list[str] = []

    plan = report_plan(spec, jobs, scheduler)
    work = _Work(spec, pairs, tasks.Runner(plan, {"n_jobs": jobs, "scheduler": scheduler}), out, log)
    for pt in spec.points:  # here, while the workers evaluate
        _point_rows(pt, pairs, table, notes, spec.frame)
    ws_figs, map_sections = work.collect()
    # workspace volume first (as in Cobet Table 5.1), then sections, points, machine values
    point_rows, table.rows = table.rows, []
    if spec.workspace is not None:
        for meth in spec.workspace.methods:
            table.add(_workspace_label(meth), "m^3", [res.volumes.get(meth) for res in work.workspaces])
        notes[:0] = [f"Workspace of {v.name} touches the initial box and is cut there (enlarge box_mm)."
                     for v, res in zip(spec.variants, work.workspaces) if res.octree.touches_box]
    multi = len(spec.sections) > 1
    for sec, results in zip(spec.sections, work.sections):
        _section_rows(sec, results, table, multi)
    table.rows += point_rows
    for key in spec.machine_rows:
        label, unit, fn = MACHINE_ROWS[key]
        table.add(label, unit, [fn(m, v) for v, m in pairs])

    stats_note = ("Section statistics (min, mean, max) are taken over the admissible raster points of the plane "
                  "(unweighted); n/a = no admissible point.") if spec.sections else ""
    comparison.text += "\n\n" + "\n\n".join([t for t in [stats_note] + notes if t])
    for sec, figs in map_sections:
        s = report.section(f"Section maps: {sec.name}",
                           f"Quantities {', '.join(sec.quantities)} on the {sec.name} "
                           f"(raster {sec.step * 1e3:g} mm, {sec.range_text}); the colour scale of a quantity is "
                           f"the same for every variant.")
        s.figures.extend(figs)
    if ws_figs:
        s = report.section("Workspace", "Constant-orientation workspace of each variant (closed boundary surface) "
                                        "with the machine at a central pose.")
        s.figures.extend(ws_figs)

    if spec.evaluation:
        _weighted_section(report, spec, table)
    report.assumptions = dict(spec.assumptions)
    if spec.sections:
        report.assumptions.setdefault("report: section statistics",
                                      "min/mean/max over the admissible raster points, every point weighted equally")
    report.variant_assumptions = {v.name: dict(m.assumptions) for v, m in pairs}
    report.settings = _settings(spec, machines, fast, jobs)
    return report


def _weighted_section(report: Report, spec: ReportSpec, table: Table) -> None:
    """Weighted evaluation (pkmstiff.report.weighted): utilities per criterion, the score and rank of every
    variant, and how the ranking changes when one weight is set to 0 or doubled."""
    from pkmstiff.report import weighted

    rows = {r.label: r for r in table.rows}  # every metric is a row: check_evaluation ran before the evaluation
    crit = spec.evaluation
    x = np.array([[np.nan if v is None else v for v in rows[c.metric].values] for c in crit]).T
    w = np.array([c.weight for c in crit])
    better = np.array([c.higher_is_better for c in crit])
    u = weighted.utilities(x, better)
    score = weighted.scores(x, w, better)
    order = weighted.ranking(score)
    names = [v.name for v in spec.variants]
    t = Table("Weighted evaluation: utility per criterion (best variant 100, worst 0) and weighted score",
              names, digits=3)
    for j, c in enumerate(crit):
        t.add(f"{c.metric} (weight {c.weight:g}, {'higher' if c.higher_is_better else 'lower'} is better)", "pts",
              list(100.0 * u[:, j]))
    t.add("weighted score", "pts", list(score))
    t.add("rank", "count", [order.index(i) + 1 for i in range(len(names))])
    t.highlight = ("weighted score",)

    def text(rank: list[int]) -> str:
        return " > ".join(names[i] for i in rank)

    varied = weighted.sensitivity(x, w, better)
    lines = [f"- weight of {crit[j].metric} x{f:g}: {text(rank)} ({'unchanged' if rank == order else 'CHANGED'})"
             for j, f, rank in varied]
    stable = all(rank == order for _, _, rank in varied)
    sec = report.section("Weighted evaluation",
                         "Scoring rule: per criterion the best variant gets 100 points and the worst 0, linearly in "
                         "between (a missing value 0); the score is the weighted mean of these utilities with the "
                         "spec's weights ([[evaluation]]). Ranking: " + text(order) + ".\n\n"
                         "Sensitivity of the ranking to the weights (each weight in turn set to 0 and doubled): "
                         + ("the ranking does not change." if stable else "the ranking changes where marked.")
                         + "\n\n" + "\n".join(lines))
    sec.tables.append(t)


def _variant_text(v: Variant, m: Machine) -> str:
    overrides = (", overrides " + ", ".join(f"{k} = {val!r}" for k, val in v.overrides.items())) if v.overrides else ""
    ku = ", K_U neglected (platform and spindle rigid)" if v.neglect_spindle else ""
    ku += f", {left_out_text(v.skip_checks)}" if v.skip_checks else ""
    return (f"{v.name}: {m.title} ({m.name}{overrides}{ku}), tool length {_tool_mm(m, v.tool_length):g} mm, "
            f"orientation a, b, c = {_fmt_deg(v.orientation)} deg" + (f". {v.description}" if v.description else ""))


def report_plan(spec: ReportSpec, jobs: int, scheduler: Any = None) -> tasks.ReportPlan:
    """Where the evaluations and figures of ``spec`` (after ``--fast``) run (:mod:`pkmstiff.report.tasks`)."""
    n = len(spec.variants)
    ws = spec.workspace
    return tasks.report_plan(jobs, scheduler, n * ((ws is not None) + len(spec.sections)),
                             n * sum(len(sec.quantities) for sec in spec.sections if sec.maps),
                             n if ws is not None and ws.figures else 0)


class _Work:
    """A report's evaluations and figures, started by a :class:`~pkmstiff.report.tasks.Runner` and collected in the
    spec's order. A section finished for every variant sends its maps at once (a callback of its futures, also while
    this thread draws a workspace figure); a finished workspace gets its figure in this thread."""

    def __init__(self, spec: ReportSpec, pairs: list, runner: tasks.Runner, out: Path,
                 log: Callable[[str], None]) -> None:
        self.spec, self.pairs, self.runner, self.out, self.log = spec, pairs, runner, out, log
        if runner.plan.pool and runner.plan.maps:
            import pkmstiff.plots.section_maps  # noqa: F401  (before the pool forks: its workers inherit matplotlib)
        ws = spec.workspace
        self.sections: list[list[SectionResult] | None] = [None] * len(spec.sections)
        self.workspaces: list[WorkspaceResult | None] = [None] * (len(pairs) if ws is not None else 0)
        self._maps: list[list[tuple[Path, str, Future]]] = [[] for _ in spec.sections]
        self._ws_figures: list[Figure | None] = [None] * len(self.workspaces)
        self._section_futures: list[list[Future]] = []
        self._workspace_futures: list[Future] = []
        self._lock, self._changed, self._error = threading.Lock(), threading.Event(), None
        # the longest tasks first (a section outlasts a workspace at the usual steps), and the sections' maps queue
        # behind the workspaces while the last section runs; but the workspaces first where this process draws
        # their figures, so that it draws while the workers run
        starts = [self._start_sections, self._start_workspaces]
        try:
            for start in starts[::-1] if ws is not None and ws.figures else starts:
                start()
        except BaseException:
            self._cancel()
            raise

    def _start_sections(self) -> None:
        for k, sec in enumerate(self.spec.sections):
            futures = [self.runner.evaluate(_section_request(sec, v, self.spec.frame), m) for v, m in self.pairs]
            self._section_futures.append(futures)
            for f in futures:
                f.add_done_callback(lambda _, k=k: self._section_finished(k))

    def _start_workspaces(self) -> None:
        for v, m in self.pairs if self.spec.workspace is not None else []:
            self._workspace_futures.append(self.runner.evaluate(_workspace_request(self.spec, v), m,
                                                                self.spec.workspace.figures))
            self._workspace_futures[-1].add_done_callback(lambda _: self._changed.set())

    def _cancel(self) -> None:
        for f in [*self._workspace_futures, *(f for fs in self._section_futures for f in fs),
                  *(f for maps in self._maps for _, _, f in maps)]:
            f.cancel()

    def _section_finished(self, k: int) -> None:
        """Callback of section ``k``'s futures: once all are done, take the results and send the maps."""
        with self._lock:
            if self.sections[k] is None and all(f.done() for f in self._section_futures[k]):
                try:
                    self.sections[k] = self._section_done(k, self._section_futures[k])
                except BaseException as exc:  # raised in collect(), in the thread that waits
                    self._error = self._error or exc
        self._changed.set()

    def _section_done(self, k: int, futures: list[Future]) -> list[SectionResult]:
        sec, results = self.spec.sections[k], []
        for (v, m), f in zip(self.pairs, futures):
            res, seconds = self.runner.result(f)
            res.machine = f"{v.name} ({m.name})"  # figure titles name the variant
            if res.tool_length is None:
                res.tool_length = m.tool.length
            results.append(res)
            self.log(f"section {sec.name}, {v.name}: {int(res.ok.sum())} of {res.ok.size} points admissible "
                     f"({seconds:.1f} s)")
        for q in sec.quantities if sec.maps else ():
            clim = tasks.common_clim(results, q)  # one colour scale per quantity across the variants
            for (v, _), res in zip(self.pairs, results):
                path = self.out / "maps" / f"{k + 1}_{_slug(sec.plane)}_{_slug(q)}_{_slug(v.name)}.png"
                caption = (f"{v.name}: {get_quantity(q).label} [{res.units[q]}] on the {sec.name}; white = "
                           f"inadmissible, black line = admissible boundary")
                self._maps[k].append((path, caption, self.runner.map_png(res, q, clim)))
        return results

    def _workspace_finished(self) -> bool:
        """Take one finished workspace (and draw its figure); False when none is waiting."""
        for i, f in enumerate(self._workspace_futures):
            if self.workspaces[i] is None and f.done():
                break
        else:
            return False
        (v, m), ws = self.pairs[i], self.spec.workspace
        res, seconds = self.runner.result(f)
        self.workspaces[i] = res
        self.log(f"workspace {v.name}: {res.volume:.4f} m^3 ({seconds:.1f} s)")
        if ws.figures:
            from pkmstiff.plots.workspace import plot_workspace

            with parallel.meanwhile_work(time.process_time) if self.runner.plan.pool else contextlib.nullcontext():
                path = plot_workspace(res, m, self.out / "workspace" / f"{_slug(v.name)}.png")
            self._ws_figures[i] = Figure(path, f"{v.name}: workspace at a, b, c = "
                                               f"{_fmt_deg(_workspace_request(self.spec, v).orientation)} deg, "
                                               f"resolution {ws.resolution * 1e3:g} mm, V = {res.volume:.4g} m^3")
        return True

    def collect(self) -> tuple[list[Figure], list[tuple[SectionSpec, list[Figure]]]]:
        """Wait for every evaluation and map, write the maps; (workspace figures, (section, its maps) of the
        sections with maps)."""
        try:
            while True:
                if self._error is not None:
                    raise self._error
                if self._workspace_finished():
                    continue
                if all(x is not None for x in [*self.sections, *self.workspaces]):
                    break
                self._changed.wait()  # set after each change of state: a change before the clear is seen above
                self._changed.clear()
            maps = []
            for sec, figs in zip(self.spec.sections, self._maps):
                for path, _, f in figs:
                    with atomic_open(path, "wb") as fh:
                        fh.write(self.runner.result(f))
                if sec.maps:
                    maps.append((sec, [Figure(path, caption) for path, caption, _ in figs]))
        except BaseException:
            self._cancel()
            raise
        return [f for f in self._ws_figures if f is not None], maps


def _workspace_request(spec: ReportSpec, v: Variant) -> WorkspaceRequest:
    ws = spec.workspace
    ori = ws.orientation if ws.orientation is not None else v.orientation
    return WorkspaceRequest(ws.resolution, ws.box, ws.requirements, ori, ws.methods, frame=spec.frame,
                            neglect_spindle=v.neglect_spindle, skip_checks=v.skip_checks)


def _section_request(sec: SectionSpec, v: Variant, frame: str) -> SectionRequest:
    return SectionRequest(sec.plane, sec.at, sec.u_range, sec.v_range, sec.step, sec.quantities,
                          sec.orientation if sec.orientation is not None else v.orientation,
                          sec.tool_length if sec.tool_length is not None else v.tool_length,
                          frame=frame, neglect_spindle=v.neglect_spindle, skip_checks=v.skip_checks)


def spec_cost(spec: ReportSpec, fast: bool = False, jobs: int | None = None, scheduler: Any = None,
              machines: Sequence[Machine] | None = None) -> Cost:
    """The :class:`~pkmstiff.evaluation.cost.Cost` of :func:`build_report`: every variant's workspace (pilot octree,
    growth law) and sections (with their maps), one after another; the peak is this process's largest piece plus,
    where the evaluations run as whole tasks (:func:`report_plan` for ``jobs``/``scheduler``), those running at once
    in the other workers. ``machines``: the variants' machines if already loaded."""
    if fast:
        spec = fast_spec(spec)
    parts, peaks = [], [0.0]
    for v, m in zip(spec.variants, machines or [_load_variant(v) for v in spec.variants]):
        if spec.workspace is not None:
            c = _workspace_request(spec, v).cost(m)
            peaks.append(c.bytes)
            parts.append(c.plus(FIGURE_3D_SECONDS, FIGURE_3D_BYTES) if spec.workspace.figures else c)
        for sec in spec.sections:
            parts.append(_section_request(sec, v, spec.frame).cost(m, len(sec.quantities) if sec.maps else 0))
            peaks.append(parts[-1].bytes)
    what = (f"{len(spec.variants)} variant(s), {len(spec.sections)} section(s)"
            + (f", workspace at {spec.workspace.resolution * 1e3:g} mm" if spec.workspace is not None else ""))
    libraries = (PLOT_LIBRARY_SECONDS if any(sec.maps for sec in spec.sections) else 0.0) + (
        FIGURE_3D_LIBRARY_SECONDS if spec.workspace is not None and spec.workspace.figures else 0.0)
    out = total(parts, what, "the spec's step_mm / resolution_mm").plus(libraries)
    plan = report_plan(spec, spec.jobs if jobs is None else jobs, scheduler)
    return replace(out, unit="octree evaluations and raster points",
                   bytes=tasks.cost_bytes(out.bytes, max(peaks), plan))


def _point_rows(pt: PointSpec, pairs: list, table: Table, notes: list[str], frame: str = "machine") -> None:
    rows: dict[str, list[float | None]] = {q: [] for q in pt.quantities}
    for v, m in pairs:
        tl = pt.tool_length if pt.tool_length is not None else v.tool_length
        res = PointRequest(pt.pose, pt.quantities, tl, frame=frame, neglect_spindle=v.neglect_spindle,
                           skip_checks=v.skip_checks).evaluate(m)
        if not res.admissible:
            notes.append(f"{v.name} at {pt.name}: inadmissible ({'; '.join(res.failing)})")
        for q in pt.quantities:
            rows[q].append(res.values.get(q))
    for q in pt.quantities:
        table.add(_point_label(pt, q), get_quantity(q).unit, rows[q])


def _settings(spec: ReportSpec, machines: list[Machine], fast: bool, jobs: int) -> dict[str, Any]:
    s: dict[str, Any] = {"spec": spec.source, "fast": fast, "jobs": jobs, "frame": spec.frame}
    if spec.baseline:
        s["baseline"] = spec.baseline
    for v, m in zip(spec.variants, machines):
        s[f"variant {v.name}"] = {"machine": m.name, "file": m.path, "options": list(v.options),
                                  "overrides": dict(v.overrides), "tool_length_mm": _tool_mm(m, v.tool_length),
                                  "orientation_deg": [round(math.degrees(a), 9) for a in v.orientation],
                                  "neglect_spindle": v.neglect_spindle,
                                  "checks_left_out": checks_left_out(checks_without(v.skip_checks)),
                                  "frame_origin_mm": (frame_origin(m, spec.frame) * 1e3).tolist()}
    for k, sec in enumerate(spec.sections):
        s[f"section {k + 1}"] = {"plane": sec.name, "range_mm": sec.range_text, "step_mm": sec.step * 1e3,
                                 "quantities": list(sec.quantities), "statistics": list(sec.statistics),
                                 "tool_length_mm": None if sec.tool_length is None else sec.tool_length * 1e3,
                                 "orientation_deg": None if sec.orientation is None else
                                 [round(math.degrees(a), 9) for a in sec.orientation]}
    if spec.workspace is not None:
        ws = spec.workspace
        s["workspace"] = {"resolution_mm": ws.resolution * 1e3, "methods": list(ws.methods),
                          "requirements": list(ws.requirements),
                          "box_mm": None if ws.box is None else [1e3 * x for pair in zip(*ws.box) for x in pair],
                          "orientation_deg": None if ws.orientation is None else
                          [round(math.degrees(a), 9) for a in ws.orientation]}
    for k, pt in enumerate(spec.points):
        s[f"point {k + 1}"] = {"pose": pt.name, "quantities": list(pt.quantities),
                               "tool_length_mm": None if pt.tool_length is None else pt.tool_length * 1e3}
    return s


def run_spec(path: str | Path, out_dir: str | Path, *, fast: bool = False, n_jobs: int | None = None,
             log: Callable[[str], None] | None = None, scheduler: Any = None,
             check: Callable[[Cost, str], None] | None = None) -> dict[str, Path]:
    """Load a spec, build the report and write it (``report.html``, ``report.md``); returns their paths.
    ``check`` receives the :func:`spec_cost` and the text of the :func:`report_plan` before any work (and may
    refuse it by raising)."""
    from pkmstiff.report.render import run_info, write_report

    t0 = time.perf_counter()
    spec = load_spec(path)
    check_evaluation(spec)  # a bad [[evaluation]] metric: one line before the cost and any evaluation
    machines = None
    if check is not None:
        machines = [_load_variant(v) for v in spec.variants]
        jobs = spec.jobs if n_jobs is None else n_jobs
        check(spec_cost(spec, fast, jobs, scheduler, machines),
              report_plan(fast_spec(spec) if fast else spec, jobs, scheduler).text())
    report = build_report(spec, out_dir, fast=fast, n_jobs=n_jobs, log=log, scheduler=scheduler, machines=machines)
    info = run_info()
    info["run time"] = f"{time.perf_counter() - t0:.1f} s"
    return write_report(report, out_dir, run=info)
