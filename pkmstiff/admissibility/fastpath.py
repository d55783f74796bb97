"""Small-N fast path of the pose pipeline: a few poses through one fused compiled kernel (issue 12 item 6).

:func:`pkmstiff.admissibility.pipeline.evaluate_chunk` spends ~0.8 ms on one pose in ~1,100 Python calls and ~150
numpy operations on tiny arrays (inverse kinematics, J_C^-1, QR, joint angles, each check, combining them). For
N ≤ :data:`SMALL_N` poses, once the process runs the compiled kernels (:mod:`pkmstiff.kinematics.dispatch`), this
module does the same work in two compiled calls (:func:`pkmstiff.kinematics.kernels.cardan_soa`,
:func:`pkmstiff.kinematics.kernels.evaluate_small`) around the one BLAS product R p'_i, with every per-machine
constant prepared once and kept on the machine object. The kernel repeats the arithmetic of the array code
operation by operation and calls the general path's kernels (QR, joint angles, collisions) unchanged, so both
paths give the same numbers (tests/test_pose_fast_path.py). Rare cases (κ bounds straddling the singularity
threshold, which need an exact κ by SVD) are handed back to the general path.
"""

from __future__ import annotations

import os
import sys
from typing import Any, Sequence

import numpy as np

import pkmstiff.admissibility.checks as adm
from pkmstiff.kinematics.inverse import IK
from pkmstiff.kinematics.joint_angles import PARALLEL_TOL, _ref_parallel
from pkmstiff.machine.model import Machine, memo
from pkmstiff.machine.roles import DriveLoadData

#: largest number of poses that takes the fused kernel (the general path's array code wins for large batches)
SMALL_N = 64
#: poses per call of the fused kernel where a caller needs only the admissibility (rotation-map searches, workspace
#: octrees): it costs ~0.1 ms per call and ~2.6 us per pose against ~1 ms and ~3.2 us of the array path (measured on
#: the Hexaglide, 100-2000 poses), and most of their batches hold a few hundred poses. A call's buffers (~1.7 kB per
#: pose) stay in a core's cache up to about this many: per pose, calls of 256-1024 poses took 3.4-3.5 us, of 4096
#: poses 4.3 us (random Hexaglide poses on the 2-core machine)
FUSED_CHUNK = 1024

_R = adm.Reason
#: the checks of the kernel's ``ok_rows`` in row order, with the ``checks`` name that enables each
_ROWS = (("frame", _R.FRAME), ("drive_range", _R.DRIVE_RANGE), ("drive_spacing", _R.DRIVE_SPACING),
         ("joint_angles", _R.JOINT_ANGLE), ("joint_angles", _R.INA_LIMIT), ("singularity", _R.SINGULAR),
         ("strut_collision", _R.STRUT_COLLISION), ("platform_collision", _R.PLATFORM_COLLISION),
         ("drive_load", _R.DRIVE_LOAD))
_ANGLE_KEYS = tuple((f"{side}_{qty}", s, row) for s, side in enumerate(("drive", "platform"))
                    for qty, row in (("swivel", 0), ("swivel_signed", 4), ("tilt", 1), ("tilt_axis", 2),
                                     ("tilt_normal", 3)))
_NO_LOAD = np.zeros((0, 3))


def compiled_active() -> bool:
    """True if the process runs the compiled kernels (without counting poses towards the switch)."""
    mode = os.environ.get("PKMSTIFF_JIT", "")
    if mode == "1":
        return True
    return mode != "0" and "pkmstiff.kinematics.kernels" in sys.modules


