"""Compiled residuals and analytic Jacobians of a spatial constraint system (the hot path of the Newton solver).

The same equations as :func:`pkmstiff.mechanisms.constraints.block_eval` (DE 10 2004 026 707 A1 eq. 2–8, fixed
coordinates eq. 15–16, output equations [0017]), evaluated constraint instance by constraint instance in one
compiled loop per pose instead of one numpy call per constraint kind.  A :class:`Plan` flattens a system's blocks
once (kind code, links, points, axes, first row) so that an evaluation is a single call without Python work per
constraint; the numpy version stays the reference (tests compare both to rounding).  Spatial systems only
(planar mechanisms are small and keep the numpy path).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

_CHUNK = 256
#: kind codes of the compiled loop (block kinds of :mod:`pkmstiff.mechanisms.constraints`)
KIND = {"fixed": 0, "1A": 1, "1B": 2, "1C": 3, "1D": 4, "1E": 5, "1F": 6, "drive_lin": 7, "drive_rot": 8,
        "out_point": 9, "out_full": 10, "out_axis": 11}


@dataclass
class Plan:
    """A system's constraint instances as flat arrays (one entry per instance; ``out_point`` one per row)."""

    kind: np.ndarray  #: (ni,) int64 kind code
    j: np.ndarray  #: (ni,) int64 link j
    k: np.ndarray  #: (ni,) int64 link k (−1: world)
    row: np.ndarray  #: (ni,) int64 first row in the full system
    coord: np.ndarray  #: (ni,) int64 fixed / drive / output coordinate
    value: np.ndarray  #: (ni,) fixed value / drive offset
    p: np.ndarray  #: (ni, 3)
    a: np.ndarray  #: (ni, 3)
    b: np.ndarray  #: (ni, 3)
    has_full: bool
    has_axis: bool
    needs_target: bool  #: drive or output equations present


def make_plan(blocks) -> Plan:
    kind, j, k, row, coord, value, p, a, b = ([] for _ in range(9))
    for bl in blocks:
        code = KIND[bl.kind]
        for i in range(bl.n):
            if bl.kind == "out_point":
                for c_i, c in enumerate(bl.coord):
                    kind.append(code), j.append(bl.j[i]), k.append(-1), row.append(bl.row0 + c_i)
                    coord.append(int(c)), value.append(0.0), p.append(bl.p[i]), a.append(bl.a[i]), b.append(bl.b[i])
                continue
            kind.append(code), j.append(bl.j[i]), k.append(bl.k[i]), row.append(bl.row0 + i * bl.nrows)
            coord.append(int(bl.coord[i]) if bl.coord.size else 0)
            value.append(float(bl.value[i]) if bl.value.size else 0.0)
            p.append(bl.p[i]), a.append(bl.a[i]), b.append(bl.b[i])
    i64 = lambda v: np.array(v, dtype=np.int64)  # noqa: E731
    f3 = lambda v: np.array(v, dtype=float).reshape(-1, 3)  # noqa: E731
    kinds = {bl.kind for bl in blocks}
    return Plan(i64(kind), i64(j), i64(k), i64(row), i64(coord), np.array(value, dtype=float), f3(p), f3(a), f3(b),
                "out_full" in kinds, "out_axis" in kinds,
                bool(kinds & {"drive_lin", "drive_rot", "out_point", "out_full", "out_axis"}))


# ----------------------------------------------------------------------------------------------------------
# compiled kernel
# ----------------------------------------------------------------------------------------------------------


def _mm3(X, Y, out):  # pragma: no cover - compiled
    for r in range(3):
        for c in range(3):
            out[r, c] = X[r, 0] * Y[0, c] + X[r, 1] * Y[1, c] + X[r, 2] * Y[2, c]


