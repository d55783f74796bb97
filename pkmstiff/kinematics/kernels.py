"""Compiled (numba) kernels of the pose pipeline's hot paths: collision geometry, QR of J_C^-1, joint angles.

This module holds the only implementation of each geometric primitive of docs/theory/admissibility.md (Cobet App. B.4)
and of the batched 6×6 QR of §1.4/§1.6; the array-level public functions in :mod:`pkmstiff.admissibility.collision`,
:mod:`pkmstiff.kinematics`, :mod:`pkmstiff.kinematics.joint_angles` and :mod:`pkmstiff.admissibility.checks` are thin wrappers
that validate and lay out the arrays and call the kernels here.

Conventions:

* scalar primitives take points as 3-tuples of floats (kept in registers by the compiler) and follow numpy's
  NaN semantics (a NaN input gives a NaN distance / a False test, so unreachable chains never collide);
* per-pose kernels take "component-first" arrays (pose axis last, C-contiguous), the internal layout of
  :mod:`pkmstiff.kinematics`, e.g. joint points (3, n, N), rotations (3, 3, N), J_C^-1 (n, n, N);
* ``error_model="numpy"``: division by zero gives inf/NaN instead of raising, as in the numpy code paths;
  no ``fastmath``, so NaN/inf handling and IEEE rounding are kept;
* ``cache=True``: compiled code is stored next to this file (``__pycache__``), so only the first run on a
  machine pays the compile time (a few seconds, measured by ``benchmarks/bench_admissibility.py``).
  All kernels live in this one module because numba's cache is invalidated per source file.

Callers take the kernels from :func:`pkmstiff.kinematics.dispatch.kernels_for`: the same source runs interpreted
(without importing numba) for the first few poses of a process, and compiled after that (start-up time of one-pose
commands, issue 12 item 6).
"""

from __future__ import annotations

import math

import numpy as np

#: relative tolerance of the parallel / degenerate-segment tests of the collision primitives
EPS = 1e-12

if globals().get("_PURE_PYTHON"):  # the interpreted twin (pkmstiff.kinematics.dispatch): the same source, no numba
    def _jit(fn):
        return fn
else:
    import numba

    _jit = numba.njit(cache=True, nogil=True, error_model="numpy")


# ------------------------------------------------------------------------------------------------ 3-vector helpers


@_jit
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@_jit
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@_jit
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@_jit
def _norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@_jit
def _finite3(a):
    return math.isfinite(a[0]) and math.isfinite(a[1]) and math.isfinite(a[2])


@_jit
def _maximum(a, b):
    """np.maximum for scalars: NaN if either is NaN."""
    if a != a or b != b:
        return a + b
    return a if a > b else b


@_jit
def _minimum(a, b):
    """np.minimum for scalars: NaN if either is NaN."""
    if a != a or b != b:
        return a + b
    return a if a < b else b


@_jit
def _clip01(x):
    """np.clip(x, 0, 1) for scalars (NaN stays NaN)."""
    if x < 0.0:
        return 0.0
    if x > 1.0:
        return 1.0
    return x


@_jit
def _combine(w, s, u, t, v):
    """w + s u - t v."""
    return (w[0] + s * u[0] - t * v[0], w[1] + s * u[1] - t * v[1], w[2] + s * u[2] - t * v[2])


# ------------------------------------------------------------------------------------------ geometric primitives


@_jit
def point_segment_distance(x, p, q):
    """Distance of point x from segment [p, q]."""
    u = _sub(q, p)
    t = _clip01(_dot(_sub(x, p), u) / _maximum(_dot(u, u), EPS))
    return _norm(_sub(_combine(p, t, u, 0.0, u), x))


