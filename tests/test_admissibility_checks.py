"""Single admissibility checks on synthetic inputs (spec models.md §8)."""

import dataclasses

import numpy as np

import pkmstiff.admissibility.checks as adm
from pkmstiff import load_machine
from pkmstiff.machine.model import Hull


def _angles(n_pose, swivel_deg, tilt_deg):
    sw = np.zeros((n_pose, 6))
    ti = np.zeros((n_pose, 6))
    sw[:, 0] = np.deg2rad(swivel_deg)
    ti[:, 0] = np.deg2rad(tilt_deg)
    return sw, ti


def test_ina_coupled_limit(hexapod):
    # platform joint 1 of the 6X: |tilt| <= 75 - 2/3 |swivel| (eq. B.6, applied symmetrically)
    swivel = np.array([0.0, 30.0, 30.0, 30.0, -30.0, 90.0, 112.5, np.nan])
    tilt = np.array([74.9, 54.9, 55.1, -55.1, 54.9, 14.9, 0.1, 80.0])
    expect_ok = np.array([True, True, False, False, True, True, False, True])  # NaN swivel: check skipped
    sw, ti = _angles(len(swivel), swivel, tilt)
    zeros = np.zeros_like(sw)
    lim, ina = adm.check_joint_angles(hexapod, {"drive": (zeros, zeros), "platform": (sw, ti)})
    np.testing.assert_array_equal(ina.ok, expect_ok)
    assert lim.ok.all()  # the 6X has no B.5 limits
    bad = np.nonzero(~ina.ok)[0][0]
    assert ina.labels[6 + 0] == "platform joint 1" and ina.detail[bad, 6]


def test_tilt_minimum_of_hexaglide_drive_joints(hexaglide):
    tilt = np.array([4.9, 5.0, 5.1, 90.0])
    sw = np.full((4, 6), np.nan)  # drive-joint swivel undefined (b = +-a)
    ti = np.full((4, 6), np.deg2rad(30.0))
    ti[:, 2] = np.deg2rad(tilt)
    lim, ina = adm.check_joint_angles(hexaglide, {"drive": (sw, ti), "platform": (sw, np.full((4, 6), 0.5))})
    # limits are inclusive: 5.0 deg is admissible (float deg2rad round-trip is exact for the comparison)
    np.testing.assert_array_equal(lim.ok, [False, True, True, True])
    assert ina.ok.all()


def test_drive_range_glide(hexaglide):
    drive = np.full((4, 6), 1.0)
    drive[1, 3] = -0.001
    drive[2, 5] = 2.701
    reach = np.ones((4, 6), bool)
    reach[3, 0] = False
    res = adm.check_drive_range(hexaglide, drive, reach)
    np.testing.assert_array_equal(res.ok, [True, False, False, False])
    assert res.detail[1, 3] and res.detail[2, 5] and res.detail[3, 0]


def test_drive_range_pod(hexapod):
    lengths = np.array([[1.28] * 6, [2.57] * 6, [1.2799] * 6, [2.5701] * 6])
    res = adm.check_drive_range(hexapod, lengths, np.ones((4, 6), bool))
    np.testing.assert_array_equal(res.ok, [True, True, False, False])


def test_drive_spacing(hexaglide):
    # guide y800 holds chains 1, 2 with d_min = 0.40 m and s = 0.01 m: admissible iff distance > 0.41 m
    q = np.zeros((3, 6, 3))
    q[:, :, 0] = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])  # all pairs 2 m apart
    q[1, 0, 0], q[1, 1, 0] = 0.2, -0.2  # 0.40 m apart: too close
    q[2, 0, 0], q[2, 1, 0] = 0.2051, -0.2051  # 0.4102 m: ok
    res = adm.check_drive_spacing(hexaglide, q)
    np.testing.assert_array_equal(res.ok, [True, False, True])
    assert res.labels[0] == "y800: drives 1-2"


def test_drive_spacing_maximum(hexaglide):
    g = dataclasses.replace(hexaglide.guides["y800"], max_distance=1.5)
    m = dataclasses.replace(hexaglide, guides={**hexaglide.guides, "y800": g})
    q = np.zeros((2, 6, 3))
    q[:, :, 0] = np.array([0.7, -0.7, 1.0, -1.0, 1.0, -1.0])
    q[1, 0, 0] = 0.9  # 1.6 m apart: beyond 1.5 - 0.01
    np.testing.assert_array_equal(adm.check_drive_spacing(m, q).ok, [True, False])


def test_singularity(hexaglide):
    kappa = np.array([1.0, 1e8, 1.0001e8, np.inf, np.nan])
    np.testing.assert_array_equal(adm.check_singularity(hexaglide, kappa).ok, [True, True, False, False, False])


def _cube_machine(base):
    """The Hexaglide with a unit-cube hull centred at the origin of the PKS and platform joints outside it."""
    v = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    from scipy.spatial import ConvexHull

    from pkmstiff.machine.loader import _oriented

    hull = Hull(vertices=v, triangles=_oriented(v, ConvexHull(v).simplices))
    ch = dataclasses.replace(base.chains, platform_joint=np.tile([2.0, 0.0, 0.0], (6, 1)),
                             strut_radius=np.full(6, 0.05))
    return dataclasses.replace(base, hull=hull, chains=ch)


