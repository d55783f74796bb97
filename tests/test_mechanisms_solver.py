"""Solver correctness of the generic mechanism kinematics (issue 27, item 4): revolute drives without spurious roots,
path continuation for large drive steps."""

from __future__ import annotations

import numpy as np
import pytest

import pkmstiff.mechanisms as mm
from pkmstiff.mechanisms.constraints import Frames, fk_system, link_rotations
from pkmstiff.mechanisms.solver import MAX_ANGLE_STEP, path_steps


@pytest.fixture(scope="module")
def hybrid():
    return mm.load_mechanism("hybrid_tripod_wrist")


@pytest.mark.parametrize("v1", [80.0, 90.0, 150.0, 179.0, -179.0])
def test_large_revolute_drive_step_from_home_gives_the_connected_configuration(hybrid, v1):
    d = np.array([[0.0, 0.0, 0.0, np.radians(v1), np.radians(40.0)]])
    fk = mm.forward(hybrid, d)  # default steps=1: the continuation subdivides the 80…179° step itself
    assert fk.status[0] == "converged"
    # the drive residual is the angle difference itself: solved to the Newton tolerance (1e-13·1 m scale)
    assert np.abs(fk.drives - d).max() < 1e-11
    # the same configuration as a 1°-per-step path (an independent continuation)
    ref = mm.forward(hybrid, d, steps=int(abs(v1)) + 1)
    assert np.abs(fk.poses - ref.poses).max() < 1e-10
    # round trip IK(FK(d)) = d from home: carriages unique; the wrist (V1, V2) is unique within V2's 5–80° limits.
    # Tolerance: poses are solved to 1e-13 m and the drive/pose sensitivity of this wrist is O(1–10) (κ at V2 = 40°)
    ik = mm.inverse(hybrid, fk.poses)
    assert ik.status[0] == "converged"
    err = ik.drives - d
    err[:, 3] = (err[:, 3] + np.pi) % (2.0 * np.pi) - np.pi  # V1 = ±180° are the same angle
    assert np.abs(err).max() < 1e-9


def test_revolute_drive_residual_has_no_root_half_a_turn_away(hybrid):
    d = np.array([[0.0, 0.0, 0.0, np.radians(30.0), np.radians(40.0)]])
    fk = mm.forward(hybrid, d)
    system = fk_system(hybrid)
    row = next(b.row0 for b in system.blocks if b.kind == "drive_rot")  # V1 comes first among the revolute drives
    r0, _ = system.evaluate(fk.q, d)
    r1, _ = system.evaluate(fk.q, d + np.array([0, 0, 0, np.pi, 0]))
    assert abs(r0[0, row]) < 1e-12
    # sin(θ − θ*) vanished here; the wrapped difference is ±π (float rounding of π + 30° − 30°)
    assert abs(abs(r1[0, row]) - np.pi) < 1e-12
    # compiled kernel and numpy reference agree on the wrapped residual and its Jacobian
    rr, Jr = system.evaluate_reference(fk.q, d + np.array([0, 0, 0, 2.5, 0]))
    rk, Jk = system.evaluate(fk.q, d + np.array([0, 0, 0, 2.5, 0]))
    assert np.abs(rr - rk).max() < 1e-14 and np.abs(Jr - Jk).max() < 1e-13


def test_path_steps_bound_the_change_per_step():
    delta = np.array([[np.radians(179.0), 0.0], [0.01, 0.01], [0.0, 1.0]])
    n = path_steps(delta, np.array([True, False]), 1.0, 1)
    # 179° / 15° → 12 → next power of two; small changes keep one step; 1 m at 0.25 m per step → 4
    assert n.tolist() == [16, 1, 4]
    assert (np.abs(delta[:, 0]) / n <= MAX_ANGLE_STEP).all()
    # steps=3: multiples 3·2^i (179° → 12 steps of 14.9°, 1 m → 6)
    assert path_steps(delta, np.array([True, False]), 1.0, 3).tolist() == [12, 3, 6]


def test_wrist_singularity_flagged_by_forward_kinematics_with_output_kappa(hybrid):
    # V2 = 0: tool axis parallel to V1 — the controlled outputs (point + tool axis) lose a direction although the
    # forward kinematics and the Cardan-pose ∂x/∂s stay regular (κ ≈ 3.2 there)
    fk = mm.forward(hybrid, [[0.05, -0.02, 0.01, 0.4, 0.0], [0.05, -0.02, 0.01, 0.4, 0.3]], steps=4)
    assert fk.status.tolist() == ["singular", "converged"]
    # exact singularity: σ_min at rounding level of σ_max (κ ≥ 1e12 measured 6.7e12); regular wrist: κ = O(10)
    assert fk.output_kappa[0] > 1e10 and 1.0 < fk.output_kappa[1] < 100.0
    # near it κ grows like 1/V2 (axis rate ∝ sin V2): κ·V2 constant to O(V2²)
    near = mm.forward(hybrid, [[0.05, -0.02, 0.01, 0.4, v] for v in (1e-3, 1e-4)], steps=4)
    k = near.output_kappa * np.array([1e-3, 1e-4])
    assert abs(k[0] / k[1] - 1.0) < 1e-3


