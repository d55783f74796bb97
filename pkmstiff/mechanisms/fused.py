"""The whole damped Newton solve of one pose in one compiled call (issue 27 item 6: speed of the generic solver).

Same iteration as :func:`pkmstiff.mechanisms.solver.newton` (DE 10 2004 026 707 A1 [0019], [0051]): residual and
analytic Jacobian (:func:`pkmstiff.mechanisms.kernel._eval_pose`), the normal-equation step with its σ-ratio
estimate (:func:`pkmstiff.mechanisms.linalg._normal_pose`, here on link blocks), the incremental rotation-vector
update of the link rotations, Armijo halving — but per pose in compiled code with per-thread work arrays of one
pose, so no (N, m, n) Jacobian stack is built, zeroed or copied, and no Python runs between the phases.

The unknowns are grouped in blocks of six per free link (δt, δω; a fixed coordinate is padded with a decoupled
unit pivot), the blocks ordered once per system by a minimum-degree elimination order of the link graph (links
joined by a constraint are neighbours; :func:`elimination_order`): a link that only touches the ground and one other
link (a strut of a 6-UPS leg) comes before the link it joins.  The normal equations are then a block Cholesky
(Schur) elimination with fixed-size 6 × 6 kernels (:func:`pkmstiff.mechanisms.linalg._block_normal_pose`) over
the block pattern of JᵀJ with the fill of that order (:func:`pkmstiff.mechanisms.linalg.block_pattern`): for the
6-UPS each strut's block is eliminated onto the platform's Schur complement.  Derived from the constraints' links
at load, so any spatial mechanism file (6-RUS, hybrid, Hexaglide) takes the same path.

A pose whose σ-ratio estimate is below the screen (rank deficient or badly conditioned: the pivoted-QR step is
needed) stops with the code ``FALLBACK`` at its current iterate; the solver finishes it with the numpy loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from pkmstiff.mechanisms.kernel import _angles, _eval_pose, _exp_left, _scratch
from pkmstiff.mechanisms.linalg import BLOCK, _block_normal_pose, _block_solve, block_pattern, block_start

Array = NDArray[np.float64]

#: status codes of :func:`newton`
CONVERGED, NO_SOLUTION, MAX_ITER, FALLBACK = 0, 1, 2, 3
#: poses per work chunk (one set of work arrays each) and the pose count from which the chunks run in parallel
_CHUNK = 64
PARALLEL_MIN = 2048


@dataclass
class FusedPlan:
    """Column order, block structure and index maps of a spatial
    :class:`~pkmstiff.mechanisms.constraints.System` for the fused Newton kernel; built once per system
    (:func:`fused_plan`).  The solve columns are 6 per free link (block), blocks in elimination order; a link with
    fixed coordinates pads them (column −1 in ``cols``)."""

    cmap: np.ndarray  #: (L·6,) full column → solve column, −1 for fixed coordinates
    cols: np.ndarray  #: (6·nb,) full column of each solve column, −1 on the padding
    rot_links: np.ndarray  #: (nl,) links updated by incremental rotation vectors
    rot_cols: np.ndarray  #: (nl, 3) their rotation columns (solve columns)
    rb: np.ndarray  #: (m_s, 2) blocks each solved row touches (−1: none)
    nptr: np.ndarray  #: block pattern of JᵀJ with fill (:func:`linalg.block_pattern`)
    nidx: np.ndarray
    slot: np.ndarray
    nslots: int
    pad: np.ndarray  #: (nb, 6) 1.0 on padded coordinates
    x0: np.ndarray  #: (6·nb,) inverse-iteration start vector (:func:`linalg.block_start`)


def elimination_order(n_links: int, edges: list[tuple[int, int]], active: np.ndarray) -> list[int]:
    """Minimum-degree elimination order of the ``active`` links of a graph (edges between links that share a
    constraint): repeatedly the link with the fewest remaining neighbours (ties: fewest neighbours in the whole
    graph, then lowest index: hubs last), whose neighbours then become mutually adjacent (the fill of eliminating
    it)."""
    adj = [set() for _ in range(n_links)]
    for a, b in edges:
        if a != b and active[a] and active[b]:
            adj[a].add(b)
            adj[b].add(a)
    left = set(np.flatnonzero(active).tolist())
    deg0 = [len(a) for a in adj]
    order = []
    while left:
        li = min(left, key=lambda x: (len(adj[x] & left), deg0[x], x))
        nb = adj[li] & left
        for x in nb:
            adj[x] |= nb - {x}
        left.remove(li)
        order.append(li)
    return order


def fused_plan(system) -> FusedPlan:
    """The :class:`FusedPlan` of a spatial system, cached on it."""
    fp = system.__dict__.get("_fused_plan")
    if fp is not None:
        return fp
    d = system.mech.dof_per_link
    L = len(system.mech.links)
    free = system.free
    has_free = np.zeros(L, dtype=bool)
    has_free[free // d] = True
    edges = [(int(a), int(b)) for bl in system.blocks for a, b in zip(bl.j, bl.k) if b >= 0]
    order = elimination_order(L, edges, has_free)
    blk = np.full(L, -1, dtype=np.int64)
    blk[order] = np.arange(len(order))
    nb = len(order)
    cmap = np.full(system.n, -1, dtype=np.int64)
    cmap[free] = BLOCK * blk[free // d] + free % d
    cols = np.full(BLOCK * nb, -1, dtype=np.int64)
    cols[cmap[free]] = free
    pad = (cols < 0).astype(float).reshape(nb, BLOCK)
    rot_links = np.flatnonzero(system.omega_links).astype(np.int64)
    rot_cols = cmap[rot_links[:, None] * d + system.mech.dim + np.arange(3)].astype(np.int64).reshape(-1, 3)
    pat_cols, cnt = system.sparsity
    rb = np.full((cnt.size, 2), -1, dtype=np.int64)
    for i in range(cnt.size):
        b = np.unique(blk[free[pat_cols[i, :cnt[i]]] // d])
        if b.size > 2:
            raise ValueError(f"fused_plan: row {i} joins {b.size} links (a constraint joins two)")
        rb[i, :b.size] = b
    nptr, nidx, slot, nslots = block_pattern(nb, [(int(a), int(b)) for a, b in rb if b >= 0])
    fp = FusedPlan(cmap, cols, rot_links, rot_cols, rb, nptr, nidx, slot, nslots, pad, block_start(pad))
    system.__dict__["_fused_plan"] = fp
    return fp


def _step(q, Rq, qt, Rtr, dx, alpha, cols, rot_links, rot_cols):  # pragma: no cover - compiled
    """(qt, Rtr) ← (q, Rq) after the step α·dx: positions and the angles of the other links add; the rotation of a
    rotation-vector link becomes exp([α δω]×) R (its angles in qt are not updated: :func:`_sync_angles`)."""
    qt[:] = q
    for c in range(cols.shape[0]):
        if cols[c] >= 0:
            qt[cols[c]] += alpha * dx[c]
    for i in range(rot_links.shape[0]):
        l = rot_links[i]
        _exp_left(alpha * dx[rot_cols[i, 0]], alpha * dx[rot_cols[i, 1]], alpha * dx[rot_cols[i, 2]], Rq[l], Rtr[l])


def _sync_angles(q, Rq, rot_links):  # pragma: no cover - compiled
    """The angles of the rotation-vector links in q from their rotations (:func:`constraints.link_angles`)."""
    for i in range(rot_links.shape[0]):
        l = rot_links[i]
        R = Rq[l]
        _angles(R[0, 0], R[1, 0], R[2, 0], R[0, 1], R[1, 1], R[0, 2], R[1, 2], q[6 * l + 3:6 * l + 6])


def _newton_chunk(q, target, om, Rt, kind, lj, lk, row, coord, value, P, A, B, m, roff, cmap, cols, rot_links,
                  rot_cols, rb, nptr, nidx, slot, nslots, pad, x0, tol, max_iter, max_backtrack, screen, sweeps,
                  armijo, status, iters, resid, rcond, steps, n0, n1):  # pragma: no cover - compiled
    L = q.shape[1] // 6
    ni = kind.shape[0]
    n = cols.shape[0]
    ms = m - roff
    S = _scratch(L)
    r = np.empty(m)
    rt = np.empty(m)
    # zeroed once: every evaluation writes the same structural entries (the constraint instances' links)
    J = np.zeros((ms, n))
    Jt = np.zeros((ms, n))
    Jd = np.zeros((1, 1))
    qc = np.empty(q.shape[1])
    qt = np.empty(q.shape[1])
    dx = np.empty(n)
    Ab = np.empty((nslots, BLOCK, BLOCK))
    g = np.empty(n)
    xw = np.empty(n)
    Rc = np.empty((L, 3, 3))
    Rtr = np.empty((L, 3, 3))
    Rs = S[1]
    a2 = (1.0 - armijo) ** 2
    for p in range(n0, n1):
        tn = target[min(p, target.shape[0] - 1)]
        Rtn = Rt[min(p, Rt.shape[0] - 1)]
        qc[:] = q[p]
        _eval_pose(qc, tn, om, Rtn, kind, lj, lk, row, coord, value, P, A, B, roff, cmap, True, r, J, L, ni, S,
                   False)
        Rc[:] = Rs
        st = MAX_ITER
        it_ = 0
        acc = 0
        for it_ in range(max_iter + 1):
            rn = 0.0
            r2 = 0.0
            for i in range(roff, m):
                v = r[i]
                r2 += v * v
                if not abs(v) <= rn:  # NaN propagates
                    rn = abs(v)
            resid[p] = rn
            if rn <= tol:
                st = CONVERGED
                break
            if it_ == max_iter:
                break
            est = _block_normal_pose(J, r[roff:], rb, nptr, nidx, slot, pad, x0, sweeps, Ab, g, xw, dx)
            if not est >= screen:
                st = FALLBACK
                break
            rcond[p] = est
            _step(qc, Rc, qt, Rtr, dx, 1.0, cols, rot_links, rot_cols)
            Rs[:] = Rtr
            _eval_pose(qt, tn, om, Rtn, kind, lj, lk, row, coord, value, P, A, B, roff, cmap, True, rt, Jt, L, ni, S,
                       True)
            t2 = 0.0
            tmax = 0.0
            for i in range(roff, m):
                v = rt[i]
                t2 += v * v
                if not abs(v) <= tmax:
                    tmax = abs(v)
            if math.isfinite(t2) and (t2 <= a2 * r2 or tmax <= tol):  # accepted: its r, J next
                qc[:] = qt
                Rc[:] = Rtr
                acc += 1
                r, rt = rt, r
                J, Jt = Jt, J
                continue
            alpha = 0.5
            ok = False
            for _ in range(max_backtrack):
                _step(qc, Rc, qt, Rtr, dx, alpha, cols, rot_links, rot_cols)
                Rs[:] = Rtr
                _eval_pose(qt, tn, om, Rtn, kind, lj, lk, row, coord, value, P, A, B, roff, cmap, False, rt, Jd, L,
                           ni, S, True)
                t2 = 0.0
                for i in range(roff, m):
                    t2 += rt[i] * rt[i]
                if math.isfinite(t2) and t2 <= (1.0 - armijo * alpha) ** 2 * r2:
                    ok = True
                    break
                alpha *= 0.5
            if not ok:
                st = CONVERGED if rn <= 10.0 * tol else NO_SOLUTION
                break
            qc[:] = qt
            Rc[:] = Rtr
            acc += 1
            Rs[:] = Rc
            _eval_pose(qc, tn, om, Rtn, kind, lj, lk, row, coord, value, P, A, B, roff, cmap, True, r, J, L, ni, S,
                       True)
        _sync_angles(qc, Rc, rot_links)
        q[p] = qc
        status[p] = st
        iters[p] = acc
        steps[p] = it_


def _newton_impl(q, target, om, Rt, kind, lj, lk, row, coord, value, P, A, B, m, roff, cmap, cols, rot_links, rot_cols,
                 rb, nptr, nidx, slot, nslots, pad, x0, tol, max_iter, max_backtrack, screen, sweeps, armijo, status,
                 iters, resid, rcond, steps):  # pragma: no cover - compiled
    N = q.shape[0]
    for ch in numba.prange((N + _CHUNK - 1) // _CHUNK):
        _newton_chunk(q, target, om, Rt, kind, lj, lk, row, coord, value, P, A, B, m, roff, cmap, cols, rot_links,
                      rot_cols, rb, nptr, nidx, slot, nslots, pad, x0, tol, max_iter, max_backtrack, screen, sweeps,
                      armijo, status, iters, resid, rcond, steps, ch * _CHUNK, min(N, (ch + 1) * _CHUNK))


_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}
_step = numba.njit(**_OPTS)(_step)
_sync_angles = numba.njit(**_OPTS)(_sync_angles)
_newton_chunk = numba.njit(**_OPTS)(_newton_chunk)
_newton_parallel = numba.njit(parallel=True, **_OPTS)(_newton_impl)


@numba.njit(**_OPTS)
def _newton_serial(q, target, om, Rt, kind, lj, lk, row, coord, value, P, A, B, m, roff, cmap, cols, rot_links,
                   rot_cols, rb, nptr, nidx, slot, nslots, pad, x0, tol, max_iter, max_backtrack, screen, sweeps,
                   armijo, status, iters, resid, rcond, steps):  # pragma: no cover - compiled
    _newton_chunk(q, target, om, Rt, kind, lj, lk, row, coord, value, P, A, B, m, roff, cmap, cols, rot_links,
                  rot_cols, rb, nptr, nidx, slot, nslots, pad, x0, tol, max_iter, max_backtrack, screen, sweeps,
                  armijo, status, iters, resid, rcond, steps, 0, q.shape[0])


def newton(system, q: Array, target: Array | None, Rt: Array | None, tol: float, max_iter: int, max_backtrack: int,
           screen: float, sweeps: int, armijo: float) -> tuple[Array, Array, Array, Array, Array, Array]:
    """Damped Newton per pose in compiled code on q (N, L·6) (fixed coordinates already set); returns q, status
    code (N,) (:data:`CONVERGED` … :data:`FALLBACK`), accepted steps, max |F|, the σ-ratio estimate of the last step
    (NaN without a step) and the Newton iterations spent (the remaining budget of a ``FALLBACK`` pose)."""
    fp = fused_plan(system)
    plan = system.plan
    N = q.shape[0]
    q = np.ascontiguousarray(q, dtype=float).copy()
    tg = np.zeros((1, 1)) if target is None else np.ascontiguousarray(target, dtype=float)
    rt = np.zeros((1, 3, 3)) if Rt is None else np.ascontiguousarray(Rt, dtype=float)
    status = np.empty(N, dtype=np.int64)
    iters = np.zeros(N, dtype=np.int64)
    resid = np.full(N, np.inf)
    rcond = np.full(N, np.nan)
    steps = np.zeros(N, dtype=np.int64)
    kern = _newton_parallel if N >= PARALLEL_MIN else _newton_serial
    kern(q, tg, system._om, rt, plan.kind, plan.j, plan.k, plan.row, plan.coord, plan.value, plan.p, plan.a, plan.b,
         system.m, system.n_fixed_rows, fp.cmap, fp.cols, fp.rot_links, fp.rot_cols, fp.rb, fp.nptr, fp.nidx, fp.slot,
         fp.nslots, fp.pad, fp.x0, float(tol), int(max_iter), int(max_backtrack), float(screen), int(sweeps),
         float(armijo), status, iters, resid, rcond, steps)
    return q, status, iters, resid, rcond, steps


def _outjac_chunk(q, target, om, kind, lj, lk, row, coord, value, P, A, B, m, roff, cmap, rb, nptr, nidx, slot, nslots,
                  pad, x0, drive_rows, olink, opoint, ocoords, orient, oaxis, out, n0,
                  n1):  # pragma: no cover - compiled
    L = q.shape[1] // 6
    ni = kind.shape[0]
    n = BLOCK * slot.shape[0]
    ms = m - roff
    nd = drive_rows.shape[0]
    S = _scratch(L)
    r = np.empty(m)
    rhs = np.zeros(ms)
    J = np.zeros((ms, n))
    X = np.empty((nd, n))
    Ab = np.empty((nslots, BLOCK, BLOCK))
    g = np.empty(n)
    xw = np.empty(n)
    Rt = np.zeros((3, 3))
    w = np.empty(3)
    Dw = np.empty((3, 3))
    G = np.zeros((out.shape[1], n))
    e1 = np.empty(3)
    e2 = np.empty(3)
    R, dR, Wr = S[1], S[2], S[3]
    co = 6 * olink
    g0 = 0
    for c in range(6):
        if cmap[co + c] >= 0:
            g0 = cmap[co + c] - cmap[co + c] % BLOCK
    for p in range(n0, n1):
        _eval_pose(q[p], target[p], om, Rt, kind, lj, lk, row, coord, value, P, A, B, roff, cmap, True, r, J, L, ni,
                   S, False)
        # q_s: F_q q_s = e_c on each drive row c (least squares by the normal equations, one factor for all c)
        rhs[:] = 0.0
        rhs[drive_rows[0]] = -1.0
        if not _block_normal_pose(J, rhs, rb, nptr, nidx, slot, pad, x0, 0, Ab, g, xw, X[0]) > 0.0:
            out[p] = np.nan
            continue
        for c in range(1, nd):
            for i in range(n):
                X[c, i] = J[drive_rows[c], i]
            _block_solve(Ab, nptr, nidx, slot, X[c])
        # G = ∂x_c/∂q of the output link's columns (point rows, then ω or the axis turn about e1, e2)
        G[:] = 0.0
        nc = ocoords.shape[0]
        for a in range(3):
            w[a] = 0.0
        for a in range(3):
            for c in range(3):
                Dw[a, c] = (dR[olink, c, a, 0] * opoint[0] + dR[olink, c, a, 1] * opoint[1]
                            + dR[olink, c, a, 2] * opoint[2])
        for i in range(nc):
            ca = ocoords[i]
            if cmap[co + ca] >= 0:
                G[i, cmap[co + ca]] = 1.0
            for c in range(3):
                if cmap[co + 3 + c] >= 0:
                    G[i, cmap[co + 3 + c]] = Dw[ca, c]
        if orient == 1:  # full: ω
            for a in range(3):
                for c in range(3):
                    if cmap[co + 3 + c] >= 0:
                        G[nc + a, cmap[co + 3 + c]] = Wr[olink, c, a]
        elif orient == 2:  # axis u = R a turned about e1, e2 ⊥ u: e·∂u/∂q
            for a in range(3):
                w[a] = R[olink, a, 0] * oaxis[0] + R[olink, a, 1] * oaxis[1] + R[olink, a, 2] * oaxis[2]
            im = 0
            for a in range(1, 3):
                if abs(w[a]) < abs(w[im]):
                    im = a
            e2[:] = 0.0
            e2[im] = 1.0
            e1[0] = w[1] * e2[2] - w[2] * e2[1]
            e1[1] = w[2] * e2[0] - w[0] * e2[2]
            e1[2] = w[0] * e2[1] - w[1] * e2[0]
            ne = math.sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2])
            for a in range(3):
                e1[a] /= ne
            e2[0] = w[1] * e1[2] - w[2] * e1[1]
            e2[1] = w[2] * e1[0] - w[0] * e1[2]
            e2[2] = w[0] * e1[1] - w[1] * e1[0]
            for c in range(3):
                if cmap[co + 3 + c] >= 0:
                    du0 = dR[olink, c, 0, 0] * oaxis[0] + dR[olink, c, 0, 1] * oaxis[1] + dR[olink, c, 0, 2] * oaxis[2]
                    du1 = dR[olink, c, 1, 0] * oaxis[0] + dR[olink, c, 1, 1] * oaxis[1] + dR[olink, c, 1, 2] * oaxis[2]
                    du2 = dR[olink, c, 2, 0] * oaxis[0] + dR[olink, c, 2, 1] * oaxis[1] + dR[olink, c, 2, 2] * oaxis[2]
                    G[nc, cmap[co + 3 + c]] = e1[0] * du0 + e1[1] * du1 + e1[2] * du2
                    G[nc + 1, cmap[co + 3 + c]] = e2[0] * du0 + e2[1] * du1 + e2[2] * du2
        for i in range(out.shape[1]):
            for c in range(nd):
                s = 0.0
                for k in range(g0, g0 + BLOCK):  # G is nonzero on the output link's block only
                    s += G[i, k] * X[c, k]
                out[p, i, c] = s


def _outjac_impl(q, target, om, kind, lj, lk, row, coord, value, P, A, B, m, roff, cmap, rb, nptr, nidx, slot, nslots,
                 pad, x0, drive_rows, olink, opoint, ocoords, orient, oaxis, out):  # pragma: no cover - compiled
    N = q.shape[0]
    for ch in numba.prange((N + _CHUNK - 1) // _CHUNK):
        _outjac_chunk(q, target, om, kind, lj, lk, row, coord, value, P, A, B, m, roff, cmap, rb, nptr, nidx, slot,
                      nslots, pad, x0, drive_rows, olink, opoint, ocoords, orient, oaxis, out, ch * _CHUNK, min(N,
                      (ch + 1) * _CHUNK))


_outjac_chunk = numba.njit(**_OPTS)(_outjac_chunk)
_outjac_parallel = numba.njit(parallel=True, **_OPTS)(_outjac_impl)


@numba.njit(**_OPTS)
def _outjac_serial(q, target, om, kind, lj, lk, row, coord, value, P, A, B, m, roff, cmap, rb, nptr, nidx, slot,
                   nslots, pad, x0, drive_rows, olink, opoint, ocoords, orient, oaxis,
                   out):  # pragma: no cover - compiled
    _outjac_chunk(q, target, om, kind, lj, lk, row, coord, value, P, A, B, m, roff, cmap, rb, nptr, nidx, slot, nslots,
                  pad, x0, drive_rows, olink, opoint, ocoords, orient, oaxis, out, 0, q.shape[0])


def output_jacobian(system, q: Array, drives: Array, n_out: int) -> Array:
    """∂x_c/∂s (N, n_out, n_drives) of the controlled outputs (:mod:`pkmstiff.mechanisms.outputs`) per pose in
    compiled code: F_q q_s = e_c by the normal equations on the link blocks (one block Cholesky factor for
    all drives), times the output rates G, both in the Newton coordinates (incremental rotation vectors; κ does not
    depend on the parametrisation).  NaN rows where the normal matrix is singular (the caller falls back)."""
    fp = fused_plan(system)
    plan = system.plan
    mech = system.mech
    o = mech.output
    drive_rows = np.empty(len(mech.drives), dtype=np.int64)
    for b in system.blocks:
        if b.kind.startswith("drive"):
            drive_rows[b.coord] = b.row0 - system.n_fixed_rows + np.arange(b.n)
    N = q.shape[0]
    out = np.empty((N, n_out, drive_rows.size))
    kern = _outjac_parallel if N >= PARALLEL_MIN else _outjac_serial
    kern(np.ascontiguousarray(q.reshape(N, -1), dtype=float), np.ascontiguousarray(drives, dtype=float), system._om,
         plan.kind, plan.j, plan.k, plan.row, plan.coord, plan.value, plan.p, plan.a, plan.b, system.m,
         system.n_fixed_rows, fp.cmap, fp.rb, fp.nptr, fp.nidx, fp.slot, fp.nslots, fp.pad, fp.x0, drive_rows,
         int(o.link), np.asarray(o.point, dtype=float), np.asarray(o.coordinates, dtype=np.int64), {"none": 0,
         "full": 1, "axis": 2}[o.orientation], np.zeros(3) if o.axis is None else np.asarray(o.axis, dtype=float), out)
    return out