def _rotations(q, L, R, dR, om, W, T7, given):  # pragma: no cover - compiled
    """R = Rz(φz) Ry(φy) Rx(φx) (eq. 2) of every link and dR[l, c] = ∂R/∂φ_c, or for the links with om[l] = 1
    dR[l, c] = [e_c]× R = ∂R/∂ω_c (an incremental world-frame rotation vector ω: no parametrisation singularity);
    W[l, c] = vee(dR[l, c] Rᵀ), the angular velocity per unit rate of coordinate c.  ``given``: R of the om links
    is already in ``R`` (the fused Newton keeps it as its state) and their angles in q are not read.
    ``T7`` (7, 3, 3): zero-initialised work matrices."""
    Rx, Ry, Rz, dX, dY, dZ, T = T7[0], T7[1], T7[2], T7[3], T7[4], T7[5], T7[6]
    for l in range(L):
        if not (given and om[l]):
            x, y, z = q[6 * l + 3], q[6 * l + 4], q[6 * l + 5]
            cx, sx, cy, sy, cz, sz = math.cos(x), math.sin(x), math.cos(y), math.sin(y), math.cos(z), math.sin(z)
            Rx[0, 0] = 1.0
            Rx[1, 1], Rx[1, 2], Rx[2, 1], Rx[2, 2] = cx, -sx, sx, cx
            dX[1, 1], dX[1, 2], dX[2, 1], dX[2, 2] = -sx, -cx, cx, -sx
            Ry[1, 1] = 1.0
            Ry[0, 0], Ry[0, 2], Ry[2, 0], Ry[2, 2] = cy, sy, -sy, cy
            dY[0, 0], dY[0, 2], dY[2, 0], dY[2, 2] = -sy, cy, -cy, -sy
            Rz[2, 2] = 1.0
            Rz[0, 0], Rz[0, 1], Rz[1, 0], Rz[1, 1] = cz, -sz, sz, cz
            dZ[0, 0], dZ[0, 1], dZ[1, 0], dZ[1, 1] = -sz, -cz, cz, -sz
            _mm3(Rz, Ry, T)
            _mm3(T, Rx, R[l])
        if om[l]:
            for c in range(3):  # [e_c]× R: row a of e_c × (column of R); its angular velocity is e_c
                c1 = (c + 1) % 3
                c2 = (c + 2) % 3
                for b in range(3):
                    dR[l, c, c, b] = 0.0
                    dR[l, c, c1, b] = -R[l, c2, b]
                    dR[l, c, c2, b] = R[l, c1, b]
                for a in range(3):
                    W[l, c, a] = 1.0 if a == c else 0.0
            continue
        _mm3(T, dX, dR[l, 0])
        _mm3(Rz, dY, T)
        _mm3(T, Rx, dR[l, 1])
        _mm3(dZ, Ry, T)
        _mm3(T, Rx, dR[l, 2])
        for c in range(3):
            for a in range(3):
                a1 = (a + 1) % 3
                a2 = (a + 2) % 3
                # vee(dR Rᵀ)_a = (dR Rᵀ)[a2, a1]
                W[l, c, a] = dR[l, c, a2, 0] * R[l, a1, 0] + dR[l, c, a2, 1] * R[l, a1, 1] + \
                    dR[l, c, a2, 2] * R[l, a1, 2]


def _point(q, R, dR, l, p, w, Dw):  # pragma: no cover - compiled
    """w = t_l + R_l p and Dw[a, c] = ∂w_a/∂φ_c."""
    for a in range(3):
        w[a] = q[6 * l + a] + R[l, a, 0] * p[0] + R[l, a, 1] * p[1] + R[l, a, 2] * p[2]
        for c in range(3):
            Dw[a, c] = dR[l, c, a, 0] * p[0] + dR[l, c, a, 1] * p[1] + dR[l, c, a, 2] * p[2]


def _vector(R, dR, l, v, U, DU):  # pragma: no cover - compiled
    """U = R_l v and DU[a, c] = ∂U_a/∂φ_c."""
    for a in range(3):
        U[a] = R[l, a, 0] * v[0] + R[l, a, 1] * v[1] + R[l, a, 2] * v[2]
        for c in range(3):
            DU[a, c] = dR[l, c, a, 0] * v[0] + dR[l, c, a, 1] * v[1] + dR[l, c, a, 2] * v[2]


