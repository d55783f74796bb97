"""Analyses of the PKM structure model (spec models.md §5, §6): TCP stiffness, weak points, modal analysis, FRF,
kinetostatics and the batch evaluation, each against an independent relation or reference."""

from __future__ import annotations

import numpy as np
import pytest

import pkmstiff.multibody as sde
from pkmstiff.analysis import (
    evaluate_structure,
    kinetostatics,
    modal_analysis,
    natural_frequencies,
    static_deformation,
    tcp_compliance,
    tcp_frf,
    tcp_stiffness_matrix,
    weak_points,
)
from pkmstiff.kinematics import inverse_kinematics
from pkmstiff.machine.loader import load_machine
from pkmstiff.multibody.linalg import reference_matrix
from pkmstiff.structure import build_structure

HEXAGLIDE = load_machine("hexaglide")
POSES = np.array([[0.0, 0.0, -1.0, 0.0, 0.0, 0.0],
                  [0.05, 0.25, -0.95, 0.03, -0.02, 0.05],
                  [-0.1, 0.35, -0.85, -0.04, 0.05, -0.08]])
ST = build_structure(HEXAGLIDE, POSES)


# ------------------------------------------------------------------------------------------------ static


def test_tool_length_transfers_the_compliance_as_a_rigid_body():
    """C(L) = N(Δ) C(0) N(Δ)ᵀ with Δ = R L·axis (the tool is rigid, spec §5.1)."""
    c0, c1 = tcp_compliance(ST, 0.0), tcp_compliance(ST, 0.15)
    delta = np.einsum("nij,j->ni", ST.R, 0.15 * HEXAGLIDE.tool.axis)
    n = reference_matrix(delta)
    np.testing.assert_allclose(c1, n @ c0 @ np.swapaxes(n, 1, 2), rtol=1e-10, atol=1e-12 * np.abs(c1).max())


def test_neglect_spindle_removes_exactly_the_platform_stiffness_in_series():
    """The spindle hangs on U only: C_full − C_neglect = N(Δ) (H K_U Hᵀ)⁻¹ N(Δ)ᵀ (series connection), Δ = TCP − r_U."""
    from pkmstiff.structure import StructureOptions

    rigid_u = build_structure(HEXAGLIDE, POSES, StructureOptions(load_platform=True))  # load the platform, K_U rigid
    full, neg = tcp_compliance(ST, 0.15), tcp_compliance(rigid_u, 0.15)
    ku = np.diag([1603e6, 1567e6, 588e6, 4348e6, 5115e6, 2564e6])  # machines.md §1.4 (Nm/µrad reading)
    H = np.zeros((len(POSES), 6, 6))
    H[:, :3, :3] = H[:, 3:, 3:] = ST.R
    n = reference_matrix(ST.tcp(0.15) - ST.w)
    expect = n @ H @ np.linalg.inv(ku) @ np.swapaxes(H, 1, 2) @ np.swapaxes(n, 1, 2)
    # the difference of two compliances of ~1e-7 m/N loses digits to cancellation: tolerances relative to |C_full|
    np.testing.assert_allclose(full - neg, expect, rtol=1e-6, atol=1e-9 * np.abs(full).max())


def test_stiffness_matrix_is_the_inverse_compliance_and_directional_stiffness_matches_a_solve():
    c = tcp_compliance(ST, 0.15)
    k = tcp_stiffness_matrix(ST, 0.15)
    np.testing.assert_allclose(k @ c, np.broadcast_to(np.eye(6), c.shape), atol=1e-9)  # condition ~1e3
    e = np.array([0.6, -0.48, 0.64])
    d = static_deformation(ST, force=e, tool_length=0.15)
    k_e = 1.0 / (d.tcp[:, :3] @ e)  # |F| / (e·u) for a unit force (spec §5.1)
    np.testing.assert_allclose(k_e, sde.directional_stiffness(c, e), rtol=1e-10)


