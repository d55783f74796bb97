"""Geometric primitives of the collision checks of docs/theory/admissibility.md (Cobet App. B.4), vectorised.

All functions broadcast over leading axes; points are ``(..., 3)`` arrays in m. The arithmetic lives in
:mod:`pkmstiff.kinematics.kernels` (compiled scalar primitives, the only implementation, shared with the fused per-pose
collision kernels of :mod:`pkmstiff.admissibility.checks`); the functions here broadcast their inputs and loop over the
rows in compiled code. NaN inputs give NaN distances and False tests.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from pkmstiff.kinematics import dispatch as _dispatch

_EPS = _dispatch.pure_kernels().EPS


def _many(name: str, *points: np.ndarray) -> np.ndarray:
    """Apply primitive ``name`` of :data:`pkmstiff.kinematics.kernels.PRIMITIVES` row by row over broadcast points."""
    arrs = [np.asarray(p, dtype=np.float64) for p in points]
    for k, a in enumerate(arrs):
        if a.shape[-1:] != (3,):
            raise ValueError(f"{name}: point argument {k + 1} must have shape (..., 3) in m, found {a.shape}")
    shape = np.broadcast_shapes(*(a.shape for a in arrs))
    pts = np.empty(shape[:-1] + (len(arrs), 3))
    for k, a in enumerate(arrs):
        pts[..., k, :] = a
    out = np.empty(shape[:-1])
    rows = pts.reshape(-1, len(arrs), 3)
    code = _dispatch.pure_kernels().PRIMITIVES[name][0]
    _dispatch.run("primitive_many", rows.shape[0], code, rows, out.reshape(-1))
    return out if out.ndim else out[()]


def segment_distance(
    p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray, mode: Literal["exact", "table_B2"] = "exact"
) -> np.ndarray:
    """Distance between segments [p1, q1] and [p2, q2] (Cobet eq. B.7-B.11, Table B.2).

    ``mode="exact"`` is the true segment-segment distance: closest points of the infinite lines, clamp one
    parameter, re-project the clamped point onto the other segment and clamp again (the toolkit default, see the
    Note to Table B.2). ``mode="table_B2"`` reproduces the dissertation's table: both infinite-line parameters are
    clamped independently, which can overestimate the distance (and so miss collisions). Parallel segments
    (B.10): distance of the end points to the other segment.
    """
    if mode not in ("exact", "table_B2"):
        raise ValueError(f"segment distance mode: expected 'exact' or 'table_B2', found {mode!r}")
    return _many(f"segment_distance_{mode}", p1, q1, p2, q2)


def line_parameters(p1: np.ndarray, d1: np.ndarray, p2: np.ndarray, d2: np.ndarray) -> tuple[np.ndarray, ...]:
    """Parameters (nu, mu, tau) of the closed vector loop mu d2 + tau (d1 x d2) - nu d1 = p1 - p2 (Cobet eq. B.11).

    ``d1``, ``d2`` are unit strut directions; nu and mu are then distances along the struts (Table B.2).
    Returns NaN for parallel struts (B.10).
    """
    n = np.cross(d1, d2)
    a = np.stack([-d1, d2, n], axis=-1)  # columns: unknowns nu, mu, tau
    rhs = p1 - p2
    det = np.linalg.det(a)
    ok = np.abs(det) > 1e-12
    a_safe = np.where(ok[..., None, None], a, np.eye(3))
    sol = np.linalg.solve(a_safe, rhs[..., None])[..., 0]
    sol = np.where(ok[..., None], sol, np.nan)
    return sol[..., 0], sol[..., 1], sol[..., 2]


def point_segment_distance(x: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distance of point ``x`` from segment [p, q]."""
    return _many("point_segment_distance", x, p, q)


def segment_pierces_triangle(
    a: np.ndarray, b: np.ndarray, t1: np.ndarray, t2: np.ndarray, t3: np.ndarray
) -> np.ndarray:
    """True where segment [a, b] intersects triangle (t1, t2, t3) (Moller-Trumbore).

    Implements the piercing test of Cobet Fig. B.5 in the corrected form of the spec (Note to eq. B.12):
    n = t1 + beta (t2 - t1) + gamma (t3 - t1) with beta, gamma >= 0, beta + gamma <= 1 and the intersection
    parameter inside the segment. A segment lying in the triangle's plane does not count as piercing (its edges
    are caught by the edge-distance test).
    """
    return _many("segment_pierces_triangle", a, b, t1, t2, t3) > 0.5


def point_triangle_face_distance(
    x: np.ndarray, t1: np.ndarray, t2: np.ndarray, t3: np.ndarray
) -> np.ndarray:
    """Distance of ``x`` from the triangle's plane where its projection falls inside the triangle, else inf."""
    return _many("point_triangle_face_distance", x, t1, t2, t3)


def segment_triangle_distance(
    a: np.ndarray, b: np.ndarray, t1: np.ndarray, t2: np.ndarray, t3: np.ndarray
) -> np.ndarray:
    """Exact distance between segment [a, b] and triangle (t1, t2, t3).

    Cobet's test (Fig. B.3-B.5) combines the distance to the triangle's edges with the piercing test; a segment
    running parallel to a face within one strut radius, away from the edges, passes both. Adding the distance of
    the segment's end points to the face makes the result the exact segment-triangle distance.
    """
    return _many("segment_triangle_distance", a, b, t1, t2, t3)


def unique_edges(triangles: np.ndarray) -> np.ndarray:
    """Unique undirected edges (E, 2) of a triangle list (T, 3)."""
    e = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    # return_index: the same sorted rows, without numpy's masked-array check (which imports numpy.ma, ~60 ms)
    return np.unique(np.sort(e, axis=1), axis=0, return_index=True)[0]
