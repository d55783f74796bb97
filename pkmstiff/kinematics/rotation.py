"""Cardan angles, rotation matrices and small-rotation helpers, vectorised over poses.

Conventions (docs/theory/kinematics.md, Cobet eq. A.1–A.4): rotation ``a`` about x, then ``b`` about the
rotated y-axis, then ``c`` about the twice-rotated z-axis, :math:`R = R_a R_b R_c` (PKS → MKS).
All angles in rad.  Every function broadcasts over leading axes: angle arrays of shape ``S`` give
matrices of shape ``S + (3, 3)``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


def cardan_matrix(a: ArrayLike, b: ArrayLike, c: ArrayLike) -> Array:
    """Rotation matrix :math:`R = R_a R_b R_c` from Cardan angles a, b, c in rad (docs/theory/kinematics.md).

    Note (docs/theory/kinematics.md): the matrix printed as Cobet eq. A.5 equals R_x(c) R_y(b) R_z(a), i.e. it has a
    and c interchanged and contradicts eq. A.1–A.4; this function implements the product A.1·A.2·A.3.

    Returns an array of shape ``broadcast(a, b, c).shape + (3, 3)``.
    """
    a, b, c = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (a, b, c)))
    sa, ca = np.sin(a), np.cos(a)
    sb, cb = np.sin(b), np.cos(b)
    sc, cc = np.sin(c), np.cos(c)
    R = np.empty(a.shape + (3, 3))
    R[..., 0, 0] = cb * cc
    R[..., 0, 1] = -cb * sc
    R[..., 0, 2] = sb
    R[..., 1, 0] = sa * sb * cc + ca * sc
    R[..., 1, 1] = -sa * sb * sc + ca * cc
    R[..., 1, 2] = -sa * cb
    R[..., 2, 0] = -ca * sb * cc + sa * sc
    R[..., 2, 1] = ca * sb * sc + sa * cc
    R[..., 2, 2] = ca * cb
    return R


def cardan_angles(R: ArrayLike) -> Array:
    """Cardan angles (a, b, c) in rad of rotation matrices ``R`` (shape ``(..., 3, 3)``), docs/theory/kinematics.md.

    Inverse of :func:`cardan_matrix` for |b| < 90°: b = asin(R13), a = atan2(-R23, R33),
    c = atan2(-R12, R11).  ``b`` is evaluated as atan2(R13, hypot(R11, R12)), which equals asin(R13)
    for orthonormal R but stays accurate near |b| = 90°.  Returns shape ``(..., 3)``.
    """
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (3, 3):
        raise ValueError(f"cardan_angles: expected an array of shape (..., 3, 3), found shape {R.shape}")
    out = np.empty(R.shape[:-2] + (3,))
    out[..., 0] = np.arctan2(-R[..., 1, 2], R[..., 2, 2])
    out[..., 1] = np.arctan2(R[..., 0, 2], np.hypot(R[..., 0, 0], R[..., 0, 1]))
    out[..., 2] = np.arctan2(-R[..., 0, 1], R[..., 0, 0])
    return out


def cardan_rate_matrix(a: ArrayLike, b: ArrayLike) -> Array:
    """Matrix E(a, b) with ω = E (ȧ, ḃ, ċ)ᵀ (angular velocity in the MKS), docs/theory/kinematics.md; det E = cos b."""
    a, b = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    sa, ca = np.sin(a), np.cos(a)
    sb, cb = np.sin(b), np.cos(b)
    E = np.zeros(a.shape + (3, 3))
    E[..., 0, 0] = 1.0
    E[..., 0, 2] = sb
    E[..., 1, 1] = ca
    E[..., 1, 2] = -sa * cb
    E[..., 2, 1] = sa
    E[..., 2, 2] = ca * cb
    return E


def skew(v: ArrayLike) -> Array:
    """Skew matrix [v]× with [v]× u = v × u; ``v`` of shape ``(..., 3)`` gives ``(..., 3, 3)``."""
    v = np.asarray(v, dtype=float)
    if v.shape[-1:] != (3,):
        raise ValueError(f"skew: expected an array of shape (..., 3), found shape {v.shape}")
    S = np.zeros(v.shape + (3,))
    S[..., 0, 1] = -v[..., 2]
    S[..., 0, 2] = v[..., 1]
    S[..., 1, 0] = v[..., 2]
    S[..., 1, 2] = -v[..., 0]
    S[..., 2, 0] = -v[..., 1]
    S[..., 2, 1] = v[..., 0]
    return S


def rotation_from_axis_angle(w: ArrayLike) -> Array:
    """Rotation matrix exp([w]×) of the rotation vector ``w`` (axis · angle in rad), shape ``(..., 3)``.

    Rodrigues' formula R = I + (sin θ/θ) K + ((1 − cos θ)/θ²) K², K = [w]×, θ = |w|, with both
    coefficients written through ``np.sinc`` so that θ → 0 (finite-difference steps) is exact.
    """
    w = np.asarray(w, dtype=float)
    K = skew(w)
    theta = np.linalg.norm(w, axis=-1)
    s1 = np.sinc(theta / np.pi)  # sin θ / θ
    s2 = 0.5 * np.sinc(theta / (2.0 * np.pi)) ** 2  # (1 - cos θ) / θ²  = 2 sin²(θ/2) / θ²
    return np.eye(3) + s1[..., None, None] * K + s2[..., None, None] * (K @ K)
