"""Ball-screw formulas: spindle, bearing and nut stiffness in series/parallel, apparent mass, maximum force
(Cobet eq. 3.1-3.4, 3.24), the shared data check and the l_eff range policy."""

from __future__ import annotations

from typing import Any

import numpy as np

from components.protocol import parallel, series
from pkmstiff.errors import ArgumentError, ComponentRangeError

ARRANGEMENTS: tuple[str, ...] = ("fixed_fixed", "fixed_floating", "floating_fixed")
RANGE_POLICIES: tuple[str, ...] = ("clamp", "error")
DRIVE_MODELS: tuple[str, ...] = ("fit_3_22", "exact_3_3")


def _check_drive_data(drive) -> None:
    """Range policy and positive stiffness data common to the ball-screw drives (eq. 3.2, 3.3)."""
    if drive.out_of_range not in RANGE_POLICIES:
        raise ArgumentError(f"drive '{drive.name}': out_of_range must be one of {RANGE_POLICIES}, "
                                 f"found {drive.out_of_range!r}")
    for key in ("k_al", "spindle_ea", "k_m", "k_tm"):
        if not getattr(drive, key) > 0:
            raise ArgumentError(f"drive '{drive.name}': {key} must be positive, found {getattr(drive, key)!r}")



def spindle_axial_rigidity(d_sp: float, E: float) -> float:
    """EA = π d_Sp² E / 4 [N] of the spindle (numerator of Cobet eq. 3.1); d_Sp = mean of core and nominal diameter."""
    return np.pi * d_sp**2 * E / 4.0


def spindle_stiffness(d_sp: float, E: float, l_eff: Any) -> np.ndarray:
    """Spindle stiffness k_Sp = π d_Sp² E / (4 l_eff) [N/m], Cobet eq. 3.1 (l_eff = 0 gives np.inf)."""
    with np.errstate(divide="ignore"):
        return spindle_axial_rigidity(d_sp, E) / np.asarray(l_eff, dtype=float)


def fixed_fixed_stiffness_eq_3_2(k_al: float, k_sp1: Any, k_sp2: Any, k_m: float, k_tm: float) -> np.ndarray:
    """Axial stiffness of the fixed–fixed arrangement, closed form of Cobet eq. 3.2 (finite k_Sp only)."""
    k1 = np.asarray(k_sp1, dtype=float)
    k2 = np.asarray(k_sp2, dtype=float)
    bearing_spindle = (2 * k_al + k1) * (2 * k_al + k2) / (4 * k_al * (k1 * k2 + k_al * (k1 + k2)))
    return 1.0 / (bearing_spindle + 1.0 / k_m + 1.0 / k_tm)


def fixed_fixed_bearing_spindle(k_al: float, k_sp1: Any, k_sp2: Any) -> np.ndarray:
    """Bearing + spindle part of eq. 3.2 as two parallel paths, each ``2 k_al`` in series with a segment."""
    return parallel(series(2 * k_al, k_sp1), series(2 * k_al, k_sp2))


def fixed_floating_stiffness(k_al: float, k_sp: Any, k_m: float, k_tm: float) -> np.ndarray:
    """Axial stiffness 1/k_A = 1/(2 k_aL) + 1/k_Sp + 1/k_M + 1/k_TM, Cobet eq. 3.3 (np.inf = rigid)."""
    return series(2 * k_al, k_sp, k_m, k_tm)


def apparent_mass_from_inertia(J: float, lead: float) -> float:
    """Apparent translational mass m = (2π/h_S)² J [kg], Cobet eq. 3.4 (J: spindle inertia [kg·m²], h_S [m])."""
    return (2.0 * np.pi / lead) ** 2 * J


def apparent_mass_from_geometry(d_sp: float, l_abs: float, rho: float, lead: float) -> float:
    """Apparent translational mass m = π³ d⁴ l_abs ρ / (8 h_S²) [kg], Cobet eq. 3.4 (solid spindle)."""
    return np.pi**3 * d_sp**4 * l_abs * rho / (8.0 * lead**2)


def max_axial_force(motor_torque: float, efficiency: float, lead: float) -> float:
    """Maximum axial drive force τ_q,max = 2π M_t η / h_S [N], Cobet eq. 3.24."""
    return 2.0 * np.pi * motor_torque * efficiency / lead


def _range_policy(values: np.ndarray, lo: float, hi: float, policy: str, what: str, name: str) -> np.ndarray:
    if policy == "error":
        bad = (values < lo) | (values > hi)
        if np.any(bad):
            idx = int(np.flatnonzero(bad)[0])
            raise ComponentRangeError(f"drive '{name}': {what} = {values[idx]:.6g} m (pose {idx}) outside the "
                                      f"admissible range [{lo:.6g}, {hi:.6g}] m (out_of_range='error')")
        return values
    return np.clip(values, lo, hi)

