"""Rank-revealing least squares for the Newton steps, and rank by singular-value gap (calibration.md §3).

Because eq. 5 and eq. 7 of DE 10 2004 026 707 A1 have three rows of rank 2, every system is row-redundant: the
Newton step is the least-squares solution by Householder QR with column pivoting (the patent's Householder
method, [0051]), computed per pose in compiled code and run over the poses in parallel.  Rank decisions use the
largest gap in the singular values (or, inside the Newton loop, in the pivoted-QR diagonal, which tracks them).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: a singular value counts as zero only below this fraction of the largest one …
GAP_FLOOR = 1e-8
#: … and only if it sits behind a gap of at least this factor
GAP_FACTOR = 1e3


def gap_rank(s: Array, floor: float = GAP_FLOOR, factor: float = GAP_FACTOR) -> Array:
    """Rank from sorted (descending) singular values s (…, k): the first gap of at least ``factor`` between
    s_i and s_(i+1) with s_(i+1) ≤ ``floor``·s_0; full rank k if there is none.  Structural redundancy (eq. 5, 7)
    gives singular values of O(ε·s_0), so the first such gap separates them from the genuine ones."""
    s = np.asarray(s, dtype=float)
    k = s.shape[-1]
    if k == 0:
        return np.zeros(s.shape[:-1], dtype=int)
    s0 = s[..., :1]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = s[..., :-1] / np.maximum(s[..., 1:], 1e-300 * np.maximum(s0, 1e-300))
    cand = (s[..., 1:] <= floor * s0) & (ratio >= factor)
    has = cand.any(axis=-1)
    r = np.where(has, np.argmax(cand, axis=-1) + 1, k)
    return np.where(s0[..., 0] > 0.0, r, 0)


def numerical_rank(A: Array) -> int:
    """Rank of one matrix by the singular-value gap (:func:`gap_rank`)."""
    if A.size == 0:
        return 0
    return int(gap_rank(np.linalg.svd(A, compute_uv=False)))


def _lstsq_impl(J, r, floor, factor):  # pragma: no cover - compiled
    """Least-squares steps dx (N, n) minimising ‖J dx + r‖ by Householder QR with column pivoting per pose.

    Returns dx, the absolute pivoted R diagonal (N, n) and the rank used (gap rule on that diagonal: the basic
    solution drops the columns behind the gap).  Works on Jᵀ so that every column is contiguous.
    """
    N, m, n = J.shape
    dx = np.zeros((N, n))
    diag = np.zeros((N, n))
    ranks = np.zeros(N, dtype=np.int64)
    kmax = min(m, n)
    for p in numba.prange(N):
        A = np.ascontiguousarray(J[p].T)  # (n, m): row c = column c of J
        b = -r[p].copy()
        perm = np.arange(n)
        cn = np.zeros(n)
        for c in range(n):
            acc = 0.0
            for i in range(m):
                acc += A[c, i] * A[c, i]
            cn[c] = acc
        v = np.zeros(m)
        nz = np.zeros(m, dtype=np.int64)
        for k in range(kmax):
            best = k
            for c in range(k + 1, n):
                if cn[c] > cn[best]:
                    best = c
            if best != k:
                for i in range(m):
                    t = A[k, i]
                    A[k, i] = A[best, i]
                    A[best, i] = t
                t2 = cn[k]
                cn[k] = cn[best]
                cn[best] = t2
                ti = perm[k]
                perm[k] = perm[best]
                perm[best] = ti
            acc = 0.0
            for i in range(k, m):
                acc += A[k, i] * A[k, i]
            norm = math.sqrt(acc)
            if norm == 0.0:
                diag[p, k] = 0.0
                continue
            alpha = -norm if A[k, k] >= 0.0 else norm
            vn2 = 0.0
            for i in range(k, m):
                v[i] = A[k, i]
            v[k] -= alpha
            # constraint Jacobians are sparse (a row touches two links): work on the nonzero rows of v only
            nnz = 0
            for i in range(k, m):
                if v[i] != 0.0:
                    nz[nnz] = i
                    nnz += 1
                    vn2 += v[i] * v[i]
            for c in range(k + 1, n):
                acc = 0.0
                for t_ in range(nnz):
                    acc += v[nz[t_]] * A[c, nz[t_]]
                if acc != 0.0:
                    f = 2.0 * acc / vn2
                    for t_ in range(nnz):
                        A[c, nz[t_]] -= f * v[nz[t_]]
                # downdate the remaining column norm; recompute when cancellation makes it unreliable
                nc = cn[c] - A[c, k] * A[c, k]
                if nc < 1e-8 * cn[c]:
                    nc = 0.0
                    for i in range(k + 1, m):
                        nc += A[c, i] * A[c, i]
                cn[c] = nc
            acc = 0.0
            for t_ in range(nnz):
                acc += v[nz[t_]] * b[nz[t_]]
            f = 2.0 * acc / vn2
            for t_ in range(nnz):
                b[nz[t_]] -= f * v[nz[t_]]
            A[k, k] = alpha
            diag[p, k] = abs(alpha)
        rk = kmax
        d0 = diag[p, 0]
        if d0 == 0.0:
            rk = 0
        else:
            for k in range(kmax - 1):
                nxt = diag[p, k + 1]
                if nxt <= floor * d0 and diag[p, k] >= factor * max(nxt, 1e-300 * d0):
                    rk = k + 1
                    break
        ranks[p] = rk
        z = np.zeros(n)
        for k in range(rk - 1, -1, -1):
            s = b[k]
            for c in range(k + 1, rk):
                s -= A[c, k] * z[c]
            z[k] = s / A[k, k]
        for k in range(rk):
            dx[p, perm[k]] = z[k]
    return dx, diag, ranks


_FM = {"reassoc", "contract", "nsz"}
_lstsq_parallel = numba.njit(cache=True, parallel=True, nogil=True, fastmath=_FM)(_lstsq_impl)



def _renamed(fn, name):
    """A copy of ``fn`` under another name: numba's on-disk cache is keyed by the function, and two dispatchers of
    one function (parallel and serial) would evict each other's entries on every call."""
    import types

    code = fn.__code__.replace(co_name=name, co_qualname=name) if hasattr(fn.__code__, "co_qualname") else \
        fn.__code__.replace(co_name=name)
    out = types.FunctionType(code, fn.__globals__, name, fn.__defaults__, fn.__closure__)
    out.__qualname__ = name
    return out