def _cross(x, y, out):  # pragma: no cover - compiled
    out[0] = x[1] * y[2] - x[2] * y[1]
    out[1] = x[2] * y[0] - x[0] * y[2]
    out[2] = x[0] * y[1] - x[1] * y[0]


def _logm(M, r):  # pragma: no cover - compiled
    """Rotation vector r of the rotation matrix M (|r| = angle ∈ [0, π]): the unique root of log M = 0."""
    v0 = 0.5 * (M[2, 1] - M[1, 2])
    v1 = 0.5 * (M[0, 2] - M[2, 0])
    v2 = 0.5 * (M[1, 0] - M[0, 1])
    sn = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    cs = 0.5 * (M[0, 0] + M[1, 1] + M[2, 2] - 1.0)
    th = math.atan2(sn, cs)
    if cs > -0.99:
        f = 1.0 + sn * sn / 6.0 if sn < 1e-8 else th / sn
        r[0], r[1], r[2] = f * v0, f * v1, f * v2
        return
    # near half a turn: the axis from the symmetric part (M + I)/2 = cos-weighted u uᵀ, sign from v
    i = 0
    if M[1, 1] > M[i, i]:
        i = 1
    if M[2, 2] > M[i, i]:
        i = 2
    u = np.empty(3)
    for a in range(3):
        u[a] = 0.5 * (M[a, i] + M[i, a])
    u[i] = M[i, i] - cs
    nu = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
    sg = 1.0 if u[0] * v0 + u[1] * v1 + u[2] * v2 >= 0.0 else -1.0
    for a in range(3):
        r[a] = sg * th * u[a] / nu


def _jlinv(r, Ji):  # pragma: no cover - compiled
    """Inverse left Jacobian of SO(3): d log(exp(δ) M)/dδ at r = log M (Barfoot eq. 7.45):
    I − ½[r]× + (1/θ² − (1 + cos θ)/(2θ sin θ)) [r]×²."""
    th2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    th = math.sqrt(th2)
    if th < 1e-4:
        g = 1.0 / 12.0 + th2 / 720.0
    else:
        g = 1.0 / th2 - (1.0 + math.cos(th)) / (2.0 * th * math.sin(th))
    K = np.empty((3, 3))
    K[0, 0], K[0, 1], K[0, 2] = 0.0, -r[2], r[1]
    K[1, 0], K[1, 1], K[1, 2] = r[2], 0.0, -r[0]
    K[2, 0], K[2, 1], K[2, 2] = -r[1], r[0], 0.0
    for a in range(3):
        for b in range(3):
            k2 = K[a, 0] * K[0, b] + K[a, 1] * K[1, b] + K[a, 2] * K[2, b]
            Ji[a, b] = (1.0 if a == b else 0.0) - 0.5 * K[a, b] + g * k2


def _mmT(X, Y, out):  # pragma: no cover - compiled
    """out = X Yᵀ (3 × 3)."""
    for a in range(3):
        for b in range(3):
            out[a, b] = X[a, 0] * Y[b, 0] + X[a, 1] * Y[b, 1] + X[a, 2] * Y[b, 2]


def _log_rows(r, J, r0, cj, M, Wr, j, x, Ji, jac, roff, cmap):  # pragma: no cover - compiled
    """Rows r0…r0+2: log M (M = R_j ·ᵀ, a rotation of link j against another) and ∂/∂q_j,c = J_l⁻¹(log M) w_j,c;
    leaves log M in x and J_l⁻¹ in Ji."""
    _logm(M, x)
    for a in range(3):
        r[r0 + a] = x[a]
    if jac:
        _jlinv(x, Ji)
        for c in range(3):
            for a in range(3):
                _put(J, r0 + a, cj + 3 + c, Ji[a, 0] * Wr[j, c, 0] + Ji[a, 1] * Wr[j, c, 1]
                     + Ji[a, 2] * Wr[j, c, 2], roff, cmap)


