"""Measurement models: commanded pose → nominal IK → forward kinematics of the perturbed machine → reading
(Szatmári §4.2.4, Fig. 4.5: the simulated measurement; Denkena §1.3, Gl. 47–48), vectorised over poses.
"""

from __future__ import annotations

import numpy as np

from pkmstiff.calibration.backlash import drive_offsets, has_backlash, held_signs, plan_run_starts
from pkmstiff.calibration.instruments import readings
from pkmstiff.calibration.parameters import ParameterSet
from pkmstiff.calibration.perturb import perturbed_machine
from pkmstiff.calibration.plans import Plan
from pkmstiff.errors import InadmissibleError, NumericalError
from pkmstiff.kinematics import as_poses, forward_kinematics, inverse_kinematics
from pkmstiff.kinematics.rotation import cardan_matrix
from pkmstiff.machine import Machine


def commanded_drives(machine: Machine, poses: np.ndarray) -> np.ndarray:
    """Drive values (N, n) the nominal controller commands for the poses (nominal IK); unreachable -> error."""
    ik = inverse_kinematics(machine, poses)
    bad = np.flatnonzero(~ik.all_reachable)
    if bad.size:
        raise InadmissibleError(f"machine '{machine.name}': {bad.size} commanded poses unreachable by the nominal "
                               f"inverse kinematics, first pose {int(bad[0]) + 1}")
    return ik.drive


def reached_poses(machine: Machine, params: ParameterSet, delta: np.ndarray, poses: np.ndarray,
                  tol: float = 1e-13, starts: np.ndarray | list[int] = (0,)) -> np.ndarray:
    """The poses (N, 6) the machine with errors ``delta`` reaches for the nominal drive values of ``poses``
    (forward kinematics started at the commanded pose; Newton to ``tol`` m in the drive residual); backlash
    parameters shift each drive by −b/2 · sign(q̇) with the direction of motion taken per run (runs start at
    ``starts``, :mod:`pkmstiff.calibration.backlash`)."""
    x = as_poses(poses)
    u = commanded_drives(machine, x)
    if has_backlash(params):
        u = u + drive_offsets(params, delta, held_signs(u, starts))
    real = perturbed_machine(machine, params, delta)
    fk = forward_kinematics(real, u, x, tol_q=tol, tol_x=tol)
    if not fk.converged.all():
        raise NumericalError(f"machine '{machine.name}' with errors: {fk.report(3).splitlines()[0]} "
                               f"({'; '.join(fk.report(3).splitlines()[1:]).strip()})")
    return fk.poses


def simulate_readings(machine: Machine, params: ParameterSet, delta: np.ndarray, plan: Plan) -> np.ndarray:
    """Readings (N, k) of the plan's instrument on the machine with errors ``delta`` (machine and set-up errors),
    noise-free (Szatmári §4.2.4). A zero ``delta`` gives the nominal readings (ball bar: the bar length)."""
    delta = params.check_vector(delta)
    from pkmstiff.calibration.setups import PlanSet, actual_state, parts

    if isinstance(plan, PlanSet):
        return np.vstack([simulate_readings(machine, sub, delta[idx], part)
                          for part, sub, idx, _ in parts(plan, params)])
    x = as_poses(plan.poses)
    reached = x if not np.any(delta[params.chain >= 0]) else reached_poses(machine, params, delta, x,
                                                                            starts=plan_run_starts(plan))
    R = cardan_matrix(reached[:, 3], reached[:, 4], reached[:, 5])
    Rc = cardan_matrix(x[:, 3], x[:, 4], x[:, 5])
    return readings(plan.setup, actual_state(machine, params, delta, plan.setup), reached[:, :3], R, Rc)
