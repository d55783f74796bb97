"""Admissibility of bundled machines through the full pose pipeline."""

import dataclasses

import numpy as np
import pytest

import pkmstiff.admissibility.checks as adm
from pkmstiff import load_machine
from pkmstiff.admissibility.pipeline import check_admissibility, evaluate_poses


def _yz_grid(x=0.0, ny=29, nz=15):
    y, z = np.meshgrid(np.linspace(-0.6, 0.8, ny), np.linspace(-1.2, -0.5, nz))
    p = np.zeros((y.size, 6))
    p[:, 0], p[:, 1], p[:, 2] = x, y.ravel(), z.ravel()
    return p


def test_measurement_pose_is_admissible(hexaglide):
    # Cobet 5.5: the real machine was measured at x = y = 0, z = -1000 mm, a = b = c = 0
    ev = evaluate_poses(hexaglide, [[0.0, 0.0, -1.0, 0.0, 0.0, 0.0]])
    assert ev.ok[0], ev.admissibility.failing(0)
    assert 1.0 < ev.kappa[0] < 1e3


def test_staged_convex_hull_test_equals_the_full_test(hexaglide):
    rng = np.random.default_rng(3)
    n = 3000
    poses = np.column_stack([rng.uniform(-0.4, 0.4, n), rng.uniform(-0.6, 0.8, n), rng.uniform(-1.2, -0.5, n),
                             *(rng.uniform(-0.2, 0.2, n) for _ in range(3))])
    ev = evaluate_poses(hexaglide, poses, checks=())
    from pkmstiff.kinematics import inverse_kinematics

    ik = inverse_kinematics(hexaglide, poses)
    staged = adm.check_platform_collision(hexaglide, ik.q, ik.R, ik.poses[:, :3])
    full_m = dataclasses.replace(hexaglide, hull=dataclasses.replace(hexaglide.hull, convex=False))
    full = adm.check_platform_collision(full_m, ik.q, ik.R, ik.poses[:, :3])
    np.testing.assert_array_equal(staged.detail, full.detail)
    assert 0.05 < (~staged.ok[ev.admissibility.reasons == 0]).mean() or staged.detail.any()  # the test exercises hits


def test_mirror_symmetry_of_the_mask(hexaglide):
    # The Hexaglide is symmetric to the Y-Z plane at a = b = c = 0: pose (x, y, z) and (-x, y, z) are equally admissible
    # and chain i <-> its mirror partner swap their per-chain verdicts.
    p = _yz_grid(x=0.15)
    pm = p.copy()
    pm[:, 0] *= -1
    a, b = evaluate_poses(hexaglide, p).admissibility, evaluate_poses(hexaglide, pm).admissibility
    np.testing.assert_array_equal(a.ok, b.ok)
    np.testing.assert_array_equal(a.reasons, b.reasons)
    swap = [1, 0, 3, 2, 5, 4]
    np.testing.assert_array_equal(a.checks["platform_collision"].detail,
                                  b.checks["platform_collision"].detail[:, swap])


def test_unreachable_and_singular_poses_never_raise(hexaglide):
    poses = np.array([[0, 0, -5.0, 0, 0, 0],  # far below: no strut reaches
                      [0, 0, 0.3, 0, 0, 0],  # above the guides
                      [np.nan, 0, -1.0, 0, 0, 0],
                      [0, 0, -1.0, 0, 0, 0]])
    try:
        ev = evaluate_poses(hexaglide, poses)
    except ValueError as exc:  # NaN input is rejected with a clear message instead
        assert "finite" in str(exc) or "NaN" in str(exc)
        ev = evaluate_poses(hexaglide, poses[[0, 1, 3]])
    assert not ev.ok[0] and ev.admissibility.reasons[0] & adm.Reason.UNREACHABLE
    assert ev.ok[-1]


