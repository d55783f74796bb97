"""Positions, velocities, accelerations and jerk along a drive path (patent claim 9), by implicit differentiation.

Along a motion s(t) the configuration q(t) satisfies F(q(t), s(t)) ≡ 0 (model + drive equations).  With Taylor
coefficients q(t₀ + τ) = Σ_k q_k τ^k and s(t₀ + τ) = Σ_k s_k τ^k every coefficient of F vanishes:

    F_q q_k = E s_k − G_k(q_0, …, q_{k−1}),     k = 1, 2, 3,

where G_k is coefficient k of F evaluated with q_k = s_k = 0 and E selects the drive rows (∂F/∂s = −1 there).
G_k is computed exactly by truncated power-series (Taylor-mode) arithmetic on the link frames — spatial link
rotations as exp([ψ(τ)]×) R₀ in the solver's rotation-vector coordinates (ψ₀ = 0, regular at φy = ±90°), planar
ones by sin/cos of the angle, products of rotation matrices, points and axes, atan2 of the revolute drives and the rotation logarithm of
equal orientation — so velocities q̇ = q_1, accelerations q̈ = 2 q_2 and jerk q⃛ = 6 q_3 carry rounding errors only
(no finite differences).  Each F_q solve is the least-squares step of the Newton solver (redundant model rows).
The output point's derivatives follow from w = t + R p, the output link's angular velocity, acceleration and its
rate ("rotational jerk") from ω = vee(Ṙ Rᵀ).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pkmstiff.errors import ArgumentError
from pkmstiff.mechanisms.constraints import Block, System, fk_system, wrap
from pkmstiff.mechanisms.linalg import lstsq_step
from pkmstiff.mechanisms.model import Mechanism
from pkmstiff.mechanisms.solver import Solution, forward

Array = NDArray[np.float64]

ORDER = 3  #: derivatives up to jerk


# ----------------------------------------------------------------------------------------------------------
# truncated power series: arrays with the coefficient index first, (K + 1, …)
# ----------------------------------------------------------------------------------------------------------


def _mul(a: Array, b: Array) -> Array:
    """Cauchy product of two series (elementwise, broadcasting)."""
    K = a.shape[0]
    out = np.zeros(np.broadcast_shapes(a.shape, b.shape))
    for k in range(K):
        for i in range(k + 1):
            out[k] += a[i] * b[k - i]
    return out


def _matmul(a: Array, b: Array) -> Array:
    K = a.shape[0]
    out = np.zeros(np.broadcast_shapes(a.shape[:-1], b.shape[:-2] + (1,))[:-1] + (a.shape[-2], b.shape[-1]))
    for k in range(K):
        for i in range(k + 1):
            out[k] += a[i] @ b[k - i]
    return out


def _dot(a: Array, b: Array) -> Array:
    return _mul(a, b).sum(axis=-1)


def _cross(a: Array, b: Array) -> Array:
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([_mul(a1, b2) - _mul(a2, b1), _mul(a2, b0) - _mul(a0, b2), _mul(a0, b1) - _mul(a1, b0)], -1)


def _sincos(x: Array) -> tuple[Array, Array]:
    """Series of sin x and cos x: k s_k = Σ_j j x_j c_{k−j}, k c_k = −Σ_j j x_j s_{k−j}."""
    s, c = np.zeros_like(x), np.zeros_like(x)
    s[0], c[0] = np.sin(x[0]), np.cos(x[0])
    for k in range(1, x.shape[0]):
        for j in range(1, k + 1):
            s[k] += j * x[j] * c[k - j] / k
            c[k] -= j * x[j] * s[k - j] / k
    return s, c


def _div(n: Array, d: Array) -> Array:
    """Series quotient n/d: q_k = (n_k − Σ_{j≥1} d_j q_{k−j}) / d_0."""
    q = np.zeros(np.broadcast_shapes(n.shape, d.shape))
    for k in range(q.shape[0]):
        acc = n[k].copy() if np.ndim(n[k]) else n[k]
        for j in range(1, k + 1):
            acc = acc - d[j] * q[k - j]
        q[k] = acc / d[0]
    return q


def _deriv(x: Array) -> Array:
    """Series of dx/dτ (the last coefficient is dropped: zero-padded)."""
    out = np.zeros_like(x)
    for k in range(1, x.shape[0]):
        out[k - 1] = k * x[k]
    return out


def _integ(dx: Array, x0: Array) -> Array:
    out = np.zeros_like(dx)
    out[0] = x0
    for k in range(1, dx.shape[0]):
        out[k] = dx[k - 1] / k
    return out


def _atan2(S: Array, C: Array) -> Array:
    """Series of atan2(S, C): θ' = (C S' − S C')/(S² + C²)."""
    num = _mul(C, _deriv(S)) - _mul(S, _deriv(C))
    return _integ(_div(num, _mul(S, S) + _mul(C, C)), np.arctan2(S[0], C[0]))


