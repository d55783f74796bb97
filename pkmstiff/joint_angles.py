"""Swivel and tilt angles of the drive-side and platform-side joints (spec models.md §2, Cobet eq. 3.25–3.29).

Every joint has a first axis (drive side a_i, platform side m_i = R m'_i) and a swivel reference
vector (b_i, n_i = R n'_i).  With the joint-local strut direction u (decision (a)):

* swivel  φ = ∠(n, u_⊥), u_⊥ = m × (u × m)   ∈ [0, π]   (eq. 3.25/3.28; NaN if n ∥ m or u ∥ m)
* signed swivel φ_s = atan2(m̂ · (n × u_⊥), n · u_⊥) ∈ (−π, π]  (spec §2, optional variant)
* tilt, axis-referenced   ϑ_axis   = arccos(|m · u| / (|m||u|)) ∈ [0, π/2]   (zero: strut ∥ axis)
* tilt, normal-referenced ϑ_normal = arcsin(m · u / (|m||u|))    ∈ [−π/2, π/2] (zero: strut ⊥ axis)

``tilt`` holds the convention of each chain's joint type (decision (b)); both conventions are
always returned as well.  All angles in rad.  Limits (B.5, B.6) are checked in
:mod:`pkmstiff.admissibility`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .kinematics import IK, _cross_soa, _to_soa, _vec_soa
from .model import Machine

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
    """Joint angles of both sides (spec models.md §2)."""

    drive: SideAngles
    platform: SideAngles

    def for_admissibility(self) -> dict[str, tuple[Array, Array]]:
        """``{"drive": (swivel, tilt), "platform": (swivel, tilt)}`` as used by the joint-angle checks."""
        return {"drive": (self.drive.swivel, self.drive.tilt), "platform": (self.platform.swivel, self.platform.tilt)}


def _dot(u: Array, v: Array) -> Array:
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _norm(v: Array) -> Array:
    return np.sqrt(_dot(v, v))


def _side_angles(
    axis: Array, ref: Array, u: Array, axis0: Array, ref0: Array, normal: Array, tol: float, signed: bool
) -> SideAngles:
    """Angles of one side.  ``axis``, ``ref`` (3, n, N or 1) in the MKS, ``u`` (3, n, N) unit strut
    directions; ``axis0``, ``ref0`` (n, 3) the same vectors in their own frame (norms and the angle
    between them do not change under the rotation R)."""
    m_norm = np.linalg.norm(axis0, axis=1)[:, None]  # (n, 1)
    n_norm = np.linalg.norm(ref0, axis=1)[:, None]
    ref_par = (np.linalg.norm(np.cross(ref0, axis0), axis=1)[:, None] <= tol * n_norm * m_norm)  # n ∥ m
    mu = _dot(axis, u)
    mxu = _norm(_cross_soa(axis, u))  # |m × u| = |m| sin∠(m, u), |u| = 1
    # atan2 forms equal the arccos/arcsin of spec §2 but stay accurate near 0 and 90 deg
    tilt_axis = np.arctan2(mxu, np.abs(mu))
    tilt_normal = np.copysign(0.5 * np.pi - tilt_axis, mu)  # = arcsin(m·u / |m|)
    u_perp = u * (m_norm * m_norm) - axis * mu  # m × (u × m)
    nu = _dot(ref, u_perp)
    nxu = _cross_soa(ref, u_perp)
    undefined = ref_par | (mxu <= tol * m_norm)  # |u_⊥| = |m| |m × u| = 0: strut along the axis
    swivel = np.where(undefined, np.nan, np.arctan2(_norm(nxu), nu))  # ∠(n, u_⊥) in [0, π]
    swivel_signed = None
    if signed:
        swivel_signed = np.where(undefined, np.nan, np.arctan2(_dot(axis, nxu) / m_norm, nu))
    tilt = np.where(normal[:, None], tilt_normal, tilt_axis)
    return SideAngles(
        swivel=swivel.T,
        tilt=tilt.T,
        tilt_axis=tilt_axis.T,
        tilt_normal=tilt_normal.T,
        normal=normal,
        swivel_signed=None if swivel_signed is None else swivel_signed.T,
    )


def joint_angles(machine: Machine, ik: IK, signed: bool = True, parallel_tol: float = PARALLEL_TOL) -> JointAngles:
    """Swivel and tilt angles (rad) of all drive-side and platform-side joints for the poses of ``ik``.

    Strut direction per joint type (``strut_direction``, spec §2 decision (a)): ``"outward"``
    (default) uses u = +d̂ at the drive joint and u = −d̂ at the platform joint;
    ``"drive_to_platform"`` uses u = +d̂ at both.  Note: the dissertation does not fix the sign; the
    outward convention is the spec's interpretation (it makes the 6X swivel angles small at the
    workspace centre).  Platform vectors rotate with the platform, m = R m', n = R n' (eq. 3.26).
    The swivel angle is NaN where undefined: reference ∥ axis (|n × m| ≤ tol |n||m|, e.g. the
    Hexaglide drive joints with b = ±a) or strut ∥ axis (|u × m| ≤ tol |m|).  Chains that are
    unreachable give NaN throughout.  ``signed=False`` skips the signed swivel angle (``None``; ~10 % faster).
    """
    ch = machine.chains
    d = _vec_soa(ik.d)  # (3, n, N)
    with np.errstate(invalid="ignore", divide="ignore"):
        dhat = d / _norm(d)[None]
    R = _to_soa(ik.R, 2)  # (3, 3, N)
    sides = {}
    for side in ("drive", "platform"):
        jt = machine.joint_type_arrays(side)  # type: ignore[arg-type]
        if side == "drive":
            axis0, ref0 = ch.drive_axis, ch.drive_reference
            axis, ref = axis0.T[:, :, None], ref0.T[:, :, None]
            u = dhat
        else:
            axis0, ref0 = ch.platform_axis, ch.platform_reference
            axis = np.matmul(axis0[None], R)  # (3, n, N): m_i = R m'_i
            ref = np.matmul(ref0[None], R)
            u = dhat * np.where(jt["outward"], -1.0, 1.0)[None, :, None]
        normal = np.asarray(jt["normal"], dtype=bool)
        with np.errstate(invalid="ignore"):
            sides[side] = _side_angles(axis, ref, u, axis0, ref0, normal, parallel_tol, signed)
    return JointAngles(drive=sides["drive"], platform=sides["platform"])
