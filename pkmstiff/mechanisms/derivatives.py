"""Velocities and accelerations from the derivatives of the total system (DE 10 2004 026 707 A1, claim 9, [0050]).

With model and drive equations F(q, s) = 0 (drive rows m(q) − s), differentiation along a motion s(t) gives
F_q q̇ = E ṡ and F_q q̈ = E s̈ − (d/dt F_q) q̇, where E selects the drive rows.  Both are solved as least-squares
problems (the rows are redundant, calibration.md §3) by pivoted QR; the curvature term (d/dt F_q) q̇ is the second
directional derivative of F along q̇, taken as a central difference of the analytic residual (error O(h²), h
scaled to the configuration).  Output rates follow from the output pose along the same path.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pkmstiff.errors import ArgumentError
from pkmstiff.mechanisms.constraints import fk_system
from pkmstiff.mechanisms.linalg import GAP_FACTOR, GAP_FLOOR, lstsq_pivoted
from pkmstiff.mechanisms.solver import Solution, output_pose

Array = NDArray[np.float64]


@dataclass
class Rates:
    qdot: Array  #: (N, L, d) link coordinate rates (m/s, rad/s)
    qddot: Array  #: (N, L, d) (m/s², rad/s²)
    pose_dot: Array | None  #: (N, 6) output pose rates (m/s, rad/s of the Cardan angles); None without output
    pose_ddot: Array | None  #: (N, 6)


def rates(sol: Solution, drive_rates: ArrayLike, drive_accelerations: ArrayLike | None = None,
          h: float = 1e-4) -> Rates:
    """Velocities and accelerations of the configurations of a forward/inverse solution for drive rates ṡ and
    drive accelerations s̈ (N, n_drives) [m/s or rad/s; m/s² or rad/s²] (claim 9)."""
    mech = sol.mech
    nd = len(mech.drives)
    N = sol.q.shape[0]
    sd = np.broadcast_to(np.asarray(drive_rates, dtype=float), (N, nd)) if nd else None
    sdd = np.zeros((N, nd)) if drive_accelerations is None else np.broadcast_to(
        np.asarray(drive_accelerations, dtype=float), (N, nd))
    if sd is None or sd.shape != (N, nd):
        raise ArgumentError(f"drive_rates: expected shape ({nd},) or ({N}, {nd})")
    system = fk_system(mech)
    rows, free = system.solve_rows, system.free
    L, d = sol.q.shape[1:]
    drv = sol.drives
    r0, J = system.evaluate(sol.q, drv)
    Jf = np.ascontiguousarray(J[:, rows][:, :, free])
    E = np.zeros((N, system.m))
    Edd = np.zeros((N, system.m))
    for b in system.blocks:
        if b.kind.startswith("drive"):
            E[:, b.row0 + np.arange(b.n)] = sd[:, b.coord]
            Edd[:, b.row0 + np.arange(b.n)] = sdd[:, b.coord]
    # F_q q̇ = E ṡ (drive rows: ∂(m − s)/∂s = −1)
    v, _, _ = lstsq_pivoted(Jf, np.ascontiguousarray(-E[:, rows]), GAP_FLOOR, GAP_FACTOR)
    qd = np.zeros((N, L * d))
    qd[:, free] = v
    scale = h * mech.length_scale / np.maximum(np.abs(qd).max(axis=1, keepdims=True), 1e-300)
    qf = sol.q.reshape(N, -1)
    # the drive rows of F(q ± εq̇) with the targets s ± εṡ: second difference of F along the motion
    rp, _ = system.evaluate((qf + scale * qd).reshape(N, L, d), drv + scale * sd, jac=False)
    rm, _ = system.evaluate((qf - scale * qd).reshape(N, L, d), drv - scale * sd, jac=False)
    curv = (rp - 2.0 * r0 + rm) / scale**2
    rhs = Edd - curv
    a, _, _ = lstsq_pivoted(Jf, np.ascontiguousarray(-rhs[:, rows]), GAP_FLOOR, GAP_FACTOR)
    qdd = np.zeros((N, L * d))
    qdd[:, free] = a
    pd = pdd = None
    if mech.output is not None:
        P = lambda x: output_pose(mech, x.reshape(N, L, d))  # noqa: E731
        pp, p0, pm = P(qf + scale * qd + 0.5 * scale**2 * qdd), P(qf), P(qf - scale * qd + 0.5 * scale**2 * qdd)
        pd = (pp - pm) / (2.0 * scale)
        pdd = (pp - 2.0 * p0 + pm) / scale**2
    return Rates(qd.reshape(N, L, d), qdd.reshape(N, L, d), pd, pdd)