_lstsq_serial = numba.njit(cache=True, nogil=True, fastmath=_FM)(_renamed(_lstsq_impl, "_lstsq_serial_impl"))
#: below this many poses the serial kernel is used (thread start-up costs more than it saves)
PARALLEL_MIN = 64


def lstsq_pivoted(J: Array, r: Array, floor: float = GAP_FLOOR, factor: float = GAP_FACTOR
                  ) -> tuple[Array, Array, Array]:
    """Least-squares steps dx (N, n) minimising ‖J dx + r‖ (J (N, m, n), r (N, m)) by Householder QR with column
    pivoting per pose (compiled; parallel over poses for large N).  Returns dx, |R_kk| in pivot order (N, n) and
    the rank used (first gap of ``factor`` below ``floor``·|R_00| in that diagonal: basic solution)."""
    kern = _lstsq_parallel if J.shape[0] >= PARALLEL_MIN else _lstsq_serial
    return kern(J, r, floor, factor)


def _normal_impl(J, r, cols, cnt, screen, sweeps):  # pragma: no cover - compiled
    """Least-squares steps dx (N, n) minimising ‖J dx + r‖ by the normal equations JᵀJ dx = −Jᵀr (Cholesky), with a
    condition estimate per pose.

    JᵀJ is accumulated row by row over the structural nonzero columns ``cols[i, :cnt[i]]`` (ascending; a
    constraint row touches at most two links); the
    Cholesky factor keeps the envelope of JᵀJ (no fill-in before a row's first nonzero), so the zeros between
    unconnected links are skipped.  The estimate of σ_min/σ_max is √(λ/trace JᵀJ) with λ from four steps of
    inverse iteration on JᵀJ (two triangular solves each) from a fixed generic start vector: inverse iteration
    approaches λ_min from above and √trace ≥ σ_max, so the estimate is the closer to the truth the more isolated
    the small singular value is (the near-singular case it has to catch).  ``ok`` is False where the factor
    breaks down or the estimate is below ``screen``: those poses need the rank-revealing step.
    """
    N, m, n = J.shape
    dx = np.zeros((N, n))
    est = np.zeros(N)
    ok = np.zeros(N, dtype=np.bool_)
    nchunk = (N + 127) // 128
    for ch in numba.prange(nchunk):  # scratch arrays once per chunk of poses
        _normal_chunk(J, r, cols, cnt, screen, sweeps, dx, est, ok, ch * 128, min(N, (ch + 1) * 128))
    return dx, est, ok


