"""Assembly of the generic SDE model (spec models.md §4.3–4.6): congruence rule, symmetry, invariances."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import pkmstiff.multibody as sde
from pkmstiff.errors import InputError
from pkmstiff.multibody.linalg import reference_matrix, rotation_about_axis, skew, translation_matrix


def random_spd(rng: np.random.Generator, d: int, lo: float, hi: float) -> np.ndarray:
    q, _ = np.linalg.qr(rng.standard_normal((d, d)))
    return q @ np.diag(rng.uniform(lo, hi, d)) @ q.T


def pkm_like(rng: np.random.Generator, n_poses: int = 4):
    """30-DOF model with the binding structure of spec §4.2/4.4 and the data to rebuild eq. 4.64–4.69 by hand."""
    w = rng.uniform(-0.2, 0.2, (n_poses, 3)) + [0, 0, 1.0]
    r_s = w + rng.uniform(-0.05, 0.05, (n_poses, 3)) + [0, 0, 0.2]
    r_p = w + rng.uniform(-0.05, 0.05, (n_poses, 3))
    p = w[:, None] + rng.uniform(-0.4, 0.4, (n_poses, 6, 3))
    q = rng.uniform(-1.5, 1.5, (n_poses, 6, 3)) + [0, 0, 2.0]
    d_hat = (p - q) / np.linalg.norm(p - q, axis=-1, keepdims=True)
    kv = rng.uniform(5e7, 3e8, (n_poses, 6))
    kw = np.stack([random_spd(rng, 3, 1e7, 1e9) for _ in range(6)])
    ku = random_spd(rng, 6, 1e8, 1e9)
    m = sde.SDEModel()
    m.add_rigid_body("spindle", 40.0, r_s, [0.8, 0.9, 0.3])
    m.add_rigid_body("platform", 120.0, r_p, [6.0, 5.0, 10.0])
    for i in range(6):
        m.add_point_mass(f"A{i}", 10.0 + 10 * i, q[:, i])
    names = [f"A{i}" for i in range(6)]
    m.add_sde_set([f"W{i}" for i in range(6)], names, sde.FRAME, q, stiffness=kw)
    m.add_sde_set([f"V{i}" for i in range(6)], names, "platform", p, k=kv, axis=d_hat)
    m.add_sde("U", "platform", "spindle", w, stiffness=ku)
    return m, dict(w=w, r_s=r_s, r_p=r_p, p=p, d_hat=d_hat, kv=kv, kw=kw, ku=ku)


def test_pkm_matrix_equals_cobet_4_69():
    """K of the 30-DOF structure equals the block matrix of Cobet eq. 4.64–4.69 built by hand (spec §4.5)."""
    rng = np.random.default_rng(1)
    m, g = pkm_like(rng)
    k = sde.stiffness_matrix(m)
    for n in range(k.shape[0]):
        n_su, n_pu = reference_matrix(g["w"][n] - g["r_s"][n]), reference_matrix(g["w"][n] - g["r_p"][n])
        a = n_su.T @ g["ku"] @ n_su
        b = n_su.T @ g["ku"] @ n_pu
        c = n_pu.T @ g["ku"] @ n_pu
        ref = np.zeros((30, 30))
        for i in range(6):
            t = translation_matrix(g["p"][n, i] - g["r_p"][n])
            kvi = g["kv"][n, i] * np.outer(g["d_hat"][n, i], g["d_hat"][n, i])
            c = c + t.T @ kvi @ t
            d = t.T @ kvi
            s = slice(12 + 3 * i, 15 + 3 * i)
            ref[6:12, s], ref[s, 6:12] = -d, -d.T
            ref[s, s] = kvi + g["kw"][i]
        ref[:6, :6], ref[:6, 6:12], ref[6:12, :6], ref[6:12, 6:12] = a, -b, -b.T, c
        # round-off of sums of terms up to ~1e9 N/m: 1e-12 relative to the largest entry
        np.testing.assert_allclose(k[n], ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    assert m.dof_index("platform") == slice(6, 12) and m.dof_index("A5") == slice(27, 30)


def test_mass_matrix_blocks_and_rotation():
    """M = diag(m I3, R I' Rᵀ) for a rigid body with inertia in body axes (spec §4.6)."""
    rot = rotation_about_axis([1.0, 2.0, 0.5], 0.7)
    m = sde.SDEModel()
    m.add_rigid_body("b", 3.0, [0.1, 0.2, 0.3], [1.0, 2.0, 3.0], rotation=rot)
    m.add_point_mass("p", 2.0, [0, 0, 0])
    mm = sde.mass_matrix(m)[0]
    np.testing.assert_allclose(mm[:3, :3], 3.0 * np.eye(3), rtol=1e-15)
    np.testing.assert_allclose(mm[3:6, 3:6], rot @ np.diag([1.0, 2.0, 3.0]) @ rot.T, rtol=0, atol=1e-14)
    np.testing.assert_allclose(mm[6:, 6:], 2.0 * np.eye(3), rtol=1e-15)
    assert np.all(mm[:6, 6:] == 0)


def test_axial_element_equals_dyad_and_3x3_form():
    """k n nᵀ along an axis equals the same element given as a 3x3 matrix (spec §4.4, eq. 4.48)."""
    rng = np.random.default_rng(2)
    n = rng.standard_normal(3)
    models = []
    for form in ("axial", "matrix"):
        m = sde.SDEModel()
        m.add_rigid_body("b", 1.0, [0.3, 0.1, 0.0], [1.0, 1.0, 1.0])
        kwargs = dict(k=2e7, axis=n) if form == "axial" else dict(stiffness=2e7 * np.outer(n, n) / (n @ n))
        m.add_sde("s", "b", sde.FRAME, [1.0, -0.5, 0.2], **kwargs)
        models.append(sde.stiffness_matrix(m)[0])
    np.testing.assert_allclose(models[0], models[1], rtol=1e-13, atol=1e-6)  # 1e-6 N/m of ~1e7: round-off


def test_pose_broadcast_and_per_pose_geometry():
    """A model with a pose axis equals the stack of single-pose models (no per-pose mixing)."""
    rng = np.random.default_rng(3)
    m_all, _ = pkm_like(rng, n_poses=3)
    k_all = sde.stiffness_matrix(m_all)
    for n in range(3):
        k_one = sde.stiffness_matrix(m_all.poses(slice(n, n + 1)))
        np.testing.assert_array_equal(k_one[0], k_all[n])


# ---------------------------------------------------------------- random models (hypothesis)

def random_model(seed: int, free: bool = False) -> tuple[sde.SDEModel, list]:
    """Random connected model; point masses sit at the coupling points of their elements (consistent geometry).
    ``free=True``: no frame binding (exactly six rigid-body modes)."""
    rng = np.random.default_rng(seed)
    n_rigid, n_point = int(rng.integers(1, 4)), int(rng.integers(0, 4))
    m = sde.SDEModel()
    rigid = [f"R{i}" for i in range(n_rigid)]
    for name in rigid:
        m.add_rigid_body(name, rng.uniform(1, 50), rng.uniform(-1, 1, 3), random_spd(rng, 3, 0.1, 2.0))
    for i in range(1, n_rigid):  # spanning tree of 6x6 elements between rigid bodies
        j = int(rng.integers(0, i))
        m.add_sde(f"RR{i}", rigid[i], rigid[j], rng.uniform(-1, 1, 3), stiffness=random_spd(rng, 6, 1e6, 1e8))
    for i in range(n_point):
        pos = rng.uniform(-1, 1, 3)
        m.add_point_mass(f"P{i}", rng.uniform(1, 20), pos)
        m.add_sde(f"PR{i}", f"P{i}", rigid[int(rng.integers(0, n_rigid))], pos,
                  stiffness=random_spd(rng, 3, 1e6, 1e8))
    if not free:
        m.add_sde("ground", rigid[0], sde.FRAME, rng.uniform(-1, 1, 3), stiffness=random_spd(rng, 6, 1e6, 1e8))
        if n_point:
            m.add_sde("ground_p", "P0", sde.FRAME, m.body("P0").position[0], k=5e6, axis=rng.standard_normal(3))
    return m, rigid


def rigid_motion(m: sde.SDEModel, u0: np.ndarray, th0: np.ndarray) -> np.ndarray:
    """Generalized coordinates of a small rigid motion of the whole system (translation u0, rotation th0 about O)."""
    q = np.zeros(m.n_dof)
    for b in m.bodies:
        s = m.dof_index(b.name)
        q[s][:3] = u0 + np.cross(th0, b.position[0])
        if b.n_dof == 6:
            q[s][3:] = th0
    return q


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_random_model_symmetric_psd(seed):
    """K is symmetric (round-off) and positive semi-definite for random models (spec §4.5)."""
    m, _ = random_model(seed)
    k = sde.stiffness_matrix(m)[0]
    scale = np.abs(k).max()
    assert np.abs(k - k.T).max() <= 1e-13 * scale  # sums of products: a few ulp of the largest entry
    eig = np.linalg.eigvalsh(k)
    assert eig[0] >= -1e-10 * eig[-1]  # PSD up to eigen-solver round-off (~n eps |K|)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_free_model_has_six_rigid_body_modes(seed):
    """Without frame bindings, rigid motions produce no strain (K q_rigid = 0) and there are exactly six zero
    eigenvalues of K v = λ M v (all bodies connected by full-rank elements)."""
    m, _ = random_model(seed, free=True)
    k = sde.stiffness_matrix(m)[0]
    rng = np.random.default_rng(seed)
    for _ in range(3):
        q = rigid_motion(m, rng.standard_normal(3), rng.standard_normal(3))
        assert np.abs(k @ q).max() <= 1e-11 * np.abs(k).max() * np.abs(q).max()  # cancellation of ~n terms
    lam = sde.modes(m, n_modes=m.n_dof).eigenvalues[0]
    # zero modes: eigvalsh round-off is ~n eps λmax; elastic modes of these models are > 1e-8 λmax
    assert np.all(np.abs(lam[:6]) <= 1e-10 * lam[-1])
    if m.n_dof > 6:
        assert lam[6] > 1e-8 * lam[-1]


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), angle=st.floats(0.1, 3.0))
def test_rotation_invariance(seed, angle):
    """Rotating the whole system (H = diag(Q, Q)) leaves the frequencies unchanged and transforms stiffness and
    compliance at a point as H K Hᵀ, H C Hᵀ (tolerances: condensation of stiffness ratios ≤ 1e2, round-off)."""
    m, rigid = random_model(seed)
    rng = np.random.default_rng(seed + 1)
    rot = rotation_about_axis(rng.standard_normal(3), angle)
    hmat = np.kron(np.eye(2), rot)
    mr = sde.SDEModel()
    for b in m.bodies:
        if b.n_dof == 6:
            mr.add_rigid_body(b.name, b.mass, rot @ b.position[0], rot @ b.inertia[0] @ rot.T)
        else:
            mr.add_point_mass(b.name, b.mass, rot @ b.position[0])
    for s in m.sets:
        kmat = s.stiffness.full()[0, 0]
        h = hmat if s.dim == 6 else rot
        mr.add_sde(s.names[0], s.body_a[0], s.body_b[0], rot @ s.point[0, 0], stiffness=h @ kmat @ h.T)
    point = rng.uniform(-1, 1, 3)
    c0 = sde.point_compliance(m, rigid[0], point)[0]
    c1 = sde.point_compliance(mr, rigid[0], rot @ point)[0]
    np.testing.assert_allclose(c1, hmat @ c0 @ hmat.T, rtol=0, atol=1e-9 * np.abs(c0).max())
    k0 = sde.point_stiffness(m, rigid[0], point)[0]
    k1 = sde.point_stiffness(mr, rigid[0], rot @ point)[0]
    np.testing.assert_allclose(k1, hmat @ k0 @ hmat.T, rtol=0, atol=1e-9 * np.abs(k0).max())
    f0 = sde.natural_frequencies(m, m.n_dof)[0]
    f1 = sde.natural_frequencies(mr, m.n_dof)[0]
    np.testing.assert_allclose(f1, f0, rtol=1e-8)  # eigenvalues to ~1e-12 of λmax; frequencies to 1e-8