def _put(J, row, col, val, roff, cmap):  # pragma: no cover - compiled
    rr = row - roff
    if rr >= 0:
        cc = cmap[col]
        if cc >= 0:
            J[rr, cc] = val


def _eval_impl(q, target, om, Rt, kind, lj, lk, row, coord, value, P, A, B, roff, cmap, jac, r, J):
    # pragma: no cover - compiled
    N = q.shape[0]
    L = q.shape[1] // 6
    ni = kind.shape[0]
    nchunk = (N + _CHUNK - 1) // _CHUNK
    for ch in numba.prange(nchunk):  # scratch arrays once per chunk of poses, not per pose
        _eval_chunk(q, target, om, Rt, kind, lj, lk, row, coord, value, P, A, B, roff, cmap, jac, r, J, L, ni,
                    ch * _CHUNK, min(N, (ch + 1) * _CHUNK))


def _scratch(L):  # pragma: no cover - compiled
    """Work arrays of one evaluation (per thread, reused for every pose it evaluates)."""
    return (np.zeros((7, 3, 3)), np.empty((L, 3, 3)), np.empty((L, 3, 3, 3)), np.empty((L, 3, 3)), np.empty((3, 3)),
            np.empty((3, 3)),
            np.empty(3), np.empty(3), np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3), np.empty(3),
            np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3), np.empty(3), np.empty(3))


def _eval_chunk(q, target, om, Rt, kind, lj, lk, row, coord, value, P, A, B, roff, cmap, jac, r, J, L, ni,
                n0, n1):  # pragma: no cover - compiled
    S = _scratch(L)
    for n in range(n0, n1):
        _eval_pose(q[n], target[min(n, target.shape[0] - 1)], om, Rt[min(n, Rt.shape[0] - 1)], kind, lj, lk, row,
                   coord, value, P, A, B, roff, cmap, jac, r[n], J[min(n, J.shape[0] - 1)], L, ni, S, False)


