"""The identification Jacobian ∂readings/∂parameters, analytic and vectorised over poses (Szatmári §4.4.2.1,
eq. 4.3–4.4; Denkena §1.4.1, Gl. 61–63).

With the drive values u fixed at their nominal (commanded) values, the reached platform pose x(p) is defined
implicitly by F(x, p) = q(x, p) − u = 0, q the perturbed inverse kinematics (drive coordinates). The implicit
function theorem (Denkena Gl. 61–68) gives the platform twist

    δt = (δo, δω) = −F_x⁻¹ F_p δp = −J_C (∂q/∂p) δp,      F_x = J_C⁻¹ (twist form, models.md §1.4),

and a reading y(o, R, s) of the instrument changes by δy = H δt + (∂y/∂s) δs with H its twist derivative and s
the set-up parameters. Per chain i the drive derivative ∂q_i/∂p involves only that chain's parameters:

* pod, q_i = |p_i − b_i| − Δl_i: ∂/∂b_i = −û_i, ∂/∂p'_i = Rᵀ û_i, ∂/∂Δl_i = −1;
* glide, |s_i + q_off,i + λ_i r_i − p_i| = l_i, q_i = λ_i − Δλ_i with d_i = p_i − q_i, w_i = d_i/(d_i·r_i):
  ∂/∂s_i = ∂/∂q_off,i = −w_i, ∂/∂r_i = −λ_i w_i, ∂/∂l_i = −l_i/(d_i·r_i), ∂/∂p'_i = Rᵀ w_i, ∂/∂Δλ_i = −1.

So J = −H J_C G + S (G block-diagonal by chain): one batched 6×6 solve per pose, no per-pose Python loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pkmstiff.calibration.backlash import has_backlash, held_signs, plan_run_starts
from pkmstiff.calibration.instruments import Instrument
from pkmstiff.calibration.parameters import ParameterSet
from pkmstiff.calibration.plans import Plan
from pkmstiff.errors import ArgumentError, InadmissibleError
from pkmstiff.kinematics import as_poses, inverse_jacobian, inverse_kinematics, singular_mask
from pkmstiff.machine import Machine


@dataclass(frozen=True)
class IdentificationJacobian:
    """J (m, n): readings (rows, pose-major: pose 0's k readings first) per unit parameter (SI).

    ``row_scale`` (m,) weights rows of mixed units before any rank or condition analysis: 1 for length readings,
    ``rotation_length`` (m) for orientation readings (Assumption: orientation errors weighted by the platform
    joint radius, so that 1 mrad counts like the displacement it causes at a platform joint).
    """

    J: np.ndarray
    params: ParameterSet
    plan_name: str
    instrument: Instrument
    n_poses: int
    reading_names: tuple[str, ...]
    reading_units: tuple[str, ...]
    row_scale: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return self.J.shape  # type: ignore[return-value]

    def weighted(self) -> np.ndarray:
        """Row-weighted Jacobian (all rows in m)."""
        return self.J * self.row_scale[:, None]

    def scaled(self) -> np.ndarray:
        """Row-weighted and column-scaled Jacobian W J D, D = diag(parameter scales): dimensionless sensitivities
        of the readings (m) per typical parameter error (the matrix identifiability works on)."""
        return self.weighted() * self.params.scale[None, :]


def reading_weights(machine: Machine, instrument: Instrument, n_poses: int) -> np.ndarray:
    """Row weights (n_poses · k,): 1 for length readings, :func:`rotation_length` for orientation readings."""
    return np.tile([1.0 if u == "m" else rotation_length(machine) for u in instrument.reading_units], n_poses)


def rotation_length(machine: Machine) -> float:
    """Length (m) that weights orientation readings: the mean platform-joint radius |p'_i|."""
    return float(np.mean(np.linalg.norm(machine.chains.platform_joint, axis=1)))


def identification_jacobian(machine: Machine, params: ParameterSet, plan: Plan,
                            signs: np.ndarray | None = None) -> IdentificationJacobian:
    """Analytic identification Jacobian of ``plan`` on ``machine`` for the parameters ``params`` at the nominal
    geometry (see the module docstring), shape (N k, n); k readings per pose. Backlash columns
    (:mod:`pkmstiff.calibration.backlash`, ∂q_i/∂b_i = s_i/2) use the drives' directions of motion ``signs``
    (N, n), by default those of ``machine``'s inverse kinematics along the plan's runs. A plan of several set-ups
    (:class:`~pkmstiff.calibration.setups.PlanSet`) stacks the rows of its parts, each with the machine's columns
    and its own set-up's (``signs`` per part from its own runs)."""
    if params.machine != machine.name or params.kind != machine.kind:
        raise ArgumentError(f"error model of '{params.machine}' used with machine '{machine.name}'")
    from pkmstiff.calibration.setups import PlanSet, parts, placed_ball_jacobian

    if isinstance(plan, PlanSet):
        k = plan.instrument.n_readings
        J = np.zeros((plan.n_readings, params.n))
        for part, sub, idx, rows in parts(plan, params):
            J[rows.start * k:rows.stop * k, idx] = identification_jacobian(machine, sub, part).J
        inst = plan.instrument
        return IdentificationJacobian(J=J, params=params, plan_name=plan.name, instrument=inst,
                                      n_poses=plan.n_poses, reading_names=inst.reading_names,
                                      reading_units=inst.reading_units,
                                      row_scale=reading_weights(machine, inst, plan.n_poses))
    x = as_poses(plan.poses, f"plan '{plan.name}'")
    N, n_ch = x.shape[0], machine.n_chains
    inst = plan.instrument
    ik = inverse_kinematics(machine, x)
    if not ik.all_reachable.all():
        i = int(np.flatnonzero(~ik.all_reachable)[0])
        raise InadmissibleError(f"plan '{plan.name}': pose {i + 1} is unreachable on {machine.name} (a strut cannot "
                               "reach its guide)")
    jinv = inverse_jacobian(machine, ik)  # (N, n, 6)
    R = ik.R
    o = x[:, :3]
    setup = plan.setup
    Rv = np.einsum("nij,j->ni", R, setup.target)
    m = o + Rv
    H = inst.reading_twist(setup, m, Rv, f"plan '{plan.name}'")
    k = H.shape[1]
    sing = singular_mask(machine, jinv)  # κ(J_C⁻¹) > threshold (models.md §1.6), as the admissibility check
    if sing.any():
        i = int(np.flatnonzero(sing)[0])
        raise InadmissibleError(f"plan '{plan.name}': singular set-up, {int(sing.sum())} poses singular on "
                               f"{machine.name} (condition number of J_C^-1 above "
                               f"{machine.limits.singularity_threshold:g}), first pose {i + 1}")
    try:
        with np.errstate(all="raise"):
            LamT = np.linalg.solve(np.swapaxes(jinv, 1, 2), np.swapaxes(H, 1, 2))  # (N, n, k) = (H J_C)ᵀ
    except (np.linalg.LinAlgError, FloatingPointError):
        LamT = np.full((N, n_ch, k), np.nan)
    bad = ~np.isfinite(LamT).all(axis=(1, 2))
    if bad.any():
        raise InadmissibleError(f"plan '{plan.name}': singular set-up, the inverse Jacobian is singular at "
                               f"{int(bad.sum())} poses, first pose {int(np.flatnonzero(bad)[0]) + 1}")

    ch = machine.chains
    d = ik.d
    Rt = np.swapaxes(R, 1, 2)
    if ch.kind == "pod":
        w = d / ik.length[..., None]
        vec = {"base_joint": -w, "platform_joint": np.einsum("nij,ncj->nci", Rt, w)}
        sca = {"strut_offset": -np.ones((N, n_ch))}
    else:
        den = np.einsum("nci,ci->nc", d, ch.guide_direction)
        w = d / den[..., None]
        lam = ik.drive + ch.drive_offset[None, :]
        vec = {"guide_start": -w, "drive_joint": -w, "guide_direction": -lam[..., None] * w,
               "platform_joint": np.einsum("nij,ncj->nci", Rt, w)}
        sca = {"strut_length": -ch.strut_length[None, :] / den, "drive_zero": -np.ones((N, n_ch))}

    if has_backlash(params):
        sca["backlash"] = 0.5 * (held_signs(ik.drive, plan_run_starts(plan)) if signs is None else signs)
    J = np.zeros((N, k, params.n))
    for block, P in vec.items():
        idx = np.flatnonzero(params.mask(block))
        if idx.size:
            c = params.chain[idx]
            g = np.einsum("nlj,lj->nl", P[:, c, :], params.axis[idx])  # (N, len) drive sensitivity
            J[:, :, idx] = -LamT[:, c, :].transpose(0, 2, 1) * g[:, None, :]
    for block, g_all in sca.items():
        idx = np.flatnonzero(params.mask(block))
        if idx.size:
            c = params.chain[idx]
            J[:, :, idx] = -LamT[:, c, :].transpose(0, 2, 1) * g_all[:, c][:, None, :]
    inst.setup_jacobian(J, params, setup, R, m)
    if setup.placing_pose is not None:  # r = |m - s(p)|: the fixed ball moves with the machine that placed it
        u = (m - setup.fixed_ball) / np.linalg.norm(m - setup.fixed_ball, axis=1)[:, None]
        J[:, 0, :] -= u @ placed_ball_jacobian(machine, params, setup)
    names, units = inst.reading_names, inst.reading_units
    row_scale = reading_weights(machine, inst, N)
    return IdentificationJacobian(J=J.reshape(N * k, params.n), params=params, plan_name=plan.name, instrument=inst,
                                  n_poses=N, reading_names=names, reading_units=units, row_scale=row_scale)

