"""The HTML comparison report of an optimisation run (``report.html`` + ``report.md``): the design comparison report of
``pkmstiff report`` (:func:`pkmstiff.report.build.build_report`) over the base design, the references and the
optimised designs (machine files that extend the base), with the design's sections (maps on one colour scale),
points and workspace, preceded by an "Optimisation" section: the objectives and constraints of every compared
design as the run measured them (% of the base design), the Pareto front or bar comparison and the convergence."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pkmstiff.optimise.compare import Compared
from pkmstiff.optimise.design import Design, PointMeasure, SectionMeasure, WorkspaceMeasure
from pkmstiff.optimise.engine import OptimisationResult

__all__ = ["comparison_spec", "write_comparison_report"]


def _variant(c: Compared, options: tuple[str, ...], request: Any) -> Any:
    from pkmstiff.machine.variants import split_machine_spec
    from pkmstiff.report.spec import Variant

    machine, opts = split_machine_spec(c.machine)
    if c.kind == "optimised":
        opts = list(options)  # a front design's file extends the base without its options
    what = {"base": "The base design.", "reference": "A reference design of the design file.",
            "optimised": "An optimised design (a machine file extending the base):"}[c.kind]
    return Variant(c.name, machine, tuple(opts), description=f"{what} {c.note}".strip(),
                   neglect_spindle=bool(getattr(request, "neglect_spindle", False)),
                   skip_checks=tuple(getattr(request, "skip_checks", ())))


def comparison_spec(design: Design, compared: list[Compared]) -> Any:
    """The :class:`~pkmstiff.report.spec.ReportSpec` comparing ``compared`` on the design's sections (one per
    distinct section request, with the statistics the design asks for), points and workspace."""
    from pkmstiff.machine.variants import split_machine_spec
    from pkmstiff.report.spec import PointSpec, ReportSpec, SectionSpec, WorkspaceSpec

    measures = design.measures()
    sections: dict[Any, tuple[set[str], set[str]]] = {}
    points, workspace, first = [], None, None
    for m in measures:
        if isinstance(m, SectionMeasure):
            qs, stats = sections.setdefault(m.request, (set(), set()))
            qs.add(m.quantity)
            stats.add({"q05": "p5"}.get(m.statistic, m.statistic))
            first = first or m.request
        elif isinstance(m, PointMeasure):
            req = m.evaluation.request()
            points.append(PointSpec(tuple(req.pose), tuple(req.quantities), req.tool_length, m.name))
            first = first or req
        elif isinstance(m, WorkspaceMeasure) and workspace is None:
            req = m.evaluation.request()
            workspace = WorkspaceSpec(req.resolution, req.box, req.requirements, req.methods, figures=False,
                                      orientation=req.orientation)
            first = first or req
    order = ("min", "p5", "mean", "max", "area")
    specs = tuple(SectionSpec(r.plane, r.at, r.u_range, r.v_range, r.step, tuple(sorted(qs)),
                              tuple(s for s in order if s in stats), maps=True, tool_length=r.tool_length,
                              orientation=r.orientation,
                              range_text=f"{r.plane[0]} = {1e3 * r.u_range[0]:g}..{1e3 * r.u_range[1]:g} mm, "
                                         f"{r.plane[1]} = {1e3 * r.v_range[0]:g}..{1e3 * r.v_range[1]:g} mm")
                  for r, (qs, stats) in sections.items())
    _, base_opts = split_machine_spec(design.machine)
    variants = tuple(_variant(c, tuple(base_opts), first) for c in compared)
    return ReportSpec(f"Optimisation: {Path(design.source).stem}", variants, specs, workspace, tuple(points),
                      baseline="base", frame=getattr(first, "frame", "machine"), source=design.source,
                      summary=f"The base design, the design file's references and the optimised designs of "
                              f"{Path(design.source).name} compared on the design's sections, points and workspace.")


def _optimisation_section(report: Any, res: OptimisationResult, compared: list[Compared],
                          figures: dict[str, Path]) -> None:
    from pkmstiff.report.model import Figure, Table

    design = res.design
    names = [c.name for c in compared]
    table = Table("Objectives and constraints of the compared designs (as measured by the run)", names,
                  baseline="base", digits=4)
    for o in design.objectives:
        table.add(f"objective: {o.measure.name} ({o.sense})", o.measure.unit, [_num(c, o.measure.label)
                                                                                for c in compared])
    for k in design.constraints:
        bounds = " and ".join(t for t in (None if k.lower is None else f">= {k.lower:g}",
                                          None if k.upper is None else f"<= {k.upper:g}") if t)
        table.add(f"constraint: {k.measure.name} {bounds}", k.measure.unit, [_num(c, k.measure.label)
                                                                              for c in compared])
    failed = [f"- {c.name}: {c.error}" for c in compared if c.error]
    front = "the best design" if len(design.objectives) == 1 else f"{len(res.front)} designs on the Pareto front"
    text = (f"{len(res.history)} evaluations ({res.evaluated} run) with {res.algorithm}, seed "
            f"{res.meta.get('seed')}: {front}. The compared designs: base (the design file's machine), the "
            f"references of the design file, and the optimised designs (the best, or at most four front designs "
            f"spread along the front; each is a machine file in designs/ that extends the base).")
    sec = report.section("Optimisation", text + ("\n\nDesigns that could not be evaluated:\n\n" + "\n".join(failed)
                                                 if failed else ""))
    sec.tables.append(table)
    what = "Pareto front" if len(design.objectives) > 1 else "Objective of base, references and best"
    sec.figures.append(Figure(figures["front"], f"{what} ({len(res.history)} evaluations; grey: candidates)"))
    sec.figures.append(Figure(figures["convergence"], "Convergence: every feasible candidate and the best so far"))
    report.sections.insert(0, report.sections.pop())


def _num(c: Compared, label: str) -> float | None:
    v = c.outputs.get(label)
    return None if c.error or not isinstance(v, (int, float)) or not math.isfinite(v) else float(v)


def write_comparison_report(res: OptimisationResult, compared: list[Compared], out: str | Path,
                            figures: dict[str, Path], jobs: int = 1,
                            figures_done: Callable[[], None] = lambda: None) -> dict[str, Path]:
    """Build the comparison report into ``out/report`` (``report.html``, ``report.md``, figures); ``figures_done()``
    returns once the files of ``figures`` are written (they may still be drawn elsewhere while the report builds)."""
    from pkmstiff.report.build import build_report
    from pkmstiff.report.render import run_info, write_report

    spec = comparison_spec(res.design, compared)
    folder = Path(out) / "report"
    report = build_report(spec, folder, n_jobs=jobs)
    _optimisation_section(report, res, compared, figures)
    report.settings = {"design file": res.design.source, "algorithm": res.algorithm,
                       "evaluations": len(res.history), **{k: v for k, v in res.meta.items()
                                                           if k in ("seed", "budget", "jobs")},
                       **report.settings}
    figures_done()
    return write_report(report, folder, run=run_info())
