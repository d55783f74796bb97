"""Angle-independent joint and the analytic substitute Cardan-joint model (Cobet eq. 3.30), with their models."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from components.joints.base import JOINT_COMMON, JointModel, read_joint_common
from components.params import ModelSpec, Param
from components.protocol import ComponentState, _full
from pkmstiff.errors import ArgumentError


@dataclass(frozen=True, kw_only=True, eq=False)
class ConstantJoint(JointModel):
    """Angle-independent joint stiffness ``k`` [N/m] (``np.inf`` = rigid)."""

    k: float

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.k > 0:
            raise ArgumentError(f"joint '{self.name}': k must be positive, found {self.k!r}")

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
                raise ArgumentError(f"joint '{self.name}': {key} must be positive, found {getattr(self, key)!r}")

    def stiffness(self, state: ComponentState) -> np.ndarray:
        tilt = state.require("tilt", self.name)
        return analytic_3_30(tilt, self.k_AaL, self.k_BrL, self.k_CrL, self.k_CaL)


# --------------------------------------------------------------------------------------------- machine files
MODELS: tuple[ModelSpec, ...] = (
    ModelSpec("joint_constant", "angle-independent joint stiffness", "k = const",
              (Param("k", "N/m", None, "joint stiffness", required=True, positive=True, rigid_ok=True),)
              + JOINT_COMMON,
              lambda p: ConstantJoint(k=p["k"], **read_joint_common(p))),
    ModelSpec("joint_analytic_3_30", "analytic substitute Cardan-joint model over tilt", "Cobet eq. 3.30",
              tuple(Param(k, "N/m", None, m, required=True, positive=True) for k, m in (
                  ("k_AaL", "bearing A axial stiffness"), ("k_BrL", "bearing B radial stiffness"),
                  ("k_CrL", "bearing C radial stiffness"), ("k_CaL", "bearing C axial stiffness"))) + JOINT_COMMON,
              lambda p: AnalyticJoint330(**{k: p[k] for k in ("k_AaL", "k_BrL", "k_CrL", "k_CaL")},
                                         **read_joint_common(p))),
)
