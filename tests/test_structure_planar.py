"""Planar examples (spec models.md §1.7, §4.8, §6; machines.md §5): bundled files, kinematics, stiffness, modes
and kinetostatics of the biglide and the bipod against closed forms."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from pkmstiff.analysis.planar import (
    bundled_planar,
    load_planar,
    planar_compliance,
    planar_inverse_jacobian,
    planar_inverse_kinematics,
    planar_kinetostatics,
    planar_modes,
    planar_stiffness,
    planar_structure,
)
from pkmstiff.errors import InputError

BIGLIDE, BIPOD = load_planar("biglide"), load_planar("bipod")
POS = np.array([[0.0, -0.707], [0.15, -0.6], [-0.2, -0.8]])  # m; x = 0, y = -707 mm is Cobet's mode-shape point


def test_bundled_files_hold_the_chapter_4_values():
    assert bundled_planar() == ["biglide", "bipod"]
    assert BIGLIDE.kind == "glide" and BIPOD.kind == "pod"
    np.testing.assert_allclose(BIGLIDE.drive_stiffness, 1e6)  # 1 N/µm along the guide
    np.testing.assert_allclose(BIGLIDE.guide_stiffness, 1e7)  # one order of magnitude higher transverse
    assert np.all(np.isinf(BIGLIDE.strut_stiffness))  # rigid struts
    np.testing.assert_allclose(BIPOD.chain_stiffness, 1e6)
    assert BIGLIDE.platform_mass == 50.0 and BIPOD.platform_mass == 50.0
    np.testing.assert_allclose(BIGLIDE.drive_mass, 10.0)
    np.testing.assert_allclose(BIPOD.drive_point, [[-1.0, 0.0], [1.0, 0.0]])


def unit_struts(pm, pos):
    ik = planar_inverse_kinematics(pm, pos)
    return ik.d / np.linalg.norm(ik.d, axis=-1, keepdims=True)


def test_bipod_stiffness_is_sum_of_dyads():
    """K = Σ k_i n_i n_iᵀ (Cobet eq. 4.57)."""
    n = unit_struts(BIPOD, POS)
    ref = 1e6 * np.einsum("nij,nik->njk", n, n)
    np.testing.assert_allclose(planar_stiffness(planar_structure(BIPOD, POS)), ref, rtol=1e-10, atol=1e-4)


def test_biglide_from_first_principles():
    """Rigid struts: K = Σ k_eff n nᵀ, k_eff = 1/(nᵀ K_A⁻¹ n), K_A = R diag(1, 10) N/µm Rᵀ (spec §4.8; not the
    dissertation's componentwise eq. 4.53–4.56)."""
    n = unit_struts(BIGLIDE, POS)
    ref = np.zeros((len(POS), 2, 2))
    for i in range(2):
        r = BIGLIDE.guide_direction[i]
        t = np.array([-r[1], r[0]])
        ka_inv = np.outer(r, r) / 1e6 + np.outer(t, t) / 1e7
        k_eff = 1.0 / np.einsum("nj,jk,nk->n", n[:, i], ka_inv, n[:, i])
        ref += k_eff[:, None, None] * np.einsum("nj,nk->njk", n[:, i], n[:, i])
    np.testing.assert_allclose(planar_stiffness(planar_structure(BIGLIDE, POS)), ref, rtol=1e-10, atol=1e-4)
    # the dissertation's simplified formula differs (it ignores the coupling through the rigid struts)
    simplified = np.array([np.diag([sum(1e6 * n[p, i, 0] ** 2 for i in range(2)),
                                    sum(1e7 * n[p, i, 1] ** 2 for i in range(2))]) for p in range(len(POS))])
    assert np.abs(simplified[0] - ref[0]).max() > 0.1 * np.abs(ref[0]).max()


def test_bipod_frequencies_closed_form():
    k = planar_stiffness(planar_structure(BIPOD, POS))
    ref = np.sqrt(np.linalg.eigvalsh(k / 50.0)) / (2 * np.pi)
    md = planar_modes(planar_structure(BIPOD, POS))
    np.testing.assert_allclose(md.frequencies_hz, ref, rtol=1e-10)


def test_biglide_modes_against_a_null_space_reference():
    """6 DOF (drives and platform, x/y each), two rigid-strut constraints nᵀ(δp − δq_i) = 0 eliminated by a
    null-space basis Z: Zᵀ K Z v = λ Zᵀ M Z v (spec §4.8 modal reference)."""
    n = unit_struts(BIGLIDE, POS)
    md = planar_modes(planar_structure(BIGLIDE, POS))
    for p in range(len(POS)):
        K = np.zeros((6, 6))  # order: platform (0, 1), drive 1 (2, 3), drive 2 (4, 5)
        for i in range(2):
            r = BIGLIDE.guide_direction[i]
            t = np.array([-r[1], r[0]])
            s = slice(2 + 2 * i, 4 + 2 * i)
            K[s, s] = 1e6 * np.outer(r, r) + 1e7 * np.outer(t, t)
        M = np.diag([50.0, 50.0, 10.0, 10.0, 10.0, 10.0])
        phi = np.zeros((2, 6))
        for i in range(2):
            phi[i, 0:2] = n[p, i]
            phi[i, 2 + 2 * i:4 + 2 * i] = -n[p, i]
        Z = scipy.linalg.null_space(phi)
        lam = scipy.linalg.eigh(Z.T @ K @ Z, Z.T @ M @ Z, eigvals_only=True)
        np.testing.assert_allclose(md.frequencies_hz[p], np.sqrt(lam) / (2 * np.pi), rtol=1e-9)


def test_inverse_jacobian_against_finite_differences():
    h = 1e-6
    for pm in (BIGLIDE, BIPOD):
        jinv = planar_inverse_jacobian(pm, planar_inverse_kinematics(pm, POS))
        for j in range(2):
            dp = np.zeros(2)
            dp[j] = h
            ahead, back = planar_inverse_kinematics(pm, POS + dp), planar_inverse_kinematics(pm, POS - dp)
            fd = (ahead.drive - back.drive) / (2 * h)
            np.testing.assert_allclose(jinv[:, :, j], fd, rtol=1e-7, atol=1e-9)  # central differences, O(h²)


def test_transmission_quality_closed_form():
    """At p = (0, y): bipod U = |y| (for |y| ≤ 1, drive points at x = ±1); biglide U = min(t, 1/t) with
    t = |y| / sqrt(l² − y²) (unit strut length)."""
    y = np.array([-0.3, -0.6, -0.9])
    pos = np.column_stack([np.zeros(3), y])
    np.testing.assert_allclose(planar_kinetostatics(BIPOD, pos).transmission_quality, np.abs(y), rtol=1e-12)
    t = np.abs(y) / np.sqrt(1.0 - y ** 2)
    np.testing.assert_allclose(planar_kinetostatics(BIGLIDE, pos).transmission_quality, np.minimum(t, 1 / t),
                               rtol=1e-12)


def test_bipod_acceleration_closed_form_without_gravity():
    """Bipod, M_A = 0 (eq. 4.94): τ = Jᵀ m_P a. At p = (0, y) and a along y both struts share the load equally:
    a_max = 2 T |n_y| / m_P with T = 1000 N."""
    y = -0.707
    k = planar_kinetostatics(BIPOD, [[0.0, y]], directions=[(0.0, 1.0)], include_gravity=False)
    ny = abs(y) / np.hypot(1.0, y)
    np.testing.assert_allclose(k.a_max[0, 0], 2 * 1000.0 * ny / 50.0, rtol=1e-12)
    # with gravity the static loads are the holding forces: 2 f n_y = m_P g
    kg = planar_kinetostatics(BIPOD, [[0.0, y]], directions=[(0.0, 1.0)])
    np.testing.assert_allclose(np.abs(kg.drive_loads[0]), 50 * 9.81 / (2 * ny), rtol=1e-12)
    np.testing.assert_allclose(kg.a_max[0, 0], (1000.0 - 50 * 9.81 / (2 * ny)) * 2 * ny / 50.0, rtol=1e-12)


def test_unreachable_and_singular_positions_give_nan():
    pos = np.array([[0.0, -0.707], [0.0, -2.0], [0.0, 0.0]])  # (0, -2): struts too short; (0, 0): singular
    ps = planar_structure(BIGLIDE, pos)
    c = planar_compliance(ps)
    assert np.isfinite(c[0]).all() and np.isnan(c[1:]).all()
    assert ps.reasons[1] & 1 and ps.reasons[2] & 32  # UNREACHABLE, SINGULAR
    md = planar_modes(ps)
    assert np.isnan(md.frequencies_hz[1:]).all() and np.isfinite(md.frequencies_hz[0]).all()


@pytest.mark.parametrize("text, key", [
    ("[machine]\nname='b'\ntype='glide'\n[platform]\nmass='1 kg'\n[[chains]]\n[[chains]]\n", "guide_start"),
    ("[machine]\nname='b'\ntype='pod'\n[platform]\nmass='1 kg'\n[chain_defaults]\nlength_min=1\nlength_max=2\n"
     "strut_stiffness='3 N/kg'\n[[chains]]\ndrive_point=[0,0]\n[[chains]]\ndrive_point=[1,0]\n", "strut_stiffness"),
    ("[machine]\nname='b'\ntype='pod'\ncolour='red'\n", "machine.colour"),
    ("[machine]\nname='b'\ntype='pod'\n[platform]\nmass='1 kg'\n[[chains]]\n", "chains"),
])
def test_file_errors_name_the_key(tmp_path, text, key):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(InputError, match=key.replace(".", r"\.")):
        load_planar(f)