def _eval_pose(qn, tn, om, Rtn, kind, lj, lk, row, coord, value, P, A, B, roff, cmap, jac, rn, Jn, L, ni,
               S, given):  # pragma: no cover - compiled
    """Residual rn (m,) and Jacobian Jn (m − roff, ncol) (only the constraints' entries are written: Jn starts
    zeroed) at the link coordinates qn (L·6,) for the control values tn (drive values / output pose) and Rtn (the
    output pose's rotation); ``S`` from :func:`_scratch`; ``given``: see :func:`_rotations` (R in ``S[1]``)."""
    T7, R, dR, Wr, M, Ji, wj, wk, Dwj, Dwk, U, V, W, DU, DV, DW, d, x1, x2, x3 = S
    _rotations(qn, L, R, dR, om, Wr, T7, given)
    for i in range(ni):
        kd = kind[i]
        j = lj[i]
        k = lk[i]
        r0 = row[i]
        cj = 6 * j
        ck = 6 * k
        if kd == 0:  # fixed coordinate (eq. 15-16)
            rn[r0] = qn[cj + coord[i]] - value[i]
            if jac:
                _put(Jn, r0, cj + coord[i], 1.0, roff, cmap)
        elif kd == 1:  # 1A common point (eq. 3)
            _point(qn, R, dR, j, P[i], wj, Dwj)
            _point(qn, R, dR, k, P[i], wk, Dwk)
            for a in range(3):
                rn[r0 + a] = wj[a] - wk[a]
                if jac:
                    _put(Jn, r0 + a, cj + a, 1.0, roff, cmap)
                    _put(Jn, r0 + a, ck + a, -1.0, roff, cmap)
                    for c in range(3):
                        _put(Jn, r0 + a, cj + 3 + c, Dwj[a, c], roff, cmap)
                        _put(Jn, r0 + a, ck + 3 + c, -Dwk[a, c], roff, cmap)
        elif kd == 2:  # 1B equal orientation (eq. 4) as log(R_j R_kᵀ) = 0 (see constraints.block_eval)
            _mmT(R[j], R[k], M)
            _log_rows(rn, Jn, r0, cj, M, Wr, j, x1, Ji, jac, roff, cmap)
            if jac:
                for c in range(3):
                    for a in range(3):  # ∂r/∂q_k,c = −J⁻¹ M w_k,c
                        x2[a] = M[a, 0] * Wr[k, c, 0] + M[a, 1] * Wr[k, c, 1] + M[a, 2] * Wr[k, c, 2]
                    for a in range(3):
                        _put(Jn, r0 + a, ck + 3 + c, -(Ji[a, 0] * x2[0] + Ji[a, 1] * x2[1] + Ji[a, 2] * x2[2]),
                             roff, cmap)
        elif kd == 3:  # 1C common axis direction (eq. 5)
            _vector(R, dR, j, A[i], U, DU)
            _vector(R, dR, k, A[i], V, DV)
            for a in range(3):
                rn[r0 + a] = U[a] - V[a]
                if jac:
                    for c in range(3):
                        _put(Jn, r0 + a, cj + 3 + c, DU[a, c], roff, cmap)
                        _put(Jn, r0 + a, ck + 3 + c, -DV[a, c], roff, cmap)
        elif kd == 4:  # 1D perpendicular axes (eq. 6)
            _vector(R, dR, j, A[i], U, DU)
            _vector(R, dR, k, B[i], V, DV)
            rn[r0] = U[0] * V[0] + U[1] * V[1] + U[2] * V[2]
            if jac:
                for c in range(3):
                    _put(Jn, r0, cj + 3 + c, DU[0, c] * V[0] + DU[1, c] * V[1] + DU[2, c] * V[2], roff, cmap)
                    _put(Jn, r0, ck + 3 + c, DV[0, c] * U[0] + DV[1, c] * U[1] + DV[2, c] * U[2], roff, cmap)
        elif kd == 5:  # 1E point on axis (eq. 7): (w_j − w_k) × u_j
            _point(qn, R, dR, j, P[i], wj, Dwj)
            _point(qn, R, dR, k, P[i], wk, Dwk)
            _vector(R, dR, j, A[i], U, DU)
            for a in range(3):
                d[a] = wj[a] - wk[a]
            _cross(d, U, x1)
            for a in range(3):
                rn[r0 + a] = x1[a]
            if jac:
                # ∂/∂t_j: e_c × u (columns), ∂/∂t_k the negative
                _put(Jn, r0 + 0, cj + 1, U[2], roff, cmap)
                _put(Jn, r0 + 0, cj + 2, -U[1], roff, cmap)
                _put(Jn, r0 + 1, cj + 0, -U[2], roff, cmap)
                _put(Jn, r0 + 1, cj + 2, U[0], roff, cmap)
                _put(Jn, r0 + 2, cj + 0, U[1], roff, cmap)
                _put(Jn, r0 + 2, cj + 1, -U[0], roff, cmap)
                _put(Jn, r0 + 0, ck + 1, -U[2], roff, cmap)
                _put(Jn, r0 + 0, ck + 2, U[1], roff, cmap)
                _put(Jn, r0 + 1, ck + 0, U[2], roff, cmap)
                _put(Jn, r0 + 1, ck + 2, -U[0], roff, cmap)
                _put(Jn, r0 + 2, ck + 0, -U[1], roff, cmap)
                _put(Jn, r0 + 2, ck + 1, U[0], roff, cmap)
                for c in range(3):
                    for a in range(3):
                        x2[a] = Dwj[a, c]
                        x3[a] = DU[a, c]
                    _cross(x2, U, W)
                    _cross(d, x3, x1)
                    for a in range(3):
                        _put(Jn, r0 + a, cj + 3 + c, W[a] + x1[a], roff, cmap)
                    for a in range(3):
                        x2[a] = Dwk[a, c]
                    _cross(x2, U, W)
                    for a in range(3):
                        _put(Jn, r0 + a, ck + 3 + c, -W[a], roff, cmap)
        elif kd == 6 or kd == 7:  # 1F point in plane u_j·(w_j − w_k); drive (eq. 8) u·(w_k − w_j) + off − s
            sg = 1.0 if kd == 6 else -1.0
            _point(qn, R, dR, j, P[i], wj, Dwj)
            _point(qn, R, dR, k, P[i], wk, Dwk)
            _vector(R, dR, j, A[i], U, DU)
            for a in range(3):
                d[a] = wj[a] - wk[a]
            res = sg * (d[0] * U[0] + d[1] * U[1] + d[2] * U[2])
            if kd == 7:
                res += value[i] - tn[coord[i]]
            rn[r0] = res
            if jac:
                for a in range(3):
                    _put(Jn, r0, cj + a, sg * U[a], roff, cmap)
                    _put(Jn, r0, ck + a, -sg * U[a], roff, cmap)
                for c in range(3):
                    gj = 0.0
                    gk = 0.0
                    for a in range(3):
                        gj += Dwj[a, c] * U[a] + d[a] * DU[a, c]
                        gk += Dwk[a, c] * U[a]
                    _put(Jn, r0, cj + 3 + c, sg * gj, roff, cmap)
                    _put(Jn, r0, ck + 3 + c, -sg * gk, roff, cmap)
        elif kd == 8:  # revolute drive: wrapped relative angle about the axis a (see block_eval)
            th = tn[coord[i]] - value[i]
            c0, s0 = math.cos(th), math.sin(th)
            _vector(R, dR, j, A[i], W, DW)  # A
            _vector(R, dR, j, B[i], U, DU)  # U
            _vector(R, dR, k, B[i], V, DV)  # V
            _cross(U, V, x1)
            S = W[0] * x1[0] + W[1] * x1[1] + W[2] * x1[2]
            C = U[0] * V[0] + U[1] * V[1] + U[2] * V[2]
            rn[r0] = math.atan2(c0 * S - s0 * C, c0 * C + s0 * S)
            n2 = S * S + C * C
            if jac:
                _cross(V, W, x2)
                _cross(W, U, x3)
                for c in range(3):
                    dSj = 0.0
                    dSk = 0.0
                    dCj = 0.0
                    dCk = 0.0
                    for a in range(3):
                        dSj += DW[a, c] * x1[a] + DU[a, c] * x2[a]
                        dSk += DV[a, c] * x3[a]
                        dCj += DU[a, c] * V[a]
                        dCk += DV[a, c] * U[a]
                    _put(Jn, r0, cj + 3 + c, (C * dSj - S * dCj) / n2, roff, cmap)
                    _put(Jn, r0, ck + 3 + c, (C * dSk - S * dCk) / n2, roff, cmap)
        elif kd == 9:  # output point coordinate
            _point(qn, R, dR, j, P[i], wj, Dwj)
            c_ = coord[i]
            rn[r0] = wj[c_] - tn[c_]
            if jac:
                _put(Jn, r0, cj + c_, 1.0, roff, cmap)
                for c in range(3):
                    _put(Jn, r0, cj + 3 + c, Dwj[c_, c], roff, cmap)
        elif kd == 10:  # output orientation: log(R_j R(target)ᵀ) = 0
            _mmT(R[j], Rtn, M)
            _log_rows(rn, Jn, r0, cj, M, Wr, j, x1, Ji, jac, roff, cmap)
        else:  # output axis: R_j a = R(target) a
            _vector(R, dR, j, A[i], U, DU)
            for a in range(3):
                rn[r0 + a] = U[a] - (Rtn[a, 0] * A[i, 0] + Rtn[a, 1] * A[i, 1] + Rtn[a, 2] * A[i, 2])
                if jac:
                    for c in range(3):
                        _put(Jn, r0 + a, cj + 3 + c, DU[a, c], roff, cmap)


