"""Struts (docs/theory/components.md; Cobet eq. 3.7, 3.8).

Constant cross-section: k_St = EA / l (eq. 3.7). Sections in series: 1/k_St = Σ l_j / (E_j A_j) (eq. 3.8).
Mass = density × volume, or mass per length × length, or given directly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from components.params import ModelSpec, Param
from components.protocol import Component, ComponentState, _full
from pkmstiff.errors import ArgumentError

if TYPE_CHECKING:
    from components.reader import Params


def strut_stiffness(E: float, area: float, length: float | np.ndarray) -> np.ndarray:
    """k_St = E A / l [N/m], Cobet eq. 3.7."""
    return E * area / np.asarray(length, dtype=float)


def sections_stiffness(E: np.ndarray, area: np.ndarray, length: np.ndarray) -> float:
    """1/k_St = Σ l_j / (E_j A_j) [N/m], Cobet eq. 3.8 (arrays over the sections)."""
    l, e, a = (np.asarray(v, dtype=float) for v in (length, E, area))
    return 1.0 / float(np.sum(l / (e * a)))


@dataclass(frozen=True, kw_only=True, eq=False)
class Strut(Component):
    """Axial strut stiffness: ``k`` [N/m] constant, or ``axial_rigidity`` EA [N] over ``length`` [m].

    Without ``length`` the length comes from ``state.strut_length`` (variable-length strut). ``mass`` [kg].
    """

    kind: ClassVar[str] = "axial"
    k: float | None = None
    axial_rigidity: float | None = None
    length: float | None = None

    def __post_init__(self) -> None:
        if (self.k is None) == (self.axial_rigidity is None):
            raise ArgumentError(f"strut '{self.name}': give either k or axial_rigidity (EA), not both or neither")
        for key in ("k", "axial_rigidity", "length"):
            value = getattr(self, key)
            if value is not None and not value > 0:
                raise ArgumentError(f"strut '{self.name}': {key} must be positive, found {value!r}")

    def stiffness(self, state: ComponentState) -> np.ndarray:
        if self.k is not None:
            return _full(state, self.k)
        if self.length is not None:
            return _full(state, self.axial_rigidity / self.length)
        return self.axial_rigidity / state.require("strut_length", self.name)


@dataclass(frozen=True, kw_only=True, eq=False)
class StrutSections(Component):
    """Strut of ``n`` sections in series (Cobet eq. 3.8): arrays ``E`` [Pa], ``area`` [m²], ``length`` [m]."""

    kind: ClassVar[str] = "axial"
    E: tuple[float, ...]
    area: tuple[float, ...]
    length: tuple[float, ...]

    def __post_init__(self) -> None:
        arrays = [np.atleast_1d(np.asarray(getattr(self, key), dtype=float)) for key in ("E", "area", "length")]
        if len({a.shape for a in arrays}) != 1 or arrays[0].ndim != 1:
            raise ArgumentError(f"strut '{self.name}': E, area and length must be 1-D arrays of equal length, "
                                     f"found shapes {[a.shape for a in arrays]}")
        for key, a in zip(("E", "area", "length"), arrays):
            if np.any(~(a > 0)):
                raise ArgumentError(f"strut '{self.name}': {key} must be positive, found {a.tolist()}")
            object.__setattr__(self, key, tuple(a.tolist()))

    @property
    def k(self) -> float:
        """Constant strut stiffness [N/m]."""
        return sections_stiffness(np.array(self.E), np.array(self.area), np.array(self.length))

    @property
    def total_length(self) -> float:
        return float(np.sum(self.length))

    def stiffness(self, state: ComponentState) -> np.ndarray:
        return _full(state, self.k)


# --------------------------------------------------------------------------------------------- machine files
def _strut(p: "Params") -> Component:
    which = p.exactly_one(("k",), ("EA",), ("E", "area"))
    length = p["length"]
    area = None
    if which == 0:  # the parameters of the chosen alternative are required
        k, ea = p.get("k", required=True), None
    elif which == 1:
        k, ea = None, p.get("EA", required=True)
    else:
        area = p.get("area", required=True)
        k, ea = None, p.get("E", required=True) * area
    mass_kind = [key for key in ("mass", "density", "mass_per_length") if p.has(key)]
    if len(mass_kind) > 1:
        raise p.error(mass_kind[1], "only one of mass, density, mass_per_length", mass_kind)
    mass = 0.0
    if mass_kind == ["mass"]:
        mass = p["mass"]
    elif mass_kind == ["density"]:
        rho = p["density"]
        if area is None or length is None:
            raise p.error("density", "density only together with area and length (mass = rho A l)", rho)
        mass = rho * area * length
    elif mass_kind == ["mass_per_length"]:
        mu = p["mass_per_length"]
        if length is None:
            raise p.error("mass_per_length", "mass_per_length only together with length (mass = mu l)", mu)
        mass = mu * length
    return Strut(name=p.name, k=k, axial_rigidity=ea, length=length, mass=mass)


def _strut_sections(p: "Params") -> Component:
    E = p["E"]
    area = p["area"]
    length = p["length"]
    if not (E.shape == area.shape == length.shape):
        raise p.error("area", f"as many entries as E ({E.size})", f"E {E.size}, area {area.size}, length {length.size}")
    if p.has("density") and p.has("mass"):
        raise p.error("density", "either mass or density", "both")
    mass = p["mass"]
    if p.has("density"):
        per_section = isinstance(p.raw("density"), (list, tuple, dict))
        rho = p.get("density", shape=(E.size,) if per_section else None)
        mass = float(np.sum(np.broadcast_to(rho, E.shape) * area * length))
    return StrutSections(name=p.name, E=tuple(E), area=tuple(area), length=tuple(length), mass=mass)


MODELS: tuple[ModelSpec, ...] = (
    ModelSpec("strut", "strut of constant cross-section (k given or EA/l)", "Cobet eq. 3.7",
              (Param("k", "N/m", None, "axial stiffness", required="unless EA or E + area", positive=True),
               Param("EA", "N", None, "axial rigidity (k = EA / l)", required="unless k or E + area", positive=True),
               Param("E", "Pa", None, "Young's modulus, with area", required="unless k or EA", positive=True),
               Param("area", "m^2", None, "cross-section, with E", required="unless k or EA", positive=True),
               Param("length", "m", None, "strut length", positive=True, default_text="state.strut_length"),
               Param("mass", "kg", 0.0, "strut mass (or density, or mass_per_length)", min_value=0.0),
               Param("density", "kg/m^3", None, "density, with area and length (mass = rho A l)", positive=True),
               Param("mass_per_length", "kg/m", None, "mass per length, with length (mass = mu l)", positive=True)),
              _strut),
    ModelSpec("strut_sections", "strut of sections in series", "Cobet eq. 3.8",
              (Param("E", "Pa", None, "Young's modulus per section", required=True, shape=(None,), positive=True),
               Param("area", "m^2", None, "cross-section per section", required=True, shape=(None,), positive=True),
               Param("length", "m", None, "length per section", required=True, shape=(None,), positive=True),
               Param("mass", "kg", 0.0, "strut mass (or density)", min_value=0.0),
               Param("density", "kg/m^3", None, "density, scalar or per section (instead of mass)", positive=True)),
              _strut_sections),
)
