"""The optimised designs beside the base design and the design file's references: their evaluation (the same
measures, the sweep's machinery) and the comparison figures — the Pareto front (two or more objectives: every pair
of objectives) or, for one objective, a bar chart of base, references and best."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.io.atomic import atomic_path
from pkmstiff.optimise.design import Design
from pkmstiff.optimise.engine import Candidate, OptimisationResult

__all__ = ["Compared", "compared_designs", "plot_comparison", "references_compared"]

#: the text sizes of the comparison figures [pt] (at least 9 pt on the page)
_FONT = 10
_SMALL = 9
_MARKERS = ("D", "s", "^", "v", "P", "X", "<", ">")


@dataclass(frozen=True)
class Compared:
    """One design of the comparison: ``kind`` "base", "reference" or "optimised"; ``machine`` a bundled name with
    options or a machine file; ``outputs`` measure label -> value (empty with ``error``)."""

    name: str
    kind: str
    machine: str
    outputs: dict[str, float]
    error: str = ""
    note: str = ""  # an optimised design's variable values


def references_compared(design: Design, evaluated: list[Candidate]) -> list[Compared]:
    """The base machine and every reference of ``design`` as the run evaluated them with the design's measures
    (:func:`pkmstiff.optimise.engine.run_optimisation` with ``references=True``: the base first); a design that
    failed records its error, as a candidate does."""
    named = [("base", "base", design.machine)] + [(r.name, "reference", r.machine) for r in design.references]
    return [Compared(name, kind, machine, {k: float(v) for k, v in c.outputs.items()}, c.error)
            for (name, kind, machine), c in zip(named, evaluated, strict=True)]


def compared_designs(res: OptimisationResult, names: list[str], files: list[str], limit: int = 4) -> list[Compared]:
    """Base, references (``res.meta["references"]``) and the optimised designs: one objective the best, several
    at most ``limit`` front designs spread evenly along the front (its two ends included)."""
    front = list(zip(names, files, res.front))
    if len(front) > limit:
        front = [front[round(i)] for i in np.linspace(0, len(front) - 1, limit)]
    out = [Compared(**c) for c in res.meta.get("references", [])]
    return out + [Compared(n, "optimised", f, dict(c.outputs), c.error, _values_text(res.design, c.values))
                  for n, f, c in front]


def _values_text(design: Design, values: list[Any]) -> str:
    """"name = value unit" of every variable (a direction as polar, azimuth)."""
    parts = []
    for v, val in zip(design.variables, values):
        text = ", ".join(f"{x:.6g}" for x in val) if v.kind == "direction" else (
            f"{val:.6g}" if isinstance(val, float) else str(val))
        parts.append(f"{v.name} = {text}" + (f" {v.unit}" if v.unit and v.kind != "categorical" else ""))
    return "; ".join(parts)


def _value(c: Candidate | Compared, label: str) -> float:
    v = c.outputs.get(label, float("nan"))
    return float(v) if isinstance(v, (int, float)) and not c.error else float("nan")


def _axis_label(design: Design, j: int) -> str:
    from pkmstiff.plots.section_maps import pretty_unit

    o = design.objectives[j]
    return f"{o.measure.name} [{pretty_unit(o.measure.unit)}] ({'max' if o.sense == 'maximise' else 'min'}imise)"


def plot_comparison(res: OptimisationResult, compared: list[Compared], path: str | Path) -> Path:
    """``path`` (PNG): the Pareto front of every pair of objectives with every feasible candidate, the base design
    and the references marked; one objective: bars of base, references and best with their values."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    design = res.design
    n = len(design.objectives)
    pairs = [(a, b) for a in range(n) for b in range(a + 1, n)]
    if n == 1:
        fig = _bars(plt, design, compared)
    else:
        cols = min(len(pairs), 3)
        rows = math.ceil(len(pairs) / cols)
        fig, axes = plt.subplots(rows, cols, figsize=(6.4 * cols, 4.8 * rows), squeeze=False)
        for ax, (a, b) in zip(axes.flat, pairs):
            _front_axes(ax, res, compared, a, b)
        for ax in list(axes.flat)[len(pairs):]:
            ax.set_visible(False)
        fig.tight_layout()
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=150)
    plt.close(fig)
    return path


