"""Kinematic Jacobian J_C by batch Householder QR, certified condition number, singularity check and
transmission quality (docs/theory/kinematics.md, Cobet §1.5, §6.1).

The QR of J_C^-1, the condition-number bounds and the singularity check run per pose in compiled code
(:func:`pkmstiff.kinematics.kernels.qr_inverse`); the certified power iteration for kappa stays vectorised numpy.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.errors import ArgumentError
from pkmstiff.kinematics import dispatch as _dispatch
from pkmstiff.kinematics.arrays import DEFAULT_CHUNK, Array, chunk_slices
from pkmstiff.machine.model import Machine


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
    _dispatch.run("qr_inverse", m, As, s.start, s.stop, rt, inv is not None, bnd is not None, r, t,
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
        raise ArgumentError(
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
        raise ArgumentError(option="rtol", expected="a relative tolerance in [0, 1)", found=rtol)
    if kappa and A.shape[1] != 6:
        raise ArgumentError(f"jinv: the fast condition number needs 6×6 matrices, found {A.shape[1:]}")
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
    """Kinematic Jacobian J_C = (J_C⁻¹)⁻¹, t = J_C q̇ (docs/theory/kinematics.md, Cobet eq. A.22/A.23), shape (N, n, n).

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
    """Spectral condition number κ = σ_max/σ_min = ‖A‖₂‖A⁻¹‖₂ per matrix (Cobet eq. A.18, docs/theory/kinematics.md), (N,).

    Matrices with NaN/inf entries (unreachable chains, glide d·r = 0) and exactly singular ones
    give ``inf`` (docs/theory/kinematics.md: non-finite counts as singular).

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
        raise ArgumentError(f"condition_number: method must be 'fast' or 'svd', found {method!r}")
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
    """True where κ(J_C⁻¹) > ``machine.limits.singularity_threshold`` (default 1e8) or not finite (docs/theory/kinematics.md)."""
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
    """Singularity check κ(J_C⁻¹) > threshold (docs/theory/kinematics.md) without computing κ where not needed, (N,) bool.

    Uses :func:`condition_bounds`; only poses whose bounds straddle the threshold get an exact κ (SVD).
    Same result as ``is_singular(machine, condition_number(jinv, method="svd"))``.
    """
    A = _check_square_stack(jinv, "jinv")
    lo, hi = condition_bounds(A, chunk_size)
    return _singular_from_bounds(machine, A, lo, hi)


def jacobian_and_singular(machine: Machine, jinv: ArrayLike, chunk_size: int = DEFAULT_CHUNK) -> tuple[Array, Array]:
    """J_C (N, n, n) (:func:`kinematic_jacobian`) and the singularity check (:func:`singular_mask`) from one QR
    factorisation per pose (docs/theory/kinematics.md); the pose pipeline's form, which needs no condition number."""
    A = _check_square_stack(jinv, "jinv")
    inv, _, bnd, _ = _run_chunked(A, inverse=True, bounds=True, chunk_size=chunk_size)
    return inv, _singular_from_bounds(machine, A, *bnd)  # type: ignore[misc]


def transmission_quality(machine: Machine, jinv: ArrayLike, w: float | None = None, form: str | None = None,
                         **kw) -> Array:
    """Transmission quality U ∈ [0, 1] (Cobet eq. 4.75, 4.77; docs/theory/kinetostatics.md and its eq. 4.75 note).

    ``form`` (default ``machine.transmission_form``): ``"inverse_sqrt_kappa"`` U = κ(W J_C)^(-1/2) =
    sqrt(σ_min/σ_max), the literal reading of the printed eq. 4.75 (λ read as singular values), which agrees with
    the dissertation's published values; ``"inverse_kappa"`` U = σ_min(W J_C)/σ_max(W J_C) = 1/κ(J_C⁻¹ W⁻¹).
    W = diag(1, 1, 1, w, w, w) with ``w`` in m/rad (default ``machine.transmission_weight``); singular
    poses give 0.  Keyword arguments go to :func:`condition_number`.
    """
    form = getattr(machine, "transmission_form", "inverse_sqrt_kappa") if form is None else form
    if form not in ("inverse_sqrt_kappa", "inverse_kappa"):
        raise ArgumentError(f"transmission_quality: form must be 'inverse_sqrt_kappa' or 'inverse_kappa', "
                                   f"found {form!r}")
    w = machine.transmission_weight if w is None else float(w)
    if not (np.isfinite(w) and w > 0):
        raise ArgumentError(f"transmission_quality: weight w must be a positive number in m/rad, found {w!r}")
    A = np.array(_check_square_stack(jinv, "jinv"), copy=True)
    A[:, :, 3:] /= w
    inv_kappa = 1.0 / condition_number(A, **kw)
    return np.sqrt(inv_kappa) if form == "inverse_sqrt_kappa" else inv_kappa