def test_skew_and_reference_matrix():
    """N(Δ) q gives u + θ × Δ and θ (spec §4.3, eq. 4.45)."""
    rng = np.random.default_rng(5)
    delta, u, th = rng.standard_normal((3, 3))
    np.testing.assert_allclose(skew(delta) @ u, np.cross(delta, u), rtol=1e-14)
    out = reference_matrix(delta) @ np.concatenate([u, th])
    np.testing.assert_allclose(out[:3], u + np.cross(th, delta), rtol=1e-14)
    np.testing.assert_allclose(out[3:], th, rtol=0)


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda m: m.add_sde("x", "nope", sde.FRAME, [0, 0, 0], k=1.0, axis=[1, 0, 0]), "existing body"),
        (lambda m: m.add_sde("x", "p", sde.FRAME, [0, 0, 0], stiffness=np.eye(6)), "3x3 stiffness"),
        (lambda m: m.add_sde("x", "p", sde.FRAME, [0, 0, 0], stiffness=[[1, 2, 0], [0, 1, 0], [0, 0, 1]]),
         "symmetric"),
        (lambda m: m.add_sde("x", "p", sde.FRAME, [0, 0, 0], stiffness=-np.eye(3)), "semi-definite"),
        (lambda m: m.add_sde("x", "p", sde.FRAME, [0, 0, 0], k=1.0, axis=[0, 0, 0]), "non-zero"),
        (lambda m: m.add_sde("x", "p", sde.FRAME, np.zeros((5, 3)), k=1.0, axis=[1, 0, 0]), "pose axes"),
        (lambda m: m.add_sde("x", "p", sde.FRAME, [0, 0], k=1.0, axis=[1, 0, 0]), "shape"),
        (lambda m: m.add_point_mass("q", -1.0), "mass >= 0"),
        (lambda m: m.add_point_mass("p", 1.0), "new name"),
        (lambda m: m.add_sde("x", "p", sde.FRAME, [0, 0, np.nan], k=1.0, axis=[1, 0, 0]), "finite"),
    ],
)
def test_bad_input_is_reported(call, match):
    m = sde.SDEModel()
    m.add_point_mass("p", np.ones(4), np.zeros((4, 3)))
    with pytest.raises(InputError, match=match):
        call(m)
