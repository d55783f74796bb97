"""The compiled constraint loop and the normal-equation Newton step against their references (issue 14 speed work):
compiled residuals/Jacobians = the numpy block evaluation, Cholesky step = pivoted-QR step where well-conditioned,
and the QR fallback where the Jacobian is (near) singular."""

from __future__ import annotations

import numpy as np
import pytest

import pkmstiff.mechanisms as mm
from pkmstiff.mechanisms.constraints import fk_system, ik_system, model_system
from pkmstiff.mechanisms import kernel, linalg
from pkmstiff.mechanisms.linalg import lstsq_pivoted, lstsq_step
from pkmstiff.mechanisms.model import Mechanism, Output

from tests.test_mechanisms_jacobians import _u, spatial_all_kinds


def _spatial_mechanisms():
    m = spatial_all_kinds()
    axis = Mechanism("ax", "ax", 3, m.links, (0,), m.joints,
                     Output(1, np.array([0.1, 0.2, 0.3]), "axis", _u([0, 1, -2]), (0, 2)))
    return [m, axis] + [mm.load_mechanism(n) for n in ("hybrid_tripod_wrist", "hexapod_6ups", "hexaglide_generic")]


@pytest.mark.parametrize("reduced, omega", [(False, False), (True, False), (True, True)])
def test_compiled_evaluation_equals_numpy_reference(reduced, omega, monkeypatch):
    monkeypatch.setattr(kernel, "PARALLEL_MIN", 64)  # 300 poses = two chunks on the parallel kernel
    rng = np.random.default_rng(11)
    for mech in _spatial_mechanisms():
        for sysm, width in ((fk_system(mech), len(mech.drives)), (ik_system(mech), 6), (model_system(mech), 0)):
            q = rng.uniform(-0.6, 0.6, (300, len(mech.links), 6))
            tg = rng.uniform(-1.0, 1.0, (300, width)) if width else None
            for n in (300, 1):  # parallel and serial kernel
                r1, J1 = sysm.evaluate(q[:n], None if tg is None else tg[:n], reduced=reduced, omega=omega)
                r2, J2 = sysm.evaluate_reference(q[:n], None if tg is None else tg[:n], reduced=reduced,
                                                 omega=omega)
                assert J1.shape == J2.shape
                # same formulas, different summation order: rounding only (entries are O(1))
                assert np.abs(r1 - r2).max() < 1e-13 and np.abs(J1 - J2).max() < 1e-13, mech.name


@pytest.mark.parametrize("parallel", [False, True])
def test_normal_equation_step_equals_pivoted_qr_when_well_conditioned(parallel, monkeypatch):
    if parallel:
        monkeypatch.setattr(linalg, "NORMAL_PARALLEL_MIN", 16)  # 200 poses = two chunks of 128
    mech = mm.load_mechanism("hybrid_tripod_wrist")
    rng = np.random.default_rng(2)
    n = 200
    d = np.column_stack([rng.uniform(-0.1, 0.1, (n, 3)), rng.uniform(-1, 1, n), np.radians(rng.uniform(20, 60, n))])
    sol = mm.forward(mech, d, steps=2)
    sysm = ik_system(mech)
    q = sol.q + rng.normal(0, 1e-3, sol.q.shape)  # a Newton step away from the solution
    r, J = sysm.evaluate(q, sol.poses, reduced=True)
    dx, rank, rcond, qr = lstsq_step(J, r, pattern=sysm.sparsity if parallel else None)
    dq, diag, rk = lstsq_pivoted(J, r)
    assert not qr.any() and (rank == J.shape[2]).all() and (rk == J.shape[2]).all()
    # σ ratio here ~1e-2: the normal equations lose ~cond² ε ~ 1e-12 relative
    assert np.abs(dx - dq).max() < 1e-9 * np.abs(dq).max()
    s = np.linalg.svd(J, compute_uv=False)
    ratio = s[:, -1] / s[:, 0]
    # the estimate is a lower bound through √trace ≥ σ_max and at most a few times off (inverse iteration)
    assert (rcond <= ratio * (1 + 1e-9)).all() and (rcond > 0.05 * ratio).all()


