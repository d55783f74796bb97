"""The optimisation loop: a pymoo algorithm asks for candidates, the engine evaluates the new ones (cached by the
content hash of the machine variant, checkpointed as JSON lines) and tells the algorithm the objectives F and the
constraint violations G (<= 0 feasible).

* **Parallel candidates.** The new candidates of a generation are evaluated together: in this process (``jobs`` 1),
  in the run's forked process pool (``jobs`` > 1: one candidate per task, whichever worker is free takes the next) or
  on a Dask cluster (``scheduler``: tasks sized by :func:`pkmstiff.evaluation.parallel.plan` from the cost per
  candidate measured in the previous generation). The run's context (the base machine's name or file and the
  evaluation) is a :class:`~pkmstiff.evaluation.parallel.Shared`, unpickled once per worker; a task adds only its
  candidates' overrides (or a reference's machine), from which the worker builds each variant; a candidate's own
  evaluation runs serially in its worker (no nested pools). The base machine and the references are tasks beside
  the first batch on their rasters, not serial work before or after the search. Results come back in candidate
  order, so a run gives the same history whatever ``jobs``/``scheduler``.
* **Budgets.** The run stops after ``budget`` evaluations or, checked between generations, once ``time_budget``
  seconds have passed; either way it reports the best feasible design found so far. The re-evaluation on the
  requested raster (coarse-to-fine) comes after the search: it keeps to what is left of ``time_budget`` where it can,
  but always runs until one re-evaluated design is feasible, so a run may end after its ``time_budget``.
* **Coarse-to-fine.** With ``Design.coarse_step`` the search evaluates every section on that raster; afterwards the
  best ``Design.refine`` feasible candidates (one objective) or the feasible front (several) are re-evaluated on the
  requested rasters, and the front is taken from those values.
* **Resume.** An interrupted run resumes with ``resume=True``: the algorithm restarts with the same seed, so it asks
  for the same candidates, and every candidate already in the checkpoint is read instead of evaluated.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.errors import ArgumentError, InadmissibleError, PkmstiffError
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
    """The evaluation of one candidate: every measure of the design, one section per settings (memo)."""

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
    search_outputs: dict[str, float] | None = None  # coarse-to-fine: the outputs on the search (coarse) raster
    machine: str | None = None  # a reference design's machine (None: the base machine with ``overrides``)

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
    front: list[Candidate]  # feasible, non-dominated (one objective: the best); coarse-to-fine: requested raster
    evaluated: int  # search evaluations actually run (not read from the checkpoint nor repeated)
    cached: int  # search candidates repeated or read from the checkpoint
    reevaluated: int  # coarse-to-fine: candidates re-evaluated on the requested raster (run or from the checkpoint)
    wall_time_s: float
    algorithm: str
    meta: dict[str, Any] = field(default_factory=dict)  # seed, budget, jobs, stopped (why the search ended), ...
    search_design: Design | None = None  # as searched: coarse rasters, relative bounds resolved (history's terms)
    refined: list[Candidate] = field(default_factory=list)  # coarse-to-fine: every re-evaluated candidate
    #: ``references=True``: the base machine, then the design's references, on the requested rasters
    references: list[Candidate] = field(default_factory=list)

    @property
    def best(self) -> Candidate:
        return self.front[0]


def _variant_hash(raw: dict, overrides: dict[str, Any], evaluation: Any) -> str:
    from pkmstiff.machine.variants import apply_overrides

    text = json.dumps({"machine": apply_overrides(raw, overrides, share=True), "evaluation": repr(evaluation)},
                      sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def _reference_hash(machine: str, evaluation: Any) -> str:
    """The key of a reference design: its machine (name with options, or file), its raw data and the evaluation."""
    from pkmstiff.machine.variants import raw_machine

    text = json.dumps({"reference": machine, "machine": raw_machine(machine)[0], "evaluation": repr(evaluation)},
                      sort_keys=True, default=repr)
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


class _Pymoo:
    """A pymoo algorithm through the engine's ask/tell: ``ask() -> X`` (decision vectors), ``tell(F, G)``."""

    def __init__(self, algorithm: Any, lo: np.ndarray, hi: np.ndarray, n_obj: int, n_g: int, budget: int,
                 seed: int):
        from pymoo.core.problem import Problem

        self.algo = algorithm
        self.problem = Problem(n_var=len(lo), n_obj=n_obj, n_ieq_constr=n_g, xl=lo, xu=hi)
        self.algo.setup(self.problem, termination=("n_eval", budget), seed=seed, verbose=False)
        self.pop: Any = None

    def has_next(self) -> bool:
        return bool(self.algo.has_next())

    def ask(self, most: int) -> np.ndarray:
        self.pop = self.algo.ask()
        X = np.atleast_2d(self.pop.get("X"))[:most]
        self.pop = self.pop[: len(X)]
        return X

    def tell(self, F: np.ndarray, G: np.ndarray) -> None:
        from pymoo.core.evaluator import Evaluator
        from pymoo.problems.static import StaticProblem

        Evaluator().eval(StaticProblem(self.problem, F=F, G=G), self.pop)
        self.algo.tell(infills=self.pop)


