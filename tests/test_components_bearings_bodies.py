"""Dietl bearing model (eq. 3.31-3.32), test-rig evaluation (eq. 3.33-3.36), rigid bodies and body stiffness."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from components import ComponentState
from components.bearings import TaperedRollerBearing, dietl_stiffness_matrix, evaluate_test_rig, roller_positions
from components.bodies import BodyStiffness, RigidBody, reference_matrix, shift_mass_matrix, skew
from pkmstiff.units import si, to_unit

DEG = math.radians


# ------------------------------------------------------------------ Dietl
def test_dietl_iwf_joint_bearing_reproduces_published_stiffness():
    b = TaperedRollerBearing(name="b", n_rollers=21, k_roller=si(22.5, "N/um"), contact_angle=DEG(30.1))
    assert to_unit(b.k_radial, "N/um") == pytest.approx(176.8, abs=0.1)  # printed with one decimal
    assert to_unit(b.k_axial, "N/um") == pytest.approx(118.8, abs=0.1)
    # closed forms for equally spaced rollers, component-data.md §6 "Check" line
    assert to_unit(b.k_radial, "N/um") == pytest.approx(21 / 2 * 22.5 * math.cos(DEG(30.1)) ** 2, rel=1e-12)
    assert to_unit(b.k_axial, "N/um") == pytest.approx(21 * 22.5 * math.sin(DEG(30.1)) ** 2, rel=1e-12)
    assert "roller_angles" in b.assumptions
    K = b.stiffness(ComponentState(n_poses=2))
    assert K.shape == (2, 3, 3)


@given(st.integers(3, 40), st.floats(1e7, 1e9), st.floats(0.05, 1.5), st.floats(0.0, 0.2))
@settings(max_examples=50, deadline=None)
def test_dietl_matrix_closed_form_for_equal_spacing(n, k, alpha, r):
    K = dietl_stiffness_matrix(k, alpha, roller_positions(n), r)
    sa, ca = math.sin(alpha), math.cos(alpha)
    # sum cos^2(phi_i) = n/2 and sum cos(phi_i) = 0 for n >= 3 equally spaced angles
    expected = np.array([[n / 2 * k * ca**2, 0.0, -n / 2 * k * r * sa * ca],
                         [0.0, n * k * sa**2, 0.0],
                         [-n / 2 * k * r * sa * ca, 0.0, n / 2 * k * r**2 * sa**2]])
    np.testing.assert_allclose(K, expected, rtol=1e-9, atol=1e-9 * n * k)
    assert np.linalg.eigvalsh(K).min() >= -1e-6 * n * k  # sum of dyads: positive semi-definite


def test_explicit_roller_angles():
    phi = (0.0, np.pi / 2, np.pi, 3 * np.pi / 2)
    explicit = TaperedRollerBearing(name="b", n_rollers=4, k_roller=1e8, contact_angle=0.5, roller_angles=phi)
    spaced = TaperedRollerBearing(name="b", n_rollers=4, k_roller=1e8, contact_angle=0.5)
    np.testing.assert_allclose(explicit.matrix, spaced.matrix, atol=1e-6)
    with pytest.raises(ValueError, match="4 entries"):
        TaperedRollerBearing(name="b", n_rollers=4, k_roller=1e8, contact_angle=0.5, roller_angles=(0.0, 1.0))


# ------------------------------------------------------------------ test rig, eq. 3.33-3.36
GEOM = dict(b_h1=0.05, b_h2=0.07, l_h1=0.06, l_h3=0.04, r=0.1)


def test_test_rig_pure_translation_and_tangential():
    # equal probe readings: no plate rotation, dl = cos(alpha) dh; a tangential reading adds -sin(alpha) dt
    res = evaluate_test_rig(10e-6, 10e-6, 10e-6, 0.0, alpha=DEG(30.0), **GEOM)
    assert res.phi == 0.0 and res.theta == 0.0 and res.dl_rot == 0.0
    assert res.dl == pytest.approx(math.cos(DEG(30.0)) * 10e-6, rel=1e-12)
    res = evaluate_test_rig(0.0, 0.0, 0.0, 4e-6, alpha=DEG(30.0), **GEOM)
    assert res.dl == pytest.approx(-0.5 * 4e-6, rel=1e-12)


def test_test_rig_hand_computation():
    # dh1 = 12 um, dh2 = 0, dh3 = 2 um, dt = 1 um, alpha = 0:
    # phi = atan(12e-6 / 0.12) = atan(1e-4); theta = atan(10e-6 / 0.10) = atan(1e-4)
    # dl_rot = 0.1 (cos(phi) - 1) + 0.1 (1 - cos(theta)) = 0 (phi == theta)
    # dl_trans = 12e-6 + 0.6 (2e-6 - 12e-6) + 0.05/0.12 (0 - 12e-6) - 0 = 12 - 6 - 5 = 1 um
    res = evaluate_test_rig(12e-6, 0.0, 2e-6, 1e-6, alpha=0.0, **GEOM)
    assert res.phi == pytest.approx(math.atan(1e-4), rel=1e-12)
    assert res.theta == pytest.approx(math.atan(1e-4), rel=1e-12)
    assert res.dl_rot == pytest.approx(0.0, abs=1e-16)  # r * machine epsilon: cancellation of two ~5e-10 m terms
    assert res.dl_trans == pytest.approx(1e-6, rel=1e-9)
    # alpha = 90 deg: cos alpha = 0 -> dl_rot = r (cos(90deg - phi) - 0) = r sin(phi), dl_trans = -dt
    res = evaluate_test_rig(12e-6, 0.0, 2e-6, 1e-6, alpha=math.pi / 2, **GEOM)
    assert res.dl == pytest.approx(0.1 * math.sin(math.atan(1e-4)) - 1e-6, rel=1e-9)


# ------------------------------------------------------------------ bodies
def _random_body(rng):
    A = rng.normal(size=(3, 3))
    return RigidBody(name="p", mass=float(rng.uniform(10, 200)), inertia=A @ A.T + np.eye(3),
                     cog=rng.normal(scale=0.2, size=3))


def test_mass_matrix_about_cog_and_parallel_axis_hand_value():
    body = RigidBody(name="p", mass=117.24, inertia=[7.42, 7.74, 2.87])
    M = body.mass_matrix()
    np.testing.assert_allclose(np.diag(M), [117.24] * 3 + [7.42, 7.74, 2.87], rtol=1e-15)
    # CoG 0.2 m above the point: I_xx and I_yy grow by m d^2, I_zz unchanged; coupling m [rho]x
    MO = body.mass_matrix_about(point=[0.0, 0.0, -0.2])
    assert MO[3, 3] == pytest.approx(7.42 + 117.24 * 0.04, rel=1e-12)
    assert MO[4, 4] == pytest.approx(7.74 + 117.24 * 0.04, rel=1e-12)
    assert MO[5, 5] == pytest.approx(2.87, rel=1e-12)
    np.testing.assert_allclose(MO[3:, :3], 117.24 * skew([0.0, 0.0, 0.2]), rtol=1e-12)


@given(st.integers(0, 2**31 - 1))
@settings(max_examples=40, deadline=None)
def test_kinetic_energy_is_independent_of_the_reference_point(seed):
    rng = np.random.default_rng(seed)
    body = _random_body(rng)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    R = Q * np.sign(np.linalg.det(Q))
    origin, point = rng.normal(size=3), rng.normal(size=3)
    v_o, omega = rng.normal(size=3), rng.normal(size=3)
    cog = origin + R @ body.cog
    v_cg = v_o + np.cross(omega, cog - point)  # rigid-body velocity field from the point O to the CoG
    T_cg = 0.5 * body.mass * v_cg @ v_cg + 0.5 * omega @ (R @ body.inertia @ R.T) @ omega
    t_o = np.concatenate([v_o, omega])
    T_o = 0.5 * t_o @ body.mass_matrix_about(point, origin, R) @ t_o
    assert T_o == pytest.approx(T_cg, rel=1e-10)


def test_shift_mass_matrix_is_batched_and_reference_matrix_matches_cross_product():
    rng = np.random.default_rng(7)
    delta = rng.normal(size=(4, 3))
    q = rng.normal(size=6)
    N = reference_matrix(delta)
    np.testing.assert_allclose(N[2] @ q, np.concatenate([q[:3] + np.cross(q[3:], delta[2]), q[3:]]), rtol=1e-12)
    M = RigidBody(name="b", mass=3.0, inertia=[1.0, 2.0, 3.0]).mass_matrix()
    shifted = shift_mass_matrix(M, delta)
    assert shifted.shape == (4, 6, 6)
    np.testing.assert_allclose(shifted, np.swapaxes(shifted, -1, -2), atol=1e-12)


def test_rigid_body_validation():
    with pytest.raises(ValueError, match="symmetric"):
        RigidBody(name="b", mass=1.0, inertia=[[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    with pytest.raises(ValueError, match="semi-definite"):
        RigidBody(name="b", mass=1.0, inertia=[1.0, -1.0, 1.0])
    assert np.isposinf(RigidBody(name="b", mass=1.0).stiffness(ComponentState(n_poses=2))).all()


def test_body_stiffness_units_validation_and_rotation():
    kp = BodyStiffness.from_units([1603, 1567, 588, 4348, 5115, 2564])
    np.testing.assert_allclose(np.diag(kp.matrix), [1.603e9, 1.567e9, 5.88e8, 4.348e9, 5.115e9, 2.564e9], rtol=1e-12)
    alt = BodyStiffness.from_units([1603, 1567, 588, 4348, 5115, 2564], rotational_unit="N*mm/urad")
    assert alt.matrix[3, 3] == pytest.approx(4.348e6, rel=1e-12)  # the alternative reading of machines.md §1.4
    with pytest.raises(ValueError, match="symmetric"):
        BodyStiffness(matrix=np.eye(6) + np.triu(np.ones((6, 6)), 1))
    with pytest.raises(ValueError, match="positive definite"):
        BodyStiffness(matrix=np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 0.0]))
    Rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90 deg about z swaps x and y
    K = kp.in_mks(Rz)
    np.testing.assert_allclose(np.diag(K), np.diag(kp.matrix)[[1, 0, 2, 4, 3, 5]], rtol=1e-12)
    assert kp.stiffness(ComponentState(n_poses=3)).shape == (3, 6, 6)
