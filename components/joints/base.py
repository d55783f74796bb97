"""Common part of the joint models: tilt convention, angle limits (Cobet eq. B.5), shared checks and the
parameters every joint model accepts in a machine file."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from components.params import Param
from components.protocol import Component, ComponentState
from components.spline import EXTRAPOLATION_POLICIES, apply_range_policy
from pkmstiff.errors import ArgumentError

if TYPE_CHECKING:
    from components.reader import Params

CLAMP_NOTE = "outside the tabulated angle range the end value is used (docs/theory/components.md Assumption)"


@dataclass(frozen=True, kw_only=True, eq=False)
class JointModel(Component):
    """Common part of all joint models: tilt convention and angle limits (rad, keys tilt_min/... in limits)."""

    kind: ClassVar[str] = "axial"
    angle_convention: str | None = None

    def __post_init__(self) -> None:
        if self.angle_convention not in (None, "axis", "normal"):
            raise ArgumentError(f"joint '{self.name}': angle_convention must be 'axis', 'normal' or None, "
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


def check_policy(name: str, policy: str) -> None:
    if policy not in EXTRAPOLATION_POLICIES:
        raise ArgumentError(f"joint '{name}': extrapolation must be one of {EXTRAPOLATION_POLICIES}, found "
                                 f"{policy!r}")


def positive_finite(name: str, what: str, values: np.ndarray) -> None:
    if not np.all(np.isfinite(values)) or np.any(values <= 0):
        raise ArgumentError(f"joint '{name}': {what} must be positive and finite, found "
                                 f"{np.asarray(values).tolist()}")


def swivel_values(state: ComponentState, name: str, undefined_swivel: str | float) -> np.ndarray:
    swivel = state.require("swivel", name)
    if undefined_swivel == "nan":
        return swivel
    return np.where(np.isnan(swivel), float(undefined_swivel), swivel)


def swivel_tilt_in_range(joint: Any, state: ComponentState, table: str) -> tuple[np.ndarray, np.ndarray]:
    """(swivel, tilt) per pose for a swivel- and tilt-dependent joint: the ``undefined_swivel`` rule, then the
    joint's extrapolation policy on both axes (docs/theory/components.md); ``table`` names the data in errors."""
    sw = apply_range_policy(swivel_values(state, joint.name, joint.undefined_swivel), joint.swivel_nodes[0],
                            joint.swivel_nodes[-1], joint.extrapolation, angle="swivel", table=table)
    ti = apply_range_policy(state.require("tilt", joint.name), joint.tilt_nodes[0], joint.tilt_nodes[-1],
                            joint.extrapolation, angle="tilt", table=table)
    return sw, ti


def check_undefined(name: str, undefined_swivel: Any) -> None:
    if undefined_swivel != "nan" and not isinstance(undefined_swivel, (int, float)):
        raise ArgumentError(f"joint '{name}': undefined_swivel must be 'nan' or a swivel angle in rad, "
                                 f"found {undefined_swivel!r}")


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


def read_joint_common(p: "Params") -> dict[str, Any]:
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


def read_undefined_swivel(p: "Params") -> str | float:
    value = p["undefined_swivel"]
    if value == "nan":
        return "nan"
    return p.get("undefined_swivel", kind="quantity")