class _CMAES:
    """CMA-ES (the ``cma`` package) through the engine's ask/tell, on the decision vector scaled to [0, 1] (cma's
    bound handling), initial step 0.3, from the middle of the box. Constraints by ranking: an infeasible candidate
    ranks after the worst feasible one seen so far, by its violation. The budget ends the run, not cma's own
    tolerances."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, population: int, seed: int):
        import cma

        self.lo, self.span = lo, hi - lo
        self.es = cma.CMAEvolutionStrategy(np.full(len(lo), 0.5), 0.3, {
            "bounds": [0.0, 1.0], "popsize": population, "seed": seed + 1,  # cma: seed 0 = from the clock
            "verbose": -9, "tolfun": 0.0, "tolx": 0.0, "tolfunhist": 0.0, "tolflatfitness": 10**9,
            "tolstagnation": 10**9})
        self.worst = -np.inf
        self.U: list[np.ndarray] = []

    def has_next(self) -> bool:
        return not self.es.stop()

    def ask(self, most: int) -> np.ndarray:
        self.U = self.es.ask()
        return self.lo + self.span * np.array(self.U)[:most]

    def tell(self, F: np.ndarray, G: np.ndarray) -> None:
        f = F[:, 0].astype(float)
        v = np.maximum(G, 0.0).sum(axis=1)
        ok = v <= 0.0
        if ok.any():
            self.worst = max(self.worst, float(f[ok].max()))
        base = self.worst if np.isfinite(self.worst) else 0.0
        ranked = np.where(ok, f, base + 1.0 + v)
        if len(ranked) < len(self.U):  # the budget cut the generation: cma needs all of it
            self.U = self.U[: len(ranked)]
            return
        self.es.tell(self.U, ranked.tolist())


def _algorithm(name: str, design: Design, budget: int, seed: int) -> Any:
    lo, hi = design.bounds()
    n_obj = len(design.objectives)
    if name != "nsga2" and n_obj > 1:
        raise PkmstiffError(f"algorithm {name!r} is single-objective; the design has {n_obj} objectives (use nsga2)")
    if name == "cmaes":
        return _CMAES(lo, hi, design.population, seed)
    if name == "nsga2":
        from pymoo.algorithms.moo.nsga2 import NSGA2

        algo = NSGA2(pop_size=design.population)
    else:
        from pymoo.algorithms.soo.nonconvex.de import DE
        from pymoo.operators.sampling.lhs import LHS

        # best/1/bin, CR 0.7 (scipy's defaults) from a Latin hypercube: on the Hexaglide example it reaches in 900
        # evaluations what rand/1/bin (CR 0.9, F 0.7) had not reached (32.96 vs 31.99 N/um, docs/user-guide/optimise.md)
        algo = DE(pop_size=design.population, sampling=LHS(), variant="DE/best/1/bin", CR=0.7, F=0.6)
    return _Pymoo(algo, lo, hi, n_obj, max(1, len(design.constraints) + 1), budget, seed)


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


# ---------------------------------------------------------------------------------------------------- evaluation
@dataclass(frozen=True)
class _Context:
    """What every candidate of a run shares: the base machine (name or file) and the evaluation."""

    machine: str
    evaluation: DesignEvaluation


#: what the evaluator evaluates: a machine (None: the run's base machine) and the overrides applied to it
Item = tuple[str | None, dict[str, Any]]


def _evaluate_batch(context: Any, items: Sequence[Item]) -> list[tuple[dict[str, float], str, float]]:
    """(outputs, error, seconds) of each candidate of a task, in order (a worker's task, or the serial run); a
    candidate's error is recorded, never raised."""
    from pkmstiff.evaluation.sweep import SweepTask, run_task

    ctx: _Context = context.get()
    out = []
    for machine, ov in items:
        t0 = time.perf_counter()
        row = run_task(SweepTask(0, machine or ctx.machine, {}, ov, {}, ctx.evaluation))
        out.append(({k: v for k, v in row.items() if k not in ("task", "error")}, row["error"],
                    time.perf_counter() - t0))
    return out


class _Evaluator:
    """Evaluates candidates (:data:`Item`) with one evaluation, serially, in the local pool or on Dask (results in
    order); ``seconds`` is the measured cost of one candidate (the median of the last batch), from which
    :func:`pkmstiff.evaluation.parallel.plan` sizes the tasks: as small as the least task time allows (locally one
    candidate each), taken by whichever worker is free, so a generation of 12 candidates on 2 workers ends at most
    one candidate after the slower worker's share."""

    def __init__(self, machine: str, evaluation: DesignEvaluation, jobs: int, scheduler: Any):
        from pkmstiff.evaluation import parallel

        self.shared = parallel.Shared(_Context(machine, evaluation))
        self.jobs, self.scheduler = jobs, scheduler
        self.seconds = parallel.MIN_LOCAL_TASK_SECONDS  # until measured: small tasks
        self.where = "serial"

    def __call__(self, items: Sequence[Item]) -> list[tuple[dict[str, float], str, float]]:
        from pkmstiff.evaluation import parallel

        if not items:
            return []
        p = parallel.plan(len(items), self.seconds, self.jobs, self.scheduler, tasks_per_worker=len(items))
        payloads = [(self.shared, list(items[a:b])) for a, b in parallel.split(len(items), p)]
        done = parallel.run_tasks(_evaluate_batch, payloads, p, self.scheduler)
        rows = [r for task in done for r in task]
        self.seconds = max(float(np.median([r[2] for r in rows])), 1e-4)
        self.where = p.where if p.parallel else self.where
        return rows


def _coarse(design: Design) -> Design:
    """``design`` with every section request on the coarse raster (sections that shared one request still do)."""
    from pkmstiff.optimise.design import SectionMeasure

    if design.coarse_step is None:
        return design
    swapped: dict[Any, Any] = {}

    def measure(m: Any) -> Any:
        if not isinstance(m, SectionMeasure):
            return m
        req = swapped.setdefault(m.request, dataclasses.replace(m.request, step=design.coarse_step))
        return dataclasses.replace(m, request=req)

    return dataclasses.replace(
        design, objectives=tuple(dataclasses.replace(o, measure=measure(o.measure)) for o in design.objectives),
        constraints=tuple(dataclasses.replace(c, measure=measure(c.measure)) for c in design.constraints))


# ---------------------------------------------------------------------------------------------------------- run
def run_optimisation(design: Design, out: str | Path, *, jobs: int = 1, scheduler: Any = None,
                     budget: int | None = None, time_budget: float | None = None, seed: int | None = None,
                     resume: bool = False, force: bool = False, progress: Callable[[str], None] | None = None,
                     references: bool = False) -> OptimisationResult:
    """Optimise ``design``; the checkpoint ``out/evaluations.jsonl`` grows as candidates are evaluated.

    ``references``: also evaluate the base machine and the design's references with the design's measures on the
    requested rasters (``result.references``), beside the candidates of the first batch on those rasters (the first
    generation, or the first re-evaluated batch of a coarse-to-fine run) so that the workers share them out.

    ``jobs``: local worker processes (-1: all cores); ``scheduler``: a Dask scheduler address or client (``jobs`` is
    then ignored). ``budget`` (evaluations), ``time_budget`` (s) and ``seed`` override the design's. ``out`` must not
    hold a checkpoint unless ``resume`` (continue it) or ``force`` (start afresh). Raises :class:`InadmissibleError`
    (exit 3) when no evaluated candidate satisfies every constraint.
    """
    if importlib.util.find_spec("pymoo") is None:
        raise ArgumentError(INSTALL_HINT)
    from pkmstiff.evaluation.parallel import connected, resolve_workers
    from pkmstiff.machine.variants import raw_machine

    if scheduler is None:
        resolve_workers(jobs)
    out = Path(out)
    ckpt = out / CHECKPOINT
    if ckpt.exists() and not (resume or force):
        raise ArgumentError(f"{ckpt} exists: pass --resume to continue that run or --force to start afresh")
    out.mkdir(parents=True, exist_ok=True)
    if force and not resume and ckpt.exists():
        ckpt.unlink()
    cache = _read_checkpoint(ckpt) if resume else {}
    if resume and ckpt.exists():  # drop a torn last line before appending to the file
        atomic_write_text(ckpt, "".join(json.dumps(rec, default=repr) + "\n" for rec in cache.values()))
    budget = design.budget if budget is None else budget
    time_budget = design.time_budget if time_budget is None else time_budget
    seed = design.seed if seed is None else seed
    search = _coarse(design)
    raw, _, _ = raw_machine(design.machine)
    name = design.resolved_algorithm()
    algo = _algorithm(name, design, budget, seed)
    history: list[Candidate] = []
    counts = {"evaluated": 0, "cached": 0, "reevaluated": 0}
    stopped = f"budget of {budget} evaluations"
    t0 = time.perf_counter()

    def evaluate(batch: list[Candidate], ev: _Evaluator, log: Any, count: str = "search",
                 extra: Sequence[Candidate] = ()) -> None:
        """Fill the outputs of ``extra`` (the base machine, references: not counted) and ``batch``, in one go: from
        the checkpoint or evaluated (and appended to it); ``count`` "search" counts ``batch`` as evaluated or
        cached, "refine" as re-evaluated."""
        new = list({c.key: c for c in [*extra, *batch] if c.key not in cache}.values())
        fresh = {c.key for c in new} - {c.key for c in extra}
        recs = [{"key": c.key, "values": c.values, "overrides": c.overrides, "error": error, "outputs": outputs}
                for c, (outputs, error, _) in zip(new, ev([(c.machine, c.overrides) for c in new]))]
        # one write: a Ctrl-C lands before or after the batch's records, and closing the file on the way out
        # flushes what was written, so the checkpoint holds whole batches
        log.write("".join(json.dumps(rec, default=repr) + "\n" for rec in recs))
        log.flush()
        cache.update((rec["key"], rec) for rec in recs)
        if count == "refine":
            counts["reevaluated"] += len(batch)
        else:
            new_in_batch = len({c.key for c in batch} & fresh)
            counts["evaluated"] += new_in_batch
            counts["cached"] += len(batch) - new_in_batch
        for c in [*extra, *batch]:
            rec = cache[c.key]
            c.outputs, c.error = dict(rec["outputs"]), rec["error"]

    with connected(scheduler), open(ckpt, "a", encoding="utf-8") as log:
        evaluation = DesignEvaluation(search.measures())
        ev = _Evaluator(design.machine, evaluation, jobs, scheduler)
        base, refs = _extras(search, raw, evaluation, references and design.coarse_step is None)
        pending = refs or [b for b in (base,) if b]  # evaluated with the first generation
        while algo.has_next() and len(history) < budget:
            if history and time_budget is not None and time.perf_counter() - t0 >= time_budget:
                stopped = f"time budget of {time_budget:g} s"
                break
            X = algo.ask(budget - len(history))
            batch = []
            for x in X:
                values = design.split(x)
                ov = design.overrides(values)
                batch.append(Candidate(_variant_hash(raw, ov, evaluation), values, ov, {},
                                       index=len(history) + len(batch)))
            evaluate(batch, ev, log, extra=pending)
            search, pending = _absolute(search, base), []
            history += batch
            algo.tell(np.array([c.objective_vector(search) for c in batch]),
                      np.array([c.violations(search) for c in batch]))
            if progress is not None:
                progress(_progress_line(search, history, budget, counts, time.perf_counter() - t0))
        if pending:  # no generation ran (a resumed run that had ended)
            evaluate([], ev, log, extra=pending)
            search = _absolute(search, base)
        front = _front(search, history)
        refined: list[Candidate] | None = None
        if design.coarse_step is not None and front:
            deadline = None if time_budget is None else t0 + time_budget
            design, refined, spent, refs = _refine(design, search, history, front, raw, jobs, scheduler, evaluate,
                                                   log, deadline, references)
            front = _front(design, refined)
        elif refined is None:
            design = search
    if not front:
        where = " on the requested raster" if refined is not None else ""
        raise InadmissibleError(f"no feasible design{where} among {len(history)} evaluations of {design.source} "
                                f"(every candidate violates a constraint or failed); nothing reported as best")
    meta = {"seed": seed, "budget": budget, "time_budget_s": time_budget, "jobs": jobs, "stopped": stopped,
            "parallel": ev.where}
    if scheduler is not None:
        meta["scheduler"] = scheduler if isinstance(scheduler, str) else repr(scheduler)
    if refined is not None:
        meta["refined"] = {"search_step_mm": design.coarse_step * 1e3, "candidates": len(refined)}
        if spent:
            meta["refined"]["time_budget_spent"] = True
    return OptimisationResult(design, history, front, counts["evaluated"], counts["cached"],
                              counts["reevaluated"], time.perf_counter() - t0, name, meta, search, refined or [],
                              refs)


#: coarse-to-fine, one objective: at most this many batches of ``Design.refine`` candidates are re-evaluated
REFINE_BATCHES = 5


def _refine(design: Design, search: Design, history: list[Candidate], front: list[Candidate], raw: dict, jobs: int,
            scheduler: Any, evaluate: Callable, log: Any, deadline: float | None = None,
            references: bool = False) -> tuple[Design, list[Candidate], bool, list[Candidate]]:
    """Re-evaluate search candidates on the requested rasters; their ``search_outputs`` keep the coarse values.

    One objective: the feasible search candidates in order of their objective, in batches of ``design.refine``,
    until a batch holds one that is feasible on the requested rasters too (a search that converged onto an active
    constraint leaves many candidates just inside it on the coarse raster and just outside on the fine one), at
    most :data:`REFINE_BATCHES` batches. Several objectives: the feasible search front, in one batch. Once the
    time budget (``deadline``, a :func:`time.perf_counter` time) is spent, no further batch starts when a
    re-evaluated design is feasible already; until one is, the batches shrink to one candidate per worker. The base
    machine (relative constraints) and, with ``references``, the references are evaluated with the first batch.
    Returns the design with its relative constraints resolved on the requested rasters, the re-evaluated candidates,
    whether the time budget was spent before the re-evaluation ended, and the references (base first)."""
    evaluation = DesignEvaluation(design.measures())
    ev = _Evaluator(design.machine, evaluation, jobs, scheduler)
    base, refs = _extras(design, raw, evaluation, references)
    pending = refs or [b for b in (base,) if b]

    def fine(picked: list[Candidate]) -> list[Candidate]:
        nonlocal design, pending
        out = [Candidate(_variant_hash(raw, c.overrides, evaluation), c.values, c.overrides, {}, index=c.index,
                         search_outputs=c.outputs) for c in picked]
        evaluate(out, ev, log, count="refine", extra=pending)
        design, pending = _absolute(design, base), []
        return out

    single = len(design.objectives) == 1
    if single:
        pool = sorted({c.key: c for c in history if c.feasible(search)}.values(),
                      key=lambda c: float(c.objective_vector(search)[0]))[:REFINE_BATCHES * design.refine]
    else:
        pool = list(front)
    size = design.refine if single else len(pool)
    done: list[Candidate] = []
    spent = False
    k = 0
    while k < len(pool):
        if deadline is not None and time.perf_counter() >= deadline:
            spent = True
            if any(c.feasible(design) for c in done):
                break
            size = min(size, _workers(jobs, scheduler))
        done += fine(pool[k:k + size])
        k += size
        if single and any(c.feasible(design) for c in done):
            break
    return design, done, spent or (deadline is not None and time.perf_counter() >= deadline), refs


def _workers(jobs: int, scheduler: Any) -> int:
    """How many candidates one batch needs to keep every worker busy (a cluster: one per Dask worker)."""
    if scheduler is not None:
        from pkmstiff.evaluation.parallel import client

        return max(1, len(client(scheduler).scheduler_info().get("workers", {})))
    from pkmstiff.evaluation.parallel import resolve_workers

    return max(1, resolve_workers(jobs))


def _extras(design: Design, raw: dict, evaluation: DesignEvaluation,
            references: bool) -> tuple[Candidate | None, list[Candidate]]:
    """What is evaluated beside the candidates, checkpointed like one, not counted as one: the base machine where a
    constraint is relative to it or ``references`` are asked for, and (``references``) the list of the base and the
    design's references."""
    base = None
    if references or any(c.relative for c in design.constraints):
        base = Candidate(_variant_hash(raw, {}, evaluation), [], {}, {})
    if not references:
        return base, []
    return base, [base] + [Candidate(_reference_hash(r.machine, evaluation), [], {}, {}, machine=r.machine)
                           for r in design.references]


def _absolute(design: Design, base: Candidate | None) -> Design:
    """``design`` with its relative constraints' bounds resolved from the (evaluated) ``base`` machine's values."""
    if not any(c.relative for c in design.constraints):
        return design
    assert base is not None  # _extras asks for it
    cons = []
    for c in design.constraints:
        v = base.outputs.get(c.measure.label, float("nan"))
        if c.relative and (base.error or not math.isfinite(v) or v == 0.0):
            raise InadmissibleError(f"{design.source}: constraint {c.measure.name!r} is relative to the base "
                                    f"machine, whose value is {base.error or v}")
        cons.append(c.absolute(v))
    return dataclasses.replace(design, constraints=tuple(cons))


def _progress_line(design: Design, history: list[Candidate], budget: int, counts: dict[str, int],
                   elapsed: float) -> str:
    front = _front(design, history)
    best = ", ".join(f"{o.measure.name} {front[0].outputs[o.measure.label]:.6g} {o.measure.unit}"
                     for o in design.objectives) if front else "none feasible"
    return (f"{len(history)}/{budget} evaluations ({counts['evaluated']} run, {counts['cached']} cached), "
            f"{elapsed:.0f} s; best feasible so far: {best}")
