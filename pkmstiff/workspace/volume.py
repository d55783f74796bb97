"""Volume of a workspace from its octree boundary (docs/theory/workspace.md, Cobet eq. 4.2-4.20).

Methods (all return the volume in the cube of the box's length unit, m^3 for positions in m):

* ``pyramid`` — eq. 4.4-4.6: V = 1/3 sum h_i A_i, h_i = |z - s_i|, A_i = ((dx + dy + dz) / 3)^2 over the boundary
  points s_i (eq. 4.1); no triangulation. The spec itself states that it may converge to a wrong value.
* ``tetrahedron`` — eq. 4.14: V = sum |(p1 - z) . ((p2 - z) x (p3 - z))| / 6 over the triangles of the boundary
  points (eq. 4.1) connected to a closed mesh, z = centre of the point cloud (mid-point of its extent).
* ``divergence`` — the signed sum of eq. 4.14 (divergence theorem) on the same mesh: exact for the triangulated
  surface, independent of z, also for non-star-shaped sets (docs/theory/workspace.md Assumption: recommended default there).
* ``surface_nets`` (this toolkit's method, default) — the divergence theorem on the closed mesh whose vertices are
  the estimated crossing points on the sign-change edges (:mod:`pkmstiff.workspace.surface`), instead of the
  centroids of eq. 4.1. The centroids lie on average half a voxel inside the boundary, so every method built on
  them converges linearly in eps from below; the edge mid-points are unbiased for a locally flat boundary, which
  removes the first-order error (optionally sharpened by bisection along the edges, ``refine_steps``).
* ``voxels`` — voxel counting: the volume of all voxels discarded as inside plus (admissible corners / 8) of
  every leaf voxel; a mesh-free cross-check for simple bodies. It ignores what the closure step finds inside
  voxels discarded on a coarse level (it counts them as wholly inside/outside), so it is not among the defaults.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.errors import ArgumentError
from pkmstiff.workspace import kernels
from pkmstiff.workspace.octree import OctreeResult
from pkmstiff.workspace.surface import BoundarySurface, boundary_surface, six_volumes

METHODS = ("surface_nets", "divergence", "tetrahedron", "pyramid", "voxels")
DEFAULT_METHODS = ("surface_nets", "divergence", "tetrahedron", "pyramid")
#: the method whose volume is the result to quote (``WorkspaceResult.volume``); the others are cross-checks
HEADLINE_METHOD = "surface_nets"
#: what each method's number is, for the printed output (docs/user-guide/workspace.md, "Volume methods")
METHOD_NOTES = {
    "surface_nets": "divergence theorem on the mesh through the boundary-edge mid-points; converges quadratically",
    "divergence": "signed sum on the mesh through the eq. 4.1 points, whose corners are cut: small",
    "tetrahedron": "Cobet eq. 4.14, unsigned sum about the cloud centre: wrong where the workspace is not star-shaped",
    "pyramid": "eq. 4.4-4.6 as specified: 25-50 % too large on test bodies",
    "voxels": "voxel counting: a cross-check for simple bodies",
}




def cloud_centre(points: np.ndarray) -> np.ndarray:
    """Mid-point of the maximum extent of a point cloud in each direction (Cobet 4.1.4, tetrahedron method)."""
    return kernels.extent_centre(np.ascontiguousarray(points, float))


def pyramid_volume(res: OctreeResult, z: ArrayLike | None = None) -> float:
    """Pyramid method, eq. 4.4-4.6 (z defaults to the centre of the boundary-point cloud)."""
    s = res.boundary_points
    if s.shape[0] == 0:
        return 0.0
    zz = _centre(res) if z is None else np.asarray(z, float)
    h = kernels.distances(np.ascontiguousarray(s, float), np.ascontiguousarray(zz, float).reshape(3))  # eq. 4.4
    e_bar = res.spacing.sum() / 3.0  # eq. 4.5 (all leaves have the finest size)
    return float(h.sum() * e_bar**2 / 3.0)  # eq. 4.6


def _centre(res: OctreeResult) -> np.ndarray:
    """:func:`cloud_centre` of the boundary points, from their extent (computed once per result)."""
    lo, hi = res.extent
    return 0.5 * (lo + hi)


def tetrahedron_volume(mesh: BoundarySurface, z: ArrayLike | None = None, signed: bool = False) -> float:
    """Tetrahedron method, eq. 4.14 (unsigned, about z = cloud centre) or its signed form (divergence theorem)."""
    if mesh.triangles.shape[0] == 0:
        return 0.0
    zz = cloud_centre(mesh.vertices) if z is None else np.asarray(z, float)
    six_v = six_volumes(mesh.vertices, mesh.triangles, zz)
    return float((six_v.sum() if signed else np.abs(six_v).sum()) / 6.0)


def voxel_volume(res: OctreeResult) -> float:
    """Voxel counting: inside voxels plus the admissible-corner fraction of every leaf."""
    return float(res.inside_volume + res.leaf_corners.sum() / 8.0 * res.voxel_volume)


def _centroid_volumes(res: OctreeResult, methods: tuple[str, ...], z: ArrayLike | None
                      ) -> tuple[dict[str, float], BoundarySurface | None]:
    """The volumes of ``methods`` but surface nets and the centroid mesh (None where none of them needs it)."""
    cmesh = boundary_surface(res, "centroid") if {"tetrahedron", "divergence"} & set(methods) else None
    out: dict[str, float] = {}
    for m in methods:
        if m == "pyramid":
            out[m] = pyramid_volume(res, z)
        elif m == "tetrahedron":  # the centroid mesh's vertices are the boundary points
            out[m] = tetrahedron_volume(cmesh, _centre(res) if z is None else z)  # type: ignore[arg-type]
        elif m == "divergence":
            out[m] = cmesh.signed_volume()  # type: ignore[union-attr]
        elif m == "voxels":
            out[m] = voxel_volume(res)
    return out, cmesh


@dataclass
class VolumeReport:
    """Volumes by method (unit: box length unit cubed) and the meshes they used."""

    volumes: dict[str, float]
    centroid_mesh: BoundarySurface | None
    crossing_mesh: BoundarySurface | None
    refine_evaluations: int


def workspace_volume(
    res: OctreeResult,
    methods: tuple[str, ...] = DEFAULT_METHODS,
    *,
    z: ArrayLike | None = None,
    refine_steps: int = 0,
    admissible: Callable[[np.ndarray], np.ndarray] | None = None,
) -> VolumeReport:
    """Volumes of the octree result by the requested methods (see the module docstring)."""
    bad = [m for m in methods if m not in METHODS]
    if bad:
        raise ArgumentError(f"volume methods {bad}: expected a subset of {METHODS}")
    want_c, want_x = bool({"tetrahedron", "divergence"} & set(methods)), "surface_nets" in methods

    def crossing() -> tuple[BoundarySurface | None, float]:
        if not want_x:
            return None, float("nan")
        mesh = boundary_surface(res, "crossing", refine_steps=refine_steps, admissible=admissible)
        return mesh, mesh.signed_volume()

    if res.threads > 1 and want_c and want_x and refine_steps == 0 and res.leaf_index.shape[0]:
        # the crossing mesh and its volume on a thread of its own while the others are computed here (the compiled
        # kernels release the GIL); the edges and rings both meshes use first
        _ = res.ring_triangles
        with ThreadPoolExecutor(1) as ex:
            later = ex.submit(crossing)
            out, cmesh = _centroid_volumes(res, methods, z)
            xmesh, nets = later.result()
    else:
        xmesh, nets = crossing()
        out, cmesh = _centroid_volumes(res, methods, z)
    out = {m: nets if m == "surface_nets" else out[m] for m in methods}
    return VolumeReport(out, cmesh, xmesh, 0 if xmesh is None else xmesh.refine_evaluations)
