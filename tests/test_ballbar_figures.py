"""Circle fit and the ISO 230-4 style figures G, F, H (Szatmári §2.2.3.1) against hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest

from pkmstiff.calibration.ballbar import (ball_positions, evaluate_circular_test, fit_circle, hysteresis,
                                          plane_frame)
from pkmstiff.errors import InputError
from tests.ballbar_synth import circle_run

R = 0.15
UM = 1e-6
# The synthetic readings are exact to the rounding of |A − s| ≈ 0.15 m (≈ 3e-17 m) and the Gauss–Newton fit stops
# at a step of 1e-14 R; 1e-12 m covers both with margin.
TOL = 1e-12


def _two_direction_test():
    """CCW: d = 3 µm + 2 µm cos 3θ; CW: d = 1 µm + 1 µm cos 3θ (N divisible by 6: the extremes are sampled).

    Hand computation: a pure 3-lobe radial pattern keeps the LSQ centre at the fixed ball (the pattern is orthogonal
    to cos θ, sin θ) and the LSQ radius at R + mean(d), so
      G_ccw = 2·2 = 4 µm, G_cw = 2·1 = 2 µm; F_ccw = +5/+1 µm, F_cw = +2/0 µm;
      H = max |(3 − 1) + (2 − 1) cos 3θ| = 3 µm;
      circularity (both runs, one circle of radius R + 2 µm): max(1 + 2 cos) − min(−1 + cos) = 3 − (−2) = 5 µm.
    """
    ccw = circle_run(R, 1200, radius_error=3 * UM, lobes={3: (2 * UM, 0.0)})
    cw = circle_run(R, 1200, radius_error=1 * UM, lobes={3: (1 * UM, 0.0)}, direction=-1, start=0.0)
    P = np.concatenate([ccw.positions, cw.positions])
    reading = np.concatenate([ccw.reading, cw.reading])
    direction = np.array(["ccw"] * 1200 + ["cw"] * 1200)
    return evaluate_circular_test(P, reading, (0, 0, 0), R, direction=direction)


def test_G_F_H_hand_computed():
    ev = _two_direction_test()
    ccw, cw = ev.runs["ccw"], ev.runs["cw"]
    assert ccw.circular_deviation == pytest.approx(4 * UM, abs=TOL)
    assert cw.circular_deviation == pytest.approx(2 * UM, abs=TOL)
    assert (ccw.radial_deviation_max, ccw.radial_deviation_min) == pytest.approx((5 * UM, 1 * UM), abs=TOL)
    assert (cw.radial_deviation_max, cw.radial_deviation_min) == pytest.approx((2 * UM, 0.0), abs=TOL)
    assert ev.hysteresis == pytest.approx(3 * UM, abs=TOL)
    assert ev.circularity == pytest.approx(5 * UM, abs=TOL)
    assert ccw.radius_deviation == pytest.approx(3 * UM, abs=TOL)
    assert np.allclose(ccw.centre_offset, 0.0, atol=TOL)


def test_direction_inferred_without_column():
    run = circle_run(R, 500, direction=-1, radius_error=UM)
    ev = evaluate_circular_test(run.positions, run.reading, (0, 0, 0), R)
    assert list(ev.runs) == ["cw"] and ev.hysteresis is None


def test_fit_circle_exact_circle():
    rng = np.random.default_rng(0)
    th = rng.uniform(0, 2 * np.pi, 50)  # scattered points: the geometric fit needs no uniform sampling
    c, r = np.array([0.3, -0.2]), 0.123
    fit = fit_circle(c + r * np.column_stack([np.cos(th), np.sin(th)]))
    assert np.allclose(fit.centre, c, atol=TOL) and fit.radius == pytest.approx(r, abs=TOL)
    assert np.max(np.abs(fit.residual)) < TOL


def test_fit_circle_geometric_not_algebraic():
    # points on a partial arc with noise: the geometric fit minimises Σ residual², so perturbing its solution
    # in any direction must not lower the cost (first-order optimality, checked by central differences)
    rng = np.random.default_rng(1)
    th = rng.uniform(0, 2.0, 80)
    q = (0.1 + rng.normal(0, 1e-3, 80))[:, None] * np.column_stack([np.cos(th), np.sin(th)])
    fit = fit_circle(q)
    x0 = np.array([*fit.centre, fit.radius])

    def cost(x):
        return np.sum((np.linalg.norm(q - x[:2], axis=1) - x[2]) ** 2)

    h = 1e-7
    grad = [(cost(x0 + h * e) - cost(x0 - h * e)) / (2 * h) for e in np.eye(3)]
    # gradient of a cost of size ~8e-5 m² at the optimum: central-difference noise ~ eps·cost/h ≈ 1e-13
    assert np.max(np.abs(grad)) < 1e-9


@pytest.mark.parametrize("plane,e1,e2", [("YZ", (0, 1, 0), (0, 0, 1)), ("ZX", (0, 0, 1), (1, 0, 0)),
                                         ("XY", (1, 0, 0), (0, 1, 0))])
def test_any_coordinate_plane(plane, e1, e2):
    s = np.array([0.1, -0.2, 0.35])
    e = (12 * UM, -5 * UM)
    run = circle_run(R, 800, offset=e, e1=e1, e2=e2, fixed_ball=s)
    ev = evaluate_circular_test(run.positions, run.reading, s, R)
    assert ev.plane.name == plane
    r = ev.runs["ccw"]
    # an exact circle of centre s + e: the bar measures length only, so each reading is placed along the commanded
    # direction; that polar curve R + e cos α + e² sin²α/(2R) differs from the circle of centre e
    # (R + e cos α − e² sin²α/(2R)) by e² sin²α / R: the fitted centre is e to O(e²/R) and G = e²/R to O(e³/R²)
    emag2 = e[0] ** 2 + e[1] ** 2
    assert np.allclose(r.centre_offset, e, atol=emag2 / R)
    assert np.allclose(r.centre_offset_xyz, e[0] * np.array(e1) + e[1] * np.array(e2), atol=emag2 / R)
    assert r.circular_deviation == pytest.approx(emag2 / R, rel=1e-3)


def test_oblique_plane_and_explicit_normal():
    n = np.array([1.0, 1.0, 1.0]) / np.sqrt(3)
    e1 = np.array([1.0, -1.0, 0.0]) / np.sqrt(2)
    e2 = np.cross(n, e1)
    s = np.array([0.0, 0.05, -0.1])
    off = np.array([8 * UM, 3 * UM])
    run = circle_run(R, 900, offset=tuple(off), e1=e1, e2=e2, fixed_ball=s, start=0.0)
    for plane in ("auto", n):
        ev = evaluate_circular_test(run.positions, run.reading, s, R, plane=plane)
        assert abs(abs(ev.plane.normal @ n) - 1) < 1e-12
        true_xyz = off[0] * e1 + off[1] * e2
        # second-order ball-bar effect, see test_any_coordinate_plane
        assert np.allclose(ev.runs["ccw"].centre_offset_xyz, true_xyz, atol=off @ off / R)


def test_non_planar_positions_rejected():
    run = circle_run(R, 400)
    P = run.positions.copy()
    P[:, 2] = 0.01 * np.sin(2 * run.theta)  # saddle: 10 mm out of plane
    with pytest.raises(InputError, match="not in the"):
        evaluate_circular_test(P, run.reading, (0, 0, 0), R, plane="XY")
    with pytest.raises(InputError, match="plane must be"):
        plane_frame(run.positions, (0, 0, 0), "QQ")


def test_hysteresis_symmetric_and_zero_for_identical_runs():
    th = np.linspace(0, 2 * np.pi, 500, endpoint=False)
    d = 2 * UM * np.cos(2 * th)
    assert hysteresis(th, d, th[::-1], d[::-1]) == pytest.approx(0.0, abs=1e-18)
    assert hysteresis(th, d, th, d + UM) == pytest.approx(UM, abs=1e-18)
    assert hysteresis(th, d + UM, th, d) == hysteresis(th, d, th, d + UM)


def test_ball_positions_rotate_offset():
    poses = np.array([[0.1, 0.2, 0.3, 0.0, 0.0, np.pi / 2]])
    # rotation c = 90° about z maps the offset (0.01, 0, 0.05) to (0, 0.01, 0.05)
    assert np.allclose(ball_positions(poses, [0.01, 0.0, 0.05]), [[0.1, 0.21, 0.35]], atol=1e-15)