def test_output_jacobian_matches_central_differences_of_forward_kinematics(hybrid):
    from pkmstiff.mechanisms.outputs import output_jacobian

    d0 = np.array([0.03, -0.02, 0.05, 0.7, 0.5])
    fk = mm.forward(hybrid, d0[None], steps=4)
    Jc = output_jacobian(hybrid, fk.q, d0[None])[0]
    o = hybrid.output
    h = 1e-6  # central differences: truncation O(h²) ≈ 1e-12, rounding 1e-16/1e-6 = 1e-10 → compare to 1e-8
    for c in range(5):
        dp, dm = d0.copy(), d0.copy()
        dp[c] += h
        dm[c] -= h
        qp = mm.forward(hybrid, dp[None], start=fk.q).q
        qm = mm.forward(hybrid, dm[None], start=fk.q).q
        Fp, Fm = Frames(qp, 3, False), Frames(qm, 3, False)
        wp, up = Fp.point(np.array([o.link]), o.point[None])[0][0, 0], Fp.R[0, o.link] @ o.axis
        wm, um = Fm.point(np.array([o.link]), o.point[None])[0][0, 0], Fm.R[0, o.link] @ o.axis
        assert np.abs((wp - wm) / (2 * h) - Jc[:3, c]).max() < 1e-8
        # the axis rows are u̇ on two unit vectors ⊥ u: their norm is |u̇|
        assert abs(np.linalg.norm((up - um) / (2 * h)) - np.linalg.norm(Jc[3:, c])) < 1e-8


def _slider_crank_text(drive_a: str, drive_s: str) -> str:
    """The slider-crank of tests/test_mechanisms_files.py with the crank (A) and slider drives as given."""
    from tests.test_mechanisms_files import BASE

    return BASE.replace('point = [0.04, 0.02]\n', f'point = [0.04, 0.02]\n{drive_a}\n', 1).replace(
        'drive = "s"\n', f"{drive_s}\n")


@pytest.mark.parametrize("drive_a, drive_s, found", [
    ("", "", None),  # no drives: a structure, not checked
    ("", 'drive = "s"', None),  # slider-crank: mobility 1, one drive
    ('drive = "a"', 'drive = "s"', "drive 's' locks no motion"),  # two drives on one degree of freedom
])
def test_mobility_against_drives_at_load(tmp_path, drive_a, drive_s, found):
    from pkmstiff.errors import InputError

    p = tmp_path / "m.toml"
    p.write_text(_slider_crank_text(drive_a, drive_s))
    if found is None:
        mm.load_mechanism(p)
        return
    with pytest.raises(InputError) as ei:
        mm.load_mechanism(p)
    assert found in str(ei.value) and "mobility at home (1 = 12 unknowns − rank 11)" in str(ei.value)
    assert "\n" not in str(ei.value)


def test_free_motion_named_at_load(tmp_path):
    from pkmstiff.errors import InputError

    # the slider-crank with its coupler pin C removed: crank + free coupler + slider, three degrees of freedom
    text = _slider_crank_text("", 'drive = "s"').replace(
        '[[joints]]\nname = "C"\ntype = "revolute"\nlinks = ["2", "3"]\npoint = [0.115, 0.055]\n', "")
    p = tmp_path / "m.toml"
    p.write_text(text)
    with pytest.raises(InputError) as ei:
        mm.load_mechanism(p)
    msg = str(ei.value)
    assert "2 motion(s) left free, e.g. link '2' phi" in msg and "mobility at home (3 = 12 unknowns − rank 9)" in msg