@_jit
def segment_distance(p1, q1, p2, q2, table_b2):
    """Distance between segments [p1, q1] and [p2, q2] (Cobet eq. B.7-B.11, Table B.2).

    ``table_b2=False``: the exact segment-segment distance (closest points of the infinite lines, clamp one
    parameter, re-project onto the other segment and clamp again). ``table_b2=True``: the dissertation's table,
    both line parameters clamped independently (may overestimate). Parallel segments (B.10): end points.
    """
    u = _sub(q1, p1)
    v = _sub(q2, p2)
    w = _sub(p1, p2)
    a = _dot(u, u)
    b = _dot(u, v)
    c = _dot(v, v)
    d = _dot(u, w)
    e = _dot(v, w)
    denom = a * c - b * b
    parallel = denom <= EPS * _maximum(a * c, EPS)
    a_safe = a if a > 0.0 else 1.0  # only exact zeros need guarding: the quotients below are well scaled
    c_safe = c if c > 0.0 else 1.0
    s_line = 0.0 if parallel else (b * e - c * d) / denom
    if parallel:  # (nearly) parallel: the minimum lies at an end point of one of the struts (B.10) - both modes
        par = _minimum(point_segment_distance(p1, p2, q2), point_segment_distance(q1, p2, q2))
        return _minimum(par, _minimum(point_segment_distance(p2, p1, q1), point_segment_distance(q2, p1, q1)))
    if table_b2:
        s = _clip01(s_line)
        t = _clip01((a * e - b * d) / denom)
        return _norm(_combine(w, s, u, t, v))
    s = _clip01(s_line)
    t = (b * s + e) / c_safe
    if t < 0.0:
        s = _clip01(-d / a_safe)
    elif t > 1.0:
        s = _clip01((b - d) / a_safe)
    t = _clip01(t)  # a point-like second segment (c = 0) took the parallel branch above; a merely short one is
    return _norm(_combine(w, s, u, t, v))  # well conditioned here (t ~ |w|/|v|), so no special case is needed


@_jit
def segment_pierces_triangle(a, b, t1, t2, t3):
    """True if segment [a, b] intersects triangle (t1, t2, t3) (Moller-Trumbore; Fig. B.5, Note to eq. B.12).

    A segment lying in the triangle's plane does not count (its edges are caught by the edge-distance test).
    """
    e1 = _sub(t2, t1)
    e2 = _sub(t3, t1)
    dvec = _sub(b, a)
    pvec = _cross(dvec, e2)
    det = _dot(e1, pvec)
    if not abs(det) > EPS * _maximum(_norm(e1) * _norm(e2), EPS):
        return False
    inv = 1.0 / det
    tvec = _sub(a, t1)
    beta = _dot(tvec, pvec) * inv
    qvec = _cross(tvec, e1)
    gamma = _dot(dvec, qvec) * inv
    lam = _dot(e2, qvec) * inv
    return beta >= 0.0 and gamma >= 0.0 and beta + gamma <= 1.0 and lam >= 0.0 and lam <= 1.0


@_jit
def point_triangle_face_distance(x, t1, t2, t3):
    """Distance of x from the triangle's plane where its projection falls inside the triangle, else inf."""
    e1 = _sub(t2, t1)
    e2 = _sub(t3, t1)
    n = _cross(e1, e2)
    nn = _dot(n, n)
    rel = _sub(x, t1)
    h = _dot(rel, n) / math.sqrt(_maximum(nn, EPS))
    d11, d12, d22 = _dot(e1, e1), _dot(e1, e2), _dot(e2, e2)
    r1, r2 = _dot(rel, e1), _dot(rel, e2)
    beta = (d22 * r1 - d12 * r2) / _maximum(nn, EPS)
    gamma = (d11 * r2 - d12 * r1) / _maximum(nn, EPS)
    if beta >= 0.0 and gamma >= 0.0 and beta + gamma <= 1.0 and nn > EPS:
        return abs(h)
    return math.inf


@_jit
def segment_triangle_distance(a, b, t1, t2, t3):
    """Exact distance between segment [a, b] and triangle (t1, t2, t3): 0 if it pierces, else the minimum of
    the distances to the three edges and of the end points to the face."""
    if segment_pierces_triangle(a, b, t1, t2, t3):
        return 0.0
    edge = _minimum(_minimum(segment_distance(a, b, t1, t2, False), segment_distance(a, b, t2, t3, False)),
                    segment_distance(a, b, t3, t1, False))
    face = _minimum(point_triangle_face_distance(a, t1, t2, t3), point_triangle_face_distance(b, t1, t2, t3))
    return _minimum(edge, face)


#: operation codes of :func:`primitive_many`: name -> (code, number of input points)
PRIMITIVES = {
    "segment_distance_exact": (0, 4),
    "segment_distance_table_B2": (1, 4),
    "point_segment_distance": (2, 3),
    "segment_pierces_triangle": (3, 5),
    "point_triangle_face_distance": (4, 4),
    "segment_triangle_distance": (5, 5),
}


