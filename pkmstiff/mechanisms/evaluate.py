"""A mechanism evaluated like a machine: drive values, status and admissibility by joint limits (issue 14, item 5).

Mirrors :func:`pkmstiff.admissibility.evaluate_poses` for the kinematic quantities a generic mechanism has: the
inverse kinematics of the poses (continuation from home), the drive values, every joint variable that has limits,
and a reason code per pose (bits of :data:`REASONS`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pkmstiff.mechanisms.model import Mechanism
from pkmstiff.mechanisms.solver import Solution, inverse, joint_values

Array = NDArray[np.float64]

#: reason bits: no configuration found, singular configuration, a joint outside its limits, a configuration only in
#: another working/assembly mode than the start's (:mod:`pkmstiff.mechanisms.modes`)
REASONS = {"NO_SOLUTION": 1, "SINGULAR": 2, "JOINT_LIMIT": 4, "OTHER_WORKING_MODE": 8}


def reason_names(code: int) -> list[str]:
    """Names of the reason bits set in ``code``."""
    return [n for n, b in REASONS.items() if int(code) & b]


@dataclass
class MechanismEvaluation:
    poses: Array  #: (N, 6) or (N, 3)
    solution: Solution
    drives: Array  #: (N, n_drives) m or rad
    drive_names: tuple[str, ...]
    joint_names: tuple[str, ...]  #: joints with limits
    joint_values: Array  #: (N, n_limited) m or rad
    violated: Array  #: (N, n_limited) bool
    reasons: Array  #: (N,) int, bits of REASONS

    @property
    def admissible(self) -> Array:
        return self.reasons == 0

    @property
    def status(self) -> Array:
        return self.solution.status


def evaluate(mech: Mechanism, poses: ArrayLike, solution: Solution | None = None, **solve_kw) -> MechanismEvaluation:
    """Inverse kinematics of N poses (or their given ``solution``), drive values, joint variables against their
    limits and reason codes."""
    sol = inverse(mech, poses, **solve_kw) if solution is None else solution
    limited = [i for i, j in enumerate(mech.joints) if np.isfinite(j.limits).any()]
    vals = joint_values(mech, sol.q, limited) if limited else np.zeros((sol.q.shape[0], 0))
    lo = np.array([mech.joints[i].limits[0] for i in limited])
    hi = np.array([mech.joints[i].limits[1] for i in limited])
    ok = sol.ok
    vals = np.where(ok[:, None], vals, np.nan)
    violated = ok[:, None] & ((vals < lo) | (vals > hi))
    other = sol.status == "other_mode"
    reasons = np.where(ok | other, 0, REASONS["NO_SOLUTION"]) | np.where(other, REASONS["OTHER_WORKING_MODE"], 0) \
        | np.where(sol.status == "singular", REASONS["SINGULAR"], 0) \
        | np.where(violated.any(axis=1), REASONS["JOINT_LIMIT"], 0)
    return MechanismEvaluation(np.atleast_2d(np.asarray(poses, dtype=float)), sol, sol.drives, mech.drive_names,
                               tuple(mech.joints[i].name for i in limited), vals, violated, reasons.astype(int))
