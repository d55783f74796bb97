"""Series/parallel helpers and the per-pose state of the component library."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from components import ComponentState, parallel, series
from components.protocol import ConstantAxial

# stiffness values spanning joints (1e7 N/m) to guide carriages (1e10 N/m)
stiff = st.floats(min_value=1e5, max_value=1e11, allow_nan=False, allow_infinity=False)
REL = 1e-12  # exact rational arithmetic up to round-off of a few operations


def test_series_parallel_hand_values():
    assert series(2.0, 2.0) == pytest.approx(1.0, rel=REL)
    assert series(1.0, 2.0, 3.0) == pytest.approx(6.0 / 11.0, rel=REL)
    assert parallel(1.0, 2.0, 3.0) == pytest.approx(6.0, rel=REL)
    np.testing.assert_allclose(series(np.array([1.0, 2.0]), 2.0), [2.0 / 3.0, 1.0], rtol=REL)


def test_series_rigid_and_break():
    assert series(5.0, np.inf) == 5.0  # rigid element has zero compliance
    assert np.isposinf(series(np.inf, np.inf))
    assert series(0.0, 5.0) == 0.0  # a zero stiffness breaks the chain
    assert np.isposinf(parallel(3.0, np.inf))


def test_series_of_matrices_diagonal_hand_values():
    K = np.diag([2.0, 4.0, 8.0])
    np.testing.assert_allclose(series(K, K), np.diag([1.0, 2.0, 4.0]), atol=1e-12)
    np.testing.assert_allclose(series(K, np.inf), K, atol=1e-12)
    np.testing.assert_allclose(parallel(K, K), 2 * K, atol=0)


def test_series_of_full_matrices_is_inverse_of_summed_compliances():
    A = np.array([[4.0, 1.0], [1.0, 3.0]])
    B = np.array([[2.0, -0.5], [-0.5, 5.0]])
    # hand: inv(A) = [[3,-1],[-1,4]]/11, inv(B) = [[5,0.5],[0.5,2]]/9.75
    C = np.array([[3.0, -1.0], [-1.0, 4.0]]) / 11.0 + np.array([[5.0, 0.5], [0.5, 2.0]]) / 9.75
    np.testing.assert_allclose(series(A, B), np.linalg.inv(C), rtol=1e-12)
    batch = np.stack([A, B, A + B])
    np.testing.assert_allclose(series(batch, batch)[2], (A + B) / 2.0, rtol=1e-12)


def test_series_matrix_flag_forces_elementwise():
    a = np.array([[2.0, 4.0], [6.0, 8.0]])  # e.g. 2 poses x 2 chains of scalars
    np.testing.assert_allclose(series(a, a, matrix=False), a / 2.0, rtol=REL)
    with pytest.raises(ValueError, match="operand 1"):
        series(np.eye(2), np.ones(2), matrix=True)


@given(st.lists(stiff, min_size=1, max_size=6))
@settings(max_examples=60, deadline=None)
def test_series_below_min_parallel_above_max(ks):
    s, p = float(series(*ks)), float(parallel(*ks))
    assert s <= min(ks) * (1 + 1e-12)
    assert s >= min(ks) / len(ks) * (1 - 1e-12)  # n equal springs of the weakest stiffness are the lower bound
    assert p >= max(ks)
    assert float(series(*reversed(ks))) == pytest.approx(s, rel=1e-12)


@given(st.lists(st.tuples(stiff, stiff, stiff), min_size=2, max_size=4), st.integers(0, 2**31 - 1))
@settings(max_examples=40, deadline=None)
def test_matrix_series_is_softer_than_each_part(diags, seed):
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    mats = [Q @ np.diag(d) @ Q.T for d in diags]
    Ks = series(*mats)
    scale = max(max(d) for d in diags)
    for K in mats:  # K - Ks must be positive semi-definite (Loewner order)
        assert np.linalg.eigvalsh(K - Ks).min() >= -1e-9 * scale
    # same eigenvectors: series acts on the eigenvalues like the scalar rule
    np.testing.assert_allclose(np.sort(np.linalg.eigvalsh(Ks)),
                               np.sort([float(series(*[d[i] for d in diags])) for i in range(3)]), rtol=1e-8)


def test_component_state_validation_and_size():
    assert ComponentState(tilt=[0.1, 0.2, 0.3]).n == 3
    assert ComponentState().n == 1
    assert ComponentState(n_poses=4).n == 4
    with pytest.raises(ValueError, match="same length"):
        ComponentState(tilt=[0.1, 0.2], swivel=[0.1])
    with pytest.raises(ValueError, match="1-D"):
        ComponentState(tilt=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="n_poses"):
        ComponentState(tilt=[0.1], n_poses=2)
    with pytest.raises(ValueError, match="tilt is required"):
        ComponentState(n_poses=2).require("tilt", "joint A")


def test_constant_axial_returns_per_pose_array():
    k = ConstantAxial(name="c", k=25e6).stiffness(ComponentState(drive_position=np.zeros(5)))
    assert k.shape == (5,) and np.all(k == 25e6)
    with pytest.raises(ValueError, match="positive"):
        ConstantAxial(name="c", k=-1.0)
