"""In-memory description of a mechanism built from links and joints (DE 10 2004 026 707 A1, calibration.md §3).

Every link carries a frame that coincides with the world frame at home (patent claim 4); its unknowns are the frame
position t and the angles φ with R = Rz(φz) Ry(φy) Rx(φx) (eq. 1–2): 6 per link in space, 3 (tx, ty, φ) in the plane
(eq. 9).  Joints are entered by type, the two links they join, and their point/axis in world coordinates at home
(so the same numbers are the link-frame coordinates, eq. 3–7).  SI units inside (m, rad).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

#: elementary constraints of the patent (Fig. 1A–1E, eq. 3–7), the toolkit's point-in-plane (1F) and fixed coordinates
ELEMENTARY = ("1A", "1B", "1C", "1D", "1E", "1F", "fixed")
#: nominal rank of each elementary constraint in space / in the plane (eq. 5 and 7 have 3 rows of rank 2)
NOMINAL_RANK = {3: {"1A": 3, "1B": 3, "1C": 2, "1D": 1, "1E": 2, "1F": 1, "fixed": 1},
                2: {"1A": 2, "1B": 1, "1E": 1, "fixed": 1}}
#: rows of each elementary constraint in space / in the plane
ROWS = {3: {"1A": 3, "1B": 3, "1C": 3, "1D": 1, "1E": 3, "1F": 1, "fixed": 1},
        2: {"1A": 2, "1B": 1, "1E": 1, "fixed": 1}}

#: joint types → elementary constraints (calibration.md §3; the patent's "Schubgelenk ohne Orientierung" is the
#: cylindrical joint; "planar" (a link sliding on a plane of the other) = common normal 1C + point in plane 1F)
JOINT_TYPES_3D = {
    "spherical": ("1A",), "revolute": ("1A", "1C"), "cardan": ("1A", "1D"), "cylindrical": ("1C", "1E"),
    "prismatic": ("1B", "1E"), "planar": ("1C", "1F"), "rigid": ("1A", "1B"),
    "common_point": ("1A",), "equal_orientation": ("1B",), "common_axis": ("1C",), "perpendicular_axes": ("1D",),
    "point_on_axis": ("1E",), "point_in_plane": ("1F",), "fixed": ("fixed",),
}
#: in the plane every rotation axis is z: a revolute joint is a common point, 1C/1D do not exist (eq. 9–14)
JOINT_TYPES_2D = {
    "revolute": ("1A",), "prismatic": ("1B", "1E"), "rigid": ("1A", "1B"), "slot": ("1E",),
    "common_point": ("1A",), "equal_orientation": ("1B",), "point_on_axis": ("1E",), "fixed": ("fixed",),
}
#: which joint variable a drive / a limit refers to: "linear" (displacement along the axis, eq. 8), "angle"
#: (relative rotation about the axis) or "tilt" (angle between the axis on both links)
JOINT_VARIABLE = {"revolute": "angle", "prismatic": "linear", "cylindrical": "linear", "point_on_axis": "linear",
                  "slot": "linear", "spherical": "tilt", "cardan": "tilt", "common_point": "tilt"}
COORDINATES = {3: ("x", "y", "z", "phi_x", "phi_y", "phi_z"), 2: ("x", "y", "phi")}


@dataclass(frozen=True)
class Drive:
    """An active joint: drive value = joint variable + offset (eq. 8; linear in m, angle in rad)."""

    name: str
    offset: float = 0.0


@dataclass(frozen=True)
class Joint:
    """One joint: type, links (j, k) as indices, point and axes in world coordinates at home (m, unit vectors).

    ``axis2`` is the Cardan joint's axis on link k (1D).  ``limits`` bound the joint variable (see
    :data:`JOINT_VARIABLE`; m or rad); ``coordinates``/``values`` are used by the ``fixed`` type only.
    """

    name: str
    type: str
    links: tuple[int, int]
    point: np.ndarray
    axis: np.ndarray | None = None
    axis2: np.ndarray | None = None
    drive: Drive | None = None
    limits: tuple[float, float] = (-np.inf, np.inf)
    coordinates: tuple[int, ...] = ()
    values: tuple[float, ...] = ()

    @property
    def variable(self) -> str | None:
        return JOINT_VARIABLE.get(self.type)


@dataclass(frozen=True)
class Output:
    """The controlled link for inverse kinematics (patent [0017], [0045]).

    Pose (x, y, z [m], a, b, c [rad]; planar x, y [m], phi [rad]) fixes the world position of ``point`` (world at
    home) and, by ``orientation``: "full" the link rotation R = cardan(a, b, c) (pkmstiff's Cardan convention,
    R_a R_b R_c) relative to home, "axis" only the direction R·axis (5-axis machines), "none" nothing.
    ``coordinates`` lists the controlled position components (indices).
    """

    link: int
    point: np.ndarray
    orientation: str = "full"
    axis: np.ndarray | None = None
    coordinates: tuple[int, ...] = (0, 1, 2)


@dataclass(frozen=True)
class Mechanism:
    """Links, joints and output of a mechanism file (SI)."""

    name: str
    title: str
    dim: int  #: 3 spatial, 2 planar
    links: tuple[str, ...]
    ground: tuple[int, ...]
    joints: tuple[Joint, ...]
    output: Output | None
    assumptions: dict[str, str] = field(default_factory=dict)
    source: str = ""
    path: str = ""
    #: components on joints and links (:class:`pkmstiff.mechanisms.elastic.ElasticData`); None: kinematics only
    elastic: Any = None

    @property
    def dof_per_link(self) -> int:
        return 6 if self.dim == 3 else 3

    @property
    def n_unknowns(self) -> int:
        return len(self.links) * self.dof_per_link

    @property
    def drives(self) -> tuple[Joint, ...]:
        return tuple(j for j in self.joints if j.drive is not None)

    @property
    def drive_names(self) -> tuple[str, ...]:
        return tuple(j.drive.name for j in self.drives)  # type: ignore[union-attr]

    @property
    def drive_units(self) -> tuple[str, ...]:
        return tuple("m" if j.variable == "linear" else "rad" for j in self.drives)

    @property
    def pose_size(self) -> int:
        return 6 if self.dim == 3 else 3

    @cached_property
    def length_scale(self) -> float:
        """Largest joint-point distance from the origin (m), ≥ 1 mm; scales the solver tolerances."""
        pts = [np.abs(j.point).max() for j in self.joints if j.point is not None and j.point.size]
        return float(max([1e-3, *pts]))

    def link_index(self, name: str) -> int:
        return self.links.index(name)

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)

    @cached_property
    def home_output_pose(self) -> np.ndarray:
        """Output pose at home (all link frames = world): position of the output point, angles 0."""
        pose = np.zeros(self.pose_size)
        if self.output is not None:
            pose[: self.dim] = self.output.point
        return pose
