"""Inverse kinematics of pod and glide machines for arrays of poses (docs/theory/kinematics.md, Cobet §1.2, §1.3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.kinematics.arrays import Array, KinematicsInputError, _to_soa, _vec_aos, as_poses
from pkmstiff.kinematics.rotation import cardan_angles, cardan_matrix
from pkmstiff.machine.model import Machine


@dataclass(frozen=True)
class IK:
    """Result of the inverse kinematics for N poses of a machine with n chains (docs/theory/kinematics.md).

    All lengths in m, angles in rad.  Entries of chains that cannot reach their guide (glide,
    negative discriminant) are NaN and ``reachable`` is False there.  The vector arrays are views of
    component-first storage; for pod machines ``q`` is a read-only broadcast of the fixed points.
    """

    kind: str  #: "pod" or "glide"
    poses: Array  #: (N, 6) x, y, z [m], a, b, c [rad]
    R: Array  #: (N, 3, 3) rotation PKS → MKS
    rho: Array  #: (N, n, 3) m, R p'_i (platform joint relative to O', MKS components)
    p: Array  #: (N, n, 3) m, platform-side joint points in the MKS
    q: Array  #: (N, n, 3) m, drive-side joint points in the MKS
    d: Array  #: (N, n, 3) m, strut vectors d_i = p_i − q_i
    length: Array  #: (N, n) m, strut lengths |d_i|
    drive: Array  #: (N, n) m, drive coordinates (glide: λ_i; pod: strut length l_i), minus ``chains.drive_offset``
    reachable: Array  #: (N, n) bool (glide: discriminant ≥ 0; pod: True)

    @property
    def n_poses(self) -> int:
        return int(self.poses.shape[0])

    @property
    def all_reachable(self) -> Array:
        """(N,) bool: every chain of the pose is reachable."""
        return self.reachable.all(axis=1)

    @property
    def unit_d(self) -> Array:
        """(N, n, 3) unit strut directions d̂_i (drive-side → platform-side joint)."""
        return self.d / self.length[..., None]

    @classmethod
    def _of(cls, **fields) -> IK:
        """The same object as ``IK(**fields)`` without the frozen dataclass's ``__init__`` (ten ``object.__setattr__``
        calls, ≈ 4 µs): for the small-N fast path (:mod:`pkmstiff.admissibility.fastpath`), where one pose takes
        ≈ 50 µs in all. Every field must be given."""
        ik = object.__new__(cls)
        ik.__dict__.update(fields)
        return ik

    def take(self, idx: ArrayLike) -> IK:
        """The result at the poses ``idx`` (boolean mask or index array over the N poses)."""
        return IK(kind=self.kind, **{name: getattr(self, name)[idx] for name in IK_ARRAYS})


#: the per-pose arrays of :class:`IK` (pose axis first)
IK_ARRAYS = ("poses", "R", "rho", "p", "q", "d", "length", "drive", "reachable")


def inverse_kinematics(machine: Machine, poses: ArrayLike) -> IK:
    """Inverse kinematics of N poses (docs/theory/kinematics.md pod, eq. A.6–A.8; §1.3 glide, eq. A.9–A.11).

    Glide chains use the root of the line–sphere intersection selected per chain by
    ``machine.chains.larger_root`` (default False = smaller root).  Never raises for unreachable
    poses: drive coordinate, q, d and length are NaN and ``reachable`` is False for such chains.
    """
    x = as_poses(poses)
    pt = np.ascontiguousarray(x.T)  # (6, N)
    R = cardan_matrix(pt[3], pt[4], pt[5])  # (N, 3, 3) view of (3, 3, N) storage
    return _ik_soa(machine, x, pt[:3], _to_soa(R, 2))


def inverse_kinematics_frames(machine: Machine, w: ArrayLike, R: ArrayLike) -> IK:
    """Inverse kinematics from the platform frame: origin ``w`` (N, 3) in m and rotation ``R`` (N, 3, 3).

    Used for finite differences with small rotations about the global axes (R ← exp([δω]×) R);
    ``IK.poses`` holds the Cardan angles of R (:func:`pkmstiff.kinematics.rotation.cardan_angles`).
    """
    w = np.atleast_2d(np.asarray(w, dtype=float))
    R = np.asarray(R, dtype=float)
    if R.ndim == 2:
        R = R[None]
    if w.ndim != 2 or w.shape[1] != 3 or R.shape != (w.shape[0], 3, 3):
        raise KinematicsInputError(
            f"inverse_kinematics_frames: expected w of shape (N, 3) [m] and R of shape (N, 3, 3), "
            f"found {w.shape} and {R.shape}"
        )
    if not (np.isfinite(w).all() and np.isfinite(R).all()):
        raise KinematicsInputError("inverse_kinematics_frames: expected finite w and R, found NaN/inf")
    x = np.concatenate([w, cardan_angles(R)], axis=1)
    return _ik_soa(machine, x, np.ascontiguousarray(w.T), _to_soa(R, 2))


def _ik_soa(machine: Machine, x: Array, w: Array, R: Array) -> IK:
    """IK core; w (3, N), R (3, 3, N) component-first."""
    ch = machine.chains
    N = w.shape[1]
    # rho[k, i, :] = sum_j R[k, j, :] p'_i[j]: one BLAS product (n, 3) @ (3, N) per row k of R
    rho = np.matmul(ch.platform_joint[None, :, :], R)  # (3, n, N)
    p = rho + w[:, None, :]
    if ch.kind == "glide":
        r = ch.guide_direction.T[:, :, None]  # (3, n, 1)
        base = (ch.guide_start + ch.drive_joint).T[:, :, None]  # s_i + q_off_i
        c = base - p  # (3, n, N)
        rr = np.einsum("ik,ik->i", ch.guide_direction, ch.guide_direction)[:, None]
        rc = r[0] * c[0] + r[1] * c[1] + r[2] * c[2]
        cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
        l2 = (ch.strut_length**2)[:, None]
        disc = rc * rc - rr * (cc - l2)
        reachable = disc >= 0.0
        with np.errstate(invalid="ignore"):
            root = np.sqrt(disc)  # NaN where unreachable, propagates into λ, q, d
        sign = np.where(np.asarray(ch.larger_root, dtype=bool), 1.0, -1.0)[:, None]
        lam = (-rc + sign * root) / rr
        q = base + lam[None] * r
        d = p - q
        length = np.where(reachable, ch.strut_length[:, None], np.nan)
        drive = lam
    elif ch.kind == "pod":
        q = np.broadcast_to(ch.drive_joint.T[:, :, None], (3, ch.n, N))
        d = p - q
        length = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        drive = length
        reachable = np.ones((ch.n, N), dtype=bool)
    else:
        raise KinematicsInputError(f"machine '{machine.name}': chains.kind must be 'pod' or 'glide', found {ch.kind!r}")
    off = ch.drive_offset
    if off is not None and np.any(off != 0.0):  # calibrated drive zero: controller coordinate = geometric - offset
        drive = drive - off[:, None]
    return IK(
        kind=ch.kind,
        poses=x,
        R=np.moveaxis(R, 2, 0),
        rho=_vec_aos(rho),
        p=_vec_aos(p),
        q=_vec_aos(q),
        d=_vec_aos(d),
        length=length.T,
        drive=drive.T,
        reachable=reachable.T,
    )
