"""Tests of pkmstiff.kinematics.rotation: Cardan matrices (spec models.md §1.1), their inverse, E(a, b), skew, exp map."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from pkmstiff.kinematics.rotation import (
    cardan_angles,
    cardan_matrix,
    cardan_rate_matrix,
    rotation_from_axis_angle,
    skew,
)

angle = st.floats(-np.pi, np.pi, allow_nan=False)
small_b = st.floats(-np.deg2rad(80.0), np.deg2rad(80.0), allow_nan=False)
vec3 = st.lists(st.floats(-3.0, 3.0, allow_nan=False), min_size=3, max_size=3)


def Ra(a):  # Cobet eq. A.1, typed from the spec
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def Rb(b):  # eq. A.2
    return np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])


def Rc(c):  # eq. A.3
    return np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])


@settings(max_examples=200, deadline=None)
@given(angle, angle, angle)
def test_cardan_matrix_is_product_of_elementary_rotations(a, b, c):
    # products of three rotations: entries carry a few ulp of rounding, 1e-14 is ~50 ulp
    np.testing.assert_allclose(cardan_matrix(a, b, c), Ra(a) @ Rb(b) @ Rc(c), atol=1e-14)


@settings(max_examples=200, deadline=None)
@given(angle, angle, angle)
def test_cardan_matrix_orthonormal_det_one(a, b, c):
    R = cardan_matrix(a, b, c)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)  # rounding of 3-term dot products
    assert abs(np.linalg.det(R) - 1.0) < 1e-14


def test_note_on_a5_printed_matrix_differs_for_rotated_poses():
    # Note (spec §1.1): printed A.5 equals R_x(c) R_y(b) R_z(a); it must not be what we implement
    a, b, c = 0.3, -0.2, 0.7
    printed = Ra(c) @ Rb(b) @ Rc(a)
    assert np.abs(cardan_matrix(a, b, c) - printed).max() > 0.1
    np.testing.assert_array_equal(cardan_matrix(0.0, 0.0, 0.0), np.eye(3))  # both agree at a = b = c = 0


def test_cardan_matrix_broadcasts():
    a = np.linspace(-1, 1, 5)
    R = cardan_matrix(a, 0.1, np.zeros((2, 1)))
    assert R.shape == (2, 5, 3, 3)
    np.testing.assert_allclose(R[1, 3], Ra(a[3]) @ Rb(0.1), atol=1e-15)


@settings(max_examples=200, deadline=None)
@given(angle, small_b, angle)
def test_cardan_angles_round_trip(a, b, c):
    # |b| <= 80 deg keeps the inverse well conditioned (1/cos b <= 5.8): 1e-12 rad covers the rounding
    got = cardan_angles(cardan_matrix(a, b, c))
    np.testing.assert_allclose(got, [a, b, c], atol=1e-12)


def test_cardan_angles_rejects_bad_shape():
    with pytest.raises(ValueError, match=r"\(\.\.\., 3, 3\)"):
        cardan_angles(np.zeros((3, 2)))


@settings(max_examples=100, deadline=None)
@given(angle, small_b, angle, vec3)
def test_rate_matrix_maps_cardan_rates_to_angular_velocity(a, b, c, rates):
    # [ω]× = Ṙ Rᵀ with Ṙ by central differences: truncation O(h²) ≈ 1e-10, rounding eps/h ≈ 1e-10
    rates = np.asarray(rates)
    h = 1e-5
    Rp = cardan_matrix(*(np.array([a, b, c]) + h * rates))
    Rm = cardan_matrix(*(np.array([a, b, c]) - h * rates))
    W = (Rp - Rm) / (2 * h) @ cardan_matrix(a, b, c).T
    omega = np.array([W[2, 1], W[0, 2], W[1, 0]])
    np.testing.assert_allclose(cardan_rate_matrix(a, b) @ rates, omega, atol=1e-8)
    assert abs(np.linalg.det(cardan_rate_matrix(a, b)) - np.cos(b)) < 1e-14


@settings(max_examples=100, deadline=None)
@given(vec3, vec3)
def test_skew_is_cross_product(v, u):
    S = skew(v)
    np.testing.assert_allclose(S @ np.asarray(u), np.cross(v, u), atol=1e-14)
    np.testing.assert_array_equal(S, -S.T)


@settings(max_examples=200, deadline=None)
@given(vec3)
def test_rotation_from_axis_angle_matches_scipy(w):
    R = rotation_from_axis_angle(w)
    # scipy computes the same map by quaternions; different rounding, 1e-14 is ~50 ulp
    np.testing.assert_allclose(R, Rotation.from_rotvec(w).as_matrix(), atol=1e-14)
    np.testing.assert_allclose(R @ np.asarray(w), w, atol=1e-14)  # the axis is invariant


def test_rotation_from_axis_angle_small_and_zero():
    np.testing.assert_array_equal(rotation_from_axis_angle([0.0, 0.0, 0.0]), np.eye(3))
    w = np.array([1e-9, -2e-9, 3e-9])
    # exp([w]×) = I + [w]× + O(|w|²); |w|² ≈ 1.4e-17 is below the rounding of the unit diagonal
    np.testing.assert_allclose(rotation_from_axis_angle(w), np.eye(3) + skew(w), atol=1e-16)
    ws = np.array([[0.1, 0.2, 0.3], [0.0, 0.0, np.pi]])
    assert rotation_from_axis_angle(ws).shape == (2, 3, 3)
