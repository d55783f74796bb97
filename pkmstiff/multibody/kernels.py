"""Compiled (numba) kernels of the batch structure analysis: assembly of K, block elimination onto one body and the
mass-normalised eigenproblem matrix, one pose at a time in cache (docs/theory/structure.md, Cobet eq. 4.58-4.73).

The numpy implementation (:mod:`pkmstiff.multibody.assembly`, :mod:`~pkmstiff.multibody.solver`,
:mod:`~pkmstiff.multibody.modal`) builds every step for a whole chunk of poses with many small array operations;
these kernels do the same arithmetic per pose on data that stays in L1 (issue 12 item 6: batch throughput within
1.15x of the LAPACK floor).  Results agree with the numpy path to round-off (tests/test_multibody_kernels.py).
:mod:`pkmstiff.multibody.fast` lays out the arrays and decides when the kernels apply.

Conventions as in :mod:`pkmstiff.kinematics.kernels`: no ``fastmath`` (IEEE rounding and NaN kept),
``error_model="numpy"``, ``cache=True`` (compiled once per machine); arrays with a leading pose axis of length 1
are broadcast over the poses.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


@intrinsic
def _fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (LLVM ``llvm.fma``): numpy's matmul inner loop accumulates this way on CPUs with
    FMA, so the mass normalisation below reproduces numpy's rounding bit for bit."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        dbl = ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [dbl], ir.FunctionType(dbl, [dbl, dbl, dbl]))
        return builder.call(fn, args)

    return sig, codegen


@_jit
def _side_matrix(g, col, kind, dx, dy, dz, d):
    """Write G of one side (sign +1) into columns col… of g (d × m); returns the number of columns.

    kind 0: frame (no columns); 1: point mass, G = I3; 2: rigid body, G = T(Δ) (d = 3) or N(Δ) (d = 6).
    """
    if kind == 0:
        return 0
    for r in range(3):
        for c in range(3):
            g[r, col + c] = 1.0 if r == c else 0.0
    if kind == 1:
        return 3
    # -[Δ]x
    g[0, col + 3], g[0, col + 4], g[0, col + 5] = 0.0, dz, -dy
    g[1, col + 3], g[1, col + 4], g[1, col + 5] = -dz, 0.0, dx
    g[2, col + 3], g[2, col + 4], g[2, col + 5] = dy, -dx, 0.0
    if d == 6:
        for r in range(3):
            for c in range(6):
                g[3 + r, col + c] = 1.0 if c == r + 3 else 0.0
    return 6


@_jit
def _rank_one_row(h, col, kind, n0, n1, n2, dx, dy, dz, sign):
    """``h = sign nᵀ G`` of one side into h[col…] (kinds as :func:`_side_matrix`); the products with the 0/1
    entries of G are left out (exact, so the result equals the full product bit for bit)."""
    if kind == 0:
        return 0
    h[col], h[col + 1], h[col + 2] = sign * n0, sign * n1, sign * n2
    if kind == 1:
        return 3
    h[col + 3] = sign * (n1 * -dz + n2 * dy)
    h[col + 4] = sign * (n0 * dz + n2 * -dx)
    h[col + 5] = sign * (n0 * -dy + n1 * dx)
    return 6


@_jit
def assemble_set(out, start_a, kind_a, start_b, kind_b, delta_a, delta_b, k, axis, mat, rank_one):
    """Add ``G_abᵀ K_e G_ab`` of every element of one SDE set to ``out`` (P, n, n) (Cobet eq. 4.58-4.69).

    ``start_*``/``kind_*`` (E,): first global DOF and body kind of side a/b (kind 0 frame, 1 point mass,
    2 rigid body); ``delta_*`` (1|P, E, 3): coupling point − body reference point; rank one (``k n nᵀ``):
    ``k`` (1|P, E), ``axis`` (1|P, E, 3); otherwise ``mat`` (1|P, E, d, d).
    """
    n_p, n_el = out.shape[0], start_a.shape[0]
    d = 3 if rank_one else mat.shape[2]
    g = np.zeros((d, 12))
    h = np.zeros((d, 12))
    hv = np.zeros(12)
    blk = np.zeros((12, 12))
    idx = np.zeros(12, np.int64)
    for p in range(n_p):
        pa = p if delta_a.shape[0] > 1 else 0
        pb = p if delta_b.shape[0] > 1 else 0
        for e in range(n_el):
            m = 0
            for c in range(0 if kind_a[e] == 0 else (3 if kind_a[e] == 1 else 6)):
                idx[m] = start_a[e] + c
                m += 1
            ma = m
            for c in range(0 if kind_b[e] == 0 else (3 if kind_b[e] == 1 else 6)):
                idx[m] = start_b[e] + c
                m += 1
            if rank_one:
                pk = p if k.shape[0] > 1 else 0
                pn = p if axis.shape[0] > 1 else 0
                kk = k[pk, e]
                n0, n1, n2 = axis[pn, e, 0], axis[pn, e, 1], axis[pn, e, 2]
                _rank_one_row(hv, 0, kind_a[e], n0, n1, n2, delta_a[pa, e, 0], delta_a[pa, e, 1],
                              delta_a[pa, e, 2], 1.0)
                _rank_one_row(hv, ma, kind_b[e], n0, n1, n2, delta_b[pb, e, 0], delta_b[pb, e, 1],
                              delta_b[pb, e, 2], -1.0)
                for r in range(m):
                    kr = kk * hv[r]
                    row = idx[r]
                    for c in range(m):
                        out[p, row, idx[c]] += kr * hv[c]
                continue
            pm = p if mat.shape[0] > 1 else 0
            if kind_a[e] != 2 and kind_b[e] != 2:  # G = [I3, -I3] (or one of them): the block is ±K_e, exact
                for r in range(m):
                    sr = 1.0 if r < ma else -1.0
                    row = idx[r]
                    for c in range(m):
                        sc = 1.0 if c < ma else -1.0
                        out[p, row, idx[c]] += (sr * sc) * mat[pm, e, r % 3, c % 3]
                continue
            _side_matrix(g, 0, kind_a[e], delta_a[pa, e, 0], delta_a[pa, e, 1], delta_a[pa, e, 2], d)
            _side_matrix(g, ma, kind_b[e], delta_b[pb, e, 0], delta_b[pb, e, 1], delta_b[pb, e, 2], d)
            for r in range(d):
                for c in range(ma, m):
                    g[r, c] = -g[r, c]
            for r in range(d):  # h = K G_ab
                for c in range(m):
                    s = 0.0
                    for l in range(d):
                        s += mat[pm, e, r, l] * g[l, c]
                    h[r, c] = s
            for r in range(m):  # G_abᵀ h
                for c in range(m):
                    s = 0.0
                    for l in range(d):
                        s += g[l, r] * h[l, c]
                    blk[r, c] = s
            for r in range(m):
                row = idx[r]
                for c in range(m):
                    out[p, row, idx[c]] += blk[r, c]


@_jit
def condensed_compliance(k, order, n_elim, right, comp, ok):
    """``comp[p] = Rᵀ K_c⁻¹ R`` with ``K_c`` the stiffness ``k[p]`` (n, n) statically condensed onto the DOFs
    ``order[n_elim:]`` (block elimination of ``order[:n_elim]``, docs/theory/structure.md), ``R = right[p]``
    (1|P, n_k, r).  Cholesky of the permuted matrix; entries that are zero (no coupling between bodies) are
    skipped, so the cost follows the body graph.  ``ok[p]`` False where a pivot is not positive (K not positive
    definite); ``comp[p]`` is then left NaN.
    """
    n_p, n = k.shape[0], k.shape[1]
    nk = n - n_elim
    r_cols = right.shape[2]
    w = np.empty((n, n))
    upd = np.empty((nk, nk))
    y = np.empty((nk, r_cols))
    nz = np.empty(n, np.int64)
    for p in range(n_p):
        for i in range(n):
            oi = order[i]
            for j in range(i + 1):
                w[i, j] = k[p, oi, order[j]]
        for i in range(nk):
            for j in range(nk):
                upd[i, j] = 0.0
        good = True
        for j in range(n):
            if j == n_elim:  # the Schur complement on the kept DOFs: K_kk − Σ Yᵀ Y (as in BlockFactor)
                for i in range(nk):
                    for c in range(i + 1):
                        w[n_elim + i, n_elim + c] -= upd[i, c]
            piv = w[j, j]
            if not piv > 0.0:
                good = False
                break
            piv = math.sqrt(piv)
            w[j, j] = piv
            m = 0
            m_e = 0  # non-zero rows of column j among the eliminated DOFs (they come first)
            for i in range(j + 1, n):
                if w[i, j] != 0.0:
                    w[i, j] /= piv
                    nz[m] = i
                    m += 1
                    if i < n_elim:
                        m_e = m
            # rank-one update restricted to the non-zero rows of column j; kept-kept entries of an eliminated
            # column are summed in upd first (the Schur complement update of BlockFactor)
            for a in range(m):
                i = nz[a]
                lij = w[i, j]
                for b in range(min(a + 1, m_e)):
                    c = nz[b]
                    w[i, c] -= lij * w[c, j]
                if a >= m_e:
                    if j < n_elim:
                        for b in range(m_e, a + 1):
                            c = nz[b]
                            upd[i - n_elim, c - n_elim] += lij * w[c, j]
                    else:
                        for b in range(m_e, a + 1):
                            c = nz[b]
                            w[i, c] -= lij * w[c, j]
        ok[p] = good
        if not good:
            comp[p] = np.nan
            continue
        _compliance_from_factor(w[n_elim:, n_elim:], right, p if right.shape[0] > 1 else 0, y, comp, p)


@_jit
def _compliance_from_factor(lk, right, pr, y, comp, p):
    """comp[p] = (L⁻¹R)ᵀ (L⁻¹R) for the lower Cholesky factor ``lk`` of the condensed stiffness."""
    nk, r_cols = lk.shape[0], right.shape[2]
    for c in range(r_cols):  # y = L⁻¹ R
        for i in range(nk):
            s = right[pr, i, c]
            for l in range(i):
                s -= lk[i, l] * y[l, c]
            y[i, c] = s / lk[i, i]
    for a in range(r_cols):  # yᵀ y
        for b in range(a + 1):
            s = 0.0
            for i in range(nk):
                s += y[i, a] * y[i, b]
            comp[p, a, b] = s
            comp[p, b, a] = s


@_jit
def condensed_star(k, starts, d, kept, right, comp, ok):
    """:func:`condensed_compliance` for the common body graph of a PKM: bodies of ``d`` DOFs starting at
    ``starts`` (G,) that are coupled only to the kept DOFs ``kept`` (n_k,) (e.g. six drives and the platform),
    eliminated block by block with dense small loops (BlockFactor's single elimination step: ``L = chol(K_ii)``,
    ``Y = L⁻¹ K_ik``, ``K_kk −= Σ YᵀY``; then ``chol(K_kk)``)."""
    n_p, n_g, nk = k.shape[0], starts.shape[0], kept.shape[0]
    r_cols = right.shape[2]
    lm = np.empty((d, d))
    ym = np.empty((d, nk))
    upd = np.empty((nk, nk))
    lk = np.empty((nk, nk))
    y = np.empty((nk, r_cols))
    for p in range(n_p):
        for a in range(nk):
            for b in range(a + 1):
                upd[a, b] = 0.0
        good = True
        for gi in range(n_g):
            s0 = starts[gi]
            for j in range(d):  # Cholesky of the member block (lower triangle)
                v = k[p, s0 + j, s0 + j]
                for l in range(j):
                    v -= lm[j, l] * lm[j, l]
                if not v > 0.0:
                    good = False
                    break
                lm[j, j] = math.sqrt(v)
                for i in range(j + 1, d):
                    v = k[p, s0 + i, s0 + j]
                    for l in range(j):
                        v -= lm[i, l] * lm[j, l]
                    lm[i, j] = v / lm[j, j]
            if not good:
                break
            for c in range(nk):  # Y = L⁻¹ K_ik
                kc = kept[c]
                for i in range(d):
                    v = k[p, s0 + i, kc]
                    for l in range(i):
                        v -= lm[i, l] * ym[l, c]
                    ym[i, c] = v / lm[i, i]
            for a in range(nk):  # Σ YᵀY
                for b in range(a + 1):
                    v = 0.0
                    for i in range(d):
                        v += ym[i, a] * ym[i, b]
                    upd[a, b] += v
        if good:
            for j in range(nk):  # Cholesky of the condensed stiffness K_kk − Σ YᵀY
                v = k[p, kept[j], kept[j]] - upd[j, j]
                for l in range(j):
                    v -= lk[j, l] * lk[j, l]
                if not v > 0.0:
                    good = False
                    break
                lk[j, j] = math.sqrt(v)
                for i in range(j + 1, nk):
                    v = k[p, kept[i], kept[j]] - upd[i, j]
                    for l in range(j):
                        v -= lk[i, l] * lk[j, l]
                    lk[i, j] = v / lk[j, j]
        ok[p] = good
        if not good:
            comp[p] = np.nan
            continue
        _compliance_from_factor(lk, right, p if right.shape[0] > 1 else 0, y, comp, p)


@_jit
def mass_normalised(k, scale, rot_start, linv, a):
    """``a[p] = S k[p] Sᵀ`` (P, n, n), S = diag(scale) with the 3×3 blocks ``L⁻¹`` (I_cg = L Lᵀ) of the rotation
    DOFs starting at ``rot_start`` (B,) (docs/theory/structure.md: mass normalisation, same order of operations as
    :func:`pkmstiff.multibody.modal.dynamic_system`); ``scale`` (1|P, n), ``linv`` (1|P, B, 3, 3)."""
    n_p, n = k.shape[0], k.shape[1]
    n_rot = rot_start.shape[0]
    tmp = np.empty((3, n))
    for p in range(n_p):
        ps = p if scale.shape[0] > 1 else 0
        pl = p if linv.shape[0] > 1 else 0
        for i in range(n):
            si = scale[ps, i]
            for j in range(n):
                a[p, i, j] = k[p, i, j] * (si * scale[ps, j])
        for b in range(n_rot):
            s0 = rot_start[b]
            for r in range(3):  # rows: L⁻¹ a[idx, :]
                for j in range(n):
                    s = 0.0
                    for l in range(3):
                        s = _fma(linv[pl, b, r, l], a[p, s0 + l, j], s)
                    tmp[r, j] = s
            for r in range(3):
                for j in range(n):
                    a[p, s0 + r, j] = tmp[r, j]
            for i in range(n):  # columns: a[:, idx] L⁻ᵀ
                t0 = a[p, i, s0]
                t1 = a[p, i, s0 + 1]
                t2 = a[p, i, s0 + 2]
                for c in range(3):
                    a[p, i, s0 + c] = _fma(t2, linv[pl, b, c, 2], _fma(t1, linv[pl, b, c, 1], _fma(t0, linv[pl, b, c, 0], 0.0)))
