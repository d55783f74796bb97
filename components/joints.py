"""Joint stiffness models (docs/theory/components.md).

A joint stiffness is a scalar axial (tension/compression) stiffness along the strut in N/m that depends
on the joint angles of docs/theory/kinematics.md, handed over in ``state.tilt`` / ``state.swivel`` (rad) in the joint's
own convention (``angle_convention`` = ``"axis"`` | ``"normal"`` | ``None`` for models valid in either).

Models: :class:`ConstantJoint`, :class:`AnalyticJoint330` (Cobet eq. 3.30), :class:`TiltTableJoint`
(clamped cubic spline over tilt, Cobet 3.2.5), :class:`SwivelTiltTableJoint` (bicubic on a (swivel, tilt)
grid) and :class:`ProductJoint` (k_ref · g_φ(φ) · g_θ(θ)); the latter two are the spec's Assumption for
swivel- and tilt-dependent joints.

NaN policy: a NaN tilt gives a NaN stiffness for that pose only (the other poses are unaffected). A NaN
(undefined) swivel gives NaN for swivel-dependent models unless ``undefined_swivel`` names a swivel
angle to use instead. Extrapolation outside a table: ``"clamp"`` (default, spec Assumption) or ``"error"``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from components.joint_tables import (  # re-exported: the documented entry points are components.joints.*
    JointTable,
    bundled_tables,
    load_joint_table,
    write_joint_table,
)
from components.protocol import Component, ComponentState, _full
from components.spline import EXTRAPOLATION_POLICIES, apply_range_policy, clamped_spline, spline_weights

__all__ = [
    "JointModel", "ConstantJoint", "AnalyticJoint330", "TiltTableJoint", "SwivelTiltTableJoint", "ProductJoint",
    "analytic_3_30", "joint_from_table", "load_joint_table", "write_joint_table", "bundled_tables", "JointTable",
]

_CLAMP_NOTE = "outside the tabulated angle range the end value is used (docs/theory/components.md Assumption)"


@dataclass(frozen=True, kw_only=True, eq=False)
class JointModel(Component):
    """Common part of all joint models: tilt convention and angle limits (rad, keys tilt_min/... in limits)."""

    kind: ClassVar[str] = "axial"
    angle_convention: str | None = None

    def __post_init__(self) -> None:
        if self.angle_convention not in (None, "axis", "normal"):
            raise ValueError(f"joint '{self.name}': angle_convention must be 'axis', 'normal' or None, "
                             f"found {self.angle_convention!r}")

    def within_limits(self, state: ComponentState) -> np.ndarray:
        """``(N,)`` bool: angles inside the limits of Cobet eq. B.5 (an undefined swivel skips swivel checks)."""
        ok = np.ones(state.n, dtype=bool)
        if state.tilt is not None:
            tilt = state.tilt
            ok &= ~(tilt < self.limits.get("tilt_min", -np.inf)) & ~(tilt > self.limits.get("tilt_max", np.inf))
        if state.swivel is not None:
            sw = state.swivel
            ok &= ~(sw < self.limits.get("swivel_min", -np.inf)) & ~(sw > self.limits.get("swivel_max", np.inf))
        return ok

    def _add_assumption(self, key: str, text: str) -> None:
        if key not in self.assumptions:
            object.__setattr__(self, "assumptions", {**self.assumptions, key: text})


@dataclass(frozen=True, kw_only=True, eq=False)
class ConstantJoint(JointModel):
    """Angle-independent joint stiffness ``k`` [N/m] (``np.inf`` = rigid)."""

    k: float

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.k > 0:
            raise ValueError(f"joint '{self.name}': k must be positive, found {self.k!r}")

    def stiffness(self, state: ComponentState) -> np.ndarray:
        return _full(state, self.k)


def analytic_3_30(tilt: Any, k_AaL: float, k_BrL: float, k_CrL: float, k_CaL: float) -> np.ndarray:
    """Analytic substitute model of a Cardan joint, Cobet eq. 3.30 (docs/theory/components.md).

    k_G(θ) = 2 k_AaL k_BrL / (2 k_BrL + k_AaL (2 + k_BrL sqrt((cos θ / k_CrL)² + (4 sin θ / k_CaL)²))).
    Homogeneous in the stiffness unit (SI in, SI out); ``tilt`` in rad.
    """
    t = np.asarray(tilt, dtype=float)
    root = np.sqrt((np.cos(t) / k_CrL) ** 2 + (4.0 * np.sin(t) / k_CaL) ** 2)
    return 2.0 * k_AaL * k_BrL / (2.0 * k_BrL + k_AaL * (2.0 + k_BrL * root))


@dataclass(frozen=True, kw_only=True, eq=False)
class AnalyticJoint330(JointModel):
    """Joint stiffness from bearing stiffnesses after Cobet eq. 3.30 (all in N/m); needs ``state.tilt``."""

    k_AaL: float
    k_BrL: float
    k_CrL: float
    k_CaL: float

    def __post_init__(self) -> None:
        super().__post_init__()
        for key in ("k_AaL", "k_BrL", "k_CrL", "k_CaL"):
            if not getattr(self, key) > 0:
                raise ValueError(f"joint '{self.name}': {key} must be positive, found {getattr(self, key)!r}")

    def stiffness(self, state: ComponentState) -> np.ndarray:
        tilt = state.require("tilt", self.name)
        return analytic_3_30(tilt, self.k_AaL, self.k_BrL, self.k_CrL, self.k_CaL)


def _check_policy(name: str, policy: str) -> None:
    if policy not in EXTRAPOLATION_POLICIES:
        raise ValueError(f"joint '{name}': extrapolation must be one of {EXTRAPOLATION_POLICIES}, found {policy!r}")


def _positive_finite(name: str, what: str, values: np.ndarray) -> None:
    if not np.all(np.isfinite(values)) or np.any(values <= 0):
        raise ValueError(f"joint '{name}': {what} must be positive and finite, found {np.asarray(values).tolist()}")


@dataclass(frozen=True, kw_only=True, eq=False)
class TiltTableJoint(JointModel):
    """Tabulated stiffness over tilt (rad, ascending) with the clamped end-slope spline (Cobet 3.2.5)."""

    tilt_nodes: np.ndarray
    k_nodes: np.ndarray
    extrapolation: str = "clamp"
    table_name: str = ""
    _spline: Any = field(init=False, repr=False, default=None)

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_policy(self.name, self.extrapolation)
        tilt = np.asarray(self.tilt_nodes, dtype=float)
        k = np.asarray(self.k_nodes, dtype=float)
        _positive_finite(self.name, "tabulated stiffness", k)
        object.__setattr__(self, "tilt_nodes", tilt)
        object.__setattr__(self, "k_nodes", k)
        object.__setattr__(self, "_spline", clamped_spline(tilt, k, what=f"joint '{self.name}' tilt table"))
        if self.extrapolation == "clamp":
            self._add_assumption("extrapolation", _CLAMP_NOTE)

    def stiffness(self, state: ComponentState) -> np.ndarray:
        tilt = apply_range_policy(state.require("tilt", self.name), self.tilt_nodes[0], self.tilt_nodes[-1],
                                  self.extrapolation, angle="tilt", table=f"joint '{self.name}' ({self.table_name})")
        return self._spline(tilt)

    def derivative(self, state: ComponentState) -> np.ndarray:
        """dk/dθ [N/m per rad] of the spline (zero where clamped)."""
        tilt = state.require("tilt", self.name)
        inside = (tilt >= self.tilt_nodes[0]) & (tilt <= self.tilt_nodes[-1])
        d = self._spline(np.clip(tilt, self.tilt_nodes[0], self.tilt_nodes[-1]), 1)
        return np.where(inside | np.isnan(tilt), d, 0.0)


def _swivel_values(state: ComponentState, name: str, undefined_swivel: str | float) -> np.ndarray:
    swivel = state.require("swivel", name)
    if undefined_swivel == "nan":
        return swivel
    return np.where(np.isnan(swivel), float(undefined_swivel), swivel)


def _check_undefined(name: str, undefined_swivel: Any) -> None:
    if undefined_swivel != "nan" and not isinstance(undefined_swivel, (int, float)):
        raise ValueError(f"joint '{name}': undefined_swivel must be 'nan' or a swivel angle in rad, "
                         f"found {undefined_swivel!r}")


@dataclass(frozen=True, kw_only=True, eq=False)
class SwivelTiltTableJoint(JointModel):
    """Stiffness on a (swivel, tilt) grid, tensor-product (bicubic) end-slope spline per axis (Assumption).

    ``k_grid`` has shape (len(swivel_nodes), len(tilt_nodes)) in N/m; nodes in rad, ascending.
    """

    swivel_nodes: np.ndarray
    tilt_nodes: np.ndarray
    k_grid: np.ndarray
    extrapolation: str = "clamp"
    undefined_swivel: str | float = "nan"
    table_name: str = ""

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_policy(self.name, self.extrapolation)
        _check_undefined(self.name, self.undefined_swivel)
        sw = np.asarray(self.swivel_nodes, dtype=float)
        ti = np.asarray(self.tilt_nodes, dtype=float)
        k = np.asarray(self.k_grid, dtype=float)
        if k.shape != (sw.size, ti.size):
            raise ValueError(f"joint '{self.name}': k_grid must have shape ({sw.size}, {ti.size}) = (swivel, tilt), "
                             f"found {k.shape}")
        _positive_finite(self.name, "tabulated stiffness", k)
        clamped_spline(sw, k, what=f"joint '{self.name}' swivel axis")  # validates the nodes
        clamped_spline(ti, k.T, what=f"joint '{self.name}' tilt axis")
        for key, value in (("swivel_nodes", sw), ("tilt_nodes", ti), ("k_grid", k)):
            object.__setattr__(self, key, value)
        self._add_assumption("interpolation", "bicubic tensor-product spline with the end-slope rule per axis "
                                              "(docs/theory/components.md Assumption)")
        if self.extrapolation == "clamp":
            self._add_assumption("extrapolation", _CLAMP_NOTE)

    def stiffness(self, state: ComponentState) -> np.ndarray:
        table = f"joint '{self.name}' ({self.table_name})"
        sw = apply_range_policy(_swivel_values(state, self.name, self.undefined_swivel), self.swivel_nodes[0],
                                self.swivel_nodes[-1], self.extrapolation, angle="swivel", table=table)
        ti = apply_range_policy(state.require("tilt", self.name), self.tilt_nodes[0], self.tilt_nodes[-1],
                                self.extrapolation, angle="tilt", table=table)
        w_sw = spline_weights(self.swivel_nodes, sw)
        w_ti = spline_weights(self.tilt_nodes, ti)
        return np.sum((w_sw @ self.k_grid) * w_ti, axis=1)  # k(φ_n, θ_n) = Σ_st w_s(φ_n) K_st w_t(θ_n)


@dataclass(frozen=True, kw_only=True, eq=False)
class ProductJoint(JointModel):
    """k(φ, θ) = k_ref · g_φ(φ) · g_θ(θ) from two 1-D curves normalised to their maxima (docs/theory/components.md).

    The curves may be given in any unit (stiffness or already normalised); each is divided by its largest
    support value. ``k_ref`` [N/m] is the stiffness at the common maximum.
    """

    k_ref: float
    swivel_nodes: np.ndarray
    g_swivel: np.ndarray
    tilt_nodes: np.ndarray
    g_tilt: np.ndarray
    extrapolation: str = "clamp"
    undefined_swivel: str | float = "nan"
    _splines: Any = field(init=False, repr=False, default=None)

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_policy(self.name, self.extrapolation)
        _check_undefined(self.name, self.undefined_swivel)
        if not self.k_ref > 0:
            raise ValueError(f"joint '{self.name}': k_ref must be positive, found {self.k_ref!r}")
        curves = []
        for nodes, values, axis in ((self.swivel_nodes, self.g_swivel, "swivel"), (self.tilt_nodes, self.g_tilt, "tilt")):
            x = np.asarray(nodes, dtype=float)
            g = np.asarray(values, dtype=float)
            _positive_finite(self.name, f"{axis} curve", g)
            curves.append((x, g / g.max()))
        (sw, gs), (ti, gt) = curves
        for key, value in (("swivel_nodes", sw), ("g_swivel", gs), ("tilt_nodes", ti), ("g_tilt", gt)):
            object.__setattr__(self, key, value)
        object.__setattr__(self, "_splines", (clamped_spline(sw, gs, what=f"joint '{self.name}' swivel curve"),
                                              clamped_spline(ti, gt, what=f"joint '{self.name}' tilt curve")))
        self._add_assumption("interpolation", "k = k_ref g_swivel(swivel) g_tilt(tilt), curves normalised to "
                                              "their maxima (docs/theory/components.md Assumption)")
        if self.extrapolation == "clamp":
            self._add_assumption("extrapolation", _CLAMP_NOTE)

    def stiffness(self, state: ComponentState) -> np.ndarray:
        table = f"joint '{self.name}'"
        sw = apply_range_policy(_swivel_values(state, self.name, self.undefined_swivel), self.swivel_nodes[0],
                                self.swivel_nodes[-1], self.extrapolation, angle="swivel", table=table)
        ti = apply_range_policy(state.require("tilt", self.name), self.tilt_nodes[0], self.tilt_nodes[-1],
                                self.extrapolation, angle="tilt", table=table)
        s_sw, s_ti = self._splines
        return self.k_ref * s_sw(sw) * s_ti(ti)


def joint_from_table(table: JointTable, **kwargs: Any) -> TiltTableJoint | SwivelTiltTableJoint:
    """Joint component from a loaded table; ``kwargs`` go to the component (name, extrapolation, limits, ...)."""
    kwargs.setdefault("name", table.name)
    kwargs.setdefault("angle_convention", table.angle_convention)
    kwargs.setdefault("provenance", table.provenance)
    if table.angle_convention != kwargs["angle_convention"]:
        raise ValueError(f"joint '{kwargs['name']}': table {table.path} is tabulated in the "
                         f"'{table.angle_convention}' convention, not '{kwargs['angle_convention']}'")
    if table.swivel is None:
        kwargs.pop("undefined_swivel", None)
        return TiltTableJoint(tilt_nodes=table.tilt, k_nodes=table.stiffness, table_name=table.path, **kwargs)
    return SwivelTiltTableJoint(swivel_nodes=table.swivel, tilt_nodes=table.tilt, k_grid=table.stiffness,
                                table_name=table.path, **kwargs)