def _skyline_solve(A, first, v):  # pragma: no cover - compiled
    """v ← (L Lᵀ)⁻¹ v in place for the lower Cholesky factor L in ``A`` whose row i starts at column ``first[i]``."""
    n = v.shape[0]
    for i in range(n):
        s = v[i]
        for t in range(first[i], i):
            s -= A[i, t] * v[t]
        v[i] = s / A[i, i]
    for i in range(n - 1, -1, -1):
        v[i] /= A[i, i]
        for t in range(first[i], i):
            v[t] -= A[i, t] * v[i]


_skyline_solve = numba.njit(cache=True, nogil=True, fastmath=_FM)(_skyline_solve)


def _normal_chunk(J, r, cols, cnt, screen, sweeps, dx, est, ok, p0, p1):  # pragma: no cover - compiled
    n = J.shape[2]
    A = np.empty((n, n))
    g = np.empty(n)
    first = np.empty(n, dtype=np.int64)
    x = np.empty(n)
    for p in range(p0, p1):
        est[p] = _normal_pose(J[p], r[p], cols, cnt, sweeps, A, g, first, x, dx[p])
        ok[p] = est[p] >= screen


def _normal_pose(Jp, rp, cols, cnt, sweeps, A, g, first, x, dxp):  # pragma: no cover - compiled
    """One pose of :func:`_normal_impl`: dxp (n,) ← −(JᵀJ)⁻¹Jᵀr; returns the σ_min/σ_max estimate (0 where
    the Cholesky factor breaks down: dxp is then left as it was).  ``A`` keeps the skyline Cholesky factor L of JᵀJ
    (rows from ``first``) for further solves (:func:`_skyline_solve`)."""
    m, n = Jp.shape
    A[:] = 0.0
    g[:] = 0.0
    for i in range(m):
        ri = rp[i]
        for a_ in range(cnt[i]):
            ca = cols[i, a_]
            va = Jp[i, ca]
            if va == 0.0:
                continue
            g[ca] += va * ri
            for b_ in range(a_ + 1):
                cb = cols[i, b_]
                A[ca, cb] += va * Jp[i, cb]
    tr = 0.0
    for i in range(n):
        tr += A[i, i]
        f = i
        for c in range(i):
            if A[i, c] != 0.0:
                f = c
                break
        first[i] = f
    if not tr > 0.0:
        return 0.0
    for k in range(n):
        s = A[k, k]
        for t in range(first[k], k):
            s -= A[k, t] * A[k, t]
        if not s > 1e-15 * tr:
            return 0.0
        lkk = math.sqrt(s)
        A[k, k] = lkk
        for i in range(k + 1, n):
            if first[i] > k:
                continue
            s = A[i, k]
            for t in range(max(first[i], first[k]), k):
                s -= A[i, t] * A[k, t]
            A[i, k] = s / lkk
    for i in range(n):  # solve L Lᵀ dx = −g
        dxp[i] = -g[i]
    _skyline_solve(A, first, dxp)
    # inverse iteration for λ_min(JᵀJ)
    nx = 0.0
    for i in range(n):
        x[i] = 1.0 + 0.5 * math.sin(1.7 * i + 0.3)
        nx += x[i] * x[i]
    nx = math.sqrt(nx)
    lam = tr
    for _ in range(sweeps):
        for i in range(n):
            x[i] /= nx
        _skyline_solve(A, first, x)
        nx = 0.0
        for i in range(n):
            nx += x[i] * x[i]
        nx = math.sqrt(nx)
        lam = 1.0 / nx
    return math.sqrt(lam / tr)


