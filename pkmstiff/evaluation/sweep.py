"""Parameter sweeps over machine-file values: grid or random, run serially, in local processes or on Dask.

A sweep is a base machine (bundled name with ``:options`` or a path), parameters — each a dotted path into the
machine file's raw tables (``components.strut_950.k``, ``chains[3].platform_joint``,
``joint_types.iwf_3dof.tilt_min``; see :mod:`pkmstiff.machine.variants`) with a list of values (grid: Cartesian
product) or a distribution (random: ``n_samples`` draws from a seeded generator) — and an evaluation: a function
of the modified machine returning named numbers (ready-made ones in :mod:`pkmstiff.report.sweep_evaluations`).

Every task is the pure function :func:`run_task` of a picklable :class:`SweepTask`; a failing task records its
error message in its row and never stops the sweep. Serial, local-parallel (the run's worker pool) and Dask
(``dask.distributed.Client(address)``) execution give identical rows in task order; tasks travel in batches, about
four per local worker, on Dask sized by the measured time of a task run here first
(:mod:`pkmstiff.evaluation.parallel`).

    from pkmstiff.evaluation.sweep import Parameter, Sweep, run_sweep
    from pkmstiff.report.sweep_evaluations import SectionStatistics
    sweep = Sweep("hexaglide", [Parameter("components.strut_950.k", values=(200, 344, 500), unit="N/um")],
                  SectionStatistics(("kx",), range="y=-200:800,z=-1100:-500", step_mm=25))
    result = run_sweep(sweep, n_jobs=2)                 # or scheduler="tcp://10.0.0.5:8786"
    result.to_csv("sweep.csv")
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from pkmstiff.errors import ArgumentError
from pkmstiff.evaluation.parallel import (
    MIN_LOCAL_TASK_SECONDS,
    Plan,
    connected,
    plan,
    resolve_workers,
    run_tasks,
    split,
)
from pkmstiff.evaluation.progress import callback as progress_callback
from pkmstiff.io.atomic import atomic_open, atomic_write_text
from pkmstiff.io.columns import label_column, sidecar_path, text_cell
from pkmstiff.machine.model import Machine

__all__ = ["Uniform", "LogUniform", "Normal", "Choice", "Parameter", "Sweep", "SweepTask",
           "SweepResult", "grid_points", "random_points", "run_task", "run_sweep"]




# ----------------------------------------------------------------------------------------------------- distributions
@dataclass(frozen=True)
class Uniform:
    """Uniform on [low, high] (in the parameter's unit)."""

    low: float
    high: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.high > self.low):
            raise ArgumentError(f"Uniform: expected finite low < high, found low={self.low!r}, high={self.high!r}")

    def sample(self, rng: np.random.Generator, n: int) -> list[float]:
        return [float(v) for v in rng.uniform(self.low, self.high, n)]


@dataclass(frozen=True)
class LogUniform:
    """log-uniform on [low, high], 0 < low < high (for stiffnesses spanning decades)."""

    low: float
    high: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.low) and math.isfinite(self.high) and 0 < self.low < self.high):
            raise ArgumentError(f"LogUniform: expected 0 < low < high, found low={self.low!r}, high={self.high!r}")

    def sample(self, rng: np.random.Generator, n: int) -> list[float]:
        return [float(v) for v in np.exp(rng.uniform(math.log(self.low), math.log(self.high), n))]


@dataclass(frozen=True)
class Normal:
    """Normal(mean, std), optionally clipped to [low, high] (e.g. a tolerance band)."""

    mean: float
    std: float
    low: float = -math.inf
    high: float = math.inf

    def __post_init__(self) -> None:
        if not (math.isfinite(self.mean) and math.isfinite(self.std) and self.std > 0 and self.high > self.low):
            raise ArgumentError(f"Normal: expected a finite mean, std > 0 and low < high, found mean={self.mean!r}, "
                             f"std={self.std!r}, low={self.low!r}, high={self.high!r}")

    def sample(self, rng: np.random.Generator, n: int) -> list[float]:
        return [float(v) for v in np.clip(rng.normal(self.mean, self.std, n), self.low, self.high)]


