"""Linear direct drives and ball screws with direct measuring system (docs/theory/components.md).

The axial stiffness of a PD-controlled drive is position independent (Cobet eq. 3.5, 3.9):
``k_A = k_m k_px = m_i Ω²``. The toolkit offers ``axial_stiffness = "constant"`` (default, value given,
e.g. 25 N/µm for the Hexaglide, eq. 3.13) or ``"pole_placement"`` with the pole distance Ω [rad/s] and the
apparent mass m_i = diag(M_A + J_Cᵀ M_P J_C)_i (eq. 3.10–3.12) handed over in ``state.effective_mass``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from components.limits import DRIVE_LIMITS, drive_limits
from components.params import ModelSpec, Param
from components.protocol import Component, ComponentState, _full
from pkmstiff.errors import ArgumentError

if TYPE_CHECKING:
    from components.reader import Params

AXIAL_MODES: tuple[str, ...] = ("constant", "pole_placement")


def joint_space_mass_diagonal(J_C: Any, M_A: Any, M_P: Any) -> np.ndarray:
    """Diagonal of the joint-space mass matrix M_q = M_A + J_Cᵀ M_P J_C (Cobet eq. 3.10–3.12) [kg].

    ``J_C`` (N, n, n): kinematic Jacobian, twist = J_C q̇ (docs/theory/kinematics.md); ``M_A`` (n,) or (N, n): drive
    masses (diagonal of M_A); ``M_P`` (n, n) or (N, n, n): platform + spindle mass matrix referred to O' in
    MKS axes (docs/theory/structure.md). Returns (N, n).
    """
    J = np.asarray(J_C, dtype=float)
    MP = np.asarray(M_P, dtype=float)
    MA = np.asarray(M_A, dtype=float)
    if J.ndim != 3 or J.shape[1] != J.shape[2]:
        raise ArgumentError(f"joint_space_mass_diagonal: J_C must have shape (N, n, n), found {J.shape}")
    n = J.shape[-1]
    if MP.shape[-2:] != (n, n) or MA.shape[-1] != n:
        raise ArgumentError(f"joint_space_mass_diagonal: M_A must end in ({n},) and M_P in ({n}, {n}), "
                                 f"found {MA.shape} and {MP.shape}")
    MP = np.broadcast_to(MP, (J.shape[0], n, n))
    return MA + np.einsum("nki,nkl,nli->ni", J, MP, J)


@dataclass(frozen=True, kw_only=True, eq=False)
class LinearDirectDrive(Component):
    """Position-independent axial drive stiffness (Cobet eq. 3.5, 3.9) with force/speed/friction limits.

    ``k_axial`` [N/m] for ``axial_stiffness="constant"``; ``pole_distance`` Ω [rad/s] for
    ``"pole_placement"`` (k = m_eff Ω², m_eff from ``state.effective_mass``). ``mass`` = drive mass m_A [kg].
    Limits (SI): max_force, force_reserve, max_speed, coulomb_friction [N], viscous_friction [N·s/m].
    """

    kind: ClassVar[str] = "axial"
    axial_stiffness: str = "constant"
    k_axial: float | None = None
    pole_distance: float | None = None

    def __post_init__(self) -> None:
        if self.axial_stiffness not in AXIAL_MODES:
            raise ArgumentError(f"drive '{self.name}': axial_stiffness must be one of {AXIAL_MODES}, "
                                     f"found {self.axial_stiffness!r}")
        if self.axial_stiffness == "constant" and not (self.k_axial is not None and self.k_axial > 0):
            raise ArgumentError(f"drive '{self.name}': axial_stiffness='constant' needs a positive k_axial, "
                                     f"found {self.k_axial!r}")
        if self.axial_stiffness == "pole_placement" and not (self.pole_distance is not None and self.pole_distance > 0):
            raise ArgumentError(f"drive '{self.name}': axial_stiffness='pole_placement' needs a positive "
                                     f"pole_distance (rad/s), found {self.pole_distance!r}")
        for key, value in self.limits.items():
            if not value >= 0:
                raise ArgumentError(f"drive '{self.name}': limit {key} must be >= 0, found {value!r}")

    def stiffness(self, state: ComponentState) -> np.ndarray:
        if self.axial_stiffness == "constant":
            return _full(state, self.k_axial)
        m_eff = state.require("effective_mass", self.name)
        return m_eff * self.pole_distance**2

    def friction_force(self, velocity: Any) -> np.ndarray:
        """Drive friction f_q = C sign(q̇) + V q̇ [N] (Cobet eq. 4.89) for drive velocities q̇ [m/s]."""
        v = np.asarray(velocity, dtype=float)
        return self.limits.get("coulomb_friction", 0.0) * np.sign(v) + self.limits.get("viscous_friction", 0.0) * v

    def available_force(self) -> float:
        """T = τ_q,max − τ_q,min [N] (docs/theory/kinetostatics.md); needs limits max_force (reserve defaults to 0)."""
        if "max_force" not in self.limits:
            raise ArgumentError(f"drive '{self.name}': no max_force limit given")
        return self.limits["max_force"] - self.limits.get("force_reserve", 0.0)


# --------------------------------------------------------------------------------------------- machine files
def _linear_direct_drive(p: "Params") -> Component:
    mode = p["axial_stiffness"]
    k = p["k_axial"]
    omega = p["pole_distance"]
    if mode == "constant" and omega is not None:
        raise p.error("pole_distance", "no pole_distance with axial_stiffness = 'constant'", omega)
    if mode == "pole_placement" and k is not None:
        raise p.error("k_axial", "no k_axial with axial_stiffness = 'pole_placement' (k = m_eff Omega^2)", k)
    if mode == "constant" and k is None:
        raise p.error("k_axial", "the axial stiffness (axial_stiffness = 'constant')", "missing")
    if mode == "pole_placement" and omega is None:
        raise p.error("pole_distance", "the pole distance Omega in rad/s (axial_stiffness = 'pole_placement')",
                      "missing")
    return LinearDirectDrive(name=p.name, axial_stiffness=mode, k_axial=k, pole_distance=omega, mass=p["mass"],
                             limits=drive_limits(p))


MODELS: tuple[ModelSpec, ...] = (ModelSpec(
    "linear_direct_drive",
    "linear direct drive: constant or pole-placement axial stiffness, force/speed/friction limits",
    "Cobet eq. 3.5, 3.9-3.13",
    (Param("axial_stiffness", "-", "constant", "constant k_axial, or k = m_eff Omega^2", choices=AXIAL_MODES),
     Param("k_axial", "N/m", None, "axial stiffness", required="if axial_stiffness = 'constant'", positive=True),
     Param("pole_distance", "rad/s", None, "pole distance Omega (k = m_eff Omega^2)",
           required="if axial_stiffness = 'pole_placement'", positive=True),
     Param("mass", "kg", 0.0, "drive mass m_A", min_value=0.0)) + DRIVE_LIMITS,
    _linear_direct_drive),)
