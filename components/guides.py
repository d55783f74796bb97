"""Guide carriages and the anisotropic glide-drive stiffness (docs/theory/components.md; Cobet eq. 3.6, 3.14).

In the drive coordinate system (x' = guide direction, y' horizontal transverse, z' vertical transverse)
the drive stiffness is K'_W = diag(k_x, k_y, k_z): k_x = axial drive stiffness, k_y / k_z = sum of the
horizontal / vertical stiffnesses of all carriages (parallel connection). In the MKS it is K_W = R K'_W Rᵀ
with the drive-frame axes as the columns of R.

Note (docs/theory/structure.md): Cobet eq. 4.40 prints K_W = R K'_W; a stiffness tensor transforms by the
congruence R K' Rᵀ, which is what :func:`drive_frame_stiffness` implements.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from components.params import ModelSpec, Param
from components.protocol import Component, ComponentState
from pkmstiff.errors import ArgumentError

_PARALLEL_TOL = 1e-6  # |component of the vertical orthogonal to x'| below which the guide counts as vertical


def drive_frame(
    guide_direction: Any,
    vertical: Any = (0.0, 0.0, 1.0),
    fallback: Any = (1.0, 0.0, 0.0),
) -> np.ndarray:
    """Drive frame R (..., 3, 3) whose columns are x', y', z' in MKS components.

    x' = guide direction (normalised); z' = component of the machine's ``vertical`` orthogonal to x'
    (normalised); y' = z' × x' (right-handed). Vertical guides (x' ∥ vertical): z' is taken from the
    ``fallback`` reference instead (default the machine x-axis) — a toolkit choice, as the source has no
    vertical guides; pass a different ``fallback`` to orient the carriages' "vertical" direction.
    """
    x = np.asarray(guide_direction, dtype=float)
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    if np.any(norm == 0) or not np.all(np.isfinite(norm)):
        raise ArgumentError(f"drive_frame: guide directions must be finite non-zero vectors, found {x.tolist()}")
    x = x / norm

    def orthogonal(ref: np.ndarray) -> np.ndarray:
        return ref - np.sum(ref * x, axis=-1, keepdims=True) * x

    z = orthogonal(np.broadcast_to(np.asarray(vertical, dtype=float), x.shape))
    zn = np.linalg.norm(z, axis=-1, keepdims=True)
    is_vertical = zn < _PARALLEL_TOL
    if np.any(is_vertical):
        zf = orthogonal(np.broadcast_to(np.asarray(fallback, dtype=float), x.shape))
        if np.any(is_vertical & (np.linalg.norm(zf, axis=-1, keepdims=True) < _PARALLEL_TOL)):
            raise ArgumentError("drive_frame: the fallback reference is parallel to a vertical guide direction")
        z = np.where(is_vertical, zf, z)
        zn = np.linalg.norm(z, axis=-1, keepdims=True)
    z = z / zn
    y = np.cross(z, x)
    y = y / np.linalg.norm(y, axis=-1, keepdims=True)
    z = np.cross(x, y)  # re-orthogonalise: z' from cancellation-prone subtraction may be off by round-off
    return np.stack([x, y, z], axis=-1)


def drive_frame_stiffness(K_local: Any, R: Any) -> np.ndarray:
    """K_W = R K' Rᵀ (..., 3, 3) — drive stiffness from drive coordinates into the MKS (docs/theory/structure.md)."""
    K = np.asarray(K_local, dtype=float)
    Rm = np.asarray(R, dtype=float)
    return Rm @ K @ np.swapaxes(Rm, -1, -2)


def local_drive_stiffness(k_x: Any, k_y: Any, k_z: Any) -> np.ndarray:
    """K'_W = diag(k_x, k_y, k_z) (N, 3, 3) from broadcastable per-pose values [N/m] (Cobet eq. 3.6)."""
    kx, ky, kz = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=float)) for v in (k_x, k_y, k_z)))
    K = np.zeros(kx.shape + (3, 3))
    K[..., 0, 0], K[..., 1, 1], K[..., 2, 2] = kx, ky, kz
    return K


@dataclass(frozen=True, kw_only=True, eq=False)
class GuideCarriages(Component):
    """``count`` identical guide carriages in parallel: k_y = count·k_horizontal, k_z = count·k_vertical [N/m].

    :meth:`stiffness` returns the transverse part diag(0, k_y, k_z) (N, 3, 3) in drive coordinates (the
    carriages carry no load along the guide); :meth:`local_stiffness` adds the axial drive stiffness,
    giving K'_W = diag(k_x, k_y, k_z) (Cobet eq. 3.6, 3.14).
    """

    kind: ClassVar[str] = "matrix3"
    k_horizontal: float
    k_vertical: float
    count: int = 1

    def __post_init__(self) -> None:
        if not (self.k_horizontal > 0 and self.k_vertical > 0):
            raise ArgumentError(f"guide '{self.name}': carriage stiffnesses must be positive, found "
                                     f"{self.k_horizontal!r}, {self.k_vertical!r}")
        if int(self.count) != self.count or self.count < 1:
            raise ArgumentError(f"guide '{self.name}': count must be a positive integer, found {self.count!r}")

    @property
    def k_y(self) -> float:
        """Horizontal transverse stiffness of the drive unit [N/m] (parallel connection)."""
        return self.count * self.k_horizontal

    @property
    def k_z(self) -> float:
        """Vertical transverse stiffness of the drive unit [N/m] (parallel connection)."""
        return self.count * self.k_vertical

    def stiffness(self, state: ComponentState) -> np.ndarray:
        return local_drive_stiffness(np.zeros(state.n), self.k_y, self.k_z)

    def local_stiffness(self, k_axial: Any) -> np.ndarray:
        """K'_W = diag(k_x, k_y, k_z) (N, 3, 3) in drive coordinates for axial drive stiffness k_x (N,) [N/m]."""
        return local_drive_stiffness(k_axial, self.k_y, self.k_z)

    def drive_stiffness(self, k_axial: Any, R: Any) -> np.ndarray:
        """K_W = R K'_W Rᵀ (N, 3, 3) in the MKS; ``R`` from :func:`drive_frame`."""
        return drive_frame_stiffness(self.local_stiffness(k_axial), R)


# --------------------------------------------------------------------------------------------- machine files
MODELS: tuple[ModelSpec, ...] = (ModelSpec(
    "guide_carriages", "guide carriages in parallel: transverse drive stiffness", "Cobet eq. 3.6, 3.14",
    (Param("k_horizontal", "N/m", None, "per carriage, horizontal (y')", required=True, positive=True),
     Param("k_vertical", "N/m", None, "per carriage, vertical (z')", required=True, positive=True),
     Param("count", "-", 1, "number of carriages per drive", kind="integer", min_value=1),
     Param("mass", "kg", 0.0, "carriage mass", min_value=0.0)),
    lambda p: GuideCarriages(name=p.name, k_horizontal=p["k_horizontal"], k_vertical=p["k_vertical"],
                             count=p["count"], mass=p["mass"])),)