@_jit
def _row(x, m, k):
    return (x[m, k, 0], x[m, k, 1], x[m, k, 2])


@_jit
def primitive_many(op, pts, out):
    """Evaluate one primitive (code ``op`` of PRIMITIVES) for M rows: ``pts`` (M, k, 3) holds the k input
    points of each row in argument order; ``out`` (M,) gets the distance (or 1.0/0.0 for the piercing test)."""
    for m in range(pts.shape[0]):
        if op == 0 or op == 1:
            out[m] = segment_distance(_row(pts, m, 0), _row(pts, m, 1), _row(pts, m, 2), _row(pts, m, 3), op == 1)
        elif op == 2:
            out[m] = point_segment_distance(_row(pts, m, 0), _row(pts, m, 1), _row(pts, m, 2))
        elif op == 3:
            hit = segment_pierces_triangle(_row(pts, m, 0), _row(pts, m, 1), _row(pts, m, 2), _row(pts, m, 3),
                                           _row(pts, m, 4))
            out[m] = 1.0 if hit else 0.0
        elif op == 4:
            out[m] = point_triangle_face_distance(_row(pts, m, 0), _row(pts, m, 1), _row(pts, m, 2),
                                                  _row(pts, m, 3))
        else:
            out[m] = segment_triangle_distance(_row(pts, m, 0), _row(pts, m, 1), _row(pts, m, 2),
                                               _row(pts, m, 3), _row(pts, m, 4))


# ------------------------------------------------------------------------------------------- collision kernels


@_jit
def _col(x, i, k):
    """Point i of pose k from component-first storage (3, n, N)."""
    return (x[0, i, k], x[1, i, k], x[2, i, k])


@_jit
def strut_collision(p, q, ii, jj, rsum, table_b2, bad):
    """B.7 for all listed strut pairs of every pose: ``bad[k, c]`` = distance of struts ii[c], jj[c] < rsum[c].

    ``p``, ``q`` (3, n, N) platform- and drive-side joint points; NaN points (unreachable chains) never collide.
    """
    for k in range(p.shape[2]):
        for c in range(ii.shape[0]):
            i = ii[c]
            j = jj[c]
            dist = segment_distance(_col(p, i, k), _col(q, i, k), _col(p, j, k), _col(q, j, k), table_b2)
            bad[k, c] = dist < rsum[c]


@_jit
def clip_to_expanded_hull(a, b, r, normals, offsets):
    """True if segment [a, b] meets the convex hull {x: n_f . x <= h_f} with every plane pushed out by r
    (Cyrus-Beck). That region contains every point closer than r to the hull, so False rejects exactly."""
    d = _sub(b, a)
    t_enter = 0.0
    t_exit = 1.0
    for f in range(normals.shape[0]):
        nf = (normals[f, 0], normals[f, 1], normals[f, 2])
        na = _dot(a, nf)
        nd = _dot(d, nf)
        room = offsets[f] + r - na  # n.(a + t d) <= h + r  <=>  t nd <= room
        if abs(nd) < 1e-15 and room < 0.0:
            return False  # parallel to the plane and outside it
        if nd < 0.0:
            t_enter = max(t_enter, room / nd)
        elif nd > 0.0:
            t_exit = min(t_exit, room / nd)
        if t_enter > t_exit:
            return False
    return True


@_jit
def segment_hits_hull(a, b, r, tri, edges):
    """Exact strut-hull test (Fig. B.3-B.5, eq. B.12 as corrected in the spec): the axis [a, b] pierces a
    triangle, or an edge is closer than r, or an end point is closer than r to a face."""
    for f in range(tri.shape[0]):
        t1, t2, t3 = _row(tri, f, 0), _row(tri, f, 1), _row(tri, f, 2)
        if segment_pierces_triangle(a, b, t1, t2, t3):
            return True
        if point_triangle_face_distance(a, t1, t2, t3) < r or point_triangle_face_distance(b, t1, t2, t3) < r:
            return True
    for e in range(edges.shape[0]):
        if segment_distance(a, b, _row(edges, e, 0), _row(edges, e, 1), False) < r:
            return True
    return False