def test_chunking_gives_identical_results(hexaglide):
    p = _yz_grid(ny=21, nz=11)
    a = evaluate_poses(hexaglide, p, chunk_size=10_000)
    b = evaluate_poses(hexaglide, p, chunk_size=17)
    np.testing.assert_array_equal(a.admissibility.reasons, b.admissibility.reasons)
    np.testing.assert_allclose(a.kappa, b.kappa, rtol=1e-12)
    assert a.admissibility.summary() == b.admissibility.summary()


def test_requirements_are_reported(hexaglide):
    p = _yz_grid(ny=11, nz=6)
    ev = evaluate_poses(hexaglide, p, requirements=[lambda e: e.kappa < 15.0])
    base = evaluate_poses(hexaglide, p)
    req = (ev.admissibility.reasons & adm.Reason.REQUIREMENT) > 0
    reachable = (base.admissibility.reasons & adm.Reason.UNREACHABLE) == 0
    np.testing.assert_array_equal(req, reachable & ~(base.kappa < 15.0))
    np.testing.assert_array_equal(ev.ok, base.ok & (base.kappa < 15.0))
    assert req.any() and ev.ok.sum() < base.ok.sum()


@pytest.mark.parametrize("name", ["hexaglide", "hexaglide_v1", "hexaglide_v2", "hexapod_6x", "linapod", "paralix"])
def test_every_bundled_machine_has_admissible_poses(name):
    m = load_machine(name)
    # a coarse box around the platform's typical region: the machine must have some admissible poses there
    boxes = {"hexapod_6x": ((-0.5, 0.5), (-0.5, 0.5), (0.6, 1.6)), "linapod": ((-0.4, 0.4), (-0.4, 0.4), (-0.4, 0.7)),
             "paralix": ((-2.2, -0.6), (-0.4, 0.4), (-0.3, 1.0))}
    (x0, x1), (y0, y1), (z0, z1) = boxes.get(name, ((-0.3, 0.3), (-0.5, 0.8), (-1.3, -0.5)))
    g = np.stack(np.meshgrid(np.linspace(x0, x1, 9), np.linspace(y0, y1, 9), np.linspace(z0, z1, 9)), -1)
    poses = np.concatenate([g.reshape(-1, 3), np.zeros((g.size // 3, 3))], axis=1)
    a = check_admissibility(m, poses)
    # each box is the region the platform works in: a healthy model admits a real share of it (observed 14-80 %),
    # a broken check (everything masked) or a stand-in (everything admitted) fails one of the bounds
    assert 0.10 <= a.ok.mean() <= 0.90, (name, a.ok.mean(), a.summary())


def test_static_drive_loads_balance_gravity(hexaglide):
    # eq. 4.90: tau_g = J_C^T g_P, so (J_C^-1)^T tau_g must give back the holding wrench (m g up, rho x F)
    from pkmstiff.machine.roles import drive_load_data

    data = drive_load_data(hexaglide)
    # platform with spindle + the six struts (machines.md §1.7 item 5)
    assert data is not None and data.moved_mass == pytest.approx(117.24 + 2 * 12.13 + 4 * 11.52)
    p = _yz_grid(ny=7, nz=5)
    p[:, 3] = 0.05  # tilted platform: the CoG moment term matters if the CoG is off O'
    ev = evaluate_poses(hexaglide, p)
    good = np.isfinite(ev.drive_loads).all(axis=1)
    wrench = np.einsum("nji,nj->ni", ev.jinv[good], ev.drive_loads[good])
    expect_f = np.array([0.0, 0.0, data.moved_mass * 9.81])
    # relative 1e-9: J_C from a QR inverse of J_C^-1 (condition numbers < 1e3 here)
    np.testing.assert_allclose(wrench[:, :3], np.broadcast_to(expect_f, wrench[:, :3].shape), rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(wrench[:, 3:], 0.0, atol=1e-6)  # CoG at O' (assumption): no moment
    assert "drive_load" not in ev.admissibility.skipped()


def test_drive_load_check_skipped_without_masses():
    m = load_machine("linapod")
    a = evaluate_poses(m, [[0.0, 0.0, 0.3, 0, 0, 0]]).admissibility
    assert "no mass data" in a.skipped()["drive_load"]
