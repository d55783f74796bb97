"""Options, status codes and the error of the PKM structure model (docs/theory/structure.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from pkmstiff.errors import StructureModelError  # noqa: F401 (re-exported)

Array = NDArray[np.float64]


#: default number of poses per chunk of the batch evaluation (memory ≈ 3·chunk·30²·8 bytes of work arrays)
DEFAULT_CHUNK = 2048


#: extra status bits of the structure model (beside :class:`pkmstiff.admissibility.checks.Reason`)
COMPONENT_FAILED = 1  # a component could not be evaluated (range error, NaN or non-positive stiffness)


NOT_POSITIVE_DEFINITE = 2  # the assembled stiffness matrix is not positive definite


STATUS_TEXT = {
    COMPONENT_FAILED: "a component stiffness could not be evaluated at this pose (out of range, NaN or <= 0)",
    NOT_POSITIVE_DEFINITE: "stiffness matrix not positive definite (structurally singular pose)",
}




@dataclass(frozen=True)
class StructureOptions:
    """Settings of the structure model; every field not prescribed by the spec is an Assumption.

    ``strut_mass_to_drive``: None (default) = the machine's ``strut_mass_shares`` (machine file); a fraction
    overrides them: that fraction of each strut's mass at the drive joint, the rest at the platform joint;
    ``joint_masses``: add the joint types' masses (drive joint → drive, platform joint → platform);
    ``coupling_point``: r_U in the PKS [m] (docs/theory/structure.md Assumption: O'); ``k_u_axes``: axes in which the
    ``platform_spindle`` matrix is given (``"platform"`` → ``H K_U Hᵀ``, or ``"machine"``);
    ``damping_beta``: stiffness-proportional SDE damping ``C_e = β K_e`` [s] (no damping data given: 0);
    ``free_frame``: replace the fixed frame by a free rigid body ``base`` of ``frame_mass`` [kg] and
    ``frame_inertia`` [kg m²] (test of the six rigid-body modes; not a machine model);
    ``check``: ``"kinematic"`` (default) models every reachable, non-singular pose; ``"full"`` also excludes poses
    failing any admissibility check of :func:`pkmstiff.admissibility.pipeline.evaluate_poses` (collisions, joint limits, ...);
    ``load_platform``: the static analyses (TCP compliance, weak points, deflections, FRFs) load the platform at the
    TCP, i.e. with K_U rigid, while the spindle body and K_U stay in the model (the modes keep them; K_U's weak-point
    share is 0). This is the one load choice that differs from leaving K_U out of the machine
    (:func:`pkmstiff.machine.frames.neglect_spindle`, the machine's ``spindle_neglected``, which merges platform and
    spindle for every analysis): ``pkmstiff point --neglect-spindle`` reports it so (docs/theory/structure.md).
    """

    strut_mass_to_drive: float | None = None
    joint_masses: bool = True
    coupling_point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    k_u_axes: Literal["platform", "machine"] = "platform"
    damping_beta: float = 0.0
    free_frame: bool = False
    frame_mass: float = 1.0e3
    frame_inertia: float = 1.0e3
    check: Literal["kinematic", "full"] = "kinematic"
    load_platform: bool = False

    def __post_init__(self) -> None:
        if self.strut_mass_to_drive is not None and not 0.0 <= self.strut_mass_to_drive <= 1.0:
            raise StructureModelError("StructureOptions", "strut_mass_to_drive", "a fraction in [0, 1]",
                                      self.strut_mass_to_drive)
        if self.k_u_axes not in ("platform", "machine"):
            raise StructureModelError("StructureOptions", "k_u_axes", "'platform' or 'machine'", self.k_u_axes)
        if self.check not in ("kinematic", "full"):
            raise StructureModelError("StructureOptions", "check", "'kinematic' or 'full'", self.check)
        if not (np.isfinite(self.damping_beta) and self.damping_beta >= 0):
            raise StructureModelError("StructureOptions", "damping_beta", "a time >= 0 s", self.damping_beta)
        if np.shape(self.coupling_point) != (3,):
            raise StructureModelError("StructureOptions", "coupling_point", "a point (3,) in m (PKS)",
                                      self.coupling_point)
