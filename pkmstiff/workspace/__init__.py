"""Workspace analysis (docs/theory/workspace.md, Cobet 4.1): modified octree, boundary surface and volume, rotation-angle
maps and the rotational workspace, user requirements.

Modules: :mod:`.octree` (generic modified octree), :mod:`.oracle` (pose admissibility as a predicate),
:mod:`.translational` (constant-orientation workspace of a machine), :mod:`.surface` (closed mesh, STL/VTK),
:mod:`.volume` (volume methods), :mod:`.rotation` (predictor-corrector angle maps), :mod:`.requirements`
(``"kx>=20 N/um"``), :mod:`.plots` (figures), :mod:`.validation` (accuracy on sphere and cube).
"""

from pkmstiff.workspace.octree import OctreeResult, octree_boundary
from pkmstiff.workspace.oracle import PoseOracle, staged_admissible
from pkmstiff.workspace.requirements import Requirement, parse_requirement
from pkmstiff.workspace.rotation import SIX_DIRECTIONS, RotationMapResult, rotation_angle_map, rotational_workspace_map
from pkmstiff.workspace.surface import BoundarySurface, boundary_surface
from pkmstiff.workspace.translational import (
           WorkspaceResult,
           constant_orientation_workspace,
           reach_box,
           volume_vs_orientation,
)
from pkmstiff.workspace.volume import workspace_volume

__all__ = ["BoundarySurface", "OctreeResult", "PoseOracle", "Requirement", "RotationMapResult", "SIX_DIRECTIONS",
           "WorkspaceResult", "boundary_surface", "constant_orientation_workspace", "octree_boundary",
           "parse_requirement", "reach_box", "rotation_angle_map", "rotational_workspace_map",
           "staged_admissible", "volume_vs_orientation", "workspace_volume"]
