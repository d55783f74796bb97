"""Collision primitives: every row of Cobet Table B.2, exactness of the segment distance, piercing test."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize

from pkmstiff.admissibility.collision import (
    line_parameters,
    point_segment_distance,
    segment_distance,
    segment_pierces_triangle,
    segment_triangle_distance,
    unique_edges,
)


def brute_force_distance(p1, q1, p2, q2):
    """Reference: minimise the convex squared distance over the parameter box (multi-start L-BFGS-B)."""
    u, v = q1 - p1, q2 - p2

    def f(x):
        r = p1 + x[0] * u - p2 - x[1] * v
        return r @ r, np.array([2 * r @ u, -2 * r @ v])

    best = np.inf
    for x0 in ([0.5, 0.5], [0, 0], [1, 1], [0, 1], [1, 0]):
        res = minimize(f, x0, jac=True, bounds=[(0, 1), (0, 1)], method="L-BFGS-B",
                       options={"ftol": 1e-15, "gtol": 1e-12})
        best = min(best, res.fun)
    return np.sqrt(max(best, 0.0))


# Strut i: from p_i = 0 along +x, length l_i = 1. Strut j: along a direction e (not parallel to x) at height h,
# placed so that the infinite lines' closest points are at nu0 on strut i and mu0 on strut j.
H = 0.3


def strut_pair(nu0, mu0, e=(0.0, 1.0, 0.0), l_j=1.0):
    e = np.asarray(e, float) / np.linalg.norm(e)
    d_i = np.array([1.0, 0.0, 0.0])
    normal = np.cross(d_i, e)
    normal /= np.linalg.norm(normal)
    p_i, q_i = np.zeros(3), d_i.copy()
    c_i = nu0 * d_i  # closest point on line i
    c_j = c_i + H * normal  # closest point on line j
    p_j = c_j - mu0 * e
    q_j = p_j + l_j * e
    return p_i, q_i, p_j, q_j, d_i, e


# (nu0, mu0, expected Table B.2 distance as a function of the geometry) — one case per table row
ROWS = [
    ("nu<=0, mu<=0", -0.4, -0.3, lambda pi, qi, pj, qj, di, dj, nu, mu: np.linalg.norm(pi - pj)),
    ("nu<=0, mu>=l", -0.4, 1.3, lambda pi, qi, pj, qj, di, dj, nu, mu: np.linalg.norm(pi - qj)),
    ("nu<=0, 0<=mu<=l", -0.4, 0.6, lambda pi, qi, pj, qj, di, dj, nu, mu: np.linalg.norm(pj + mu * dj - pi)),
    ("0<=nu<=l, mu<=0", 0.5, -0.3, lambda pi, qi, pj, qj, di, dj, nu, mu: np.linalg.norm(pi + nu * di - pj)),
    ("0<=nu<=l, mu>=l", 0.5, 1.3, lambda pi, qi, pj, qj, di, dj, nu, mu: np.linalg.norm(pi + nu * di - qj)),
    ("0<=nu<=l, 0<=mu<=l", 0.5, 0.6,
     lambda pi, qi, pj, qj, di, dj, nu, mu: np.linalg.norm(pi + nu * di - (pj + mu * dj))),
    ("nu>=l, 0<=mu<=l", 1.4, 0.6, lambda pi, qi, pj, qj, di, dj, nu, mu: np.linalg.norm(pj + mu * dj - qi)),
    ("nu>=l, mu<=0", 1.4, -0.3, lambda pi, qi, pj, qj, di, dj, nu, mu: np.linalg.norm(qi - pj)),
    ("nu>=l, mu>=l", 1.4, 1.3, lambda pi, qi, pj, qj, di, dj, nu, mu: np.linalg.norm(qi - qj)),
]


@pytest.mark.parametrize("name,nu0,mu0,table", ROWS, ids=[r[0] for r in ROWS])
@pytest.mark.parametrize("e", [(0.0, 1.0, 0.0), (0.6, 0.8, 0.0), (-0.5, 0.7, 0.5)])
def test_table_b2_rows(name, nu0, mu0, table, e):
    pi, qi, pj, qj, di, dj = strut_pair(nu0, mu0, e)
    nu, mu, tau = line_parameters(pi, di, pj, dj)
    # eq. B.11 recovers the construction parameters (exact arithmetic up to round-off)
    assert nu == pytest.approx(nu0, abs=1e-12)
    assert mu == pytest.approx(mu0, abs=1e-12)
    # tau multiplies the unnormalised d_i x d_j, so |tau| |d_i x d_j| is the distance of the lines
    assert abs(tau) * np.linalg.norm(np.cross(di, dj)) == pytest.approx(H, abs=1e-12)
    expected_table = table(pi, qi, pj, qj, di, dj, nu, mu)
    assert segment_distance(pi, qi, pj, qj, mode="table_B2") == pytest.approx(expected_table, rel=1e-12)
    exact = segment_distance(pi, qi, pj, qj, mode="exact")
    # the exact distance is the true minimum (the optimiser reaches ~1e-8 relative) and never above the table value
    assert exact == pytest.approx(brute_force_distance(pi, qi, pj, qj), rel=1e-6, abs=1e-9)
    assert exact <= expected_table + 1e-12


def test_table_b2_can_miss_a_collision():
    # A configuration where the dissertation's table overestimates: strut j oblique, infinite-line closest point of
    # strut i beyond its end while the segments come close (Note to Table B.2).
    pi, qi, pj, qj, di, dj = strut_pair(1.4, 0.6, e=(0.2, 1.0, 0.0))
    table = segment_distance(pi, qi, pj, qj, mode="table_B2")
    exact = segment_distance(pi, qi, pj, qj, mode="exact")
    assert exact < table - 1e-3  # clearly smaller: a strut radius between the two would be missed by the table


def test_parallel_struts():
    p1, q1 = np.zeros(3), np.array([1.0, 0, 0])
    p2, q2 = np.array([0.5, 0.2, 0.0]), np.array([1.5, 0.2, 0.0])  # overlapping parallel
    assert segment_distance(p1, q1, p2, q2) == pytest.approx(0.2, abs=1e-12)
    assert segment_distance(p1, q1, p2, q2, mode="table_B2") == pytest.approx(0.2, abs=1e-12)
    p3, q3 = np.array([2.0, 0.2, 0.0]), np.array([3.0, 0.2, 0.0])  # parallel, end to end
    assert segment_distance(p1, q1, p3, q3) == pytest.approx(np.hypot(1.0, 0.2), abs=1e-12)
    nu, mu, tau = line_parameters(p1, np.array([1.0, 0, 0]), p2, np.array([1.0, 0, 0]))
    assert np.isnan(nu) and np.isnan(mu)


coord = st.floats(-2, 2, allow_nan=False)
point = st.tuples(coord, coord, coord).map(np.array)


@settings(max_examples=150, deadline=None)
@given(point, point, point, point)
def test_exact_distance_is_the_minimum(p1, q1, p2, q2):
    exact = segment_distance(p1, q1, p2, q2)
    ref = brute_force_distance(p1, q1, p2, q2)
    # L-BFGS-B on the convex quadratic reaches the minimum to ~1e-7 absolute in the distance
    assert exact == pytest.approx(ref, abs=2e-6)
    assert exact <= segment_distance(p1, q1, p2, q2, mode="table_B2") + 1e-12


def test_vectorised_shapes():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(7, 5, 3))
    b = rng.normal(size=(7, 5, 3))
    c = rng.normal(size=(7, 5, 3))
    d = rng.normal(size=(7, 5, 3))
    out = segment_distance(a, b, c, d)
    assert out.shape == (7, 5)
    assert out[3, 2] == pytest.approx(segment_distance(a[3, 2], b[3, 2], c[3, 2], d[3, 2]), rel=1e-14)


def test_point_segment_distance():
    p, q = np.zeros(3), np.array([2.0, 0, 0])
    assert point_segment_distance(np.array([1.0, 1.0, 0]), p, q) == pytest.approx(1.0)
    assert point_segment_distance(np.array([-1.0, 0, 0]), p, q) == pytest.approx(1.0)
    assert point_segment_distance(np.array([3.0, 0, 2.0]), p, q) == pytest.approx(np.sqrt(5.0))


TRI = (np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([0.0, 1, 0]))


@pytest.mark.parametrize(
    "a,b,expected",
    [
        ((0.2, 0.2, -1), (0.2, 0.2, 1), True),  # through the interior
        ((0.6, 0.6, -1), (0.6, 0.6, 1), False),  # outside (beta + gamma > 1)
        ((0.2, 0.2, 0.1), (0.2, 0.2, 1), False),  # segment ends above the plane
        ((-0.1, 0.2, -1), (-0.1, 0.2, 1), False),  # beta < 0
        ((0.2, 0.2, -1), (0.4, 0.1, 1), True),  # oblique, crossing inside
    ],
)
def test_piercing(a, b, expected):
    assert bool(segment_pierces_triangle(np.array(a, float), np.array(b, float), *TRI)) is expected


def test_unique_edges_of_tetrahedron():
    tris = np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]])
    assert unique_edges(tris).shape == (6, 2)


@settings(max_examples=80, deadline=None)
@given(point, point, point, point, point)
def test_segment_triangle_distance_is_exact(a, b, t1, t2, t3):
    from hypothesis import assume

    # well-conditioned triangle (area not tiny against its longest edge): the SLSQP reference below stalls on
    # sliver triangles, where it is the reference, not the kernel, that is wrong
    longest = max(np.linalg.norm(t2 - t1), np.linalg.norm(t3 - t2), np.linalg.norm(t1 - t3))
    assume(np.linalg.norm(np.cross(t2 - t1, t3 - t1)) > 1e-2 * max(longest, 1e-9) ** 2)

    # reference: minimise over the segment parameter s and barycentric (u, v) with u, v >= 0, u + v <= 1
    def f(x):
        s_, u, v = x
        r = a + s_ * (b - a) - (t1 + u * (t2 - t1) + v * (t3 - t1))
        return r @ r

    from scipy.optimize import LinearConstraint

    con = LinearConstraint([[0, 1, 1]], -np.inf, 1.0)
    best = min(minimize(f, x0, bounds=[(0, 1), (0, 1), (0, 1)], constraints=[con], method="SLSQP",
                        options={"ftol": 1e-14, "maxiter": 500}).fun
               for x0 in ([0.5, 0.3, 0.3], [0.5, 0.05, 0.05], [0, 0.9, 0.05], [1, 0.05, 0.9])
               + tuple([s0, u0, v0] for s0 in (0, 1) for u0, v0 in ((0, 0), (1, 0), (0, 1))))
    # (also a start at every segment end x triangle vertex: SLSQP stalls short of a touching vertex otherwise)
    # SLSQP on a convex quadratic over a polytope: ~1e-6 absolute in the distance
    assert segment_triangle_distance(a, b, t1, t2, t3) == pytest.approx(np.sqrt(max(best, 0)), abs=2e-5)
