"""Struts (docs/theory/components.md; Cobet eq. 3.7, 3.8).

Constant cross-section: k_St = EA / l (eq. 3.7). Sections in series: 1/k_St = Σ l_j / (E_j A_j) (eq. 3.8).
Mass = density × volume, or mass per length × length, or given directly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from components.protocol import Component, ComponentState, _full


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
            raise ValueError(f"strut '{self.name}': give either k or axial_rigidity (EA), not both or neither")
        for key in ("k", "axial_rigidity", "length"):
            value = getattr(self, key)
            if value is not None and not value > 0:
                raise ValueError(f"strut '{self.name}': {key} must be positive, found {value!r}")

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
            raise ValueError(f"strut '{self.name}': E, area and length must be 1-D arrays of equal length, found "
                             f"shapes {[a.shape for a in arrays]}")
        for key, a in zip(("E", "area", "length"), arrays):
            if np.any(~(a > 0)):
                raise ValueError(f"strut '{self.name}': {key} must be positive, found {a.tolist()}")
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
