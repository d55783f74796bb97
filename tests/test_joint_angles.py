"""Tests of pkmstiff.kinematics.joint_angles: swivel and tilt angles in both conventions (spec models.md §2)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pkmstiff.kinematics import inverse_kinematics
from pkmstiff.kinematics.joint_angles import joint_angles
from pkmstiff.kinematics.rotation import cardan_matrix
from pkmstiff.machine.loader import load_machine
from tests.conftest import BUNDLED, CENTRE, hexaglide_by_hand, random_poses, with_chains

MACHINES = {name: load_machine(name) for name in BUNDLED}
deg = np.deg2rad


def test_hexaglide_joint_angles_by_hand():
    # Pose x = y = 0, z = -1.0 m, a = b = c = 0, Table C.1 as printed (see test_kinematics for q1, d1):
    # d1 = p1 - q1 = (-s, -0.61, -0.70), s = √0.1379 = 0.371349, |d1| = l1 = 1.0
    # drive joint 1: a1 = (-1, 0, 0), u = +d̂1, a1·u = s
    #   axis-referenced tilt   = arccos(|a1·u|) = arccos(0.371349) = 68.201°
    #   normal-referenced tilt = arcsin(a1·u)   = arcsin(0.371349) = 21.799°
    #   swivel undefined because b1 = a1
    # platform joint 1: m1 = (0.7071, 0.7071, 0), u = -d̂1 = (s, 0.61, 0.70)
    #   m̂1·u = (s + 0.61)/√2 = 0.693920 -> axis tilt = 46.059°, normal tilt = 43.941°
    #   n1 = (0, 0, 1) ⊥ m1, so n·u_⊥ = u_z = 0.70 and |u_⊥| = √(1 - 0.693920²) = 0.720052
    #   swivel = arccos(0.70 / 0.720052) = arccos(0.972152) = 13.554°
    m = hexaglide_by_hand()
    ja = joint_angles(m, inverse_kinematics(m, [0.0, 0.0, -1.0, 0.0, 0.0, 0.0]), signed=True)
    s = np.sqrt(0.1379)
    c = (s + 0.61) / np.sqrt(2.0)
    # exact expressions vs. the vectorised atan2 forms: a few ulp, 1e-13 rad
    assert abs(ja.drive.tilt_axis[0, 0] - np.arccos(s)) < 1e-13
    assert abs(ja.drive.tilt_normal[0, 0] - np.arcsin(s)) < 1e-13
    assert np.isnan(ja.drive.swivel).all() and np.isnan(ja.drive.swivel_signed).all()
    assert abs(ja.platform.tilt_axis[0, 0] - np.arccos(c)) < 1e-13
    assert abs(ja.platform.tilt_normal[0, 0] - np.arcsin(c)) < 1e-13
    assert abs(ja.platform.swivel[0, 0] - np.arccos(0.70 / np.sqrt(1.0 - c * c))) < 1e-13
    # the hand-rounded numbers of the comment (6 digits -> 1e-3 deg)
    np.testing.assert_allclose(np.rad2deg([ja.drive.tilt_axis[0, 0], ja.platform.tilt_axis[0, 0],
                                           ja.platform.swivel[0, 0]]), [68.201, 46.059, 13.554], atol=1e-3)
    # the Hexaglide joints are axis-referenced: ``tilt`` is the axis-referenced angle
    np.testing.assert_array_equal(ja.drive.tilt, ja.drive.tilt_axis)
    np.testing.assert_array_equal(ja.platform.tilt, ja.platform.tilt_axis)


def test_6x_platform_joint_1_by_hand():
    # Pose x = y = 0, z = 1.0 m, a = b = c = 0; Table C.8 with the spec corrections (machines.md §4.1 notes 1, 2):
    # p1 = (-0.253, 0.024, 1.495), q1 = (-0.419, 1.564, 2.884), d1 = (0.166, -1.540, -1.389), |d1| = 2.080499
    # u = -d̂1; m'1 = (0, 0.608, -0.793) (|m| = 0.999256), n'1 = (0, 0.793, 0.608) ⊥ m'1
    # m̂·u = (0.608·1.540 - 0.793·1.389)/(0.999256·2.080499) = -0.165157/2.078952 = -0.079442
    #   normal-referenced tilt = arcsin(-0.079442) = -4.5565°
    # n̂·u = (0.793·1.540 + 0.608·1.389)/2.078952 = 2.065732/2.078952 = 0.993641; |u_⊥| = √(1 - 0.079442²) = 0.996839
    #   swivel = arccos(0.993641/0.996839) = arccos(0.996792) = 4.591°
    m = MACHINES["hexapod_6x"]
    ch = m.chains
    np.testing.assert_allclose(ch.drive_joint[2], [1.564, -0.419, 2.884])  # note 1 applied by the machine file
    np.testing.assert_allclose(ch.platform_axis[0] / np.linalg.norm(ch.platform_axis[0]),
                               np.array([0.0, 0.608, -0.793]) / np.hypot(0.608, 0.793))  # note 2
    ja = joint_angles(m, inverse_kinematics(m, [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]))
    # hand arithmetic carried 6-7 digits: 2e-3 deg
    assert np.rad2deg(ja.platform.tilt_normal[0, 0]) == pytest.approx(-4.5565, abs=2e-3)
    assert np.rad2deg(ja.platform.swivel[0, 0]) == pytest.approx(4.591, abs=2e-3)
    np.testing.assert_array_equal(ja.platform.tilt, ja.platform.tilt_normal)  # INA joints: normal-referenced
    # spec §2 Note: with the outward strut direction all 6X platform swivel angles are a few degrees here
    assert np.all(np.rad2deg(ja.platform.swivel) < 10.0)


def test_6x_inward_strut_direction_flips_normal_tilt_and_swivel():
    # u -> -u at the platform joints: u_⊥ -> -u_⊥, so swivel -> 180° - swivel; signed tilt changes sign
    m = MACHINES["hexapod_6x"]
    jt = {k: dataclasses.replace(v, strut_direction="drive_to_platform") for k, v in m.joint_types.items()}
    m_in = dataclasses.replace(m, joint_types=jt)
    ik = inverse_kinematics(m, random_poses("hexapod_6x", 100, np.random.default_rng(1), 0.2, 10.0))
    out, inw = joint_angles(m, ik), joint_angles(m_in, ik)
    np.testing.assert_allclose(inw.platform.tilt_normal, -out.platform.tilt_normal, atol=1e-14)
    np.testing.assert_allclose(inw.platform.swivel, np.pi - out.platform.swivel, atol=1e-12)
    np.testing.assert_allclose(inw.platform.tilt_axis, out.platform.tilt_axis, atol=1e-14)
    np.testing.assert_array_equal(inw.drive.swivel, out.drive.swivel)  # drive side uses +d̂ either way
    assert np.all(np.rad2deg(inw.platform.swivel) > 150.0)  # spec §2 Note: "close to 180°"


@pytest.mark.parametrize("name", BUNDLED)
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_angle_conventions_are_consistent(name, seed):
    m = MACHINES[name]
    ik = inverse_kinematics(m, random_poses(name, 50, np.random.default_rng(seed), 0.1, 10.0))
    ja = joint_angles(m, ik)
    for side in (ja.drive, ja.platform):
        # normal tilt = ±(90° - axis tilt) (spec §2 table); rounding of atan2, 1e-14 rad
        np.testing.assert_allclose(np.abs(side.tilt_normal), np.pi / 2 - side.tilt_axis, atol=1e-14)
        assert np.all((side.tilt_axis >= 0) & (side.tilt_axis <= np.pi / 2))
        np.testing.assert_array_equal(side.tilt, np.where(side.normal, side.tilt_normal, side.tilt_axis))
        sw = side.swivel[np.isfinite(side.swivel)]
        assert np.all((sw >= 0) & (sw <= np.pi))


@pytest.mark.parametrize("name", ["hexaglide_v2", "hexapod_6x", "linapod", "paralix"])
def test_platform_angles_against_scalar_formulas(name):
    # independent per-joint evaluation of spec §2 with m = R m', n = R n', u = -d̂ (outward)
    m = MACHINES[name]
    poses = random_poses(name, 5, np.random.default_rng(9), 0.1, 15.0)
    ik = inverse_kinematics(m, poses)
    ja = joint_angles(m, ik, signed=True)
    ch = m.chains
    for k, x in enumerate(poses):
        R = cardan_matrix(*x[3:])
        for i in range(ch.n):
            d = x[:3] + R @ ch.platform_joint[i] - ik.q[k, i]
            u = -d / np.linalg.norm(d)
            mm, nn = R @ ch.platform_axis[i], R @ ch.platform_reference[i]
            up = np.cross(mm, np.cross(u, mm))
            sw = np.arccos(np.clip(nn @ up / (np.linalg.norm(nn) * np.linalg.norm(up)), -1, 1))
            cm = mm @ u / np.linalg.norm(mm)
            sws = np.arctan2(mm @ np.cross(nn, up) / np.linalg.norm(mm), nn @ up)
            # arccos/arcsin vs. atan2 forms: ≤ 1e-7 rad near 0/90° where arccos loses digits, else ~1e-15
            assert ja.platform.swivel[k, i] == pytest.approx(sw, abs=1e-7)
            assert ja.platform.swivel_signed[k, i] == pytest.approx(sws, abs=1e-12)
            assert ja.platform.tilt_axis[k, i] == pytest.approx(np.arccos(abs(cm)), abs=1e-7)
            assert ja.platform.tilt_normal[k, i] == pytest.approx(np.arcsin(cm), abs=1e-7)


def test_hexaglide_mirror_symmetric_joint_angles():
    m = MACHINES["hexaglide"]
    poses = random_poses("hexaglide", 200, np.random.default_rng(3), 0.3, 0.0)
    a = joint_angles(m, inverse_kinematics(m, poses), signed=True)
    b = joint_angles(m, inverse_kinematics(m, poses * [-1, 1, 1, 1, 1, 1]), signed=True)
    swap = [1, 0, 3, 2, 5, 4]
    for sa, sb in ((a.drive, b.drive), (a.platform, b.platform)):
        # mirrored inputs, same arithmetic: rounding only, 1e-12 rad
        np.testing.assert_allclose(sb.tilt_axis[:, swap], sa.tilt_axis, atol=1e-12)
        np.testing.assert_allclose(sb.swivel[:, swap], sa.swivel, atol=1e-12)
    # a reflection reverses orientation: the signed swivel changes sign
    np.testing.assert_allclose(b.platform.swivel_signed[:, swap], -a.platform.swivel_signed, atol=1e-12)
    # n'1 ⊥ m'1 on the Hexaglide: |signed swivel| equals the unsigned one
    np.testing.assert_allclose(np.abs(a.platform.swivel_signed), a.platform.swivel, atol=1e-12)


def test_swivel_undefined_when_strut_along_axis_and_nan_when_unreachable():
    m = hexaglide_by_hand()
    pose = [0.0, 0.0, -1.0, 0.0, 0.0, 0.0]
    d1 = inverse_kinematics(m, pose).d[0, 0]
    axis = m.chains.platform_axis.copy()
    axis[0] = -d1  # first platform axis along the (outward) strut direction (R = I at this pose)
    ja = joint_angles(with_chains(m, platform_axis=axis), inverse_kinematics(m, pose), signed=True)
    assert np.isnan(ja.platform.swivel[0, 0]) and np.isnan(ja.platform.swivel_signed[0, 0])
    assert ja.platform.tilt_axis[0, 0] == pytest.approx(0.0, abs=1e-7)  # atan2(|m×u| ≈ 1e-16, 1)
    assert ja.platform.tilt_normal[0, 0] == pytest.approx(np.pi / 2, abs=1e-7)
    assert np.isfinite(ja.platform.swivel[0, 1:]).all()
    ik = inverse_kinematics(m, [[0.0, 0.0, -1.0, 0, 0, 0], [0.0, 0.0, -3.0, 0, 0, 0]])  # second: unreachable
    ja = joint_angles(m, ik)
    assert np.isnan(ja.platform.tilt[1]).all() and np.isnan(ja.drive.tilt[1]).all()
    assert np.isfinite(ja.platform.tilt[0]).all()
    adm = ja.for_admissibility()
    assert set(adm) == {"drive", "platform"} and adm["platform"][1] is ja.platform.tilt


def test_drive_joint_tilt_respects_hexaglide_minimum_at_centre():
    # plausibility of the data + convention: at the workspace centre every drive joint tilt is far above
    # the 5° minimum (Cobet 5.4) and the platform joints are well inside their 90° range
    m = MACHINES["hexaglide"]
    ja = joint_angles(m, inverse_kinematics(m, CENTRE["hexaglide"]))
    assert np.all(ja.drive.tilt > deg(5.0)) and np.all(ja.platform.tilt < deg(89.0))