def _skew(x: Array) -> Array:
    K = np.zeros(x.shape + (3,))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -x[..., 2], x[..., 1], -x[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = x[..., 2], -x[..., 1], x[..., 0]
    return K


def _vee_skew(A: Array) -> Array:
    """vee of the skew-symmetric part of A."""
    return 0.5 * np.stack([A[..., 2, 1] - A[..., 1, 2], A[..., 0, 2] - A[..., 2, 0], A[..., 1, 0] - A[..., 0, 1]], -1)


def _log_near_identity(M: Array) -> Array:
    """Series of log M for M(0) = I (equal orientation holds along the path): with M = exp([x]×), x = Σ x_k τ^k,
    the coefficients of exp give [x_k]× = M_k − (terms of x_1 … x_{k−1}); coefficient 0 is vee(skew M_0) (≈ 0)."""
    x = np.zeros(M.shape[:-1])
    x[0] = _vee_skew(M[0])
    Kx = np.zeros_like(M)
    for k in range(1, M.shape[0]):
        Kx[k] = 0.0
        # coefficient k of exp([x]×) − I − [x]× : ½[x]×² + ⅙[x]×³ (orders ≤ 3)
        sq = _matmul(Kx, Kx)
        cu = _matmul(sq, Kx)
        x[k] = _vee_skew(M[k] - 0.5 * sq[k] - cu[k] / 6.0)
        Kx[k] = _skew(x[k])
    return x


# ----------------------------------------------------------------------------------------------------------
# Taylor-mode residual of a system
# ----------------------------------------------------------------------------------------------------------


def _rotations(phi: Array, dim: int) -> Array:
    """Series of R(φ) (K+1, N, L, D, D): eq. 2 (R = Rz Ry Rx) or eq. 9."""
    if dim == 2:
        s, c = _sincos(phi[..., 0])
        return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    (sx, cx), (sy, cy), (sz, cz) = (_sincos(phi[..., i]) for i in range(3))
    z, o = np.zeros_like(sx), np.zeros_like(sx)
    o[0] = 1.0
    def m(*e):
        return np.stack([np.stack(e[0:3], -1), np.stack(e[3:6], -1), np.stack(e[6:9], -1)], -2)

    Rx = m(o, z, z, z, cx, -sx, z, sx, cx)
    Ry = m(cy, z, sy, z, o, z, -sy, z, cy)
    Rz = m(cz, -sz, z, sz, cz, z, z, z, o)
    return _matmul(_matmul(Rz, Ry), Rx)


def _rotvec_rotations(psi: Array, R0: Array) -> Array:
    """Series of R(τ) = exp([ψ(τ)]×) R₀ (K+1, N, L, 3, 3) for a rotation-vector series ψ (K+1, N, L, 3) with ψ₀ = 0
    (the solver's world-frame increments, :meth:`System.step`): exp = I + X + X²/2 + X³/6 with X = [ψ]×, exact to
    order 3 because X has no constant term.  Regular at every orientation (no Euler-angle rates)."""
    X = _skew(psi)
    X[0] = 0.0
    X2 = _matmul(X, X)
    E = X + 0.5 * X2 + _matmul(X2, X) / 6.0
    E[0] += np.eye(3)
    return E @ R0  # R₀ is constant: coefficientwise


def _euler_series(R: Array, phi0: Array) -> Array:
    """Series of the link angles φ (eq. 2, R = Rz Ry Rx) of a rotation series R; coefficient 0 is ``phi0``.
    φx = atan2(R₂₁, R₂₂), φz = atan2(R₁₀, R₀₀), φy = atan2(−R₂₀, cos φz R₀₀ + sin φz R₁₀): their rates are
    undefined at φy = ±90° (use :attr:`PathDerivatives.link_omega` there)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        x = _atan2(R[..., 2, 1], R[..., 2, 2])
        z = _atan2(R[..., 1, 0], R[..., 0, 0])
        sz, cz = _sincos(z)
        y = _atan2(-R[..., 2, 0], _mul(cz, R[..., 0, 0]) + _mul(sz, R[..., 1, 0]))
    out = np.stack([x, y, z], axis=-1)
    out[0] = phi0
    return out


def taylor_residual(system: System, Q: Array, S: Array, R: Array | None = None) -> Array:
    """Series of the residual F (K+1, N, m) of a forward-kinematics system along q(τ) = Σ Q_k τ^k (Q (K+1, N, L, d))
    and drive values s(τ) = Σ S_k τ^k (S (K+1, N, n_drives)); coefficient 0 is ``system.evaluate``'s residual.
    ``R``: the link rotation series (K+1, N, L, D, D) (default: from the angles of Q, eq. 2)."""
    mech = system.mech
    D = mech.dim
    t, R = Q[..., :D], (_rotations(Q[..., D:], D) if R is None else R)
    K1, N = Q.shape[:2]
    out = np.zeros((K1, N, system.m))

    def point(li, p):
        return t[:, :, li] + np.einsum("knlab,lb->knla", R[:, :, li], p)

    def vector(li, a):
        return np.einsum("knlab,lb->knla", R[:, :, li], a)

    for b in system.blocks:
        r = _block(b, D, Q, R, S, point, vector)
        out[:, :, b.row0:b.row0 + b.rows] = r.reshape(K1, N, -1)
    return out


def _block(b: Block, D: int, Q: Array, R: Array, S: Array, point, vector) -> Array:
    kind = b.kind
    if kind == "fixed":
        r = Q[:, :, b.j, b.coord].copy()
        r[0] -= b.value
        return r[..., None]
    if kind in ("1A", "1E", "1F", "drive_lin"):
        delta = point(b.j, b.p) - point(b.k, b.p)
    if kind == "1A":
        return delta
    if kind == "1B":
        if D == 2:
            return Q[:, :, b.j, D:] - Q[:, :, b.k, D:]
        return _log_near_identity(_matmul(R[:, :, b.j], np.swapaxes(R[:, :, b.k], -1, -2)))
    if kind == "1C":
        return vector(b.j, b.a) - vector(b.k, b.a)
    if kind == "1D":
        return _dot(vector(b.j, b.a), vector(b.k, b.b))[..., None]
    if kind == "1E":
        u = vector(b.j, b.a)
        if D == 3:
            return _cross(delta, u)
        return (_mul(delta[..., 0], u[..., 1]) - _mul(delta[..., 1], u[..., 0]))[..., None]
    if kind in ("1F", "drive_lin"):
        r = _dot(delta, vector(b.j, b.a))
        if kind == "1F":
            return r[..., None]
        r = -r
        r[0] += b.value
        return (r - S[:, :, b.coord])[..., None]
    if kind == "drive_rot":
        th = S[:, :, b.coord].copy()
        th[0] -= b.value
        if D == 2:
            r = Q[:, :, b.k, D] - Q[:, :, b.j, D] - th
            return r[..., None]
        A, U, V = vector(b.j, b.a), vector(b.j, b.b), vector(b.k, b.b)
        theta = _atan2(_dot(A, _cross(U, V)), _dot(U, V))
        r = theta - th
        r[0] = wrap(r[0])
        return r[..., None]
    raise ArgumentError(f"path: constraint kind {kind!r} is not part of a forward-kinematics system")


def cardan_series(R: Array) -> Array:
    """Series of the Cardan angles (a, b, c) (…, 3) of a rotation series R (K+1, …, 3, 3), pkmstiff's convention
    R = R_a R_b R_c (:func:`pkmstiff.kinematics.rotation.cardan_angles`): a = atan2(−R₁₂, R₂₂),
    c = atan2(−R₀₁, R₀₀), b = atan2(R₀₂, cos a·R₂₂ − sin a·R₁₂) (the second argument is cos b)."""
    a = _atan2(-R[..., 1, 2], R[..., 2, 2])
    c = _atan2(-R[..., 0, 1], R[..., 0, 0])
    sa, ca = _sincos(a)
    b = _atan2(R[..., 0, 2], _mul(ca, R[..., 2, 2]) - _mul(sa, R[..., 1, 2]))
    return np.stack([a, b, c], axis=-1)


# ----------------------------------------------------------------------------------------------------------
# path derivatives
# ----------------------------------------------------------------------------------------------------------


@dataclass
class PathDerivatives:
    """Configurations and their time derivatives along a drive path (SI; N samples)."""

    solution: Solution  #: positions (status, drive values, output pose)
    q: Array  #: (K+1, N, L, d): q, q̇, q̈, q⃛ (m, rad per s^k)
    point: Array | None  #: (K+1, N, D): output point and its derivatives (m/s^k); None without [output]
    omega: Array | None  #: (K, N, 3) spatial / (K, N, 1) planar: ω, ω̇, ω̈ of the output link (rad/s^(k+1))
    pose: Array | None  #: (K+1, N, pose_size): output pose x, y, z, a, b, c (Cardan; planar x, y, φ) and its
    #: derivatives (m, rad per s^k)
    #: (K, N, L, 3) spatial / (K, N, L, 1) planar: ω, ω̇, ω̈ of every link (rad/s^(k+1)), regular at every
    #: orientation (the angle rates in ``q`` are undefined at φy = ±90°)
    link_omega: Array | None = None


def path_derivatives(mech: Mechanism, drives: ArrayLike, rates: ArrayLike, accelerations: ArrayLike | None = None,
                     jerks: ArrayLike | None = None, start: Solution | Array | None = None,
                     solution: Solution | None = None) -> PathDerivatives:
    """q, q̇, q̈, q⃛ at N samples of a drive path: drive values s, ṡ, s̈, s⃛ (N, n_drives) [m or rad per s^k].

    The positions come from the forward kinematics (continuation from ``start`` or home, sample after sample is
    the caller's choice: pass ``solution`` to reuse configurations already solved); the derivatives from the
    Taylor recursion of the module docstring."""
    nd = len(mech.drives)
    s = [np.atleast_2d(np.asarray(v, dtype=float)) for v in (drives, rates)]
    N = s[0].shape[0]
    for v in (accelerations, jerks):
        s.append(np.zeros((N, nd)) if v is None else np.atleast_2d(np.asarray(v, dtype=float)))
    for name, v in zip(("drives", "rates", "accelerations", "jerks"), s):
        if v.shape != (N, nd) or not np.isfinite(v).all():
            raise ArgumentError(f"path: {name} expected finite values of shape ({N}, {nd}), found {v.shape}")
    sol = solution if solution is not None else forward(mech, s[0], start=start)
    system = fk_system(mech)
    L, d = sol.q.shape[1:]
    Sser = np.stack(s) / np.array([1.0, 1.0, 2.0, 6.0])[:, None, None]  # Taylor coefficients s^(k)/k!
    Q = np.zeros((ORDER + 1, N, L, d))
    Q[0] = sol.q
    D = mech.dim
    # spatial links: the rotation series is exp([ψ(τ)]×) R₀ in the solver's rotation-vector coordinates (the
    # Jacobian with omega=True), regular at φy = ±90°; planar ones keep their angle
    spatial = D == 3
    _, J = system.evaluate(sol.q, s[0], reduced=True, omega=spatial)
    R0 = _rotations(sol.q[None, ..., D:], D)[0]
    if spatial:
        Q[0, ..., D:] = 0.0

    def rot(Qs):
        return _rotvec_rotations(Qs[..., D:], R0) if spatial else _rotations(Qs[..., D:], D)
    roff = system.n_fixed_rows
    free = system.free
    for k in range(1, ORDER + 1):
        # with Q_k = 0: coefficient k is −(F_q q_k) + …
        G = taylor_residual(system, Q[:k + 1], Sser[:k + 1], rot(Q[:k + 1]))[k]
        dq, _, _, _ = lstsq_step(J, G[:, roff:], pattern=system.sparsity)  # F_q q_k = −G_k
        Qk = np.zeros((N, L * d))
        Qk[:, free] = dq
        Q[k] = Qk.reshape(N, L, d)
    Rser = rot(Q)  # (K+1, N, L, D, D)
    fact = np.array([1.0, 1.0, 2.0, 6.0])[:, None, None, None]
    Wl = _matmul(_deriv(Rser), np.swapaxes(Rser, -1, -2))  # Ṙ Rᵀ = [ω]× as a series, per link
    link_omega = (Wl[..., 1, 0][..., None] if D == 2 else _vee_skew(Wl))[:ORDER] * fact[:ORDER]
    if spatial:
        Q[..., D:] = _euler_series(Rser, sol.q[..., D:])
    qder = Q * fact
    bad = ~sol.ok
    qder[:, bad] = np.nan
    link_omega[:, bad] = np.nan
    point = omega = pose = None
    if mech.output is not None:
        o = mech.output
        D = mech.dim
        R = Rser[:, :, o.link]  # (K+1, N, D, D)
        W = Q[:, :, o.link, :D] + np.einsum("knab,b->kna", R, o.point)
        point = W * fact[..., 0]
        omega = link_omega[:, :, o.link].copy()
        ang = Q[:, :, o.link, 2:3] if D == 2 else cardan_series(R)
        pose = np.concatenate([W, ang], axis=-1) * fact[..., 0]
        for a in (point, omega, pose):
            a[:, bad] = np.nan
    return PathDerivatives(sol, qder, point, omega, pose, link_omega)
