"""Tapered roller bearings after Dietl and the tensile-test-rig evaluation (docs/theory/components.md).

Dietl's linear spring model (Cobet eq. 3.31, 3.32): with displacements u_B = (u_x, u_z, u_ϑ) (radial,
axial, tilt) K_L = Σ k_i N_iᵀ N_i, N_i = [cos α cos φ_i, sin α, −r sin α cos φ_i]. For equally spaced
rollers (Assumption) k_r = n/2 k cos² α and k_a = n k sin² α. The pitch radius r is not given by the
source and only affects the tilt row/column.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from components.params import ModelSpec, Param
from components.protocol import Component, ComponentState
from pkmstiff.errors import ArgumentError

if TYPE_CHECKING:
    from components.reader import Params


def roller_positions(n: int) -> np.ndarray:
    """Equally spaced roller angles φ_i = 2π(i−1)/n [rad] (Assumption, docs/theory/components.md)."""
    return 2.0 * np.pi * np.arange(n) / n


def dietl_stiffness_matrix(k_roller: Any, alpha: float, phi: Any, pitch_radius: float = 0.0) -> np.ndarray:
    """K_L = Σ k_i N_iᵀ N_i (3, 3) in (u_x, u_z, u_ϑ), Cobet eq. 3.31/3.32.

    ``k_roller`` [N/m] scalar or per roller; ``alpha`` contact angle [rad]; ``phi`` roller angles [rad];
    ``pitch_radius`` r [m]. Units: N/m (translation), N/rad (coupling), N·m/rad (tilt).
    """
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    k = np.broadcast_to(np.asarray(k_roller, dtype=float), phi.shape)
    N = np.stack([np.cos(alpha) * np.cos(phi), np.full_like(phi, np.sin(alpha)),
                  -pitch_radius * np.sin(alpha) * np.cos(phi)], axis=-1)
    return np.einsum("i,ia,ib->ab", k, N, N)


@dataclass(frozen=True, kw_only=True, eq=False)
class TaperedRollerBearing(Component):
    """Preloaded tapered roller bearing (Dietl): ``n_rollers``, ``k_roller`` [N/m], ``contact_angle`` [rad],
    ``pitch_radius`` [m], optional ``roller_angles`` [rad] (default equally spaced)."""

    kind: ClassVar[str] = "matrix3"
    n_rollers: int
    k_roller: float
    contact_angle: float
    pitch_radius: float = 0.0
    roller_angles: tuple[float, ...] | None = None
    _K: np.ndarray = field(init=False, repr=False, default=None)

    def __post_init__(self) -> None:
        if int(self.n_rollers) != self.n_rollers or self.n_rollers < 3:
            raise ArgumentError(f"bearing '{self.name}': n_rollers must be an integer >= 3, found "
                                     f"{self.n_rollers!r}")
        if not self.k_roller > 0:
            raise ArgumentError(f"bearing '{self.name}': k_roller must be positive, found {self.k_roller!r}")
        if not 0 < self.contact_angle < np.pi / 2:
            raise ArgumentError(f"bearing '{self.name}': contact_angle must lie in (0, 90) deg, found "
                                     f"{np.rad2deg(self.contact_angle)!r} deg")
        if not self.pitch_radius >= 0:
            raise ArgumentError(f"bearing '{self.name}': pitch_radius must be >= 0, found {self.pitch_radius!r}")
        if self.roller_angles is None:
            phi = roller_positions(int(self.n_rollers))
            if "roller_angles" not in self.assumptions:
                object.__setattr__(self, "assumptions", {**self.assumptions, "roller_angles":
                                   "equally spaced rollers (docs/theory/components.md Assumption)"})
        else:
            phi = np.asarray(self.roller_angles, dtype=float)
            if phi.shape != (int(self.n_rollers),):
                raise ArgumentError(f"bearing '{self.name}': roller_angles must have {self.n_rollers} entries, "
                                         f"found {phi.shape}")
        object.__setattr__(self, "_K", dietl_stiffness_matrix(self.k_roller, self.contact_angle, phi,
                                                               self.pitch_radius))

    @property
    def matrix(self) -> np.ndarray:
        """K_L (3, 3) in (u_x, u_z, u_ϑ)."""
        return self._K.copy()

    @property
    def k_radial(self) -> float:
        """Radial stiffness k_r = K_L[0, 0] [N/m]."""
        return float(self._K[0, 0])

    @property
    def k_axial(self) -> float:
        """Axial stiffness k_a = K_L[1, 1] [N/m]."""
        return float(self._K[1, 1])

    def stiffness(self, state: ComponentState) -> np.ndarray:
        return np.broadcast_to(self._K, (state.n, 3, 3)).copy()


def _tapered_roller_bearing(p: "Params") -> Component:
    n = p["n_rollers"]
    notes = {}
    if not p.has("pitch_radius"):
        notes["pitch_radius"] = "not given by the source (docs/theory/components.md); 0 m: tilt row/column is zero"
    angles = p.get("roller_angles", shape=(n,))
    return TaperedRollerBearing(name=p.name, n_rollers=n, k_roller=p["k_roller"], contact_angle=p["contact_angle"],
                                pitch_radius=p["pitch_radius"], roller_angles=None if angles is None else tuple(angles),
                                mass=p["mass"], assumptions=notes)


MODELS: tuple[ModelSpec, ...] = (ModelSpec(
    "tapered_roller_bearing", "tapered roller bearing, Dietl spring model", "Cobet eq. 3.31, 3.32",
    (Param("n_rollers", "-", None, "number of rollers", required=True, kind="integer", min_value=3),
     Param("k_roller", "N/m", None, "local roller stiffness", required=True, positive=True),
     Param("contact_angle", "rad", None, "contact angle alpha", required=True, positive=True),
     Param("pitch_radius", "m", 0.0, "pitch radius r (tilt DOF)", min_value=0.0, default_text="0 (not given)"),
     Param("roller_angles", "rad", None, "roller positions phi_i (n_rollers values)", shape=(None,),
           default_text="equally spaced"),
     Param("mass", "kg", 0.0, "bearing mass", min_value=0.0)),
    _tapered_roller_bearing),)


@dataclass(frozen=True)
class RigDeformation:
    """Results of Cobet eq. 3.33–3.36 (angles in rad, lengths in m)."""

    phi: np.ndarray
    theta: np.ndarray
    dl_rot: np.ndarray
    dl_trans: np.ndarray
    dl: np.ndarray


def evaluate_test_rig(
    dh1: Any, dh2: Any, dh3: Any, dt: Any,
    *, b_h1: float, b_h2: float, l_h1: float, l_h3: float, r: float, alpha: float,
) -> RigDeformation:
    """Axial deformation of the joint reference point B caused by the fixture, Cobet eq. 3.33–3.36.

    Probe readings ``dh1..dh3`` (orthogonal) and ``dt`` (tangential) [m], probe distances ``b_h1, b_h2,
    l_h1, l_h3`` [m], distance ``r`` of B from the plate [m], joint angle ``alpha`` of the measurement [rad].
    """
    dh1, dh2, dh3, dt = (np.asarray(v, dtype=float) for v in (dh1, dh2, dh3, dt))
    phi = np.arctan((dh1 - dh2) / (b_h1 + b_h2))
    theta = np.arctan((dh1 - dh3) / (l_h1 + l_h3))
    dl_rot = r * (np.cos(alpha - phi) - np.cos(alpha)) + np.cos(alpha) * (r - r * np.cos(theta))
    dl_trans = (np.cos(alpha) * (dh1 + l_h1 / (l_h1 + l_h3) * (dh3 - dh1) + b_h1 / (b_h1 + b_h2) * (dh2 - dh1))
                - np.sin(alpha) * dt)
    return RigDeformation(phi=phi, theta=theta, dl_rot=dl_rot, dl_trans=dl_trans, dl=dl_rot + dl_trans)

