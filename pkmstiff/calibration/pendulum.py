"""Denkena's planar double pendulum (Denkena §1.5, Gl. 93–96), the smallest implicit identification model.

World coordinates s = (x_T, y_T, ψ_T), parameters p = (L1, L2), controls u = (φ1, φ2), no passive joints. The
transformation equation is F(x, ψ, p, u) = 0 with six rows: the top two rows of the homogeneous pendulum-tip frame,
row by row, [R(ψ) | x] − [R(φ1 + φ2) | L1 e(φ1) + L2 e(φ1 + φ2)]:

    F = [cos ψ − c12, −sin ψ + s12, x_T − c12 L2 − c1 L1, sin ψ − s12, cos ψ − c12, y_T − s12 L2 − s1 L1].

Reading (docs/theory/calibration.md): the printed Gl. 93 lacks one of the six rows; reconstructed from F_ψ in Gl. 94, whose
row order (−sin ψ, −cos ψ, 0, cos ψ, −sin ψ, 0) fixes the rows above (the missing one is the fifth, cos ψ − c12).

A measurement i reads the squared distance d_i² = ‖z − x_i‖² to the measuring base point z (Gl. 49). The identification
equations G = [d̃_i² − ‖z − x_i‖²; F(x_i, ψ_i, p, u_i)] (Gl. 51) have the extended Jacobian (Gl. 95–96)

    J = ∂G/∂[p, x_1, ψ_1, x_2, ψ_2, …] ∈ R^{m_u (n_F + 1) × (n_p + m_u (n_x + n_ψ))} = 14 × 8 for two measurements;

rank 8 at generic poses. Note: Gl. 95 prints the distance row as −2(z − x_i)ᵀ; the derivative of G as defined in
Gl. 51 is +2(z − x_i)ᵀ (a row sign, which changes neither rank nor singular values).
"""

from __future__ import annotations

import numpy as np

from pkmstiff.calibration.implicit import implicit_sensitivity
from pkmstiff.errors import InputError

N_F, N_X, N_PSI, N_P = 6, 2, 1, 2


def _uv(u: np.ndarray) -> tuple[np.ndarray, ...]:
    u = np.atleast_2d(np.asarray(u, dtype=float))
    if u.shape[-1] != 2:
        raise InputError("double pendulum", "u", "controls (phi1, phi2) in rad, shape (m, 2)", u.shape)
    p1, p2 = u[:, 0], u[:, 1]
    return np.cos(p1), np.sin(p1), np.cos(p1 + p2), np.sin(p1 + p2)


def forward(p: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Explicit forward kinematics (m, 3): x_T, y_T, ψ_T of the pendulum tip for controls u (m, 2)."""
    c1, s1, c12, s12 = _uv(u)
    L1, L2 = float(p[0]), float(p[1])
    u2 = np.atleast_2d(u)
    return np.c_[L1 * c1 + L2 * c12, L1 * s1 + L2 * s12, u2[:, 0] + u2[:, 1]]


def residual(s: np.ndarray, p: np.ndarray, u: np.ndarray) -> np.ndarray:
    """F(s, p, u) (m, 6) (Gl. 93 with the reconstructed fifth row)."""
    s = np.atleast_2d(s)
    c1, s1, c12, s12 = _uv(u)
    x, y, psi = s[:, 0], s[:, 1], s[:, 2]
    L1, L2 = float(p[0]), float(p[1])
    return np.c_[np.cos(psi) - c12, -np.sin(psi) + s12, x - c12 * L2 - c1 * L1, np.sin(psi) - s12,
                 np.cos(psi) - c12, y - s12 * L2 - s1 * L1]


def partials(s: np.ndarray, p: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """F_x (m, 6, 2), F_ψ (m, 6, 1), F_p (m, 6, 2) (Gl. 94)."""
    s = np.atleast_2d(s)
    c1, s1, c12, s12 = _uv(u)
    m = s.shape[0]
    psi = s[:, 2]
    Fx = np.zeros((m, N_F, N_X))
    Fx[:, 2, 0] = Fx[:, 5, 1] = 1.0
    Fpsi = np.zeros((m, N_F, 1))
    Fpsi[:, 0, 0], Fpsi[:, 1, 0], Fpsi[:, 3, 0], Fpsi[:, 4, 0] = -np.sin(psi), -np.cos(psi), np.cos(psi), -np.sin(psi)
    Fp = np.zeros((m, N_F, N_P))
    Fp[:, 2, 0], Fp[:, 2, 1], Fp[:, 5, 0], Fp[:, 5, 1] = -c1, -c12, -s1, -s12
    return Fx, Fpsi, Fp


def identification_equations(z: np.ndarray, d2: np.ndarray, states: np.ndarray, p: np.ndarray,
                             u: np.ndarray) -> np.ndarray:
    """G (Gl. 51) stacked per measurement: [d̃_i² − ‖z − x_i‖², F(s_i, p, u_i)], shape (m (n_F + 1),)."""
    states = np.atleast_2d(states)
    dist = np.asarray(d2, dtype=float) - np.sum((np.asarray(z, float) - states[:, :2]) ** 2, axis=1)
    return np.c_[dist, residual(states, p, u)].ravel()


def extended_jacobian(z: np.ndarray, p: np.ndarray, u: np.ndarray) -> np.ndarray:
    """∂G/∂[p, x_1, ψ_1, …, x_m, ψ_m] (Gl. 96) at the nominal states of the controls u (m, 2): shape
    (m (n_F + 1), n_p + m (n_x + n_ψ)) = (14, 8) for m = 2."""
    u = np.atleast_2d(u)
    m = u.shape[0]
    s = forward(p, u)
    Fx, Fpsi, Fp = partials(s, p, u)
    nr, ns = N_F + 1, N_X + N_PSI
    J = np.zeros((m * nr, N_P + m * ns))
    for i in range(m):  # block structure of Gl. 96 (m is the number of measurements, 2 in the paper)
        r, c = i * nr, N_P + i * ns
        J[r, c:c + N_X] = 2.0 * (np.asarray(z, float) - s[i, :2])
        J[r + 1:r + nr, :N_P] = Fp[i]
        J[r + 1:r + nr, c:c + N_X] = Fx[i]
        J[r + 1:r + nr, c + N_X:c + ns] = Fpsi[i]
    return J


def reading_jacobian(z: np.ndarray, p: np.ndarray, u: np.ndarray) -> np.ndarray:
    """∂d_i/∂p (m, 2) of the distances d_i = ‖z − x_i‖ by the implicit function theorem: ds/dp = −F_s⁺ F_p with
    F_s = [F_x F_ψ] (6 × 3, rank 3), then ∂d/∂x · dx/dp (Denkena Gl. 61–68)."""
    u = np.atleast_2d(u)
    s = forward(p, u)
    Fx, Fpsi, Fp = partials(s, p, u)
    ds = implicit_sensitivity(np.concatenate([Fx, Fpsi], axis=2), Fp)  # (m, 3, 2)
    rel = s[:, :2] - np.asarray(z, float)
    e = rel / np.linalg.norm(rel, axis=1, keepdims=True)
    return np.einsum("mi,mij->mj", e, ds[:, :2, :])
