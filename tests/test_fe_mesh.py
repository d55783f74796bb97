"""Structured hexahedral primitives of pkmstiff.fe.mesh: exact polygonal volumes, valid elements, errors."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skfem import Basis, ElementHex1

from pkmstiff.fe import mesh as fm


def polygon_area(radius: float, n: int) -> float:
    """Area of the regular n-gon inscribed in a circle (the faceted cross-section of the primitives)."""
    return 0.5 * n * radius**2 * math.sin(2 * math.pi / n)


def min_jacobian(m) -> float:
    """Smallest Jacobian determinant at the Gauss points, signed so that skfem's own tensor meshes are > 0.

    ``MeshHex.init_tensor`` elements have det J < 0 in scikit-fem's vertex order; a valid (untangled) mesh in
    the same order has det J < 0 at every Gauss point.
    """
    b = Basis(m, ElementHex1(), intorder=2)
    return float((-b.mapping.detDF(b.X)).min())


# Volumes of straight-edged meshes of polygons are exact up to round-off: relative tolerance 1e-12.
REL = 1e-12


@settings(max_examples=25, deadline=None)
@given(r=st.floats(0.005, 0.1), length=st.floats(0.01, 0.3), n4=st.integers(2, 8), h=st.floats(0.004, 0.05))
def test_cylinder_volume_is_the_polygon_prism(r, length, n4, h):
    n_phi = 4 * n4
    m = fm.cylinder((0, 0, 0), (0, 0, length), r, h, n_phi=n_phi)
    assert fm.mesh_volume(m) == pytest.approx(polygon_area(r, n_phi) * length, rel=REL)
    assert min_jacobian(m) > 0


@settings(max_examples=25, deadline=None)
@given(r0=st.floats(0.005, 0.05), t=st.floats(0.001, 0.03), length=st.floats(0.005, 0.2), n4=st.integers(2, 8))
def test_tube_volume_is_the_polygon_annulus(r0, t, length, n4):
    n_phi = 4 * n4
    m = fm.tube((0, 0, 0), (0, length, 0), r0, r0 + t, 0.01, n_phi=n_phi)
    expected = (polygon_area(r0 + t, n_phi) - polygon_area(r0, n_phi)) * length
    assert fm.mesh_volume(m) == pytest.approx(expected, rel=REL)
    assert min_jacobian(m) > 0
    # the tube lies along y: every node at distance <= r0 + t from the y axis
    assert np.hypot(m.p[0], m.p[2]).max() == pytest.approx(r0 + t, rel=1e-12)


@settings(max_examples=25, deadline=None)
@given(hx=st.floats(0.02, 0.1), hy=st.floats(0.02, 0.1), frac=st.floats(0.2, 0.8), length=st.floats(0.01, 0.1),
       axis=st.sampled_from(["x", "y", "z"]))
def test_block_with_bore_volume(hx, hy, frac, length, axis):
    r = frac * min(hx, hy)
    k = "xyz".index(axis)
    lo, hi = np.zeros(3), np.zeros(3)
    others = [i for i in range(3) if i != k]
    # local x, y of the primitive map to the cyclically next axes of the global frame
    lo[others], hi[others] = -1.0, 1.0
    lo[k], hi[k] = 0.0, length
    half = {others[0]: hx, others[1]: hy}
    for i, v in half.items():
        lo[i], hi[i] = -v, v
    m = fm.block_with_bore(lo, hi, axis, r, 0.01)
    # hole polygon vertices are radial projections of the side nodes: area = sum of triangle areas
    bore = m.p[:, np.abs(np.linalg.norm(np.delete(m.p, k, axis=0), axis=0) - r) < 1e-12]
    pts = np.delete(bore, k, axis=0)
    pts = np.unique(np.round(pts.T, 15), axis=0).T
    ang = np.sort(np.arctan2(pts[1], pts[0]))
    dphi = np.diff(np.concatenate([ang, ang[:1] + 2 * np.pi]))
    hole = 0.5 * r**2 * np.sum(np.sin(dphi))
    assert fm.mesh_volume(m) == pytest.approx((4 * hx * hy - hole) * length, rel=1e-10)
    assert min_jacobian(m) > 0
    assert np.allclose(m.p.min(axis=1), lo) and np.allclose(m.p.max(axis=1), hi)


def test_box_and_rotation_helpers():
    m = fm.box((0, -1, 2), (3, 1, 2.5), 0.5)
    assert fm.mesh_volume(m) == pytest.approx(3 * 2 * 0.5, rel=REL)
    R = fm.rotation((0, 1, 0), math.radians(30))
    assert R @ np.array([0, 0, 1.0]) == pytest.approx([0.5, 0, math.sqrt(3) / 2])
    assert R.T @ R == pytest.approx(np.eye(3))
    moved = fm.transformed(m, R, (1, 2, 3))
    assert fm.mesh_volume(moved) == pytest.approx(fm.mesh_volume(m), rel=1e-12)


@pytest.mark.parametrize("call, match", [
    (lambda: fm.cylinder((0, 0, 0), (0.1, 0.1, 0), 0.01, 0.01), "exactly one coordinate axis"),
    (lambda: fm.tube((0, 0, 0), (0, 0, 1), 0.02, 0.01, 0.01), "r_inner < r_outer"),
    (lambda: fm.block_with_bore((-1, -1, 0), (1, 1, 1), "z", 1.5, 0.1), "bore radius"),
    (lambda: fm.box((0, 0, 0), (1, -1, 1), 0.1), "hi > lo"),
    (lambda: fm.disk2d(1.0, 10, 2), "multiple of 4"),
])
def test_impossible_geometry_is_rejected(call, match):
    with pytest.raises(fm.ArgumentError, match=match):
        call()