@_jit
def platform_collision(q, rot, w, pj, excl, radius, normals, offsets, tri, edges, convex, bad):
    """Strut-platform collision of every strut of every pose, in platform coordinates (see
    :func:`pkmstiff.admissibility.checks.check_platform_collision`).

    ``q`` (3, n, N) drive-side joints, ``rot`` (3, 3, N), ``w`` (3, N) MKS; ``pj`` (n, 3) platform joints p'_i,
    ``excl`` (n,) length excluded at the platform end, ``radius`` (n,); hull: ``normals`` (F, 3), ``offsets`` (F,)
    of the convex hull's planes, ``tri`` (T, 3, 3), ``edges`` (E, 2, 3) in the PKS. ``bad`` (N, n) out.
    """
    for k in range(q.shape[2]):
        for i in range(q.shape[1]):
            dx, dy, dz = q[0, i, k] - w[0, k], q[1, i, k] - w[1, k], q[2, i, k] - w[2, k]
            b = (rot[0, 0, k] * dx + rot[1, 0, k] * dy + rot[2, 0, k] * dz,  # R^T (q - w)
                 rot[0, 1, k] * dx + rot[1, 1, k] * dy + rot[2, 1, k] * dz,
                 rot[0, 2, k] * dx + rot[1, 2, k] * dy + rot[2, 2, k] * dz)
            if not _finite3(b):
                bad[k, i] = False
                continue
            p0 = (pj[i, 0], pj[i, 1], pj[i, 2])
            seg = _sub(b, p0)
            length = max(_norm(seg), 1e-12)
            a = (p0[0] + seg[0] / length * excl[i], p0[1] + seg[1] / length * excl[i],
                 p0[2] + seg[2] / length * excl[i])
            r = radius[i]
            if not clip_to_expanded_hull(a, b, r, normals, offsets):
                bad[k, i] = False
            elif convex and clip_to_expanded_hull(a, b, 0.0, normals, offsets):
                bad[k, i] = True  # a segment entering the convex hull itself collides
            else:
                bad[k, i] = segment_hits_hull(a, b, r, tri, edges)


# ------------------------------------------------------------------------------------- QR of J_C^-1 (n × n)


