"""Maximum admissible rotation angles on a raster (docs/theory/workspace.md, Cobet 4.1.5, eq. 4.21-4.24).

From the base orientation at every raster point, the angle in a direction (+a, -a, +b, -b, +a+b, -a-b, also +c, -c;
"+a+b" = equal simultaneous rotation) is raised in steps of ``increment`` until the pose becomes inadmissible; the
result is the last admissible angle (>= 0, rad), NaN where the base orientation itself is inadmissible.

Angles live on the lattice k * increment, k = 0 .. K = floor(max_angle / increment) (Assumption: max_angle 90 deg);
a point admissible up to K reports K * increment (``at_limit``).

* ``method="plain"``: incremental search from k = 0 at every point. Vectorised: all active raster points and all
  directions advance together in blocks of ``block`` increments; a point stops after the block holding its first
  inadmissible increment.
* ``method="predictor_corrector"``: the search at (u_n, v_m) starts at the prediction from the neighbours
  (eq. 4.21-4.24; two previous values -> linear extrapolation, one -> that value, none -> the base angle; the
  available directions averaged; NaN neighbours unavailable), rounded to the lattice (Note: so that the result is
  on the same lattice as the plain search and equals it whenever the admissible angles form one interval). If
  the prediction is admissible the angle is raised until inadmissible and the last admissible value stored (spec
  rule), otherwise lowered until admissible, bounded by the base angle, which is known admissible.
  Vectorisation: the predictor needs the results at (n-1, m), (n-2, m), (n, m-1), (n, m-2) only, so all points on
  one anti-diagonal n + m = const are independent: each anti-diagonal is corrected in lock-step (one evaluation
  per point and direction per step) for all directions at once. The stored angles are those of the printed
  row-by-row order.
* ``verify=True``: after each anti-diagonal, every increment between the base angle and the corrector's search
  range is checked; a point with an inadmissible gap gets the plain-search result (spec caveat). With it the
  result always equals the plain search.

The base-orientation check is done once per raster point and shared by all directions and both methods (in tasks of
whole chunks when the search runs in parallel).
Evaluation counts: ``evaluations[dir]`` = poses evaluated by the search in that direction (excluding the shared
base check); ``plain_sequential[dir]`` = what a plain search stopping at the first inadmissible increment needs
(k* + 2 per point, K + 1 at the limit, 0 outside): the reference for the savings.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any, Iterable, Literal, Sequence

import numpy as np
from numpy.typing import ArrayLike

import pkmstiff.admissibility.checks as adm
from pkmstiff.admissibility import fastpath
from pkmstiff.admissibility.fastpath import FUSED_CHUNK
from pkmstiff.admissibility.pipeline import admissible
from pkmstiff.errors import ArgumentError
from pkmstiff.evaluation import parallel
from pkmstiff.machine.model import Machine
from pkmstiff.machine.roles import drive_load_data
from pkmstiff.workspace import kernels
from pkmstiff.workspace.oracle import EvaluationStats, staged_admissible
from pkmstiff.workspace.requirements import Requirement, parse_requirements

DIRECTIONS: dict[str, tuple[int, int, int]] = {
    "+a": (1, 0, 0), "-a": (-1, 0, 0), "+b": (0, 1, 0), "-b": (0, -1, 0), "+a+b": (1, 1, 0), "-a-b": (-1, -1, 0),
    "+c": (0, 0, 1), "-c": (0, 0, -1),
}
SIX_DIRECTIONS = ("+a", "-a", "+b", "-b", "+a+b", "-a-b")
Method = Literal["predictor_corrector", "plain"]
#: the time of one direction's search in units of the base check of the raster: sizes the parallel tasks before any
#: search has run (measured 0.65-0.85 on the Hexaglide's yz maps of 1.5625-3.125 mm, six directions searched
#: together, both through the fused kernel; ~1.2 times more per direction in a task of three)
POSES_PER_POINT = 1.0




@dataclass
class RotationMapResult:
    """Maximum admissible angles (rad) per direction on a raster; arrays (nv, nu)."""

    u_values: np.ndarray
    v_values: np.ndarray
    base_poses: np.ndarray  # (nv, nu, 6)
    angles: dict[str, np.ndarray]  # rad, NaN where the base orientation is inadmissible
    at_limit: dict[str, np.ndarray]  # bool: admissible up to max_angle
    base_ok: np.ndarray  # (nv, nu) bool
    evaluations: dict[str, int]
    plain_sequential: dict[str, int]
    base_evaluations: int
    verify_corrections: dict[str, int]
    increment: float
    max_angle: float
    method: str
    settings: dict[str, Any] = field(default_factory=dict)
    #: how the directions were split over workers (:mod:`pkmstiff.evaluation.parallel`); not part of the written results
    plan: parallel.Plan | None = None

    @property
    def angle(self) -> np.ndarray:
        """The map of the only direction (error if there are several)."""
        if len(self.angles) != 1:
            raise ArgumentError(f"result holds {len(self.angles)} directions; use .angles[direction]")
        return next(iter(self.angles.values()))

    def savings(self) -> dict[str, dict[str, float]]:
        """Evaluations per direction vs the plain sequential search (both without the shared base check)."""
        out = {}
        for d in self.angles:
            e, p = self.evaluations[d], self.plain_sequential[d]
            out[d] = {"evaluations": e, "plain_sequential": p, "saved": p - e,
                      "saved_fraction": (p - e) / p if p else 0.0}
        return out

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary; keys name their units."""
        stats = {}
        for d, a in self.angles.items():
            fin = a[np.isfinite(a)]
            stats[d] = {"max_deg": float(np.degrees(fin.max())) if fin.size else None,
                        "mean_deg": float(np.degrees(fin.mean())) if fin.size else None,
                        "min_deg": float(np.degrees(fin.min())) if fin.size else None,
                        "points_at_limit": int(self.at_limit[d].sum())}
        return {"method": self.method, "increment_deg": math.degrees(self.increment),
                "max_angle_deg": math.degrees(self.max_angle),
                "raster": [int(len(self.v_values)), int(len(self.u_values))],
                "admissible_points": int(self.base_ok.sum()), "base_evaluations": self.base_evaluations,
                "angles": stats, "evaluations": self.savings(), "verify_corrections": self.verify_corrections,
                "settings": self.settings}


