"""Product model k_ref g_swivel(swivel) g_tilt(tilt) of two normalised 1-D curves (docs/theory/components.md Assumption)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from components.joints import base
from components.params import ModelSpec, Param
from components.protocol import Component, ComponentState
from components.spline import clamped_cubic
from pkmstiff.errors import ArgumentError

if TYPE_CHECKING:
    from components.reader import Params


@dataclass(frozen=True, kw_only=True, eq=False)
class ProductJoint(base.JointModel):
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
        base.check_policy(self.name, self.extrapolation)
        base.check_undefined(self.name, self.undefined_swivel)
        if not self.k_ref > 0:
            raise ArgumentError(f"joint '{self.name}': k_ref must be positive, found {self.k_ref!r}")
        curves = []
        for nodes, values, axis in ((self.swivel_nodes, self.g_swivel, "swivel"),
                                    (self.tilt_nodes, self.g_tilt, "tilt")):
            x = np.asarray(nodes, dtype=float)
            g = np.asarray(values, dtype=float)
            base.positive_finite(self.name, f"{axis} curve", g)
            curves.append((x, g / g.max()))
        (sw, gs), (ti, gt) = curves
        for key, value in (("swivel_nodes", sw), ("g_swivel", gs), ("tilt_nodes", ti), ("g_tilt", gt)):
            object.__setattr__(self, key, value)
        object.__setattr__(self, "_splines", (clamped_cubic(sw, gs, what=f"joint '{self.name}' swivel curve"),
                                              clamped_cubic(ti, gt, what=f"joint '{self.name}' tilt curve")))
        self._add_assumption("interpolation", "k = k_ref g_swivel(swivel) g_tilt(tilt), curves normalised to "
                                              "their maxima (docs/theory/components.md Assumption)")
        if self.extrapolation == "clamp":
            self._add_assumption("extrapolation", base.CLAMP_NOTE)

    def stiffness(self, state: ComponentState) -> np.ndarray:
        table = f"joint '{self.name}'"
        sw, ti = base.swivel_tilt_in_range(self, state, table)
        s_sw, s_ti = self._splines
        return self.k_ref * s_sw(sw) * s_ti(ti)


# --------------------------------------------------------------------------------------------- machine files
def _joint_product(p: "Params") -> Component:
    common = base.read_joint_common(p)
    sw = p["swivel"]
    ti = p["tilt"]
    return ProductJoint(k_ref=p["k_ref"], swivel_nodes=sw, g_swivel=p.get("g_swivel", shape=(sw.size,)),
                        tilt_nodes=ti, g_tilt=p.get("g_tilt", shape=(ti.size,)), extrapolation=p["extrapolation"],
                        undefined_swivel=base.read_undefined_swivel(p), **common)


MODELS: tuple[ModelSpec, ...] = (
    ModelSpec("joint_product_swivel_tilt", "k_ref g_swivel(swivel) g_tilt(tilt) from two normalised 1-D curves",
              "docs/theory/components.md Assumption",
              (Param("k_ref", "N/m", None, "stiffness at the maxima of both curves", required=True, positive=True),
               Param("swivel", "rad", None, "swivel nodes of g_swivel, ascending", required=True, shape=(None,)),
               Param("g_swivel", "-", None, "swivel curve (normalised to its maximum)", required=True,
                     shape=(None,), positive=True),
               Param("tilt", "rad", None, "tilt nodes of g_tilt, ascending", required=True, shape=(None,)),
               Param("g_tilt", "-", None, "tilt curve (normalised to its maximum)", required=True, shape=(None,),
                     positive=True),
               base.UNDEFINED_SWIVEL, base.EXTRAPOLATION) + base.JOINT_COMMON,
              _joint_product),
)