class _Constants:
    """Per-machine arrays of the fused kernel (built once, kept on the machine object)."""

    def __init__(self, machine: Machine) -> None:
        ch = machine.chains
        n = ch.n
        glide = ch.kind == "glide"
        self.glide = glide
        self.n = n
        f64 = np.float64
        cf = np.zeros((n, 10))
        if glide:
            cf[:, 0:3] = ch.guide_direction
            cf[:, 3:6] = ch.guide_start + ch.drive_joint
            cf[:, 6] = np.einsum("ik,ik->i", ch.guide_direction, ch.guide_direction)
            cf[:, 7] = ch.strut_length ** 2
            cf[:, 8] = ch.strut_length
            cf[:, 9] = np.broadcast_to(ch.guide_length, (n,))
        else:
            cf[:, 3:6] = ch.drive_joint
            cf[:, 8] = np.broadcast_to(ch.length_min, (n,))
            cf[:, 9] = np.broadcast_to(ch.length_max, (n,))
        self.cf = cf
        self.croot = np.where(np.asarray(ch.larger_root, dtype=bool), 1.0, -1.0) * np.ones(n)
        off = ch.drive_offset
        self.has_off = bool(off is not None and np.any(off != 0.0))
        self.off = np.ascontiguousarray(off if self.has_off else np.zeros(n), dtype=f64)
        self.pj = np.ascontiguousarray(ch.platform_joint, dtype=f64)
        self.pj3 = self.pj[None]
        # joint angles (pkmstiff.kinematics.joint_angles.joint_angles) and their limits (checks.check_joint_angles)
        side = {}
        jlim = np.zeros((5, 2 * n))
        for s, name in enumerate(("drive", "platform")):
            jt = machine.joint_type_arrays(name)  # type: ignore[arg-type]
            axis0, ref0 = (ch.drive_axis, ch.drive_reference) if s == 0 else (ch.platform_axis, ch.platform_reference)
            sign = np.ones(n) if s == 0 else np.where(jt["outward"], -1.0, 1.0) * np.ones(n)
            side[name] = (np.ascontiguousarray(axis0, dtype=f64), np.ascontiguousarray(ref0, dtype=f64),
                          np.ascontiguousarray(sign, dtype=f64), np.ascontiguousarray(jt["normal"], dtype=np.bool_),
                          np.ascontiguousarray(_ref_parallel(axis0, ref0, PARALLEL_TOL), dtype=np.bool_))
            cols = slice(s * n, (s + 1) * n)
            for r, key in enumerate(("tilt_min", "tilt_max", "swivel_min", "swivel_max", "ina_coupled")):
                jlim[r, cols] = jt[key]
        self.side = side
        self.jlim = jlim
        self.ina75 = float(np.deg2rad(75.0))
        self.joint_labels = [f"{s} joint {i + 1}" for s in ("drive", "platform") for i in range(n)]
        # frame
        lim = machine.limits
        self.frame_skipped = bool(np.all(np.isinf(lim.position_min)) and np.all(np.isinf(lim.position_max)))
        self.frame_lim = np.array([np.broadcast_to(lim.position_min, (3,)), np.broadcast_to(lim.position_max, (3,))],
                                  dtype=f64)
        self.chain_labels = [f"chain {i + 1}" for i in range(n)]
        # drive spacing
        pairs = [(g.name, i, j, g) for g in machine.guides.values()
                 for k, i in enumerate(g.chains) for j in g.chains[k + 1:]]
        self.si = np.array([i for _, i, _, _ in pairs], dtype=np.int64)
        self.sj = np.array([j for _, _, j, _ in pairs], dtype=np.int64)
        self.space_lim = np.array([[g.min_distance + g.safety_margin for *_, g in pairs],
                                   [g.max_distance - g.safety_margin for *_, g in pairs]], dtype=f64).reshape(2, -1)
        self.space_labels = [f"{name}: drives {i + 1}-{j + 1}" for name, i, j, _ in pairs]
        # strut collision (checks.check_strut_collision)
        cpairs = adm._collision_pairs(ch)
        self.ii = np.array([a for a, _ in cpairs], dtype=np.int64)
        self.jj = np.array([b for _, b in cpairs], dtype=np.int64)
        self.rsum = np.ascontiguousarray(ch.strut_radius[self.ii] + ch.strut_radius[self.jj], dtype=f64)
        self.table_b2 = lim.strut_collision_mode == "table_B2"
        self.strut_labels = [f"struts {a + 1}-{b + 1}" for a, b in cpairs]
        # platform collision (checks.check_platform_collision)
        self.has_hull = not machine.hull.empty
        if self.has_hull:
            hc = adm._hull_cache(machine)
            self.hull = (hc.normals, hc.offsets, hc.tri, hc.edges)
        else:
            self.hull = (np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3, 3)), np.zeros((0, 2, 3)))
        excl = ch.strut_radius if lim.platform_end_exclusion is None else np.full(n, lim.platform_end_exclusion)
        self.excl = np.ascontiguousarray(excl, dtype=f64)
        self.radius = np.ascontiguousarray(ch.strut_radius, dtype=f64)
        self.convex = bool(machine.hull.convex) if self.has_hull else False
        self.strut1_labels = [f"strut {i + 1}" for i in range(n)]
        self.drive_labels = [f"drive {i + 1}" for i in range(n)]
        self.thr = float(lim.singularity_threshold)
        self.include_coulomb = bool(lim.drive_load_include_coulomb)
        self.gravity = machine.gravity
        self.load_key: Any = None
        self._active: dict[tuple[tuple[str, ...], bool], np.ndarray] = {}
        self.load: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def active(self, checks: Sequence[str], has_load: bool) -> np.ndarray:
        """(9,) int64: the reason bit of each row of ``ok_rows`` that counts (requested, not skipped), else 0."""
        key = (tuple(checks), has_load)
        hit = self._active.get(key)
        if hit is None:
            skipped = (self.frame_skipped, False, self.si.shape[0] == 0, False, False, False, self.ii.shape[0] == 0,
                       not self.has_hull, not has_load)
            hit = np.array([int(reason) if name in checks and not skipped[r] else 0
                            for r, (name, reason) in enumerate(_ROWS)], dtype=np.int64)
            self._active[key] = hit
        return hit

    def load_arrays(self, data: DriveLoadData) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(force (3,), CoG offset (3,), available force (n,)) of checks.static_drive_loads / check_drive_load."""
        if self.load_key is not data:
            force = -data.moved_mass * self.gravity
            avail = data.max_force - data.force_reserve - (data.coulomb if self.include_coulomb else 0.0)
            self.load = (np.ascontiguousarray(force, dtype=np.float64), data.cog_offset,
                         np.ascontiguousarray(np.broadcast_to(avail, (self.n,)), dtype=np.float64))
            self.load_key = data
        return self.load  # type: ignore[return-value]


def _constants(machine: Machine) -> _Constants:
    return memo(machine, "_fastpath_constants", lambda: _Constants(machine))


def usable(machine: Machine, n_poses: int) -> bool:
    """Whether :func:`evaluate_small` may take ``n_poses`` poses of ``machine`` (else: the general path)."""
    ch = machine.chains
    return (0 < n_poses <= SMALL_N and compiled_active() and ch.kind in ("glide", "pod") and ch.n == 6
            and machine.limits.strut_collision_mode in ("exact", "table_B2"))


def admissible_small(machine: Machine, x: np.ndarray, checks: Sequence[str],
                     drive_load_data: DriveLoadData | None) -> np.ndarray | None:
    """Only ``admissibility.ok`` of :func:`evaluate_small` (N,), without the other fields (for searches that need
    nothing else); None where the general path must run."""
    r = reasons_small(machine, x, checks, drive_load_data)
    return None if r is None else r == 0


def reasons_small(machine: Machine, x: np.ndarray, checks: Sequence[str],
                  drive_load_data: DriveLoadData | None) -> np.ndarray | None:
    """Only ``admissibility.reasons`` of :func:`evaluate_small` (N,) uint32; None where the general path must run."""
    run = _run(machine, x, checks, drive_load_data)
    return None if run is None else run[14]


def _run(machine: Machine, x: np.ndarray, checks: Sequence[str], drive_load_data: DriveLoadData | None
         ) -> tuple | None:
    """The fused kernel over poses ``x`` (N, 6): (constants, N, strut pairs, then its output arrays as
    :func:`evaluate_small` unpacks them, the reasons 15th), or None where a pose needs an exact κ."""
    from pkmstiff.kinematics import kernels as K

    c = _constants(machine)
    n = c.n
    N = x.shape[0]
    pt = np.ascontiguousarray(x.T)
    rot = np.empty((3, 3, N))
    K.cardan_soa(pt, rot)
    rho = np.matmul(c.pj3, rot)  # (3, n, N): the BLAS product of pkmstiff.kinematics.inverse._ik_soa
    rot_aos = rot.transpose(2, 0, 1)
    if drive_load_data is not None:
        force, cog, avail = c.load_arrays(drive_load_data)
        rho_cog = np.ascontiguousarray(np.einsum("nij,j->ni", rot_aos, cog))  # as checks.static_drive_loads
        has_load = True
    else:
        force, rho_cog, avail, has_load = c.radius, _NO_LOAD, c.radius, False
    fbuf = np.empty((3 * 3 + 2) * n * N)
    pqd = fbuf[:9 * n * N].reshape(3, 3, n, N)
    ld = fbuf[9 * n * N:].reshape(2, n, N)
    reach = np.empty((n, N), dtype=np.bool_)
    jac = np.empty((n, 6, N))
    jc = np.empty((N, n, n))
    bounds = np.empty((2, N))
    ang = np.empty((2, 5, n, N))
    n_pairs = c.ii.shape[0]
    bbuf = np.empty(N * (3 + n + c.si.shape[0] + 4 * n + n_pairs + n + n), dtype=np.bool_)
    widths = (3, n, c.si.shape[0], 2 * n, 2 * n, n_pairs, n)
    bad = []
    start = 0
    for w in widths:
        bad.append(bbuf[start:start + N * w].reshape(N, w))
        start += N * w
    load_bad = bbuf[start:].reshape(N, n)
    tau = np.empty((N, n))
    ok_rows = np.empty((9, N), dtype=np.bool_)
    reasons = np.empty(N, dtype=np.uint32)
    active = c.active(checks, has_load)
    sd, sp = c.side["drive"], c.side["platform"]
    n_amb = K.evaluate_small(
        pt, rot, rho, c.glide, c.cf, c.croot, c.off, c.has_off,
        pqd[0], pqd[1], pqd[2], ld[0], ld[1], reach, jac, jc, bounds[0], bounds[1],
        sd[0], sd[1], sd[2], sd[3], sd[4], sp[0], sp[1], sp[2], sp[3], sp[4], PARALLEL_TOL,
        ang[0], ang[1], c.jlim, c.ina75, c.frame_lim, c.si, c.sj, c.space_lim, c.ii, c.jj, c.rsum, c.table_b2,
        c.pj, c.excl, c.radius, *c.hull, c.convex, c.has_hull,
        force, rho_cog, avail, has_load, c.thr, active,
        *bad, tau, load_bad, ok_rows, reasons)
    if n_amb:
        return None
    return c, N, n_pairs, rot, rho, pqd, ld, reach, jac, jc, bad, tau, load_bad, ok_rows, reasons, ang, has_load


def evaluate_small(machine: Machine, x: np.ndarray, checks: Sequence[str],
                   drive_load_data: DriveLoadData | None) -> tuple[dict[str, Any], np.ndarray] | None:
    """The fields of :class:`pkmstiff.admissibility.pipeline.PoseEvaluation` (the inverse kinematics included, as
    views of the kernel's outputs) for poses ``x`` (N, 6) and the (N,)
    reachability of the poses, or None where the general path must run (a pose needs an exact κ). Call only where
    :func:`usable` holds."""
    run = _run(machine, x, checks, drive_load_data)
    if run is None:
        return None
    c, N, n_pairs, rot, rho, pqd, ld, reach, jac, jc, bad, tau, load_bad, ok_rows, reasons, ang, has_load = run
    rot_aos = rot.transpose(2, 0, 1)
    frame_bad, range_bad, space_bad, lim_bad, ina_bad, strut_bad, plat_bad = bad
    CR = adm.CheckResult
    results: dict[str, adm.CheckResult] = {}
    if "frame" in checks:
        results["frame"] = (CR(np.ones(N, bool), _R.FRAME, skipped="no frame limits in the machine file")
                            if c.frame_skipped else CR(ok_rows[0], _R.FRAME, frame_bad, ["x", "y", "z"]))
    if "drive_range" in checks:
        results["drive_range"] = CR(ok_rows[1], _R.DRIVE_RANGE, range_bad, c.chain_labels)
    if "drive_spacing" in checks:
        results["drive_spacing"] = (CR(ok_rows[2], _R.DRIVE_SPACING, space_bad, c.space_labels) if c.si.shape[0]
                                    else CR(np.ones(N, bool), _R.DRIVE_SPACING, skipped="no shared guides"))
    if "joint_angles" in checks:
        results["joint_angle"] = CR(ok_rows[3], _R.JOINT_ANGLE, lim_bad, c.joint_labels)
        results["ina_limit"] = CR(ok_rows[4], _R.INA_LIMIT, ina_bad, c.joint_labels)
    if "singularity" in checks:
        results["singular"] = CR(ok_rows[5], _R.SINGULAR)
    if "strut_collision" in checks:
        results["strut_collision"] = (CR(ok_rows[6], _R.STRUT_COLLISION, strut_bad, c.strut_labels) if n_pairs
                                      else CR(np.ones(N, bool), _R.STRUT_COLLISION, skipped="no strut pairs"))
    if "platform_collision" in checks:
        results["platform_collision"] = (
            CR(ok_rows[7], _R.PLATFORM_COLLISION, plat_bad, c.strut1_labels) if c.has_hull
            else CR(np.ones(N, bool), _R.PLATFORM_COLLISION, skipped="machine has no platform hull"))
    if "drive_load" in checks:
        results["drive_load"] = (
            CR(ok_rows[8], _R.DRIVE_LOAD, load_bad, c.drive_labels) if has_load
            else CR(np.ones(N, bool), _R.DRIVE_LOAD,
                    skipped="no mass data (platform mass and drive force limits needed)"))
    angles = {key: ang[s, row].T for key, s, row in _ANGLE_KEYS}
    aos = pqd.transpose(0, 3, 2, 1)  # (3, N, n, 3) pose-first views, as pkmstiff.kinematics.arrays._vec_aos
    ik = IK._of(kind=machine.chains.kind, poses=x, R=rot_aos, rho=rho.transpose(2, 1, 0), p=aos[0], q=aos[1],
                d=aos[2], length=ld[0].T, drive=ld[1].T, reachable=reach.T)
    return dict(
        ik=ik, jinv=jac.transpose(2, 0, 1), jc=jc, kappa=None, angles=angles,
        admissibility=adm.Admissibility(ok=reasons == 0, reasons=reasons, checks=results),
        drive_loads=tau if has_load else None,
    ), reach.all(axis=0)
