"""The bundled hybrid machine (tripod + passive central strut + two-axis wrist): round trips, singularities,
velocities/accelerations, joint-limit admissibility and the identification Jacobian."""

from __future__ import annotations

import numpy as np
import pytest

import pkmstiff.mechanisms as mm


@pytest.fixture(scope="module")
def mech():
    return mm.load_mechanism("hybrid_tripod_wrist")


def _drives(n, seed=5):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-0.15, 0.15, (n, 3)), rng.uniform(-1.5, 1.5, n),
                            np.radians(rng.uniform(15, 75, n))])


@pytest.fixture(scope="module")
def workspace(mech):
    """Poses over the workspace: forward kinematics of random drive values (carriages ±150 mm, V1 ±86°,
    V2 15–75°)."""
    d = _drives(400)
    sol = mm.forward(mech, d, steps=4)
    assert sol.converged.all()
    return d, sol.poses


def test_fk_of_ik_is_identity(mech, workspace):
    d, P = workspace
    ik = mm.inverse(mech, P, steps=4)
    assert ik.converged.all()
    fk = mm.forward(mech, ik.drives, steps=4)
    assert fk.converged.all()
    diff = fk.poses - P
    diff[:, 5] = 0.0  # c (rotation about the tool axis) is not a pose coordinate of a 5-axis machine
    assert np.abs(diff[:, :5]).max() < 1e-10  # issue 14 tolerance (measured ~1e-13)
    # the carriages are unique; the wrist has two solutions (V1, V2) and (V1 ± π, −V2) for the same tool axis
    assert np.abs(ik.drives[:, :3] - d[:, :3]).max() < 1e-10


def test_wrist_singularity_detected(mech):
    # V2 = 0: the tool is parallel to the central strut, V1 is undetermined (Denkena §1.2.1)
    fk = mm.forward(mech, [[0.05, -0.02, 0.01, 0.4, 0.0]], steps=4)
    # the forward problem is regular there (a configuration is found), but the controlled outputs are singular
    assert fk.status[0] == "singular" and fk.rank[0] == fk.n_free and fk.output_kappa[0] > 1e10
    ik = mm.inverse(mech, fk.poses)
    assert ik.status[0] == "singular"
    assert ik.rank[0] == ik.n_free - 1 and ik.sigma_ratio[0] < 1e-7
    ev = mm.evaluate(mech, fk.poses)
    assert ev.reasons[0] & mm.REASONS["SINGULAR"] and not ev.admissible[0]
    # a regular pose nearby is fine
    ok = mm.inverse(mech, mm.forward(mech, [[0.05, -0.02, 0.01, 0.4, 0.3]], steps=4).poses)
    assert ok.status[0] == "converged"


@pytest.mark.parametrize("tilt", [1e-7, 1e-6, 1e-5])
def test_ik_from_home_near_the_wrist_singularity(mech, tilt):
    # issue 27 item 4: home is at the wrist singularity (V2 = 0), so continuation from home turns the tool axis by
    # only `tilt` while V1 must swing by 0.7 rad; the damped Newton crept there (max_iter), the watchdog solves it
    d = np.array([[0.02, -0.03, 0.01, 0.7, tilt]])
    fk = mm.forward(mech, d, steps=4)
    ik = mm.inverse(mech, fk.poses)
    assert ik.ok[0]
    err = np.abs(ik.drives - d)[0]
    assert err[:3].max() < 1e-12  # carriages: regular, measured ~1e-15
    # V1 moves the tool axis by tilt·ΔV1 only, so a residual at rounding level (~1e-16) leaves ΔV1 ~ 1e-16/tilt:
    # measured 9e-10 at 1e-7, 2e-10 at 1e-6, 6e-12 at 1e-5; bound 10× that rounding floor
    assert err[3] <= 1e-15 / tilt and err[4] < 1e-12
    kappa = ik.output_kappa[0]
    assert kappa == pytest.approx(fk.output_kappa[0], rel=1e-6)  # same configuration, same κ
    assert (ik.status[0] == "singular") == (kappa > 1e7 or ik.sigma_ratio[0] < 1e-7)
    assert ik.status[0] == ("converged" if tilt == 1e-5 else "singular")


def test_joint_limits(mech):
    d = np.array([[0.0, 0.0, 0.0, 0.0, np.radians(30)], [0.0, 0.0, 0.0, 0.0, np.radians(85)],
                  [0.3, 0.0, 0.0, 0.0, np.radians(30)]])
    fk = mm.forward(mech, d, steps=8)
    ev = mm.evaluate(mech, fk.poses, steps=4)
    assert ev.admissible.tolist() == [True, False, False]
    assert "V2" in [n for n, v in zip(ev.joint_names, ev.violated[1]) if v]
    assert "slider1" in [n for n, v in zip(ev.joint_names, ev.violated[2]) if v]
    assert mm.reason_names(ev.reasons[1]) == ["JOINT_LIMIT"]


def test_velocities_and_accelerations(mech):
    d0 = _drives(3, seed=9)
    sd = np.array([0.1, -0.2, 0.05, 0.5, -0.3])
    sdd = np.array([0.3, 0.1, -0.2, 1.0, 0.4])
    sol = mm.forward(mech, d0, steps=4)
    rt = mm.rates(sol, sd, sdd)
    h = 1e-4
    path = lambda t: mm.forward(mech, d0 + t * sd + 0.5 * t**2 * sdd, start=sol)  # noqa: E731
    sp, sm = path(h), path(-h)
    pd_fd = (sp.poses - sm.poses) / (2 * h)
    pdd_fd = (sp.poses - 2 * sol.poses + sm.poses) / h**2
    # central differences of converged solutions: O(h²) ~ 1e-8 plus rounding 1e-13/h² ~ 1e-5 for the second one
    assert np.abs(rt.pose_dot - pd_fd).max() < 1e-6
    assert np.abs(rt.pose_ddot - pdd_fd).max() < 1e-3 * max(1.0, np.abs(pdd_fd).max())


def test_identification_jacobian_matches_resolved_forward_kinematics(mech):
    names, units, p0 = mm.parameters(mech)
    assert "slider1.point.x" in names and units[names.index("V2.offset")] == "rad"
    sel = ["slider1.point.z", "plate_cardan2.point.x", "V2.point.y", "V2.offset", "output.point.z", "V1.axis.y"]
    d = _drives(4, seed=3)
    sol, Jid, got = mm.identification_jacobian(mech, d, names=sel, steps=4)
    assert got == sel and Jid.shape == (4, 6, len(sel))
    h = 1e-6
    for c, n in enumerate(sel):
        k = names.index(n)
        pp, pm = p0.copy(), p0.copy()
        pp[k] += h
        pm[k] -= h
        fp = mm.forward(mm.with_parameters(mech, pp), d, start=sol)
        fm = mm.forward(mm.with_parameters(mech, pm), d, start=sol)
        fd = (fp.poses - fm.poses) / (2 * h)
        # both are central differences (h = 1e-6) of exact solutions: agreement to 1e-6 absolute (m/m, rad/m)
        assert np.abs(Jid[:, :5, c] - fd[:, :5]).max() < 1e-6, n