def _directions(direction: str | Sequence[str]) -> list[str]:
    dirs = [direction] if isinstance(direction, str) else list(direction)
    bad = [d for d in dirs if d not in DIRECTIONS]
    if bad or not dirs or len(set(dirs)) != len(dirs):
        raise ArgumentError(option="direction", expected=f"distinct names among {list(DIRECTIONS)}", found=direction)
    return dirs


def _values(v: ArrayLike, name: str) -> np.ndarray:
    arr = np.asarray(v, float).ravel()
    if arr.size == 0 or not np.isfinite(arr).all() or (arr.size > 1 and np.any(np.diff(arr) <= 0)):
        raise ArgumentError(option=name, found=v,
                            expected="a non-empty strictly increasing list of finite numbers")
    return arr


class _Evaluator:
    """Admissibility of poses (N, 6): :func:`pkmstiff.admissibility.pipeline.admissible` (the fused kernel in chunks)
    where it applies (no requirements), else :func:`pkmstiff.workspace.oracle.staged_admissible`."""

    def __init__(self, machine: Machine, checks: Sequence[str], reqs: Sequence[Requirement]):
        self.machine, self.checks, self.reqs = machine, tuple(checks), list(reqs)
        self.stats = EvaluationStats()
        self.load = drive_load_data(machine)
        self.fused = False  # set once the fused kernel applies (the compiled kernels load on the first large call)

    def __call__(self, poses: np.ndarray) -> np.ndarray:
        if len(poses) == 0:
            return np.zeros(0, bool)
        # usable(.., 1): the machine and the kernels, not the size
        self.fused = self.fused or (not self.reqs and fastpath.usable(self.machine, 1))
        if not self.fused:
            return staged_admissible(self.machine, poses, self.checks, self.reqs, self.stats)
        return admissible(self.machine, poses, self.checks, self.load)


