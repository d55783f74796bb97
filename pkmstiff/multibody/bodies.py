"""Bodies of the SDE structure model: the fixed frame, point masses and rigid bodies (docs/theory/structure.md).

Generalized coordinates (small displacements, SI units):

* point mass: ``(u_x, u_y, u_z)`` in m, translation of the mass;
* rigid body: ``(u_x, u_y, u_z, θ_x, θ_y, θ_z)``, translation (m) of its reference point = centre of gravity (CoG)
  and small rotations (rad) about the global (MKS) axes;
* the frame ``FRAME`` is fixed and has no DOF.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from pkmstiff.errors import InputError
from pkmstiff.multibody.inputs import pose_array, take

FRAME = "frame"
"""Name of the fixed frame (0 DOF); may be used as ``body_a``/``body_b`` of any element."""


@dataclass(frozen=True)
class PointMass:
    """Point mass with 3 translational DOF.

    ``mass`` (P,) in kg; ``position`` (P, 3) in m.  The position is only descriptive (the displacement of a point
    mass does not depend on where an element attaches) but must be the coupling point of its elements for the
    model to be invariant under rigid motions of the whole system.
    """

    name: str
    mass: np.ndarray
    position: np.ndarray
    n_dof = 3

    def poses(self, sl: slice) -> "PointMass":
        return replace(self, mass=take(self.mass, sl), position=take(self.position, sl))


@dataclass(frozen=True)
class RigidBody:
    """Rigid body with 6 DOF about its reference point = CoG.

    ``mass`` (P,) in kg, ``position`` (P, 3) CoG in m, ``inertia`` (P, 3, 3) in kg m² about the CoG in global axes.
    """

    name: str
    mass: np.ndarray
    position: np.ndarray
    inertia: np.ndarray
    n_dof = 6

    def poses(self, sl: slice) -> "RigidBody":
        return replace(
            self, mass=take(self.mass, sl), position=take(self.position, sl), inertia=take(self.inertia, sl)
        )


Body = PointMass | RigidBody


def _mass(value: Any, source: str) -> np.ndarray:
    mass = pose_array(value, (), source, "mass")
    if np.any(mass < 0):
        raise InputError(source, "mass", "mass >= 0 kg", f"min {mass.min()}")
    if np.any(mass == 0) and not np.all(mass == 0):
        raise InputError(source, "mass", "zero at all poses or positive at all poses", "mixed zero/positive")
    return mass


def make_point_mass(name: str, mass: Any, position: Any = (0.0, 0.0, 0.0)) -> PointMass:
    """Validated :class:`PointMass`; ``mass`` scalar or (N,) kg, ``position`` (3,) or (N, 3) m."""
    source = f"point mass '{name}'"
    return PointMass(name, _mass(mass, source), pose_array(position, (3,), source, "position"))


def make_rigid_body(
    name: str, mass: Any, position: Any, inertia: Any, rotation: Any | None = None
) -> RigidBody:
    """Validated :class:`RigidBody` (docs/theory/structure.md: ``M_body = diag(m I3, R I'_cg Rᵀ)``).

    ``inertia``: about the CoG, (3,) principal moments, (3, 3) or (N, 3, 3) tensor, in kg m².  With ``rotation``
    ((3, 3) or (N, 3, 3), columns = body axes in global components) the tensor is given in body axes and
    transformed to ``R I' Rᵀ``; without it, it is in global axes.
    """
    source = f"rigid body '{name}'"
    inertia_arr = np.asarray(inertia, dtype=float)
    if inertia_arr.shape == (3,):
        inertia_arr = np.diag(inertia_arr)
    tensor = pose_array(inertia_arr, (3, 3), source, "inertia")
    if not np.allclose(tensor, np.swapaxes(tensor, 1, 2), rtol=1e-9, atol=1e-12 * max(1.0, np.abs(tensor).max())):
        raise InputError(source, "inertia", "symmetric 3x3 tensor (kg m^2)", "asymmetric tensor")
    eig = np.linalg.eigvalsh(0.5 * (tensor + np.swapaxes(tensor, 1, 2)))  # before rotating: usually one tensor
    scale = max(1.0, float(np.abs(eig).max()))
    if np.any(eig < -1e-12 * scale):
        raise InputError(source, "inertia", "positive semi-definite tensor", f"eigenvalue {eig.min():.3e}")
    if rotation is not None:
        rot = pose_array(rotation, (3, 3), source, "rotation")
        err = np.abs(np.swapaxes(rot, 1, 2) @ rot - np.eye(3)).max()
        if err > 1e-8:
            raise InputError(source, "rotation", "orthonormal 3x3 rotation matrix", f"|RᵀR - I| = {err:.2e}")
        tensor = rot @ tensor @ np.swapaxes(rot, 1, 2)
    return RigidBody(name, _mass(mass, source), pose_array(position, (3,), source, "position"), tensor)


def combine_rigid(name: str, bodies: list[RigidBody | PointMass]) -> RigidBody:
    """One rigid body with the total mass, the common CoG and the inertia about it (parallel-axis theorem).

    Useful for an ideally rigid connection (e.g. platform + spindle of a machine with a rigid platform).
    """
    if not bodies:
        raise InputError(f"combine_rigid('{name}')", "bodies", "at least one body", "none")
    total = sum(b.mass for b in bodies)
    if np.any(total <= 0):
        raise InputError(f"combine_rigid('{name}')", "mass", "positive total mass", "zero")
    cog = sum(b.mass[:, None] * b.position for b in bodies) / total[:, None]
    inertia = 0.0
    for b in bodies:
        rho = b.position - cog
        steiner = b.mass[:, None, None] * (np.einsum("ni,ni->n", rho, rho)[:, None, None] * np.eye(3)
                                           - np.einsum("ni,nj->nij", rho, rho))
        own = b.inertia if isinstance(b, RigidBody) else 0.0
        inertia = inertia + own + steiner
    return RigidBody(name, total, cog, inertia)