@dataclass(frozen=True)
class Choice:
    """One of the given values, each equally likely."""

    values: tuple[Any, ...]

    def __post_init__(self) -> None:
        if len(self.values) == 0:
            raise ArgumentError("Choice: expected at least one value, found none")

    def sample(self, rng: np.random.Generator, n: int) -> list[Any]:
        return [self.values[int(i)] for i in rng.integers(0, len(self.values), n)]


Distribution = Uniform | LogUniform | Normal | Choice


# -------------------------------------------------------------------------------------------------------- parameters
@dataclass(frozen=True)
class Parameter:
    """A swept machine-file value.

    ``path``: dotted path into the machine file (1-based ``chains[i]``, ``chains[*]``). ``values``: grid values;
    ``distribution``: for random sweeps (a parameter with only ``values`` is sampled as a :class:`Choice`).
    ``unit``: unit of numeric values (``"N/um"``, ``"deg"``, ``"mm"``) — the override is written as
    ``"<value> <unit>"``, exactly as in a machine file; None = values as written in a machine file (bare numbers SI,
    strings with units, lists).
    """

    path: str
    values: tuple[Any, ...] = ()
    distribution: Distribution | None = None
    unit: str | None = None

    def __post_init__(self) -> None:
        from pkmstiff.machine.variants import parse_override_path

        parse_override_path(self.path)  # raises InputError for a malformed path
        object.__setattr__(self, "values", tuple(self.values))
        if self.unit is not None:
            from pkmstiff.units import ureg

            try:
                ureg()(self.unit)
            except Exception:
                raise ArgumentError(f"parameter '{self.path}': expected a unit such as 'N/um' or 'deg', "
                                 f"found unit={self.unit!r}") from None
            bad = [v for v in self.values if isinstance(v, bool) or not isinstance(v, (int, float))]
            if bad:
                raise ArgumentError(f"parameter '{self.path}': with unit {self.unit!r} the values must be numbers, "
                                 f"found {bad[0]!r}")

    @property
    def column(self) -> str:
        """Column name in the results: the path, with the unit in brackets if given."""
        return f"{self.path} [{self.unit}]" if self.unit else self.path

    def override(self, value: Any) -> Any:
        """The value as written into the machine file."""
        if self.unit is not None and isinstance(value, (int, float)) and not isinstance(value, bool):
            return f"{float(value)!r} {self.unit}"
        return value


def _as_parameters(parameters: Iterable[Parameter] | Mapping[str, Any]) -> tuple[Parameter, ...]:
    if isinstance(parameters, Mapping):
        out = []
        for path, spec in parameters.items():
            if isinstance(spec, (Uniform, LogUniform, Normal, Choice)):
                out.append(Parameter(path, distribution=spec))
            else:
                out.append(Parameter(path, values=tuple(spec)))
        return tuple(out)
    params = tuple(parameters)
    if not all(isinstance(p, Parameter) for p in params):
        raise ArgumentError("parameters: expected Parameter objects or a mapping path -> values/distribution")
    return params


def grid_points(parameters: Iterable[Parameter] | Mapping[str, Any]) -> list[dict[str, Any]]:
    """Cartesian product of the parameters' values, the first parameter varying slowest: [{path: value}]."""
    params = _as_parameters(parameters)
    for p in params:
        if not p.values:
            raise ArgumentError(f"parameter '{p.path}': a grid sweep needs a list of values, found none"
                             + (" (it has a distribution: use mode 'random')" if p.distribution else ""))
    return [dict(zip((p.path for p in params), combo)) for combo in itertools.product(*(p.values for p in params))]


