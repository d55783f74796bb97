"""Watertight triangulated boundary of an octree result (docs/theory/workspace.md "triangulated by connecting
neighbouring points"; Assumption: surface extraction from the leaf voxels).

Connectivity (surface nets): every leaf voxel carries one vertex; every finest-lattice edge whose two end points
differ in admissibility is surrounded by four leaf voxels (guaranteed by the octree's closure step) whose vertices
form a quad, split into two triangles and oriented so that the normal points from the admissible to the
inadmissible end. Every mesh edge is then shared by an even number of consistently oriented triangles: the
surface is closed and the divergence theorem applies.

Vertex placement (``vertices=``):

* ``"centroid"`` — the boundary point of eq. 4.1 (centroid of the admissible corners): the dissertation's point
  cloud, connected. It lies inside the set, on average half a voxel behind the boundary.
* ``"crossing"`` (default) — the mean of the estimated crossing points on the voxel's sign-change edges: the edge
  mid-point (unbiased with binary information), or, with ``refine_steps = k``, the mid-point of the bracket left
  after k bisection steps along the edge (k extra evaluations per edge, error <= spacing / 2**(k+1)).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.errors import ArgumentError
from pkmstiff.io.atomic import atomic_path
from pkmstiff.io.vtk_xml import write_vtk_xml
from pkmstiff.workspace import kernels
from pkmstiff.workspace.octree import Lattice, OctreeResult

VertexMode = Literal["centroid", "crossing"]




@dataclass
class BoundarySurface:
    """Closed triangle mesh of the boundary (coordinates in the units of the octree box, usually m)."""

    vertices: np.ndarray  # (V, 3)
    triangles: np.ndarray  # (T, 3) int, counter-clockwise seen from outside
    vertex_mode: str
    refine_evaluations: int = 0

    def signed_volume(self) -> float:
        """Divergence theorem: V = sum over triangles of p1 . (p2 x p3) / 6 (exact for the closed mesh)."""
        return float(six_volumes(self.vertices, self.triangles).sum() / 6.0)

    def area(self) -> float:
        p = self.vertices[self.triangles]
        return float(0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum())

    def is_closed(self) -> bool:
        """Every directed edge is matched by an opposite one (closed, consistently oriented)."""
        t = self.triangles
        e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
        e = e[e[:, 0] != e[:, 1]]
        fwd = np.sort(e[:, 0] * (self.vertices.shape[0] + 1) + e[:, 1])
        bwd = np.sort(e[:, 1] * (self.vertices.shape[0] + 1) + e[:, 0])
        return bool(fwd.size == bwd.size and np.array_equal(fwd, bwd))

    def to_pyvista(self):
        import pyvista as pv

        faces = np.hstack([np.full((self.triangles.shape[0], 1), 3), self.triangles]).ravel()
        return pv.PolyData(self.vertices.copy(), faces)

    def save(self, path: str | Path, scale: float = 1.0) -> Path:
        """Write the mesh as STL (binary), VTK/VTP or PLY, chosen by the suffix (VTP:
        :func:`pkmstiff.io.vtk_xml.write_vtk_xml`); coordinates times ``scale`` (e.g. 1000 for mm in STL files, whose
        format carries no unit). VTK's writers release the GIL: several files can be written on threads at once."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in (".stl", ".vtk", ".vtp", ".ply"):
            raise ArgumentError(option=path, expected="a file name ending in .stl, .vtk, .vtp or .ply", found=suffix)
        mesh = BoundarySurface(self.vertices * scale, self.triangles, self.vertex_mode).to_pyvista()
        if suffix == ".vtp":
            return write_vtk_xml(mesh, path)
        with atomic_path(path) as tmp:
            mesh.save(str(tmp), binary=True)
        return path


