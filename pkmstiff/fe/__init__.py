"""Finite-element component models with scikit-fem (docs/theory/components.md, §3.7).

* :mod:`.mesh` — structured hexahedral primitives (box, O-grid cylinder, tube, block with bore).
* :mod:`.materials`, :mod:`.elasticity` — isotropic and bearing-substitute (cubic-cylindrical) laws,
  vectorised stiffness assembly on scikit-fem bases (default 20-node hexahedra).
* :mod:`.ties`, :mod:`.coupling`, :mod:`.assembly` — tie constraints, RBE2 rigid coupling, Guyan condensation,
  multi-part models with rigid placements.
* :mod:`.joints` — parametric IWF joints (2 DOF / 3 DOF) and tilt sweeps -> joint tables.
* :mod:`.platform` — parametric platform plate -> 6x6 stiffness at the spindle reference point.
* :mod:`.export`, :mod:`.plots`, :mod:`.cli` — CSV/VTU output, pyvista images, ``pkmstiff fe-joint|fe-platform``.

SI units inside (m, Pa, N, N/m, rad); mm, degrees and N/µm only at the file/CLI edges.
"""

from pkmstiff.fe.assembly import NodeSet, Part, PartModel, ReferencePoint, Tie
from pkmstiff.fe.coupling import compliance_along, guyan, rbe2_rows, stiffness_along
from pkmstiff.fe.joints import (
                     DEFAULT_ANGLES_DEG,
                     JointParameters,
                     SweepResult,
                     build_joint_model,
                     load_joint_parameters,
                     sweep,
)
from pkmstiff.fe.materials import CubicCylindrical, Isotropic
from pkmstiff.fe.platform import PlatformParameters, load_platform_parameters, platform_stiffness

__all__ = ["CubicCylindrical", "DEFAULT_ANGLES_DEG", "Isotropic", "JointParameters", "NodeSet", "Part", "PartModel",
           "PlatformParameters", "ReferencePoint", "SweepResult", "Tie", "build_joint_model", "compliance_along",
           "guyan", "load_joint_parameters", "load_platform_parameters", "platform_stiffness", "rbe2_rows",
           "stiffness_along", "sweep"]