def test_singular_jacobian_takes_the_pivoted_qr_step():
    mech = mm.load_mechanism("hybrid_tripod_wrist")
    fk = mm.forward(mech, [[0.05, -0.02, 0.01, 0.4, 0.0]], steps=4)  # wrist singularity V2 = 0
    sysm = ik_system(mech)
    r, J = sysm.evaluate(fk.q, fk.poses, reduced=True)
    dx, rank, rcond, qr = lstsq_step(J, r + 1e-6)
    assert qr.all() and rank[0] == J.shape[2] - 1  # rank by the QR diagonal's gap, as before
    dq, _, rk = lstsq_pivoted(J, r + 1e-6)
    assert np.array_equal(dx, dq) and rk[0] == rank[0]


def test_compiled_rotation_step_equals_rodrigues_and_link_angles():
    from pkmstiff.mechanisms.constraints import link_angles, link_rotations

    rng = np.random.default_rng(4)
    phi = rng.uniform(-3, 3, (300, 2, 3))
    phi[:100, :, 1] = np.pi / 2  # at the lock
    w = rng.normal(size=(300, 2, 3)) * rng.choice([1e-10, 1e-3, 1.0], (300, 2, 1))
    K = np.zeros(w.shape + (3,))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    K = K - np.swapaxes(K, -1, -2)
    from scipy.linalg import expm

    E = np.array([[expm(K[n, l]) for l in range(2)] for n in range(300)])
    ref = E @ link_rotations(phi, 3)[0]
    got = kernel.rotate(phi, w)
    # same rotation to rounding: entries O(1), |w| up to ~4, scipy's Padé expm and the products carry a few 1e-16
    # each (measured 3e-14); the angles follow link_angles' convention (atan2 of the same entries)
    assert np.abs(link_rotations(got, 3)[0] - ref).max() < 1e-13
    assert np.abs(got - link_angles(ref)).max() < 1e-11


@pytest.mark.parametrize("which", ["fk", "ik"])
def test_fused_newton_equals_the_numpy_loop(which, monkeypatch):
    """The compiled per-pose Newton (pkmstiff.mechanisms.fused) takes the numpy loop's steps: same configurations,
    statuses and step counts, on the parallel and the serial kernel."""
    from pkmstiff.mechanisms import fused, solver

    rng = np.random.default_rng(4)
    monkeypatch.setattr(fused, "PARALLEL_MIN", 64)
    for name in ("hexapod_6ups", "hybrid_tripod_wrist", "hexaglide_generic"):
        mech = mm.load_mechanism(name)
        sysm = fk_system(mech) if which == "fk" else ik_system(mech)
        if which == "fk":
            fk = mm.forward(mech, mm.inverse(mech, mech.home_output_pose[None]).drives)
            tg = fk.drives + rng.uniform(-0.02, 0.02, (200, len(mech.drives)))
        else:
            tg = mech.home_output_pose + np.column_stack([rng.uniform(-0.02, 0.02, (200, 3)),
                                                          rng.uniform(-0.05, 0.05, (200, 3))])
        q0 = np.broadcast_to(solver.home(mech), (200, len(mech.links), 6))
        tol = 1e-13 * mech.length_scale
        for n in (200, 3):
            a = solver.newton(sysm, q0[:n], tg[:n], tol)
            b = solver._newton_loop(sysm, q0[:n].reshape(n, -1), tg[:n], tol, 30, 30)
            assert (a[1] == b[1]).all() and (a[4] == b[4]).all() and (a[6] == b[6]).all(), name
            # the same steps in another summation order: a residual that lands within rounding of the tolerance
            # may need one step more or less (seen: 1 pose in 200), never more
            assert np.abs(a[2] - b[2]).max() <= 1 and (a[2] != b[2]).sum() <= 0.02 * n + 1, name
            # converged configurations agree to the tolerance's scale (1e-13 m) times the conditioning (≲ 1e2)
            assert np.abs(a[0] - b[0]).max() < 1e-10, name


def test_fused_newton_hands_rank_deficient_poses_to_the_qr_loop():
    # the wrist singularity of the hybrid (V2 = 0): the σ-ratio screen fails and the pivoted QR finishes the solve
    mech = mm.load_mechanism("hybrid_tripod_wrist")
    fk = mm.forward(mech, [[0.05, -0.02, 0.01, 0.4, 0.0]], steps=4)
    ik = mm.inverse(mech, fk.poses)
    assert ik.status[0] == "singular" and ik.rank[0] == ik.n_free - 1


