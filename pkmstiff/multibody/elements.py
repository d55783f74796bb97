"""Stiffness–damping elements (SDE) and rigid bindings (docs/theory/structure.md).

An SDE connects a point of body a with a point of body b (coupling points coincide, docs/theory/structure.md).  Its deformation is
``l = G_a q_a - G_b q_b`` with ``G = T(Δ)`` (3×3 element on a rigid body), ``N(Δ)`` (6×6 element on a rigid body),
``I3`` (point mass), nothing (frame); ``Δ`` = coupling point − body reference point.  Energy ``½ lᵀ K l``
(Cobet eq. 4.36/4.37).  Stiffness forms: scalar ``k`` along a unit ``axis`` (``K = k n nᵀ``, Cobet eq. 4.48/4.42),
a full 3×3 matrix or a full 6×6 matrix (translations first, then rotations; only between rigid bodies/frame).
Damping (N s/m, N m s/rad) takes the same forms and is optional.

Elements are stored in *sets* of E elements with the same structure (same kind of body on each side, same
stiffness form) so that every set is assembled with a few vectorised operations.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from pkmstiff.errors import InputError
from pkmstiff.multibody.inputs import pose_array, take

BindingKind = Literal["axial", "point", "full", "angular"]


@dataclass(frozen=True)
class MatrixSpec:
    """Per-element matrices: either ``k`` (P, E) with unit ``axis`` (P, E, 3) -> k n nᵀ, or ``matrix`` (P, E, d, d)."""

    dim: int
    k: np.ndarray | None = None
    axis: np.ndarray | None = None
    matrix: np.ndarray | None = None

    @property
    def n_poses(self) -> int:
        return (self.k if self.matrix is None else self.matrix).shape[0]

    def poses(self, sl: slice) -> "MatrixSpec":
        if self.matrix is not None:
            return replace(self, matrix=take(self.matrix, sl))
        return replace(self, k=take(self.k, sl), axis=take(self.axis, sl))

    def full(self) -> np.ndarray:
        """(P, E, d, d) matrices."""
        if self.matrix is not None:
            return self.matrix
        return self.k[..., None, None] * self.axis[..., :, None] * self.axis[..., None, :]


def matrix_spec(
    source: str, what: str, n_el: int, *, k: Any = None, axis: Any = None, matrix: Any = None,
    check_psd: bool = True,
) -> MatrixSpec:
    """Validate a stiffness/damping description of ``n_el`` elements (set shapes, leading pose axis optional).

    Exactly one of ``k`` + ``axis`` or ``matrix`` must be given: ``k`` scalar, (E,) or (N, E) with ``axis``
    (3,), (E, 3) or (N, E, 3) (normalised here); ``matrix`` (d, d), (E, d, d) or (N, E, d, d) with d = 3 or 6
    (a single value applies to all elements).
    Matrices must be symmetric and (if ``check_psd``) positive semi-definite; ``k >= 0``.
    """
    if (k is None) == (matrix is None):
        raise InputError(source, what, "either a scalar along an axis (k + axis) or a matrix", "both or none")
    if matrix is not None:
        arr = np.asarray(matrix, dtype=float)
        d = arr.shape[-1] if arr.ndim >= 2 else -1
        if d not in (3, 6) or arr.shape[-2] != d:
            raise InputError(source, what, "3x3 or 6x6 matrices", f"shape {arr.shape}")
        if arr.shape == (d, d):
            arr = np.broadcast_to(arr, (n_el, d, d))  # one matrix for all elements
        mat = pose_array(arr, (n_el, d, d), source, what)
        scale = max(float(np.abs(mat).max()), 1e-300)
        asym = float(np.abs(mat - np.swapaxes(mat, -1, -2)).max())
        if asym > 1e-9 * scale:
            raise InputError(source, what, "symmetric matrices",
                                f"max |K - Kᵀ| = {asym:.3e} (max |K| = {scale:.3e})")
        mat = 0.5 * (mat + np.swapaxes(mat, -1, -2))
        if check_psd:
            eig = np.linalg.eigvalsh(mat)
            if np.any(eig[..., 0] < -1e-9 * np.maximum(eig[..., -1], 1e-300)):
                raise InputError(source, what, "positive semi-definite matrices",
                                    f"eigenvalue {eig[..., 0].min():.3e}")
        return MatrixSpec(dim=d, matrix=mat)
    if axis is None:
        raise InputError(source, "axis", f"a direction (3,) per element for the scalar {what}", None)
    k_arr = np.asarray(k, dtype=float)
    if k_arr.ndim == 0:
        k_arr = np.full(n_el, float(k_arr))
    kk = pose_array(k_arr, (n_el,), source, what)
    if np.any(kk < 0):
        raise InputError(source, what, "scalar >= 0", f"min {kk.min()}")
    ax_in = np.asarray(axis, dtype=float)
    if ax_in.shape == (3,):
        ax_in = np.broadcast_to(ax_in, (n_el, 3))  # one direction for all elements
    ax = pose_array(ax_in, (n_el, 3), source, "axis")
    norm = np.linalg.norm(ax, axis=-1)
    if np.any(norm < 1e-12):
        raise InputError(source, "axis", "non-zero direction vectors", "zero vector")
    return MatrixSpec(dim=3, k=kk, axis=ax / norm[..., None])


@dataclass(frozen=True)
class SDESet:
    """E stiffness–damping elements of identical structure (see module docstring).

    ``point`` (P, E, 3) coupling points in m (global coordinates); ``stiffness``/``damping`` per element.
    ``groups`` names the component each element belongs to (used to sum energy shares).
    """

    names: tuple[str, ...]
    body_a: tuple[str, ...]
    body_b: tuple[str, ...]
    point: np.ndarray
    stiffness: MatrixSpec
    damping: MatrixSpec | None
    groups: tuple[str, ...]

    @property
    def dim(self) -> int:
        return self.stiffness.dim

    @property
    def size(self) -> int:
        return len(self.names)

    def poses(self, sl: slice) -> "SDESet":
        return replace(
            self,
            point=take(self.point, sl),
            stiffness=self.stiffness.poses(sl),
            damping=None if self.damping is None else self.damping.poses(sl),
        )


@dataclass(frozen=True)
class RigidBinding:
    """A rigid connection of a point of body a with body b, eliminated by a null-space basis (docs/theory/structure.md).

    ``kind``: ``"axial"`` = no relative translation along ``axis`` (rigid strut, 1 constraint), ``"point"`` = no
    relative translation (3 constraints, a spherical joint), ``"full"`` = no relative translation or rotation
    (6 constraints, both bodies rigid or frame), ``"angular"`` = no relative rotation about ``axis`` (1 constraint,
    both bodies rigid or frame; e.g. the locked tilt of a revolute joint).
    """

    name: str
    body_a: str
    body_b: str
    point: np.ndarray  # (P, 3)
    kind: BindingKind
    axis: np.ndarray | None  # (P, 3) unit, for "axial" and "angular"

    @property
    def n_constraints(self) -> int:
        return {"axial": 1, "angular": 1, "point": 3, "full": 6}[self.kind]

    def poses(self, sl: slice) -> "RigidBinding":
        return replace(self, point=take(self.point, sl), axis=None if self.axis is None else take(self.axis, sl))