def random_points(parameters: Iterable[Parameter] | Mapping[str, Any], n: int, seed: int) -> list[dict[str, Any]]:
    """``n`` random points: each parameter drawn from its distribution (or its values, uniformly) with one
    ``numpy.random.default_rng(seed)``, parameter by parameter in order (the same seed gives the same points)."""
    params = _as_parameters(parameters)
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ArgumentError(option="n_samples", expected="a positive integer", found=n)
    rng = np.random.default_rng(seed)
    cols = []
    for p in params:
        dist = p.distribution if p.distribution is not None else (Choice(p.values) if p.values else None)
        if dist is None:
            raise ArgumentError(f"parameter '{p.path}': a random sweep needs a distribution or values, found neither")
        cols.append(dist.sample(rng, n))
    return [{p.path: col[i] for p, col in zip(params, cols)} for i in range(n)]


# ---------------------------------------------------------------------------------------------------------- tasks
Evaluation = Callable[[Machine], Mapping[str, float]]


@dataclass(frozen=True)
class SweepTask:
    """One machine variant to evaluate: everything a worker needs (picklable if the evaluation is)."""

    index: int
    machine: str
    values: Mapping[str, Any]  # parameter path -> sampled value (in the parameter's unit)
    overrides: Mapping[str, Any]  # dotted path -> value as written in the machine file (base + parameters)
    columns: Mapping[str, str]  # parameter path -> result column
    evaluation: Evaluation


def run_task(task: SweepTask) -> dict[str, Any]:
    """Build the modified machine, evaluate it, return the result row; any error is recorded, never raised.

    Row: ``task`` (index), one column per parameter, the evaluation's outputs (floats) and ``error`` ("" if none).
    """
    from pkmstiff.machine.variants import machine_with

    row: dict[str, Any] = {"task": task.index}
    for path, value in task.values.items():
        row[task.columns[path]] = value
    try:
        machine = machine_with(task.machine, task.overrides)
        out = task.evaluation(machine)
        if not isinstance(out, Mapping):
            raise ArgumentError(f"the evaluation returned {type(out).__name__}, expected a mapping name -> number")
        for name, value in out.items():
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
                raise ArgumentError(option=f"output {name!r}", expected="a number", found=value)
            row[str(name)] = float(value)
        row["error"] = ""
    except Exception as exc:  # noqa: BLE001 - one bad variant must not stop the sweep; the row names the error
        row["error"] = f"{type(exc).__name__}: {exc}"
    return row


@dataclass(frozen=True)
class Sweep:
    """A sweep definition; :meth:`tasks` expands it into independent tasks."""

    machine: str
    parameters: tuple[Parameter, ...] | Mapping[str, Any]
    evaluation: Evaluation
    mode: str = "grid"  # "grid" | "random"
    n_samples: int = 0  # random
    seed: int = 0  # random
    base_overrides: Mapping[str, Any] = field(default_factory=dict)  # applied to every task before the parameters

    def __post_init__(self) -> None:
        object.__setattr__(self, "parameters", _as_parameters(self.parameters))
        if self.mode not in ("grid", "random"):
            raise ArgumentError(option="mode", expected="'grid' or 'random'", found=self.mode)
        if self.mode == "random" and (isinstance(self.n_samples, bool) or not isinstance(self.n_samples, int)
                                      or self.n_samples < 1):
            raise ArgumentError(f"n_samples: a random sweep needs a positive number of samples, "
                                f"found {self.n_samples!r}")
        paths = [p.path for p in self.parameters]
        dup = sorted({p for p in paths if paths.count(p) > 1})
        if dup:
            raise ArgumentError(f"parameters: each path at most once, found {dup[0]!r} twice")
        if not callable(self.evaluation):
            raise ArgumentError(option="evaluation", expected="a function of the machine", found=self.evaluation)

    @property
    def n_tasks(self) -> int:
        """Number of tasks, without expanding them (a grid's product of value counts can be astronomical)."""
        if self.mode == "grid":
            return math.prod(len(p.values) for p in self.parameters)
        return int(self.n_samples)

    def points(self) -> list[dict[str, Any]]:
        """Parameter values per task: [{path: value}]."""
        if self.mode == "grid":
            return grid_points(self.parameters)
        return random_points(self.parameters, self.n_samples, self.seed)

    def tasks(self) -> list[SweepTask]:
        by_path = {p.path: p for p in self.parameters}
        columns = {p.path: p.column for p in self.parameters}
        out = []
        for i, point in enumerate(self.points()):
            overrides = dict(self.base_overrides)
            overrides.update({path: by_path[path].override(v) for path, v in point.items()})
            out.append(SweepTask(i, str(self.machine), point, overrides, columns, self.evaluation))
        return out


