"""What ``pkmstiff optimise`` writes into ``--out``: ``front.csv`` (the feasible non-dominated designs; one objective:
the best), ``history.csv`` (every evaluation), ``designs/design_NNN.toml`` (each front design as a machine file that
``extends`` the base), ``convergence.png``, ``front.png`` (the Pareto front with the base design and the references
marked, or their bar comparison for one objective), ``report/report.html`` (the comparison report,
:mod:`pkmstiff.optimise.report`) and ``summary.json``. Columns are named by the file rule
(:func:`pkmstiff.io.columns.label_column`: ``<name>_<unit>``); every file is written atomically."""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.io.atomic import atomic_write_text
from pkmstiff.io.columns import label_column
from pkmstiff.optimise.design import Design
from pkmstiff.optimise.engine import Candidate, OptimisationResult

__all__ = ["design_machine_toml", "write_outputs"]


def _labels(design: Design) -> list[str]:
    cols = [c for v in design.variables for c in v.columns()]
    return cols + [m.label for m in design.measures()]


def _row(design: Design, c: Candidate) -> list[Any]:
    vals: list[Any] = []
    for v, val in zip(design.variables, c.values):
        vals += list(val) if v.kind == "direction" else [val]
    return vals + [c.outputs.get(m.label, "") for m in design.measures()]


def _csv(design: Design, cands: list[Candidate], extra: dict[str, list[Any]]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(list(extra) + [label_column(c) for c in _labels(design)] + ["feasible", "error"])
    for i, c in enumerate(cands):
        w.writerow([col[i] for col in extra.values()] + _row(design, c) + [int(c.feasible(design)), c.error])
    return buf.getvalue()


def _toml_value(v: Any) -> str:
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, float):
        return repr(v)
    return json.dumps(v)  # str (TOML basic string), int, bool


def design_machine_toml(design: Design, c: Candidate, title: str) -> str:
    """A machine file that ``extends`` the base machine and sets the candidate's overrides (arrays of tables are
    merged element by element by the loader, so ``chains[3].x`` becomes the 3rd of as many ``[[chains]]`` tables)."""
    from pkmstiff.machine.variants import parse_override_path, raw_machine

    base, opts = design.machine.split(":", 1) if ":" in design.machine else (design.machine, "")
    raw, _, _ = raw_machine(design.machine)
    tree: dict[str, Any] = {}
    for path, value in c.overrides.items():
        node: Any = tree
        segs = parse_override_path(path)
        for k, (key, idx) in enumerate(segs):
            last = k == len(segs) - 1
            if idx is None:
                if last:
                    node[key] = value
                else:
                    node = node.setdefault(key, {})
                continue
            n = len(raw.get(key, [])) if node is tree else len(node.get(key, []))
            arr = node.setdefault(key, [{} for _ in range(n)])
            for t in (range(n) if idx == "*" else [idx - 1]):
                if last:
                    arr[t] = value
                else:
                    sub = arr[t]
                    for key2, _ in segs[k + 1:-1]:
                        sub = sub.setdefault(key2, {})
                    sub[segs[-1][0]] = value
            break
    lines = [f"# {title}: written by pkmstiff optimise from {design.source}"]
    if opts:
        lines.append(f"# load with the base's options: pkmstiff.load_machine('<this file>:{opts}')")
    lines += ["", "[machine]", f"extends = {json.dumps(str(Path(base).resolve()) if base.endswith('.toml') else base)}",
              f"name = {json.dumps(title)}", ""]
    arrays = []

    def table(prefix: str, tab: dict[str, Any]) -> None:
        scalars = {k: v for k, v in tab.items() if not isinstance(v, dict) and not (isinstance(v, list) and v
                                                                                   and isinstance(v[0], dict))}
        if scalars and prefix:
            lines.append(f"[{prefix}]")
        lines.extend(f"{json.dumps(k)} = {_toml_value(v)}" for k, v in scalars.items())
        for k, v in tab.items():
            if isinstance(v, dict):
                table(f"{prefix}.{k}" if prefix else k, v)
            elif isinstance(v, list) and v and isinstance(v[0], dict):
                arrays.append((k, v))

    table("", {k: v for k, v in tree.items() if k != "machine"})
    for k, items in arrays:
        for it in items:
            lines += ["", f"[[{k}]]"] + [f"{json.dumps(a)} = {_toml_value(b)}" for a, b in it.items()]
    return "\n".join(lines) + "\n"


def convergence_series(cands: list[Candidate], design: Design, j: int) -> tuple[np.ndarray, np.ndarray]:
    """Objective ``j`` of ``cands`` (minimised sense; NaN where failed) and whether each is feasible, both judged
    with ``design``, whose rasters and constraint bounds must be those the candidates' outputs come from."""
    vals = np.array([c.outputs.get(design.objectives[j].measure.label, np.nan) if not c.error else np.nan
                     for c in cands], dtype=float)
    if design.objectives[j].sense == "maximise":
        vals = -vals
    return vals, np.array([c.feasible(design) for c in cands], dtype=bool)


