"""Working and assembly modes of mechanisms (issue 27, known gaps): the mode signature, sections and ``point`` that
keep the start's mode, the planar default plane."""

from __future__ import annotations

import numpy as np

import pkmstiff.mechanisms as mm
from pkmstiff.mechanisms.modes import other_mode, signature
from pkmstiff.mechanisms.section import evaluate_section


def test_signature_flips_across_the_singularities_of_bipod_and_five_bar():
    bip = mm.load_mechanism("bipod_generic")
    # the bipod's platform point above and below the base line: the same strut lengths, the mirror assembly mode
    sol = mm.inverse(bip, [[0.1, 0.4, 0.0], [0.1, -0.4, 0.0], [0.0, 0.9, 0.0]])
    sig = signature(bip, sol.q)
    assert np.allclose(sol.drives[0], sol.drives[1], rtol=0, atol=1e-12)  # same drives: FK has two roots
    assert other_mode(sig[1:2], sig[0]).all() and not other_mode(sig[2:3], sig[0]).any()
    # the five-bar: a leg's elbow flipped (the same output point, crank 1 on the other side of the line A1-P)
    fb = mm.load_mechanism("five_bar")
    home = mm.solver.home(fb)
    P = np.array([0.1, 0.3])
    A1, B1 = np.array([0.0, 0.0]), np.array([-0.05, 0.15])
    d = P - A1
    mirror = A1 + 2 * (B1 - A1) @ d / (d @ d) * d - (B1 - A1)  # B1 reflected on the line A1-P
    th = np.arctan2(mirror[1], mirror[0]) - np.arctan2(B1[1], B1[0])
    flipped = mm.forward(fb, [[th, 0.0]], steps=1, start=home)  # the cranks' angles of the flipped elbow …
    ik = mm.inverse(fb, [[0.1, 0.3, 0.0]])                         # … and home's elbow, the same point
    assert flipped.ok[0] and np.allclose(flipped.poses[0, :2], P, atol=1e-9)
    s0, s1 = signature(fb, ik.q), signature(fb, flipped.q)
    assert other_mode(s1, s0[0]).all()


def test_bipod_section_keeps_the_start_assembly_mode():
    bip = mm.load_mechanism("bipod_generic")
    sec = evaluate_section(bip, "xy", 0.0, (-0.4, 0.4), (-0.6, 1.0), 0.05)
    y = np.broadcast_to(sec.v_values[:, None], sec.ok.shape)
    assert sec.ok.any() and (y[sec.ok] > 0).all()          # before: admissible points at y < 0 (the mirror mode)
    other = (sec.reasons & mm.REASONS["OTHER_WORKING_MODE"]) > 0
    # below the base line every point within the strut limits is the mirror mode; on it (y = 0) singular
    assert other[y < 0].sum() >= 0.3 * (y < 0).sum() and not other[y > 0].any()
    assert ((sec.reasons & mm.REASONS["SINGULAR"]) > 0)[np.isclose(y, 0.0)].all()
    assert sec.reason_counts()["OTHER_WORKING_MODE"] == int(other.sum())


def test_five_bar_section_points_all_keep_the_home_working_mode():
    fb = mm.load_mechanism("five_bar")
    sec = evaluate_section(fb, "xy", 0.0, (-0.15, 0.35), (-0.1, 0.38), 0.02)
    from pkmstiff.mechanisms.section import NEIGHBOUR, plane_poses, raster_inverse

    P = plane_poses(fb, "xy", 0.0, sec.u_values, sec.v_values, np.zeros(3))
    sol = raster_inverse(fb, P, sec.ok.shape, **NEIGHBOUR)
    ref = signature(fb, mm.inverse(fb, fb.home_output_pose[None]).q)[0]
    sig = signature(fb, sol.q[sec.ok.ravel()])
    assert sec.ok.sum() > 100 and not other_mode(sig, ref).any()
    # (100, 60) mm lies below the couplers' straight line of the home mode: the chain reaches it only through the
    # parallel singularity (κ → ∞ on the boundary); before, the raster hopped into it and called it admissible
    iv, iu = np.argmin(abs(sec.v_values - 0.06)), np.argmin(abs(sec.u_values - 0.1))
    assert not sec.ok[iv, iu] and sec.reasons[iv, iu] & mm.REASONS["OTHER_WORKING_MODE"]
    direct = mm.inverse(fb, [[0.1, 0.06, 0.0]])
    assert direct.ok[0] and other_mode(signature(fb, direct.q), ref).all()  # a configuration exists: other mode


