"""Admissibility of points of a workspace: a pose with some coordinates free (docs/theory/workspace.md).

:class:`PoseOracle` turns a machine, a base pose and the free coordinates into the predicate the octree and the
rotation-angle searches need: ``oracle(points (N, k)) -> bool (N,)`` with the points written into the free
columns of the base pose (positions: columns x, y, z; rotational workspace: a, b, c).

Evaluation is staged; the result equals ``evaluate_poses(...).ok`` with the same checks and requirements:

1. inverse kinematics and the drive-range check (B.1/B.2) for all points — cheap, and it removes the many
   unreachable points around a workspace boundary;
2. the full pipeline (:func:`pkmstiff.admissibility.pipeline.evaluate_poses`: joint angles, singularity, collisions, drive load)
   for the survivors;
3. the user requirements (:mod:`pkmstiff.workspace.requirements`) only for the poses admissible so far.

Workspace with one variable orientation range (docs/theory/workspace.md Table 4.1/4.2 Note): ``orientation_range=("c", lo, hi)``
samples that angle from lo to hi (both included) at ``range_step``; mode ``"all"`` (Merlet, Table 4.1) needs every
sample admissible, ``"any"`` (Table 4.2: c chosen to avoid collisions and singularities) needs at least one.
Samples are evaluated one after the other, each only for the points still undecided.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Iterable, Literal, Sequence

import numpy as np
from numpy.typing import ArrayLike

import pkmstiff.admissibility.checks as adm
from pkmstiff.admissibility import fastpath
from pkmstiff.admissibility.pipeline import admissible, evaluate_poses
from pkmstiff.errors import ArgumentError
from pkmstiff.evaluation import parallel
from pkmstiff.evaluation.quantities import EvalContext
from pkmstiff.kinematics import inverse_kinematics
from pkmstiff.machine.model import Machine
from pkmstiff.machine.roles import drive_load_data
from pkmstiff.workspace.octree import Subtree, SubtreeTask, refine_subtree
from pkmstiff.workspace.requirements import Requirement, parse_requirements

ANGLE_INDEX = {"a": 3, "b": 4, "c": 5}
RangeMode = Literal["all", "any"]




@dataclass
class EvaluationStats:
    """Counts (poses) and times (s) of the admissibility evaluations."""

    points: int = 0  # points asked for (one per octree corner / search step)
    poses: int = 0  # poses evaluated (points x orientation samples actually needed)
    full_pipeline: int = 0  # poses that reached stage 2
    requirement_poses: int = 0  # poses on which requirements were evaluated
    time_prefilter: float = 0.0
    time_pipeline: float = 0.0
    time_requirements: float = 0.0

    @property
    def time(self) -> float:
        return self.time_prefilter + self.time_pipeline + self.time_requirements

    def as_dict(self) -> dict[str, float]:
        return {"points": self.points, "poses_evaluated": self.poses, "full_pipeline_poses": self.full_pipeline,
                "requirement_poses": self.requirement_poses, "time_prefilter_s": self.time_prefilter,
                "time_pipeline_s": self.time_pipeline, "time_requirements_s": self.time_requirements}


#: the per-point counters of :meth:`PoseOracle.counted`, the :class:`EvaluationStats` fields they add up to
POINT_COUNTERS = ("poses", "full_pipeline", "requirement_poses")


def staged_admissible(machine: Machine, poses: np.ndarray, checks: Sequence[str] = adm.ALL_CHECKS,
                      requirements: Sequence[Requirement] = (), stats: EvaluationStats | None = None,
                      prefilter: bool = True, chunk_size: int = 20_000, tool_length: float | None = None,
                      per_pose: np.ndarray | None = None) -> np.ndarray:
    """(N,) admissibility of poses (N, 6), identical to ``evaluate_poses`` + requirements (see module doc).
    ``per_pose`` (N, 3) int: adds the :data:`POINT_COUNTERS` of every pose (1 or 0 each)."""
    st = stats if stats is not None else EvaluationStats()
    out = np.zeros(len(poses), bool)
    if per_pose is not None:
        per_pose[:, 0] += 1
    staged = prefilter and "drive_range" in checks
    # without requirements the full pipeline is the fused kernel (the same admissibility bit for bit,
    # tests/test_pose_fast_path.py): a small batch (the octree's closure passes of a few hundred points) in one call,
    # ~0.1 ms against ~2 ms of the staged array path; a larger one after the prefilter, which spares most outside
    # points the full pipeline, on the poses it leaves (~20 % less time than the array pipeline on them)
    fusable = not requirements and fastpath.usable(machine, 1)
    whole = fusable and 0 < len(poses) <= fastpath.FUSED_CHUNK  # a chunk: one call (pipeline.admissible's)
    load = drive_load_data(machine) if fusable else None
    for s in range(0, len(poses), chunk_size):
        x = poses[s:s + chunk_size]
        st.poses += len(x)
        t0 = time.perf_counter()
        reasons = fastpath.reasons_small(machine, np.ascontiguousarray(x), checks, load) if whole else None
        if reasons is not None:  # a pose ruled out by the prefilter's checks would not have reached the pipeline
            live = (reasons & _PREFILTER) == 0 if staged else np.ones(len(x), bool)
            st.full_pipeline += int(np.count_nonzero(live))
            if per_pose is not None:
                per_pose[s + np.flatnonzero(live), 1] += 1
            out[s:s + len(x)] = reasons == 0
            st.time_pipeline += time.perf_counter() - t0
            continue
        if staged:
            ik = inverse_kinematics(machine, x)
            live = adm.check_drive_range(machine, ik.drive, ik.reachable).ok & ik.all_reachable
        else:
            live = np.ones(len(x), bool)
        t1 = time.perf_counter()
        st.time_prefilter += t1 - t0
        idx = np.flatnonzero(live)
        if idx.size == 0:
            continue
        if fusable:
            ok = admissible(machine, x[idx], checks, load)
        else:
            ev = evaluate_poses(machine, x[idx], checks=checks, chunk_size=chunk_size)
            ok = ev.ok
        st.full_pipeline += idx.size
        if per_pose is not None:
            per_pose[s + idx, 1] += 1
            if requirements:
                per_pose[s + idx[ok], 2] += 1
        t2 = time.perf_counter()
        st.time_pipeline += t2 - t1
        if requirements and ok.any():
            sub = ev if ok.all() else ev.subset(ok)
            ctx = EvalContext(machine, sub, tool_length)
            met = np.ones(int(ok.sum()), bool)
            for r in requirements:
                met &= r.evaluate(ctx)
            st.requirement_poses += int(ok.sum())
            ok = ok.copy()
            ok[ok] = met
            st.time_requirements += time.perf_counter() - t2
        out[s + idx] = ok
    return out


#: the reasons of the prefilter (inverse kinematics and drive ranges) of :func:`staged_admissible`
_PREFILTER = np.uint32(adm.Reason.UNREACHABLE | adm.Reason.DRIVE_RANGE)


class PoseOracle:
    """Predicate ``points (N, k) -> bool (N,)``: admissibility of ``base_pose`` with ``free`` columns replaced."""

    def __init__(
        self,
        machine: Machine,
        base_pose: ArrayLike = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        free: Sequence[int] = (0, 1, 2),
        *,
        requirements: Iterable[str | Requirement] = (),
        checks: Sequence[str] = adm.ALL_CHECKS,
        orientation_range: tuple[str, float, float] | None = None,
        range_step: float = math.radians(2.0),
        range_mode: RangeMode = "all",
        prefilter: bool = True,
        chunk_size: int = 20_000,
        n_jobs: int = 1,
        scheduler: Any = None,
    ):
        base = np.asarray(base_pose, float)
        if base.shape != (6,) or not np.isfinite(base).all():
            raise ArgumentError(f"base_pose: expected 6 finite numbers (x, y, z [m], a, b, c [rad]), "
                                   f"found {base_pose!r}")
        self.free = tuple(int(f) for f in free)
        if not self.free or any(f < 0 or f > 5 for f in self.free) or len(set(self.free)) != len(self.free):
            raise ArgumentError(option="free", expected="distinct pose columns in 0..5", found=free)
        unknown = set(checks) - set(adm.ALL_CHECKS)
        if unknown:
            raise ArgumentError(f"checks: unknown {sorted(unknown)}; expected a subset of {adm.ALL_CHECKS}")
        self.machine, self.base, self.checks = machine, base, tuple(checks)
        self.requirements = parse_requirements(requirements)
        self.prefilter, self.chunk_size = prefilter, chunk_size
        self.stats = EvaluationStats()
        self.range_mode = range_mode
        self.range_samples = self._range_samples(orientation_range, range_step, range_mode)
        workers = parallel.resolve_workers(n_jobs)
        self.n_jobs, self.scheduler = n_jobs, scheduler
        self._point_seconds: float | None = None  # measured on the last call evaluated here
        #: threads this process may use for its own compiled work (the octree's mesh and volumes): the local workers'
        #: cores, idle by then (1 serially or on Dask, whose workers are elsewhere)
        self.threads = workers if scheduler is None else 1
        self._shared: parallel.Shared[PoseOracle] | None = None
        self.plans: list[parallel.Plan] = []  # one per call split over workers

    def _range_samples(self, rng, step, mode) -> tuple[int, np.ndarray] | None:
        if rng is None:
            return None
        if mode not in ("all", "any"):
            raise ArgumentError(option="range_mode", expected="'all' or 'any'", found=mode)
        try:
            name, lo, hi = rng
            col = ANGLE_INDEX[str(name)]
        except (KeyError, TypeError, ValueError):
            raise ArgumentError(f"orientation_range: expected (angle 'a'|'b'|'c', lo [rad], hi [rad]), "
                                   f"found {rng!r}") from None
        if col in self.free:
            raise ArgumentError(f"orientation_range: angle {name!r} is a free coordinate of the oracle")
        if not (np.isfinite(lo) and np.isfinite(hi) and hi >= lo and step > 0):
            raise ArgumentError(f"orientation_range: expected finite lo <= hi and a positive step, "
                                   f"found {rng!r}, step {step!r}")
        n = max(1, math.ceil((hi - lo) / step - 1e-9)) + 1
        return col, np.linspace(lo, hi, n)

    def poses(self, points: np.ndarray) -> np.ndarray:
        pts = np.asarray(points, float).reshape(len(points), -1)
        if pts.shape[1] != len(self.free):
            raise ArgumentError(f"points: expected shape (N, {len(self.free)}), found {np.shape(points)}")
        x = np.repeat(self.base[None], len(pts), axis=0)
        x[:, list(self.free)] = pts
        return x

    def admissible_poses(self, poses: np.ndarray, per_point: np.ndarray | None = None) -> np.ndarray:
        """(N,) admissibility of full poses (N, 6), honouring the orientation range; ``per_point`` (N, 3): adds the
        :data:`POINT_COUNTERS` of each pose's point."""
        if self.range_samples is None:
            return staged_admissible(self.machine, poses, self.checks, self.requirements, self.stats,
                                     self.prefilter, self.chunk_size, per_pose=per_point)
        col, samples = self.range_samples
        want_all = self.range_mode == "all"
        result = np.full(len(poses), want_all)
        undecided = np.ones(len(poses), bool)
        for v in samples:
            idx = np.flatnonzero(undecided)
            if idx.size == 0:
                break
            x = poses[idx].copy()
            x[:, col] = v
            sub = None if per_point is None else np.zeros((idx.size, len(POINT_COUNTERS)), np.int64)
            ok = staged_admissible(self.machine, x, self.checks, self.requirements, self.stats,
                                   self.prefilter, self.chunk_size, per_pose=sub)
            if per_point is not None:
                per_point[idx] += sub
            decided = ~ok if want_all else ok  # "all": one failure decides; "any": one success decides
            result[idx[decided]] = not want_all
            undecided[idx[decided]] = False
        return result

    def __call__(self, points: np.ndarray) -> np.ndarray:
        self.stats.points += len(points)
        poses = self.poses(points)
        p = None
        if (self.n_jobs != 1 or self.scheduler is not None) and self._point_seconds is not None:
            p = parallel.plan(len(poses), self._point_seconds, self.n_jobs, self.scheduler, granule=self.chunk_size)
        if p is None or not p.parallel:  # serial; its time sizes the next call's tasks
            t0 = time.perf_counter()
            out = self.admissible_poses(poses)
            self._point_seconds = (time.perf_counter() - t0) / max(len(poses), 1)
            return out
        self.plans.append(p)
        (a0, b0), *rest = parallel.split(len(poses), p)
        parts = self.run_split(_oracle_task, [(poses[a:b],) for a, b in rest], p,
                               lambda: self.admissible_poses(poses[a0:b0]))
        return np.concatenate(parts)

    def counted(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Admissibility of ``points`` here and the :data:`POINT_COUNTERS` of each point (N, 3) (an octree's
        :data:`~pkmstiff.workspace.octree.CountedPredicate`: points evaluated twice are taken out exactly)."""
        self.stats.points += len(points)
        per = np.zeros((len(points), len(POINT_COUNTERS)), np.int64)
        return self.admissible_poses(self.poses(points), per), per

    def run_split(self, task: Callable[..., tuple[Any, dict[str, float]]], payloads: list[tuple], p: parallel.Plan,
                  here: Callable[[], Any], here_last: bool = False) -> list[Any]:
        """``[here(), task(shared oracle, *payloads[0]), ...]``: ``here()`` in this process while the workers run the
        payloads (as a section's first chunk; with ``here_last`` once every payload has started,
        :func:`~pkmstiff.evaluation.parallel.run_tasks`); the statistics of all parts are added to this oracle's."""
        if self._shared is None:
            worker = copy.copy(self)
            worker.n_jobs, worker.scheduler, worker.stats, worker._shared = 1, None, EvaluationStats(), None
            self._shared = parallel.Shared(worker)
        t0 = time.perf_counter()
        first: list[tuple[Any, dict[str, float]]] = []

        def run_first() -> None:
            before = dataclasses.asdict(self.stats)
            first.append(_stats_delta(self, here))
            for k, v in before.items():  # merged below like a worker's part
                setattr(self.stats, k, v)

        parts = first + parallel.run_tasks(task, [(self._shared, *a) for a in payloads], p, self.scheduler,
                                           meanwhile=run_first, meanwhile_last=here_last)
        wall = time.perf_counter() - t0
        times = [k for k in dataclasses.asdict(self.stats) if k.startswith("time_")]
        busy = sum(st[k] for _, st in parts for k in times)
        for _, st in parts:  # counts add up; the workers' times are scaled to this call's wall time (they overlap)
            for k, v in st.items():
                setattr(self.stats, k, getattr(self.stats, k) + (v * wall / busy if k in times and busy > 0 else v))
        return [out for out, _ in parts]

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "scheduler": None, "_shared": None}


