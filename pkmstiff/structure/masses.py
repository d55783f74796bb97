"""Mass matrices of the platform and of the moved bodies for the structure model and the dynamics
(docs/theory/structure.md, Cobet §4.2, §4.7).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

import pkmstiff.multibody as sde
from pkmstiff.kinematics import IK, inverse_jacobian, kinematic_jacobian
from pkmstiff.machine.model import Machine
from pkmstiff.machine.roles import MachineComponents, machine_components
from pkmstiff.structure.layout import PKSBody, StructureLayout, combine_bodies, component_body
from pkmstiff.structure.options import Array


def platform_mass_matrix(layout: StructureLayout, R: Array) -> Array:
    """M_P (N, 6, 6) of platform + spindle referred to O' in MKS axes (docs/theory/structure.md, parallel-axis theorem)."""
    body = combine_bodies([layout.platform, layout.spindle]) if layout.separate_spindle else layout.platform
    return mass_matrix_about_origin(body, R)


def mass_matrix_about_origin(body: PKSBody, R: Array) -> Array:
    """``N(ρ)ᵀ diag(m I, R I' Rᵀ) N(ρ)`` (N, 6, 6) about O' in MKS axes, ρ = R cog (docs/theory/structure.md)."""
    rho = R @ body.cog
    m = np.zeros((R.shape[0], 6, 6))
    m[:, [0, 1, 2], [0, 1, 2]] = body.mass
    icg = R @ body.inertia @ np.swapaxes(R, 1, 2)
    s = sde.linalg.skew(rho)
    m[:, :3, 3:] = -body.mass * s
    m[:, 3:, :3] = body.mass * s
    m[:, 3:, 3:] = icg - body.mass * s @ s
    return m


def dynamics_masses(machine: Machine, strut_mass_split: bool = False,
                    components: MachineComponents | None = None) -> tuple[np.ndarray, PKSBody]:
    """M_A (n,) [kg] and the body moved by the drives (PKS) for the rigid-body dynamics of docs/theory/components.md / §6.3.

    M_A = drive + guide carriages + drive-joint mass; moved body = platform + spindle.  ``strut_mass_split``
    (docs/theory/kinetostatics.md extension, Assumption, off by default) adds half of each strut to the drive and half, at the platform
    joint, to the moved body.  (The structure model's own mass distribution is set by :class:`StructureOptions`.)
    """
    mc = components or machine_components(machine)
    jt = [machine.joint_types[t] for t in machine.chains.drive_joint_type]
    share = 0.5 if strut_mass_split else 0.0

    def mass(c: Any) -> float:
        return 0.0 if c is None else float(c.mass)

    m_a = np.array([mass(mc.drive[i]) + mass(mc.guide[i]) + jt[i].mass + share * mass(mc.strut[i])
                    for i in range(machine.n_chains)])
    body = combine_bodies([component_body(mc.platform), component_body(mc.spindle)])
    for i in range(machine.n_chains):
        body = body.plus_point(share * mass(mc.strut[i]), machine.chains.platform_joint[i])
    return m_a, body


def effective_mass(layout: StructureLayout, ik: IK, idx: Array, machine: Machine) -> Array:
    """Diagonal of M_q = M_A + J_Cᵀ M_P J_C (eq. 3.10–3.12) for pole-placement drives (N, n) [kg].

    M_A and M_P as in :func:`dynamics_masses` (platform + spindle about O', no strut shares: docs/theory/components.md).
    """
    from components.direct_drive import joint_space_mass_diagonal

    jsub = IK(**{f.name: (getattr(ik, f.name)[idx] if isinstance(getattr(ik, f.name), np.ndarray)
                          else getattr(ik, f.name)) for f in dataclasses.fields(IK)})
    jc = kinematic_jacobian(inverse_jacobian(machine, jsub))
    m_a, body = dynamics_masses(machine, components=layout.components)
    with np.errstate(invalid="ignore"):
        return joint_space_mass_diagonal(jc, m_a, mass_matrix_about_origin(body, jsub.R))
