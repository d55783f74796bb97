"""Swivel and tilt angles of the drive-side and platform-side joints (docs/theory/kinematics.md, Cobet eq. 3.25–3.29).

Every joint has a first axis (drive side a_i, platform side m_i = R m'_i) and a swivel reference
vector (b_i, n_i = R n'_i).  With the joint-local strut direction u (decision (a)):

* swivel  φ = ∠(n, u_⊥), u_⊥ = m × (u × m)   ∈ [0, π]   (eq. 3.25/3.28; NaN if n ∥ m or u ∥ m)
* signed swivel φ_s = atan2(m̂ · (n × u_⊥), n · u_⊥) ∈ (−π, π]  (docs/theory/kinematics.md, optional variant)
* tilt, axis-referenced   ϑ_axis   = arccos(|m · u| / (|m||u|)) ∈ [0, π/2]   (zero: strut ∥ axis)
* tilt, normal-referenced ϑ_normal = arcsin(m · u / (|m||u|))    ∈ [−π/2, π/2] (zero: strut ⊥ axis)

``tilt`` holds the convention of each chain's joint type (decision (b)); both conventions are
always returned as well.  All angles in rad.  Limits (B.5, B.6) are checked in
:mod:`pkmstiff.admissibility.checks`.  The per-joint arithmetic is one compiled loop per side
(:func:`pkmstiff.kinematics.kernels.side_angles`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pkmstiff.kinematics import dispatch as _dispatch
from pkmstiff.kinematics.arrays import _to_soa, _vec_soa
from pkmstiff.kinematics.inverse import IK
from pkmstiff.machine.model import Machine

Array = NDArray[np.float64]

#: sine of the angle below which two vectors count as parallel (swivel angle undefined)
PARALLEL_TOL = 1e-9


@dataclass(frozen=True)
class SideAngles:
    """Joint angles of one side (drive or platform) for N poses and n chains, arrays (N, n) in rad."""

    swivel: Array  #: unsigned swivel φ ∈ [0, π]; NaN where undefined (n ∥ m or u ∥ m) or unreachable
    tilt: Array  #: tilt in the convention of the chain's joint type
    tilt_axis: Array  #: axis-referenced tilt ∈ [0, π/2]
    tilt_normal: Array  #: normal-referenced (signed) tilt ∈ [−π/2, π/2]
    normal: Array  #: (n,) bool, True where the joint type is normal-referenced
    swivel_signed: Array | None = None  #: signed swivel ∈ (−π, π] about m̂ (None with ``signed=False``)


@dataclass(frozen=True)
class JointAngles:
    """Joint angles of both sides (docs/theory/kinematics.md)."""

    drive: SideAngles
    platform: SideAngles

    def for_admissibility(self) -> dict[str, tuple[Array, Array]]:
        """``{"drive": (swivel, tilt), "platform": (swivel, tilt)}`` as used by the joint-angle checks."""
        return {"drive": (self.drive.swivel, self.drive.tilt), "platform": (self.platform.swivel, self.platform.tilt)}


def _ref_parallel(axis0: Array, ref0: Array, tol: float) -> Array:
    """(n,) bool: swivel reference ∥ joint axis, |n × m| ≤ tol |n||m| (swivel undefined); ``axis0``, ``ref0`` (n, 3).

    Norms and the angle between them do not change under the rotation R, so the test needs no pose."""
    m_norm = np.linalg.norm(axis0, axis=1)
    n_norm = np.linalg.norm(ref0, axis=1)
    # the cross product written out (same arithmetic as np.cross, without its per-call overhead on (n, 3) arrays)
    cross = ref0[:, [1, 2, 0]] * axis0[:, [2, 0, 1]] - ref0[:, [2, 0, 1]] * axis0[:, [1, 2, 0]]
    return np.linalg.norm(cross, axis=1) <= tol * n_norm * m_norm


def _side_angles(
    d: Array, R: Array, axis0: Array, ref0: Array, rotate: bool, sign: Array, normal: Array, tol: float, signed: bool
) -> SideAngles:
    """Angles of one side from the strut vectors ``d`` (3, n, N) and rotations ``R`` (3, 3, N), component-first;
    ``axis0``, ``ref0`` (n, 3) the joint axis and swivel reference in their own frame (rotated by R if
    ``rotate``); u = sign_i d̂.  The per-pose arithmetic runs in :func:`pkmstiff.kinematics.kernels.side_angles`."""
    n, N = d.shape[1], d.shape[2]
    ref_par = _ref_parallel(axis0, ref0, tol)
    out = np.empty((5 if signed else 4, n, N))
    swivel, tilt, tilt_axis, tilt_normal = out[0], out[1], out[2], out[3]
    swivel_signed = out[4] if signed else out[0]  # not written unless ``signed``
    _dispatch.run("side_angles", N, d, R, np.ascontiguousarray(axis0, dtype=np.float64),
                         np.ascontiguousarray(ref0, dtype=np.float64), rotate,
                         np.ascontiguousarray(sign, dtype=np.float64), np.ascontiguousarray(normal, dtype=np.bool_),
                         np.ascontiguousarray(ref_par, dtype=np.bool_), float(tol), signed,
                         swivel, swivel_signed, tilt, tilt_axis, tilt_normal)
    return SideAngles(
        swivel=swivel.T,
        tilt=tilt.T,
        tilt_axis=tilt_axis.T,
        tilt_normal=tilt_normal.T,
        normal=normal,
        swivel_signed=swivel_signed.T if signed else None,
    )


def joint_angles(machine: Machine, ik: IK, signed: bool = True, parallel_tol: float = PARALLEL_TOL) -> JointAngles:
    """Swivel and tilt angles (rad) of all drive-side and platform-side joints for the poses of ``ik``.

    Strut direction per joint type (``strut_direction``, docs/theory/kinematics.md decision (a)): ``"outward"``
    (default) uses u = +d̂ at the drive joint and u = −d̂ at the platform joint;
    ``"drive_to_platform"`` uses u = +d̂ at both.  Note: the dissertation does not fix the sign; the
    outward convention is the spec's interpretation (it makes the 6X swivel angles small at the
    workspace centre).  Platform vectors rotate with the platform, m = R m', n = R n' (eq. 3.26).
    The swivel angle is NaN where undefined: reference ∥ axis (|n × m| ≤ tol |n||m|, e.g. the
    Hexaglide drive joints with b = ±a) or strut ∥ axis (|u × m| ≤ tol |m|).  Chains that are
    unreachable give NaN throughout.  ``signed=False`` skips the signed swivel angle (``None``; ~10 % faster).
    """
    ch = machine.chains
    d = np.require(_vec_soa(ik.d), dtype=np.float64, requirements=("C", "W"))  # (3, n, N), no copy for IK output
    R = np.require(_to_soa(ik.R, 2), dtype=np.float64, requirements=("C", "W"))  # (3, 3, N)
    sides = {}
    for side in ("drive", "platform"):
        jt = machine.joint_type_arrays(side)  # type: ignore[arg-type]
        normal = np.asarray(jt["normal"], dtype=bool)
        if side == "drive":
            sides[side] = _side_angles(d, R, ch.drive_axis, ch.drive_reference, False, np.ones(ch.n), normal,
                                       parallel_tol, signed)
        else:
            sign = np.where(jt["outward"], -1.0, 1.0) * np.ones(ch.n)
            sides[side] = _side_angles(d, R, ch.platform_axis, ch.platform_reference, True, sign, normal,
                                       parallel_tol, signed)
    return JointAngles(drive=sides["drive"], platform=sides["platform"])


def joint_angles_along(u: Array, R: Array | None, axis0: Array, ref0: Array, normal: bool,
                       parallel_tol: float = PARALLEL_TOL) -> tuple[Array, Array]:
    """Tilt (in the joint's convention: normal-referenced if ``normal``) and unsigned swivel (N,) in rad of one
    joint of a generic mechanism (:mod:`pkmstiff.mechanisms.elastic`): axis ``axis0`` and swivel reference
    ``ref0`` (3,) on the joint's link, rotated by that link's ``R`` (N, 3, 3) (None: a link that does not rotate),
    strut directions ``u`` (N, 3) from the joint into the strut. The same arithmetic as :func:`joint_angles`
    (eq. 3.25–3.29, :func:`pkmstiff.kinematics.kernels.side_angles`)."""
    n_p = u.shape[0]
    d = np.ascontiguousarray(np.asarray(u, float).T[:, None, :])  # (3, 1, N)
    rot = np.broadcast_to(np.eye(3), (n_p, 3, 3)) if R is None else R
    side = _side_angles(d, np.ascontiguousarray(_to_soa(np.asarray(rot, float), 2)), np.asarray(axis0, float)[None],
                        np.asarray(ref0, float)[None], R is not None, np.ones(1), np.array([normal]), parallel_tol,
                        False)
    return side.tilt[:, 0], side.swivel[:, 0]