_normal_pose = numba.njit(cache=True, nogil=True, fastmath=_FM)(_normal_pose)
_normal_chunk = numba.njit(cache=True, nogil=True, fastmath=_FM)(_normal_chunk)
_normal_parallel = numba.njit(cache=True, parallel=True, nogil=True, fastmath=_FM)(_normal_impl)
_normal_serial = numba.njit(cache=True, nogil=True, fastmath=_FM)(_renamed(_normal_impl, "_normal_serial_impl"))


# ----------------------------------------------------------------------------------------------------------
# block normal equations: one 6×6 block per link (the fused Newton, pkmstiff.mechanisms.fused)
# ----------------------------------------------------------------------------------------------------------
#: unknowns per block (a spatial link's δt, δω); a link with fixed coordinates pads them
BLOCK = 6


def _block_normal_pose(Jp, rp, rb, nptr, nidx, slot, pad, x0, sweeps, Ab, g, x, dxp):  # pragma: no cover - compiled
    """:func:`_normal_pose` on the link blocks: dxp ← −(JᵀJ)⁻¹Jᵀr and the same σ_min/σ_max estimate (same
    matrix, same column order, same start vector and inverse iteration: equal to rounding), by a block Cholesky
    factor with fixed-size 6×6 kernels instead of the skyline loops.

    Jp (m, 6·nb): columns by block (block b = columns 6b…6b+5, elimination order); ``rb`` (m, 2) the blocks
    a row touches (−1: none; a constraint joins two links); ``slot`` (nb, nb) the storage slot in ``Ab`` of the
    lower block (i, j), i ≥ j, of the filled pattern (−1: structurally zero); block k's off-diagonal column is
    ``nidx[nptr[k]:nptr[k+1]]`` (ascending).  ``pad`` (nb, 6): 1 on the padded (fixed) coordinates, which get a
    decoupled unit pivot (their step and start-vector entries stay 0).  ``x0``: the inverse-iteration start
    vector (:func:`block_start`).  Returns 0 where a pivot breaks down (s ≤ 1e-15·trace, as the skyline factor)."""
    m = Jp.shape[0]
    nb = slot.shape[0]
    Ab[:] = 0.0
    g[:] = 0.0
    for i in range(m):
        b1 = rb[i, 0]
        b2 = rb[i, 1]
        if b1 < 0:
            continue
        ri = rp[i]
        o1 = BLOCK * b1
        D = Ab[b1]
        for a in range(BLOCK):
            va = Jp[i, o1 + a]
            g[o1 + a] += va * ri
            for c in range(BLOCK):
                D[a, c] += va * Jp[i, o1 + c]
        if b2 >= 0:
            o2 = BLOCK * b2
            D = Ab[b2]
            for a in range(BLOCK):
                va = Jp[i, o2 + a]
                g[o2 + a] += va * ri
                for c in range(BLOCK):
                    D[a, c] += va * Jp[i, o2 + c]
            hi, lo = (o1, o2) if b1 > b2 else (o2, o1)
            C = Ab[slot[max(b1, b2), min(b1, b2)]]
            for a in range(BLOCK):
                va = Jp[i, hi + a]
                for c in range(BLOCK):
                    C[a, c] += va * Jp[i, lo + c]
    tr = 0.0
    for b in range(nb):
        for a in range(BLOCK):
            tr += Ab[b, a, a]
    if not tr > 0.0:
        return 0.0
    for b in range(nb):
        for a in range(BLOCK):
            Ab[b, a, a] += pad[b, a]
    for k in range(nb):
        Lk = Ab[k]
        for c in range(BLOCK):  # Cholesky of the (updated) diagonal block
            s = Lk[c, c]
            for t in range(c):
                s -= Lk[c, t] * Lk[c, t]
            if not s > 1e-15 * tr:
                return 0.0
            d = 1.0 / math.sqrt(s)  # the diagonal keeps 1/L_cc: products instead of divisions in every solve
            Lk[c, c] = d
            for a in range(c + 1, BLOCK):
                s = Lk[a, c]
                for t in range(c):
                    s -= Lk[a, t] * Lk[c, t]
                Lk[a, c] = s * d
        for p in range(nptr[k], nptr[k + 1]):  # L_ik = A_ik L_kk⁻ᵀ
            X = Ab[slot[nidx[p], k]]
            for a in range(BLOCK):
                for c in range(BLOCK):
                    s = X[a, c]
                    for t in range(c):
                        s -= X[a, t] * Lk[c, t]
                    X[a, c] = s * Lk[c, c]
        for p in range(nptr[k], nptr[k + 1]):  # Schur complement: A_ij −= L_ik L_jkᵀ
            i = nidx[p]
            Li = Ab[slot[i, k]]
            for p2 in range(nptr[k], p + 1):
                j = nidx[p2]
                Lj = Ab[slot[j, k]]
                T = Ab[slot[i, j]]
                for a in range(BLOCK):
                    for c in range(BLOCK):
                        s = 0.0
                        for t in range(BLOCK):
                            s += Li[a, t] * Lj[c, t]
                        T[a, c] -= s
    for i in range(dxp.shape[0]):
        dxp[i] = -g[i]
    _block_solve(Ab, nptr, nidx, slot, dxp)
    # inverse iteration for λ_min(JᵀJ) from the fixed start vector (as _normal_pose)
    nx = 0.0
    for i in range(x.shape[0]):
        x[i] = x0[i]
        nx += x[i] * x[i]
    nx = math.sqrt(nx)
    lam = tr
    for _ in range(sweeps):
        for i in range(x.shape[0]):
            x[i] /= nx
        _block_solve(Ab, nptr, nidx, slot, x)
        nx = 0.0
        for i in range(x.shape[0]):
            nx += x[i] * x[i]
        nx = math.sqrt(nx)
        lam = 1.0 / nx
    return math.sqrt(lam / tr)


