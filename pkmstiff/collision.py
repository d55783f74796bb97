"""Vectorised geometric primitives for the collision checks of spec models.md §8 (Cobet App. B.4).

All functions broadcast over leading axes; points are ``(..., 3)`` arrays in m.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

_EPS = 1e-12


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...k,...k->...", a, b)


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
    u = q1 - p1
    v = q2 - p2
    w = p1 - p2
    a = _dot(u, u)
    b = _dot(u, v)
    c = _dot(v, v)
    d = _dot(u, w)
    e = _dot(v, w)
    denom = a * c - b * b
    parallel = denom <= _EPS * np.maximum(a * c, _EPS)
    safe = np.where(parallel, 1.0, denom)
    a_safe = np.where(a > 0.0, a, 1.0)  # only exact zeros need guarding: the quotients below are well scaled
    c_safe = np.where(c > 0.0, c, 1.0)
    s_line = np.where(parallel, 0.0, (b * e - c * d) / safe)
    if mode == "table_B2":
        t_line = np.where(parallel, 0.0, (a * e - b * d) / safe)
        s = np.clip(s_line, 0.0, 1.0)
        t = np.clip(t_line, 0.0, 1.0)
        dist = np.linalg.norm(w + s[..., None] * u - t[..., None] * v, axis=-1)
        # parallel struts: distance of an end point to the other strut (B.10)
        par = np.minimum(point_segment_distance(p1, p2, q2), point_segment_distance(q1, p2, q2))
        par = np.minimum(par, np.minimum(point_segment_distance(p2, p1, q1), point_segment_distance(q2, p1, q1)))
        return np.where(parallel, par, dist)
    if mode != "exact":
        raise ValueError(f"segment distance mode: expected 'exact' or 'table_B2', found {mode!r}")
    s = np.clip(s_line, 0.0, 1.0)
    t = (b * s + e) / c_safe
    below, above = t < 0.0, t > 1.0
    s = np.where(below, np.clip(-d / a_safe, 0.0, 1.0), np.where(above, np.clip((b - d) / a_safe, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    # degenerate second segment (a point): project it onto the first segment
    point2 = c <= _EPS * np.maximum(a, _EPS)
    s = np.where(point2, np.clip(-d / a_safe, 0.0, 1.0), s)
    t = np.where(point2, 0.0, t)
    return np.linalg.norm(w + s[..., None] * u - t[..., None] * v, axis=-1)


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
    u = q - p
    t = np.clip(_dot(x - p, u) / np.maximum(_dot(u, u), _EPS), 0.0, 1.0)
    return np.linalg.norm(p + t[..., None] * u - x, axis=-1)


def segment_pierces_triangle(
    a: np.ndarray, b: np.ndarray, t1: np.ndarray, t2: np.ndarray, t3: np.ndarray
) -> np.ndarray:
    """True where segment [a, b] intersects triangle (t1, t2, t3) (Moller-Trumbore).

    Implements the piercing test of Cobet Fig. B.5 in the corrected form of the spec (Note to eq. B.12):
    n = t1 + beta (t2 - t1) + gamma (t3 - t1) with beta, gamma >= 0, beta + gamma <= 1 and the intersection
    parameter inside the segment. A segment lying in the triangle's plane does not count as piercing (its edges
    are caught by the edge-distance test).
    """
    e1 = t2 - t1
    e2 = t3 - t1
    dvec = b - a
    pvec = np.cross(dvec, e2)
    det = _dot(e1, pvec)
    ok = np.abs(det) > _EPS * np.maximum(np.linalg.norm(e1, axis=-1) * np.linalg.norm(e2, axis=-1), _EPS)
    inv = 1.0 / np.where(ok, det, 1.0)
    tvec = a - t1
    beta = _dot(tvec, pvec) * inv
    qvec = np.cross(tvec, e1)
    gamma = _dot(dvec, qvec) * inv
    lam = _dot(e2, qvec) * inv
    return ok & (beta >= 0.0) & (gamma >= 0.0) & (beta + gamma <= 1.0) & (lam >= 0.0) & (lam <= 1.0)


def point_triangle_face_distance(
    x: np.ndarray, t1: np.ndarray, t2: np.ndarray, t3: np.ndarray
) -> np.ndarray:
    """Distance of ``x`` from the triangle's plane where its projection falls inside the triangle, else inf."""
    e1 = t2 - t1
    e2 = t3 - t1
    n = np.cross(e1, e2)
    nn = _dot(n, n)
    rel = x - t1
    h = _dot(rel, n) / np.sqrt(np.maximum(nn, _EPS))
    # barycentric coordinates of the projection
    d11, d12, d22 = _dot(e1, e1), _dot(e1, e2), _dot(e2, e2)
    r1, r2 = _dot(rel, e1), _dot(rel, e2)
    beta = (d22 * r1 - d12 * r2) / np.maximum(nn, _EPS)
    gamma = (d11 * r2 - d12 * r1) / np.maximum(nn, _EPS)
    inside = (beta >= 0.0) & (gamma >= 0.0) & (beta + gamma <= 1.0) & (nn > _EPS)
    return np.where(inside, np.abs(h), np.inf)


def segment_triangle_distance(
    a: np.ndarray, b: np.ndarray, t1: np.ndarray, t2: np.ndarray, t3: np.ndarray
) -> np.ndarray:
    """Exact distance between segment [a, b] and triangle (t1, t2, t3).

    Cobet's test (Fig. B.3-B.5) combines the distance to the triangle's edges with the piercing test; a segment
    running parallel to a face within one strut radius, away from the edges, passes both. Adding the distance of
    the segment's end points to the face makes the result the exact segment-triangle distance.
    """
    edge = np.minimum(np.minimum(segment_distance(a, b, t1, t2), segment_distance(a, b, t2, t3)),
                      segment_distance(a, b, t3, t1))
    face = np.minimum(point_triangle_face_distance(a, t1, t2, t3), point_triangle_face_distance(b, t1, t2, t3))
    return np.where(segment_pierces_triangle(a, b, t1, t2, t3), 0.0, np.minimum(edge, face))


def unique_edges(triangles: np.ndarray) -> np.ndarray:
    """Unique undirected edges (E, 2) of a triangle list (T, 3)."""
    e = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    return np.unique(np.sort(e, axis=1), axis=0)