def test_platform_collision_piercing_and_edges(hexaglide):
    m = _cube_machine(hexaglide)
    rot = np.tile(np.eye(3), (4, 1, 1))
    w = np.zeros((4, 3))
    q = np.tile([4.0, 0.0, 0.0], (5, 6, 1))  # all struts from (2,0,0) to (4,0,0): far from the cube
    q[1, 2] = [-2.0, 0.1, 0.2]  # strut 3 passes through the cube: piercing
    res = adm.check_platform_collision(m, q[:2], rot[:2], w[:2])
    np.testing.assert_array_equal(res.ok, [True, False])
    assert res.detail[1, 2]
    pj = m.chains.platform_joint.copy()
    cases = [
        # strut 5 parallel to the cube edge y = z = 0.5 at diagonal offset e: distance to the edge e*sqrt(2)
        ([2.0, 0.528, 0.528], [-2.0, 0.528, 0.528], False),  # edge distance 0.0396 < r = 0.05: collision
        ([2.0, 0.540, 0.540], [-2.0, 0.540, 0.540], True),  # edge distance 0.0566 > r: free
        # strut ending 0.03 m above the top face (z = 0.5) interior: only the end-point/face distance sees it
        ([2.0, 0.2, 1.0], [0.1, 0.2, 0.53], False),
        ([2.0, 0.2, 1.0], [0.1, 0.2, 0.56], True),  # 0.06 m above: free
    ]
    for start, end, expect in cases:
        pj[4] = start
        mk = dataclasses.replace(m, chains=dataclasses.replace(m.chains, platform_joint=pj.copy()))
        qk = q[:1].copy()
        qk[0, 4] = end
        res = adm.check_platform_collision(mk, qk, rot[:1], w[:1])
        assert bool(res.ok[0]) is expect, (start, end, res.detail)


def test_platform_collision_in_platform_frame(hexaglide):
    # the same geometry rotated and translated as a whole gives the same verdict (test runs in the PKS)
    m = _cube_machine(hexaglide)
    from scipy.spatial.transform import Rotation

    rot = Rotation.from_euler("xyz", [0.3, -0.2, 0.9]).as_matrix()
    w = np.array([0.1, -0.4, 0.7])
    q_loc = np.tile([4.0, 0.0, 0.0], (2, 6, 1))
    q_loc[1, 2] = [-2.0, 0.1, 0.2]
    q = q_loc @ rot.T + w
    res = adm.check_platform_collision(m, q, np.tile(rot, (2, 1, 1)), np.tile(w, (2, 1)))
    np.testing.assert_array_equal(res.ok, [True, False])


def test_no_hull_is_skipped(hexapod):
    res = adm.check_platform_collision(hexapod, np.zeros((2, 6, 3)), np.tile(np.eye(3), (2, 1, 1)), np.zeros((2, 3)))
    assert res.skipped and res.ok.all()


def test_static_drive_load_and_check(hexaglide):
    # J_C = identity: the drive loads equal the holding wrench (F = m g up, M = rho x F)
    jc = np.tile(np.eye(6), (2, 1, 1))
    rot = np.tile(np.eye(3), (2, 1, 1))
    data = adm.DriveLoadData(moved_mass=100.0, cog_offset=np.array([0.1, 0.0, 0.0]),
                             max_force=np.full(6, 2500.0), force_reserve=np.full(6, 300.0),
                             coulomb=np.full(6, 100.0))
    tau = adm.static_drive_loads(hexaglide, jc, rot, data)
    np.testing.assert_allclose(tau[0], [0, 0, 981.0, 0, -98.1, 0], atol=1e-9)  # M = (0.1,0,0) x (0,0,981)
    res = adm.check_drive_load(hexaglide, tau, data)
    assert res.ok.all()
    heavy = dataclasses.replace(data, moved_mass=215.0)  # 2109 N > 2500 - 300 - 100 = 2100 N
    assert not adm.check_drive_load(hexaglide, adm.static_drive_loads(hexaglide, jc, rot, heavy), heavy).ok.any()
    skipped = adm.check_drive_load(hexaglide, None, None)
    assert "no mass data" in skipped.skipped


def test_combine_reason_codes():
    ok1 = adm.CheckResult(np.array([True, False, False, True]), adm.Reason.DRIVE_RANGE)
    ok2 = adm.CheckResult(np.array([True, True, False, False]), adm.Reason.SINGULAR)
    reach = np.array([True, True, True, False])
    a = adm.combine(4, [ok1, ok2], reach)
    np.testing.assert_array_equal(a.ok, [True, False, False, False])
    assert adm.reason_names(a.reasons[2]) == ["DRIVE_RANGE", "SINGULAR"]
    assert adm.reason_names(a.reasons[3]) == ["UNREACHABLE"]  # other checks are not evaluated there
    s = a.summary()
    assert s["DRIVE_RANGE"] == 2 and s["SINGULAR"] == 1 and s["UNREACHABLE"] == 1 and s["admissible"] == 1


def test_frame_limits(hexaglide):
    # Hexaglide frame with option machine_bed: -1.1 m <= z <= -0.15 m, x and y free
    bed = load_machine("hexaglide:machine_bed")
    pos = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.1], [0.0, 0.0, -1.1001], [5.0, -3.0, -0.15], [0.0, 0.0, 0.3]])
    res = adm.check_frame(bed, pos)
    np.testing.assert_array_equal(res.ok, [True, True, False, True, False])
    assert res.detail[2].tolist() == [False, False, True]
    # default (machines.md §1.7 item 3): no bed cut, only O' below the drive-joint plane z <= -0.15 m
    np.testing.assert_array_equal(adm.check_frame(hexaglide, pos).ok, [True, True, True, True, False])
    unlimited = adm.check_frame(load_machine("paralix"), pos)
    assert unlimited.skipped and unlimited.ok.all()
