"""Compiled kernels of the pose pipeline (pkmstiff.kinematics.kernels) against the array API and independent references.

The primitives' maths is checked against brute-force minimisation in test_collision.py; here the fused per-pose
kernels (strut-strut, strut-platform with its broad phase, QR of J_C^-1, lazy κ, singularity decision) are checked
for layout, pair/chain bookkeeping, NaN (unreachable) rows and chunk boundaries.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

import pkmstiff.admissibility.checks as adm
from pkmstiff import load_machine
from pkmstiff.admissibility.collision import (
    point_segment_distance,
    segment_distance,
    segment_pierces_triangle,
    segment_triangle_distance,
)
from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.kinematics import (
    condition_number,
    inverse_jacobian,
    inverse_kinematics,
    jacobian_and_singular,
    kinematic_jacobian,
    singular_mask,
)
from pkmstiff.machine.loader import _oriented
from pkmstiff.machine.model import Hull

BOX = {"hexaglide": ((-0.4, 0.4), (-0.6, 0.8), (-1.3, -0.4)), "hexapod_6x": ((-0.5, 0.5), (-0.5, 0.5), (0.6, 1.6))}


def _poses(name: str, n: int, seed: int, rot: float = 0.3) -> np.ndarray:
    """Random poses over the working region, rotations ±rot rad (Hexaglide: about 40 % unreachable)."""
    rng = np.random.default_rng(seed)
    return np.column_stack([*(rng.uniform(lo, hi, n) for lo, hi in BOX[name]),
                            *(rng.uniform(-rot, rot, n) for _ in range(3))])


# ------------------------------------------------------------------------------------------------ strut-strut


@pytest.mark.parametrize("name,mode", [("hexaglide", "exact"), ("hexaglide", "table_B2"), ("hexapod_6x", "exact")])
def test_strut_collision_kernel_matches_pairwise_array_api(name, mode):
    m = load_machine(name)
    m = dataclasses.replace(m, limits=dataclasses.replace(m.limits, strut_collision_mode=mode))
    ik = inverse_kinematics(m, _poses(name, 4000, seed=1, rot=0.5))
    res = adm.check_strut_collision(m, ik.p, ik.q)
    r = m.chains.strut_radius
    for col, label in enumerate(res.labels):
        i, j = (int(s) - 1 for s in label.split()[1].split("-"))
        with np.errstate(invalid="ignore"):
            ref = segment_distance(ik.p[:, i], ik.q[:, i], ik.p[:, j], ik.q[:, j], mode=mode) < r[i] + r[j]
        np.testing.assert_array_equal(res.detail[:, col], ref, err_msg=label)
    np.testing.assert_array_equal(res.ok, ~res.detail.any(axis=1))
    assert res.detail.any()  # the poses exercise collisions
    if name == "hexaglide":  # unreachable chains (NaN points) never collide, reachable pairs of the pose still count
        lost = ~ik.reachable
        assert lost.any() and (lost.sum(axis=1) < 6).any()
        for col, label in enumerate(res.labels):
            i, j = (int(s) - 1 for s in label.split()[1].split("-"))
            assert not res.detail[lost[:, i] | lost[:, j], col].any()


# ------------------------------------------------------------------------------------------------ strut-platform


def _reference_platform(m, q, rot, w):
    """Exact reference without broad phase: min over hull triangles of the segment-triangle distance < radius."""
    ch = m.chains
    q_loc = np.einsum("nji,nkj->nki", rot, q - w[:, None, :])
    seg = q_loc - ch.platform_joint
    lim = m.limits.platform_end_exclusion
    excl = ch.strut_radius if lim is None else np.full(ch.n, lim)
    start = ch.platform_joint + seg / np.linalg.norm(seg, axis=-1, keepdims=True) * excl[:, None]
    tri = m.hull.vertices[m.hull.triangles]  # (T, 3, 3)
    with np.errstate(invalid="ignore"):
        dist = segment_triangle_distance(start[:, :, None], q_loc[:, :, None], tri[:, 0], tri[:, 1], tri[:, 2])
    return dist.min(axis=-1), start, q_loc


def test_platform_kernel_equals_exact_segment_hull_distance(hexaglide):
    ik = inverse_kinematics(hexaglide, _poses("hexaglide", 3000, seed=2))
    w = ik.poses[:, :3]
    dist, _, _ = _reference_platform(hexaglide, ik.q, ik.R, w)
    with np.errstate(invalid="ignore"):
        ref = dist < hexaglide.chains.strut_radius
    for convex in (True, False):  # struts start at the hull, so the convex shortcut gives the same verdicts
        m = dataclasses.replace(hexaglide, hull=dataclasses.replace(hexaglide.hull, convex=convex))
        res = adm.check_platform_collision(m, ik.q, ik.R, w)
        np.testing.assert_array_equal(res.detail, ref)
    r = hexaglide.chains.strut_radius
    assert ref.any() and (~ref & (dist < 3 * r)).any()  # hits and near misses (the exact narrow phase) occur
    assert not res.detail[~ik.reachable].any()  # unreachable chains never collide


def _cube_machine(base, rng, n_pose):
    """Unit cube hull at the PKS origin, platform joints anywhere in [-1.5, 1.5]^3 (joint 1 inside the cube, with
    a thin strut), no end exclusion."""
    v = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    hull = Hull(vertices=v, triangles=_oriented(v, ConvexHull(v).simplices), convex=True)
    pj = rng.uniform(-1.5, 1.5, (6, 3))
    pj[0] = [0.1, -0.1, 0.05]
    radius = rng.uniform(0.02, 0.3, 6)
    radius[0] = 0.02
    ch = dataclasses.replace(base.chains, platform_joint=pj, strut_radius=radius)
    return dataclasses.replace(base, hull=hull, chains=ch,
                               limits=dataclasses.replace(base.limits, platform_end_exclusion=0.0))


def test_platform_kernel_on_random_segments_around_a_cube(hexaglide):
    # random segments in every relation to the hull: far, near edges/faces, piercing, ending inside, fully inside
    rng = np.random.default_rng(4)
    n = 4000
    m = _cube_machine(hexaglide, rng, n)
    rot = Rotation.random(n, random_state=5).as_matrix()
    w = rng.uniform(-0.3, 0.3, (n, 3))
    q = rng.uniform(-2.0, 2.0, (n, 6, 3))
    q[::97, 2] = np.nan  # unreachable chain rows
    dist, a, b = _reference_platform(m, q, rot, w)
    with np.errstate(invalid="ignore"):
        ref = dist < m.chains.strut_radius
    inside = lambda x: (np.abs(x) < 0.5).all(axis=-1)  # noqa: E731 - strictly inside the unit cube
    res_nc = adm.check_platform_collision(dataclasses.replace(m, hull=dataclasses.replace(m.hull, convex=False)),
                                          q, rot, w)
    np.testing.assert_array_equal(res_nc.detail, ref)
    # convex hull: a segment with an end point inside the body collides as well (the staged test's shortcut)
    res = adm.check_platform_collision(m, q, rot, w)
    np.testing.assert_array_equal(res.detail, ref | inside(a) | inside(b))
    assert not res.detail[::97, 2].any()
    assert (ref & ~inside(a) & ~inside(b)).any() and (~ref & (dist < 2 * m.chains.strut_radius)).any()
    assert (inside(a) & inside(b) & ~ref).any()  # segments fully inside, away from the faces: only the shortcut


def test_platform_kernel_accepts_pose_first_copies(hexaglide):
    # the kernels take component-first storage; arbitrary (N, n, 3) / (N, 3, 3) inputs are laid out the same way
    ik = inverse_kinematics(hexaglide, _poses("hexaglide", 500, seed=6))
    a = adm.check_platform_collision(hexaglide, ik.q, ik.R, ik.poses[:, :3])
    b = adm.check_platform_collision(hexaglide, np.array(ik.q), np.array(ik.R), np.array(ik.poses[:, :3]).T.T)
    np.testing.assert_array_equal(a.detail, b.detail)
    c = adm.check_strut_collision(hexaglide, np.array(ik.p), np.array(ik.q))
    np.testing.assert_array_equal(c.detail, adm.check_strut_collision(hexaglide, ik.p, ik.q).detail)


# ------------------------------------------------------------------------------------------------ primitives API


def test_primitive_wrappers_broadcast_and_propagate_nan():
    rng = np.random.default_rng(7)
    p1, q1 = rng.normal(size=(5, 1, 3)), rng.normal(size=(5, 1, 3))
    p2, q2 = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    d = segment_distance(p1, q1, p2, q2)
    assert d.shape == (5, 4)
    assert d[2, 3] == segment_distance(p1[2, 0], q1[2, 0], p2[3], q2[3])  # same compiled code: bit-identical
    nan = np.full(3, np.nan)
    assert np.isnan(segment_distance(nan, q2[0], p2[1], q2[1]))
    assert np.isnan(segment_distance(nan, q2[0], p2[1], q2[1], mode="table_B2"))
    assert np.isnan(point_segment_distance(nan, p2[0], q2[0]))
    assert not segment_pierces_triangle(nan, q2[0], p2[0], p2[1], p2[2])
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 3\)"):
        segment_distance(np.zeros(2), np.zeros(3), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="mode"):
        segment_distance(p2, q2, p2, q2, mode="cobet")


# ------------------------------------------------------------------------------------------------ J_C and κ


def test_qr_kernel_chunks_layouts_and_nan_rows(hexaglide):
    ik = inverse_kinematics(hexaglide, _poses("hexaglide", 600, seed=8))
    jinv = inverse_jacobian(hexaglide, ik)  # contains NaN rows (unreachable chains)
    assert not ik.all_reachable.all()
    ref = kinematic_jacobian(jinv)
    for chunk in (1, 7, 599):  # chunk boundaries and a pose-first C-contiguous copy give identical results
        np.testing.assert_array_equal(kinematic_jacobian(jinv, chunk_size=chunk), ref)
    np.testing.assert_array_equal(kinematic_jacobian(np.array(jinv)), ref)
    good = ik.all_reachable
    assert np.isnan(ref[~good]).all()
    # backward-stable QR inverse vs LAPACK's LU inverse, κ < 1e4 here: 1e-8 relative is generous
    np.testing.assert_allclose(ref[good], np.linalg.inv(jinv[good]), rtol=1e-8, atol=1e-10)
    jc, sing = jacobian_and_singular(hexaglide, jinv, chunk_size=7)
    np.testing.assert_array_equal(jc, ref)
    np.testing.assert_array_equal(sing, singular_mask(hexaglide, jinv))


def test_pipeline_singularity_decision_is_exact_near_the_threshold(hexaglide):
    # threshold at the median κ of the reachable poses: many poses have bounds straddling it (SVD decides)
    poses = _poses("hexaglide", 2000, seed=9)
    ik = inverse_kinematics(hexaglide, poses)
    k_svd = condition_number(inverse_jacobian(hexaglide, ik), method="svd")
    thr = float(np.median(k_svd[np.isfinite(k_svd)]))
    m = dataclasses.replace(hexaglide, limits=dataclasses.replace(hexaglide.limits, singularity_threshold=thr))
    ev = evaluate_poses(m, poses, checks=("singularity",), chunk_size=333)
    reach = ik.all_reachable
    singular = ~ev.admissibility.checks["singular"].ok
    np.testing.assert_array_equal(singular[reach], k_svd[reach] > thr)
    np.testing.assert_array_equal(ev.admissibility.reasons[reach] == int(adm.Reason.SINGULAR), k_svd[reach] > thr)
    assert 0.3 < singular[reach].mean() < 0.7


def test_kappa_is_computed_on_first_access_only(hexaglide):
    poses = _poses("hexaglide", 300, seed=10)
    ev = evaluate_poses(hexaglide, poses, chunk_size=77)
    assert not ev.kappa_computed
    repr(ev)  # printing does not compute κ
    sub = ev.subset(ev.ok)
    assert not ev.kappa_computed and not sub.kappa_computed
    kappa = ev.kappa
    assert ev.kappa_computed and ev.kappa is kappa  # computed once, then kept
    np.testing.assert_array_equal(kappa, condition_number(ev.jinv))
    svd = condition_number(ev.jinv, method="svd")
    fin = np.isfinite(svd)
    assert np.array_equal(fin, np.isfinite(kappa)) and (~fin).any()  # unreachable poses: κ = inf
    # certified relative accuracy 1e-4 of the fast method, plus rounding O(κ 1e-16)
    assert np.all(np.abs(kappa[fin] / svd[fin] - 1.0) <= 1e-4 + 1e-12)
    np.testing.assert_array_equal(sub.kappa, condition_number(sub.jinv))
    np.testing.assert_array_equal(ev.subset(ev.ok).kappa, kappa[ev.ok])  # subset of a known κ takes its values
    # a requirement that reads κ computes it per chunk; the concatenated evaluation keeps those values
    ev2 = evaluate_poses(hexaglide, poses, chunk_size=77, requirements=[lambda e: e.kappa < 15.0])
    assert ev2.kappa_computed
    # per-chunk batches change only the rounding of the batched reductions of the power iteration
    np.testing.assert_allclose(ev2.kappa, kappa, rtol=1e-12)
    ev3 = dataclasses.replace(ev, kappa=None)
    assert not ev3.kappa_computed


# ------------------------------------------------------------------------------------------------ whole pipeline


@pytest.mark.parametrize("name", ["hexaglide", "hexapod_6x"])
def test_chunk_boundaries_give_identical_details(name):
    m = load_machine(name)
    poses = _poses(name, 500, seed=11, rot=0.4)
    a = evaluate_poses(m, poses)
    b = evaluate_poses(m, poses, chunk_size=13)
    np.testing.assert_array_equal(a.admissibility.reasons, b.admissibility.reasons)
    for key, ca in a.admissibility.checks.items():
        cb = b.admissibility.checks[key]
        np.testing.assert_array_equal(ca.ok, cb.ok, err_msg=key)
        assert ca.labels == cb.labels and ca.skipped == cb.skipped
        if ca.detail is not None:
            np.testing.assert_array_equal(ca.detail, cb.detail, err_msg=key)
    np.testing.assert_array_equal(a.jc, b.jc)
    for k in a.angles:
        np.testing.assert_array_equal(a.angles[k], b.angles[k])
    # unreachable poses carry only UNREACHABLE, and failing() names the unreachable chains
    unreach = (a.admissibility.reasons & adm.Reason.UNREACHABLE) > 0
    assert np.all(a.admissibility.reasons[unreach] == int(adm.Reason.UNREACHABLE))
    if unreach.any():
        assert "chain" in a.admissibility.failing(int(np.flatnonzero(unreach)[0]))[0]
    with pytest.raises(ValueError, match="chunk_size"):
        evaluate_poses(m, poses, chunk_size=0)