def test_deformation_energy_and_component_split():
    """Σ component strain energies = ½ fᵀq = ½ e·u (Clapeyron); V's series terms share its energy in proportion
    to their compliances (same force)."""
    e = np.array([1.0, 0.0, 0.0])
    d = static_deformation(ST, force=500.0 * e)
    work = 0.5 * 500.0 * d.tcp[:, :3] @ e
    np.testing.assert_allclose(d.component_energy.sum(axis=1), work, rtol=1e-10)
    wp = weak_points(ST, "x")
    np.testing.assert_allclose(wp.component_shares.sum(axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(wp.element_shares.sum(axis=1), 1.0, rtol=1e-12)
    ks = ST.stiffness
    # per chain: E_joint/E_strut = k_strut/k_joint; summed over chains with the per-chain V energies
    v_energy = np.array([0.5 * ks.chain[:, i] * (d.sdes[f"V{i + 1}"] @ np.eye(3)
                                                 * ST.u[:, i]).sum(axis=1) ** 2 for i in range(6)]).T
    labels = d.component_labels
    expect_dj = (v_energy * ks.chain / ks.drive_joint).sum(axis=1)
    expect_st = (v_energy * ks.chain / ks.strut).sum(axis=1)
    np.testing.assert_allclose(d.component_energy[:, labels.index("drive_joint")], expect_dj, rtol=1e-12)
    np.testing.assert_allclose(d.component_energy[:, labels.index("strut")], expect_st, rtol=1e-12)
    # W: axial drive energy = ½ k_A (l·r)² with r = ±x for the Hexaglide
    w_drive = sum(0.5 * 25e6 * d.sdes[f"W{i}"][:, 0] ** 2 for i in range(1, 7))
    np.testing.assert_allclose(d.component_energy[:, labels.index("drive")], w_drive, rtol=1e-12)


def test_weak_points_for_a_moment_and_labels():
    wp = weak_points(ST, "rz", tool_length=0.15)
    assert wp.rotational and wp.element_labels[-1] == "U"
    assert wp.component_labels == ["drive", "guide", "drive_joint", "strut", "platform_joint", "platform_spindle"]
    c = tcp_compliance(ST, 0.15)
    np.testing.assert_allclose(wp.compliance, c[:, 5, 5], rtol=1e-10)  # rotation about z per unit moment


# ------------------------------------------------------------------------------------------------ modal


def test_modal_analysis_energy_shares_and_fast_path():
    ma = modal_analysis(ST, 6)
    np.testing.assert_allclose(ma.kinetic.sum(axis=-1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(ma.strain.sum(axis=-1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(ma.component_strain.sum(axis=-1), 1.0, rtol=1e-12)
    assert ma.kinetic[..., ma.body_labels.index("spindle")].max() == 0.0  # massless spindle
    # the eigenproblem without the massless spindle (exact static condensation) gives the same frequencies
    np.testing.assert_allclose(natural_frequencies(ST, 6), ma.frequencies_hz, rtol=1e-9)
    assert ST.dynamic_model.n_dof == 24
    # the dominant platform motion: its share is the largest of the six motion shares
    shares = sde.motion_shares(ST.model, np.nan_to_num(ma.shapes), "platform")
    np.testing.assert_allclose(ma.dominant_share, shares.max(axis=-1), rtol=1e-12)
    assert ma.description(0, 0).endswith("%)")


def test_mode_shapes_solve_the_generalized_eigenproblem():
    ma = modal_analysis(ST, 4)
    k = sde.stiffness_matrix(ST.model)
    m = sde.mass_matrix(ST.model)
    v = ma.shapes  # (N, k, n)
    lam = ma.eigenvalues
    res = np.einsum("nij,nkj->nki", k, v) - lam[..., None] * np.einsum("nij,nkj->nki", m, v)
    scale = np.einsum("nij,nkj->nki", k, v)
    assert np.abs(res).max() <= 1e-8 * np.abs(scale).max()  # Guyan-recovered spindle DOFs satisfy K v = λ M v


# ------------------------------------------------------------------------------------------------ FRF


def test_frf_static_limit_accelerance_and_peaks():
    f = np.linspace(0.0, 120.0, 2401)
    h = tcp_frf(ST, f, "x", "x", zeta=0.01)
    c = tcp_compliance(ST)
    np.testing.assert_allclose(h.values[:, 0].real, c[:, 0, 0], rtol=1e-9)  # H(0) = static compliance
    a = tcp_frf(ST, f, "x", "x", zeta=0.01, kind="accelerance")
    np.testing.assert_allclose(a.values, -(2 * np.pi * f) ** 2 * h.values, rtol=1e-12)
    fn = natural_frequencies(ST, 24)
    fine = np.arange(1.0, 120.0, 0.002)
    weak = tcp_frf(ST, fine, "x", "x", zeta=1e-4)
    for i in range(len(POSES)):
        peaks = weak.peak_hz[i][np.isfinite(weak.peak_hz[i])]
        assert peaks.size >= 3
        # ζ = 1e-4: the resonant term dominates near each resonance, so every peak sits at a natural frequency
        # (to the 2 mHz grid plus the O(ζ) shift from the other modes)
        assert np.all(np.min(np.abs(peaks[:, None] - fn[i][None]), axis=1) <= 0.004 + 1e-4 * peaks)
    direct = tcp_frf(ST, f[::200], "y", "z", zeta=0.02, method="direct")
    modal = tcp_frf(ST, f[::200], "z", "y", zeta=0.02)
    np.testing.assert_allclose(direct.values, modal.values, rtol=1e-6)  # reciprocity + method agreement


# ------------------------------------------------------------------------------------------------ kinetostatics


def fd_inverse_jacobian(machine, pose, h=1e-6):
    """∂q/∂(v, ω) by central differences of the inverse kinematics (small rotations about global axes)."""
    from pkmstiff.kinematics import inverse_kinematics_frames
    from pkmstiff.kinematics.rotation import cardan_matrix

    R = cardan_matrix(*pose[3:])
    cols = []
    for j in range(6):
        qs = []
        for s in (1, -1):
            w, Rj = pose[:3].copy(), R
            if j < 3:
                w[j] += s * h
            else:
                Rj = sde.linalg.rotation_about_axis(np.eye(3)[j - 3], s * h) @ R
            qs.append(inverse_kinematics_frames(machine, w[None], Rj[None]).drive[0])
        cols.append((qs[0] - qs[1]) / (2 * h))
    return np.array(cols).T


def test_max_velocity_against_finite_difference_jacobian():
    ks = kinetostatics(HEXAGLIDE, POSES)
    for i, pose in enumerate(POSES):
        jinv = fd_inverse_jacobian(HEXAGLIDE, pose)
        for j, e in enumerate(np.eye(6)[:3]):
            rate = np.abs(jinv @ e).max()  # fastest drive per unit tool speed
            np.testing.assert_allclose(ks.v_max[i, j] * rate, 1.0, rtol=1e-7)  # q̇_max = 1 m/s; FD error ~h²


def test_max_acceleration_is_the_largest_feasible_and_limits_one_drive():
    """Independent reference: required drive forces τ(α) = α M_q e + τ_g + C sign(J⁻¹e) with J⁻¹ from finite
    differences, J_C its inverse, M_P from the machine data (117.24 kg, inertia diag in PKS, CoG at O'), M_A =
    102.17 kg, gravity load of platform + six struts (187.58 kg, machines.md §1.7 item 5); a_max is the largest α
    with |τ_i| ≤ 2500 − 300 N for all drives."""
    ks = kinetostatics(HEXAGLIDE, POSES)
    coulomb = np.array([75.7, 106.4, 113.1, 153.0, 93.0, 66.4])
    ik = inverse_kinematics(HEXAGLIDE, POSES)
    for i, pose in enumerate(POSES):
        jinv = fd_inverse_jacobian(HEXAGLIDE, pose)
        jc = np.linalg.inv(jinv)
        R = ik.R[i]
        mp = np.zeros((6, 6))
        mp[:3, :3] = 117.24 * np.eye(3)
        mp[3:, 3:] = R @ np.diag([7.42, 7.74, 2.87]) @ R.T
        tau_g = jc.T @ np.r_[0, 0, (117.24 + 2 * 12.13 + 4 * 11.52) * 9.81, 0, 0, 0]
        np.testing.assert_allclose(ks.drive_loads[i], tau_g, rtol=1e-6, atol=1e-6)  # FD Jacobian accuracy
        for j, e in enumerate(ks.acceleration_directions):
            mu = 102.17 * (jinv @ e) + jc.T @ (mp @ e)
            fixed = tau_g + coulomb * np.sign(np.round(jinv @ e, 9))
            alpha = ks.a_max[i, j]
            need = np.abs(alpha * mu + fixed)
            assert np.all(need <= 2200.0 * (1 + 1e-6))  # feasible at a_max
            lim = ks.a_limiting[i, j]
            np.testing.assert_allclose(need[lim], 2200.0, rtol=1e-5)  # the limiting drive is exactly at T
            assert not ks.a_infeasible[i, j]


def test_kinetostatics_nan_for_unreachable_and_transmission_quality_range():
    ks = kinetostatics(HEXAGLIDE, np.vstack([POSES, [[0, 0, 0.5, 0, 0, 0]]]))
    assert np.all(np.isnan(ks.v_max[3])) and np.all(np.isnan(ks.a_max[3])) and np.isnan(ks.transmission_quality[3])
    assert np.all((ks.transmission_quality[:3] > 0) & (ks.transmission_quality[:3] <= 1))
    assert ks.weight == pytest.approx(0.5 / (np.pi / 9), rel=1e-12)  # eq. 5.1


# ------------------------------------------------------------------------------------------------ batch


def test_batch_equals_the_single_structure_analyses():
    rng = np.random.default_rng(11)
    poses = np.column_stack([rng.uniform(-0.15, 0.15, 40), rng.uniform(0.1, 0.45, 40), rng.uniform(-1.0, -0.8, 40),
                             rng.uniform(-0.05, 0.05, (40, 3))])
    res = evaluate_structure(HEXAGLIDE, poses, tool_length=0.15, n_modes=6, chunk_size=16)
    st_ = build_structure(HEXAGLIDE, poses)
    np.testing.assert_allclose(res.compliance, tcp_compliance(st_, 0.15), rtol=1e-10,
                               atol=1e-12 * np.nanmax(np.abs(res.compliance)))
    np.testing.assert_allclose(res.frequencies_hz, sde.natural_frequencies(st_.model, 6), rtol=1e-9)
    np.testing.assert_allclose(res.stiffness, 1.0 / np.diagonal(res.compliance, axis1=1, axis2=2), rtol=1e-14)


def test_sde_damping_is_proportional_so_modal_and_direct_frf_agree():
    """C_e = β K_e on every SDE gives C = β K (Rayleigh): the modal superposition is then exact and equals the
    direct complex solve (response at the platform: the massless spindle's U damper carries no force there)."""
    from pkmstiff.structure import StructureOptions

    st_ = build_structure(HEXAGLIDE, POSES[1:], StructureOptions(damping_beta=2e-4, load_platform=True))
    f = np.array([5.0, 17.0, 24.0, 43.0, 80.0])
    kw = dict(zeta=None, sde_damping=True)
    for resp, exc in (("x", "x"), ("z", "y")):
        modal = tcp_frf(st_, f, resp, exc, **kw)
        direct = tcp_frf(st_, f, resp, exc, method="direct", **kw)
        scale = np.abs(direct.values).max()
        np.testing.assert_allclose(modal.values, direct.values, rtol=1e-8, atol=1e-9 * scale)  # round-off only
    undamped = tcp_frf(build_structure(HEXAGLIDE, POSES[1:], StructureOptions(load_platform=True)), f, "x", "x")
    damped = tcp_frf(st_, f, "x", "x", **kw)
    assert np.all(np.abs(damped.values.imag) > 0) and np.all(undamped.values.imag == 0)  # the damping acts


def test_full_admissibility_check_excludes_inadmissible_poses():
    """check='full': every failing admissibility check of the pose pipeline makes the pose NaN (here the drive
    range: y = 0.95 m pushes drives 1, 2 off their guides), with the pipeline's reason code."""
    from pkmstiff.admissibility.checks import Reason
    from pkmstiff.admissibility.pipeline import evaluate_poses
    from pkmstiff.structure import StructureOptions

    poses = np.vstack([POSES, [[0.0, 0.95, -0.9, 0.0, 0.0, 0.0]]])
    ev = evaluate_poses(HEXAGLIDE, poses)
    full = build_structure(HEXAGLIDE, poses, StructureOptions(check="full"))
    assert full.reasons.tolist() == ev.admissibility.reasons.tolist()
    assert full.ok.tolist() == ev.ok.tolist()
    assert not full.ok[3] and full.reasons[3] != 0
    kin = build_structure(HEXAGLIDE, poses)
    # pose 3 fails by reach alone (chains 5 and 6 cannot meet their guides), so the kinematic check says the same
    assert not kin.ok[3] and kin.reasons[3] == int(Reason.UNREACHABLE)


def test_tool_vector_gives_any_tool_orientation():
    """A tool vector t (PKS) instead of a length: C = N(R t) C(O') N(R t)ᵀ; t = L·axis reproduces tool_length=L."""
    t = np.array([0.05, -0.02, -0.12])
    c = tcp_compliance(ST, t)
    n = reference_matrix(np.einsum("nij,j->ni", ST.R, t))
    c0 = tcp_compliance(ST, 0.0)
    np.testing.assert_allclose(c, n @ c0 @ np.swapaxes(n, 1, 2), rtol=1e-10, atol=1e-12 * np.abs(c).max())
    np.testing.assert_allclose(tcp_compliance(ST, 0.15 * HEXAGLIDE.tool.axis), tcp_compliance(ST, 0.15), rtol=1e-13)
    res = evaluate_structure(HEXAGLIDE, POSES, tool_length=t, n_modes=0)
    np.testing.assert_allclose(res.compliance, c, rtol=1e-10, atol=1e-12 * np.abs(c).max())
