"""Pose arrays: validation, chunking and the component-first storage helpers of the kinematics hot path.

Poses are arrays of shape ``(N, 6)`` with columns x, y, z [m] (position of O' in the MKS) and the Cardan angles
a, b, c [rad]; a single pose of shape ``(6,)`` is treated as ``N = 1``. Internally the hot path works
"component-first" (pose axis last, contiguous); exposed arrays are pose-first views of that storage.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pkmstiff.errors import ArgumentError

Array = NDArray[np.float64]


POSE_COLUMNS = ("x", "y", "z", "a", "b", "c")


POSE_UNITS = ("m", "m", "m", "rad", "rad", "rad")


#: default number of poses processed at once by the chunked 6×6 routines (bounds temporary memory:
#: a few dozen arrays of 36 × chunk float64, ≈ 10 MB at 4096)
DEFAULT_CHUNK = 4096




def as_poses(poses: ArrayLike, name: str = "poses") -> Array:
    """Validate poses and return a float array of shape ``(N, 6)`` (a ``(6,)`` pose becomes ``(1, 6)``)."""
    try:
        arr = np.asarray(poses, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ArgumentError(
            f"{name}: expected numbers of shape (6,) or (N, 6) [x, y, z in m, a, b, c in rad], found {poses!r}"
        ) from exc
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise ArgumentError(
            f"{name}: expected shape (6,) or (N, 6) [x, y, z in m, a, b, c in rad], found shape {np.shape(poses)}"
        )
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)
        raise ArgumentError(
            f"{name}: expected finite values, found NaN/inf in {rows.size} pose(s), first rows {rows[:5].tolist()}"
        )
    return arr


def chunk_slices(n: int, chunk_size: int = DEFAULT_CHUNK) -> Iterator[slice]:
    """Slices ``[0:c], [c:2c], …`` covering ``range(n)``, for processing many poses in bounded memory."""
    if chunk_size < 1:
        raise ArgumentError(option="chunk_size", expected="a positive integer", found=chunk_size)
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
