"""Vectorised stiffness assembly (pkmstiff.fe.elasticity) against scikit-fem's own forms and invariants."""

import math

import numpy as np
import pytest
from skfem import Basis, BilinearForm, ElementVector, asm
from skfem.helpers import sym_grad
from skfem.models.elasticity import linear_elasticity

from pkmstiff.errors import ArgumentError
from pkmstiff.fe import mesh as fm
from pkmstiff.fe.elasticity import ELEMENTS, rotate_stiffness, scalar_basis, stiffness_matrix
from pkmstiff.fe.materials import CubicCylindrical, Isotropic

STEEL = Isotropic("steel", 210e9, 0.3)
RING = CubicCylindrical("ring", 7.7e9, 3.2e9, 0.1, axis_point=(0.0, 0.0, 0.0), axis_dir=(0.0, 0.0, 1.0))


def distorted_box():
    m = fm.box((0, 0, 0), (0.04, 0.03, 0.05), 0.015)
    p = m.p.copy()
    p[0] += 0.003 * np.sin(40 * p[1]) * p[2] / 0.05  # non-affine elements
    return type(m)(p, m.t)


def vector_permutation(scalar_basis_, vector_basis):
    """Map our DOF order (3 * node + component) to scikit-fem's ElementVector DOF order."""
    perm = np.empty(3 * scalar_basis_.N, dtype=int)
    sd, vd = scalar_basis_.element_dofs, vector_basis.element_dofs
    for a in range(sd.shape[0]):
        for i in range(3):
            perm[3 * sd[a] + i] = vd[3 * a + i]
    return perm


@pytest.mark.parametrize("element", ["hex8", "hex20", "hex27"])
def test_isotropic_kernel_equals_scikit_fem_linear_elasticity(element):
    m = distorted_box()
    b = scalar_basis(m, element)
    K = stiffness_matrix(b, STEEL)
    cls, order = ELEMENTS[element]
    vb = Basis(m, ElementVector(cls()), intorder=order)
    K_ref = asm(linear_elasticity(*STEEL.lame()), vb)
    perm = vector_permutation(b, vb)
    # same quadrature, same algebra: equal to round-off (1e-12 of the largest entry)
    assert abs(K - K_ref[perm][:, perm]).max() <= 1e-12 * abs(K).max()


def test_cubic_cylindrical_kernel_equals_full_rotated_tensor():
    m = fm.tube((0, 0, 0), (0, 0, 0.012), 0.021, 0.028, 0.004, n_phi=8, n_rad=1)
    b = scalar_basis(m, "hex20")
    K = stiffness_matrix(b, RING)
    c11, c12, c44 = RING.cubic_constants()
    C_loc = np.zeros((3, 3, 3, 3))
    for i in range(3):
        for j in range(3):
            C_loc[i, i, j, j] = c12
            C_loc[i, j, i, j] += c44
            C_loc[i, j, j, i] += c44
        C_loc[i, i, i, i] = c11

    vb = Basis(m, ElementVector(ELEMENTS["hex20"][0]()), intorder=4)
    e = RING.local_axes(vb.global_coordinates().value)  # (a, comp, el, qp)
    # C_ijkl = e_ai e_bj e_ck e_dl C_abcd (local -> global), evaluated once at every Gauss point
    C = np.einsum("aiEQ,bjEQ,abcd->ijcdEQ", e, e, C_loc)
    C = np.einsum("ckEQ,dlEQ,ijcdEQ->ijklEQ", e, e, C)

    @BilinearForm
    def form(u, v, w):
        return np.einsum("ijklEQ,klEQ,ijEQ->EQ", C, sym_grad(u), sym_grad(v))

    K_ref = asm(form, vb)
    perm = vector_permutation(b, vb)
    assert abs(K - K_ref[perm][:, perm]).max() <= 1e-10 * abs(K).max()


def test_cubic_law_reduces_to_isotropic_when_G_is_consistent():
    E, nu = 7.7e9, 0.1
    iso = Isotropic("iso", E, nu)
    cub = CubicCylindrical("cub", E, E / (2 * (1 + nu)), nu)
    lam, mu, delta = cub.decomposition()
    assert (lam, mu) == pytest.approx(iso.lame(), rel=1e-12)
    assert abs(delta) < 1e-6 * E
    # the spec's G = 3.2 GPa differs from E/(2(1+nu)) = 3.5 GPa: a genuinely anisotropic law
    assert RING.decomposition()[2] == pytest.approx(0.6e9, rel=1e-9)


def test_compliance_of_the_ring_law_honours_E_G_nu():
    c11, c12, c44 = RING.cubic_constants()
    C = np.zeros((6, 6))
    C[:3, :3] = c12
    C[np.arange(3), np.arange(3)] = c11
    C[3:, 3:] = np.diag([c44] * 3)
    S = np.linalg.inv(C)
    assert 1 / S[0, 0] == pytest.approx(7.7e9, rel=1e-12)
    assert -S[0, 1] / S[0, 0] == pytest.approx(0.1, rel=1e-12)
    assert 1 / S[3, 3] == pytest.approx(3.2e9, rel=1e-12)


@pytest.mark.parametrize("material", [STEEL, RING])
def test_rigid_body_modes_carry_no_energy(material):
    m = fm.tube((0, 0, 0.01), (0, 0, 0.03), 0.02, 0.03, 0.006, n_phi=12, n_rad=1)
    b = scalar_basis(m, "hex20")
    K = stiffness_matrix(b, material)
    x = b.doflocs
    modes = []
    for k in range(3):
        u = np.zeros((b.N, 3))
        u[:, k] = 1
        modes.append(u.ravel())
    for w in np.eye(3):
        modes.append(np.cross(w, x.T).ravel())
    for u in modes:
        # ||K u|| relative to ||K|| ||u||: round-off level
        assert np.linalg.norm(K @ u) <= 1e-10 * abs(K).max() * np.linalg.norm(u) * 10
    # symmetric positive semi-definite: u^T K u >= 0 for random u
    rng = np.random.default_rng(0)
    for _ in range(5):
        u = rng.standard_normal(K.shape[0])
        assert u @ (K @ u) > 0
    assert abs(K - K.T).max() <= 1e-12 * abs(K).max()


@pytest.mark.parametrize("material", [STEEL, RING])
def test_rotated_part_equals_reassembly_of_the_rotated_mesh(material):
    """Q K Q^T (used for the strut-side group) equals assembling the rotated mesh (ring axis rotated too)."""
    m = fm.tube((0, 0, 0), (0, 0.02, 0), 0.015, 0.022, 0.007, n_phi=8, n_rad=1)
    mat = material.with_axis((0, 0, 0), (0, 1, 0)) if isinstance(material, CubicCylindrical) else material
    R = fm.rotation((0.3, -0.5, 0.8), math.radians(37))
    K_rot = rotate_stiffness(stiffness_matrix(scalar_basis(m, "hex20"), mat), R)
    m2 = fm.transformed(m, R)
    mat2 = mat.with_axis((0, 0, 0), R @ np.array([0, 1.0, 0])) if isinstance(mat, CubicCylindrical) else mat
    K2 = stiffness_matrix(scalar_basis(m2, "hex20"), mat2)
    assert abs(K_rot - K2).max() <= 1e-9 * abs(K2).max()


def test_invalid_material_constants_are_rejected():
    with pytest.raises(ArgumentError, match="nu"):
        Isotropic("x", 1e9, 0.5)
    with pytest.raises(ArgumentError, match="G must be a positive"):
        CubicCylindrical("x", 1e9, -1.0, 0.1)
