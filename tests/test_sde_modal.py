"""Modal analysis of the SDE model (spec models.md §4.6, §5.2): analytic frequencies, Guyan, bindings, shares."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

import pkmstiff.multibody as sde
from pkmstiff.errors import InputError


def chain(n_mass: int, k: float, m: float, k_t: float) -> sde.SDEModel:
    """Fixed–fixed chain of equal point masses along x; springs diag(k, k_t, k_t) (y/z chains are stiffer)."""
    model = sde.SDEModel()
    names = [sde.FRAME] + [f"m{i}" for i in range(n_mass)] + [sde.FRAME]
    for i in range(n_mass):
        model.add_point_mass(f"m{i}", m, [i + 1.0, 0, 0])
    for i in range(n_mass + 1):
        model.add_sde(f"k{i}", names[i + 1] if i < n_mass else names[i], names[i] if i < n_mass else names[i + 1],
                      [i + 0.5, 0, 0], stiffness=np.diag([k, k_t, k_t]))
    return model


def test_three_mass_chain_analytic():
    """ω_j = 2 √(k/m) sin(jπ / (2(n+1))) for a fixed–fixed chain; mode shapes ∝ sin(j b π/(n+1)) give the
    kinetic-energy shares sin² / Σ sin² and the strain shares of the springs (differences of neighbours)."""
    k, m = 2e6, 3.0
    model = chain(3, k, m, 100 * k)
    res = sde.modes(model, 3, shapes=True)
    j = np.arange(1, 4)
    ref = 2 * np.sqrt(k / m) * np.sin(j * np.pi / 8) / (2 * np.pi)
    np.testing.assert_allclose(res.frequencies_hz[0], ref, rtol=1e-12)  # eigvalsh: ~1e-15 λmax, λ within 1e-4 λmax
    shape = np.sin(np.outer(j, np.arange(1, 4)) * np.pi / 4)  # (mode, mass)
    np.testing.assert_allclose(sde.kinetic_energy_shares(model, res.shapes)[0],
                               shape**2 / (shape**2).sum(axis=1, keepdims=True), atol=1e-12)
    ext = np.pad(shape, ((0, 0), (1, 1)))
    strain = np.diff(ext, axis=1) ** 2
    labels, shares = sde.strain_energy_shares(model, res.shapes)
    assert labels == ["k0", "k1", "k2", "k3"]
    np.testing.assert_allclose(shares[0], strain / strain.sum(axis=1, keepdims=True), atol=1e-12)
    # mass normalisation vᵀ M v = 1 and element energies sum to ½ λ
    mm = sde.mass_matrix(model)[0]
    np.testing.assert_allclose(np.einsum("ki,ij,kj->k", res.shapes[0], mm, res.shapes[0]), 1.0, rtol=1e-13)
    np.testing.assert_allclose(sde.element_energies(model, res.shapes)[0].sum(axis=1), 0.5 * res.eigenvalues[0],
                               rtol=1e-12)


def test_cubic_hexapod_frequencies_closed_form():
    """Rigid body with isotropic inertia J on six edge struts of a cube (side a, stiffness k): translational
    ω² = 2k/m (triple), rotational ω² = k a² μ / J with μ ∈ {½, ½, 2} (eigenvalues of the hand-derived K_rr)."""
    from tests.test_sde_static import cubic_hexapod

    a, k, mass, inertia = 0.4, 2e8, 50.0, 0.9
    m = cubic_hexapod(a, k, mass, inertia)
    res = sde.modes(m, 6, shapes=True)
    ref = np.sort(np.concatenate([np.full(3, 2 * k / mass), k * a**2 * np.array([0.5, 0.5, 2.0]) / inertia]))
    np.testing.assert_allclose(res.eigenvalues[0], ref, rtol=1e-12)
    # the highest mode rotates about the body diagonal: the rotational shares are 1/3 each
    shares = sde.motion_shares(m, res.shapes, "B")[0]
    assert ref[-1] == 2 * k * a**2 / inertia
    np.testing.assert_allclose(shares[-1], [0, 0, 0, 1 / 3, 1 / 3, 1 / 3], atol=1e-10)
    assert np.all(ref[:3] == 2 * k / mass)  # with these numbers the three translational modes come first
    np.testing.assert_allclose(shares[:3, :3].sum(axis=1), 1.0, atol=1e-10)  # ... and involve no rotation


def test_describe_modes_labels():
    """A body on springs whose lowest mode is a rotation about x, then a translation along y."""
    m = sde.SDEModel()
    m.add_rigid_body("B", 10.0, [0, 0, 0], [1.0, 1.0, 1.0])
    kdiag = np.diag([9e6, 4e6, 9e6, 1e5, 9e6, 9e6])  # rx: ω² = 1e5; y: ω² = 4e5; others ≥ 9e5
    m.add_sde("G", "B", sde.FRAME, [0, 0, 0], stiffness=kdiag)
    res = sde.modes(m, 2, shapes=True)
    idx, share = sde.describe_modes(m, res.shapes, "B")
    assert [sde.mode_label(i, s) for i, s in zip(idx[0], share[0])] == ["rotation about x (100 %)",
                                                                        "translation along y (100 %)"]


def test_massless_bodies_are_condensed():
    """Guyan condensation (spec §4.6): frame –k1– massless point –k2– mass m gives ω² = k1k2/(k1+k2)/m; a massless
    rigid body in the chain (mass and inertia 0) acts the same way; shapes are recovered on all DOFs."""
    k1, k2, mass = 3e6, 6e6, 2.0
    ref = k1 * k2 / (k1 + k2) / mass
    m = sde.SDEModel()
    m.add_point_mass("mid", 0.0, [0, 0, 0])
    m.add_point_mass("end", mass, [0, 0, 0])
    m.add_sde("s1", "mid", sde.FRAME, [0, 0, 0], stiffness=k1 * np.eye(3))
    m.add_sde("s2", "end", "mid", [0, 0, 0], stiffness=k2 * np.eye(3))
    res = sde.modes(m, 3, shapes=True)
    np.testing.assert_allclose(res.eigenvalues[0], ref, rtol=1e-13)
    np.testing.assert_allclose(res.shapes[0][:, :3], res.shapes[0][:, 3:] * k2 / (k1 + k2), atol=1e-14)
    with pytest.raises(InputError, match="n_modes"):
        sde.modes(m, 4)  # only three dynamic DOFs
    r = sde.SDEModel()
    r.add_rigid_body("lever", 0.0, [0, 0, 0], np.zeros((3, 3)))
    r.add_point_mass("end", mass, [0, 0, 0])
    r.add_sde("s1", "lever", sde.FRAME, [0, 0, 0], stiffness=np.diag([k1, k1, k1, 1e4, 1e4, 1e4]))
    r.add_sde("s2", "end", "lever", [0, 0, 0], stiffness=k2 * np.eye(3))
    np.testing.assert_allclose(sde.modes(r, 3).eigenvalues[0], ref, rtol=1e-13)


def test_biglide_modes_null_space_reference_and_penalty_limit():
    """Rigid struts eliminated by the model's null-space basis equal an independent reference
    (scipy null_space of the hand-written constraint rows, eigh(ZᵀKZ, ZᵀMZ)) and the stiff-SDE limit."""
    from tests.test_sde_static import biglide

    m, n, ka = biglide(rigid=True)
    res = sde.modes(m, 7, shapes=True)
    # hand-built 9-DOF reference: P (0:3), A0 (3:6), A1 (6:9)
    kmat = np.zeros((9, 9))
    kmat[2, 2] = 3e7
    kmat[3:6, 3:6], kmat[6:9, 6:9] = ka
    mmat = np.diag([8.0] * 3 + [15.0] * 3 + [20.0] * 3)
    phi = np.zeros((2, 9))
    for i in range(2):
        phi[i, 0:3], phi[i, 3 + 3 * i:6 + 3 * i] = n[i], -n[i]
    z = scipy.linalg.null_space(phi)
    lam_ref = scipy.linalg.eigh(z.T @ kmat @ z, z.T @ mmat @ z, eigvals_only=True)
    np.testing.assert_allclose(res.eigenvalues[0], lam_ref, rtol=1e-11)
    # constraints hold in the recovered shapes and the shapes are mass-normalised
    q = res.shapes[0]
    for i in range(2):
        np.testing.assert_allclose((q[:, 0:3] - q[:, 3 + 3 * i:6 + 3 * i]) @ n[i], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("ki,ij,kj->k", q, mmat, q), 1.0, rtol=1e-12)
    # penalty limit: stiff struts (1e4 x the largest stiffness) add two spurious high modes; the others
    # converge with a relative error of order k_A / k_V = 1e-4
    mp, _, _ = biglide(rigid=False, k_v=1e4 * 9e7)
    lam_pen = sde.modes(mp, 9).eigenvalues[0]
    np.testing.assert_allclose(lam_pen[:7], lam_ref, rtol=3e-4)
    assert lam_pen[7] > 1e3 * lam_ref[-1]


def test_massless_body_with_rigid_bindings():
    """Massless platform held only by rigid struts (general path: null space, then Guyan on the massless
    directions of ZᵀMZ) agrees with the stiff-strut model (fast path, Guyan on the massless DOFs)."""
    from tests.test_sde_static import biglide

    def massless_platform(model: sde.SDEModel) -> sde.SDEModel:
        out = sde.SDEModel()
        for b in model.bodies:
            out.add_point_mass(b.name, 0.0 if b.name == "P" else b.mass, b.position)
        for s in model.sets:
            for e, name in enumerate(s.names):
                kw = dict(k=s.stiffness.k[0, e], axis=s.stiffness.axis[0, e]) if s.stiffness.matrix is None else \
                    dict(stiffness=s.stiffness.matrix[0, e])
                out.add_sde(name, s.body_a[e], s.body_b[e], s.point[0, e], **kw)
        for bd in model.bindings:
            out.add_rigid_binding(bd.name, bd.body_a, bd.body_b, bd.point[0], kind=bd.kind, axis=bd.axis[0])
        return out

    rigid = massless_platform(biglide(rigid=True)[0])
    stiff = massless_platform(biglide(rigid=False, k_v=1e4 * 9e7)[0])
    res = sde.modes(rigid, 6, shapes=True)  # 9 DOF - 2 constraints - 1 massless direction (z of P)
    lam_stiff = sde.modes(stiff, 6).eigenvalues[0]
    np.testing.assert_allclose(res.eigenvalues[0], lam_stiff, rtol=3e-4)  # penalty error ~ k_A / k_V = 1e-4
    mm = sde.mass_matrix(rigid)[0]
    np.testing.assert_allclose(np.einsum("ki,ij,kj->k", res.shapes[0], mm, res.shapes[0]), 1.0, rtol=1e-12)
    np.testing.assert_allclose(sde.element_energies(rigid, res.shapes)[0].sum(axis=1), 0.5 * res.eigenvalues[0],
                               rtol=1e-10)


def test_free_body_with_point_load_modes_and_pose_batch():
    """Per-pose frequencies of a batch equal single-pose results; chunking does not change them."""
    rng = np.random.default_rng(2)
    n = 5
    m = sde.SDEModel()
    m.add_rigid_body("B", 10.0, rng.uniform(-1, 1, (n, 3)), [1.0, 2.0, 3.0])
    m.add_point_mass("A", 3.0, [0.5, 0.5, 0.5])
    kk = np.diag([1e7, 2e7, 3e7, 1e6, 2e6, 3e6])
    m.add_sde("G", "B", sde.FRAME, rng.uniform(-1, 1, (n, 3)), stiffness=kk)
    m.add_sde("W", "A", "B", [0.5, 0.5, 0.5], k=rng.uniform(1e6, 1e7, n), axis=[1, 1, 0], c=10.0)
    m.add_sde("W2", "A", sde.FRAME, [0.5, 0.5, 0.5], stiffness=1e6 * np.eye(3))
    all_f = sde.natural_frequencies(m, 9, chunk_size=2)
    for i in range(n):
        one = sde.natural_frequencies(m.poses(slice(i, i + 1)), 9)
        np.testing.assert_allclose(all_f[i], one[0], rtol=1e-13)
    ev = sde.evaluate_point(m, "B", None, n_modes=4, chunk_size=3)
    np.testing.assert_allclose(ev.frequencies_hz, all_f[:, :4], rtol=1e-13)
    np.testing.assert_allclose(ev.compliance, sde.point_compliance(m, "B"), rtol=1e-13)


def test_mode_axes_recover_a_known_screw():
    """Chasles: shapes built as a rotation θ about an axis through p plus the translation hθ along it give back the
    axis direction, the point of the axis nearest the CoG, the pitch h and the lever |u|/|θ| (round-off only)."""
    rng = np.random.default_rng(7)
    r0 = np.array([0.1, 0.2, -1.0])
    m = sde.SDEModel()
    m.add_rigid_body("B", 10.0, r0, [1.0, 2.0, 3.0])
    n = rng.normal(size=(4, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    p = rng.normal(size=(4, 3))
    p -= np.einsum("ki,ki->k", p - r0, n)[:, None] * n  # the point of each axis nearest r0
    h = rng.normal(size=4) * 0.1
    th = n * 1e-3
    u = np.cross(th, r0 - p) + h[:, None] * th
    axes = sde.mode_axes(m, np.concatenate([u, th], axis=1)[None], "B")
    np.testing.assert_allclose(axes.direction[0], n, atol=1e-12)
    np.testing.assert_allclose(axes.point[0], p, atol=1e-12)
    np.testing.assert_allclose(axes.pitch[0], h, atol=1e-12)
    np.testing.assert_allclose(axes.lever[0], np.linalg.norm(u, axis=1) / 1e-3, rtol=1e-12)


def test_mode_axes_of_a_pendulum_pass_through_its_pivot():
    """A body held at a pivot c by stiff translational springs (1e12 N/m) and a soft torsion spring about x
    (1e3 N m/rad): its lowest mode is a rotation about the x-axis through c (axis off c by ~ k_rot/k_trans · |c − r0|
    ≈ 1e-9 m; 1e-6 m tolerance)."""
    r0, c = np.array([0.0, 0.4, -1.0]), np.array([0.0, 0.3, -1.7])
    m = sde.SDEModel()
    m.add_rigid_body("B", 117.0, r0, [7.4, 7.7, 2.9])
    m.add_sde("G", "B", sde.FRAME, c, stiffness=np.diag([1e12, 1e12, 1e12, 1e3, 1e9, 1e9]))
    res = sde.modes(m, 1, shapes=True)
    axes = sde.mode_axes(m, res.shapes, "B")
    np.testing.assert_allclose(np.abs(axes.direction[0, 0]), [1.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(axes.point[0, 0], c, atol=1e-6)
    assert abs(axes.pitch[0, 0]) < 1e-9
    # ω² = k_rot / (I_xx + m |c − r0|²) (parallel axes)
    d2 = float(np.sum((c - r0)[1:] ** 2))
    assert res.frequencies_hz[0, 0] == pytest.approx(np.sqrt(1e3 / (7.4 + 117.0 * d2)) / (2 * np.pi), rel=1e-6)


def test_massless_bound_rotations_are_condensed_once_closed_form():
    """A rigid body with mass m and no inertia, rx and ry bound to the frame (massless *and* constrained), rz free
    but massless: two x springs k1, k2 at y = ±a couple u_x and θ_z; y and z springs at the origin.  Condensing θ_z
    by hand: K = [[k1 + k2, a(k2 − k1)], [a(k2 − k1), a²(k1 + k2)]] → k_x = 4 k1 k2 / (k1 + k2).  Three modes,
    ω² = k_x/m, k_y/m, k_z/m (before, n_dof − n_constraints − massless counted the bound massless rotations twice:
    1 mode, and 0 for the bipod's held platform rotation)."""
    m, a, k1, k2, ky, kz = 4.0, 0.3, 2e6, 5e6, 1e6, 3e6
    model = sde.SDEModel()
    model.add_rigid_body("b", m, np.zeros(3), np.zeros(3))
    model.add_sde("s1", "b", sde.FRAME, [0.0, a, 0.0], k=k1, axis=[1.0, 0.0, 0.0])
    model.add_sde("s2", "b", sde.FRAME, [0.0, -a, 0.0], k=k2, axis=[1.0, 0.0, 0.0])
    model.add_sde("sy", "b", sde.FRAME, np.zeros(3), k=ky, axis=[0.0, 1.0, 0.0])
    model.add_sde("sz", "b", sde.FRAME, np.zeros(3), k=kz, axis=[0.0, 0.0, 1.0])
    model.add_rigid_binding("rx", "b", sde.FRAME, np.zeros(3), kind="angular", axis=[1.0, 0.0, 0.0])
    model.add_rigid_binding("ry", "b", sde.FRAME, np.zeros(3), kind="angular", axis=[0.0, 1.0, 0.0])
    assert sde.dynamic_dofs(model) == 3
    want = np.sort(np.sqrt(np.array([4 * k1 * k2 / (k1 + k2), ky, kz]) / m)) / (2 * np.pi)
    # eigvalsh of a 3 × 3 problem after a null-space projection and a Guyan solve: rounding ~1e-15 relative
    np.testing.assert_allclose(sde.natural_frequencies(model, 3)[0], want, rtol=1e-12)
    with pytest.raises(InputError):
        sde.natural_frequencies(model, 4)  # no fourth mode
