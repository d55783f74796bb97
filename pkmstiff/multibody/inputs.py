"""Validation of per-pose input arrays for the SDE model.

Every geometric or physical quantity may differ per pose: it is stored with a leading pose axis of
length 1 (same for all poses, broadcast) or N.  A value given without the pose axis gets one of length 1.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pkmstiff.errors import InputError


def pose_array(value: Any, core: tuple[int, ...], source: str, key: str, *, extra: int | None = None) -> np.ndarray:
    """Return ``value`` as float array of shape ``(P, *core)`` with P = 1 or N.

    ``core`` is the per-pose shape, e.g. ``(3,)`` for a point, ``(E, 3, 3)`` for E matrices.  A value of shape
    ``core`` gets a leading pose axis of length 1; a value of shape ``(N, *core)`` is kept.  NaN/inf are rejected.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(source, key, f"numeric array of shape {core} or (N, *{core})", value) from exc
    if arr.shape == core:
        arr = arr[None, ...]
    elif arr.ndim != len(core) + 1 or arr.shape[1:] != core or arr.shape[0] < 1:
        raise InputError(source, key, f"shape {core} or (N, *{core}) (N = poses)", f"shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(source, key, "finite values", "NaN or inf")
    return arr


def common_poses(sizes: list[int], source: str) -> int:
    """Number of poses N implied by leading axes of length 1 or N; raise if two different N>1 occur."""
    big = sorted({s for s in sizes if s != 1})
    if len(big) > 1:
        raise InputError(source, "pose axis", "leading pose axes of length 1 or one common N", f"lengths {big}")
    return big[0] if big else 1


def take(arr: np.ndarray, sl: slice) -> np.ndarray:
    """Slice the pose axis of a (P, ...) array (broadcast arrays with P = 1 are kept)."""
    return arr if arr.shape[0] == 1 else arr[sl]
