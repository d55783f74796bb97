"""Design optimisation (``pkmstiff optimise``; docs/user-guide/optimise.md): a design file states the base machine,
the variables (dotted machine-file paths), the objectives and the constraints; :func:`optimise` runs a pymoo
algorithm over it with cached, checkpointed, optionally parallel evaluations and writes the front.

    >>> import pkmstiff
    >>> res = pkmstiff.optimise("design.toml", out="opt", budget=40)     # doctest: +SKIP
    >>> res.best.values, res.best.outputs                                # doctest: +SKIP
"""

from __future__ import annotations

import sys
import types
from pathlib import Path
from typing import Any

from pkmstiff.optimise.design import (
    Constraint,
    Design,
    FunctionMeasure,
    MovingMassMeasure,
    Objective,
    PointMeasure,
    Reference,
    SectionMeasure,
    TaskBoxMeasure,
    Variable,
    WorkspaceMeasure,
)
from pkmstiff.optimise.design_file import load_design
from pkmstiff.optimise.engine import OptimisationResult, run_optimisation

__all__ = ["Constraint", "Design", "FunctionMeasure", "MovingMassMeasure", "Objective", "OptimisationResult",
           "PointMeasure", "Reference", "SectionMeasure", "TaskBoxMeasure", "Variable", "WorkspaceMeasure",
           "load_design", "optimise"]

#: the bundled example design files
EXAMPLES = Path(__file__).parent / "examples"


def optimise(design: Design | str | Path, out: str | Path, *, jobs: int = 1, scheduler: Any = None,
             budget: int | None = None, time_budget: float | None = None, seed: int | None = None,
             resume: bool = False, force: bool = False, progress=None, report: bool = True) -> OptimisationResult:
    """Run ``design`` (a :class:`Design` or a design file) and write its outputs into ``out`` (front.csv,
    history.csv, designs/*.toml, convergence.png, front.png, report/report.html unless ``report`` is False,
    summary.json; the checkpoint evaluations.jsonl). ``jobs`` local processes or a Dask ``scheduler`` (address or
    client) evaluate the candidates; ``budget`` (evaluations), ``time_budget`` (s) and ``seed`` override the
    design's; ``resume`` continues an interrupted run without re-evaluating its checkpointed candidates; ``force``
    starts afresh in an ``out`` that holds a run. The base design and the design's references are evaluated with
    the same measures (``res.meta["references"]``)."""
    from dataclasses import asdict

    from pkmstiff.optimise.compare import references_compared
    from pkmstiff.optimise.outputs import write_outputs

    if not isinstance(design, Design):
        design = load_design(design)
    res = run_optimisation(design, out, jobs=jobs, scheduler=scheduler, budget=budget, time_budget=time_budget,
                           seed=seed, resume=resume, force=force, progress=progress, references=True)
    res.meta["references"] = [asdict(c) for c in references_compared(design, res.references)]
    res.meta["outputs"] = {k: str(v) for k, v in write_outputs(res, out, report=report, jobs=jobs).items()}
    return res


class _CallableModule(types.ModuleType):
    """``pkmstiff.optimise(...)`` calls :func:`optimise`: the subpackage and the function share the name."""

    def __call__(self, *args, **kwargs) -> OptimisationResult:
        return optimise(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