_OPTS = dict(cache=True, nogil=True, error_model="numpy")
#: the small helpers of the constraint loop are inlined (numba IR level): a call with array arguments costs about
#: as much as the few products it does (measured: the 6-UPS residual 2.6 → 2.0 µs per pose)
_INLINE = {f: {"inline": "always"} for f in ("_point", "_vector", "_cross", "_put")}
_helpers = {}
for _f in (_mm3, _mmT, _rotations, _point, _vector, _cross, _logm, _jlinv, _put, _log_rows, _scratch, _eval_pose,
           _eval_chunk):
    _helpers[_f.__name__] = numba.njit(**_OPTS, **_INLINE.get(_f.__name__, {}))(_f)
    globals()[_f.__name__] = _helpers[_f.__name__]


def _renamed(fn, name):
    """A copy of ``fn`` under another name (numba's disk cache is keyed by the function; see linalg)."""
    import types

    code = fn.__code__.replace(co_name=name, co_qualname=name) if hasattr(fn.__code__, "co_qualname") else \
        fn.__code__.replace(co_name=name)
    out = types.FunctionType(code, fn.__globals__, name, fn.__defaults__, fn.__closure__)
    out.__qualname__ = name
    return out


def _rotate_link(x, y, z, w0, w1, w2, out):  # pragma: no cover - compiled
    """out[:3] ← angles φ' of exp([w]×) R(φ) for the link angles φ = (x, y, z) and the rotation vector w."""
    cx, sx, cy, sy, cz, sz = math.cos(x), math.sin(x), math.cos(y), math.sin(y), math.cos(z), math.sin(z)
    # R = Rz Ry Rx (eq. 2)
    R00, R01, R02 = cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx
    R10, R11, R12 = sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx
    R20, R21, R22 = -sy, cy * sx, cy * cx
    th2 = w0 * w0 + w1 * w1 + w2 * w2
    th = math.sqrt(th2)
    if th < 1e-8:
        a, b = 1.0 - th2 / 6.0, 0.5 - th2 / 24.0
    else:
        a, b = math.sin(th) / th, (1.0 - math.cos(th)) / th2
    # E = I + a K + b K², K = [w]× (Rodrigues)
    E00, E11, E22 = 1.0 - b * (w1 * w1 + w2 * w2), 1.0 - b * (w0 * w0 + w2 * w2), 1.0 - b * (w0 * w0 + w1 * w1)
    E01, E10 = -a * w2 + b * w0 * w1, a * w2 + b * w0 * w1
    E02, E20 = a * w1 + b * w0 * w2, -a * w1 + b * w0 * w2
    E12, E21 = -a * w0 + b * w1 * w2, a * w0 + b * w1 * w2
    N00 = E00 * R00 + E01 * R10 + E02 * R20
    N10 = E10 * R00 + E11 * R10 + E12 * R20
    N20 = E20 * R00 + E21 * R10 + E22 * R20
    N01 = E00 * R01 + E01 * R11 + E02 * R21
    N11 = E10 * R01 + E11 * R11 + E12 * R21
    N02 = E00 * R02 + E01 * R12 + E02 * R22
    N12 = E10 * R02 + E11 * R12 + E12 * R22
    _angles(N00, N10, N20, N01, N11, N02, N12, out)