def _block_solve(Ab, nptr, nidx, slot, v):  # pragma: no cover - compiled
    """v ← (L Lᵀ)⁻¹ v in place for the block Cholesky factor of :func:`_block_normal_pose` (diagonal blocks: L
    below the diagonal, 1/L_cc on it)."""
    nb = slot.shape[0]
    for k in range(nb):  # forward: L y = v
        Lk = Ab[k]
        o = BLOCK * k
        for c in range(BLOCK):
            s = v[o + c]
            for t in range(c):
                s -= Lk[c, t] * v[o + t]
            v[o + c] = s * Lk[c, c]
        for p in range(nptr[k], nptr[k + 1]):
            i = nidx[p]
            X = Ab[slot[i, k]]
            oi = BLOCK * i
            for a in range(BLOCK):
                s = 0.0
                for t in range(BLOCK):
                    s += X[a, t] * v[o + t]
                v[oi + a] -= s
    for k in range(nb - 1, -1, -1):  # backward: Lᵀ x = y
        Lk = Ab[k]
        o = BLOCK * k
        for p in range(nptr[k], nptr[k + 1]):
            i = nidx[p]
            X = Ab[slot[i, k]]
            oi = BLOCK * i
            for t in range(BLOCK):
                s = 0.0
                for a in range(BLOCK):
                    s += X[a, t] * v[oi + a]
                v[o + t] -= s
        for c in range(BLOCK - 1, -1, -1):
            s = v[o + c]
            for t in range(c + 1, BLOCK):
                s -= Lk[t, c] * v[o + t]
            v[o + c] = s * Lk[c, c]


_block_solve = numba.njit(cache=True, nogil=True, fastmath=_FM)(_block_solve)
_block_normal_pose = numba.njit(cache=True, nogil=True, fastmath=_FM)(_block_normal_pose)


