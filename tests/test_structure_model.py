"""PKM structure model built from the bundled machines (spec models.md §4): layout, component wiring, masses,
properties (symmetry, definiteness, rigid-body modes, invariance under rotating the whole machine) and the
NaN/reason handling of poses that cannot be modelled."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import pkmstiff.multibody as sde
from pkmstiff.admissibility.checks import Reason
from pkmstiff.analysis import evaluate_structure, tcp_compliance
from pkmstiff.analysis.batch import _evaluate_chunk
from pkmstiff.kinematics import inverse_kinematics
from pkmstiff.kinematics.rotation import cardan_angles
from pkmstiff.machine.loader import load_machine
from pkmstiff.machine.model import Limits
from pkmstiff.machine.roles import machine_components
from pkmstiff.multibody.linalg import rotation_about_axis
from pkmstiff.structure import (
    COMPONENT_FAILED,
    NOT_POSITIVE_DEFINITE,
    StructureModelError,
    StructureOptions,
    build_structure,
)

HEXAGLIDE = load_machine("hexaglide")
HEX_6X = load_machine("hexapod_6x")
# poses inside the Hexaglide workspace (x, y, z [m], a, b, c [rad]); the first is the spec's reference pose
POSES = np.array([[0.0, 0.0, -1.0, 0.0, 0.0, 0.0],
                  [0.05, 0.25, -0.95, 0.03, -0.02, 0.05],
                  [-0.1, 0.35, -0.85, -0.04, 0.05, -0.08]])


def hexaglide_strut_masses() -> np.ndarray:
    return np.array([12.13, 12.13, 11.52, 11.52, 11.52, 11.52])  # kg, machines.md §1.4


# ------------------------------------------------------------------------------------------------ layout


def test_hexaglide_has_30_dof_in_spec_order():
    st_ = build_structure(HEXAGLIDE, POSES[:1])
    m = st_.model
    assert m.body_names == ["spindle", "platform"] + [f"drive{i}" for i in range(1, 7)]
    assert m.n_dof == 30
    assert m.element_names == [f"W{i}" for i in range(1, 7)] + [f"V{i}" for i in range(1, 7)] + ["U"]
    assert list(m.massless_dofs) == list(range(6))  # all of M_P on the platform: spindle massless (assumption)


def test_merged_platform_gives_24_dof_and_pod_without_suspension_6_dof():
    merged = dataclasses.replace(HEXAGLIDE, machine_components={"platform": "platform"})
    st_ = build_structure(merged, POSES[:1])
    assert st_.model.body_names == ["platform"] + [f"drive{i}" for i in range(1, 7)]
    assert st_.model.n_dof == 24 and st_.tcp_body == "platform"
    st6 = build_structure(HEX_6X, [0.0, 0.0, 1.3, 0.0, 0.0, 0.0])
    # 6X: rigid drive suspension (machines.md §4.3) -> drive DOFs removed, V from the platform to the frame
    assert st6.model.body_names == ["platform"] and st6.model.n_dof == 6
    assert all(s.body_a == ("frame",) * 6 for s in st6.model.sets)


def test_drive_frame_binding_is_eq_3_14_in_machine_axes():
    """Hexaglide guides run along ±x: K_W = R diag(25, 4520, 6800) N/µm Rᵀ = diag(25, 4520, 6800) N/µm."""
    st_ = build_structure(HEXAGLIDE, POSES)
    kw = st_.model.sets[0].stiffness.full()  # (1|N, 6, 3, 3)
    np.testing.assert_allclose(kw, np.broadcast_to(np.diag([25e6, 4520e6, 6800e6]), kw.shape), rtol=1e-14,
                               atol=1e-3)  # round-off of 1e9-sized products


def test_chain_stiffness_is_series_of_joints_and_strut():
    """k_V (eq. 4.48) from the joint tables evaluated at tilt angles computed here from the geometry
    (axis-referenced: arccos|a·d̂| drive side, arccos|m·d̂| platform side) and the strut stiffness."""
    st_ = build_structure(HEXAGLIDE, POSES)
    mc = machine_components(HEXAGLIDE)
    from components.protocol import ComponentState

    ik = inverse_kinematics(HEXAGLIDE, POSES)
    u = ik.unit_d
    m_mks = np.einsum("nij,cj->nci", ik.R, HEXAGLIDE.chains.platform_axis)
    tilt_d = np.arccos(np.clip(np.abs(np.einsum("cj,ncj->nc", HEXAGLIDE.chains.drive_axis, u)), 0, 1))
    tilt_p = np.arccos(np.clip(np.abs(np.einsum("ncj,ncj->nc", m_mks, u)), 0, 1))
    for i in range(6):
        k_dj = mc.drive_joint[i].stiffness(ComponentState(tilt=tilt_d[:, i]))
        k_pj = mc.platform_joint[i].stiffness(ComponentState(tilt=tilt_p[:, i]))
        k_st = mc.strut[i].stiffness(ComponentState(n_poses=len(POSES)))
        ref = 1.0 / (1.0 / k_dj + 1.0 / k_st + 1.0 / k_pj)
        np.testing.assert_allclose(st_.stiffness.chain[:, i], ref, rtol=1e-12)  # same formula, round-off only
        np.testing.assert_allclose(st_.model.sets[1].stiffness.k[:, i], ref, rtol=1e-12)


def test_masses_follow_the_strut_split_option():
    """Half of each strut's mass at each end (machine-file assumption), or all at the drive with the option."""
    ms = hexaglide_strut_masses()
    for share in (0.5, 1.0):
        st_ = build_structure(HEXAGLIDE, POSES[:1], StructureOptions(strut_mass_to_drive=share))
        m = st_.model
        drive_mass = np.array([float(m.body(f"drive{i}").mass[0]) for i in range(1, 7)])
        np.testing.assert_allclose(drive_mass, 102.17 + share * ms, rtol=1e-14)
        np.testing.assert_allclose(float(m.body("platform").mass[0]), 117.24 + (1 - share) * ms.sum(), rtol=1e-14)


