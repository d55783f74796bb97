"""Plug-in protocol of the component model library: per-pose state, component base class, series/parallel.

Every component computes its stiffness for a batch of ``N`` poses at once from a :class:`ComponentState`
whose arrays all have the pose axis as their (only) axis.  All quantities are SI (m, rad, kg, N, N/m,
N·m/rad); conversion to N/µm, mm or degrees happens only at the edges (files, CLI, plots).

Stiffness shapes returned by :meth:`Component.stiffness`:

* axial (scalar along an axis: drive, strut, joint): ``(N,)`` in N/m — also when constant;
* 3×3 (guide carriages, drive stiffness, bearing): ``(N, 3, 3)``;
* 6×6 (body stiffness): ``(N, 6, 6)`` with blocks in N/m, N/rad and N·m/rad.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

import numpy as np

from components.limits import DRIVE_LIMITS, ROTARY_DRIVE_LIMITS, drive_limits
from components.params import ModelSpec, Param
from pkmstiff.errors import ArgumentError, ComponentRangeError  # noqa: F401 (components.protocol.*)

StiffnessKind = Literal["axial", "torsional", "matrix3", "matrix6", "body"]

#: SI unit of every key that may appear in :attr:`Component.limits`.
LIMIT_UNITS: dict[str, str] = {
    "max_force": "N",
    "force_reserve": "N",
    "max_speed": "m/s",
    "coulomb_friction": "N",
    "viscous_friction": "N*s/m",
    "max_torque": "N*m",
    "torque_reserve": "N*m",
    "max_angular_speed": "rad/s",
    "coulomb_torque": "N*m",
    "tilt_min": "rad",
    "tilt_max": "rad",
    "swivel_min": "rad",
    "swivel_max": "rad",
    "l_eff_min": "m",
    "l_eff_max": "m",
    "position_min": "m",
    "position_max": "m",
}


@dataclass(frozen=True)
class ComponentState:
    """Per-pose state handed to :meth:`Component.stiffness`; every given array has shape ``(N,)``.

    Fields (all optional, SI):

    * ``drive_position`` – glide drive coordinate λ_i or pod strut length l_i [m];
    * ``strut_length`` – strut length l_i [m];
    * ``l_eff`` – effective spindle length of a ball screw [m] (fixed–fixed: the segment l_Sp1 next to the
      motor-side bearing); when absent a drive derives it from its position;
    * ``swivel``, ``tilt`` – joint angles in the joint's own convention [rad]; NaN swivel = undefined;
    * ``effective_mass`` – diagonal element of the joint-space mass matrix M_q [kg] (pole placement);
    * ``n_poses`` – number of poses when no array is given (default 1).
    """

    drive_position: np.ndarray | None = None
    strut_length: np.ndarray | None = None
    l_eff: np.ndarray | None = None
    swivel: np.ndarray | None = None
    tilt: np.ndarray | None = None
    effective_mass: np.ndarray | None = None
    n_poses: int | None = None

    _ARRAYS: ClassVar[tuple[str, ...]] = (
        "drive_position", "strut_length", "l_eff", "swivel", "tilt", "effective_mass",
    )

    def __post_init__(self) -> None:
        for name in self._ARRAYS:
            value = getattr(self, name)
            if value is None:
                continue
            arr = np.atleast_1d(np.asarray(value, dtype=float))
            if arr.ndim != 1:
                raise ArgumentError(f"ComponentState.{name}: expected a 1-D array of shape (N,), found shape "
                                         f"{arr.shape}")
            object.__setattr__(self, name, arr)
        sizes = {name: getattr(self, name).shape[0] for name in self._ARRAYS if getattr(self, name) is not None}
        if len(set(sizes.values())) > 1:
            raise ArgumentError(f"ComponentState: all arrays must have the same length N, found {sizes}")
        if self.n_poses is not None:
            if int(self.n_poses) < 1:
                raise ArgumentError(option="ComponentState.n_poses", expected="an integer >= 1", found=self.n_poses)
            if sizes and next(iter(sizes.values())) != int(self.n_poses):
                raise ArgumentError(f"ComponentState: n_poses={self.n_poses} does not match the array lengths "
                                         f"{sizes}")

    @property
    def n(self) -> int:
        """Number of poses N."""
        for name in self._ARRAYS:
            value = getattr(self, name)
            if value is not None:
                return int(value.shape[0])
        return int(self.n_poses) if self.n_poses is not None else 1

    def require(self, name: str, component: str) -> np.ndarray:
        """Return the array ``name`` or raise a :class:`ArgumentError` naming the component that needs it."""
        value = getattr(self, name)
        if value is None:
            raise ArgumentError(f"component '{component}': ComponentState.{name} is required but was not given")
        return value

    def replace(self, **changes: Any) -> "ComponentState":
        """Copy with some fields replaced."""
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True, kw_only=True)
class Component(ABC):
    """Base class of all components.

    Attributes: ``name``; ``mass`` [kg] (moved mass carried into the dynamics, 0 if not relevant);
    ``limits`` (SI values, keys in :data:`LIMIT_UNITS`); ``assumptions`` (parameter -> one-line reason for
    every value the spec does not give); ``provenance`` (where the data come from).
    Subclasses set the class variable ``kind`` and implement :meth:`stiffness`.
    """

    kind: ClassVar[StiffnessKind] = "axial"
    name: str = ""
    mass: float = 0.0
    limits: dict[str, float] = field(default_factory=dict)
    assumptions: dict[str, str] = field(default_factory=dict)
    provenance: str = ""

    @abstractmethod
    def stiffness(self, state: ComponentState) -> np.ndarray:
        """Stiffness for every pose of ``state``: ``(N,)``, ``(N, 3, 3)`` or ``(N, 6, 6)`` in SI units."""

    def damping(self, state: ComponentState) -> np.ndarray | None:
        """Damping of the same shape as the stiffness, or ``None`` (damping is neglected, docs/theory/structure.md)."""
        return None

    @property
    def stiffness_unit(self) -> str:
        """SI unit of the values returned by :meth:`stiffness`."""
        return {"axial": "N/m", "matrix3": "N/m", "matrix6": "N/m | N/rad | N*m/rad (blocks)", "body": "-"}[self.kind]


def _full(state: ComponentState, value: float) -> np.ndarray:
    """``(N,)`` array filled with ``value``."""
    return np.full(state.n, float(value))


def _is_matrix(k: Any) -> bool:
    a = np.asarray(k)
    return a.ndim >= 2 and a.shape[-1] == a.shape[-2] and a.shape[-1] >= 2


def _is_rigid_scalar(k: Any) -> bool:
    return np.ndim(k) == 0 and np.isposinf(float(k))


def parallel(*k: Any) -> np.ndarray:
    """Parallel connection: sum of stiffnesses (scalars, ``(N,)`` arrays or stacked matrices).

    ``np.inf`` (rigid) makes the sum rigid.
    """
    if not k:
        raise ArgumentError("parallel() needs at least one stiffness")
    total = np.asarray(k[0], dtype=float)
    for kj in k[1:]:
        total = total + np.asarray(kj, dtype=float)
    return total


def series(*k: Any, matrix: bool | None = None) -> np.ndarray:
    """Series connection: inverse of the sum of compliances.

    Scalars / arrays (elementwise): ``1 / sum(1 / k_j)``; ``np.inf`` is rigid (compliance 0), 0 is a
    break (result 0); all rigid gives ``np.inf``.

    Matrices (``matrix=True``, or auto-detected when any operand has square trailing dims ≥ 2, e.g.
    ``(N, 3, 3)``): ``(sum K_j^-1)^-1``, evaluated pairwise as ``K_a (K_a + K_b)^-1 K_b`` (equal for
    invertible matrices).  A scalar ``np.inf`` operand is a rigid element and is skipped.
    Pass ``matrix=False`` to force the elementwise rule for arrays whose last two axes happen to be square.
    """
    if not k:
        raise ArgumentError("series() needs at least one stiffness")
    if matrix is None:
        matrix = any(_is_matrix(kj) for kj in k)
    if not matrix:
        with np.errstate(divide="ignore"):
            compliance = sum(1.0 / np.asarray(kj, dtype=float) for kj in k)
            return 1.0 / np.asarray(compliance, dtype=float)
    mats = [np.asarray(kj, dtype=float) for kj in k if not _is_rigid_scalar(kj)]
    if not mats:
        return np.asarray(np.inf)
    for j, m in enumerate(mats):
        if not _is_matrix(m):
            raise ArgumentError(f"series(matrix=True): operand {j} has shape {m.shape}, expected (..., n, n) or "
                                     f"np.inf")
    result = mats[0]
    for m in mats[1:]:
        try:
            result = result @ np.linalg.solve(result + m, m)
        except np.linalg.LinAlgError as exc:
            raise ArgumentError("series of matrices: the sum of two consecutive stiffness matrices is singular; "
                                     "series needs positive-definite stiffness matrices") from exc
    return 0.5 * (result + np.swapaxes(result, -1, -2))


@dataclass(frozen=True, kw_only=True, eq=False)
class ConstantAxial(Component):
    """Constant axial stiffness ``k`` [N/m] (``np.inf`` = rigid), e.g. a drive with fixed stiffness."""

    kind: ClassVar[StiffnessKind] = "axial"
    k: float

    def __post_init__(self) -> None:
        if not self.k > 0:
            raise ArgumentError(f"component '{self.name}': k must be positive, found {self.k!r}")

    def stiffness(self, state: ComponentState) -> np.ndarray:
        return _full(state, self.k)


@dataclass(frozen=True, kw_only=True, eq=False)
class RotaryDrive(ConstantAxial):
    """Rotary drive of constant torsional stiffness ``k`` [N m/rad] about its axis (motor + gear + control, as seen
    at the driven joint; ``np.inf`` = rigid); ``mass`` [kg] of the parts moving with the driven link; ``inertia``
    [kg m²] the rotor inertia reflected to the joint (gear ratio² × rotor inertia), about the drive axis: the
    drive-coordinate inertia M_A of the rigid-body dynamics (eq. 4.86, the apparent mass of eq. 3.4 for a rotary
    drive)."""

    kind: ClassVar[StiffnessKind] = "torsional"
    inertia: float = 0.0


MODELS: tuple[ModelSpec, ...] = (ModelSpec(
    "constant_axial", "constant axial stiffness (drive, strut or any axial element)", "k = const",
    (Param("k", "N/m", None, "axial stiffness", required=True, positive=True, rigid_ok=True),
     Param("mass", "kg", 0.0, "moved mass", min_value=0.0)) + DRIVE_LIMITS,
    lambda p: ConstantAxial(name=p.name, k=p["k"], mass=p["mass"], limits=drive_limits(p))),
    ModelSpec(
    "rotary_drive", "rotary drive: constant torsional stiffness about the drive axis (mechanism files)",
    "M = k dtheta",
    (Param("k", "N*m/rad", None, "torsional stiffness about the drive axis", required=True, positive=True,
           rigid_ok=True),
     Param("mass", "kg", 0.0, "mass moving with the driven link", min_value=0.0),
     Param("inertia", "kg*m^2", 0.0, "rotor inertia reflected to the joint (gear ratio^2 x rotor inertia) about the "
           "drive axis: drive-coordinate inertia of the accelerations (eq. 4.86)", min_value=0.0))
    + ROTARY_DRIVE_LIMITS,
    lambda p: RotaryDrive(name=p.name, k=p["k"], mass=p["mass"], inertia=p["inertia"],
                          limits=drive_limits(p, ROTARY_DRIVE_LIMITS))),)