def _convergence_png(res: OptimisationResult, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pkmstiff.plots.section_maps import pretty_unit

    design = res.design
    search = res.search_design or design  # history's values are on the search raster, judged by its constraints
    if res.refined:
        on = (f" (search raster, {res.meta['refined']['search_step_mm']:g} mm)", " (requested raster)")
    else:
        on = ("", "")
    n = len(design.objectives)
    fig, axes = plt.subplots(1, n, figsize=(5.5 * n, 3.8), squeeze=False)
    for j, (o, ax) in enumerate(zip(design.objectives, axes[0])):
        sign = -1.0 if o.sense == "maximise" else 1.0
        vals, feas = convergence_series(res.history, search, j)
        best = np.minimum.accumulate(np.where(feas, vals, np.inf))
        idx = np.arange(1, len(vals) + 1)
        ok = np.isfinite(vals)
        ax.plot(idx[ok & feas], sign * vals[ok & feas], ".", ms=3, color="0.45", label="feasible" + on[0])
        ax.plot(idx[ok & ~feas], sign * vals[ok & ~feas], "x", ms=3, color="C3", alpha=0.5,
                label="infeasible" + on[0])
        okb = np.isfinite(best)
        ax.step(idx[okb], sign * best[okb], where="post", color="C0", lw=2, label="best feasible so far" + on[0])
        if res.refined:
            rv, rf = convergence_series(res.refined, design, j)
            ri = np.array([c.index + 1 for c in res.refined])
            rok = np.isfinite(rv)
            ax.plot(ri[rok & rf], sign * rv[rok & rf], "o", mfc="none", color="C2", label="feasible" + on[1])
            ax.plot(ri[rok & ~rf], sign * rv[rok & ~rf], "o", mfc="none", color="C1", label="infeasible" + on[1])
        ax.set_xlabel("evaluation")
        ax.set_ylabel(f"{o.measure.name} [{pretty_unit(o.measure.unit)}]")
        ax.set_title(f"{o.sense} {o.measure.name}")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=9)
    fig.suptitle(f"{Path(design.source).name}: {res.algorithm}, {len(res.history)} evaluations", fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    tmp = path.with_suffix(".png.tmp")
    tmp.write_bytes(buf.getvalue())
    tmp.replace(path)


def _draw(figures: list[tuple[Callable[..., Any], tuple]], jobs: int) -> Callable[[], None]:
    """Draw ``figures`` (function, arguments): as tasks of the local pool of ``jobs`` > 1 workers, while this process
    goes on (with the comparison report, whose own tasks queue behind them), else here and now; returns a function
    that waits until every figure is written (and raises a figure's error)."""
    from pkmstiff.evaluation import parallel

    workers = parallel.resolve_workers(jobs)
    if workers < 2:
        for fn, args in figures:
            fn(*args)
        return lambda: None
    futures = [parallel.pool(workers).submit(fn, *args) for fn, args in figures]

    def done() -> None:
        for f in futures:
            f.result()
    return done


def write_outputs(res: OptimisationResult, out: str | Path, *, report: bool = True, jobs: int = 1) -> dict[str, Path]:
    """Write front.csv, history.csv, designs/*.toml, convergence.png, front.png, the comparison report (unless
    ``report`` is False; its sections evaluated in ``jobs`` processes) and summary.json into ``out``. The base
    design and the references are those of ``res.meta["references"]``
    (:func:`pkmstiff.optimise.compare.references_compared`)."""
    from pkmstiff.optimise.compare import compared_designs, plot_comparison

    out = Path(out)
    design = res.design
    paths = {"front": out / "front.csv", "history": out / "history.csv", "convergence": out / "convergence.png",
             "front_plot": out / "front.png", "summary": out / "summary.json"}
    names = [f"design_{i + 1:03d}" for i in range(len(res.front))]
    atomic_write_text(paths["front"], _csv(design, res.front, {"design": names}))
    atomic_write_text(paths["history"], _csv(design, res.history, {"evaluation": [c.index + 1 for c in res.history]}))
    (out / "designs").mkdir(exist_ok=True)
    files = []
    for name, c in zip(names, res.front):
        p = out / "designs" / f"{name}.toml"
        atomic_write_text(p, design_machine_toml(design, c, name))
        files.append(str(p))
    compared = compared_designs(res, names, files)
    figures_done = _draw([(_convergence_png, (res, paths["convergence"])),
                          (plot_comparison, (res, compared, paths["front_plot"]))], jobs)
    if report:
        from pkmstiff.optimise.report import write_comparison_report

        paths["report"] = write_comparison_report(res, compared, out, {"front": paths["front_plot"],
                                                                       "convergence": paths["convergence"]},
                                                  jobs=jobs, figures_done=figures_done)["html"]
    figures_done()
    summary = {
        "design_file": design.source, "machine": design.machine, "algorithm": res.algorithm, **res.meta,
        "evaluations": len(res.history), "evaluated": res.evaluated, "read_from_checkpoint": res.cached,
        "reevaluated_on_requested_raster": res.reevaluated,
        "wall_time_s": round(res.wall_time_s, 3),
        "objectives": [{"name": o.measure.name, "unit": o.measure.unit, "sense": o.sense} for o in design.objectives],
        "constraints": [{"name": c.measure.name, "unit": c.measure.unit, "min": c.lower, "max": c.upper}
                        for c in design.constraints],
        "front": [{"design": n, "machine_file": f, "variables": dict(zip(_labels(design), _row(design, c))),
                   "overrides": c.overrides} for n, f, c in zip(names, files, res.front)],
    }
    atomic_write_text(paths["summary"], json.dumps(summary, indent=2, default=repr))
    return paths
