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


def singular_values(A: Array, chunk: int = 2048) -> Array:
    """Singular values (N, min(m, n)) of a stack of matrices, descending, in chunks."""
    out = np.empty((A.shape[0], min(A.shape[1:])))
    for s in range(0, A.shape[0], chunk):
        out[s:s + chunk] = np.linalg.svd(A[s:s + chunk], compute_uv=False)
    return out
