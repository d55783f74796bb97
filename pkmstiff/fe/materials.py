"""Linear-elastic material laws for the FE component models (SI: Pa, kg/m^3).

* :class:`Isotropic` — steel, aluminium, cast iron (E, nu).
* :class:`CubicCylindrical` — the substitute material of the bearing rings (docs/theory/components.md): E = 7.7 GPa, G = 3.2 GPa, nu = 0.1.

Note (docs/theory/components.md): for an isotropic material G = E/(2(1+nu)) = 3.5 GPa, so the printed
E, G, nu cannot all hold for an isotropic law. We honour all three with the smallest anisotropic law that
has three independent constants: *cubic symmetry whose axes are the local cylindrical axes (radial,
circumferential, axial) of the ring*. In those axes the compliance is S11 = 1/E, S12 = -nu/E,
S44 = 1/G, i.e. the radial/axial Young's moduli are E, the r-z (axial load) and r-phi shear moduli are G
and the Poisson ratios are nu — the quantities that govern the ring's radial and axial stiffness.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pkmstiff.errors import ArgumentError


@dataclass(frozen=True)
class Isotropic:
    """Isotropic linear-elastic material: Young's modulus ``E`` [Pa], Poisson ratio ``nu``, density [kg/m^3]."""

    name: str
    E: float
    nu: float
    density: float = 0.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.E) and self.E > 0):
            raise ArgumentError(f"material '{self.name}': E must be a positive modulus in Pa, found {self.E!r}")
        if not -1.0 < self.nu < 0.5:
            raise ArgumentError(f"material '{self.name}': nu must lie in (-1, 0.5), found {self.nu!r}")

    @property
    def G(self) -> float:
        """Shear modulus E/(2(1+nu)) [Pa]."""
        return self.E / (2.0 * (1.0 + self.nu))

    def lame(self) -> tuple[float, float]:
        """Lamé constants (lambda, mu) [Pa]."""
        lam = self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))
        return lam, self.G


@dataclass(frozen=True)
class CubicCylindrical:
    """Cubic-symmetric law in the cylindrical axes (r, phi, axial) of a ring about ``axis_dir`` through ``axis_point``.

    ``E`` [Pa] Young's modulus along r, phi and the axis; ``G`` [Pa] shear modulus in the r-phi, r-axial and
    phi-axial planes; ``nu`` Poisson ratio. The axis is given in the frame in which the part is meshed.
    """

    name: str
    E: float
    G: float
    nu: float
    axis_point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis_dir: tuple[float, float, float] = (0.0, 0.0, 1.0)
    density: float = 0.0

    def __post_init__(self) -> None:
        for key in ("E", "G"):
            v = getattr(self, key)
            if not (np.isfinite(v) and v > 0):
                raise ArgumentError(f"material '{self.name}': {key} must be a positive modulus in Pa, found {v!r}")
        if not -1.0 < self.nu < 0.5:
            raise ArgumentError(f"material '{self.name}': nu must lie in (-1, 0.5), found {self.nu!r}")
        n = np.linalg.norm(self.axis_dir)
        if not n > 0:
            raise ArgumentError(f"material '{self.name}': axis_dir must be a non-zero vector, found {self.axis_dir}")

    def cubic_constants(self) -> tuple[float, float, float]:
        """Stiffness constants (C11, C12, C44) [Pa] of the cubic law (inverse of S11, S12, S44)."""
        s11, s12, s44 = 1.0 / self.E, -self.nu / self.E, 1.0 / self.G
        det = (s11 - s12) * (s11 + 2.0 * s12)
        return (s11 + s12) / det, -s12 / det, 1.0 / s44

    def decomposition(self) -> tuple[float, float, float]:
        """(lambda, mu, delta) with C = lambda I(x)I + 2 mu I_sym + delta sum_a e_a(x)e_a(x)e_a(x)e_a [Pa]."""
        c11, c12, c44 = self.cubic_constants()
        return c12, c44, c11 - c12 - 2.0 * c44

    def with_axis(self, point: np.ndarray | tuple, direction: np.ndarray | tuple) -> "CubicCylindrical":
        """Copy with another ring axis."""
        return CubicCylindrical(self.name, self.E, self.G, self.nu, tuple(map(float, point)),
                                tuple(map(float, direction)), self.density)

    def local_axes(self, x: np.ndarray) -> np.ndarray:
        """Unit vectors (e_r, e_phi, e_axial) at points ``x`` (3, ...): array (3 axes, 3 comps, ...)."""
        ez = np.asarray(self.axis_dir, float) / np.linalg.norm(self.axis_dir)
        ez_b = ez.reshape((3,) + (1,) * (x.ndim - 1))
        d = x - np.asarray(self.axis_point, float).reshape((3,) + (1,) * (x.ndim - 1))
        radial = d - np.sum(d * ez_b, axis=0) * ez_b
        norm = np.linalg.norm(radial, axis=0)
        if np.any(norm <= 0):
            raise ArgumentError(f"material '{self.name}': points on the ring axis have no radial direction")
        er = radial / norm
        ephi = np.cross(ez_b, er, axis=0)
        return np.stack([er, ephi, np.broadcast_to(ez_b, er.shape)])


Material = Isotropic | CubicCylindrical


def voigt_isotropic(E: float, nu: float) -> np.ndarray:
    """6x6 Voigt stiffness (engineering shear strains) of an isotropic material [Pa]."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    D = np.full((3, 3), lam) + 2 * mu * np.eye(3)
    out = np.zeros((6, 6))
    out[:3, :3] = D
    out[3:, 3:] = mu * np.eye(3)
    return out
