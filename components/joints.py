"""Joint stiffness models (spec models.md §3.5, component-data.md §1–§5).

A joint stiffness is a scalar axial (tension/compression) stiffness along the strut in N/m that depends
on the joint angles of models.md §2, handed over in ``state.tilt`` / ``state.swivel`` (rad) in the joint's
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
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from pkmstiff.errors import ComponentDataError, InputError, JointTableNotFound

from components.joint_tables import (  # re-exported: the documented entry points are components.joints.*
    JointTable,
    bundled_tables,
    load_joint_table,
    write_joint_table,
)
from components.params import ModelSpec, Param
from components.protocol import Component, ComponentState, _full
from components.spline import EXTRAPOLATION_POLICIES, apply_range_policy, clamped_spline, spline_weights

if TYPE_CHECKING:
    from components.reader import Params

__all__ = [
    "JointModel", "ConstantJoint", "AnalyticJoint330", "TiltTableJoint", "SwivelTiltTableJoint", "ProductJoint",
    "analytic_3_30", "joint_from_table", "load_joint_table", "write_joint_table", "bundled_tables", "JointTable",
]

_CLAMP_NOTE = "outside the tabulated angle range the end value is used (models.md §3.5 (5) Assumption)"


@dataclass(frozen=True, kw_only=True, eq=False)
class JointModel(Component):
    """Common part of all joint models: tilt convention and angle limits (rad, keys tilt_min/... in limits)."""

    kind: ClassVar[str] = "axial"
    angle_convention: str | None = None

    def __post_init__(self) -> None:
        if self.angle_convention not in (None, "axis", "normal"):
            raise ComponentDataError(f"joint '{self.name}': angle_convention must be 'axis', 'normal' or None, "
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
            raise ComponentDataError(f"joint '{self.name}': k must be positive, found {self.k!r}")

    def stiffness(self, state: ComponentState) -> np.ndarray:
        return _full(state, self.k)


def analytic_3_30(tilt: Any, k_AaL: float, k_BrL: float, k_CrL: float, k_CaL: float) -> np.ndarray:
    """Analytic substitute model of a Cardan joint, Cobet eq. 3.30 (models.md §3.5 (1)).

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
                raise ComponentDataError(f"joint '{self.name}': {key} must be positive, found {getattr(self, key)!r}")

    def stiffness(self, state: ComponentState) -> np.ndarray:
        tilt = state.require("tilt", self.name)
        return analytic_3_30(tilt, self.k_AaL, self.k_BrL, self.k_CrL, self.k_CaL)


def _check_policy(name: str, policy: str) -> None:
    if policy not in EXTRAPOLATION_POLICIES:
        raise ComponentDataError(f"joint '{name}': extrapolation must be one of {EXTRAPOLATION_POLICIES}, found "
                                 f"{policy!r}")


