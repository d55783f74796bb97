"""Analytic constraint Jacobians of every elementary constraint, drive and output equation vs central differences."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pkmstiff.mechanisms.constraints import (System, drive_blocks, link_angles, link_rotations, model_blocks,
                                             output_blocks)
from pkmstiff.mechanisms.model import Drive, Joint, Mechanism, Output


def _u(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def spatial_all_kinds() -> Mechanism:
    """Every spatial joint type between three links (not a sensible machine: only the equations matter here)."""
    p = lambda *v: np.array(v, dtype=float)  # noqa: E731
    J = [
        Joint("sph", "spherical", (0, 1), p(0.1, 0.2, 0.3)),
        Joint("rev", "revolute", (1, 2), p(-0.2, 0.1, 0.4), _u([1, 2, 3]), drive=Drive("th", 0.3)),
        Joint("car", "cardan", (0, 2), p(0.3, -0.1, 0.2), _u([1, 0, 0]), _u([0, 1, 1])),
        Joint("cyl", "cylindrical", (1, 2), p(0.05, 0.3, -0.2), _u([0, 1, 0]), drive=Drive("s", 0.7)),
        Joint("pri", "prismatic", (2, 1), p(0.4, 0.4, 0.1), _u([1, 1, 0])),
        Joint("pla", "planar", (0, 1), p(-0.3, 0.2, 0.1), _u([0, 0, 1])),
        Joint("poa", "point_on_axis", (2, 0), p(0.2, -0.3, 0.5), _u([1, -1, 2]), drive=Drive("u", -0.1)),
        Joint("eo", "equal_orientation", (1, 0), p(0, 0, 0)),
        Joint("fix", "fixed", (1, 1), p(0, 0, 0), coordinates=(0, 4), values=(0.1, -0.2)),
    ]
    return Mechanism("all", "all", 3, ("g", "a", "b"), (0,), tuple(J),
                     Output(2, p(0.1, 0.1, 0.6), "full", None, (0, 1, 2)))


def planar_all_kinds() -> Mechanism:
    p = lambda *v: np.array(v, dtype=float)  # noqa: E731
    J = [
        Joint("rev", "revolute", (0, 1), p(0.1, 0.2), drive=Drive("th", 0.2)),
        Joint("pri", "prismatic", (1, 2), p(-0.2, 0.3), _u([1, 2]), drive=Drive("s", 0.05)),
        Joint("slot", "slot", (2, 0), p(0.3, -0.1), _u([1, -1])),
        Joint("eo", "equal_orientation", (0, 2), p(0, 0)),
    ]
    return Mechanism("pl", "pl", 2, ("g", "a", "b"), (0,), tuple(J), Output(1, p(0.2, 0.1), "full", None, (0, 1)))


def _check(mech: Mechanism, blocks, q: np.ndarray, target: np.ndarray) -> float:
    sysm = System(mech, blocks)
    _, J = sysm.evaluate(q[None], target[None])
    h = 1e-6
    Jfd = np.empty_like(J[0])
    qf = q.reshape(-1)
    for c in range(qf.size):
        e = np.zeros_like(qf)
        e[c] = h
        rp, _ = sysm.evaluate((qf + e).reshape(1, *q.shape), target[None], jac=False)
        rm, _ = sysm.evaluate((qf - e).reshape(1, *q.shape), target[None], jac=False)
        Jfd[:, c] = (rp[0] - rm[0]) / (2 * h)
    return float(np.abs(J[0] - Jfd).max() / max(1.0, np.abs(J[0]).max()))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_spatial_jacobians_match_central_differences(seed):
    mech = spatial_all_kinds()
    rng = np.random.default_rng(seed)
    q = rng.uniform(-0.5, 0.5, (3, 6))
    q[:, 3:] = rng.uniform(-1.2, 1.2, (3, 3))  # angles well inside |φy| < 90°
    pose = np.concatenate([rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)])
    drives = rng.uniform(-1, 1, 3)
    # central differences with h = 1e-6: truncation O(h²·|F'''|) ~ 1e-12, rounding ~ 1e-16/h ~ 1e-10: 1e-7 is ample
    assert _check(mech, model_blocks(mech) + drive_blocks(mech), q, drives) < 1e-7
    assert _check(mech, output_blocks(mech), q, pose) < 1e-7
    axis_out = Mechanism("ax", "ax", 3, mech.links, (0,), mech.joints,
                         Output(1, np.array([0.1, 0.2, 0.3]), "axis", _u([0, 1, -2]), (0, 2)))
    assert _check(axis_out, output_blocks(axis_out), q, pose) < 1e-7


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_planar_jacobians_match_central_differences(seed):
    mech = planar_all_kinds()
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1.0, 1.0, (3, 3))
    assert _check(mech, model_blocks(mech) + drive_blocks(mech) + output_blocks(mech), q,
                  rng.uniform(-1, 1, 3)) < 1e-7  # same error budget as the spatial case


def test_link_rotation_is_rz_ry_rx_and_angles_invert_it():
    rng = np.random.default_rng(3)
    phi = rng.uniform(-1.4, 1.4, (50, 3))
    R, dR = link_rotations(phi, 3)
    c, s = np.cos, np.sin
    for k in range(5):
        x, y, z = phi[k]
        Rx = np.array([[1, 0, 0], [0, c(x), -s(x)], [0, s(x), c(x)]])
        Ry = np.array([[c(y), 0, s(y)], [0, 1, 0], [-s(y), 0, c(y)]])
        Rz = np.array([[c(z), -s(z), 0], [s(z), c(z), 0], [0, 0, 1]])
        assert np.allclose(R[k], Rz @ Ry @ Rx, atol=1e-15, rtol=0)  # eq. 2, exact up to rounding
    assert np.allclose(link_angles(R), phi, atol=1e-12, rtol=0)  # |φy| < 90°: unique inverse
    h = 1e-6
    for c_ in range(3):
        e = np.zeros(3)
        e[c_] = h
        fd = (link_rotations(phi + e, 3)[0] - link_rotations(phi - e, 3)[0]) / (2 * h)
        assert np.abs(fd - dR[:, c_]).max() < 1e-9  # central difference error O(h²) ~ 1e-12


@pytest.mark.parametrize("name", ["slider_crank", "five_bar", "hybrid_tripod_wrist", "hexaglide_generic"])
def test_bundled_system_jacobians(name):
    from pkmstiff.mechanisms import load_mechanism
    from pkmstiff.mechanisms.constraints import fk_system, ik_system

    mech = load_mechanism(name)
    rng = np.random.default_rng(7)
    q = rng.uniform(-0.3, 0.3, (len(mech.links), mech.dof_per_link))
    for sysm, tg in ((fk_system(mech), rng.uniform(-0.2, 0.2, len(mech.drives))),
                     (ik_system(mech), rng.uniform(-0.2, 0.2, mech.pose_size))):
        assert _check(mech, sysm.blocks, q, tg) < 1e-7  # see test_spatial_jacobians_match_central_differences


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from([0.0, 1e-7, 0.3]))
def test_incremental_rotation_jacobians_match_central_differences_at_any_phi_y(seed, off):
    """``evaluate(omega=True)``: rotation columns are ∂/∂ω of R → exp([ω]×) R (System.step), also at the Euler
    angles' singularity φy = ±90° (off = 0) and next to it."""
    mech = spatial_all_kinds()
    rng = np.random.default_rng(seed)
    q = rng.uniform(-0.5, 0.5, (3, 6))
    q[:, 3:] = rng.uniform(-1.2, 1.2, (3, 3))
    q[2, 4] = rng.choice([-1.0, 1.0]) * (np.pi / 2 - off)  # link b (an ω link) at or near the lock
    target = {"fk": rng.uniform(-1, 1, 3), "ik": np.concatenate([rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)])}
    for blocks, tg in ((model_blocks(mech) + drive_blocks(mech), target["fk"]),
                       (model_blocks(mech) + output_blocks(mech), target["ik"])):
        sysm = System(mech, blocks)
        assert sysm.omega_links.tolist() == [False, False, True]  # ground and the link with a fixed φy keep φ
        _, J = sysm.evaluate(q[None], tg[None], reduced=True, omega=True)
        h = 1e-6
        Jfd = np.empty_like(J[0])
        for c in range(sysm.free.size):
            e = np.zeros((1, sysm.free.size))
            e[0, c] = h
            rp, _ = sysm.evaluate(sysm.step(q.reshape(1, -1), e).reshape(1, 3, 6), tg[None], jac=False, reduced=True)
            rm, _ = sysm.evaluate(sysm.step(q.reshape(1, -1), -e).reshape(1, 3, 6), tg[None], jac=False, reduced=True)
            Jfd[:, c] = (rp[0] - rm[0]) / (2 * h)
        # same error budget as the φ Jacobians above
        assert np.abs(J[0] - Jfd).max() / max(1.0, np.abs(J[0]).max()) < 1e-7


def test_link_angles_reproduce_the_rotation_at_the_lock():
    rng = np.random.default_rng(3)
    phi = rng.uniform(-3, 3, (200, 3))
    phi[:, 1] = np.pi / 2 * rng.choice([-1.0, 1.0], 200) + rng.choice([0.0, 1e-9, 1e-7, -1e-5], 200)
    R, _ = link_rotations(phi, 3)
    R2, _ = link_rotations(link_angles(R), 3)
    # φx, φz are not separately determined at the lock, but R(φ) is reproduced to rounding (entries O(1))
    assert np.abs(R2 - R).max() < 1e-14
