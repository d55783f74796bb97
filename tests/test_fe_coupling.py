"""RBE2 coupling, tie constraints, constraint transformation and Guyan condensation (pkmstiff.fe)."""

import math

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from pkmstiff.errors import NumericalError
from pkmstiff.fe import mesh as fm
from pkmstiff.fe.assembly import NodeSet, Part, PartModel, ReferencePoint, Tie
from pkmstiff.fe.coupling import ConstraintSet, guyan, rbe2_rows, stiffness_along
from pkmstiff.fe.materials import CubicCylindrical, Isotropic

STEEL = Isotropic("steel", 210e9, 0.3)
coord = st.floats(-1.0, 1.0)


@settings(max_examples=50, deadline=None)
@given(pts=st.lists(st.tuples(coord, coord, coord), min_size=1, max_size=5), ref=st.tuples(coord, coord, coord),
       q=st.tuples(*([st.floats(-1e-3, 1e-3)] * 6)))
def test_rbe2_rows_are_the_small_rigid_body_motion(pts, ref, q):
    x = np.array(pts, float).T
    C = rbe2_rows(x, np.array(ref))
    q = np.array(q)
    expected = q[:3][None, :] + np.cross(q[3:], (x - np.array(ref)[:, None]).T)
    assert C @ q == pytest.approx(expected, abs=1e-15)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(4, 12), na=st.integers(1, 3))
def test_guyan_equals_inverse_of_the_retained_compliance(seed, n, na):
    rng = np.random.default_rng(seed)
    B = rng.standard_normal((n, n))
    K = B @ B.T + n * np.eye(n)
    ret = np.sort(rng.choice(n, na, replace=False))
    cond = guyan(sp.csr_matrix(K), ret)
    expected = np.linalg.inv(np.linalg.inv(K)[np.ix_(ret, ret)])
    assert cond.K == pytest.approx(expected, rel=1e-9, abs=1e-9 * np.abs(expected).max())
    # recovery: the unloaded DOFs follow the retained ones as in the full solve K u = f (f only at ret)
    f = np.zeros(n)
    f[ret] = rng.standard_normal(na)
    u = np.linalg.solve(K, f)
    assert cond.recovery @ u[ret] == pytest.approx(u, rel=1e-8, abs=1e-12)


def test_constraint_chains_are_resolved_and_cycles_rejected():
    cs = ConstraintSet(5)
    cs.add(np.array([1]), sp.csr_matrix(([0.5, 0.5], ([0, 0], [0, 2])), shape=(1, 5)))  # u1 = (u0 + u2)/2
    cs.add(np.array([2]), sp.csr_matrix(([1.0], ([0], [3])), shape=(1, 5)))  # u2 = u3
    cs.add(np.array([2]), sp.csr_matrix(([1.0], ([0], [4])), shape=(1, 5)))  # ignored: u2 already defined
    cs.fix(np.array([4]))
    T, free = cs.transformation()
    assert free.tolist() == [0, 3]
    assert T.toarray() == pytest.approx(np.array([[1, 0], [0.5, 0.5], [0, 1], [0, 1], [0, 0]]))
    cyc = ConstraintSet(2)
    cyc.add(np.array([0]), sp.csr_matrix(([1.0], ([0], [1])), shape=(1, 2)))
    cyc.add(np.array([1]), sp.csr_matrix(([1.0], ([0], [0])), shape=(1, 2)))
    with pytest.raises(NumericalError, match="cyclic"):
        cyc.transformation()


def bar_model(ref_point, split: bool = False):
    a, L = 0.02, 0.2
    if split:  # two parts with non-matching meshes tied at x = L/2
        parts = [Part("left", fm.box((0, -a / 2, -a / 2), (L / 2, a / 2, a / 2), 1, n=(5, 2, 2)), STEEL),
                 Part("right", fm.box((L / 2, -a / 2, -a / 2), (L, a / 2, a / 2), 1, n=(4, 3, 3)), STEEL)]
        ties, tip_part = [Tie("right", "left", 1e-7)], "right"
    else:
        parts = [Part("bar", fm.box((0, -a / 2, -a / 2), (L, a / 2, a / 2), 1, n=(10, 2, 2)), STEEL)]
        ties, tip_part = [], "bar"
    clamp = NodeSet(parts[0].name, lambda x: x[0] < 1e-9)
    ref = ReferencePoint("tip", tuple(ref_point), NodeSet(tip_part, lambda x: x[0] > L - 1e-9))
    return PartModel(parts, ties, [clamp], [ref]), a, L


