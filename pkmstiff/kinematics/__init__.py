"""Inverse and forward kinematics, Jacobians, condition number, transmission quality (spec models.md §1, §6.1).

Poses are arrays of shape ``(N, 6)`` with columns x, y, z [m] (position of O' in the MKS) and the
Cardan angles a, b, c [rad] (:mod:`pkmstiff.kinematics.rotation`); a single pose of shape ``(6,)`` is accepted
and treated as ``N = 1`` (results keep the leading pose axis).

Array layout: results are exposed pose-first, e.g. ``IK.p`` has shape ``(N, n, 3)``.  Internally the
hot path works "component-first" (pose axis last, contiguous), because numpy evaluates long 1-D
operations much faster than many tiny 3×3 / 6×6 ones; the exposed arrays are transposed *views*
of that storage (not C-contiguous; call ``np.ascontiguousarray`` if a copy is needed).

The Householder QR of J_C⁻¹ behind J_C, the condition-number bounds and the singularity check runs per pose
in compiled code (:func:`pkmstiff.kinematics.kernels.qr_inverse`, reading the component-first storage directly); the
certified power iteration for κ stays vectorised numpy over the QR factors.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray

import pkmstiff.kinematics.kernels as _kernels
from pkmstiff.machine.model import Machine
from pkmstiff.kinematics.rotation import cardan_angles, cardan_matrix, cardan_rate_matrix

Array = NDArray[np.float64]

POSE_COLUMNS = ("x", "y", "z", "a", "b", "c")
POSE_UNITS = ("m", "m", "m", "rad", "rad", "rad")

#: default number of poses processed at once by the chunked 6×6 routines (bounds temporary memory:
#: a few dozen arrays of 36 × chunk float64, ≈ 10 MB at 4096)
DEFAULT_CHUNK = 4096


class KinematicsInputError(ValueError):
    """Invalid argument of a kinematics function; the message names the argument, expectation and finding."""


# ----------------------------------------------------------------------------------------------------------
# input handling
# ----------------------------------------------------------------------------------------------------------


def as_poses(poses: ArrayLike, name: str = "poses") -> Array:
    """Validate poses and return a float array of shape ``(N, 6)`` (a ``(6,)`` pose becomes ``(1, 6)``)."""
    try:
        arr = np.asarray(poses, dtype=float)
    except (TypeError, ValueError) as exc:
        raise KinematicsInputError(
            f"{name}: expected numbers of shape (6,) or (N, 6) [x, y, z in m, a, b, c in rad], found {poses!r}"
        ) from exc
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise KinematicsInputError(
            f"{name}: expected shape (6,) or (N, 6) [x, y, z in m, a, b, c in rad], found shape {np.shape(poses)}"
        )
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)
        raise KinematicsInputError(
            f"{name}: expected finite values, found NaN/inf in {rows.size} pose(s), first rows {rows[:5].tolist()}"
        )
    return arr


def chunk_slices(n: int, chunk_size: int = DEFAULT_CHUNK) -> Iterator[slice]:
    """Slices ``[0:c], [c:2c], …`` covering ``range(n)``, for processing many poses in bounded memory."""
    if chunk_size < 1:
        raise KinematicsInputError(f"chunk_size: expected a positive integer, found {chunk_size!r}")
    for start in range(0, n, chunk_size):
        yield slice(start, min(start + chunk_size, n))


def _cross_soa(u: Array, v: Array) -> Array:
    """Cross product of vectors stored component-first, shape ``(3, ...)``."""
    out = np.empty(np.broadcast_shapes(u.shape, v.shape))
    out[0] = u[1] * v[2] - u[2] * v[1]
    out[1] = u[2] * v[0] - u[0] * v[2]
    out[2] = u[0] * v[1] - u[1] * v[0]
    return out


def _to_soa(x: Array, axes_first: int) -> Array:
    """Move the pose axis (0) behind the ``axes_first`` trailing axes, contiguous (no copy if a view of such).

    Used for R (N, 3, 3) → (3, 3, N), jinv (N, n, 6) → (n, 6, N) and (N, n) → (n, N).
    """
    return np.ascontiguousarray(np.moveaxis(x, 0, axes_first))


def _vec_soa(x: Array) -> Array:
    """Per-chain vectors (N, n, 3) → component-first (3, n, N), contiguous (no copy if a view of such)."""
    return np.ascontiguousarray(np.transpose(x, (2, 1, 0)))


def _vec_aos(x: Array) -> Array:
    """Component-first (3, n, N) → pose-first view (N, n, 3)."""
    return np.transpose(x, (2, 1, 0))


# ----------------------------------------------------------------------------------------------------------
# inverse kinematics
# ----------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class IK:
    """Result of the inverse kinematics for N poses of a machine with n chains (spec §1.2, §1.3).

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


