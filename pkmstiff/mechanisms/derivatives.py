"""Velocities and accelerations from the derivatives of the total system (DE 10 2004 026 707 A1, claim 9, [0050]).

With model and drive equations F(q, s) = 0 (drive rows m(q) − s), differentiation along a motion s(t) gives
F_q q̇ = E ṡ and F_q q̈ = E s̈ − (d/dt F_q) q̇, where E selects the drive rows.  Both are solved as least-squares
problems (the rows are redundant, calibration.md §3); the curvature term is exact — the Taylor-mode residual of
:mod:`pkmstiff.mechanisms.path`, which also gives the jerk — and so are the output pose rates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pkmstiff.errors import MechanismInputError
from pkmstiff.mechanisms.path import path_derivatives
from pkmstiff.mechanisms.solver import Solution

Array = NDArray[np.float64]


@dataclass
class Rates:
    qdot: Array  #: (N, L, d) link coordinate rates (m/s, rad/s)
    qddot: Array  #: (N, L, d) (m/s², rad/s²)
    pose_dot: Array | None  #: (N, 6) output pose rates (m/s, rad/s of the Cardan angles); None without output
    pose_ddot: Array | None  #: (N, 6)


def rates(sol: Solution, drive_rates: ArrayLike, drive_accelerations: ArrayLike | None = None) -> Rates:
    """Velocities and accelerations of the configurations of a forward/inverse solution for drive rates ṡ and
    drive accelerations s̈ (N, n_drives) [m/s or rad/s; m/s² or rad/s²] (claim 9); :func:`path_derivatives`
    gives the jerk as well."""
    mech = sol.mech
    nd = len(mech.drives)
    N = sol.q.shape[0]
    sd = np.broadcast_to(np.asarray(drive_rates, dtype=float), (N, nd)) if nd else None
    sdd = np.zeros((N, nd)) if drive_accelerations is None else np.broadcast_to(
        np.asarray(drive_accelerations, dtype=float), (N, nd))
    if sd is None or sd.shape != (N, nd):
        raise MechanismInputError(f"drive_rates: expected shape ({nd},) or ({N}, {nd})")
    pd = path_derivatives(mech, np.where(sol.ok[:, None], sol.drives, 0.0), sd, sdd, solution=sol)
    return Rates(pd.q[1], pd.q[2], None if pd.pose is None else pd.pose[1],
                 None if pd.pose is None else pd.pose[2])