def angle_search(
    machine: Machine,
    base_poses: np.ndarray,
    u_values: ArrayLike,
    v_values: ArrayLike,
    direction: str | Sequence[str] = SIX_DIRECTIONS,
    increment: float = math.radians(1.0),
    max_angle: float = math.radians(90.0),
    *,
    requirements: Iterable[str | Requirement] = (),
    checks: Sequence[str] = adm.ALL_CHECKS,
    method: Method = "predictor_corrector",
    verify: bool = False,
    block: int = 8,
    n_jobs: int = 1,
    scheduler: Any = None,
) -> RotationMapResult:
    """Maximum admissible angles from ``base_poses`` (nv, nu, 6) on the raster (u_values, v_values); see module doc.

    ``n_jobs`` > 1 (-1: all cores) / ``scheduler`` (Dask): the base check runs in tasks of whole chunks of
    :data:`FUSED_CHUNK` points (the first chunk here, timed), then the directions are searched as separate tasks in
    the run's worker pool / on the cluster (:mod:`pkmstiff.evaluation.parallel`; the searches of different directions
    do not interact, so the angles and counts are the same whatever the plan); the measured time of the first chunk,
    times the raster's points and :data:`POSES_PER_POINT`, sizes the search tasks; ``result.plan`` keeps the search's
    plan."""
    u, v = _values(u_values, "u_values"), _values(v_values, "v_values")
    base = np.asarray(base_poses, float)
    if base.shape != (v.size, u.size, 6) or not np.isfinite(base).all():
        raise ArgumentError(f"base_poses: expected finite values of shape ({v.size}, {u.size}, 6), "
                               f"found {base.shape}")
    if not (math.isfinite(increment) and increment > 0):
        raise ArgumentError(option="increment", expected="a positive angle in rad", found=increment)
    if not (math.isfinite(max_angle) and max_angle >= increment):
        raise ArgumentError(option="max_angle", expected="a finite angle >= increment (rad)", found=max_angle)
    if method not in ("predictor_corrector", "plain"):
        raise ArgumentError(option="method", expected="'predictor_corrector' or 'plain'", found=method)
    dirs = _directions(direction)
    reqs = parse_requirements(requirements)
    K = int(math.floor(max_angle / increment + 1e-9))
    dvec = np.zeros((len(dirs), 6))
    dvec[:, 3:] = np.array([DIRECTIONS[d] for d in dirs], float)
    parallel.resolve_workers(n_jobs)
    ev = _Evaluator(machine, checks, reqs)
    nv, nu = base.shape[:2]
    flat = base.reshape(-1, 6)
    base_evals = flat.shape[0]
    search = (u, v, increment, K, method, verify, block)
    with parallel.connected(scheduler):
        base_ok, point_seconds, shared = _base_check(ev, flat, n_jobs, scheduler)
        p = parallel.plan(len(dirs), point_seconds * flat.shape[0] * POSES_PER_POINT, n_jobs, scheduler,
                          granule=direction_group(len(dirs), n_jobs, scheduler))
        if p.parallel:
            shared = shared or parallel.Shared(machine)
            inside = flat[base_ok]
            parts = parallel.run_tasks(_search_task, [(shared, checks, reqs, (nv, nu), base_ok, inside, dvec[a:b],
                                                       search) for a, b in parallel.split(len(dirs), p)],
                                       p, scheduler)
            kbest = np.full((nv * nu, len(dirs)), -1, np.int64)
            kbest[base_ok] = np.concatenate([part[0] for part in parts], axis=1)
            evals, fixes = (np.concatenate([part[i] for part in parts]) for i in (1, 2))
        else:
            kbest, evals, fixes = _search(ev, flat.reshape(nv, nu, 6), base_ok, dvec, search)
    angles, at_limit, plain_seq = {}, {}, {}
    for j, d in enumerate(dirs):
        k = kbest[:, j]
        angles[d] = np.where(k >= 0, k * increment, np.nan).reshape(nv, nu)
        at_limit[d] = (k == K).reshape(nv, nu)
        plain_seq[d] = int(np.where(k < 0, 0, np.where(k == K, K, k + 1)).sum())  # k=0 is the shared base check
    settings = {"checks": list(checks), "checks_left_out": adm.checks_left_out(checks),
                "requirements": [r.text for r in reqs], "verify": verify,
                "block": block, "increments": K}
    return RotationMapResult(u, v, base, angles, at_limit, base_ok.reshape(nv, nu),
                             {d: int(evals[j]) for j, d in enumerate(dirs)}, plain_seq, base_evals,
                             {d: int(fixes[j]) for j, d in enumerate(dirs)}, float(increment), float(max_angle),
                             method, settings, plan=replace(p, items=len(dirs)))


