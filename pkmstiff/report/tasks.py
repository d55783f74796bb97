"""Where a report's work runs (issue 25): whole evaluations and section maps as tasks of the run's worker pool.

A local parallel run (``--jobs`` > 1 without ``--scheduler``) with at least :data:`WHOLE_TASKS_PER_WORKER`
evaluations per worker (one workspace or one section of one variant each) sends every evaluation to the pool as one
task, evaluated there serially: the same chunks and octree as a serial run, so the same bytes. With fewer evaluations
each one splits itself into tasks by its measured cost (:mod:`pkmstiff.evaluation.parallel`), one after another.
Either way every section map is one task of the pool, sent as soon as its section is complete for every variant (one
colour scale per quantity across the variants) and rendered there to PNG bytes that this process writes atomically.
Section results and map data cross between the processes as :class:`Compact` (their admissible entries only).
The 3-D workspace figures are rendered in this process while the workers work: VTK's off-screen context then starts
once, as in a serial run, instead of once per worker.

Serial runs and Dask runs evaluate and draw here, in order (on Dask each evaluation splits itself on the cluster).
"""

from __future__ import annotations

import time
from concurrent.futures import Future
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from pkmstiff.evaluation import parallel
from pkmstiff.evaluation.requests import SectionRequest
from pkmstiff.evaluation.sections import SectionResult
from pkmstiff.machine.model import Machine
from pkmstiff.workspace.requests import WorkspaceRequest
from pkmstiff.workspace.translational import WorkspaceResult

__all__ = ["WHOLE_TASKS_PER_WORKER", "ReportPlan", "Runner", "report_plan"]

#: whole evaluations per worker from which each evaluation is one task: with fewer, one long evaluation would keep
#: a worker busy while the others wait, so each evaluation splits itself instead
WHOLE_TASKS_PER_WORKER = 2


@dataclass(frozen=True)
class ReportPlan:
    """Where a report's ``evaluations`` evaluations, ``maps`` section maps and ``figures_3d`` workspace figures run:
    ``workers`` local workers (1: here), ``whole``: one task per evaluation, ``dask``: the cluster's address."""

    workers: int
    whole: bool
    evaluations: int
    maps: int
    figures_3d: int
    dask: str | None = None

    @property
    def pool(self) -> bool:
        """Tasks go to the local pool (maps always, evaluations when :attr:`whole`)."""
        return self.workers > 1 and self.dask is None

    def text(self) -> str:
        """The cost line's plan."""
        if self.dask is not None:
            return (f"sections and workspace on the Dask cluster {self.dask}, each split into tasks by its measured "
                    f"cost; figures here")
        if not self.pool:
            return "sections and workspace serially, each split into tasks by its measured cost; figures here"
        if self.whole:
            head = (f"on {self.workers} local workers: {self.evaluations} evaluations (workspace, sections) as one "
                    f"task each")
        else:
            head = f"sections and workspace on {self.workers} local workers, each split into tasks by its measured cost"
        maps = f"; {self.maps} maps as one task each once their section is done" if self.maps else ""
        figures = f"; {self.figures_3d} workspace figures here meanwhile" if self.figures_3d else ""
        return head + maps + figures


def report_plan(jobs: int, scheduler: Any, evaluations: int, maps: int, figures_3d: int) -> ReportPlan:
    """The :class:`ReportPlan` of ``jobs`` local workers (-1: all cores) or a Dask ``scheduler``."""
    workers = parallel.resolve_workers(jobs)
    if scheduler is not None:
        return ReportPlan(1, False, evaluations, maps, figures_3d, parallel.address(scheduler))
    whole = workers > 1 and evaluations >= WHOLE_TASKS_PER_WORKER * workers
    return ReportPlan(workers, whole, evaluations, maps, figures_3d)


def _done(value: Any) -> Future:
    f: Future = Future()
    f.set_result(value)
    return f


class Runner:
    """Starts a report's evaluations and maps by its :class:`ReportPlan`: in the local pool (futures not yet done)
    or here at once (futures already done); ``par`` = ``n_jobs``/``scheduler`` of an evaluation done here."""

    def __init__(self, plan: ReportPlan, par: dict[str, Any]) -> None:
        self.plan, self.par = plan, par
        self._shared: dict[int, parallel.Shared[Machine]] = {}

    def evaluate(self, request: SectionRequest | WorkspaceRequest, machine: Machine, figure: bool = False) -> Future:
        """A future of (result, seconds) of ``request`` on ``machine``; ``figure``: keep what the workspace figure
        draws (a whole task returns only what the report uses)."""
        if not self.plan.whole:
            return _done(evaluate_task(machine, request, figure, self.par))
        shared = self._shared.get(id(machine))
        if shared is None:  # pickled once per machine, not once per evaluation
            shared = self._shared[id(machine)] = parallel.Shared(machine)
        return parallel.submit(self.plan.workers, evaluate_task, shared, request, figure, {})

    def map_png(self, res: SectionResult, name: str, clim: tuple[float, float] | None) -> Future:
        """A future of the PNG bytes of the map of quantity ``name`` of ``res`` (colour scale ``clim``)."""
        res = replace(res, values={name: res.values[name]})  # the one quantity the map draws travels
        if not self.plan.pool:
            return _done(map_task(res, name, clim))
        return parallel.submit(self.plan.workers, map_task, Compact(res), name, clim)

    def result(self, future: Future) -> Any:
        """The result of a future of :meth:`evaluate` or :meth:`map_png` (a task's exception raised here)."""
        return parallel.result(future, self.plan.workers)


