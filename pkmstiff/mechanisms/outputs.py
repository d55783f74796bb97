"""Rates and conditioning of the controlled outputs of a mechanism (issue 27, item 4).

The controlled outputs are the ones the file's ``[output]`` declares (:class:`~pkmstiff.mechanisms.model.Output`):
the listed coordinates of the output point [m], and the orientation — "full": the angular velocity ω of the output
link (3 components; planar φ̇) [rad], "axis": the rate of the tool axis u = R a projected on two unit vectors
e₁, e₂ ⊥ u (the two directions the axis can turn) [rad], "none": nothing.  Their Jacobian with respect to the
drives, ∂x_c/∂s = G q_s, follows from implicit differentiation of the forward kinematics F(q, s) = 0
(patent claim 9: F_q q_s = −F_s, F_s = −1 on each drive row) and the analytic output rates G = ∂x_c/∂q, with no
finite differences.  Its condition number is the distance to an output singularity: it is ∞ at a wrist
singularity although the forward kinematics (and ∂x/∂s of the Cardan pose) stay regular there.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pkmstiff.mechanisms.constraints import Frames, fk_system
from pkmstiff.mechanisms.linalg import lstsq_step
from pkmstiff.mechanisms.model import Mechanism

Array = NDArray[np.float64]


def configuration_rates(mech: Mechanism, q: Array, drives: Array) -> Array:
    """q_s = ∂q/∂s (N, L·d, n_drives) at configurations q (N, L, d) with drive values (N, n_drives) (SI):
    F_q q_s = −F_s solved by the Newton step of :func:`~pkmstiff.mechanisms.linalg.lstsq_step` (least squares:
    the model rows are redundant)."""
    system = fk_system(mech)
    N, L, d = q.shape
    _, J = system.evaluate(q, drives, reduced=True)
    roff = system.n_fixed_rows
    nd = len(mech.drives)
    rows = np.empty(nd, dtype=int)
    for b in system.blocks:
        if b.kind.startswith("drive"):
            rows[b.coord] = b.row0 - roff + np.arange(b.n)
    out = np.zeros((N, L * d, nd))
    # least squares F_q q_s = e_c for all drives c at once: normal equations F_qᵀF_q q_s = F_qᵀ e_c (= row c of
    # F_q), one batched LAPACK solve (squares κ(F_q) ≲ 1e4 away from dead centres: ≲ 1e-8 relative in q_s);
    # poses whose normal matrix is singular or not finite take the pivoted-QR Newton step per drive instead
    JT = np.swapaxes(J, 1, 2)
    A = JT @ J
    B = np.ascontiguousarray(JT[:, :, rows])
    try:
        X = np.linalg.solve(A, B)
        redo = np.flatnonzero(~np.isfinite(X).all(axis=(1, 2)))
    except np.linalg.LinAlgError:
        X = np.zeros_like(B)
        redo = np.arange(N)
    for c in range(nd) if redo.size else ():
        rhs = np.zeros((redo.size, J.shape[1]))
        rhs[:, rows[c]] = -1.0  # the step solves J dq = −rhs: F_q q_s = −F_s = +1 on this drive row
        X[redo, :, c] = lstsq_step(J[redo], rhs, pattern=system.sparsity)[0]
    out[:, system.free] = X
    return out


def _perp_rows(u: Array) -> tuple[Array, Array]:
    """Unit vectors e₁, e₂ (N, 3) with (e₁, e₂, u) orthonormal, for unit vectors u (N, 3)."""
    e = np.zeros_like(u)
    e[np.arange(u.shape[0]), np.argmin(np.abs(u), axis=1)] = 1.0
    e1 = np.cross(u, e)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(u, e1)


def controlled_output_names(mech: Mechanism) -> tuple[str, ...]:
    """Names of the controlled output rates (rows of :func:`output_rate_matrix`)."""
    o = mech.output
    if o is None:
        return ()
    names = tuple("xyz"[c] for c in o.coordinates)
    if o.orientation == "full":
        names += ("omega_x", "omega_y", "omega_z") if mech.dim == 3 else ("omega",)
    elif o.orientation == "axis":
        names += ("axis_e1", "axis_e2")
    return names


def output_rate_matrix(mech: Mechanism, q: Array) -> Array:
    """G = ∂x_c/∂q (N, n_c, L·d): the controlled output rates per link coordinate rate (point [m], ω or axis
    turn [rad]) at configurations q (N, L, d)."""
    o = mech.output
    D = mech.dim
    N, L, d = q.shape
    F = Frames(q, D)
    l = np.array([o.link])
    rows = []
    _, Dw = F.point(l, o.point[None])  # (N, 1, D, nr)
    for c in o.coordinates:
        g = np.zeros((N, L, d))
        g[:, o.link, c] = 1.0
        g[:, o.link, D:] = Dw[:, 0, c]
        rows.append(g.reshape(N, -1))
    if o.orientation == "full":
        if D == 2:
            g = np.zeros((N, L, d))
            g[:, o.link, 2] = 1.0
            rows.append(g.reshape(N, -1))
        else:
            W = np.einsum("ncab,ndb->ncad", F.dR[:, o.link], F.R[:, o.link])  # ∂R/∂φ_c Rᵀ = [ω_c]×
            omega = np.stack([W[:, :, 2, 1], W[:, :, 0, 2], W[:, :, 1, 0]], axis=1)  # (N, 3, nr)
            for a in range(3):
                g = np.zeros((N, L, d))
                g[:, o.link, D:] = omega[:, a]
                rows.append(g.reshape(N, -1))
    elif o.orientation == "axis":
        U, DU = F.vector(l, o.axis[None])
        for e in _perp_rows(U[:, 0]):
            g = np.zeros((N, L, d))
            g[:, o.link, D:] = np.einsum("na,nac->nc", e, DU[:, 0])
            rows.append(g.reshape(N, -1))
    return np.stack(rows, axis=1)


def output_jacobian(mech: Mechanism, q: Array, drives: Array) -> Array:
    """∂x_c/∂s (N, n_c, n_drives) of the controlled outputs (SI), NaN where q or the drives are not finite."""
    good = np.isfinite(q).all(axis=(1, 2)) & np.isfinite(drives).all(axis=1)
    out = np.full((q.shape[0], len(controlled_output_names(mech)), len(mech.drives)), np.nan)
    system = fk_system(mech)
    if system.plan is not None and good.any():  # spatial: compiled per pose (pkmstiff.mechanisms.fused)
        from pkmstiff.mechanisms.fused import output_jacobian as compiled

        idx = np.flatnonzero(good)
        out[idx] = compiled(system, q[idx], drives[idx], out.shape[1])
        good[idx[np.isfinite(out[idx]).all(axis=(1, 2))]] = False  # the rest: singular normal matrix, below
    if good.any():
        out[good] = output_rate_matrix(mech, q[good]) @ configuration_rates(mech, q[good], drives[good])
    return out


def condition_numbers(Jx: Array) -> Array:
    """σ_1/σ_k of each Jacobian (N, p, k) over its min(p, k) largest singular values; ∞ where singular
    (σ_k ≤ 1e-14 σ_1, rounding level) or NaN."""
    out = np.full(Jx.shape[0], np.inf)
    good = np.isfinite(Jx).all(axis=(1, 2))
    if good.any():
        s = np.linalg.svd(Jx[good], compute_uv=False)
        with np.errstate(divide="ignore"):
            out[good] = np.where(s[:, -1] > 1e-14 * s[:, 0], s[:, 0] / s[:, -1], np.inf)
    return out


def output_condition(mech: Mechanism, q: Array, drives: Array) -> Array:
    """κ (N,) of ∂x_c/∂s of the controlled outputs; ∞ at an output singularity or without a configuration."""
    if mech.output is None or not mech.drives:
        return np.full(q.shape[0], np.nan)
    return condition_numbers(output_jacobian(mech, q, drives))