def inverse_kinematics(machine: Machine, poses: ArrayLike) -> IK:
    """Inverse kinematics of N poses (spec §1.2 pod, eq. A.6–A.8; §1.3 glide, eq. A.9–A.11).

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


# ----------------------------------------------------------------------------------------------------------
# Jacobians
# ----------------------------------------------------------------------------------------------------------


def inverse_jacobian(machine: Machine, ik: IK) -> Array:
    """Inverse kinematic Jacobian J_C⁻¹ (N, n, 6) in twist form, q̇ = J_C⁻¹ (v, ω) (spec §1.4).

    Row i: pod [d̂_iᵀ, (ρ_i × d̂_i)ᵀ]; glide [d_iᵀ, (ρ_i × d_i)ᵀ] / (d_i · r_i), with ρ_i = R p'_i and
    v, ω in MKS components (SI: columns 0–2 dimensionless, 3–5 in m/rad).  Rows of unreachable chains
    are NaN; a glide chain with d_i · r_i = 0 (singularity of the first kind) gives ±inf/NaN entries.
    """
    d = _vec_soa(ik.d)  # (3, n, N)
    rho = _vec_soa(ik.rho)
    n, N = d.shape[1], d.shape[2]
    if ik.kind == "glide":
        r = machine.chains.guide_direction.T[:, :, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = 1.0 / (d[0] * r[0] + d[1] * r[1] + d[2] * r[2])  # (n, N)
    else:
        scale = 1.0 / _to_soa(ik.length, 1)
    J = np.empty((n, 6, N))
    with np.errstate(invalid="ignore"):  # inf·0 at d·r = 0 gives NaN entries: the pose is singular anyway
        u = d * scale[None]
        J[:, 0:3, :] = u.transpose(1, 0, 2)
        J[:, 3:6, :] = _cross_soa(rho, u).transpose(1, 0, 2)
    return np.moveaxis(J, 2, 0)


def cardan_inverse_jacobian(jinv: Array, ik: IK) -> Array:
    """Cardan inverse Jacobian ∂q/∂(x, y, z, a, b, c) = J_C⁻¹ diag(I, E(a, b)) (Cobet eq. A.20, spec §1.4)."""
    E = cardan_rate_matrix(ik.poses[:, 3], ik.poses[:, 4])
    out = np.array(jinv, dtype=float, copy=True)
    out[:, :, 3:] = np.matmul(jinv[:, :, 3:], E)
    return out


def relative_inverse_jacobian(jinv: Array, ik: IK) -> Array:
    """Relative inverse Jacobian ∂q/∂(x, y, z, a', b', c') = J_C⁻¹ diag(I, R) (Cobet eq. A.21, spec §1.4).

    a', b', c' are infinitesimal rotations about the axes of the tool frame (PKS).
    """
    out = np.array(jinv, dtype=float, copy=True)
    out[:, :, 3:] = np.matmul(jinv[:, :, 3:], ik.R)
    return out


# ----------------------------------------------------------------------------------------------------------
# batched 6×6 linear algebra (component-first storage: matrices as (n, n, M), matrix axes first)
# ----------------------------------------------------------------------------------------------------------


def _dot_m(u: Array, v: Array) -> Array:
    """Dot products over the first axis: (n, M) · (n, M) → (M,)."""
    return np.einsum("im,im->m", u, v)


def _orthonormalise(Y: Array) -> Array:
    """Orthonormal basis of the vectors Y[0], Y[1], … (block (k, n, M), vector index first).

    Modified Gram–Schmidt applied twice ("twice is enough": orthogonal to working precision also
    for the nearly dependent vectors of power iterations).  Returns a new C-contiguous block.
    """
    X = np.array(Y, order="C", copy=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        for j in range(X.shape[0]):
            xj = X[j]
            for _ in range(2):
                for i in range(j):
                    xj -= _dot_m(X[i], xj) * X[i]
            xj /= np.sqrt(_dot_m(xj, xj))
    return X


_TH_KEYS = ("00", "01", "02", "11", "12", "22")  # upper-triangle entries of a symmetric 3×3 matrix
#: relative error allowance of the closed-form 3×3 eigenvalue (O(1e-8) at double roots)
_SYM3_SLACK = 1e-7


def _sym3_frob2(t: dict[str, Array]) -> Array:
    return t["00"] ** 2 + t["11"] ** 2 + t["22"] ** 2 + 2.0 * (t["01"] ** 2 + t["02"] ** 2 + t["12"] ** 2)


def _sym3_matvec(t: dict[str, Array], y: tuple[Array, Array, Array]) -> tuple[Array, Array, Array]:
    return (
        t["00"] * y[0] + t["01"] * y[1] + t["02"] * y[2],
        t["01"] * y[0] + t["11"] * y[1] + t["12"] * y[2],
        t["02"] * y[0] + t["12"] * y[1] + t["22"] * y[2],
    )


def _sym3_lambda_max(t: dict[str, Array]) -> Array:
    """Largest eigenvalue of symmetric 3×3 matrices given by their entries t["00"], t["01"], …

    Closed-form (trigonometric) solution; accurate to O(1e-16) relative for a simple largest
    eigenvalue and to O(1e-8) at a (near) double one, where the arccos is ill-conditioned.
    """
    a, b, c, d, e, f = t["00"], t["11"], t["22"], t["01"], t["02"], t["12"]
    q = (a + b + c) / 3.0
    a, b, c = a - q, b - q, c - q
    p = np.sqrt((a * a + b * b + c * c + 2.0 * (d * d + e * e + f * f)) / 6.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        det = a * (b * c - f * f) - d * (d * c - f * e) + e * (d * f - b * e)
        phi = np.arccos(np.clip(0.5 * det / (p * p * p), -1.0, 1.0)) / 3.0
    return np.where(p > 0.0, q + 2.0 * p * np.cos(phi), q)


def _sym3_top_vector(t: dict[str, Array], theta: Array) -> tuple[Array, Array, Array]:
    """Unit eigenvector estimate of symmetric 3×3 matrices for the eigenvalue ``theta``: the longest
    cross product of two rows of T − θI.  Only chooses a test vector; bounds built on it hold for any."""
    a, b, c = t["00"] - theta, t["11"] - theta, t["22"] - theta
    d, e, f = t["01"], t["02"], t["12"]
    c01 = (d * f - e * b, e * d - a * f, a * b - d * d)  # rows (a, d, e) × (d, b, f)
    c02 = (d * c - e * f, e * e - a * c, a * f - d * e)  # rows (a, d, e) × (e, f, c)
    c12 = (b * c - f * f, f * e - d * c, d * f - b * e)  # rows (d, b, f) × (e, f, c)
    n01, n02, n12 = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] for v in (c01, c02, c12))
    use02 = n02 > n01
    y = [np.where(use02, p, q) for p, q in zip(c02, c01)]
    n = np.maximum(n01, n02)
    use12 = n12 > n
    y = [np.where(use12, p, q) for p, q in zip(c12, y)]
    n = np.sqrt(np.maximum(n, n12))
    with np.errstate(divide="ignore", invalid="ignore"):
        ok = n > 0.0
        return np.where(ok, y[0] / n, 1.0), np.where(ok, y[1] / n, 0.0), np.where(ok, y[2] / n, 0.0)


def _lambda_max_bounds(G: Array, rtol: float, max_iter: int, step: int = 2) -> tuple[Array, Array]:
    """Certified bounds lo ≤ λ_max(G) ≤ hi for symmetric positive definite G (6, 6, M).

    Block power (subspace) iteration with three vectors from Y = G S, S = [e_k + 0.7 e_(k+3)]
    (translational and rotational columns mixed, k = 0, 1, 2), then Rayleigh–Ritz with the
    orthonormal basis X: Θ = XᵀGX, W = (GX)ᵀ(GX), residual block B = GX − XΘ with
    ‖B‖_F² = tr W − ‖Θ‖_F².  Lower bounds (Cauchy interlacing, Rayleigh quotient): θ1 = λ_max(Θ) and
    ρ = yᵀΘy for the test vector x = Xy (y ≈ top eigenvector of Θ).  Upper bounds from the Schur
    complement: if G = [[H, Eᵀ], [E, C]] in an orthonormal basis and λ1 = λ_max(G) ≥ λ_max(H) > λ_max(C),
    λ1 is an eigenvalue of H + Eᵀ(λ1 I − C)⁻¹E, so λ1 ≤ λ_max(H) + ‖E‖₂²/(λ_max(H) − λ_max(C)):

    * block bound (H = Θ, ‖E‖ ≤ ‖B‖_F, λ_max(C) ≤ ‖C‖_F = sqrt(‖G‖_F² − ‖Θ‖_F² − 2‖B‖_F²)); it holds
      up when the two or three largest eigenvalues are (nearly) equal, e.g. the translational
      directions of a symmetric hexapod; ‖B‖ decays like (λ4/λ3)^k;
    * single-vector bound (H = ρ, ‖E‖² = ‖Gx − ρx‖² = yᵀWy − ρ², Kato–Temple), λ_max(C) bounded by
      min(sqrt(‖G‖_F² − ρ² − 2‖E‖²), max(‖Θ⊥‖_F, ‖C‖_F) + ‖B‖_F) (Weyl; Θ⊥ = Θ compressed to y⊥);
      ‖E‖ decays like (λ4/λ1)^k.

    θ1 is computed in closed form, so the bounds built on it are widened by _SYM3_SLACK; all other
    quantities are exact up to rounding (O(1e-15) relative).  Works in rounds of ``step`` products
    with G (the start block is free) on the matrices not yet certified (hi ≤ lo (1 + rtol)), up to
    ``max_iter`` products; uncertified ones keep their last bounds (hi possibly inf).
    """
    M = G.shape[2]
    lo = np.zeros(M)
    hi = np.full(M, np.inf)
    frob2 = np.einsum("ijm,ijm->m", G, G)
    Y = G[:, :3].transpose(1, 0, 2) + 0.7 * G[:, 3:6].transpose(1, 0, 2)
    idx = np.arange(M)
    products = 1
    while True:
        for _ in range(step - 1):
            Y = np.einsum("ijm,kjm->kim", G, _orthonormalise(Y))
            products += 1
        X = _orthonormalise(Y)
        GX = np.einsum("ijm,kjm->kim", G, X)
        th = {k: _dot_m(X[int(k[0])], GX[int(k[1])]) for k in _TH_KEYS}
        w = {k: _dot_m(GX[int(k[0])], GX[int(k[1])]) for k in _TH_KEYS}
        th_f2 = _sym3_frob2(th)
        res2 = np.maximum(w["00"] + w["11"] + w["22"] - th_f2, 0.0)  # ‖B‖_F²
        mu_c = np.sqrt(np.maximum(frob2 - th_f2 - 2.0 * res2, 0.0))  # ≥ ‖C‖_F ≥ λ_max(C)
        theta = _sym3_lambda_max(th)
        th_lo, th_hi = theta * (1.0 - _SYM3_SLACK), theta * (1.0 + _SYM3_SLACK)
        y = _sym3_top_vector(th, theta)
        ty = _sym3_matvec(th, y)
        rho = y[0] * ty[0] + y[1] * ty[1] + y[2] * ty[2]
        wy = _sym3_matvec(w, y)
        r2 = np.maximum(y[0] * wy[0] + y[1] * wy[1] + y[2] * wy[2] - rho * rho, 0.0)
        ty2 = np.maximum(ty[0] * ty[0] + ty[1] * ty[1] + ty[2] * ty[2] - rho * rho, 0.0)  # ‖(Θ − ρ)y‖²
        th_perp = np.sqrt(np.maximum(th_f2 - rho * rho - 2.0 * ty2, 0.0))
        mu2 = np.minimum(
            np.sqrt(np.maximum(frob2 - rho * rho - 2.0 * r2, 0.0)), np.maximum(th_perp, mu_c) + np.sqrt(res2)
        )
        with np.errstate(divide="ignore", invalid="ignore"):
            gap_b, gap_s = th_lo - mu_c, rho - mu2
            upper = np.minimum(
                np.where(gap_b > 0.0, th_hi + res2 / gap_b, np.inf),
                np.where(gap_s > 0.0, rho + r2 / gap_s, np.inf),
            )
        lower = np.maximum(th_lo, rho)
        lo[idx] = lower
        hi[idx] = upper
        done = upper <= lower * (1.0 + rtol)
        if done.all() or products >= max_iter:
            return lo, hi
        keep = np.flatnonzero(~done)
        idx, frob2 = idx[keep], frob2[keep]
        G = np.take(G, keep, axis=2)
        Y = np.take(GX, keep, axis=2)
        products += 1


def _svd_condition(A: Array) -> Array:
    """Reference κ = σ_max/σ_min by SVD for (M, n, n) matrices; non-finite or singular → inf."""
    out = np.full(A.shape[0], np.inf)
    fin = np.isfinite(A).all(axis=(1, 2))
    if fin.any():
        s = np.linalg.svd(A[fin], compute_uv=False)
        with np.errstate(divide="ignore", invalid="ignore"):
            k = s[:, 0] / s[:, -1]
        out[fin] = np.where(np.isfinite(k), k, np.inf)
    return out


_NO3 = np.empty((0, 0, 0))
_NO1 = np.empty(0)


def _qr_chunk(
    As: Array, s: slice, inv: Array | None, bnd: tuple[Array, Array] | None, rt: bool
) -> tuple[Array, Array, Array]:
    """Householder QR of the matrices ``As[:, :, s]`` (component-first (n, n, N), C-contiguous) in compiled code
    (:func:`pkmstiff.kinematics.kernels.qr_inverse`): writes the inverses A⁻¹ = R⁻¹Qᵀ into ``inv[s]`` (NaN where singular or
    not finite) and the Frobenius bounds of κ into ``bnd[0][s], bnd[1][s]`` where given; returns R and R⁻¹
    (n, n, M) (if ``rt``, else empty) and ok (M,) = finite input and finite R⁻¹."""
    n = As.shape[0]
    m = s.stop - s.start
    r = np.empty((n, n, m)) if rt else _NO3
    t = np.empty((n, n, m)) if rt else _NO3
    ok = np.empty(m, dtype=np.bool_)
    _kernels.qr_inverse(As, s.start, s.stop, rt, inv is not None, bnd is not None, r, t,
                        _NO3 if inv is None else inv, _NO1 if bnd is None else bnd[0],
                        _NO1 if bnd is None else bnd[1], ok)
    return r, t, ok


def _kappa_chunk(A: Array, a: Array, t: Array, ok: Array, rtol: float, max_iter: int) -> tuple[Array, int]:
    """Certified κ for one chunk: A (n, n, M) component-first, its R factor ``a``, R⁻¹ ``t`` and ``ok``."""
    n, _, M = A.shape
    n_svd = 0
    if not ok.all():  # NaN/inf or exactly singular: κ = inf; continue with the others only
        sel = np.flatnonzero(ok)
        A, a, t = np.take(A, sel, axis=2), np.take(a, sel, axis=2), np.take(t, sel, axis=2)
    m = a.shape[2]
    G = np.empty((n, n, 2 * m))
    np.einsum("kim,kjm->ijm", a, a, out=G[:, :, :m])  # RᵀR = AᵀA
    np.einsum("ikm,jkm->ijm", t, t, out=G[:, :, m:])  # R⁻¹R⁻ᵀ, same spectrum as (AᵀA)⁻¹
    # certify each λ_max to (1 + rtol)² so that κ_hi/κ_lo ≤ (1 + rtol)²
    lo, hi = _lambda_max_bounds(G, (1.0 + rtol) ** 2 - 1.0, max_iter)
    with np.errstate(over="ignore", invalid="ignore"):
        k_lo = np.sqrt(lo[:m] * lo[m:])
        k_hi = np.sqrt(hi[:m] * hi[m:])
        k = np.sqrt(k_lo * k_hi)  # geometric midpoint: |κ_returned/κ − 1| ≤ rtol
    redo = np.flatnonzero(~(np.isfinite(k_hi) & (k_hi <= k_lo * (1.0 + rtol) ** 2) & (k_lo > 0.0)))
    if redo.size:
        k[redo] = _svd_condition(np.moveaxis(np.take(A, redo, axis=2), 2, 0))
        n_svd = int(redo.size)
    kap = np.full(M, np.inf)
    kap[ok] = np.where(np.isfinite(k), k, np.inf)
    return kap, n_svd


def _check_square_stack(A: ArrayLike, name: str) -> Array:
    A = np.asarray(A, dtype=float)
    if A.ndim == 2:
        A = A[None]
    if A.ndim != 3 or A.shape[1] != A.shape[2] or A.shape[1] < 3:
        raise KinematicsInputError(
            f"{name}: expected a stack of square matrices (N, n, n), n ≥ 3, found shape {A.shape}"
        )
    return A


def _run_chunked(
    jinv: ArrayLike,
    inverse: bool = False,
    kappa: bool = False,
    bounds: bool = False,
    rtol: float = 1e-4,
    chunk_size: int = DEFAULT_CHUNK,
    max_iter: int = 6,
) -> tuple[Array | None, Array | None, tuple[Array, Array] | None, int]:
    A = _check_square_stack(jinv, "jinv")
    if not 0.0 <= rtol < 1.0:
        raise KinematicsInputError(f"rtol: expected a relative tolerance in [0, 1), found {rtol!r}")
    if kappa and A.shape[1] != 6:
        raise KinematicsInputError(f"jinv: the fast condition number needs 6×6 matrices, found {A.shape[1:]}")
    N, n, _ = A.shape
    # component-first (n, n, N): no copy if jinv came from inverse_jacobian
    As = np.require(np.moveaxis(A, 0, 2), dtype=np.float64, requirements=("C", "W"))
    inv = np.empty((N, n, n)) if inverse else None
    kap = np.empty(N) if kappa else None
    bnd = (np.empty(N), np.empty(N)) if bounds else None
    n_svd = 0
    for s in chunk_slices(N, chunk_size):
        a, t, ok = _qr_chunk(As, s, inv, bnd, rt=kappa)
        if kappa:
            kap[s], n_s = _kappa_chunk(As[:, :, s], a, t, ok, rtol, max_iter)
            n_svd += n_s
    return inv, kap, bnd, n_svd


def kinematic_jacobian(jinv: ArrayLike, chunk_size: int = DEFAULT_CHUNK) -> Array:
    """Kinematic Jacobian J_C = (J_C⁻¹)⁻¹, t = J_C q̇ (spec §1.4, Cobet eq. A.22/A.23), shape (N, n, n).

    Inverted as R⁻¹Qᵀ from a per-pose Householder QR (compiled); unlike ``np.linalg.inv`` this never raises
    for a batch: matrices that are exactly singular or contain NaN/inf give a NaN matrix.
    """
    return _run_chunked(jinv, inverse=True, chunk_size=chunk_size)[0]  # type: ignore[return-value]


def condition_number(
    jinv: ArrayLike,
    rtol: float = 1e-4,
    chunk_size: int = DEFAULT_CHUNK,
    max_iter: int = 6,
    method: str = "fast",
) -> Array:
    """Spectral condition number κ = σ_max/σ_min = ‖A‖₂‖A⁻¹‖₂ per matrix (Cobet eq. A.18, spec §1.6), (N,).

    Matrices with NaN/inf entries (unreachable chains, glide d·r = 0) and exactly singular ones
    give ``inf`` (spec §1.6: non-finite counts as singular).

    ``method="fast"`` (default, 6×6 only): A = QR by Householder (compiled, per pose), ‖A‖₂² = λ_max(RᵀR) and
    ‖A⁻¹‖₂² = λ_max(R⁻¹R⁻ᵀ) from a three-vector block power iteration with *certified* lower and
    upper bounds (see :func:`_lambda_max_bounds`).  Every returned value satisfies
    |κ_returned/κ − 1| ≤ ``rtol`` (plus rounding, which is O(κ·1e-16) for any method, SVD included);
    matrices not certified after ``max_iter`` products are recomputed by SVD.  rtol below ~1e-6
    cannot be certified (closed-form 3×3 eigenvalue) and falls back to SVD.
    ``method="svd"``: ``np.linalg.svd`` for every matrix (reference).
    """
    if method == "svd":
        A = _check_square_stack(jinv, "jinv")
        parts = [_svd_condition(A[s]) for s in chunk_slices(A.shape[0], chunk_size)]
        return np.concatenate(parts) if parts else np.empty(0)
    if method != "fast":
        raise KinematicsInputError(f"condition_number: method must be 'fast' or 'svd', found {method!r}")
    return _run_chunked(jinv, kappa=True, rtol=rtol, chunk_size=chunk_size, max_iter=max_iter)[1]  # type: ignore


def jacobian_and_condition(
    jinv: ArrayLike, rtol: float = 1e-4, chunk_size: int = DEFAULT_CHUNK, max_iter: int = 6
) -> tuple[Array, Array]:
    """J_C (N, 6, 6) and κ(J_C⁻¹) (N,) sharing one QR factorisation per pose (see the two functions above)."""
    inv, kap, _, _ = _run_chunked(jinv, inverse=True, kappa=True, rtol=rtol, chunk_size=chunk_size, max_iter=max_iter)
    return inv, kap  # type: ignore[return-value]


def condition_bounds(jinv: ArrayLike, chunk_size: int = DEFAULT_CHUNK) -> tuple[Array, Array]:
    """Cheap certified bounds κ_lo ≤ κ(J_C⁻¹) ≤ κ_hi (N,), κ_hi/κ_lo ≤ n (= 6).

    κ_hi = ‖A‖_F ‖A⁻¹‖_F, κ_lo = max(κ_hi/n, max column norm of A · max column norm of R⁻¹) from the
    QR factorisation only (no iteration).  Enough to classify most poses against the singularity
    threshold (see :func:`singular_mask`); non-finite or singular matrices give (inf, inf).
    """
    return _run_chunked(jinv, bounds=True, chunk_size=chunk_size)[2]  # type: ignore[return-value]


def is_singular(machine: Machine, kappa: ArrayLike) -> Array:
    """True where κ(J_C⁻¹) > ``machine.limits.singularity_threshold`` (default 1e8) or not finite (spec §1.6)."""
    kappa = np.asarray(kappa, dtype=float)
    return ~(kappa <= machine.limits.singularity_threshold)


def _singular_from_bounds(machine: Machine, A: Array, lo: Array, hi: Array) -> Array:
    """κ > threshold from certified bounds lo ≤ κ ≤ hi; an exact κ (SVD) only where they straddle it."""
    thr = machine.limits.singularity_threshold
    out = ~(hi <= thr)
    amb = np.flatnonzero((lo <= thr) & (hi > thr) & np.isfinite(hi))
    if amb.size:
        out[amb] = ~(_svd_condition(A[amb]) <= thr)
    return out


def singular_mask(machine: Machine, jinv: ArrayLike, chunk_size: int = DEFAULT_CHUNK) -> Array:
    """Singularity check κ(J_C⁻¹) > threshold (spec §1.6) without computing κ where not needed, (N,) bool.

    Uses :func:`condition_bounds`; only poses whose bounds straddle the threshold get an exact κ (SVD).
    Same result as ``is_singular(machine, condition_number(jinv, method="svd"))``.
    """
    A = _check_square_stack(jinv, "jinv")
    lo, hi = condition_bounds(A, chunk_size)
    return _singular_from_bounds(machine, A, lo, hi)


def jacobian_and_singular(machine: Machine, jinv: ArrayLike, chunk_size: int = DEFAULT_CHUNK) -> tuple[Array, Array]:
    """J_C (N, n, n) (:func:`kinematic_jacobian`) and the singularity check (:func:`singular_mask`) from one QR
    factorisation per pose (spec §1.4, §1.6); the pose pipeline's form, which needs no condition number."""
    A = _check_square_stack(jinv, "jinv")
    inv, _, bnd, _ = _run_chunked(A, inverse=True, bounds=True, chunk_size=chunk_size)
    return inv, _singular_from_bounds(machine, A, *bnd)  # type: ignore[misc]


def transmission_quality(machine: Machine, jinv: ArrayLike, w: float | None = None, **kw) -> Array:
    """Transmission quality U = σ_min(W J_C)/σ_max(W J_C) = 1/κ(J_C⁻¹ W⁻¹) ∈ [0, 1] (Cobet eq. 4.75, 4.77).

    W = diag(1, 1, 1, w, w, w) with ``w`` in m/rad (default ``machine.transmission_weight``); singular
    poses give 0.  Keyword arguments go to :func:`condition_number`.
    """
    w = machine.transmission_weight if w is None else float(w)
    if not (np.isfinite(w) and w > 0):
        raise KinematicsInputError(f"transmission_quality: weight w must be a positive number in m/rad, found {w!r}")
    A = np.array(_check_square_stack(jinv, "jinv"), copy=True)
    A[:, :, 3:] /= w
    return 1.0 / condition_number(A, **kw)


# ----------------------------------------------------------------------------------------------------------
# forward kinematics
# ----------------------------------------------------------------------------------------------------------

FK_STATUS = ("converged", "max_iter", "singular_jacobian", "unreachable", "stalled")
_FK_REASON = {
    "max_iter": "no convergence within max_iter Newton iterations",
    "singular_jacobian": "Cardan inverse Jacobian numerically singular at an iterate "
    "(start pose near a singularity, or |b| = 90 deg)",
    "unreachable": "inverse kinematics undefined (a glide strut cannot reach its guide) "
    "at the start pose or at every damped trial step",
    "stalled": "the residual cannot be reduced along the Newton direction "
    "(drive coordinates probably not attainable from this start pose)",
}
#: ratio min|R_kk| / max|R_kk| of the QR factor below which the Newton matrix counts as singular
_FK_SINGULAR_RCOND = 1e-13
_ARMIJO = 1e-4


@dataclass(frozen=True)
class FKResult:
    """Result of :func:`forward_kinematics` for N targets."""

    poses: Array  #: (N, 6) last iterate x, y, z [m], a, b, c [rad]
    converged: Array  #: (N,) bool
    iterations: Array  #: (N,) int, Newton steps taken
    residual: Array  #: (N,) m, ‖q° − q(x)‖₂ at the returned pose (NaN if unreachable)
    step: Array  #: (N,) ‖Δx‖₂ of the last computed Newton step (mixed m/rad)
    status: Array  #: (N,) str, one of FK_STATUS

    def failures(self) -> dict[str, Array]:
        """Indices of the poses that did not converge, per reason."""
        return {s: np.flatnonzero(self.status == s) for s in FK_STATUS[1:] if np.any(self.status == s)}

    def report(self, max_list: int = 10) -> str:
        """Human-readable summary: how many poses failed, which, and why."""
        N = self.converged.size
        nf = int(N - self.converged.sum())
        if nf == 0:
            return f"forward kinematics: all {N} poses converged (max {int(self.iterations.max(initial=0))} iterations)"
        lines = [f"forward kinematics: {nf} of {N} poses did not converge"]
        for s, idx in self.failures().items():
            shown = ", ".join(str(i) for i in idx[:max_list]) + (", ..." if idx.size > max_list else "")
            lines.append(f"  {s} ({idx.size}): {_FK_REASON[s]}; poses [{shown}]")
        return "\n".join(lines)


def _back_substitute(Rm: Array, y: Array) -> Array:
    """Solve upper triangular Rm (M, n, n) x = y (M, n), vectorised; inf/NaN where a diagonal is 0."""
    n = Rm.shape[1]
    x = np.zeros_like(y)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for i in range(n - 1, -1, -1):
            x[:, i] = (y[:, i] - np.einsum("mj,mj->m", Rm[:, i, i + 1 :], x[:, i + 1 :])) / Rm[:, i, i]
    return x


def _drive_residual(machine: Machine, x: Array, target: Array) -> tuple[IK, Array, Array]:
    ik = inverse_kinematics(machine, x)
    res = target - ik.drive
    rn = np.sqrt(np.einsum("mi,mi->m", res, res))
    return ik, res, np.where(np.isfinite(rn), rn, np.inf)


def forward_kinematics(
    machine: Machine,
    drive_coords: ArrayLike,
    x0: ArrayLike,
    tol_q: float = 1e-12,
    tol_x: float = 1e-12,
    max_iter: int = 50,
    damping: bool = True,
    max_backtrack: int = 30,
) -> FKResult:
    """Forward kinematics by Newton's method on the inverse kinematics (Cobet eq. A.12–A.17, spec §1.5).

    ``drive_coords`` (N, n) or (n,) in m (glide λ_i, pod l_i); start poses ``x0`` (N, 6) or (6,).
    Each step solves J⁻¹(x_k) Δx = q° − q(x_k) with the Cardan inverse Jacobian (A.20) as a linear
    least-squares problem by Householder QR (``np.linalg.qr``, A.14–A.17), vectorised over N.
    Stops when ‖q° − q(x_k)‖₂ ≤ ``tol_q`` [m] and ‖Δx_k‖₂ ≤ ``tol_x`` [m, rad] (Assumption: 1e-12,
    max 50 iterations, spec §1.5).

    ``damping=True`` (toolkit addition; the dissertation's Newton method has no step-size control):
    backtracking line search — the step x_k + α Δx_k with α = 1, 1/2, 1/4, … (at most
    ``max_backtrack`` halvings) is accepted when ‖q° − q‖₂ ≤ (1 − 1e-4 α) ‖q° − q(x_k)‖₂ (Armijo) or
    already ≤ ``tol_q``; trial poses at which a glide chain is unreachable are rejected.
    ``damping=False`` takes full steps (stops as ``unreachable`` if the full step leaves the IK domain).

    Never raises for non-convergence: see ``FKResult.converged``, ``status`` and ``report()``.
    """
    q_target = np.asarray(drive_coords, dtype=float)
    n = machine.n_chains
    if q_target.ndim == 1:
        q_target = q_target[None]
    if q_target.ndim != 2 or q_target.shape[1] != n:
        raise KinematicsInputError(
            f"drive_coords: expected shape ({n},) or (N, {n}) in m, found {np.shape(drive_coords)}"
        )
    if not np.isfinite(q_target).all():
        raise KinematicsInputError("drive_coords: expected finite values in m, found NaN/inf")
    x0a = as_poses(x0, "x0")
    N = max(q_target.shape[0], x0a.shape[0])
    try:
        q_target = np.broadcast_to(q_target, (N, n)).copy()
        x = np.broadcast_to(x0a, (N, 6)).copy()
    except ValueError as exc:
        raise KinematicsInputError(
            f"forward_kinematics: drive_coords ({q_target.shape[0]} rows) and x0 ({x0a.shape[0]} rows) "
            "must have the same number of rows or one of them a single row"
        ) from exc

    status = np.full(N, "running", dtype=object)
    iterations = np.zeros(N, dtype=int)
    step = np.full(N, np.nan)
    residual = np.full(N, np.nan)

    for it in range(max_iter + 1):
        act = np.flatnonzero(status == "running")
        if act.size == 0:
            break
        xa, qa = x[act], q_target[act]
        ika, resa, rna = _drive_residual(machine, xa, qa)
        residual[act] = rna
        unreach = ~np.isfinite(rna)  # only possible at the start pose: trial steps must be reachable
        A = cardan_inverse_jacobian(inverse_jacobian(machine, ika), ika)
        A[unreach] = np.eye(6)
        Q, Rm = np.linalg.qr(A)
        dx = _back_substitute(Rm, np.einsum("mji,mj->mi", Q, np.where(unreach[:, None], 0.0, resa)))
        diag = np.abs(np.einsum("mii->mi", Rm))
        singular = ~(diag.min(axis=1) > _FK_SINGULAR_RCOND * diag.max(axis=1)) | ~np.isfinite(dx).all(axis=1)
        dn = np.sqrt(np.einsum("mi,mi->m", dx, dx))
        step[act] = np.where(unreach, np.nan, dn)
        conv = (rna <= tol_q) & (dn <= tol_x) & ~singular
        status[act[unreach]] = "unreachable"
        status[act[conv]] = "converged"
        status[act[singular & ~conv & ~unreach]] = "singular_jacobian"
        go = ~conv & ~singular & ~unreach
        if it == max_iter:
            status[act[go]] = "max_iter"
            break
        act, xa, dx, rna, qa = act[go], xa[go], dx[go], rna[go], qa[go]
        if act.size == 0:
            continue
        alpha = np.ones(act.size)
        accepted = np.zeros(act.size, dtype=bool)
        ever_reachable = np.zeros(act.size, dtype=bool)
        new_x = xa.copy()
        for _bt in range(max_backtrack + 1 if damping else 1):
            tr = np.flatnonzero(~accepted)
            if tr.size == 0:
                break
            xt = xa[tr] + alpha[tr, None] * dx[tr]
            _, _, rnt = _drive_residual(machine, xt, qa[tr])
            reach = np.isfinite(rnt)
            ever_reachable[tr] |= reach
            ok = reach & ((rnt <= (1.0 - _ARMIJO * alpha[tr]) * rna[tr]) | (rnt <= tol_q) | (not damping))
            new_x[tr[ok]] = xt[ok]
            accepted[tr[ok]] = True
            alpha[tr[~ok]] *= 0.5
        x[act[accepted]] = new_x[accepted]
        iterations[act[accepted]] += 1
        status[act[~accepted & ~ever_reachable]] = "unreachable"
        status[act[~accepted & ever_reachable]] = "stalled"

    status[status == "running"] = "max_iter"
    status = status.astype(str)
    return FKResult(
        poses=x,
        converged=status == "converged",
        iterations=iterations,
        residual=np.where(np.isfinite(residual), residual, np.nan),
        step=step,
        status=status,
    )