def six_volumes(vertices: np.ndarray, triangles: np.ndarray, origin: ArrayLike = (0.0, 0.0, 0.0)) -> np.ndarray:
    """(T,) p1 . (p2 x p3) of every triangle, p = vertex - ``origin``: six times the signed volume of its tetrahedron
    with ``origin`` (eq. 4.14), in one compiled pass over the triangles (:func:`pkmstiff.workspace.kernels.six_volumes`)."""
    return kernels.six_volumes(np.ascontiguousarray(vertices, float), np.ascontiguousarray(triangles, np.int64),
                               np.ascontiguousarray(origin, float).reshape(3))


def _edge_brackets(lat: Lattice, start: np.ndarray, axis: np.ndarray, low_adm: np.ndarray, refine_steps: int,
                   admissible: Callable[[np.ndarray], np.ndarray] | None) -> tuple[np.ndarray, int]:
    """Estimated crossing parameter t in [0, 1] along every sign-change edge from its lower end (E,) (edges leaving the
    box are cut at the box face by :func:`pkmstiff.workspace.kernels.crossing_vertices`) and the evaluations spent."""
    t_lo = np.zeros(start.shape[0])  # bracket [t_lo, t_hi] in edge-parameter units, admissible end at 0 or 1
    t_hi = np.ones(start.shape[0])
    evals = 0
    if refine_steps > 0:
        if admissible is None:
            raise ArgumentError("refine_steps > 0 needs the admissibility predicate (argument 'admissible')")
        base = lat.point(start)
        dirv = np.zeros_like(base)
        dirv[np.arange(start.shape[0]), axis] = lat.h[axis]
        inside = lat.inside(start) & lat.inside(start + np.eye(3, dtype=np.int64)[axis])
        for _ in range(refine_steps):
            mid = 0.5 * (t_lo + t_hi)
            ok = np.zeros(start.shape[0], bool)
            if inside.any():
                ok[inside] = np.asarray(admissible(base[inside] + mid[inside, None] * dirv[inside]), bool)
                evals += int(inside.sum())
            # the admissible side of the bracket is at the low end where low_adm
            same_as_low = ok == low_adm
            t_lo = np.where(same_as_low & inside, mid, t_lo)
            t_hi = np.where(~same_as_low & inside, mid, t_hi)
    return 0.5 * (t_lo + t_hi), evals


def boundary_surface(
    res: OctreeResult,
    vertices: VertexMode = "crossing",
    refine_steps: int = 0,
    admissible: Callable[[np.ndarray], np.ndarray] | None = None,
) -> BoundarySurface:
    """Closed triangle mesh of the octree boundary (see the module docstring for ``vertices``)."""
    if vertices not in ("centroid", "crossing"):
        raise ArgumentError(option="vertices", expected="'centroid' or 'crossing'", found=vertices)
    if refine_steps < 0:
        raise ArgumentError(option="refine_steps", expected="an integer >= 0", found=refine_steps)
    lat = res.lattice
    vox = res.leaf_index
    if vox.shape[0] == 0:
        return BoundarySurface(np.empty((0, 3)), np.empty((0, 3), np.int64), vertices)
    start, axis, low_adm = res.sign_change_edges()
    vid = res.edge_rings
    if np.any(vid < 0):
        raise ArgumentError("octree result is not closed (a voxel around a sign-change edge is missing); "
                           "run octree_boundary(..., closure=True)")
    extra = 0
    if vertices == "centroid":
        verts = res.boundary_points
    else:
        t, extra = _edge_brackets(lat, start, axis, low_adm, refine_steps, admissible)
        # each edge contributes its crossing to its four voxels; vertex = mean of the contributions (an edge leaving
        # the box ends at a virtual, inadmissible, never evaluated corner: the box face is the cut)
        verts = kernels.crossing_vertices(np.ascontiguousarray(vid), np.ascontiguousarray(start, np.int64),
                                          np.ascontiguousarray(axis, np.int64), t, lat.n, np.asarray(res.lo, float),
                                          np.asarray(lat.h, float), vox.shape[0])
    return BoundarySurface(verts, res.ring_triangles, vertices, refine_evaluations=extra)


__all__ = ["BoundarySurface", "boundary_surface", "six_volumes"]