@_jit
def qr_inverse(A, start, stop, want_rt, want_inv, want_bounds, r_out, t_out, inv_out, lo_out, hi_out, ok_out):
    """Householder QR of A[:, :, m] (component-first (n, n, N)) for m in [start, stop), with R^-1 and
    optionally A^-1 = R^-1 Q^T and cheap certified bounds of κ(A) (see :func:`pkmstiff.kinematics.condition_bounds`).

    Unpivoted Householder QR (backward stable): H_k = I - β_k v_k v_k^T on rows k..n-1, sign of α chosen against
    cancellation; an exactly singular matrix gives a zero R_kk and inf/NaN in R^-1. Matrices with NaN/inf are
    replaced by the identity (``ok_out`` False, inverse NaN, bounds inf). Outputs: ``r_out``, ``t_out``
    (n, n, stop - start) R and R^-1 if ``want_rt``; ``inv_out`` (N, n, n) pose-first, NaN where not ok or not
    finite; ``lo_out``, ``hi_out`` (N,); ``ok_out`` (stop - start,) = finite input and finite R^-1.
    """
    n = A.shape[0]
    W = np.empty((n, n))
    V = np.zeros((n, n))  # row k: reflector v_k on entries k..n-1
    beta = np.zeros(n)
    T = np.empty((n, n))
    X = np.empty((n, n))
    for m in range(start, stop):
        finite = True
        for i in range(n):
            for j in range(n):
                W[i, j] = A[i, j, m]
                if not math.isfinite(W[i, j]):
                    finite = False
        if not finite:
            for i in range(n):
                for j in range(n):
                    W[i, j] = 1.0 if i == j else 0.0
        for k in range(n - 1):
            sq = 0.0
            for i in range(k, n):
                sq += W[i, k] * W[i, k]
            normx = math.sqrt(sq)
            x0 = W[k, k]
            alpha = -normx if x0 >= 0.0 else normx
            for i in range(k, n):
                V[k, i] = W[i, k]
            V[k, k] = x0 - alpha
            vtv = normx * normx - x0 * x0 + V[k, k] * V[k, k]
            bk = 2.0 / vtv if vtv > 0.0 else 0.0
            beta[k] = bk
            for j in range(k + 1, n):
                s = 0.0
                for i in range(k, n):
                    s += V[k, i] * W[i, j]
                s *= bk
                for i in range(k, n):
                    W[i, j] -= V[k, i] * s
            W[k, k] = alpha
            for i in range(k + 1, n):
                W[i, k] = 0.0
        ok = finite
        for i in range(n - 1, -1, -1):  # R^-1 by back substitution
            dinv = 1.0 / W[i, i]
            for j in range(i):
                T[i, j] = 0.0
            T[i, i] = dinv
            for j in range(i + 1, n):
                s = W[i, i + 1] * T[i + 1, j]
                for k in range(i + 2, j + 1):
                    s += W[i, k] * T[k, j]
                T[i, j] = -s * dinv
            for j in range(i, n):
                if not math.isfinite(T[i, j]):
                    ok = False
        ok_out[m - start] = ok
        if want_rt:
            for i in range(n):
                for j in range(n):
                    r_out[i, j, m - start] = W[i, j]
                    t_out[i, j, m - start] = T[i, j]
        if want_inv:
            for i in range(n):
                for j in range(n):
                    X[i, j] = T[i, j]
            for k in range(n - 2, -1, -1):  # X = R^-1 H_{n-2} ... H_0 = R^-1 Q^T
                for i in range(n):
                    s = 0.0
                    for j in range(k, n):
                        s += X[i, j] * V[k, j]
                    s *= beta[k]
                    for j in range(k, n):
                        X[i, j] -= s * V[k, j]
            good = ok
            for i in range(n):
                for j in range(n):
                    if not math.isfinite(X[i, j]):
                        good = False
            for i in range(n):
                for j in range(n):
                    inv_out[m, i, j] = X[i, j] if good else math.nan
        if want_bounds:
            if ok:
                # ‖A‖₂ ≤ ‖A‖_F ≤ √n ‖A‖₂, ‖A⁻¹‖_F = ‖R⁻¹‖_F (Q orthogonal); column norms of R = those of A and
                # row norms of R⁻¹ = those of A⁻¹ bound the 2-norms below
                fa = 0.0
                ft = 0.0
                ca = 0.0
                rt = 0.0
                for j in range(n):
                    sa = 0.0
                    st = 0.0
                    for i in range(n):
                        sa += W[i, j] * W[i, j]
                        st += T[j, i] * T[j, i]
                    fa += sa
                    ft += st
                    ca = max(ca, sa)
                    rt = max(rt, st)
                hi = math.sqrt(fa * ft)
                lo_out[m] = max(hi / n, math.sqrt(ca * rt))
                hi_out[m] = hi
            else:
                lo_out[m] = math.inf
                hi_out[m] = math.inf


# ------------------------------------------------------------------------------------------------ joint angles