def _stats_delta(o: PoseOracle, fn: Callable[[], Any]) -> tuple[Any, dict[str, float]]:
    """``fn()`` and what it added to ``o``'s statistics."""
    before = dataclasses.asdict(o.stats)
    out = fn()
    return out, {k: v - before[k] for k, v in dataclasses.asdict(o.stats).items()}


def _oracle_task(oracle: parallel.Shared[PoseOracle], poses: np.ndarray) -> tuple[np.ndarray, dict[str, float]]:
    """One parallel task: admissibility of ``poses`` and the evaluation counts/times it added (a compact array and a
    small dict)."""
    o = oracle.get()
    return _stats_delta(o, lambda: o.admissible_poses(poses))


def _subtree_task(oracle: parallel.Shared[PoseOracle], task: SubtreeTask) -> tuple[Subtree, dict[str, float]]:
    """One octree subtree refined in a worker (:func:`~pkmstiff.workspace.octree.refine_subtree`) and the evaluation
    counts/times it added."""
    o = oracle.get()
    return _stats_delta(o, lambda: refine_subtree(task, o.counted))


#: a subtree task holds at least this many voxels of the level it starts from: the work per voxel varies with the
#: boundary area inside it, and many voxels per task even that out
SUBTREE_VOXELS = 16


class OracleSubtrees:
    """The octree's :class:`~pkmstiff.workspace.octree.SubtreeRunner` on the oracle's workers (local pool or Dask):
    subtrees are cut as soon as a level has enough boundary voxels for the plan's tasks; the plan is sized from the
    oracle's measured time per point and the evaluations the remaining levels will take."""

    def __init__(self, oracle: PoseOracle):
        self.oracle = oracle
        self.plan: parallel.Plan | None = None

    def slices(self, level: int, voxels: int, evaluations: float) -> int:
        o = self.oracle
        if (o.n_jobs == 1 and o.scheduler is None) or o._point_seconds is None:
            return 0
        p = parallel.plan(voxels, o._point_seconds * evaluations / voxels, o.n_jobs, o.scheduler)
        if not p.parallel or voxels < SUBTREE_VOXELS * p.tasks:
            return 0
        self.plan = p
        o.plans.append(p)
        return p.tasks

    def bounds(self, voxels: int, n_slices: int) -> np.ndarray:
        """Slices falling in size (:func:`~pkmstiff.evaluation.parallel.guided_bounds`): the workers take them in
        order, this process the last."""
        assert self.plan is not None
        return parallel.guided_bounds(voxels, n_slices, self.plan.workers + 1)

    def run(self, tasks: list[SubtreeTask]) -> list[Subtree]:
        o, p = self.oracle, self.plan
        assert p is not None
        # this process takes the last (shortest) slice once every other has started: it shares the cores with the
        # workers' last slices, so that all three end together instead of one worker waiting for the other
        here, *others = o.run_split(_subtree_task, [(t,) for t in tasks[:-1]], p,
                                    lambda: refine_subtree(tasks[-1], o.counted), here_last=True)
        return [*others, here]

    def uncount(self, points: int, counts: np.ndarray) -> None:
        st = self.oracle.stats
        st.points -= points
        for name, c in zip(POINT_COUNTERS, counts):
            setattr(st, name, getattr(st, name) - int(c))