def direction_group(n_directions: int, n_jobs: int, scheduler: Any = None) -> int:
    """Directions per task: a search evaluates all its directions in one batch per step, and every task makes about
    as many batches as the serial search (the anti-diagonals follow one another), each with a fixed cost (~0.25 ms:
    the corrector's bookkeeping and the kernel call, ~100 poses' worth), so local workers get one group of
    directions each (2 workers, 6 directions: 2 tasks of 3, not 6 tasks of 1)."""
    return 1 if scheduler is not None else math.ceil(n_directions / parallel.resolve_workers(n_jobs))


def _search(ev: _Evaluator, base: np.ndarray, base_ok: np.ndarray, dvec: np.ndarray,
            search: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(kbest (P, D) last admissible increment, -1 outside; evaluations (D,); corrections (D,)) of the directions
    ``dvec`` (D, 6) from the base poses (nv, nu, 6) with admissibility ``base_ok`` (P,)."""
    u, v, inc, K, method, verify, block = search
    nv, nu = base.shape[:2]
    D = dvec.shape[0]
    kbest = np.full((nv * nu, D), -1, np.int64)  # -1 = outside
    evals, fixes = np.zeros(D, np.int64), np.zeros(D, np.int64)
    if method == "plain":
        _plain(ev, base.reshape(-1, 6), base_ok, dvec, inc, K, block, kbest, evals)
    else:
        _predictor_corrector(ev, base, base_ok.reshape(nv, nu), u, v, dvec, inc, K, verify, kbest.reshape(nv, nu, -1),
                             evals, fixes)
    return kbest, evals, fixes


def _search_task(machine: parallel.Shared[Machine], checks: Sequence[str], reqs: Sequence[Requirement],
                 shape: tuple[int, int], base_ok: np.ndarray, inside: np.ndarray, dvec: np.ndarray,
                 search: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One task: :func:`_search` of some directions in a worker, from the base poses ``inside`` (those where
    ``base_ok``, the only ones a search evaluates); returns kbest of those points only, in the smallest integer
    type that holds it (-1 .. K), and the counts."""
    base = np.zeros((base_ok.size, 6))
    base[base_ok] = inside
    kbest, evals, fixes = _search(_Evaluator(machine.get(), checks, reqs), base.reshape(*shape, 6), base_ok, dvec,
                                  search)
    return kbest[base_ok].astype(np.min_scalar_type(-max(search[3], 1))), evals, fixes


def _base_check(ev: _Evaluator, flat: np.ndarray, n_jobs: int, scheduler: Any
                ) -> tuple[np.ndarray, float, parallel.Shared[Machine] | None]:
    """Admissibility of the base poses ``flat`` (P, 6): the first :data:`FUSED_CHUNK` here, timed (seconds per
    point, which sizes the tasks), the rest in tasks of whole chunks of :data:`FUSED_CHUNK` (the chunks the serial
    run evaluates) in the workers where that pays. Returns (base_ok, seconds per point, the machine as sent to the
    workers or None)."""
    t0 = time.perf_counter()
    first = ev(flat[:FUSED_CHUNK])
    seconds = (time.perf_counter() - t0) / max(min(len(flat), FUSED_CHUNK), 1)
    rest = flat[FUSED_CHUNK:]
    p = parallel.plan(len(rest), seconds, n_jobs, scheduler, granule=FUSED_CHUNK)
    if not p.parallel:
        return np.concatenate([first, ev(rest)]), seconds, None
    shared = parallel.Shared(ev.machine)
    parts = parallel.run_tasks(_base_task, [(shared, ev.checks, ev.reqs, rest[a:b])
                                            for a, b in parallel.split(len(rest), p)], p, scheduler)
    return np.concatenate([first, *parts]), seconds, shared


def _base_task(machine: parallel.Shared[Machine], checks: Sequence[str], reqs: Sequence[Requirement],
               poses: np.ndarray) -> np.ndarray:
    """One task of the base check: admissibility of ``poses`` in a worker."""
    return _Evaluator(machine.get(), checks, reqs)(poses)


def _plain(ev: _Evaluator, flat: np.ndarray, base_ok: np.ndarray, dvec: np.ndarray, inc: float, K: int,
           block: int, kbest: np.ndarray, evals: np.ndarray) -> None:
    """Plain incremental search, all points and directions in blocks of increments."""
    D = dvec.shape[0]
    pi, di = np.nonzero(np.repeat(base_ok[:, None], D, axis=1))
    kbest[pi, di] = 0
    k0 = 0
    while pi.size and k0 < K:
        ks = np.arange(k0 + 1, min(k0 + block, K) + 1)
        poses = flat[pi][:, None, :] + (ks[None, :, None] * inc) * dvec[di][:, None, :]
        ok = ev(poses.reshape(-1, 6)).reshape(pi.size, ks.size)
        np.add.at(evals, di, ks.size)
        first_bad = np.where(ok.all(axis=1), ks.size, np.argmin(ok, axis=1))
        kbest[pi, di] = k0 + first_bad  # last admissible increment
        go = first_bad == ks.size
        pi, di = pi[go], di[go]
        k0 = int(ks[-1])


def _predictor_corrector(ev: _Evaluator, base: np.ndarray, base_ok: np.ndarray, u: np.ndarray, v: np.ndarray,
                         dvec: np.ndarray, inc: float, K: int, verify: bool, kbest: np.ndarray,
                         evals: np.ndarray, fixes: np.ndarray) -> None:
    nv, nu, D = kbest.shape
    f = np.full((nv, nu, D), np.nan)  # results in rad (NaN = outside / not yet computed)
    for diag in range(nu + nv - 1):
        m = np.arange(max(0, diag - nu + 1), min(nv, diag + 1))
        n = diag - m
        inside = base_ok[m, n]
        m, n = m[inside], n[inside]
        if m.size == 0:
            continue
        pred = _prediction(f, u, v, m, n)  # (P, D) rad
        k = np.clip(np.rint(pred / inc), 0, K).astype(np.int64)
        k_start = k.copy()
        P = m.size
        pts = base[m, n]  # (P, 6)
        # first step: evaluate the prediction (k = 0 is the base orientation, known admissible)
        ok = np.ones((P, D), bool)
        need = k > 0
        ok[need] = _eval(ev, pts, dvec, inc, need, k, evals)
        up = ok.copy()  # searching upwards from an admissible prediction
        result = np.where(ok, k, -1)
        active = np.where(up, k < K, True)
        cur = k.copy()
        while active.any():
            _steps(ev, pts, dvec, inc, K, active, up, cur, result, evals)
        if verify:
            lo_checked = np.minimum(k_start, np.maximum(result, 0))  # the search covered [lo_checked, ...]
            result, nfix = _verify(ev, pts, dvec, inc, result, lo_checked, evals)
            fixes += nfix
        kbest[m, n] = result
        f[m, n] = result * inc


#: when few searches of an anti-diagonal are still walking, each batch evaluates up to this many next increments of
#: each at once (a batch costs ~0.25 ms besides its poses, ~100 poses' worth; larger look-aheads evaluated more
#: poses than they saved batches, measured with the fused kernel at 2 mm); only the increments the one-at-a-time
#: search evaluates are counted and used, so the angles and counts are those of that search
LOOKAHEAD = 4
#: ... as long as the batch holds at most this many poses
LOOKAHEAD_POSES = 64


def _steps(ev: _Evaluator, pts: np.ndarray, dvec: np.ndarray, inc: float, K: int, active: np.ndarray, up: np.ndarray,
           cur: np.ndarray, result: np.ndarray, evals: np.ndarray) -> None:
    """One batch of the corrector (in place on ``active``, ``cur``, ``result``, ``evals``; (P, D) C-ordered arrays):
    each active search walks from ``cur`` upwards (``up``; to the last admissible increment ≤ K) or downwards (to the
    first admissible increment; increment 0 is the base orientation, admissible) by up to L increments (compiled
    bookkeeping around the evaluation, :func:`pkmstiff.workspace.kernels.corrector_poses` / ``corrector_update``: a
    batch's fixed cost was ~0.25 ms of numpy calls, paid again by every parallel task)."""
    D = active.shape[1]
    # flat views (C-ordered arrays): the kernels write through them
    act, up1, cur1, res1 = active.reshape(-1), up.reshape(-1), cur.reshape(-1), result.reshape(-1)
    at, n, L, poses = kernels.corrector_poses(act, up1, cur1, D, K, LOOKAHEAD, LOOKAHEAD_POSES, pts, dvec, inc)
    ok = ev(poses)
    kernels.corrector_update(at, n, L, ok, D, K, up1, cur1, res1, act, evals)


def _prediction(f: np.ndarray, u: np.ndarray, v: np.ndarray, m: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Predicted angles (eq. 4.21-4.24) at raster points (m, n) for all directions, (P, D)."""
    D = f.shape[2]
    total = np.zeros((m.size, D))
    count = np.zeros((m.size, D))
    for along_u in (True, False):
        i = n if along_u else m
        c = u if along_u else v

        def at(off):
            ok = i - off >= 0
            vals = np.full((m.size, D), np.nan)
            sel = np.flatnonzero(ok)
            if along_u:
                vals[sel] = f[m[sel], n[sel] - off]
            else:
                vals[sel] = f[m[sel] - off, n[sel]]
            return vals

        f1, f2 = at(1), at(2)
        c0 = c[i]
        c1 = c[np.maximum(i - 1, 0)]
        c2 = c[np.maximum(i - 2, 0)]
        with np.errstate(invalid="ignore", divide="ignore"):
            lin = f1 + (f1 - f2) / (c1 - c2)[:, None] * (c0 - c1)[:, None]  # eq. 4.22 / 4.23
        two = np.isfinite(f1) & np.isfinite(f2)
        one = np.isfinite(f1) & ~two
        est = np.where(two, lin, np.where(one, f1, 0.0))  # eq. 4.24 for one neighbour
        have = two | one
        total += np.where(have, est, 0.0)
        count += have
    return np.where(count > 0, total / np.maximum(count, 1), 0.0)  # eq. 4.21; none: the base angle


def _eval(ev: _Evaluator, pts: np.ndarray, dvec: np.ndarray, inc: float, mask: np.ndarray, k: np.ndarray,
          evals: np.ndarray) -> np.ndarray:
    """Admissibility at angle k * inc for the (point, direction) pairs in ``mask``; counts per direction."""
    pi, di = np.nonzero(mask)
    poses = pts[pi] + (k[pi, di] * inc)[:, None] * dvec[di]
    np.add.at(evals, di, 1)
    return ev(poses)


def _verify(ev: _Evaluator, pts: np.ndarray, dvec: np.ndarray, inc: float, result: np.ndarray, lo_checked: np.ndarray,
            evals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Check increments 1 .. lo_checked - 1 below the corrector's range; on a gap take the plain result."""
    pi, di = np.nonzero(lo_checked > 1)
    D = result.shape[1]
    nfix = np.zeros(D, np.int64)
    if pi.size == 0:
        return result, nfix
    counts = lo_checked[pi, di] - 1
    rep = np.repeat(np.arange(pi.size), counts)
    ks = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts) + 1
    poses = pts[pi[rep]] + (ks * inc)[:, None] * dvec[di[rep]]
    ok = ev(poses)
    np.add.at(evals, di[rep], 1)
    bad_k = np.where(ok, np.iinfo(np.int64).max, ks)
    first_bad = np.full(pi.size, np.iinfo(np.int64).max)
    np.minimum.at(first_bad, rep, bad_k)
    gap = first_bad < np.iinfo(np.int64).max
    out = result.copy()
    out[pi[gap], di[gap]] = first_bad[gap] - 1
    np.add.at(nfix, di[gap], 1)
    return out, nfix


def _raster_points(origin: ArrayLike, u_axis: ArrayLike, v_axis: ArrayLike, u: np.ndarray, v: np.ndarray,
                   names: tuple[str, str, str]) -> np.ndarray:
    o, a, b = (np.asarray(x, float) for x in (origin, u_axis, v_axis))
    for arr, nm in ((o, names[0]), (a, names[1]), (b, names[2])):
        if arr.shape != (3,) or not np.isfinite(arr).all():
            raise ArgumentError(f"{nm}: expected 3 finite numbers, found {arr.tolist()}")
    return o + u[None, :, None] * a + v[:, None, None] * b  # (nv, nu, 3)


def rotation_angle_map(
    machine: Machine,
    origin: ArrayLike,
    u_axis: ArrayLike,
    v_axis: ArrayLike,
    u_values: ArrayLike,
    v_values: ArrayLike,
    base_orientation: ArrayLike = (0.0, 0.0, 0.0),
    direction: str | Sequence[str] = "+a",
    increment: float = math.radians(1.0),
    max_angle: float = math.radians(90.0),
    requirements: Iterable[str | Requirement] = (),
    method: Method = "predictor_corrector",
    verify: bool = False,
    **kw: Any,
) -> RotationMapResult:
    """Maximum admissible angles on a section raster: positions origin + u * u_axis + v * v_axis (m).

    ``base_orientation`` (a, b, c) in rad; ``direction`` one name or several (searched together);
    ``increment``, ``max_angle`` in rad. Returns a :class:`RotationMapResult` (angles (nv, nu) rad, NaN outside).
    """
    u, v = _values(u_values, "u_values"), _values(v_values, "v_values")
    pos = _raster_points(origin, u_axis, v_axis, u, v, ("origin", "u_axis", "v_axis"))
    ori = np.asarray(base_orientation, float)
    if ori.shape != (3,) or not np.isfinite(ori).all():
        raise ArgumentError(option="base_orientation", expected="three finite angles in rad", found=base_orientation)
    base = np.concatenate([pos, np.broadcast_to(ori, pos.shape)], axis=-1)
    res = angle_search(machine, base, u, v, direction, increment, max_angle, requirements=requirements,
                       method=method, verify=verify, **kw)
    res.settings.update({"origin_m": np.asarray(origin, float).tolist(), "u_axis": np.asarray(u_axis, float).tolist(),
                         "v_axis": np.asarray(v_axis, float).tolist(),
                         "base_orientation_deg": np.degrees(ori).tolist()})
    return res


def rotational_workspace_map(
    machine: Machine,
    point: ArrayLike,
    direction: str = "+a",
    u_values: ArrayLike = np.radians(np.arange(-30.0, 30.1, 2.0)),
    v_values: ArrayLike = np.radians(np.arange(-60.0, 60.1, 4.0)),
    base_orientation: ArrayLike = (0.0, 0.0, 0.0),
    increment: float = math.radians(1.0),
    max_angle: float = math.radians(90.0),
    **kw: Any,
) -> RotationMapResult:
    """Rotational workspace at a point (docs/theory/workspace.md): the maximum angle in ``direction`` over a raster of the two
    other angles — "+a as a function of (b, c)" (u = b, v = c) or "+b as a function of (a, c)" (u = a, v = c).

    ``point`` (x, y, z) in m; raster values in rad, added to ``base_orientation``.
    """
    dirs = _directions(direction)
    if len(dirs) != 1 or len(direction) != 2:
        raise ArgumentError(f"direction: expected one single-axis direction such as '+a' or '-b', "
                               f"found {direction!r}")
    axis = "abc".index(direction[1])
    others = [i for i in range(3) if i != axis]
    u, v = _values(u_values, "u_values"), _values(v_values, "v_values")
    p = np.asarray(point, float)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise ArgumentError(option="point", expected="x, y, z (3 finite numbers, m)", found=point)
    base = np.zeros((v.size, u.size, 6))
    base[..., :3] = p
    base[..., 3:] = np.asarray(base_orientation, float)
    base[..., 3 + others[0]] += u[None, :]
    base[..., 3 + others[1]] += v[:, None]
    res = angle_search(machine, base, u, v, direction, increment, max_angle, **kw)
    res.settings.update({"point_m": p.tolist(), "u_angle": "abc"[others[0]], "v_angle": "abc"[others[1]]})
    return res