@_jit
def side_angles(d, rot, axis0, ref0, rotate, sign, normal, ref_par, tol, signed,
                swivel, swivel_signed, tilt, tilt_axis, tilt_normal):
    """Swivel and tilt angles of one joint side (docs/theory/kinematics.md, eq. 3.25-3.29) for n chains and N poses.

    ``d`` (3, n, N) strut vectors; joint axis m and swivel reference n are ``axis0``/``ref0`` (n, 3), rotated by
    ``rot`` (3, 3, N) if ``rotate`` (platform side); u = sign_i d̂ (joint-local strut direction). ``normal`` (n,)
    selects the normal-referenced tilt for ``tilt``; ``ref_par`` (n,) marks n ∥ m (swivel undefined). Outputs
    (n, N): swivel φ = ∠(n, u_⊥) with u_⊥ = m × (u × m), NaN where undefined; signed swivel (if ``signed``);
    tilt_axis = atan2(|m × u|, |m · u|) (= arccos form, accurate near 0 and 90 deg); tilt_normal = arcsin form.
    """
    for i in range(d.shape[1]):
        m0 = (axis0[i, 0], axis0[i, 1], axis0[i, 2])
        n0 = (ref0[i, 0], ref0[i, 1], ref0[i, 2])
        m_norm = _norm(m0)
        m2 = m_norm * m_norm
        for k in range(d.shape[2]):
            dv = _col(d, i, k)
            dn = _norm(dv)
            u = (dv[0] / dn * sign[i], dv[1] / dn * sign[i], dv[2] / dn * sign[i])
            if rotate:
                mv = (rot[0, 0, k] * m0[0] + rot[0, 1, k] * m0[1] + rot[0, 2, k] * m0[2],
                      rot[1, 0, k] * m0[0] + rot[1, 1, k] * m0[1] + rot[1, 2, k] * m0[2],
                      rot[2, 0, k] * m0[0] + rot[2, 1, k] * m0[1] + rot[2, 2, k] * m0[2])
                nv = (rot[0, 0, k] * n0[0] + rot[0, 1, k] * n0[1] + rot[0, 2, k] * n0[2],
                      rot[1, 0, k] * n0[0] + rot[1, 1, k] * n0[1] + rot[1, 2, k] * n0[2],
                      rot[2, 0, k] * n0[0] + rot[2, 1, k] * n0[1] + rot[2, 2, k] * n0[2])
            else:
                mv = m0
                nv = n0
            mu = _dot(mv, u)
            mxu = _norm(_cross(mv, u))  # |m × u| = |m| sin∠(m, u), |u| = 1
            ta = math.atan2(mxu, abs(mu))
            tn = math.copysign(0.5 * math.pi - ta, mu)
            tilt_axis[i, k] = ta
            tilt_normal[i, k] = tn
            tilt[i, k] = tn if normal[i] else ta
            u_perp = (u[0] * m2 - mv[0] * mu, u[1] * m2 - mv[1] * mu, u[2] * m2 - mv[2] * mu)
            nu = _dot(nv, u_perp)
            nxu = _cross(nv, u_perp)
            undefined = ref_par[i] or mxu <= tol * m_norm  # strut along the axis: |u_⊥| = 0
            swivel[i, k] = math.nan if undefined else math.atan2(_norm(nxu), nu)
            if signed:
                swivel_signed[i, k] = math.nan if undefined else math.atan2(_dot(mv, nxu) / m_norm, nu)


# ------------------------------------------------------------------------- fused small-N pose evaluation


@_jit
def cardan_soa(pt, rot):
    """R = R_a R_b R_c (docs/theory/kinematics.md, eq. A.1-A.4) of the poses ``pt`` (6, N) into ``rot`` (3, 3, N),
    with the arithmetic of :func:`pkmstiff.kinematics.rotation.cardan_matrix` term by term (identical results)."""
    for k in range(pt.shape[1]):
        sa, ca = math.sin(pt[3, k]), math.cos(pt[3, k])
        sb, cb = math.sin(pt[4, k]), math.cos(pt[4, k])
        sc, cc = math.sin(pt[5, k]), math.cos(pt[5, k])
        rot[0, 0, k] = cb * cc
        rot[0, 1, k] = -cb * sc
        rot[0, 2, k] = sb
        rot[1, 0, k] = sa * sb * cc + ca * sc
        rot[1, 1, k] = -sa * sb * sc + ca * cc
        rot[1, 2, k] = -sa * cb
        rot[2, 0, k] = -ca * sb * cc + sa * sc
        rot[2, 1, k] = ca * sb * sc + sa * cc
        rot[2, 2, k] = ca * cb