def _positive_finite(name: str, what: str, values: np.ndarray) -> None:
    if not np.all(np.isfinite(values)) or np.any(values <= 0):
        raise ComponentDataError(f"joint '{name}': {what} must be positive and finite, found "
                                 f"{np.asarray(values).tolist()}")


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
        raise ComponentDataError(f"joint '{name}': undefined_swivel must be 'nan' or a swivel angle in rad, "
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
            raise ComponentDataError(f"joint '{self.name}': k_grid must have shape ({sw.size}, {ti.size}) = (swivel, "
                                     f"tilt), found {k.shape}")
        _positive_finite(self.name, "tabulated stiffness", k)
        clamped_spline(sw, k, what=f"joint '{self.name}' swivel axis")  # validates the nodes
        clamped_spline(ti, k.T, what=f"joint '{self.name}' tilt axis")
        for key, value in (("swivel_nodes", sw), ("tilt_nodes", ti), ("k_grid", k)):
            object.__setattr__(self, key, value)
        self._add_assumption("interpolation", "bicubic tensor-product spline with the end-slope rule per axis "
                                              "(models.md §3.5 (5) Assumption)")
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
    """k(φ, θ) = k_ref · g_φ(φ) · g_θ(θ) from two 1-D curves normalised to their maxima (models.md §3.5 (5)).

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
            raise ComponentDataError(f"joint '{self.name}': k_ref must be positive, found {self.k_ref!r}")
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
                                              "their maxima (models.md §3.5 (5) Assumption)")
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
        raise ComponentDataError(f"joint '{kwargs['name']}': table {table.path} is tabulated in the "
                                 f"'{table.angle_convention}' convention, not '{kwargs['angle_convention']}'")
    if table.swivel is None:
        kwargs.pop("undefined_swivel", None)
        return TiltTableJoint(tilt_nodes=table.tilt, k_nodes=table.stiffness, table_name=table.path, **kwargs)
    return SwivelTiltTableJoint(swivel_nodes=table.swivel, tilt_nodes=table.tilt, k_grid=table.stiffness,
                                table_name=table.path, **kwargs)


# --------------------------------------------------------------------------------------------- machine files
#: Parameters every joint model accepts: tilt convention of the data, angle limits (Cobet eq. B.5), mass.
JOINT_COMMON: tuple[Param, ...] = (
    Param("angle_convention", "-", None, "'axis' or 'normal': tilt convention the data refer to",
          kind="raw", default_text="none (any; tables: the file's)"),
    Param("tilt_min", "rad", None, "smallest admissible tilt (Cobet eq. B.5)"),
    Param("tilt_max", "rad", None, "largest admissible tilt (Cobet eq. B.5)"),
    Param("swivel_min", "rad", None, "smallest admissible swivel (Cobet eq. B.5)"),
    Param("swivel_max", "rad", None, "largest admissible swivel (Cobet eq. B.5)"),
    Param("mass", "kg", 0.0, "joint mass", min_value=0.0),
)
EXTRAPOLATION = Param("extrapolation", "-", "clamp", "outside the table: 'clamp' (end value) or 'error'",
                      choices=EXTRAPOLATION_POLICIES)
UNDEFINED_SWIVEL = Param("undefined_swivel", "rad", "nan", "swivel used where it is undefined ('nan': NaN stiffness)",
                         kind="raw")


def _joint_common(p: "Params") -> dict[str, Any]:
    limits = {}
    for key in ("tilt_min", "tilt_max", "swivel_min", "swivel_max"):
        value = p[key]
        if value is not None:
            limits[key] = value
    for lo, hi in (("tilt_min", "tilt_max"), ("swivel_min", "swivel_max")):
        if lo in limits and hi in limits and limits[lo] > limits[hi]:
            raise p.error(hi, f"a value >= {lo} ({np.rad2deg(limits[lo]):g} deg)", f"{np.rad2deg(limits[hi]):g} deg")
    conv = p["angle_convention"]
    if conv is not None and conv not in ("axis", "normal"):
        raise p.error("angle_convention", "'axis' or 'normal'", conv)
    return {"name": p.name, "limits": limits, "angle_convention": conv, "mass": p["mass"]}


def _undefined_swivel(p: "Params") -> str | float:
    value = p["undefined_swivel"]
    if value == "nan":
        return "nan"
    return p.get("undefined_swivel", kind="quantity")


def _load_table(p: "Params", swivel: bool) -> Component:
    common = _joint_common(p)
    policy = p["extrapolation"]
    extra = {"undefined_swivel": _undefined_swivel(p)} if swivel else {}
    if p.exactly_one(("table",), ("tilt", "stiffness")) == 0:
        ref = p["table"]
        try:
            table = load_joint_table(ref, base_dir=p.base_dir)
        except JointTableNotFound as exc:
            raise p.error("table", exc.expected, f"{ref!r} ({exc.found})") from exc
        except InputError as exc:  # content error: keep file/line/column, add who referenced the table
            where = f"{exc.source} (table of {p.key('table')} in {p.source or 'input'})"
            raise InputError(where, exc.key, exc.expected, exc.found) from exc
        if (table.swivel is not None) != swivel:
            want = ("a swivel-tilt table (swivel_deg,tilt_deg,k_N_per_um)" if swivel
                    else "a tilt table (tilt_deg,k_N_per_um)")
            raise p.error("table", want, f"{table.path} has the other format")
        if common["angle_convention"] is None:
            common["angle_convention"] = table.angle_convention
        elif common["angle_convention"] != table.angle_convention:
            raise p.error("angle_convention", f"the table's convention '{table.angle_convention}' ({table.path})",
                          common["angle_convention"])
        return joint_from_table(table, extrapolation=policy, **common, **extra)
    tilt = p.get("tilt", required=True)
    if swivel:
        sw = p.get("swivel", required=True)
        k = p.get("stiffness", required=True, shape=(sw.size, tilt.size))
        return SwivelTiltTableJoint(swivel_nodes=sw, tilt_nodes=tilt, k_grid=k, extrapolation=policy,
                                    table_name="inline", **common, **extra)
    k = p.get("stiffness", required=True, shape=(tilt.size,))
    return TiltTableJoint(tilt_nodes=tilt, k_nodes=k, extrapolation=policy, table_name="inline", **common)


def _joint_product(p: "Params") -> Component:
    common = _joint_common(p)
    sw = p["swivel"]
    ti = p["tilt"]
    return ProductJoint(k_ref=p["k_ref"], swivel_nodes=sw, g_swivel=p.get("g_swivel", shape=(sw.size,)),
                        tilt_nodes=ti, g_tilt=p.get("g_tilt", shape=(ti.size,)), extrapolation=p["extrapolation"],
                        undefined_swivel=_undefined_swivel(p), **common)


_TABLE = Param("table", "-", None, "bundled table name or CSV path (relative to the machine file)",
               kind="string", required="unless inline data")
_INLINE_TILT = Param("tilt", "rad", None, "inline tilt nodes, ascending", required="unless table", shape=(None,))
MODELS: tuple[ModelSpec, ...] = (
    ModelSpec("joint_constant", "angle-independent joint stiffness", "k = const",
              (Param("k", "N/m", None, "joint stiffness", required=True, positive=True, rigid_ok=True),)
              + JOINT_COMMON,
              lambda p: ConstantJoint(k=p["k"], **_joint_common(p))),
    ModelSpec("joint_analytic_3_30", "analytic substitute Cardan-joint model over tilt", "Cobet eq. 3.30",
              tuple(Param(k, "N/m", None, m, required=True, positive=True) for k, m in (
                  ("k_AaL", "bearing A axial stiffness"), ("k_BrL", "bearing B radial stiffness"),
                  ("k_CrL", "bearing C radial stiffness"), ("k_CaL", "bearing C axial stiffness"))) + JOINT_COMMON,
              lambda p: AnalyticJoint330(**{k: p[k] for k in ("k_AaL", "k_BrL", "k_CrL", "k_CaL")},
                                         **_joint_common(p))),
    ModelSpec("joint_table", "tabulated joint stiffness over tilt, clamped end-slope cubic spline", "Cobet 3.2.5",
              (_TABLE, _INLINE_TILT,
               Param("stiffness", "N/m", None, "inline stiffness at the tilt nodes", required="unless table",
                     shape=(None,), positive=True),
               EXTRAPOLATION) + JOINT_COMMON,
              lambda p: _load_table(p, swivel=False), tables="tilt"),
    ModelSpec("joint_table_swivel_tilt",
              "tabulated joint stiffness on a (swivel, tilt) grid, bicubic end-slope spline",
              "models.md §3.5 (5) Assumption",
              (_TABLE,
               Param("swivel", "rad", None, "inline swivel nodes, ascending", required="unless table", shape=(None,)),
               _INLINE_TILT,
               Param("stiffness", "N/m", None, "inline grid stiffness[swivel][tilt]", required="unless table",
                     shape=(None, None), positive=True),
               UNDEFINED_SWIVEL, EXTRAPOLATION) + JOINT_COMMON,
              lambda p: _load_table(p, swivel=True), tables="swivel_tilt"),
    ModelSpec("joint_product_swivel_tilt", "k_ref g_swivel(swivel) g_tilt(tilt) from two normalised 1-D curves",
              "models.md §3.5 (5) Assumption",
              (Param("k_ref", "N/m", None, "stiffness at the maxima of both curves", required=True, positive=True),
               Param("swivel", "rad", None, "swivel nodes of g_swivel, ascending", required=True, shape=(None,)),
               Param("g_swivel", "-", None, "swivel curve (normalised to its maximum)", required=True,
                     shape=(None,), positive=True),
               Param("tilt", "rad", None, "tilt nodes of g_tilt, ascending", required=True, shape=(None,)),
               Param("g_tilt", "-", None, "tilt curve (normalised to its maximum)", required=True, shape=(None,),
                     positive=True),
               UNDEFINED_SWIVEL, EXTRAPOLATION) + JOINT_COMMON,
              _joint_product),
)
