"""Small batched geometry and linear-algebra helpers for the SDE model (docs/theory/structure.md).

All functions broadcast over any leading axes (poses, elements).
"""

from __future__ import annotations

import numpy as np


def skew(v: np.ndarray) -> np.ndarray:
    """Skew matrix ``[v]_x`` with ``[v]_x u = v x u``; ``v`` (..., 3) -> (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def reference_matrix(delta: np.ndarray) -> np.ndarray:
    """Reference matrix N(Δ) = [[I, -[Δ]x], [0, I]] of Cobet eq. 4.45 (docs/theory/structure.md); (..., 3) -> (..., 6, 6).

    ``N(Δ) q_body`` is the (translation, rotation) of the point at offset Δ from the body reference point.
    """
    delta = np.asarray(delta, dtype=float)
    out = np.zeros(delta.shape[:-1] + (6, 6))
    idx = np.arange(6)
    out[..., idx, idx] = 1.0
    out[..., :3, 3:] = -skew(delta)
    return out


def translation_matrix(delta: np.ndarray) -> np.ndarray:
    """T(Δ) = [I, -[Δ]x], the top three rows of N(Δ) (docs/theory/structure.md); (..., 3) -> (..., 3, 6)."""
    delta = np.asarray(delta, dtype=float)
    out = np.zeros(delta.shape[:-1] + (3, 6))
    idx = np.arange(3)
    out[..., idx, idx] = 1.0
    out[..., :, 3:] = -skew(delta)
    return out


def sym(a: np.ndarray) -> np.ndarray:
    """Symmetric part (a + aᵀ)/2 over the last two axes."""
    return 0.5 * (a + np.swapaxes(a, -1, -2))


def cholesky_inverse_factor(a: np.ndarray) -> np.ndarray:
    """``L⁻¹`` for ``a = L Lᵀ`` (batched, small SPD blocks), so that ``L⁻¹ a L⁻ᵀ = I``."""
    lower = np.linalg.cholesky(a)
    eye = np.broadcast_to(np.eye(a.shape[-1]), a.shape)
    return np.linalg.solve(lower, eye)


def rotation_about_axis(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix (Rodrigues) for a unit-free ``axis`` (3,) and ``angle`` in rad."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    k = skew(axis)
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def solve_lower(lower: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve ``L y = b`` by forward substitution for batches of small lower-triangular ``L`` (..., d, d),
    ``b`` (..., d, r).  Vectorised over the batch (d steps), much faster than per-matrix LAPACK calls for d <= 6."""
    d = lower.shape[-1]
    shape = np.broadcast_shapes(lower.shape[:-2], b.shape[:-2]) + b.shape[-2:]
    y = np.empty(shape)
    for i in range(d):
        acc = b[..., i, :]
        if i:
            acc = acc - (lower[..., i:i + 1, :i] @ y[..., :i, :])[..., 0, :]
        y[..., i, :] = acc / lower[..., i, i, None]
    return y


def solve_upper_t(lower: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Solve ``Lᵀ x = y`` by backward substitution (same conventions as :func:`solve_lower`)."""
    d = lower.shape[-1]
    shape = np.broadcast_shapes(lower.shape[:-2], y.shape[:-2]) + y.shape[-2:]
    x = np.empty(shape)
    for i in range(d - 1, -1, -1):
        acc = y[..., i, :]
        if i < d - 1:
            acc = acc - (np.swapaxes(lower[..., i + 1:, i:i + 1], -1, -2) @ x[..., i + 1:, :])[..., 0, :]
        x[..., i, :] = acc / lower[..., i, i, None]
    return x
