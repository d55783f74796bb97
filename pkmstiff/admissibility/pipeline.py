"""Pose evaluation pipeline: kinematics, joint angles and all admissibility checks for arrays of poses.

``evaluate_poses(machine, poses)`` runs, chunk by chunk, the inverse kinematics (docs/theory/kinematics.md), the
inverse and kinematic Jacobians (§1.4), the joint angles (§2) and every check of §8, and returns per-pose arrays
(SI units) plus the combined admissibility with reason codes.

The singularity check (§1.6) needs no condition number: certified bounds κ_lo ≤ κ ≤ κ_hi come with the QR
factorisation that yields J_C, and κ is computed exactly (SVD) only for poses whose bounds straddle the
threshold (:func:`pkmstiff.kinematics.jacobian_and_singular`). ``PoseEvaluation.kappa`` is computed on first
access (:func:`pkmstiff.kinematics.condition_number`, relative accuracy 1e-4) and then kept.
The hot loops (QR of J_C^-1, joint angles, strut-strut and strut-platform collision) are compiled kernels
(:mod:`pkmstiff.kinematics.kernels`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike

import pkmstiff.admissibility.checks as adm
import pkmstiff.admissibility.fastpath as _fast
from pkmstiff.kinematics import (
    IK,
    as_poses,
    condition_number,
    inverse_jacobian,
    inverse_kinematics,
    jacobian_and_singular,
)
from pkmstiff.kinematics.inverse import IK_ARRAYS
from pkmstiff.kinematics.joint_angles import joint_angles
from pkmstiff.machine.model import Machine
from pkmstiff.machine.roles import DriveLoadData
from pkmstiff.machine.roles import drive_load_data as _dld

#: poses per chunk: bounds the temporaries (≈ 3 kB per pose) and keeps them cache- and allocator-friendly
#: (measured fastest between 8k and 16k poses on the CI machine; 50k was ~25 % slower)
DEFAULT_CHUNK = 8192


@dataclass
class PoseEvaluation:
    """Kinematic quantities and admissibility of N poses (SI units: m, rad).

    ``ik`` is the inverse-kinematics result itself (poses, R, joint points, strut vectors, drive coordinates), so
    that later stages (the structure model, :func:`pkmstiff.structure.build_structure`) reuse it instead of
    repeating it; ``drive``, ``strut_length``, ``drive_point`` and ``platform_point`` read it. ``checks``: the
    admissibility checks that were applied. ``kappa`` may be given as ``None`` (the pipeline does): it is then
    computed from ``jinv`` on first access.
    """

    ik: IK  # inverse kinematics of the N poses
    jinv: np.ndarray  # (N, 6, 6) J_C^-1 (twist form)
    jc: np.ndarray  # (N, 6, 6) J_C (NaN where singular)
    kappa: np.ndarray = field(repr=False)  # (N,) condition number of J_C^-1 (lazy, see the class docstring)
    angles: dict[str, np.ndarray]  # (N, n) rad: {drive,platform}_{swivel,swivel_signed,tilt,tilt_axis,tilt_normal}
    admissibility: adm.Admissibility
    drive_loads: np.ndarray | None = None  # (N, n) static drive loads tau_g, N (None without mass data)
    extra: dict[str, np.ndarray] = field(default_factory=dict)  # callers' per-pose arrays (N, ...)
    checks: tuple[str, ...] = adm.ALL_CHECKS  # the admissibility checks applied

    @property
    def poses(self) -> np.ndarray:
        """(N, 6) x, y, z [m], a, b, c [rad]."""
        return self.ik.poses

    @property
    def drive(self) -> np.ndarray:
        """(N, n) drive coordinates (glide: lambda_i, pod: strut length), m."""
        return self.ik.drive

    @property
    def strut_length(self) -> np.ndarray:
        """(N, n) strut lengths, m."""
        return self.ik.length

    @property
    def drive_point(self) -> np.ndarray:
        """(N, n, 3) drive-side joint points q_i (MKS), m."""
        return self.ik.q

    @property
    def platform_point(self) -> np.ndarray:
        """(N, n, 3) platform-side joint points p_i (MKS), m."""
        return self.ik.p

    @property
    def ok(self) -> np.ndarray:
        return self.admissibility.ok

    @property
    def kappa_computed(self) -> bool:
        """True once κ is known (given or computed); reading ``kappa`` computes it."""
        return self._kappa is not None

    def subset(self, mask: np.ndarray | slice) -> "PoseEvaluation":
        """The evaluation restricted to the poses where ``mask`` is True, or to a ``slice`` of them (κ stays lazy if
        not yet computed).

        The admissibility keeps ``ok`` and ``reasons``; the per-check details are not carried over.
        """
        if not isinstance(mask, slice):
            mask = np.asarray(mask)
        a = adm.Admissibility(ok=self.admissibility.ok[mask], reasons=self.admissibility.reasons[mask], checks={})
        return PoseEvaluation(
            ik=self.ik.take(mask), jinv=self.jinv[mask], jc=self.jc[mask],
            kappa=None if self._kappa is None else self._kappa[mask],
            angles={k: v[mask] for k, v in self.angles.items()}, admissibility=a,
            drive_loads=None if self.drive_loads is None else self.drive_loads[mask],
            extra={k: v[mask] for k, v in self.extra.items()}, checks=self.checks)


def _get_kappa(self: PoseEvaluation) -> np.ndarray:
    if self._kappa is None:
        self._kappa = condition_number(self.jinv)
    return self._kappa


def _set_kappa(self: PoseEvaluation, value: np.ndarray | None) -> None:
    self._kappa = None if value is None else np.asarray(value, dtype=float)


# the dataclass field ``kappa`` (kept in the constructor, ``dataclasses.replace`` and ``fields``) is stored
# behind a property so that it can be computed on first access
PoseEvaluation.kappa = property(  # type: ignore[assignment]
    _get_kappa, _set_kappa, doc="(N,) condition number of J_C^-1, computed on first "
                                "access (relative accuracy 1e-4, inf where singular or unreachable)")


def _angle_dict(ja) -> dict[str, np.ndarray]:
    return {f"{side}_{qty}": getattr(getattr(ja, side), qty)
            for side in ("drive", "platform") for qty in ("swivel", "swivel_signed", "tilt", "tilt_axis", "tilt_normal")}


def evaluate_chunk(
    machine: Machine,
    poses: np.ndarray,
    checks: Sequence[str] = adm.ALL_CHECKS,
    drive_load_data: DriveLoadData | None = None,
    requirements: Iterable[Callable[["PoseEvaluation"], np.ndarray]] = (),
    *,
    _valid: bool = False,
) -> PoseEvaluation:
    """Evaluate one chunk of poses (see :func:`evaluate_poses`).

    ``_valid``: ``poses`` already passed :func:`pkmstiff.kinematics.as_poses` (internal).
    """
    unknown = set(checks) - set(adm.ALL_CHECKS)
    if unknown:
        raise ValueError(f"unknown admissibility checks {sorted(unknown)}; expected a subset of {adm.ALL_CHECKS}")
    checks = tuple(checks)
    if not _valid:
        poses = as_poses(poses)
    reqs = list(requirements)
    fast = _fast.evaluate_small(machine, poses, checks, drive_load_data) if _fast.usable(machine, len(poses)) else None
    if fast is not None:  # small N: one fused compiled kernel
        fields, reach = fast
        ev = PoseEvaluation(**fields, checks=checks)
        results = None
    else:
        ev, results = _evaluate_general(machine, poses, checks, drive_load_data)
        reach = ev.ik.all_reachable
    if reqs:
        ok = np.ones(len(poses), bool)
        for req in reqs:
            ok &= np.asarray(req(ev), bool)
        results = list(ev.admissibility.checks.values()) if results is None else results
        results.append(adm.CheckResult(ok, adm.Reason.REQUIREMENT))
        ev.admissibility = adm.combine(len(poses), results, reach)
    return ev


def admissible(machine: Machine, poses: np.ndarray, checks: Sequence[str],
               drive_load_data: DriveLoadData | None) -> np.ndarray:
    """(N,) admissibility of poses (N, 6), bit for bit the ``ok`` of :func:`evaluate_chunk` without requirements
    (tests/test_pose_fast_path.py), for searches that need nothing else: the fused kernel in calls of
    :data:`~pkmstiff.admissibility.fastpath.FUSED_CHUNK` poses, the array path for a call it declines (a pose that
    needs an exact κ). Call only where ``fastpath.usable(machine, 1)`` holds."""
    out = np.empty(len(poses), bool)
    step = _fast.FUSED_CHUNK
    for s in range(0, len(poses), step):
        x = np.ascontiguousarray(poses[s:s + step])
        ok = _fast.admissible_small(machine, x, checks, drive_load_data)
        out[s:s + len(x)] = ok if ok is not None else \
            evaluate_chunk(machine, x, checks, drive_load_data, _valid=True).admissibility.ok
    return out


def _evaluate_general(machine: Machine, poses: np.ndarray, checks: tuple[str, ...],
                      drive_load_data: DriveLoadData | None) -> tuple[PoseEvaluation, list[adm.CheckResult]]:
    """The array path of :func:`evaluate_chunk` (any N): the evaluation and its check results."""
    ik = inverse_kinematics(machine, poses)
    jinv = inverse_jacobian(machine, ik)
    jc, singular = jacobian_and_singular(machine, jinv)
    angles = _angle_dict(joint_angles(machine, ik))
    reach = ik.all_reachable

    results: list[adm.CheckResult] = []
    if "frame" in checks:
        results.append(adm.check_frame(machine, ik.poses[:, :3]))
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
        results.append(adm.check_singularity(machine, singular=singular))
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
    ev = PoseEvaluation(ik=ik, jinv=jinv, jc=jc, kappa=None, angles=angles,
                        admissibility=adm.combine(len(poses), results, reach), drive_loads=tau_g, checks=checks)
    return ev, results


def evaluate_poses(
    machine: Machine,
    poses: ArrayLike,
    checks: Sequence[str] = adm.ALL_CHECKS,
    drive_load_data: DriveLoadData | None | str = "auto",
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
        drive_load_data = _dld(machine)
    if not len(x):
        raise ValueError("evaluate_poses: expected at least one pose, found an empty array")
    if chunk_size < 1:
        raise ValueError(f"evaluate_poses: chunk_size must be a positive integer, found {chunk_size!r}")
    if len(x) <= chunk_size:
        return evaluate_chunk(machine, x, checks, drive_load_data, reqs, _valid=True)
    out: PoseEvaluation | None = None
    kappas: list[np.ndarray | None] = []
    for start in range(0, len(x), chunk_size):
        sl = slice(start, min(start + chunk_size, len(x)))
        ev = evaluate_chunk(machine, x[sl], checks, drive_load_data, reqs, _valid=True)
        if out is None:
            out = _allocate(ev, len(x))
        _put(out, sl, ev)
        kappas.append(ev._kappa)  # type: ignore[attr-defined]
    assert out is not None
    if all(k is not None for k in kappas):  # κ computed in every chunk (e.g. by a requirement): keep it
        out.kappa = np.concatenate(kappas)  # type: ignore[arg-type]
    return out


def _empty_for_poses(a: np.ndarray, n: int) -> np.ndarray:
    """Uninitialised array like ``a`` with n entries along the pose axis 0 and the same memory order of the axes.

    The kinematic arrays are views of component-first storage (pose axis last in memory); keeping that order
    makes filling them chunk by chunk a copy of contiguous rows (and ``jinv`` stays usable by
    :mod:`pkmstiff.kinematics` without a copy).
    """
    perm = [int(i) for i in np.argsort([-abs(st) for st in a.strides], kind="stable")]
    shape = [n if ax == 0 else a.shape[ax] for ax in perm]
    return np.empty(shape, a.dtype).transpose(np.argsort(perm))


def _allocate(first: PoseEvaluation, n: int) -> PoseEvaluation:
    """An evaluation of n poses with the structure of the chunk ``first`` and uninitialised arrays."""
    def like(a):
        return None if a is None else _empty_for_poses(a, n)

    checks = {key: adm.CheckResult(ok=like(c.ok), reason=c.reason, detail=like(c.detail), labels=c.labels,
                                   skipped=c.skipped)
              for key, c in first.admissibility.checks.items()}
    a = first.admissibility
    ik = IK(kind=first.ik.kind, **{name: like(getattr(first.ik, name)) for name in IK_ARRAYS})
    return PoseEvaluation(
        ik=ik, jinv=like(first.jinv), jc=like(first.jc), kappa=None,
        angles={k: like(v) for k, v in first.angles.items()},
        admissibility=adm.Admissibility(ok=like(a.ok), reasons=like(a.reasons), checks=checks),
        drive_loads=like(first.drive_loads), extra={k: like(v) for k, v in first.extra.items()},
        checks=first.checks)


def _put(out: PoseEvaluation, sl: slice, ev: PoseEvaluation) -> None:
    """Copy the evaluation of the chunk ``sl`` into ``out``."""
    for name in IK_ARRAYS:
        getattr(out.ik, name)[sl] = getattr(ev.ik, name)
    for name in ("jinv", "jc", "drive_loads"):
        dst = getattr(out, name)
        if dst is not None:
            dst[sl] = getattr(ev, name)
    for group_out, group_ev in ((out.angles, ev.angles), (out.extra, ev.extra)):
        for k, dst in group_out.items():
            dst[sl] = group_ev[k]
    out.admissibility.ok[sl] = ev.admissibility.ok
    out.admissibility.reasons[sl] = ev.admissibility.reasons
    for key, c in out.admissibility.checks.items():
        c.ok[sl] = ev.admissibility.checks[key].ok
        if c.detail is not None:
            c.detail[sl] = ev.admissibility.checks[key].detail


def check_admissibility(machine: Machine, poses: ArrayLike, **kw) -> adm.Admissibility:
    """Combined admissibility (mask, reason codes, per-check detail) of N poses; see :func:`evaluate_poses`."""
    return evaluate_poses(machine, poses, **kw).admissibility