def block_pattern(nb: int, pairs: list[tuple[int, int]]) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Filled lower block pattern of JᵀJ for :func:`_block_normal_pose`: the block pairs ``pairs`` (i, j) that
    share a row (blocks numbered in elimination order), closed under the fill of eliminating the blocks in that
    order (eliminating k joins all its later neighbours).  Returns nptr, nidx (the later neighbours of each k,
    ascending), slot (nb, nb) (diagonal i → i, then the off-diagonal blocks) and the number of slots."""
    nbr = [set() for _ in range(nb)]
    for i, j in pairs:
        if i != j:
            nbr[min(i, j)].add(max(i, j))
    for k in range(nb):
        later = sorted(nbr[k])
        for a, i in enumerate(later):
            for j in later[:a]:
                nbr[j].add(i)
    slot = np.full((nb, nb), -1, dtype=np.int64)
    slot[np.arange(nb), np.arange(nb)] = np.arange(nb)
    ns = nb
    nptr = np.zeros(nb + 1, dtype=np.int64)
    nidx = []
    for k in range(nb):
        for i in sorted(nbr[k]):
            slot[i, k] = ns
            ns += 1
            nidx.append(i)
        nptr[k + 1] = len(nidx)
    return nptr, np.array(nidx, dtype=np.int64), slot, ns


def block_start(pad: np.ndarray) -> np.ndarray:
    """The inverse-iteration start vector of :func:`_normal_pose` (1 + ½ sin(1.7 i + 0.3) over the unpadded
    columns i) on the padded block columns, 0 on the padding."""
    real = pad.reshape(-1) == 0.0
    x = np.zeros(real.size)
    i = np.arange(int(real.sum()))
    x[real] = 1.0 + 0.5 * np.sin(1.7 * i + 0.3)
    return x

#: below this many poses the serial normal-equation kernel is used (it is ~5× cheaper per pose than the QR)
NORMAL_PARALLEL_MIN = 2048
#: σ_min/σ_max estimate above which the normal-equation step is used (below: pivoted QR).  Squaring the condition
#: number costs at most ~1e12·ε ≈ 1e-4 relative accuracy of the step at this bound, which only slows the last
#: Newton step slightly; the converged residual is evaluated exactly either way.
NORMAL_SCREEN = 1e-6


def sparsity(pattern: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per row of a (m, n) bool nonzero pattern: its nonzero columns, ascending (m, max count), and their count."""
    pattern = np.asarray(pattern, dtype=bool)
    cnt = pattern.sum(axis=1).astype(np.int64)
    cols = np.zeros((pattern.shape[0], max(1, int(cnt.max(initial=0)))), dtype=np.int64)
    for i in range(pattern.shape[0]):
        c = np.flatnonzero(pattern[i])
        cols[i, :c.size] = c
    return cols, cnt


def lstsq_step(J: Array, r: Array, screen: float = NORMAL_SCREEN, sweeps: int = 2, floor: float = GAP_FLOOR,
               factor: float = GAP_FACTOR, pattern: np.ndarray | None = None) -> tuple[Array, Array, Array, Array]:
    """Newton steps dx (N, n) minimising ‖J dx + r‖: normal equations with Cholesky for the poses whose condition
    estimate (``sweeps`` inverse-iteration steps) is at least ``screen`` (well-conditioned, full column rank),
    pivoted Householder QR
    (:func:`lstsq_pivoted`, the patent's step) for the rest.

    ``pattern`` (m, n) bool: the structural nonzeros of J (default: where any pose has a nonzero), or its
    :func:`sparsity` (cols, cnt) computed once (:attr:`pkmstiff.mechanisms.constraints.System.sparsity`).
    Returns dx, rank (n for the Cholesky poses; gap rule of the QR diagonal otherwise), rcond (the σ-ratio
    estimate, or min/max |R_kk| of the pivoted QR) and ``qr`` (N,) bool: which poses took the QR step.
    """
    N, m, n = J.shape
    if pattern is None:
        pattern = (J != 0.0).any(axis=0)
    cols, cnt = pattern if isinstance(pattern, tuple) else sparsity(pattern)
    kern = _normal_parallel if N >= NORMAL_PARALLEL_MIN else _normal_serial
    dx, est, ok = kern(np.ascontiguousarray(J), np.ascontiguousarray(r), cols, cnt, screen, sweeps)
    rank = np.full(N, n, dtype=int)
    rcond = est
    qr = ~ok
    if qr.any():
        idx = np.flatnonzero(qr)
        dq, diag, rk = lstsq_pivoted(np.ascontiguousarray(J[idx]), np.ascontiguousarray(r[idx]), floor, factor)
        dx[idx], rank[idx] = dq, rk
        with np.errstate(divide="ignore", invalid="ignore"):
            rcond[idx] = diag[:, -1] / diag[:, 0]
    return dx, rank, rcond, qr


def singular_values(A: Array, chunk: int = 2048) -> Array:
    """Singular values (N, min(m, n)) of a stack of matrices, descending, in chunks."""
    out = np.empty((A.shape[0], min(A.shape[1:])))
    for s in range(0, A.shape[0], chunk):
        out[s:s + chunk] = np.linalg.svd(A[s:s + chunk], compute_uv=False)
    return out