def _angles(N00, N10, N20, N01, N11, N02, N12, out):  # pragma: no cover - compiled
    """out[:3] ← link angles (φx, φy, φz) of the rotation N as constraints.link_angles (exact at φy = ±90°)."""
    py = math.atan2(-N20, math.hypot(N00, N10))
    pz = math.atan2(N10, N00)
    c, s_ = math.cos(pz), math.sin(pz)
    out[0] = math.atan2(-(-s_ * N02 + c * N12), -s_ * N01 + c * N11)
    out[1] = py
    out[2] = pz


def _exp_left(w0, w1, w2, R, out):  # pragma: no cover - compiled
    """out ← exp([w]×) R (Rodrigues: I + a K + b K², K = [w]×)."""
    th2 = w0 * w0 + w1 * w1 + w2 * w2
    if th2 < 1e-16:
        a, b = 1.0 - th2 / 6.0, 0.5 - th2 / 24.0
    else:
        th = math.sqrt(th2)
        a, b = math.sin(th) / th, (1.0 - math.cos(th)) / th2
    E00, E11, E22 = 1.0 - b * (w1 * w1 + w2 * w2), 1.0 - b * (w0 * w0 + w2 * w2), 1.0 - b * (w0 * w0 + w1 * w1)
    E01, E10 = -a * w2 + b * w0 * w1, a * w2 + b * w0 * w1
    E02, E20 = a * w1 + b * w0 * w2, -a * w1 + b * w0 * w2
    E12, E21 = -a * w0 + b * w1 * w2, a * w0 + b * w1 * w2
    for c in range(3):
        x, y, z = R[0, c], R[1, c], R[2, c]
        out[0, c] = E00 * x + E01 * y + E02 * z
        out[1, c] = E10 * x + E11 * y + E12 * z
        out[2, c] = E20 * x + E21 * y + E22 * z