def test_platform_inertia_includes_the_strut_shares_by_parallel_axis():
    """Platform inertia about its CoG = M_P inertia + point masses m_s/2 at p'_i (parallel-axis theorem), with the
    half/half strut split of option strut_mass_split (the bundled default adds no strut mass, machines.md §1.7
    item 10)."""
    st_ = build_structure(load_machine("hexaglide:strut_mass_split"), POSES[:1])
    pts = HEXAGLIDE.chains.platform_joint
    mp = 0.5 * hexaglide_strut_masses()
    total = 117.24 + mp.sum()
    cog = (mp[:, None] * pts).sum(axis=0) / total  # O' carries the 117.24 kg (CoG at O', machine file)
    inertia = np.diag([7.42, 7.74, 2.87]) + 117.24 * (cog @ cog * np.eye(3) - np.outer(cog, cog))
    for m_i, p in zip(mp, pts):
        r = p - cog
        inertia += m_i * (r @ r * np.eye(3) - np.outer(r, r))
    body = st_.model.body("platform")
    np.testing.assert_allclose(body.position[0], POSES[0, :3] + cog, atol=1e-15)
    np.testing.assert_allclose(body.inertia[0], inertia, rtol=1e-13, atol=1e-13)


# ------------------------------------------------------------------------------------------------ properties

pose_strategy = st.tuples(st.floats(-0.15, 0.15), st.floats(0.1, 0.45), st.floats(-1.0, -0.8),
                          st.floats(-0.06, 0.06), st.floats(-0.06, 0.06), st.floats(-0.1, 0.1))


@settings(max_examples=25, deadline=None)
@given(pose=pose_strategy)
def test_stiffness_matrix_symmetric_and_positive_definite(pose):
    st_ = build_structure(HEXAGLIDE, np.array(pose))
    assert st_.ok[0], st_.failing(0)
    k = sde.stiffness_matrix(st_.model)[0]
    scale = np.abs(k).max()
    assert np.abs(k - k.T).max() <= 1e-13 * scale  # symmetric to round-off
    eig = np.linalg.eigvalsh(k)
    assert eig[0] > 1e-12 * eig[-1]  # every body restrained: positive definite (not merely semi-definite)


