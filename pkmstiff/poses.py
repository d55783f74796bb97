"""Pose evaluation pipeline: kinematics, joint angles and all admissibility checks for arrays of poses.

``evaluate_poses(machine, poses)`` runs, chunk by chunk, the inverse kinematics (models.md §1.2-1.3), the
inverse and kinematic Jacobians and the condition number (§1.4, §1.6), the joint angles (§2) and every check of
§8, and returns per-pose arrays (SI units) plus the combined admissibility with reason codes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from . import admissibility as adm
from .joint_angles import joint_angles
from .kinematics import as_poses, inverse_jacobian, inverse_kinematics, jacobian_and_condition
from .model import Machine

DEFAULT_CHUNK = 50_000


@dataclass
class PoseEvaluation:
    """Kinematic quantities and admissibility of N poses (SI units: m, rad)."""

    poses: np.ndarray  # (N, 6)
    drive: np.ndarray  # (N, n) drive coordinates (glide: lambda_i, pod: strut length), m
    strut_length: np.ndarray  # (N, n) m
    drive_point: np.ndarray  # (N, n, 3) drive-side joint points q_i (MKS), m
    platform_point: np.ndarray  # (N, n, 3) platform-side joint points p_i (MKS), m
    jinv: np.ndarray  # (N, 6, 6) J_C^-1 (twist form)
    jc: np.ndarray  # (N, 6, 6) J_C (NaN where singular)
    kappa: np.ndarray  # (N,) condition number of J_C^-1
    angles: dict[str, np.ndarray]  # (N, n) rad: {drive,platform}_{swivel,swivel_signed,tilt,tilt_axis,tilt_normal}
    admissibility: adm.Admissibility
    drive_loads: np.ndarray | None = None  # (N, n) static drive loads tau_g, N (None without mass data)
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def ok(self) -> np.ndarray:
        return self.admissibility.ok


def _angle_dict(ja) -> dict[str, np.ndarray]:
    return {f"{side}_{qty}": getattr(getattr(ja, side), qty)
            for side in ("drive", "platform") for qty in ("swivel", "swivel_signed", "tilt", "tilt_axis", "tilt_normal")}


def evaluate_chunk(
    machine: Machine,
    poses: np.ndarray,
    checks: Sequence[str] = adm.ALL_CHECKS,
    drive_load_data: adm.DriveLoadData | None = None,
    requirements: Iterable[Callable[["PoseEvaluation"], np.ndarray]] = (),
) -> PoseEvaluation:
    """Evaluate one chunk of poses (see :func:`evaluate_poses`)."""
    unknown = set(checks) - set(adm.ALL_CHECKS)
    if unknown:
        raise ValueError(f"unknown admissibility checks {sorted(unknown)}; expected a subset of {adm.ALL_CHECKS}")
    ik = inverse_kinematics(machine, poses)
    jinv = inverse_jacobian(machine, ik)
    jc, kappa = jacobian_and_condition(jinv)
    angles = _angle_dict(joint_angles(machine, ik))
    reach = ik.all_reachable

    results: list[adm.CheckResult] = []
    if "drive_range" in checks:
        results.append(adm.check_drive_range(machine, ik.drive, ik.reachable))
    if "drive_spacing" in checks:
        results.append(adm.check_drive_spacing(machine, ik.q))
    if "joint_angles" in checks:
        results.extend(adm.check_joint_angles(machine, {
            "drive": (angles["drive_swivel"], angles["drive_tilt"]),
            "platform": (angles["platform_swivel"], angles["platform_tilt"]),
        }))
    if "singularity" in checks:
        results.append(adm.check_singularity(machine, kappa))
    if "strut_collision" in checks:
        results.append(adm.check_strut_collision(machine, ik.p, ik.q))
    if "platform_collision" in checks:
        results.append(adm.check_platform_collision(machine, ik.q, ik.R, ik.poses[:, :3]))
    tau_g = None
    if drive_load_data is not None:
        with np.errstate(invalid="ignore"):
            tau_g = adm.static_drive_loads(machine, jc, ik.R, drive_load_data)
    if "drive_load" in checks:
        res = adm.check_drive_load(machine, tau_g, drive_load_data)
        if res.ok.size == 0:
            res.ok = np.ones(len(poses), bool)
        results.append(res)
    ev = PoseEvaluation(
        poses=ik.poses, drive=ik.drive, strut_length=ik.length, drive_point=ik.q, platform_point=ik.p,
        jinv=jinv, jc=jc, kappa=kappa, angles=angles, admissibility=adm.combine(len(poses), results, reach),
        drive_loads=tau_g,
    )
    reqs = list(requirements)
    if reqs:
        ok = np.ones(len(poses), bool)
        for req in reqs:
            ok &= np.asarray(req(ev), bool)
        results.append(adm.CheckResult(ok, adm.Reason.REQUIREMENT))
        ev.admissibility = adm.combine(len(poses), results, reach)
    return ev


def evaluate_poses(
    machine: Machine,
    poses: ArrayLike,
    checks: Sequence[str] = adm.ALL_CHECKS,
    drive_load_data: adm.DriveLoadData | None | str = "auto",
    requirements: Iterable[Callable[[PoseEvaluation], np.ndarray]] = (),
    chunk_size: int = DEFAULT_CHUNK,
) -> PoseEvaluation:
    """Kinematics, joint angles and admissibility of N poses ``(N, 6)`` = (x, y, z [m], a, b, c [rad]).

    Work is done in chunks of ``chunk_size`` poses to bound memory. Unreachable or singular poses never raise:
    their quantities are NaN/inf and the reason code says why. ``requirements`` are callables taking the
    evaluation of a chunk and returning a per-pose boolean (True = requirement met), reported as REQUIREMENT.
    ``drive_load_data="auto"`` takes masses and drive forces from the machine's components (the static
    drive-load check is skipped, with the reason "no mass data", where they are missing).
    """
    x = as_poses(poses)
    reqs = list(requirements)
    if drive_load_data == "auto":
        from .machine_components import drive_load_data as _dld

        drive_load_data = _dld(machine)
    parts = [evaluate_chunk(machine, x[s:s + chunk_size], checks, drive_load_data, reqs)
             for s in range(0, max(len(x), 1), chunk_size)] if len(x) else []
    if not parts:
        raise ValueError("evaluate_poses: expected at least one pose, found an empty array")
    return parts[0] if len(parts) == 1 else _concat(parts)


def _concat(parts: list[PoseEvaluation]) -> PoseEvaluation:
    def cat(get):
        vals = [get(p) for p in parts]
        return None if vals[0] is None else np.concatenate(vals)

    checks = {}
    for key, first in parts[0].admissibility.checks.items():
        checks[key] = adm.CheckResult(
            ok=np.concatenate([p.admissibility.checks[key].ok for p in parts]), reason=first.reason,
            detail=None if first.detail is None else np.concatenate([p.admissibility.checks[key].detail
                                                                    for p in parts]),
            labels=first.labels, skipped=first.skipped)
    admiss = adm.Admissibility(ok=cat(lambda p: p.admissibility.ok), reasons=cat(lambda p: p.admissibility.reasons),
                               checks=checks)
    return PoseEvaluation(
        poses=cat(lambda p: p.poses), drive=cat(lambda p: p.drive), strut_length=cat(lambda p: p.strut_length),
        drive_point=cat(lambda p: p.drive_point), platform_point=cat(lambda p: p.platform_point),
        jinv=cat(lambda p: p.jinv), jc=cat(lambda p: p.jc), kappa=cat(lambda p: p.kappa),
        angles={k: np.concatenate([p.angles[k] for p in parts]) for k in parts[0].angles},
        admissibility=admiss, drive_loads=cat(lambda p: p.drive_loads),
    )


def check_admissibility(machine: Machine, poses: ArrayLike, **kw) -> adm.Admissibility:
    """Combined admissibility (mask, reason codes, per-check detail) of N poses; see :func:`evaluate_poses`."""
    return evaluate_poses(machine, poses, **kw).admissibility
