"""Tests of pkmstiff.kinematics: inverse/forward kinematics, Jacobians, condition number (spec models.md §1, §6.1)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.errors import ArgumentError
from pkmstiff.kinematics import (
    cardan_inverse_jacobian,
    condition_bounds,
    condition_number,
    forward_kinematics,
    inverse_jacobian,
    inverse_kinematics,
    inverse_kinematics_frames,
    is_singular,
    jacobian_and_condition,
    kinematic_jacobian,
    relative_inverse_jacobian,
    singular_mask,
    transmission_quality,
)
from pkmstiff.kinematics.rotation import cardan_matrix, rotation_from_axis_angle
from pkmstiff.machine.loader import load_machine
from tests.conftest import BUNDLED, CENTRE, hexaglide_by_hand, random_poses, with_chains

MACHINES = {name: load_machine(name) for name in BUNDLED}
seeds = st.integers(0, 2**32 - 1)


# ------------------------------------------------------------------------------------------------ inverse kinematics


def test_hexaglide_ik_by_hand():
    # Pose x = y = 0, z = -1.0 m, a = b = c = 0 (Table C.1 values):
    # chain 1: p1 = w + p'1 = (0.20, 0.19, -0.85); guide point (1.35 - λ, 0.80, 0) + offset (0, 0, -0.15)
    # |q1 - p1|² = (1.15 - λ)² + 0.61² + 0.70² = 1.0²  ->  (1.15 - λ)² = 0.1379
    # smaller root λ1 = 1.15 - √0.1379 = 0.77865; q1 = (0.57135, 0.80, -0.15); d1 = p1 - q1 = (-√0.1379, -0.61, -0.70)
    # chain 3: p3 = (0.30, -0.13, -0.85), (1.05 - λ)² + 0.53² + 0.70² = 0.95²  ->  (1.05 - λ)² = 0.9025 - 0.2809 - 0.49
    #          = 0.1316, λ3 = 1.05 - √0.1316 = 0.68723
    m = hexaglide_by_hand()
    ik = inverse_kinematics(m, [0.0, 0.0, -1.0, 0.0, 0.0, 0.0])
    s = np.sqrt(0.1379)
    # closed-form values vs. the vectorised quadratic: a few ulp of rounding, 1e-14 m
    assert ik.drive.shape == (1, 6)
    assert abs(ik.drive[0, 0] - (1.15 - s)) < 1e-14
    assert abs(ik.drive[0, 2] - (1.05 - np.sqrt(0.1316))) < 1e-14
    np.testing.assert_allclose(ik.p[0, 0], [0.20, 0.19, -0.85], atol=1e-15)
    np.testing.assert_allclose(ik.q[0, 0], [1.35 - (1.15 - s), 0.80, -0.15], atol=1e-14)
    np.testing.assert_allclose(ik.d[0, 0], [-s, -0.61, -0.70], atol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(ik.d[0], axis=-1), m.chains.strut_length, atol=1e-14)
    assert ik.reachable.all()
    # mirror pairs have equal λ at x = 0 (chains 1, 2 start at opposite guide ends)
    np.testing.assert_allclose(ik.drive[0, ::2], ik.drive[0, 1::2], atol=1e-14)


def test_glide_larger_root_gives_other_intersection():
    m = hexaglide_by_hand()
    pose = [0.0, 0.0, -1.0, 0.0, 0.0, 0.0]
    small = inverse_kinematics(m, pose)
    big = inverse_kinematics(with_chains(m, larger_root=np.array([True, False] * 3)), pose)
    # chain 1: the other root of (1.15 - λ)² = 0.1379
    assert abs(big.drive[0, 0] - (1.15 + np.sqrt(0.1379))) < 1e-14
    np.testing.assert_array_equal(big.drive[0, 1::2], small.drive[0, 1::2])
    assert np.all(big.drive[0, ::2] > small.drive[0, ::2])
    # both are intersections of the guide line with the sphere |q - p| = l
    np.testing.assert_allclose(np.linalg.norm(big.d[0], axis=-1), m.chains.strut_length, atol=1e-14)


def test_unreachable_pose_gives_nan_not_exception():
    m = MACHINES["hexaglide"]
    poses = np.array([CENTRE["hexaglide"], (0.0, 0.3, -3.0, 0.0, 0.0, 0.0)])  # 3 m below the guides: struts too short
    ik = inverse_kinematics(m, poses)
    assert ik.reachable[0].all() and not ik.reachable[1].any()
    assert np.isnan(ik.drive[1]).all() and np.isnan(ik.q[1]).all() and np.isnan(ik.length[1]).all()
    assert list(ik.all_reachable) == [True, False]
    jinv = inverse_jacobian(m, ik)
    assert np.isnan(jinv[1]).all() and np.isfinite(jinv[0]).all()
    assert np.isinf(condition_number(jinv)[1])
    assert np.isnan(kinematic_jacobian(jinv)[1]).all()


def test_pod_ik_matches_direct_formula():
    m = MACHINES["hexapod_6x"]
    rng = np.random.default_rng(3)
    poses = random_poses("hexapod_6x", 50, rng, 0.3, 20.0)
    ik = inverse_kinematics(m, poses)
    for k, x in enumerate(poses[:5]):
        R = cardan_matrix(*x[3:])
        for i in range(6):
            l = np.linalg.norm(x[:3] + R @ m.chains.platform_joint[i] - m.chains.drive_joint[i])
            assert abs(ik.drive[k, i] - l) < 1e-14  # same arithmetic up to summation order
    np.testing.assert_array_equal(ik.drive, ik.length)
    assert ik.reachable.all()


def test_bad_pose_input_is_reported():
    m = MACHINES["hexaglide"]
    with pytest.raises(ArgumentError, match=r"poses: expected shape \(6,\) or \(N, 6\).*found shape \(5,\)"):
        inverse_kinematics(m, [0.0] * 5)
    with pytest.raises(ArgumentError, match="NaN/inf in 1 pose"):
        inverse_kinematics(m, [[0, 0, -1, 0, 0, 0], [0, 0, np.nan, 0, 0, 0]])
    with pytest.raises(ArgumentError, match="jinv"):
        condition_number(np.zeros((4, 6, 5)))


def test_hexaglide_mirror_symmetry():
    # mirror x -> -x maps chain 1 <-> 2, 3 <-> 4, 5 <-> 6 (Table C.1 is exactly mirror-symmetric)
    m = MACHINES["hexaglide"]
    rng = np.random.default_rng(7)
    poses = random_poses("hexaglide", 200, rng, 0.3, 0.0)
    mirrored = poses * [-1, 1, 1, 1, 1, 1]
    ik, ikm = inverse_kinematics(m, poses), inverse_kinematics(m, mirrored)
    swap = [1, 0, 3, 2, 5, 4]
    ch = m.chains
    gx = ch.guide_start[:, 0] + ik.drive * ch.guide_direction[:, 0]  # s_x + λ r_x
    gxm = ch.guide_start[:, 0] + ikm.drive * ch.guide_direction[:, 0]
    # same arithmetic on mirrored inputs: differences are rounding, 1e-13 m
    np.testing.assert_allclose(gxm[:, swap], -gx, atol=1e-13)
    np.testing.assert_allclose(ikm.drive[:, swap], ik.drive, atol=1e-13)
    np.testing.assert_allclose(ikm.d[:, swap] * [-1, 1, 1], ik.d, atol=1e-13)


# ------------------------------------------------------------------------------------------------ Jacobians


def _fd_twist_jacobian(m, pose, h=1e-6):
    """Central differences of the drive coordinates: translations of O' and small rotations about the
    global axes, R <- exp([δω]×) R (spec §1.4)."""
    R = cardan_matrix(*pose[3:])
    w = np.asarray(pose[:3])
    cols = []
    for j in range(6):
        e = np.zeros(3)
        e[j % 3] = h
        if j < 3:
            qp = inverse_kinematics_frames(m, w + e, R).drive
            qm = inverse_kinematics_frames(m, w - e, R).drive
        else:
            qp = inverse_kinematics_frames(m, w, rotation_from_axis_angle(e) @ R).drive
            qm = inverse_kinematics_frames(m, w, rotation_from_axis_angle(-e) @ R).drive
        cols.append((qp - qm)[0] / (2 * h))
    return np.stack(cols, axis=1)


# FD accuracy: truncation O(h²·q''') ≈ 1e-12·10, rounding O(eps·|q|/h) ≈ 2e-16·3/1e-6 ≈ 1e-9;
# entries of J⁻¹ are O(1..10), so 1e-7 absolute is a safe bound that still detects any wrong term.
FD_ATOL = 1e-7


@pytest.mark.parametrize("name", ["hexaglide", "hexapod_6x", "linapod", "paralix"])
@settings(max_examples=15, deadline=None)
@given(seed=seeds)
def test_inverse_jacobian_matches_finite_differences(name, seed):
    m = MACHINES[name]
    pose = random_poses(name, 1, np.random.default_rng(seed))[0]
    jinv = inverse_jacobian(m, inverse_kinematics(m, pose))[0]
    np.testing.assert_allclose(jinv, _fd_twist_jacobian(m, pose), atol=FD_ATOL)


@pytest.mark.parametrize("name", ["hexaglide_v2", "hexapod_6x"])
@settings(max_examples=10, deadline=None)
@given(seed=seeds)
def test_cardan_and_relative_inverse_jacobians_match_finite_differences(name, seed):
    m = MACHINES[name]
    pose = random_poses(name, 1, np.random.default_rng(seed), 0.1, 15.0)[0]
    ik = inverse_kinematics(m, pose)
    jinv = inverse_jacobian(m, ik)
    h = 1e-6
    # Cardan: ∂q/∂(x, y, z, a, b, c) by central differences in the pose coordinates
    fd = np.stack(
        [(inverse_kinematics(m, pose + h * e).drive - inverse_kinematics(m, pose - h * e).drive)[0] / (2 * h)
         for e in np.eye(6)], axis=1)
    np.testing.assert_allclose(cardan_inverse_jacobian(jinv, ik)[0], fd, atol=FD_ATOL)
    # relative: small rotations about the tool-frame axes, R <- R exp([δ]×)
    R, w = cardan_matrix(*pose[3:]), pose[:3]
    cols = [fd[:, j] for j in range(3)]
    for j in range(3):
        e = h * np.eye(3)[j]
        qp = inverse_kinematics_frames(m, w, R @ rotation_from_axis_angle(e)).drive
        qm = inverse_kinematics_frames(m, w, R @ rotation_from_axis_angle(-e)).drive
        cols.append((qp - qm)[0] / (2 * h))
    np.testing.assert_allclose(relative_inverse_jacobian(jinv, ik)[0], np.stack(cols, axis=1), atol=FD_ATOL)


def test_glide_first_kind_singularity_gives_infinite_condition():
    # d·r = 0 (strut perpendicular to its guide): the row of J⁻¹ is unbounded (spec §1.6)
    m = hexaglide_by_hand()
    ik = inverse_kinematics(m, [0.0, 0.0, -1.0, 0.0, 0.0, 0.0])
    d = ik.d.copy()
    d[0, 0] = [0.0, -0.61, -0.79]  # perpendicular to r_1 = (-1, 0, 0)
    ik = dataclasses.replace(ik, d=d)
    jinv = inverse_jacobian(m, ik)
    assert not np.isfinite(jinv[0, 0]).all()
    assert np.isinf(condition_number(jinv)[0]) and is_singular(m, condition_number(jinv))[0]


# ------------------------------------------------------------------------------------------------ J_C, κ, U


def _matrices_with_singular_values(rng, sv):
    n = len(sv)
    U, _ = np.linalg.qr(rng.standard_normal((n, n)))
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    return U @ np.diag(sv) @ V.T


def _test_matrices(rng):
    """Stacks of 6×6 matrices with controlled spectra: random, clustered largest/smallest singular
    values (as for symmetric machines), and condition numbers up to 1e10."""
    mats = [rng.standard_normal((6, 6)) for _ in range(200)]
    for kappa in np.logspace(0, 10, 41):
        mats.append(_matrices_with_singular_values(rng, np.geomspace(kappa, 1.0, 6)))
        mats.append(_matrices_with_singular_values(rng, [kappa, kappa, kappa, 1.0, 1.0, 1.0]))
        mats.append(_matrices_with_singular_values(rng, [kappa, kappa * (1 - 1e-9), 0.5 * kappa, 2.0, 1.0, 1.0]))
    return np.array(mats)


@pytest.mark.parametrize("rtol", [1e-3, 1e-4, 1e-6])
def test_condition_number_against_svd(rtol):
    rng = np.random.default_rng(11)
    A = _test_matrices(rng)
    for name in ("hexaglide", "hexapod_6x", "linapod", "paralix"):
        m = MACHINES[name]
        ik = inverse_kinematics(m, random_poses(name, 500, rng, 0.4, 30.0))
        A = np.concatenate([A, inverse_jacobian(m, ik)])
    ref = condition_number(A, method="svd")
    s = np.linalg.svd(A[np.isfinite(A).all(axis=(1, 2))], compute_uv=False)
    np.testing.assert_array_equal(ref[np.isfinite(A).all(axis=(1, 2))], s[:, 0] / s[:, -1])
    fast = condition_number(A, rtol=rtol, chunk_size=500)
    fin = np.isfinite(ref)
    assert np.array_equal(fin, np.isfinite(fast))
    # certified bound |κ/κ_svd - 1| <= rtol, plus the rounding of both methods, O(κ·1e-16) (spec §1.6)
    err = np.abs(fast[fin] / ref[fin] - 1.0)
    assert np.all(err <= rtol + 1e-15 * ref[fin] + 1e-12), err.max()


def test_condition_number_singular_and_nonfinite_are_inf():
    A = np.array([np.eye(6), np.eye(6), np.eye(6)])
    A[1, 2] = 0.0  # exactly singular (zero row)
    A[2, 0, 0] = np.inf
    kappa = condition_number(A)
    assert kappa[0] == pytest.approx(1.0, abs=1e-12)
    assert np.isinf(kappa[1:]).all()
    jc = kinematic_jacobian(A)  # np.linalg.inv would raise for the whole batch
    np.testing.assert_allclose(jc[0], np.eye(6), atol=1e-15)
    assert np.isnan(jc[1:]).all()


def test_kinematic_jacobian_is_inverse():
    rng = np.random.default_rng(5)
    m = MACHINES["hexaglide"]
    ik = inverse_kinematics(m, random_poses("hexaglide", 300, rng, 0.3, 15.0))
    jinv = inverse_jacobian(m, ik)[ik.all_reachable]
    jc, kappa = jacobian_and_condition(jinv)
    # backward-stable QR inverse: residual ≤ c·n·eps·κ, κ < 1e3 here -> 1e-10 is generous
    np.testing.assert_allclose(jc @ jinv, np.broadcast_to(np.eye(6), jc.shape), atol=1e-10)
    np.testing.assert_allclose(jc, np.linalg.inv(jinv), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(kappa, condition_number(jinv), rtol=0, atol=0)


def test_condition_bounds_and_singular_mask():
    rng = np.random.default_rng(8)
    A = _test_matrices(rng)
    near = [_matrices_with_singular_values(rng, np.geomspace(k, 1.0, 6)) for k in np.geomspace(2e7, 5e8, 60)]
    A = np.concatenate([A, near])
    ref = condition_number(A, method="svd")
    lo, hi = condition_bounds(A)
    # certified (Frobenius-norm) bounds; 1e-12 relative slack for rounding
    assert np.all(lo <= ref * (1 + 1e-12)) and np.all(hi >= ref * (1 - 1e-12))
    assert np.all(hi <= 6.0 * lo * (1 + 1e-12))
    m = MACHINES["hexapod_6x"]
    np.testing.assert_array_equal(singular_mask(m, A), is_singular(m, ref))
    m2 = dataclasses.replace(m, limits=dataclasses.replace(m.limits, singularity_threshold=1e3))
    np.testing.assert_array_equal(singular_mask(m2, A), ref > 1e3)
    assert is_singular(m, np.array([np.inf, np.nan, 1e9, 1e7])).tolist() == [True, True, True, False]


def test_transmission_quality_against_svd():
    m = MACHINES["hexapod_6x"]
    jinv = inverse_jacobian(m, inverse_kinematics(m, random_poses("hexapod_6x", 200, np.random.default_rng(2))))
    w = m.transmission_weight
    assert w == pytest.approx(0.63 / (np.pi / 3))  # eq. 4.78
    WJ = np.linalg.inv(jinv) * np.array([1, 1, 1, w, w, w])[:, None]  # W J_C
    s = np.linalg.svd(WJ, compute_uv=False)
    U = transmission_quality(m, jinv, form="inverse_kappa")
    np.testing.assert_allclose(U, s[:, -1] / s[:, 0], rtol=2e-4)  # certified rtol 1e-4 of κ, plus inv rounding
    assert np.all((U > 0) & (U <= 1))
    # default form: the literal eq. 4.75 reading κ^(-1/2) (models.md §6.1 note); sqrt halves the relative error
    np.testing.assert_allclose(transmission_quality(m, jinv), np.sqrt(s[:, -1] / s[:, 0]), rtol=2e-4)


# ------------------------------------------------------------------------------------------------ forward kinematics


@pytest.mark.parametrize("name", BUNDLED)
@settings(max_examples=8, deadline=None)
@given(seed=seeds)
def test_fk_ik_round_trip(name, seed):
    m = MACHINES[name]
    rng = np.random.default_rng(seed)
    poses = random_poses(name, 40, rng)
    ik = inverse_kinematics(m, poses)
    ok = evaluate_poses(m, poses).ok  # admissible poses: every check of spec App. B
    poses, q = poses[ok], ik.drive[ok]
    assert poses.shape[0] > 0
    start = poses + rng.uniform(-1, 1, poses.shape) * [0.02, 0.02, 0.02, 0.02, 0.02, 0.02]
    fk = forward_kinematics(m, q, start)
    assert fk.converged.all(), fk.report()
    assert np.all(fk.residual <= 1e-12)
    # pose error ≤ ‖J‖·residual ≈ κ·1e-12 with κ < 200 at these poses -> 1e-9 (m and rad)
    np.testing.assert_allclose(fk.poses, poses, atol=1e-9)
    assert np.all(fk.iterations <= 10)


def test_fk_from_centre_converges_for_many_poses_and_undamped():
    m = MACHINES["hexapod_6x"]
    poses = random_poses("hexapod_6x", 300, np.random.default_rng(4), 0.2, 10.0)
    q = inverse_kinematics(m, poses).drive
    for damping in (True, False):
        fk = forward_kinematics(m, q, CENTRE["hexapod_6x"], damping=damping)
        assert fk.converged.all(), fk.report()
        np.testing.assert_allclose(fk.poses, poses, atol=1e-9)  # as in the round-trip test
    assert "all 300 poses converged" in fk.report()


def test_fk_unreachable_target_is_reported_not_raised():
    m = MACHINES["hexaglide"]
    good = inverse_kinematics(m, CENTRE["hexaglide"]).drive[0]
    # drives 1 and 2 at opposite guide ends are 2.7 m apart, but two 1 m struts and 0.4 m between
    # their platform joints span at most 2.4 m: no pose has these drive coordinates
    bad = good.copy()
    bad[:2] = 0.0
    fk = forward_kinematics(m, np.array([good, bad]), CENTRE["hexaglide"])
    assert fk.converged.tolist() == [True, False]
    assert fk.status[1] in ("stalled", "unreachable", "max_iter")
    rep = fk.report()
    assert "1 of 2 poses did not converge" in rep and "[1]" in rep
    assert 1 in np.concatenate(list(fk.failures().values()))


def test_fk_singular_start_and_max_iter_are_reported():
    m = MACHINES["hexapod_6x"]
    q = inverse_kinematics(m, CENTRE["hexapod_6x"]).drive
    fk = forward_kinematics(m, q, [0.0, 0.0, 1.3, 0.0, np.pi / 2, 0.0])  # b = 90°: det E = cos b = 0
    assert fk.status.tolist() == ["singular_jacobian"] and "singular" in fk.report()
    start = np.array(CENTRE["hexapod_6x"]) + [0.1, 0.0, 0.0, 0.0, 0.0, 0.0]
    fk = forward_kinematics(m, q, start, max_iter=1)
    assert fk.status.tolist() == ["max_iter"] and not fk.converged[0]
    with pytest.raises(ArgumentError, match="drive_coords"):
        forward_kinematics(m, q[:, :5], start)