def rigid_motion(model: sde.SDEModel, t: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Generalized displacement of a rigid motion (translation t of the origin, small rotation θ) of all bodies."""
    q = np.zeros(model.n_dof)
    for b in model.bodies:
        s = model.dof_index(b.name)
        q[s][:3] = t + np.cross(theta, b.position[0])
        if b.n_dof == 6:
            q[s][3:] = theta
    return q


def test_free_frame_gives_six_rigid_body_modes_and_no_strain_under_rigid_motion():
    """Frame bindings detached (the frame becomes a free body): K annihilates the six rigid motions and the
    modal analysis has exactly six zero eigenvalues (no mechanism, no spurious constraint)."""
    st_ = build_structure(HEXAGLIDE, POSES[1:2], StructureOptions(free_frame=True))
    m = st_.model
    k = sde.stiffness_matrix(m)[0]
    rng = np.random.default_rng(3)
    for _ in range(3):
        q = rigid_motion(m, rng.standard_normal(3), rng.standard_normal(3))
        assert np.linalg.norm(k @ q) <= 1e-12 * np.linalg.norm(k, 2) * np.linalg.norm(q)  # round-off level
    lam = sde.modes(m, 8).eigenvalues[0]
    assert np.all(np.abs(lam[:6]) < 1e-8 * lam[6])  # rigid-body modes: zero up to round-off of the solve
    assert lam[6] > 1.0  # first elastic mode well above zero (rad^2/s^2)


def rotated_machine(machine, Q):
    ch = machine.chains
    chains = dataclasses.replace(
        ch, guide_start=ch.guide_start @ Q.T, guide_direction=ch.guide_direction @ Q.T,
        drive_joint=ch.drive_joint @ Q.T, drive_axis=ch.drive_axis @ Q.T, drive_reference=ch.drive_reference @ Q.T)
    return dataclasses.replace(machine, chains=chains, gravity=Q @ machine.gravity, built_components={})


@pytest.mark.parametrize("name", ["hexaglide", "hexapod_6x"])
def test_invariance_under_rotating_the_whole_machine(name):
    """Rotating frame, guides, joints, gravity and the pose by Q: TCP compliance transforms as H C Hᵀ with
    H = diag(Q, Q) and the natural frequencies do not change."""
    machine = load_machine(name)
    poses = POSES if name == "hexaglide" else np.array([[0.0, 0.0, 1.3, 0.0, 0.0, 0.0],
                                                        [0.1, -0.05, 1.4, 0.05, -0.03, 0.1]])
    Q = rotation_about_axis([0.3, -0.5, 0.8], 0.7)
    rot = rotated_machine(machine, Q)
    ik = inverse_kinematics(machine, poses)
    a = build_structure(machine, poses)
    b = build_structure(rot, np.concatenate([poses[:, :3] @ Q.T, cardan_angles(Q @ ik.R)], axis=1))
    assert a.ok.all() and b.ok.all()
    ca, cb = tcp_compliance(a, 0.15), tcp_compliance(b, 0.15)
    H = np.zeros((6, 6))
    H[:3, :3] = H[3:, 3:] = Q
    expect = H @ ca @ H.T
    np.testing.assert_allclose(cb, expect, rtol=1e-9, atol=1e-9 * np.abs(ca).max())  # round-off of the rotation
    fa = sde.natural_frequencies(a.model, 6)
    fb = sde.natural_frequencies(b.model, 6)
    np.testing.assert_allclose(fb, fa, rtol=1e-9)


def test_maxwell_betti_reciprocity_between_tcp_and_a_platform_joint():
    """Displacement at B (platform joint 1, along e2) due to a unit force at A (TCP on the spindle, along e1)
    equals the displacement at A along e1 due to a unit force at B along e2 (two independent solves)."""
    st_ = build_structure(HEXAGLIDE, POSES)
    m = st_.model
    tcp = st_.tcp(0.15)
    pb = st_.p[:, 0]
    e1, e2 = np.array([0.3, -0.2, 0.9]), np.array([-0.5, 0.7, 0.1])
    q_a = sde.solve_static(m, sde.point_load(m, "spindle", tcp, force=e1))
    q_b = sde.solve_static(m, sde.point_load(m, "platform", pb, force=e2))
    u_ba = sde.point_motion(m, q_a, "platform", pb)[:, :3] @ e2
    u_ab = sde.point_motion(m, q_b, "spindle", tcp)[:, :3] @ e1
    np.testing.assert_allclose(u_ba, u_ab, rtol=1e-10)  # exact in theory; round-off of two factorised solves
    c = tcp_compliance(st_, 0.15)
    np.testing.assert_allclose(c, np.swapaxes(c, 1, 2), rtol=0, atol=1e-12 * np.abs(c).max())


# ------------------------------------------------------------------------------------ poses not modelled


def test_unreachable_and_singular_poses_give_nan_with_reason():
    poses = np.vstack([POSES, [[0.0, 0.0, 0.5, 0.0, 0.0, 0.0]]])  # z = +0.5 m: struts cannot reach the guides
    res = evaluate_structure(HEXAGLIDE, poses)
    assert res.ok.tolist() == [True, True, True, False]
    assert res.reasons[3] == Reason.UNREACHABLE
    assert np.all(np.isnan(res.frequencies_hz[3])) and np.all(np.isnan(res.compliance[3]))
    assert np.all(np.isfinite(res.frequencies_hz[:3]))
    # a threshold below every pose's condition number makes all poses singular: NaN, no exception
    strict = dataclasses.replace(HEXAGLIDE, limits=Limits(singularity_threshold=1.5))
    res = evaluate_structure(strict, poses)
    assert not res.ok.any()
    assert np.all(res.reasons[:3] == Reason.SINGULAR)
    assert "singular" in res.failing(0)[0]


def test_component_range_error_flags_only_the_affected_poses():
    """6X telescopic drive with out_of_range='error': poses whose strut length lies outside the l_eff range get
    COMPONENT_FAILED and NaN, the others are evaluated (bisection isolates them, no exception)."""
    machine = load_machine("hexapod_6x")
    machine.components["telescopic_strut"] = {**machine.components["telescopic_strut"], "out_of_range": "error"}
    poses = np.array([[0.0, 0.0, 1.3, 0, 0, 0], [0.0, 0.0, 0.2, 0, 0, 0], [0.1, 0.0, 1.2, 0, 0, 0]])
    ik = inverse_kinematics(machine, poses)
    outside = ((ik.length < 1.28) | (ik.length > 2.57)).any(axis=1)
    assert outside.tolist() == [False, True, False]  # input check of the test itself
    st_ = build_structure(machine, poses)
    assert st_.status.tolist() == [0, COMPONENT_FAILED, 0]
    c = tcp_compliance(st_)
    assert np.isnan(c[1]).all() and np.isfinite(c[[0, 2]]).all()


def test_non_positive_definite_pose_is_removed_from_the_chunk():
    """A pose whose chain stiffnesses vanish (platform held only by the massless spindle) has a singular K: the
    batch evaluation flags it NOT_POSITIVE_DEFINITE and returns the other poses unchanged."""
    st_ = build_structure(HEXAGLIDE, POSES)
    _, ref_c, ref_f = _evaluate_chunk(st_, None, 6)
    st_.stiffness.chain[1] = 0.0
    broken = st_.without(np.zeros(3, bool))
    out, comp, freq = _evaluate_chunk(broken, None, 6)
    assert out.index.tolist() == [0, 2] and out.status.tolist() == [0, NOT_POSITIVE_DEFINITE, 0]
    np.testing.assert_allclose(comp, ref_c[[0, 2]], rtol=1e-12)
    np.testing.assert_allclose(freq, ref_f[[0, 2]], rtol=1e-12)


def test_machine_without_stiffness_data_is_a_clear_error():
    with pytest.raises(StructureModelError, match="chains"):
        build_structure(load_machine("linapod"), [0.0, 0.0, 0.0, 0.0, 0.0, 0.0])


def test_pod_chain_stiffness_is_the_telescopic_drive():
    """6X (joints rigid by assumption): k_V = k_St(l) of the telescopic drive, eq. 3.22 fit with
    l_eff = 0.12 m + (l − 1.28 m) (machines.md §4.2), evaluated here from the printed polynomial."""
    poses = np.array([[0.0, 0.0, 1.3, 0, 0, 0], [0.1, -0.05, 1.4, 0.05, -0.03, 0.1]])
    st_ = build_structure(HEX_6X, poses)
    l_eff = 0.12 + (inverse_kinematics(HEX_6X, poses).length - 1.28)
    ref = np.polyval([85.3, -248.14, 285.53], l_eff) * 1e6
    np.testing.assert_allclose(st_.stiffness.chain, ref, rtol=1e-12)


def test_pole_placement_drive_stiffness_uses_the_joint_space_mass():
    """axial_stiffness = 'pole_placement': k_A,i = m_i Ω² with m_i = diag(M_A + J_Cᵀ M_P J_C)_i (eq. 3.5, 3.10–3.12),
    J_C here from a finite-difference inverse Jacobian, M_P = 117.24 kg and the PKS inertia at O' (machine file)."""
    from pkmstiff.kinematics.rotation import cardan_matrix
    from tests.test_structure_analysis import fd_inverse_jacobian

    machine = load_machine("hexaglide")
    omega = 500.0  # rad/s (not given for any machine: a test value)
    for i in range(1, 7):
        raw = dict(machine.components[f"linear_motor_{i}"])
        del raw["k_axial"]
        machine.components[f"linear_motor_{i}"] = {**raw, "axial_stiffness": "pole_placement",
                                                   "pole_distance": f"{omega} rad/s"}
    st_ = build_structure(machine, POSES)
    for n, pose in enumerate(POSES):
        jc = np.linalg.inv(fd_inverse_jacobian(machine, pose))
        R = cardan_matrix(*pose[3:])
        mp = np.zeros((6, 6))
        mp[:3, :3] = 117.24 * np.eye(3)
        mp[3:, 3:] = R @ np.diag([7.42, 7.74, 2.87]) @ R.T
        m_eff = 102.17 + np.einsum("ki,kl,li->i", jc, mp, jc)
        np.testing.assert_allclose(st_.stiffness.drive[n], m_eff * omega ** 2, rtol=1e-6)  # FD Jacobian ~1e-8
        np.testing.assert_allclose(st_.stiffness.w_local[n, :, 0, 0], m_eff * omega ** 2, rtol=1e-6)
