"""In-memory description of a six-strut PKM (pod or glide), in SI units.

A :class:`Machine` is what a machine file (TOML) loads into; every array is float64 in SI units
(m, rad, kg, N, N/m) and has the chain index as its leading axis (``n`` chains, 6 for spatial PKMs).
Symbols follow ``docs/theory/index.md and ``docs/user-guide/machines.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

ChainKind = Literal["pod", "glide"]
TiltConvention = Literal["axis", "normal"]
StrutDirection = Literal["outward", "drive_to_platform"]


@dataclass(frozen=True)
class JointType:
    """Kind of joint with its angle convention and limits (docs/theory/kinematics.md).

    Angles in rad; a missing limit is ``-inf``/``+inf``.  ``ina_coupled`` switches on the
    coupled limit |tilt| <= 75 deg - 2/3 |swivel| (Cobet eq. B.6).  ``stiffness`` names a
    component instance of the machine file (``[components.<name>]``) or is ``None`` (rigid).
    """

    name: str
    convention: TiltConvention = "axis"
    strut_direction: StrutDirection = "outward"
    swivel_min: float = -np.inf
    swivel_max: float = np.inf
    tilt_min: float = -np.inf
    tilt_max: float = np.inf
    ina_coupled: bool = False
    stiffness: str | None = None
    mass: float = 0.0


@dataclass(frozen=True)
class Guide:
    """A guide shared by several glide drives, with spacing limits (Cobet eq. B.3, B.4).

    Distances in m; ``inf``/``0`` where no limit applies.  ``chains`` holds the 0-based chain indices.
    """

    name: str
    chains: tuple[int, ...]
    min_distance: float = 0.0
    max_distance: float = np.inf
    safety_margin: float = 0.0


@dataclass(frozen=True)
class Chains:
    """Geometry of all kinematic chains; arrays with leading dimension n (chains).

    Glide chains (``kind == "glide"``): drive-side joint point q_i = s_i + lambda_i r_i + q_off_i
    (docs/theory/kinematics.md).  Pod chains: q_i is fixed in the MKS and the strut length is the drive coordinate.
    """

    kind: ChainKind
    # glide: guide start s_i, unit direction r_i, usable length t_i, constant strut length l_i
    guide_start: np.ndarray  # (n, 3)
    guide_direction: np.ndarray  # (n, 3), unit vectors
    guide_length: np.ndarray  # (n,)
    strut_length: np.ndarray  # (n,) glide: constant; pod: NaN
    larger_root: np.ndarray  # (n,) bool, glide root choice (default False = smaller root)
    # pod: strut length limits (glide: NaN)
    length_min: np.ndarray  # (n,)
    length_max: np.ndarray  # (n,)
    # drive-side joint: glide = offset q_off from the guide point; pod = fixed point in the MKS
    drive_joint: np.ndarray  # (n, 3)
    drive_axis: np.ndarray  # (n, 3) a_i (MKS)
    drive_reference: np.ndarray  # (n, 3) b_i (MKS)
    # platform-side joint (PKS)
    platform_joint: np.ndarray  # (n, 3) p'_i
    platform_axis: np.ndarray  # (n, 3) m'_i
    platform_reference: np.ndarray  # (n, 3) n'_i
    strut_radius: np.ndarray  # (n,) m, for collision checks
    drive_joint_type: tuple[str, ...]  # names into Machine.joint_types
    platform_joint_type: tuple[str, ...]
    guide: tuple[str | None, ...]  # name of the shared guide per chain (glide) or None
    # drive zero offset o_i (m): the controller's drive coordinate is the geometric one minus o_i (pod: strut length
    # l_i - o_i, glide: lambda_i - o_i), i.e. a commanded value u drives the geometry to u + o_i. Zero unless a
    # calibrated machine file sets it (docs/theory/calibration.md: strut length offsets Δl_i; glide drive zero).
    drive_offset: np.ndarray | None = None  # (n,); None on construction means zeros

    def __post_init__(self) -> None:
        if self.drive_offset is None:
            object.__setattr__(self, "drive_offset", np.zeros(self.drive_joint.shape[0]))

    @property
    def n(self) -> int:
        return int(self.drive_joint.shape[0])


def memo(obj: Any, key: str, compute: Any) -> Any:
    """``compute()`` once per (frozen) object, kept in the object's ``__dict__`` under ``key`` (derived data such
    as hull planes or per-machine kernel constants; a changed copy from ``dataclasses.replace`` starts afresh)."""
    d = obj.__dict__
    if key not in d:
        object.__setattr__(obj, key, compute())
    return d[key]


@dataclass(frozen=True)
class Hull:
    """Platform hull polyhedron in the PKS: vertices (m) and triangles (vertex indices)."""

    vertices: np.ndarray  # (nv, 3)
    triangles: np.ndarray  # (nt, 3) int
    convex: bool = False  # True when the triangles are the convex hull of the vertices

    @property
    def empty(self) -> bool:
        return self.vertices.shape[0] == 0

    def convex_hull_equations(self) -> np.ndarray:
        """(F, 4) plane equations ``n . x + d <= 0`` (inside) of the convex hull of the vertices (scipy's Qhull),
        computed once per hull and kept with it (so that a cached machine needs no scipy at start-up)."""
        def qhull() -> np.ndarray:
            from scipy.spatial import ConvexHull

            return ConvexHull(self.vertices).equations

        return memo(self, "_equations", qhull)

    def face_planes(self) -> np.ndarray:
        """The distinct planes of :meth:`convex_hull_equations` (rounded to 1e-12: coplanar triangles share one),
        computed once per hull and kept with it."""
        # return_index: the same sorted rows without numpy's masked-array check (which imports numpy.ma)
        return memo(self, "_planes", lambda: np.unique(np.round(self.convex_hull_equations(), 12), axis=0,
                                                       return_index=True)[0])


@dataclass(frozen=True)
class Tool:
    """Tool centre point: tip = O' + R (offset + length * axis) (docs/theory/structure.md; default axis -z')."""

    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))
    length: float = 0.0

    def tip(self, length: float | None = None) -> np.ndarray:
        """TCP position in the PKS (m)."""
        return self.offset + (self.length if length is None else length) * self.axis


@dataclass(frozen=True)
class Limits:
    """Machine-level admissibility settings (docs/theory/admissibility.md)."""

    singularity_threshold: float = 1e8  # condition number of J_C^-1 (SI) above which a pose is singular
    strut_collision_mode: Literal["exact", "table_B2"] = "exact"
    platform_end_exclusion: float | None = None  # m excluded at the platform end of a strut; None = strut radius
    drive_load_include_coulomb: bool = True
    # fraction of the strut masses that the static drive load (eq. 4.90, B.13) adds to the moved mass
    # (docs/user-guide/validation-hexaglide.md (reading 5): the Hexaglide's drives carry platform + spindle + the six struts, i.e. 1.0)
    drive_load_strut_mass: float = 0.0
    # frame: box for the position of O' in the MKS (m); -inf/+inf where not limited
    position_min: np.ndarray = field(default_factory=lambda: np.full(3, -np.inf))
    position_max: np.ndarray = field(default_factory=lambda: np.full(3, np.inf))


#: note added to the displayed title of a machine whose K_U is left out (:attr:`Machine.display_title`)
NEGLECT_SPINDLE_NOTE = "K_U neglected (platform and spindle rigid, Cobet 4.2.4)"


@dataclass(frozen=True)
class Machine:
    """A complete PKM description loaded from a machine file."""

    name: str
    title: str
    chains: Chains
    joint_types: dict[str, JointType]
    guides: dict[str, Guide]
    hull: Hull
    tool: Tool
    gravity: np.ndarray  # (3,) m/s^2, e.g. (0, 0, -9.81)
    limits: Limits
    transmission_weight: float  # w in m/rad (docs/theory/kinetostatics.md)
    components: dict[str, dict[str, Any]]  # named component instances (raw, SI), built by `components`
    chain_components: tuple[dict[str, str], ...]  # per chain: role -> component instance name
    machine_components: dict[str, str]  # machine-level role -> component instance name
    assumptions: dict[str, str]  # key -> one-line reason for every value not given by the spec
    source: str = ""
    path: str = ""
    # origin of the reporting frame in the MKS (m): positions quoted by the source are measured from it
    # (docs/user-guide/validation-hexaglide.md (reading 2)); axes parallel to the MKS
    report_origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    report_origin_note: str = ""
    # transmission quality form (docs/theory/kinetostatics.md eq. 4.75 note): "inverse_sqrt_kappa" = κ(WJ_C)^(-1/2) (default),
    # "inverse_kappa" = 1/κ(WJ_C)
    transmission_form: str = "inverse_sqrt_kappa"
    # shares (drive joint, platform joint) of each strut's mass that the structure model lumps there ([machine]
    # strut_mass_shares; docs/theory/structure.md): (0, 0) where the drive and platform masses already hold the struts
    strut_mass_shares: tuple[float, float] = (0.5, 0.5)
    # component instances built on load: name -> (raw parameter table it was built from, instance)
    built_components: dict[str, tuple[dict, Any]] = field(default_factory=dict, compare=False, repr=False)
    # provenance of a calibrated machine file (its [calibration] table, validated on load; empty otherwise)
    calibration: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)
    # the platform-spindle stiffness K_U is left out (platform and spindle one rigid body); set by
    # pkmstiff.machine.frames.neglect_spindle, which also removes the platform_spindle role
    spindle_neglected: bool = False

    @property
    def display_title(self) -> str:
        """The title for outputs: the machine file's, with :data:`NEGLECT_SPINDLE_NOTE` when K_U is left out."""
        return f"{self.title} [{NEGLECT_SPINDLE_NOTE}]" if self.spindle_neglected else self.title

    @property
    def kind(self) -> ChainKind:
        return self.chains.kind

    @property
    def n_chains(self) -> int:
        return self.chains.n

    def joint_type_arrays(self, side: Literal["drive", "platform"]) -> dict[str, np.ndarray]:
        """Per-chain arrays of the joint settings of one side (for vectorised checks); read-only, built once per
        machine and side (the single-pose path asked for them four times per evaluation)."""
        def build() -> dict[str, np.ndarray]:
            arrays = self._joint_type_arrays(side)
            for a in arrays.values():
                a.flags.writeable = False
            return arrays

        return memo(self, f"_joint_type_arrays_{side}", build)

    def _joint_type_arrays(self, side: str) -> dict[str, np.ndarray]:
        names = self.chains.drive_joint_type if side == "drive" else self.chains.platform_joint_type
        jts = [self.joint_types[n] for n in names]
        return {
            "normal": np.array([j.convention == "normal" for j in jts]),
            "outward": np.array([j.strut_direction == "outward" for j in jts]),
            "swivel_min": np.array([j.swivel_min for j in jts]),
            "swivel_max": np.array([j.swivel_max for j in jts]),
            "tilt_min": np.array([j.tilt_min for j in jts]),
            "tilt_max": np.array([j.tilt_max for j in jts]),
            "ina_coupled": np.array([j.ina_coupled for j in jts]),
        }

