"""Calibration 1: Denkena's double pendulum (§1.5, Gl. 93–96) and the implicit-function-theorem sensitivities."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from pkmstiff.calibration import pendulum as P
from pkmstiff.calibration.implicit import implicit_sensitivity
from pkmstiff.errors import InadmissibleError

angles = st.floats(-np.pi, np.pi)


@settings(max_examples=40, deadline=None)
@given(angles, angles, angles, angles, st.floats(-2, 2), st.floats(-2, 2), st.floats(0.3, 2), st.floats(0.3, 2))
def test_identification_jacobian_is_14_by_8_of_rank_8_at_generic_poses(a1, a2, b1, b2, zx, zy, L1, L2):
    p = np.array([L1, L2])
    u = np.array([[a1, a2], [b1, b2]])
    z = np.array([zx, zy])
    x = P.forward(p, u)[:, :2]
    red = P.reading_jacobian(z, p, u)  # the 2 × 2 reduced Jacobian decides the rank (see pendulum docstring)
    d = np.linalg.norm(x - z, axis=1)
    # generic: measurement point away from the tips, reduced Jacobian far from singular
    assume(d.min() > 0.05 and abs(np.linalg.det(red)) > 1e-3)
    J = P.extended_jacobian(z, p, u)
    assert J.shape == (14, 8)
    s = np.linalg.svd(J, compute_uv=False)
    assert s[-1] > 1e-8 * s[0]  # rank 8 (well above rounding, 1e-16)


def test_residual_vanishes_at_the_explicit_solution_and_rows_follow_gl94():
    rng = np.random.default_rng(0)
    p = np.array([1.0, 0.7])
    u = rng.uniform(-np.pi, np.pi, (20, 2))
    s = P.forward(p, u)
    assert np.abs(P.residual(s, p, u)).max() <= 1e-15 * 4  # trigonometric identities, rounding only
    Fx, Fpsi, Fp = P.partials(s, p, u)
    h = 1e-6  # central differences of F: O(h²) ≈ 1e-12, rounding ~1e-10
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        num = (P.residual(s + e, p, u) - P.residual(s - e, p, u)) / (2 * h)
        ana = np.concatenate([Fx, Fpsi], axis=2)[:, :, k]
        np.testing.assert_allclose(ana, num, atol=1e-9)
    for k in range(2):
        e = np.zeros(2)
        e[k] = h
        num = (P.residual(s, p + e, u) - P.residual(s, p - e, u)) / (2 * h)
        np.testing.assert_allclose(Fp[:, :, k], num, atol=1e-9)


def test_extended_jacobian_matches_central_differences_of_g():
    p = np.array([1.0, 0.7])
    u = np.array([[0.3, 0.9], [1.2, -0.5]])
    z = np.array([0.4, -0.3])
    s = P.forward(p, u)
    d2 = np.sum((z - s[:, :2]) ** 2, axis=1)
    v0 = np.r_[p, s.ravel()]

    def G(v):
        return P.identification_equations(z, d2, v[2:].reshape(2, 3), v[:2], u)

    h = 1e-6
    num = np.array([(G(v0 + h * e) - G(v0 - h * e)) / (2 * h) for e in np.eye(8)]).T
    # G is quadratic in x and trigonometric in ψ: FD error O(h²) ~1e-12, rounding ~1e-10
    np.testing.assert_allclose(P.extended_jacobian(z, p, u), num, atol=1e-8)


def test_reduced_jacobian_by_the_implicit_function_theorem_matches_explicit_fk():
    rng = np.random.default_rng(4)
    p = np.array([0.8, 1.1])
    u = rng.uniform(-np.pi, np.pi, (10, 2))
    z = np.array([0.2, 0.5])
    h = 1e-6

    def d(pp):
        return np.linalg.norm(P.forward(pp, u)[:, :2] - z, axis=1)

    num = np.array([(d(p + h * e) - d(p - h * e)) / (2 * h) for e in np.eye(2)]).T
    np.testing.assert_allclose(P.reading_jacobian(z, p, u), num, atol=1e-8)  # FD O(h²) + rounding 1e-10


def test_implicit_sensitivity_rejects_a_singular_state_jacobian():
    with pytest.raises(InadmissibleError, match="rank deficient"):
        implicit_sensitivity(np.array([[1.0, 2.0], [2.0, 4.0], [0.0, 0.0]]), np.eye(3)[:, :1])
    # square, regular case: −F_s⁻¹ F_p exactly (solve of a 2 × 2 system, rounding 1e-16)
    Fs = np.array([[2.0, 1.0], [0.0, 3.0]])
    Fp = np.array([[1.0], [3.0]])
    np.testing.assert_allclose(implicit_sensitivity(Fs, Fp), -np.linalg.solve(Fs, Fp), rtol=1e-14)