_angles = numba.njit(**_OPTS)(_angles)
_exp_left = numba.njit(**_OPTS)(_exp_left)
_rotate_link = numba.njit(**_OPTS)(_rotate_link)


@numba.njit(**_OPTS)
def _rotate_impl(phi, w, out):  # pragma: no cover - compiled
    for n in range(phi.shape[0]):
        for l in range(phi.shape[1]):
            _rotate_link(phi[n, l, 0], phi[n, l, 1], phi[n, l, 2], w[n, l, 0], w[n, l, 1], w[n, l, 2], out[n, l])


def rotate(phi: Array, w: Array) -> Array:
    """Angles φ' (N, nl, 3) of exp([w]×) R(φ) for link angles φ and rotation vectors w (N, nl, 3) (the compiled
    :meth:`pkmstiff.mechanisms.constraints.System.step`)."""
    out = np.empty_like(phi)
    _rotate_impl(np.ascontiguousarray(phi, dtype=float), np.ascontiguousarray(w, dtype=float), out)
    return out


_eval_parallel = numba.njit(parallel=True, **_OPTS)(_eval_impl)
_eval_serial = numba.njit(**_OPTS)(_renamed(_eval_impl, "_eval_serial_impl"))
#: below this many poses the serial kernel is used (a parallel region costs more than it saves for small
#: batches, and much more on a loaded machine)
PARALLEL_MIN = 2048


def evaluate(plan: Plan, q: Array, target: Array | None, om: np.ndarray, Rt: Array | None, m: int, roff: int,
             cmap: np.ndarray, ncol: int, jac: bool) -> tuple[Array, Array | None]:
    """Residual (N, m) and Jacobian (N, m − roff, ncol) (columns through ``cmap``, −1 = dropped) of the plan;
    ``om`` (L,) int64: links whose rotation columns are incremental rotation vectors (1) or the angles φ (0)."""
    N = q.shape[0]
    qf = np.ascontiguousarray(q.reshape(N, -1), dtype=float)
    if target is None and plan.needs_target:
        raise ValueError("kernel.evaluate: drive/output equations need target values")  # no bounds checks inside
    tg = np.zeros((N, 1)) if target is None else np.ascontiguousarray(target, dtype=float)
    rt = np.zeros((1, 3, 3)) if Rt is None else np.ascontiguousarray(Rt)
    r = np.empty((N, m))
    J = np.zeros((N, m - roff, ncol)) if jac else np.zeros((1, 1, 1))
    kern = _eval_parallel if N >= PARALLEL_MIN else _eval_serial
    kern(qf, tg, np.ascontiguousarray(om, dtype=np.int64), rt, plan.kind, plan.j, plan.k, plan.row, plan.coord, plan.value, plan.p, plan.a, plan.b,
         roff, cmap, jac, r, J)
    return r, (J if jac else None)