def test_cli_solve_reports_solved_drives_output_kappa_links_and_start(capsys):
    import json

    from pkmstiff.cli import main

    assert main(["mechanism", "solve", "hybrid_tripod_wrist", "--drives", "0,0,0,150,40", "--drives", "0,0,0,20,0",
                 "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    r0, r1 = rep["results"]
    assert rep["controlled_outputs"] == ["x", "y", "z", "axis_e1", "axis_e2"]
    assert abs(r0["drives"]["V1_deg"] - 150.0) < 1e-9 and r0["status"] == "converged"
    assert abs(r0["links"]["fork"]["phi_z_deg"] - 150.0) < 1e-9  # the fork turns by V1 about z
    assert r1["status"] == "singular" and r1["output_condition_number"] > 1e10
    # the other wrist solution (V1 + 180°, −V2) is the same tool axis: chosen by starting from its drive values
    assert main(["mechanism", "solve", "hybrid_tripod_wrist", "--pose", "0,100,-1073.2,10,0,0", "--start-drives",
                 "0,0,0,180,-30", "--json"]) == 0
    dr = json.loads(capsys.readouterr().out)["results"][0]["drives"]
    assert main(["mechanism", "solve", "hybrid_tripod_wrist", "--pose", "0,100,-1073.2,10,0,0", "--json"]) == 0
    dr_home = json.loads(capsys.readouterr().out)["results"][0]["drives"]
    assert abs(dr["V2_deg"] + dr_home["V2_deg"]) < 1e-6 and abs(abs(dr["V1_deg"] - dr_home["V1_deg"]) - 180) < 1e-6
    assert main(["mechanism", "solve", "slider_crank", "--drives", "10", "--links"]) == 0
    out = capsys.readouterr().out
    assert "condition number of the controlled outputs (x): 1" in out and "link " in out


ARM = """
format_version = 1
[mechanism]
name = "arm"
dimension = 3
links = ["ground", "arm", "hand"]
ground = "ground"
[[joints]]
name = "shoulder"
type = "revolute"
links = ["ground", "arm"]
point = [0, 0, 0]
axis = [0, 1, 0]
drive = "q1"
[[joints]]
name = "wrist"
type = "revolute"
links = ["arm", "hand"]
point = [0.5, 0, 0]
axis = [1, 0, 0]
drive = "q2"
[output]
link = "hand"
point = [0.6, 0.1, 0]
orientation = "none"
coordinates = ["x", "y"]
"""


@pytest.mark.parametrize("q1_deg", [90.0, 90.0 + 1e-5, 90.0 - 1e-5, -90.0, 89.0])
def test_link_at_phi_y_90_degrees_solves(tmp_path, q1_deg):
    # the arm turns about y: its Euler angle φy = q1, the parametrisation singularity of R = Rz Ry Rx at ±90°
    p = tmp_path / "arm.toml"
    p.write_text(ARM)
    mech = mm.load_mechanism(p)
    d = np.radians([[q1_deg, 30.0]])
    fk = mm.forward(mech, d)
    assert fk.status[0] == "converged" and fk.rank[0] == fk.n_free
    # the arm's rotation is Ry(q1) (its angles are stored with |φy| ≤ 90°: beyond, φx = φz = 180°)
    c, s_ = np.cos(d[0, 0]), np.sin(d[0, 0])
    R_arm = link_rotations(fk.q[0, 1, 3:], 3)[0]
    assert np.abs(R_arm - np.array([[c, 0, s_], [0, 1, 0], [-s_, 0, c]])).max() < 1e-13
    assert np.abs(fk.drives - d).max() < 1e-12
    # IK of the hand point's x, y from the FK configuration's neighbourhood (x, y leave two assembly modes)
    ik = mm.inverse(mech, fk.poses, start=mm.forward(mech, d - np.radians(5.0)).q)
    assert ik.status[0] == "converged"
    # x, y solved to 1e-13 m; drives follow with sensitivity ≤ 1/(0.1 m · sin 30°) = 20 rad/m
    assert np.abs(ik.drives - d).max() < 1e-10


def test_range_of_an_unlimited_revolute_drive(tmp_path):
    import time

    p = tmp_path / "arm.toml"
    p.write_text(ARM.replace('drive = "q2"', 'drive = "q2"\nlimits = { min = "-100 deg", max = "120 deg" }'))
    mech = mm.load_mechanism(p)
    t0 = time.process_time()
    rng = mm.drive_ranges(mech)
    # q1 turns round (angles unwrapped along the curve): unlimited both ways, not min > max after 2000 steps
    assert (rng["q1"].min.kind, rng["q1"].max.kind) == ("unlimited", "unlimited")
    assert rng["q1"].min.value == -np.inf and rng["q1"].max.value == np.inf
    # q2 passes its home value and stops at its limits (radians, exact: the limit is reported, not the overshoot)
    assert (rng["q2"].min.kind, rng["q2"].max.kind) == ("limit", "limit")
    assert (rng["q2"].min.value, rng["q2"].max.value) == (np.radians(-100.0), np.radians(120.0))
    assert time.process_time() - t0 < 20.0  # a full turn in 2 %-of-size steps: a few hundred corrector solves


@pytest.mark.parametrize("q1_deg", [90.0, 90.0 + 1e-5, -90.0, 60.0])
def test_identification_jacobian_of_a_link_at_phi_y_90_degrees(tmp_path, q1_deg):
    # ∂q/∂p in rotation-vector coordinates: the arm at φy = ±90° is an ordinary configuration (with the Euler
    # angles as coordinates F_q loses rank there and the pseudo-inverse drops a real motion)
    p = tmp_path / "arm.toml"
    p.write_text(ARM)
    mech = mm.load_mechanism(p)
    d = np.radians([[q1_deg, 30.0]])
    sel = ["wrist.point.x", "wrist.point.z", "output.point.y", "shoulder.axis.x"]
    sol, Jid, _ = mm.identification_jacobian(mech, d, names=sel)
    names, _, p0 = mm.parameters(mech)
    h = 1e-6
    for c, n in enumerate(sel):
        pp, pm = p0.copy(), p0.copy()
        pp[names.index(n)] += h
        pm[names.index(n)] -= h
        fd = (mm.forward(mm.with_parameters(mech, pp), d, start=sol).poses
              - mm.forward(mm.with_parameters(mech, pm), d, start=sol).poses) / (2 * h)
        # both central differences (h = 1e-6 m) of 1e-13-accurate solutions: 1e-6 absolute on x, y (m/m)
        assert np.abs(Jid[0, :2, c] - fd[0, :2]).max() < 1e-6, n
