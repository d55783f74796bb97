"""Machine-file parameters shared by the ball-screw drives: screw stiffness data and dynamics (eq. 3.1-3.4, 3.24)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from components.ballscrew.formulas import (
    RANGE_POLICIES,
    apparent_mass_from_inertia,
    max_axial_force,
    spindle_axial_rigidity,
)
from components.limits import drive_limits
from components.params import Param

if TYPE_CHECKING:
    from components.reader import Params

#: Stiffness data of a ball screw (Cobet eq. 3.1-3.3); the spindle is given by E*A or by d_Sp and E.
SCREW_DATA: tuple[Param, ...] = (
    Param("k_aL", "N/m", None, "axial stiffness of the bearings (fixed bearing = 2 k_aL)", required=True,
          positive=True),
    Param("k_M", "N/m", None, "nut stiffness", required=True, positive=True),
    Param("k_TM", "N/m", np.inf, "nut connection stiffness", positive=True, rigid_ok=True),
    Param("spindle_EA", "N", None, "spindle E*A (= k_Sp l_eff)", required="unless d_Sp + E", positive=True),
    Param("d_Sp", "m", None, "spindle diameter (mean of core and nominal), with E", required="unless spindle_EA",
          positive=True),
    Param("E", "Pa", None, "Young's modulus of the spindle, with d_Sp", required="unless spindle_EA", positive=True),
)
#: Moved mass, apparent spindle mass (eq. 3.4) and maximum force from the motor torque (eq. 3.24).
SCREW_DYNAMICS: tuple[Param, ...] = (
    Param("mass", "kg", 0.0, "moved mass (the apparent spindle mass is added)", min_value=0.0),
    Param("lead", "m", None, "spindle lead h_S", positive=True),
    Param("spindle_inertia", "kg*m^2", None, "spindle inertia J for the apparent mass (eq. 3.4)", positive=True),
    Param("spindle_inertia_per_length", "kg*m", None, "spindle inertia per length, with spindle_total_length "
          "(instead of spindle_inertia)", positive=True),
    Param("spindle_total_length", "m", None, "total spindle length, with spindle_inertia_per_length", positive=True),
    Param("motor_torque", "N*m", None, "max_force = 2 pi M_t eta / h_S (eq. 3.24; instead of max_force)",
          positive=True),
    Param("efficiency", "-", 1.0, "efficiency eta, with motor_torque (eq. 3.24)", positive=True),
)
RANGE_PARAM = Param("out_of_range", "-", "clamp", "policy for l_eff outside [l_eff_min, l_eff_max]",
                    choices=RANGE_POLICIES)


def _spindle_ea(p: "Params") -> float:
    if p.exactly_one(("spindle_EA",), ("d_Sp", "E")) == 0:  # the chosen alternative is required
        return p.get("spindle_EA", required=True)
    return spindle_axial_rigidity(p.get("d_Sp", required=True), p.get("E", required=True))


def screw_dynamics(p: "Params") -> tuple[float, dict[str, float], dict[str, str]]:
    """(mass, limits, notes) from the optional dynamic parameters of a ball-screw drive (:data:`SCREW_DYNAMICS`)."""
    notes: dict[str, str] = {}
    moved = p["mass"]
    lead = p["lead"]
    inertia = p["spindle_inertia"]
    per_length = p["spindle_inertia_per_length"]
    total_length = p["spindle_total_length"]
    if per_length is not None:
        if inertia is not None or total_length is None:
            raise p.error("spindle_inertia_per_length", "together with spindle_total_length and without "
                          "spindle_inertia", "an incomplete or conflicting spindle inertia")
        inertia = per_length * total_length
    apparent = 0.0
    if inertia is not None:
        if lead is None:
            raise p.error("lead", "the spindle lead (needed with a spindle inertia, eq. 3.4)", "missing")
        apparent = apparent_mass_from_inertia(inertia, lead)
        notes["mass"] = f"moved mass {moved:g} kg + apparent spindle mass {apparent:.4g} kg (Cobet eq. 3.4)"
    limits = drive_limits(p)
    torque = p["motor_torque"]
    if torque is not None:
        if "max_force" in limits:
            raise p.error("motor_torque", "either max_force or motor_torque (+ efficiency, lead)", "both")
        if lead is None:
            raise p.error("lead", "the spindle lead (needed with motor_torque, eq. 3.24)", "missing")
        eta = p["efficiency"]
        if eta > 1:
            raise p.error("efficiency", "a value in (0, 1]", eta)
        limits["max_force"] = max_axial_force(torque, eta, lead)
        notes["max_force"] = f"2 pi M_t eta / h_S = {limits['max_force']:.5g} N (Cobet eq. 3.24)"
    elif p.has("efficiency"):
        raise p.error("efficiency", "only together with motor_torque", p.raw("efficiency"))
    return moved + apparent, limits, notes

