"""Inverse Jacobian J_C^-1 in twist form and its Cardan-rate and relative variants
(docs/theory/kinematics.md, Cobet §1.4).
"""

from __future__ import annotations

import numpy as np

from pkmstiff.kinematics.arrays import Array, _cross_soa, _to_soa, _vec_soa
from pkmstiff.kinematics.inverse import IK
from pkmstiff.kinematics.rotation import cardan_rate_matrix
from pkmstiff.machine.model import Machine


def inverse_jacobian(machine: Machine, ik: IK) -> Array:
    """Inverse kinematic Jacobian J_C⁻¹ (N, n, 6) in twist form, q̇ = J_C⁻¹ (v, ω) (docs/theory/kinematics.md).

    Row i: pod [d̂_iᵀ, (ρ_i × d̂_i)ᵀ]; glide [d_iᵀ, (ρ_i × d_i)ᵀ] / (d_i · r_i), with ρ_i = R p'_i and
    v, ω in MKS components (SI: columns 0–2 dimensionless, 3–5 in m/rad).  Rows of unreachable chains
    are NaN; a glide chain with d_i · r_i = 0 (singularity of the first kind) gives ±inf/NaN entries.
    """
    d = _vec_soa(ik.d)  # (3, n, N)
    rho = _vec_soa(ik.rho)
    n, N = d.shape[1], d.shape[2]
    if ik.kind == "glide":
        r = machine.chains.guide_direction.T[:, :, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = 1.0 / (d[0] * r[0] + d[1] * r[1] + d[2] * r[2])  # (n, N)
    else:
        scale = 1.0 / _to_soa(ik.length, 1)
    J = np.empty((n, 6, N))
    with np.errstate(invalid="ignore"):  # inf·0 at d·r = 0 gives NaN entries: the pose is singular anyway
        u = d * scale[None]
        J[:, 0:3, :] = u.transpose(1, 0, 2)
        J[:, 3:6, :] = _cross_soa(rho, u).transpose(1, 0, 2)
    return np.moveaxis(J, 2, 0)


def cardan_inverse_jacobian(jinv: Array, ik: IK) -> Array:
    """Cardan inverse Jacobian ∂q/∂(x, y, z, a, b, c) = J_C⁻¹ diag(I, E(a, b)) (Cobet eq. A.20, docs/theory/kinematics.md)."""
    E = cardan_rate_matrix(ik.poses[:, 3], ik.poses[:, 4])
    out = np.array(jinv, dtype=float, copy=True)
    out[:, :, 3:] = np.matmul(jinv[:, :, 3:], E)
    return out


def relative_inverse_jacobian(jinv: Array, ik: IK) -> Array:
    """Relative inverse Jacobian ∂q/∂(x, y, z, a', b', c') = J_C⁻¹ diag(I, R) (Cobet eq. A.21, docs/theory/kinematics.md).

    a', b', c' are infinitesimal rotations about the axes of the tool frame (PKS).
    """
    out = np.array(jinv, dtype=float, copy=True)
    out[:, :, 3:] = np.matmul(jinv[:, :, 3:], ik.R)
    return out