def test_elimination_order_puts_hubs_last():
    from pkmstiff.mechanisms.fused import elimination_order, fused_plan

    # a star: links 1…4 each joined to the hub 5 and to the ground 0 (inactive)
    edges = [(0, i) for i in range(1, 5)] + [(i, 5) for i in range(1, 5)]
    active = np.array([False] + [True] * 5)
    assert elimination_order(6, edges, active) == [1, 2, 3, 4, 5]
    # the 6-UPS: the six struts before the platform; each strut row of JᵀJ touches only its own block and the
    # platform's (an arrowhead envelope)
    mech = mm.load_mechanism("hexapod_6ups")
    fp = fused_plan(fk_system(mech))
    assert (fp.cols[-6:] // 6 == mech.link_index("platform")).all()


def test_block_normal_equations_equal_the_skyline_factor():
    """The fused Newton's block-Schur normal equations (linalg._block_normal_pose) give the skyline Cholesky's step
    and σ-ratio estimate (same matrix, column order and start vector) on a block pattern with fill (a cycle of four
    links) and a padded (fixed) coordinate, and break down where the skyline factor does."""
    from pkmstiff.mechanisms.linalg import _block_normal_pose, _normal_pose, block_pattern, block_start, sparsity

    rng = np.random.default_rng(7)
    nb, m = 4, 40
    pairs = [(1, 0), (2, 1), (3, 0), (3, 2)]  # a cycle: eliminating 0 joins 1 and 3 (fill)
    pad = np.zeros((nb, 6))
    pad[2, 4] = 1.0
    rb = np.full((m, 2), -1, dtype=np.int64)
    Jp = np.zeros((m, 6 * nb))
    for i in range(m):
        b = pairs[i % 4] if i % 5 else (i % nb, -1)
        rb[i] = b
        for bl in b:
            if bl >= 0:
                Jp[i, 6 * bl:6 * bl + 6] = rng.normal(size=6) * (rng.random(6) < 0.8)
    Jp[:, pad.reshape(-1) == 1.0] = 0.0
    r = rng.normal(size=m)
    nptr, nidx, slot, ns = block_pattern(nb, [tuple(p) for p in pairs])
    assert slot[3, 1] >= 0  # the fill block
    real = pad.reshape(-1) == 0.0
    Jr = np.ascontiguousarray(Jp[:, real])
    blk = np.flatnonzero(real) // 6  # block of each unpadded column: a row's pattern is its blocks' columns
    cols, cnt = sparsity((rb[:, :1] == blk) | (rb[:, 1:] == blk))
    n = Jr.shape[1]

    def both(J, Jpad):
        A, g, first, x, dx = np.empty((n, n)), np.empty(n), np.empty(n, dtype=np.int64), np.empty(n), np.zeros(n)
        e1 = _normal_pose(J, r, cols, cnt, 2, A, g, first, x, dx)
        Ab, gb, xb, dxb = np.empty((ns, 6, 6)), np.empty(6 * nb), np.empty(6 * nb), np.zeros(6 * nb)
        e2 = _block_normal_pose(Jpad, r, rb, nptr, nidx, slot, pad, block_start(pad), 2, Ab, gb, xb, dxb)
        return e1, dx, e2, dxb

    e1, dx, e2, dxb = both(Jr, Jp)
    # the same factorisation in another summation order: a condition number ≲ 1e3 of JᵀJ loses ≲ 1e-13 relative
    assert e1 > 1e-3 and abs(e2 - e1) < 1e-12 * e1
    assert np.abs(dxb[real] - dx).max() < 1e-12 * np.abs(dx).max() and dxb[~real].max() == 0.0
    # rank deficient: a block column repeated (block 1's first coordinate = its second) → both report breakdown 0
    Jr2, Jp2 = Jr.copy(), Jp.copy()
    Jp2[:, 6] = Jp2[:, 7]
    Jr2[:, 6] = Jr2[:, 7]
    e1, _, e2, _ = both(Jr2, Jp2)
    assert e1 == 0.0 and e2 == 0.0