def test_reference_point_shift_is_the_rigid_lever_transformation():
    """K at B equals Gamma^T K_A Gamma, u_A = u_B + theta x (x_A - x_B): checks the RBE2 kinematics exactly."""
    mA, _, L = bar_model((0.2, 0.0, 0.0))
    xA, xB = np.array([0.2, 0.0, 0.0]), np.array([0.25, 0.01, -0.03])
    mB, _, _ = bar_model(tuple(xB))
    KA, KB = mA.condense().K, mB.condense().K
    d = xA - xB
    Gam = np.eye(6)
    Gam[:3, 3:] = -np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])
    # same FE system, only the coupling point moves: equal up to solver round-off
    assert KB == pytest.approx(Gam.T @ KA @ Gam, rel=1e-7, abs=1e-7 * np.abs(KB).max())


def test_tie_of_non_matching_meshes_transmits_axial_and_bending_load():
    one, _, _ = bar_model((0.2, 0, 0))
    two, _, _ = bar_model((0.2, 0, 0), split=True)
    C1, C2 = np.linalg.inv(one.condense().K), np.linalg.inv(two.condense().K)
    # non-matching interface: the tie is slightly weaker/stiffer locally; 1 % on the whole bar
    for i in (0, 1, 2, 3):
        assert C2[i, i] == pytest.approx(C1[i, i], rel=0.01)


def shaft_in_ring(angle: float) -> float:
    """Axial stiffness of a shaft bonded into a bearing ring whose outside is clamped; shaft turned by angle."""
    r_in, r_out, w = 0.015, 0.022, 0.014
    ring_mat = CubicCylindrical("ring", 7.7e9, 3.2e9, 0.1, axis_dir=(0, 0, 1))
    parts = [Part("ring", fm.tube((0, 0, 0), (0, 0, w), r_in, r_out, 0.007, n_phi=16, n_rad=1), ring_mat),
             Part("shaft", fm.cylinder((0, 0, -0.01), (0, 0, w + 0.01), r_in, 0.008, n_phi=16), STEEL, group="shaft")]
    sag = 1.5 * r_in * (1 - math.cos(math.pi / 16)) + 5e-5
    model = PartModel(parts, [Tie("ring", "shaft", sag)],
                      clamps=[NodeSet("ring", lambda x: np.hypot(x[0], x[1]) > r_out * math.cos(math.pi / 16) - 1e-9)],
                      references=[ReferencePoint("end", (0, 0, w + 0.01),
                                                 NodeSet("shaft", lambda x: x[2] > w + 0.01 - 1e-9))])
    sol = model.condense({"shaft": (fm.rotation((0, 0, 1), angle), np.zeros(3))})
    return stiffness_along(sol.K, np.array([0, 0, 1.0]))


def test_tie_to_a_rotated_part_is_rotation_invariant_for_an_axisymmetric_joint():
    k0 = shaft_in_ring(0.0)
    # rotated by a fraction of a segment (non-matching nodes): the polygonal sag changes the contact by
    # < 1 % (sag/thickness ~ 0.4 %); a whole segment (22.5 deg) restores matching nodes exactly
    assert shaft_in_ring(math.radians(7.0)) == pytest.approx(k0, rel=0.01)
    assert shaft_in_ring(math.radians(22.5)) == pytest.approx(k0, rel=1e-8)
    # long-ring limit (plane sections, axial shear of an annulus): 2 pi G w / ln(r_out / r_in); the short
    # ring with free ends is softer (end faces warp), within 40 %
    k_shear = 2 * math.pi * 3.2e9 * 0.014 / math.log(0.022 / 0.015)
    print(f"shaft in ring: {k0 / 1e6:.1f} N/um, annulus-shear limit {k_shear / 1e6:.1f} N/um")
    assert 0.6 * k_shear < k0 < k_shear


def test_unconnected_part_and_missing_contact_are_reported():
    a = 0.02
    parts = [Part("bar", fm.box((0, 0, 0), (a, a, a), 1, n=(1, 1, 1)), STEEL),
             Part("loose", fm.box((2 * a, 0, 0), (3 * a, a, a), 1, n=(1, 1, 1)), STEEL)]
    model = PartModel(parts, [Tie("loose", "bar", 1e-6)], [NodeSet("bar", lambda x: x[0] < 1e-9)],
                      [ReferencePoint("r", (a, a / 2, a / 2), NodeSet("bar", lambda x: x[0] > a - 1e-9))])
    with pytest.raises(NumericalError, match="no node of 'loose' lies within"):
        model.condense()
    with pytest.raises(NumericalError, match="loose not connected"):
        PartModel(parts, [], [NodeSet("bar", lambda x: x[0] < 1e-9)],
                  [ReferencePoint("r", (a, a / 2, a / 2), NodeSet("bar", lambda x: x[0] > a - 1e-9))])
    # supported at a single node only: rotations about it are free -> zero pivot
    with pytest.raises(NumericalError, match="singular"):
        PartModel(parts[:1], [], [NodeSet("bar", lambda x: np.linalg.norm(x, axis=0) < 1e-9)],
                  [ReferencePoint("r", (a, a / 2, a / 2), NodeSet("bar", lambda x: x[0] > a - 1e-9))]).condense()
