"""PKM structure model: spindle, platform and six drives connected by the bindings W, V, U (docs/theory/structure.md).

:func:`build_structure` turns a machine and N poses into a pose-vectorised :class:`~pkmstiff.multibody.SDEModel`:

* bodies (docs/theory/structure.md, DOF order of the spec): ``spindle`` (rigid, 6 DOF; only if the machine gives a
  ``platform_spindle`` stiffness), ``platform`` (rigid, 6), ``drive1`` … ``drive6`` (point masses, 3 each, at the
  drive-side joint points q_i; absent where the drive is rigidly suspended in the frame);
* ``W1`` … ``W6`` drive–frame (docs/theory/structure.md): glide ``K_W = R_i diag(k_A, k_y, k_z) R_iᵀ`` from the axial drive
  stiffness and the guide carriages (eq. 3.6; R_i: x' = guide direction, z' = machine vertical); pod: the
  ``drive_suspension`` 3×3 stiffness in the MKS (absent = rigid, the drive DOFs are removed, docs/theory/structure.md);
* ``V1`` … ``V6`` drive–platform (eq. 4.48–4.50): ``k_V d̂ d̂ᵀ`` at the platform joint p_i with
  ``1/k_V = 1/k_drive-joint + 1/k_strut + 1/k_platform-joint`` (pod: the telescopic ``drive`` is the strut term);
  joint stiffness at the joint angles of the pose in the joint type's convention (docs/theory/kinematics.md);
* ``U`` platform–spindle (eq. 4.51–4.52): the 6×6 ``platform_spindle`` stiffness at the coupling point r_U,
  given in platform axes (``H K_U Hᵀ``).  Without it platform and spindle are one body (24 DOF for a glide).

Components that are not given are rigid (``None`` in :func:`pkmstiff.machine.roles.machine_components`): a
rigid direction becomes an exact rigid binding (null-space elimination of the SDE layer), a fully rigid drive
suspension removes the drive body and attaches V to the frame.

Poses whose inverse kinematics has no solution or that are singular (κ(J_C⁻¹) above the machine's threshold,
docs/theory/kinematics.md) are not modelled: the structure keeps them with a reason code and every analysis returns NaN for them
(never an exception inside a batch).  The same holds for poses where a component cannot be evaluated (range
error, NaN or non-positive stiffness) and, in the batch evaluation, for poses whose stiffness matrix is not
positive definite.

Assumptions (not in the spec, configurable in :class:`StructureOptions`): strut masses are lumped at the drive and
platform joints by the machine file's ``strut_mass_shares`` (default half at either joint; the Hexaglide: none, its
drive and platform masses hold the struts); joint masses of the joint types go to the
drive resp. the platform; the platform–spindle coupling point is O' (docs/theory/structure.md Assumption); the spindle's
reference point is O'; a massless spindle (Hexaglide: all of M_P on the platform) is condensed statically.
"""

from pkmstiff.structure.assembly import platform_spindle_matrix
from pkmstiff.structure.build import build_structure, iter_structures, structure_evaluation, structure_summary
from pkmstiff.structure.layout import (
                                       PKSBody,
                                       StructureLayout,
                                       combine_bodies,
                                       component_body,
                                       structure_layout,
                                       strut_mass_shares,
                                       strut_mass_text,
                                       vertical_direction,
)
from pkmstiff.structure.masses import dynamics_masses, mass_matrix_about_origin, platform_mass_matrix
from pkmstiff.structure.model import PKMStructure
from pkmstiff.structure.options import (
                                       COMPONENT_FAILED,
                                       DEFAULT_CHUNK,
                                       NOT_POSITIVE_DEFINITE,
                                       STATUS_TEXT,
                                       StructureModelError,
                                       StructureOptions,
)
from pkmstiff.structure.stiffness import ChainStiffness, chain_stiffness

__all__ = [
    "StructureOptions", "StructureLayout", "StructureModelError", "PKMStructure", "ChainStiffness",
    "structure_layout", "strut_mass_shares", "strut_mass_text", "build_structure", "structure_evaluation",
    "iter_structures", "chain_stiffness",
    "platform_mass_matrix", "mass_matrix_about_origin", "PKSBody", "combine_bodies", "component_body",
    "vertical_direction", "platform_spindle_matrix", "dynamics_masses", "structure_summary", "DEFAULT_CHUNK",
    "COMPONENT_FAILED",
    "NOT_POSITIVE_DEFINITE", "STATUS_TEXT",
]
