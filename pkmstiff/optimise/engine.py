"""The optimisation loop: a pymoo algorithm asks for candidates, the engine evaluates the new ones (cached by the
content hash of the machine variant, checkpointed as JSON lines, in local processes through the sweep's machinery)
and tells the algorithm the objectives F and the constraint violations G (<= 0 feasible).

An interrupted run resumes with ``resume=True``: the algorithm restarts with the same seed, so it asks for the same
candidates, and every candidate already in the checkpoint is read instead of evaluated.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.errors import CliError, NothingFeasibleError, PkmstiffError
from pkmstiff.io.atomic import atomic_write_text
from pkmstiff.machine.model import Machine
from pkmstiff.optimise.design import Design

__all__ = ["CHECKPOINT", "INSTALL_HINT", "Candidate", "DesignEvaluation", "OptimisationResult", "run_optimisation"]

CHECKPOINT = "evaluations.jsonl"
INSTALL_HINT = "pkmstiff optimise needs pymoo: pip install 'pkmstiff[optimise]'"
#: F of a failed or NaN candidate (it is also infeasible, G = 1, so it is never reported as the best)
_FAILED_F = 1e30


@dataclass(frozen=True)
class DesignEvaluation:
    """The sweep evaluation of one candidate: every measure of the design, one section per settings (memo)."""

    measures: tuple

    def __call__(self, machine: Machine) -> dict[str, float]:
        memo: dict = {}
        return {m.label: m(machine, memo) for m in self.measures}


@dataclass
class Candidate:
    """One evaluated machine variant."""

    key: str  # content hash of the variant (and of the evaluation)
    values: list[Any]  # one per variable
    overrides: dict[str, Any]
    outputs: dict[str, float]
    error: str = ""
    index: int = 0  # evaluation order (requested by the algorithm, cached ones included)

    def objective_vector(self, design: Design) -> np.ndarray:
        out = []
        for o in design.objectives:
            v = self.outputs.get(o.measure.label, float("nan"))
            out.append(_FAILED_F if self.error or not math.isfinite(v) else (-v if o.sense == "maximise" else v))
        return np.array(out)

    def violations(self, design: Design) -> np.ndarray:
        g = [1.0 if self.error else c.violation(self.outputs.get(c.measure.label, float("nan")))
             for c in design.constraints]
        if any(not math.isfinite(self.outputs.get(o.measure.label, float("nan"))) for o in design.objectives):
            g.append(1.0)  # a NaN objective (no admissible point) is infeasible
        elif design.constraints or self.error:
            g.append(1.0 if self.error else 0.0)
        return np.array(g or [0.0])

    def feasible(self, design: Design) -> bool:
        return not self.error and bool(np.all(self.violations(design) <= 0.0))


@dataclass
class OptimisationResult:
    design: Design
    history: list[Candidate]  # in evaluation order (a candidate requested twice appears twice)
    front: list[Candidate]  # feasible, non-dominated (one objective: the best)
    evaluated: int  # evaluations actually run (not read from the checkpoint)
    cached: int
    wall_time_s: float
    algorithm: str
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def best(self) -> Candidate:
        return self.front[0]


def _variant_hash(raw: dict, overrides: dict[str, Any], evaluation: Any) -> str:
    from pkmstiff.machine.variants import apply_overrides

    text = json.dumps({"machine": apply_overrides(raw, overrides), "evaluation": repr(evaluation)}, sort_keys=True,
                      default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def _read_checkpoint(path: Path) -> dict[str, dict[str, Any]]:
    """key -> record; a torn last line (the run was killed while writing) is skipped."""
    out: dict[str, dict[str, Any]] = {}
    if not path.exists():
        return out
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:
            continue
        out[rec["key"]] = rec
    return out


def _algorithm(name: str, population: int, n_obj: int, x0: np.ndarray | None) -> Any:
    if name == "nsga2":
        from pymoo.algorithms.moo.nsga2 import NSGA2

        return NSGA2(pop_size=population)
    if n_obj > 1:
        raise PkmstiffError(f"algorithm {name!r} is single-objective; the design has {n_obj} objectives (use nsga2)")
    if name == "cmaes":
        from pymoo.algorithms.soo.nonconvex.cmaes import CMAES

        # the budget ends the run, not cma's own tolerances (they stop at absolute f changes of 1e-11)
        return CMAES(popsize=population, restarts=0, tolfun=0.0, tolx=0.0, tolfunhist=0.0)
    from pymoo.algorithms.soo.nonconvex.de import DE

    return DE(pop_size=population, variant="DE/rand/1/bin", CR=0.9, F=0.7)


def _front(design: Design, cands: Sequence[Candidate]) -> list[Candidate]:
    feas = list({c.key: c for c in cands if c.feasible(design)}.values())
    if not feas:
        return []
    F = np.array([c.objective_vector(design) for c in feas])
    if F.shape[1] == 1:
        return [feas[int(np.argmin(F[:, 0]))]]
    from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

    idx = NonDominatedSorting().do(F, only_non_dominated_front=True)
    return sorted((feas[i] for i in idx), key=lambda c: tuple(c.objective_vector(design)))


def run_optimisation(design: Design, out: str | Path, *, jobs: int = 1, budget: int | None = None,
                     seed: int | None = None, resume: bool = False, force: bool = False,
                     progress: Callable[[str], None] | None = None) -> OptimisationResult:
    """Optimise ``design``; the checkpoint ``out/evaluations.jsonl`` grows as candidates are evaluated.

    ``out`` must not hold a checkpoint unless ``resume`` (continue it) or ``force`` (start afresh). Raises
    :class:`NothingFeasibleError` (exit 3) when no evaluated candidate satisfies every constraint.
    """
    try:
        from pymoo.core.evaluator import Evaluator
        from pymoo.core.problem import Problem
        from pymoo.problems.static import StaticProblem
    except ImportError:
        raise CliError(INSTALL_HINT) from None
    from pkmstiff.evaluation.sweep import SweepTask, run_sweep
    from pkmstiff.machine.variants import raw_machine

    out = Path(out)
    ckpt = out / CHECKPOINT
    if ckpt.exists() and not (resume or force):
        raise CliError(f"{ckpt} exists: pass --resume to continue that run or --force to start afresh")
    out.mkdir(parents=True, exist_ok=True)
    if force and not resume and ckpt.exists():
        ckpt.unlink()
    cache = _read_checkpoint(ckpt) if resume else {}
    if resume and ckpt.exists():  # drop a torn last line before appending to the file
        atomic_write_text(ckpt, "".join(json.dumps(rec, default=repr) + "\n" for rec in cache.values()))
    budget = design.budget if budget is None else budget
    seed = design.seed if seed is None else seed
    evaluation = DesignEvaluation(design.measures())
    raw, _, _ = raw_machine(design.machine)
    lo, hi = design.bounds()
    n_obj = len(design.objectives)
    n_g = max(1, len(design.constraints) + 1)
    problem = Problem(n_var=design.n_var, n_obj=n_obj, n_ieq_constr=n_g, xl=lo, xu=hi)
    name = design.resolved_algorithm()
    algo = _algorithm(name, design.population, n_obj, (lo + hi) / 2)
    algo.setup(problem, termination=("n_eval", budget), seed=seed, verbose=False)
    history: list[Candidate] = []
    evaluated = cached = 0
    t0 = time.perf_counter()
    with open(ckpt, "a", encoding="utf-8") as log:
        while algo.has_next() and len(history) < budget:
            pop = algo.ask()
            X = np.atleast_2d(pop.get("X"))[: budget - len(history)]
            pop = pop[: len(X)]
            batch = []
            for x in X:
                values = design.split(x)
                ov = design.overrides(values)
                batch.append(Candidate(_variant_hash(raw, ov, evaluation), values, ov, {}, index=len(history)
                                       + len(batch)))
            new = {c.key: c for c in batch if c.key not in cache}
            tasks = [SweepTask(i, design.machine, {}, c.overrides, {}, evaluation) for i, c in enumerate(new.values())]
            rows = run_sweep(tasks, n_jobs=jobs).rows if tasks else []
            for c, row in zip(new.values(), rows):
                rec = {"key": c.key, "values": c.values, "overrides": c.overrides, "error": row.get("error", ""),
                       "outputs": {k: v for k, v in row.items() if k not in ("task", "error")}}
                cache[c.key] = rec
                log.write(json.dumps(rec, default=repr) + "\n")
            log.flush()
            evaluated += len(rows)
            cached += len(batch) - len(new)
            for c in batch:
                rec = cache[c.key]
                c.outputs, c.error = dict(rec["outputs"]), rec["error"]
            history += batch
            static = StaticProblem(problem, F=np.array([c.objective_vector(design) for c in batch]),
                                   G=np.array([c.violations(design) for c in batch]))
            Evaluator().eval(static, pop)
            algo.tell(infills=pop)
            if progress is not None:
                front = _front(design, history)
                best = ", ".join(f"{o.measure.name} {v:.6g}" for o, v in
                                 zip(design.objectives, front[0].outputs.values())) if front else "none feasible"
                progress(f"{len(history)}/{budget} evaluations ({evaluated} run, {cached} cached); best: {best}")
    front = _front(design, history)
    if not front:
        raise NothingFeasibleError(f"no feasible design among {len(history)} evaluations of {design.source} "
                                   f"(every candidate violates a constraint or failed); nothing reported as best")
    return OptimisationResult(design, history, front, evaluated, cached, time.perf_counter() - t0, name,
                              {"seed": seed, "budget": budget, "jobs": jobs})