def test_point_finds_what_the_section_finds(capsys):
    from pkmstiff.cli import main
    from pkmstiff.cli.point import point_report
    from pkmstiff.mechanisms.section import NEIGHBOUR, plane_poses, raster_inverse

    fb = mm.load_mechanism("five_bar")
    sec = evaluate_section(fb, "xy", 0.0, (-0.12, 0.12), (-0.2, 0.2), 0.02, names=("theta1", "theta2", "kx"))
    raster = raster_inverse(fb, plane_poses(fb, "xy", 0.0, sec.u_values, sec.v_values, np.zeros(3)), sec.ok.shape,
                            **NEIGHBOUR).drives.reshape(*sec.ok.shape, 2)  # the section's configurations
    i, j = np.argmin(abs(sec.v_values + 0.2)), np.argmin(abs(sec.u_values + 0.1))
    # (−100, −200) mm: the straight path from home leaves the workspace (before: "no solution"); the section reaches
    # it through its neighbours, in home's working mode (the cranks beyond their ±90° limits)
    assert mm.inverse(fb, [[-0.1, -0.2, 0.0]]).status[0] == "no_solution"
    assert sec.status[i, j] == "converged" and sec.reasons[i, j] == mm.REASONS["JOINT_LIMIT"]
    rep = point_report("five_bar", "-100,-200,0", n_modes=1, allow_inadmissible=True)
    # both are Newton solutions of the same root to 1e-13 of the length scale: drives equal to ~1e-12 rad
    th = [rep["drives"]["theta1_deg"], rep["drives"]["theta2_deg"]]
    sdr = np.degrees(raster[i, j])
    assert rep["reasons"] == ["joint limit"] and np.allclose(th, sdr, rtol=0, atol=1e-9)
    # an admissible point: the stiffness too (same configuration; the model's rounding, 1e-9 relative)
    i, j = np.argmin(abs(sec.v_values - 0.16)), np.argmin(abs(sec.u_values + 0.1))
    rep = point_report("five_bar", "-100,160,0", n_modes=1, allow_inadmissible=False)
    assert sec.ok[i, j] and np.isclose(rep["k_N_per_um"]["x"] * 1e6, sec.values["kx"][i, j], rtol=1e-9)
    # a point of the other assembly mode: refused with its reason (exit 3), and solved from a start in that mode
    assert main(["point", "five_bar", "--pose", "100,60,0"]) == 3
    assert "other working mode" in capsys.readouterr().err
    start = mm.inverse(fb, [[0.1, 0.06, 0.0]])
    other = evaluate_section(fb, "xy", 0.0, (0.0, 0.2), (-0.06, 0.1), 0.02, names=("theta1", "theta2"),
                             start=start.q[0])
    i, j = np.argmin(abs(other.v_values + 0.04)), np.argmin(abs(other.u_values - 0.04))
    rep = point_report("five_bar", "40,-40,0", n_modes=1, allow_inadmissible=True, start_pose="100,60,0")
    assert other.ok[i, j] and rep["admissible"]
    assert np.allclose([rep["drives"]["theta1_deg"], rep["drives"]["theta2_deg"]],
                       np.degrees([other.values["theta1"][i, j], other.values["theta2"][i, j]]), rtol=0, atol=1e-9)
    assert main(["point", "hexaglide", "--pose", "0,0,-1000,0,0,0", "--start-pose", "0,0,-1000,0,0,0"]) == 2
    assert "--start-pose: only for a mechanism" in capsys.readouterr().err