# -------------------------------------------------------------------------------------------------------- results
@dataclass
class SweepResult:
    """Rows in task order: ``task``, parameter columns, output columns, ``error``."""

    rows: list[dict[str, Any]]
    parameter_columns: list[str]
    metadata: dict[str, Any] = field(default_factory=dict)
    wall_time_s: float = float("nan")
    #: how the tasks were split over workers (not written to the CSV: rows are the same whatever the plan)
    plan: Plan | None = None

    @property
    def output_columns(self) -> list[str]:
        seen: dict[str, None] = {}
        skip = {"task", "error", *self.parameter_columns}
        for r in self.rows:
            for k in r:
                if k not in skip:
                    seen.setdefault(k, None)
        return list(seen)

    @property
    def columns(self) -> list[str]:
        return ["task", *self.parameter_columns, *self.output_columns, "error"]

    @property
    def failed(self) -> list[dict[str, Any]]:
        return [r for r in self.rows if r.get("error")]

    def column(self, name: str) -> np.ndarray:
        """Values of one column over the tasks (NaN where a task has no value, e.g. it failed)."""
        if name not in self.columns:
            raise KeyError(f"no column {name!r}; columns: {self.columns}")
        vals = [r.get(name) for r in self.rows]
        if all(v is None or isinstance(v, (int, float)) for v in vals):
            return np.array([np.nan if v is None else float(v) for v in vals])
        return np.array(vals, dtype=object)

    def to_csv(self, path: str | Path) -> Path:
        """A plain CSV (``pandas.read_csv(path)`` reads it with no options): one header row, named by the file rule
        (:func:`pkmstiff.io.columns.label_column`: ``kx_N_per_um``), and one row per task (empty = no value); the
        metadata and the map from file columns to result labels go to ``<name>.json`` beside it."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        cols = self.columns
        meta = {k: v for k, v in self.metadata.items()}
        meta["columns"] = {label_column(c): c for c in cols}
        atomic_write_text(sidecar_path(path), json.dumps(meta, indent=2, default=str))
        with atomic_open(path, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow([label_column(c) for c in cols])
            for r in self.rows:
                w.writerow(["" if r.get(c) is None else (repr(r[c]) if isinstance(r[c], float) else text_cell(r[c]))
                            for c in cols])
        return path


def _run_batch(tasks: Sequence[SweepTask]) -> list[dict[str, Any]]:
    return [run_task(t) for t in tasks]


def _run_timed_batch(tasks: Sequence[SweepTask]) -> tuple[list[dict[str, Any]], float]:
    """The rows of ``tasks`` and the seconds they took (in the worker)."""
    t0 = time.perf_counter()
    return _run_batch(tasks), time.perf_counter() - t0


def _run(tasks: Sequence[SweepTask], n_jobs: int, scheduler: Any, progress: bool) -> tuple[list[dict[str, Any]], Plan]:
    """Rows in task order. In the local pool every task goes to the workers at once, in batches sized as if a task took
    :data:`~pkmstiff.evaluation.parallel.MIN_LOCAL_TASK_SECONDS` (a sweep task builds and evaluates a machine: far
    longer), about four per worker, and none runs here: with as many workers as cores a task here would share a core
    with a worker, and the one task more that one worker then ended with made the 12-task Hexaglide sweep about 6 %
    slower on 2 workers (docs/user-guide/parallel.md). The plan's cost per task is the workers' mean. On Dask or
    serially the first task (on Dask the first two) runs here and the measured time of the last of them sizes
    batches of the others (:func:`pkmstiff.evaluation.parallel.plan`; too little work stays serial)."""
    if scheduler is None and len(tasks) > 1 and resolve_workers(n_jobs) > 1:
        p = plan(len(tasks), MIN_LOCAL_TASK_SECONDS, n_jobs)
        batches = split(len(tasks), p)
        step = progress_callback(len(batches), progress, "sweep", "batch")
        done = run_tasks(_run_timed_batch, [(tasks[a:b],) for a, b in batches], p, None, step)
        return [r for rows, _ in done for r in rows], replace(p, item_seconds=sum(s for _, s in done) / len(tasks))
    t0 = time.perf_counter()
    first = [run_task(tasks[0])] if tasks else []
    rest = list(tasks[1:])
    if scheduler is not None and len(rest) > 1:
        # the first task carries this process's one-off costs (3–5 times a later task measured on the Hexaglide
        # strut sweep, which then went to a cluster that finished later): a second one sizes the plan
        t0 = time.perf_counter()
        first.append(run_task(rest.pop(0)))
    p = plan(len(rest), time.perf_counter() - t0, n_jobs, scheduler)
    batches = split(len(rest), p if p.parallel else replace(p, task_items=1))
    step = progress_callback(len(batches), progress, "sweep" if scheduler is None else "sweep (dask)", "batch")
    done = run_tasks(_run_batch, [(rest[a:b],) for a, b in batches], p, scheduler, step)
    return first + [r for batch in done for r in batch], replace(p, items=len(tasks))


def run_sweep(sweep: Sweep | Sequence[SweepTask], *, n_jobs: int = 1, scheduler: Any = None,
              progress: bool = False) -> SweepResult:
    """Run every task of ``sweep`` and collect the rows in task order.

    ``scheduler``: a Dask scheduler address (``"tcp://host:8786"``) or a ``dask.distributed.Client`` — the tasks
    are submitted to that cluster (``n_jobs`` is ignored). Otherwise ``n_jobs`` = 1 runs serially, > 1 (or -1 =
    all cores) in the run's local worker pool, all tasks on the workers; serially and on Dask the first task runs
    here and its time sizes batches of the others (:mod:`pkmstiff.evaluation.parallel`). All give identical rows;
    ``result.plan`` says how the work was split.
    """
    tasks = sweep.tasks() if isinstance(sweep, Sweep) else list(sweep)
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, int) or n_jobs == 0:
        raise ArgumentError(option="n_jobs", expected="a non-zero integer (-1: all cores)", found=n_jobs)
    t0 = time.perf_counter()
    with connected(scheduler):
        rows, p = _run(tasks, n_jobs, scheduler, progress)
    rows = sorted(rows, key=lambda r: r["task"])
    meta: dict[str, Any] = {}
    pcols: list[str] = []
    if isinstance(sweep, Sweep):
        pcols = [p.column for p in sweep.parameters]
        meta = {"machine": sweep.machine, "mode": sweep.mode, "tasks": len(tasks),
                "parameters": ", ".join(pcols), "evaluation": repr(sweep.evaluation)}
        if sweep.mode == "random":
            meta.update({"n_samples": sweep.n_samples, "seed": sweep.seed})
        if sweep.base_overrides:
            meta["base_overrides"] = dict(sweep.base_overrides)
    elif tasks:
        pcols = list(dict.fromkeys(c for t in tasks for c in t.columns.values()))
    meta["failed"] = sum(1 for r in rows if r.get("error"))
    return SweepResult(rows, pcols, meta, time.perf_counter() - t0, p)
