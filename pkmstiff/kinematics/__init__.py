"""Kinematics layer: rotations, inverse kinematics, Jacobians, condition number, forward kinematics, joint angles and
the compiled per-pose kernels (docs/theory/kinematics.md; Cobet §1, §6.1).

Poses are arrays of shape ``(N, 6)``: x, y, z [m] (O' in the MKS) and Cardan angles a, b, c [rad]
(:mod:`pkmstiff.kinematics.rotation`). Results are pose-first, e.g. ``IK.p`` has shape ``(N, n, 3)``.
"""

from pkmstiff.kinematics.arrays import DEFAULT_CHUNK, POSE_COLUMNS, POSE_UNITS, as_poses, chunk_slices
from pkmstiff.kinematics.conditioning import (
    condition_bounds,
    condition_number,
    is_singular,
    jacobian_and_condition,
    jacobian_and_singular,
    kinematic_jacobian,
    singular_mask,
    transmission_quality,
)
from pkmstiff.kinematics.forward import FK_STATUS, FKResult, forward_kinematics
from pkmstiff.kinematics.inverse import IK, inverse_kinematics, inverse_kinematics_frames
from pkmstiff.kinematics.jacobians import cardan_inverse_jacobian, inverse_jacobian, relative_inverse_jacobian

__all__ = ["DEFAULT_CHUNK", "FKResult", "FK_STATUS", "IK", "POSE_COLUMNS", "POSE_UNITS",
           "as_poses", "cardan_inverse_jacobian", "chunk_slices", "condition_bounds", "condition_number",
           "forward_kinematics", "inverse_jacobian", "inverse_kinematics", "inverse_kinematics_frames",
           "is_singular", "jacobian_and_condition", "jacobian_and_singular", "kinematic_jacobian",
           "relative_inverse_jacobian", "singular_mask", "transmission_quality"]