def test_planar_mechanism_section_defaults_to_the_plane_of_motion(capsys, tmp_path):
    from pkmstiff.cli import main

    # before: the default yz plane was refused for a planar mechanism (it needed --plane xy)
    assert main(["section", "biglide_generic", "--step", "100"]) == 0
    assert "plane of motion" in capsys.readouterr().out
    out = tmp_path / "o"
    assert main(["section", "biglide_generic", "--plane", "xz", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "planar (it moves in the xy plane): expected xy, found xz" in err[0]
    assert not out.exists()  # refused before any work


def test_section_maps_the_mode_of_a_start_pose(capsys):
    import json

    from pkmstiff.cli import main

    assert main(["section", "five_bar", "--step", "20", "--start-pose", "100,60,0", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    # the other assembly mode (below the couplers' straight line): admissible there, home's mode now "other"
    assert rep["start_pose_mm_deg"] == [100.0, 60.0, 0.0] and rep["admissible_points"] > 20
    assert rep["inadmissible_reasons"]["OTHER_WORKING_MODE"] > 0 and rep["window_mm"]["y"][0] < 0
    home = json.loads((main(["section", "five_bar", "--step", "20", "--json"]), capsys.readouterr().out)[1])
    assert home["window_mm"]["y"][0] >= 0 and "start_pose_mm_deg" not in home
    assert main(["section", "hexaglide", "--start-pose", "0,0,-1000,0,0,0"]) == 2
    assert "--start-pose: only for a mechanism" in capsys.readouterr().err


def test_a_drive_path_sample_in_another_mode_is_flagged(tmp_path, monkeypatch, capsys):
    """``mechanism path`` follows the drives sample after sample; a sample whose forward kinematics lands in another
    assembly mode than the path's start (forced here: the bipod's mirror configuration for the second sample) is
    ``other_mode``, with empty pose cells, not a pose of the other branch."""
    import csv

    from pkmstiff.cli import main

    bip = mm.load_mechanism("bipod_generic")
    mirror = mm.inverse(bip, [[0.0, -0.4583, 0.0]])  # l1 = l2 ≈ 1.1 m below the base line
    real = mm.forward
    calls = []

    def flipping(mech, drives, start=None, **kw):
        sol = real(mech, drives, start=start, **kw)
        calls.append(1)
        if len(calls) == 2:
            sol = real(mech, drives, start=mirror.q, **kw)  # the same drives, the mirror configuration
        return sol

    monkeypatch.setattr(mm, "forward", flipping)
    f = tmp_path / "d.csv"
    f.write_text("t_s,l1_mm,l2_mm\n0,1200,1200\n0.1,1100,1100\n0.2,1150,1150\n")
    out = tmp_path / "o.csv"
    assert main(["mechanism", "path", "bipod_generic", "--drives-file", str(f), "--out", str(out)]) == 0
    assert "other_mode 1" in capsys.readouterr().out
    rows = list(csv.DictReader(out.open()))
    assert [r["status"] for r in rows] == ["converged", "other_mode", "converged"]
    assert rows[1]["y_mm"] == "" and float(rows[0]["y_mm"]) > 0


def test_signature_separates_the_mirror_assembly_mode_of_a_6ups():
    """Spatial: the platform mirrored through the plane of the base joints (z → −z, parallel platform) has the same
    six strut lengths — the other assembly mode; the forward-kinematics block's sign tells them apart, a pose of the
    same mode does not differ."""
    hexa = mm.load_mechanism("hexapod_6ups")
    sol = mm.inverse(hexa, [[0.05, 0.02, 1.2, 0, 0, 0], [0.05, 0.02, -1.2, 0, 0, 0], [-0.1, 0.05, 1.1, 3e-2, 0, 0]],
                     steps=8)
    assert sol.ok.all() and np.allclose(sol.drives[0], sol.drives[1], rtol=0, atol=1e-12)
    sig = signature(hexa, sol.q)
    assert other_mode(sig[1:2], sig[0]).all() and not other_mode(sig[2:3], sig[0]).any()


def test_signature_flips_across_the_hybrid_wrist_singularity():
    """Spatial, serial (working-mode) singularity: the hybrid's wrist with V2 = ±0.3 rad holds the tool axis on
    either side of the central strut — one inverse-kinematics block changes sign, and is singular (0) at V2 = 0."""
    hyb = mm.load_mechanism("hybrid_tripod_wrist")
    fk = mm.forward(hyb, [[0.05, -0.02, 0.01, 0.4, v2] for v2 in (0.3, 0.0, -0.3, 0.5)], steps=4)
    sig = signature(hyb, fk.q)
    assert (sig[1] == 0).sum() == 1 and fk.status[1] == "singular"
    assert other_mode(sig[2:3], sig[0]).all() and not other_mode(sig[3:4], sig[0]).any()
