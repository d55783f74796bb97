"""Tabulated joint stiffness: over tilt (clamped end-slope spline, Cobet 3.2.5) and on a (swivel, tilt) grid
(bicubic, docs/theory/components.md Assumption); bundled or own CSV tables, or inline data in the machine file."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from components.joint_tables import JointTable, load_joint_table
from components.joints import base
from components.params import ModelSpec, Param
from components.protocol import Component, ComponentState
from components.spline import apply_range_policy, clamped_cubic, clamped_spline, spline_weights
from pkmstiff.errors import ArgumentError, InputError, JointTableNotFound

if TYPE_CHECKING:
    from components.reader import Params


@dataclass(frozen=True, kw_only=True, eq=False)
class TiltTableJoint(base.JointModel):
    """Tabulated stiffness over tilt (rad, ascending) with the clamped end-slope spline (Cobet 3.2.5)."""

    tilt_nodes: np.ndarray
    k_nodes: np.ndarray
    extrapolation: str = "clamp"
    table_name: str = ""
    _spline: Any = field(init=False, repr=False, default=None)

    def __post_init__(self) -> None:
        super().__post_init__()
        base.check_policy(self.name, self.extrapolation)
        tilt = np.asarray(self.tilt_nodes, dtype=float)
        k = np.asarray(self.k_nodes, dtype=float)
        base.positive_finite(self.name, "tabulated stiffness", k)
        object.__setattr__(self, "tilt_nodes", tilt)
        object.__setattr__(self, "k_nodes", k)
        object.__setattr__(self, "_spline", clamped_cubic(tilt, k, what=f"joint '{self.name}' tilt table"))
        if self.extrapolation == "clamp":
            self._add_assumption("extrapolation", base.CLAMP_NOTE)

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


@dataclass(frozen=True, kw_only=True, eq=False)
class SwivelTiltTableJoint(base.JointModel):
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
        base.check_policy(self.name, self.extrapolation)
        base.check_undefined(self.name, self.undefined_swivel)
        sw = np.asarray(self.swivel_nodes, dtype=float)
        ti = np.asarray(self.tilt_nodes, dtype=float)
        k = np.asarray(self.k_grid, dtype=float)
        if k.shape != (sw.size, ti.size):
            raise ArgumentError(f"joint '{self.name}': k_grid must have shape ({sw.size}, {ti.size}) = (swivel, "
                                     f"tilt), found {k.shape}")
        base.positive_finite(self.name, "tabulated stiffness", k)
        clamped_spline(sw, k, what=f"joint '{self.name}' swivel axis")  # validates the nodes
        clamped_spline(ti, k.T, what=f"joint '{self.name}' tilt axis")
        for key, value in (("swivel_nodes", sw), ("tilt_nodes", ti), ("k_grid", k)):
            object.__setattr__(self, key, value)
        self._add_assumption("interpolation", "bicubic tensor-product spline with the end-slope rule per axis "
                                              "(docs/theory/components.md Assumption)")
        if self.extrapolation == "clamp":
            self._add_assumption("extrapolation", base.CLAMP_NOTE)

    def stiffness(self, state: ComponentState) -> np.ndarray:
        table = f"joint '{self.name}' ({self.table_name})"
        sw, ti = base.swivel_tilt_in_range(self, state, table)
        w_sw = spline_weights(self.swivel_nodes, sw)
        w_ti = spline_weights(self.tilt_nodes, ti)
        return np.sum((w_sw @ self.k_grid) * w_ti, axis=1)  # k(φ_n, θ_n) = Σ_st w_s(φ_n) K_st w_t(θ_n)


def joint_from_table(table: JointTable, **kwargs: Any) -> TiltTableJoint | SwivelTiltTableJoint:
    """Joint component from a loaded table; ``kwargs`` go to the component (name, extrapolation, limits, ...)."""
    kwargs.setdefault("name", table.name)
    kwargs.setdefault("angle_convention", table.angle_convention)
    kwargs.setdefault("provenance", table.provenance)
    if table.angle_convention != kwargs["angle_convention"]:
        raise ArgumentError(f"joint '{kwargs['name']}': table {table.path} is tabulated in the "
                                 f"'{table.angle_convention}' convention, not '{kwargs['angle_convention']}'")
    if table.swivel is None:
        kwargs.pop("undefined_swivel", None)
        return TiltTableJoint(tilt_nodes=table.tilt, k_nodes=table.stiffness, table_name=table.path, **kwargs)
    return SwivelTiltTableJoint(swivel_nodes=table.swivel, tilt_nodes=table.tilt, k_grid=table.stiffness,
                                table_name=table.path, **kwargs)


# --------------------------------------------------------------------------------------------- machine files
def _load_table(p: "Params", swivel: bool) -> Component:
    common = base.read_joint_common(p)
    policy = p["extrapolation"]
    extra = {"undefined_swivel": base.read_undefined_swivel(p)} if swivel else {}
    if p.exactly_one(("table",), ("tilt", "stiffness")) == 0:
        ref = p["table"]
        try:
            table = load_joint_table(ref, base_dir=p.base_dir)
        except JointTableNotFound as exc:
            raise p.error("table", exc.expected, f"{ref!r} ({exc.found})") from exc
        except InputError as exc:  # content error: keep file/line/column, add who referenced the table
            where = f"{exc.file} (table of {p.key('table')} in {p.source or 'input'})"
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


_TABLE = Param("table", "-", None, "bundled table name or CSV path (relative to the machine file)",
               kind="string", required="unless inline data")
_INLINE_TILT = Param("tilt", "rad", None, "inline tilt nodes, ascending", required="unless table", shape=(None,))
MODELS: tuple[ModelSpec, ...] = (
    ModelSpec("joint_table", "tabulated joint stiffness over tilt, clamped end-slope cubic spline", "Cobet 3.2.5",
              (_TABLE, _INLINE_TILT,
               Param("stiffness", "N/m", None, "inline stiffness at the tilt nodes", required="unless table",
                     shape=(None,), positive=True),
               base.EXTRAPOLATION) + base.JOINT_COMMON,
              lambda p: _load_table(p, swivel=False), tables="tilt"),
    ModelSpec("joint_table_swivel_tilt",
              "tabulated joint stiffness on a (swivel, tilt) grid, bicubic end-slope spline",
              "docs/theory/components.md Assumption",
              (_TABLE,
               Param("swivel", "rad", None, "inline swivel nodes, ascending", required="unless table", shape=(None,)),
               _INLINE_TILT,
               Param("stiffness", "N/m", None, "inline grid stiffness[swivel][tilt]", required="unless table",
                     shape=(None, None), positive=True),
               base.UNDEFINED_SWIVEL, base.EXTRAPOLATION) + base.JOINT_COMMON,
              lambda p: _load_table(p, swivel=True), tables="swivel_tilt"),
)