def _front_axes(ax: Any, res: OptimisationResult, compared: list[Compared], a: int, b: int) -> None:
    design = res.design
    la, lb = (design.objectives[j].measure.label for j in (a, b))
    feas = [c for c in res.history if c.feasible(design)]
    infeas = [c for c in res.history if not c.feasible(design) and not c.error]
    if infeas:
        ax.plot([_value(c, la) for c in infeas], [_value(c, lb) for c in infeas], "x", ms=4, color="0.75",
                label="infeasible candidate")
    ax.plot([_value(c, la) for c in feas], [_value(c, lb) for c in feas], ".", ms=5, color="0.55",
            label="feasible candidate")
    front = sorted(res.front, key=lambda c: _value(c, la))
    # with more than two objectives the front is non-dominated in all of them, not in this pair: no line
    pair = len(design.objectives) == 2
    ax.plot([_value(c, la) for c in front], [_value(c, lb) for c in front], "o-" if pair else "o", ms=5, lw=1.5,
            color="C0", label=f"Pareto front ({len(front)} designs{'' if pair else ', all objectives'})")
    cats = [i for i, v in enumerate(design.variables) if v.kind == "categorical"]
    if cats and len(front) <= 8:  # name the catalogue choices of each front design
        for c in front:
            ax.annotate(", ".join(str(c.values[i]) for i in cats), (_value(c, la), _value(c, lb)),
                        textcoords="offset points", xytext=(6, -12), fontsize=_SMALL, color="C0")
    k = 0
    for c in compared:
        x, y = _value(c, la), _value(c, lb)
        if c.kind == "optimised" or not (math.isfinite(x) and math.isfinite(y)):
            continue
        if c.kind == "base":
            ax.plot(x, y, "*", ms=16, color="k", label="base design", zorder=5)
        else:
            ax.plot(x, y, _MARKERS[k % len(_MARKERS)], ms=10, color=f"C{(k + 1) % 10}", mec="k",
                    label=f"reference: {c.name}", zorder=5)
            k += 1
    ax.set_xlabel(_axis_label(design, a), fontsize=_FONT)
    ax.set_ylabel(_axis_label(design, b), fontsize=_FONT)
    ax.tick_params(labelsize=_SMALL)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=_SMALL, loc="best", framealpha=0.9)
    ax.set_title(f"{Path(design.source).stem}: {len(res.history)} evaluations, {res.algorithm}", fontsize=_FONT)


def _bars(plt: Any, design: Design, compared: list[Compared]) -> Any:
    from pkmstiff.plots.section_maps import pretty_unit

    o = design.objectives[0]
    shown = [c for c in compared if math.isfinite(_value(c, o.measure.label))]
    vals = [_value(c, o.measure.label) for c in shown]
    fig, ax = plt.subplots(figsize=(6.4, 0.9 + 0.55 * max(len(shown), 2)))
    colours = ["0.3" if c.kind == "base" else "C0" if c.kind == "optimised" else f"C{1 + i % 9}"
               for i, c in enumerate(shown)]
    y = np.arange(len(shown))[::-1]
    ax.barh(y, vals, color=colours, height=0.6)
    kinds = {"base": "base design", "reference": "reference", "optimised": "best"}
    ax.set_yticks(y, [c.name if c.name == c.kind else f"{c.name} ({kinds[c.kind]})" for c in shown], fontsize=_FONT)
    lo = min(min(vals), 0.0)
    span = max(vals) - lo or 1.0
    for yi, v in zip(y, vals):
        ax.text(v + 0.01 * span, yi, f"{v:.4g}", va="center", fontsize=_SMALL)
    ax.set_xlim(lo, max(vals) + 0.15 * span)
    ax.set_xlabel(f"{o.measure.name} [{pretty_unit(o.measure.unit)}] ({o.sense})", fontsize=_FONT)
    ax.tick_params(labelsize=_SMALL)
    ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    return fig