@_jit
def evaluate_small(pt, rot, rho, glide, cf, croot, off, has_off,
                   p, q, d, length, drive, reach, jac, jc, lo, hi,
                   ax_d, ref_d, sign_d, normal_d, refpar_d, ax_p, ref_p, sign_p, normal_p, refpar_p, tol,
                   ang_d, ang_p, jlim, ina75, frame_lim, si, sj, space_lim, ii, jj, rsum, table_b2,
                   pj, excl, radius, normals, offsets, tri, edges, convex, has_hull,
                   force, rho_cog, avail, has_load, thr, active,
                   frame_bad, range_bad, space_bad, lim_bad, ina_bad, strut_bad, plat_bad, tau, load_bad,
                   ok_rows, reasons):
    """The whole pose pipeline of :func:`pkmstiff.admissibility.pipeline.evaluate_chunk` for N poses in one compiled
    call: inverse kinematics (docs/theory/kinematics.md eq. A.6-A.11), J_C^-1 (§1.4), J_C and the κ bounds by
    :func:`qr_inverse`, the joint angles by :func:`side_angles`, every App. B check and their combination. Each step
    repeats the arithmetic of the array code it replaces operation by operation (the results are identical;
    tests/test_pose_fast_path.py), and the compiled kernels of the general path are called unchanged.

    Inputs (component-first, pose axis last): ``pt`` (6, N) poses, ``rot`` (3, 3, N) from :func:`cardan_soa`,
    ``rho`` (3, n, N) = R p'_i. Per-chain constants ``cf`` (n, 10): guide direction r (3), s_i + q_off_i (glide) or
    the drive joint (pod) (3), r·r, l², strut length (glide) / l_min (pod), guide length (glide) / l_max (pod);
    ``croot`` (n,) ±1 root sign. Outputs: IK ``p``, ``q``, ``d`` (3, n, N), ``length``, ``drive``, ``reach`` (n, N),
    ``jac`` (n, 6, N), ``jc`` (N, n, n), κ bounds ``lo``, ``hi`` (N,), angles ``ang_d``/``ang_p`` (5, n, N) as in
    :func:`pkmstiff.kinematics.joint_angles._side_angles`, the per-check details (N, ·) and ``ok_rows`` (9, N) in the
    order FRAME, DRIVE_RANGE, DRIVE_SPACING, JOINT_ANGLE, INA_LIMIT, SINGULAR, STRUT_COLLISION, PLATFORM_COLLISION,
    DRIVE_LOAD; ``reasons`` (N,) the combined code, where ``active`` (9,) marks the checks that count.
    Returns the number of poses whose κ bounds straddle ``thr`` (the caller then needs an exact κ).
    """
    n = p.shape[1]
    N = p.shape[2]
    for k in range(N):
        for i in range(n):
            ln = 0.0
            dr = 0.0
            p0 = rho[0, i, k] + pt[0, k]
            p1 = rho[1, i, k] + pt[1, k]
            p2 = rho[2, i, k] + pt[2, k]
            p[0, i, k] = p0
            p[1, i, k] = p1
            p[2, i, k] = p2
            if glide:
                c0 = cf[i, 3] - p0
                c1 = cf[i, 4] - p1
                c2 = cf[i, 5] - p2
                rc = cf[i, 0] * c0 + cf[i, 1] * c1 + cf[i, 2] * c2
                cc = c0 * c0 + c1 * c1 + c2 * c2
                disc = rc * rc - cf[i, 6] * (cc - cf[i, 7])
                ok = disc >= 0.0
                root = math.sqrt(disc) if ok else math.nan
                lam = (-rc + croot[i] * root) / cf[i, 6]
                q0 = cf[i, 3] + lam * cf[i, 0]
                q1 = cf[i, 4] + lam * cf[i, 1]
                q2 = cf[i, 5] + lam * cf[i, 2]
                ln = cf[i, 8] if ok else math.nan
                dr = lam
            else:
                q0 = cf[i, 3]
                q1 = cf[i, 4]
                q2 = cf[i, 5]
                ok = True
            d0 = p0 - q0
            d1 = p1 - q1
            d2 = p2 - q2
            if not glide:
                ln = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                dr = ln
            if has_off:
                dr = dr - off[i]
            q[0, i, k] = q0
            q[1, i, k] = q1
            q[2, i, k] = q2
            d[0, i, k] = d0
            d[1, i, k] = d1
            d[2, i, k] = d2
            length[i, k] = ln
            drive[i, k] = dr
            reach[i, k] = ok
            # J_C^-1 row (pkmstiff.kinematics.jacobians.inverse_jacobian)
            if glide:
                scale = 1.0 / (d0 * cf[i, 0] + d1 * cf[i, 1] + d2 * cf[i, 2])
            else:
                scale = 1.0 / ln
            u0 = d0 * scale
            u1 = d1 * scale
            u2 = d2 * scale
            r0, r1, r2 = rho[0, i, k], rho[1, i, k], rho[2, i, k]
            jac[i, 0, k] = u0
            jac[i, 1, k] = u1
            jac[i, 2, k] = u2
            jac[i, 3, k] = r1 * u2 - r2 * u1
            jac[i, 4, k] = r2 * u0 - r0 * u2
            jac[i, 5, k] = r0 * u1 - r1 * u0
    no3 = np.empty((0, 0, 0))
    okq = np.empty(N, dtype=np.bool_)
    qr_inverse(jac, 0, N, False, True, True, no3, no3, jc, lo, hi, okq)
    side_angles(d, rot, ax_d, ref_d, False, sign_d, normal_d, refpar_d, tol, True,
                ang_d[0], ang_d[4], ang_d[1], ang_d[2], ang_d[3])
    side_angles(d, rot, ax_p, ref_p, True, sign_p, normal_p, refpar_p, tol, True,
                ang_p[0], ang_p[4], ang_p[1], ang_p[2], ang_p[3])
    if ii.shape[0] > 0:
        strut_collision(p, q, ii, jj, rsum, table_b2, strut_bad)
    if has_hull:
        platform_collision(q, rot, pt[:3], pj, excl, radius, normals, offsets, tri, edges, convex, plat_bad)
    n_amb = 0
    for k in range(N):
        okr = np.ones(9, dtype=np.bool_)
        for c in range(3):  # frame
            w = pt[c, k]
            b = w < frame_lim[0, c] or w > frame_lim[1, c]
            frame_bad[k, c] = b
            if b:
                okr[0] = False
        all_reach = True
        for i in range(n):  # drive range B.1/B.2
            dr = drive[i, k]
            if not reach[i, k]:
                all_reach = False
            if glide:
                b = not reach[i, k] or dr < 0.0 or dr > cf[i, 9]
            else:
                b = dr < cf[i, 8] or dr > cf[i, 9] or not math.isfinite(dr)
            range_bad[k, i] = b
            if b:
                okr[1] = False
        for c in range(si.shape[0]):  # drive spacing B.3/B.4 (np.linalg.norm: ((x0² + x1²) + x2²))
            i, j = si[c], sj[c]
            e0 = q[0, i, k] - q[0, j, k]
            e1 = q[1, i, k] - q[1, j, k]
            e2 = q[2, i, k] - q[2, j, k]
            dist = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            b = dist <= space_lim[0, c] or dist >= space_lim[1, c]
            space_bad[k, c] = b
            if b:
                okr[2] = False
        for s in range(2):  # joint angles B.5, INA limit B.6; jlim rows: tilt min/max, swivel min/max, ina
            ang = ang_d if s == 0 else ang_p
            for i in range(n):
                col = s * n + i
                sw = ang[0, i, k]
                tl = ang[1, i, k]
                defined = math.isfinite(sw)
                b = tl < jlim[0, col] or tl > jlim[1, col]
                b = b or (defined and (sw < jlim[2, col] or sw > jlim[3, col]))
                lim_bad[k, col] = b
                if b:
                    okr[3] = False
                bi = jlim[4, col] != 0.0 and defined and abs(tl) > ina75 - 2.0 / 3.0 * abs(sw)
                ina_bad[k, col] = bi
                if bi:
                    okr[4] = False
        # singularity (pkmstiff.kinematics.conditioning._singular_from_bounds)
        okr[5] = hi[k] <= thr
        if lo[k] <= thr and hi[k] > thr and math.isfinite(hi[k]):
            n_amb += 1
        for c in range(ii.shape[0]):
            if strut_bad[k, c]:
                okr[6] = False
        if has_hull:
            for i in range(n):
                if plat_bad[k, i]:
                    okr[7] = False
        if has_load:  # static drive loads tau_g = J_C^T g_P (eq. 4.90) and B.13
            m0 = rho_cog[k, 1] * force[2] - rho_cog[k, 2] * force[1]
            m1 = rho_cog[k, 2] * force[0] - rho_cog[k, 0] * force[2]
            m2 = rho_cog[k, 0] * force[1] - rho_cog[k, 1] * force[0]
            for i in range(n):
                t = jc[k, 0, i] * force[0]
                t += jc[k, 1, i] * force[1]
                t += jc[k, 2, i] * force[2]
                t += jc[k, 3, i] * m0
                t += jc[k, 4, i] * m1
                t += jc[k, 5, i] * m2
                tau[k, i] = t
                b = not (abs(t) <= avail[i])
                load_bad[k, i] = b
                if b:
                    okr[8] = False
        code = 0
        if not all_reach:
            code = 1
        else:
            for c in range(9):
                if active[c] != 0 and not okr[c]:
                    code |= active[c]
        reasons[k] = code
        for c in range(9):
            ok_rows[c, k] = okr[c]
    return n_amb