def evaluate_task(machine: Machine | parallel.Shared[Machine], request: SectionRequest | WorkspaceRequest,
                  figure: bool, par: dict[str, Any]) -> tuple[SectionResult | WorkspaceResult, float]:
    """(result, seconds) of one evaluation; a workspace without its ``figure`` leaves out the octree's lattice keys
    and edges and the surface (tens of MB at fine resolutions: the report uses the volumes)."""
    m = machine.get() if isinstance(machine, parallel.Shared) else machine
    t0 = time.perf_counter()
    res = request.evaluate(m, **par)
    seconds = time.perf_counter() - t0
    if isinstance(res, WorkspaceResult) and isinstance(machine, parallel.Shared):
        # the lattice keys are computed from the leaves on demand (cached properties, not carried by ``replace``)
        o = replace(res.octree, edges=None,
                    **({} if figure else {"leaf_table": None, "leaf_index": np.empty((0, 3), np.int64),
                                          "leaf_corners": np.empty((0, 8), bool)}))
        res = replace(res, octree=o, surface=res.surface if figure else None)
    if isinstance(res, SectionResult) and isinstance(machine, parallel.Shared):
        res = Compact(res)  # type: ignore[assignment]  (unpickles as the SectionResult)
    return res, seconds


def map_task(res: SectionResult, name: str, clim: tuple[float, float] | None) -> bytes:
    """The PNG bytes of one section map (:func:`pkmstiff.plots.section_maps.section_png`)."""
    from pkmstiff.plots.section_maps import section_png

    return section_png(res, name, clim=clim)


#: the bits of the NaN that marks a point without a value (``np.full(..., np.nan)``, as the section fills its arrays)
_NAN_BITS = np.array(np.nan).view(np.uint64)


class Compact:
    """A :class:`SectionResult` on its way between processes: each array that holds NaN exactly at the inadmissible
    points (values, κ) travels as its admissible entries only (6–17 % of the raster in the Hexaglide variants
    report) and is rebuilt bit for bit on arrival (:func:`_expand`); the object unpickles as the SectionResult
    itself."""

    def __init__(self, res: SectionResult) -> None:
        self.res = res

    def __reduce__(self) -> tuple:
        r = self.res
        out = ~r.ok
        packed = {k: _pack(v, r.ok, out) for k, v in r.values.items()}
        kappa = None if r.kappa is None else _pack(r.kappa, r.ok, out)
        return _expand, (replace(r, values={}, kappa=None), packed, kappa)


def _pack(a: np.ndarray, ok: np.ndarray, out: np.ndarray) -> tuple[bool, np.ndarray]:
    """(True, the entries at ``ok``) where every other entry is the plain NaN, else (False, ``a``)."""
    if a.shape == ok.shape and a.dtype == np.float64 and (a[out].view(np.uint64) == _NAN_BITS).all():
        return True, a[ok]
    return False, a


def _unpack(p: tuple[bool, np.ndarray], ok: np.ndarray) -> np.ndarray:
    packed, a = p
    if not packed:
        return a
    full = np.full(ok.shape, np.nan)
    full[ok] = a
    return full


def _expand(res: SectionResult, packed: dict[str, tuple[bool, np.ndarray]],
            kappa: tuple[bool, np.ndarray] | None) -> SectionResult:
    """The SectionResult of :meth:`Compact.__reduce__`."""
    res.values = {k: _unpack(p, res.ok) for k, p in packed.items()}
    res.kappa = None if kappa is None else _unpack(kappa, res.ok)
    return res


def common_clim(results: list[SectionResult], name: str) -> tuple[float, float] | None:
    """One colour scale of quantity ``name`` across the variants' sections (display unit): the range of its finite
    admissible values; None where they do not span a range."""
    finite = np.concatenate([v[np.isfinite(v)] for v in (r.display(name)[r.ok] for r in results)])
    return (float(finite.min()), float(finite.max())) if finite.size and finite.max() > finite.min() else None


def cost_bytes(parent_peak: float, evaluation_peak: float, plan: ReportPlan) -> float:
    """Peak memory of a report: this process's peak (its largest piece, as in a serial run) plus, for whole tasks,
    the peaks of the further evaluations that run at once (one per worker)."""
    at_once = min(plan.workers, plan.evaluations) if plan.whole else 1
    return parent_peak + max(at_once - 1, 0) * evaluation_peak

