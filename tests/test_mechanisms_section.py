"""A mechanism evaluated like a machine (issue 14, item 5): kinematic Jacobian ∂x/∂s, its condition number against
the closed-form machines, section rasters against pointwise evaluation, and the ``pose``/``section`` commands."""

from __future__ import annotations

import json

import numpy as np
import pytest

import pkmstiff
from pkmstiff.admissibility import evaluate_poses
import pkmstiff.mechanisms as mm
from pkmstiff.cli import main
from pkmstiff.mechanisms.section import condition_numbers, evaluate_section, kinematic_jacobian


@pytest.mark.parametrize("name, drives", [("hybrid_tripod_wrist", [[0.05, -0.02, 0.01, 0.4, 0.5]]),
                                          ("slider_crank", [[0.01]])])
def test_kinematic_jacobian_matches_forward_differences(name, drives):
    mech = mm.load_mechanism(name)
    sol = mm.forward(mech, drives, steps=4)
    Jx = kinematic_jacobian(sol)
    h = 1e-6
    for c in range(len(mech.drives)):
        e = np.zeros(len(mech.drives))
        e[c] = h
        fd = (mm.forward(mech, np.array(drives) + e, start=sol).poses
              - mm.forward(mech, np.array(drives) - e, start=sol).poses) / (2 * h)
        # central differences of converged FK (tol 1e-13 m): truncation O(h²) ~ 1e-12, rounding 1e-13/h ~ 1e-7
        assert np.abs(Jx[:, :, c] - fd).max() < 1e-6


def test_condition_number_equals_closed_form_machines():
    for machine, generic, P in (("hexapod_6x", "hexapod_6x_generic", [[0.05, -0.03, 1.3, 0, 0, 0],
                                                                       [-0.1, 0.08, 1.25, 0, 0, 0]]),
                                ("hexaglide", "hexaglide_generic", [[0.05, 0.3, -0.9, 0, 0, 0],
                                                                    [-0.1, 0.35, -0.95, 0, 0, 0]])):
        P = np.array(P)
        ref = evaluate_poses(pkmstiff.load_machine(machine), P).kappa
        got = condition_numbers(kinematic_jacobian(mm.inverse(mm.load_mechanism(generic), P)))
        # at zero angles Cardan rates = angular velocity, so ∂x/∂s = (J⁻¹)⁻¹; the machines' κ is certified to
        # rtol 1e-4 (kinematics.condition_number "fast"), ours is an SVD of a 1e-9-accurate Jacobian
        assert np.abs(got / ref - 1).max() < 2e-4, machine


def test_section_equals_pointwise_evaluation_and_marks_reasons():
    mech = mm.load_mechanism("hybrid_tripod_wrist")
    sec = evaluate_section(mech, "xy", -1.073205080757, (-0.25, 0.25), (-0.05, 0.35), 0.1, (0, 0, 0),
                           ("kappa", "U1", "V2"))
    assert sec.values["kappa"].shape == (5, 6)
    U, V = np.meshgrid(sec.u_values, sec.v_values)
    P = np.column_stack([U.ravel(), V.ravel(), np.full(U.size, -1.073205080757), np.zeros((U.size, 3))])
    ev = mm.evaluate(mech, P, steps=4)
    assert np.array_equal(sec.reasons.ravel(), ev.reasons)
    ok = ev.admissible
    assert ok.any() and (~ok).any()  # the window crosses the workspace boundary
    assert np.allclose(sec.values["U1"].ravel()[ok], ev.drives[ok, 0], rtol=0, atol=1e-12)  # same solutions
    assert np.isnan(sec.values["kappa"].ravel()[~ok]).all() and np.isfinite(sec.values["kappa"].ravel()[ok]).all()
    assert sec.reason_counts()["JOINT_LIMIT"] > 0


def test_pose_and_section_commands_dispatch_to_mechanisms(tmp_path, capsys):
    assert main(["pose", "hybrid_tripod_wrist", "--pose", "50,100,-1073.205,0,40,0", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["status"] == "converged" and not rep["admissible"]
    assert rep["reasons"] == ["JOINT_LIMIT"] and rep["violated_joints"] == ["slider2"]
    assert rep["joints"]["slider2"]["violated"] and rep["condition_number"] > 1
    out = tmp_path / "sec"
    assert main(["section", "slider_crank", "--plane", "xy", "--range", "x=0:200,y=-20:20", "--step", "20",
                 "--quantities", "kappa,s", "--out", str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["points"] == 11 * 3 and rep["admissible_points"] > 0
    assert rep["statistics"]["s"]["unit"] == "mm" and rep["inadmissible_reasons"]["NO_SOLUTION"] > 0
    names = {p.name for p in out.iterdir()}
    assert {"slider_crank_xy_kappa.png", "slider_crank_xy_s.png", "slider_crank_xy_admissibility.png",
            "slider_crank_xy.csv", "slider_crank_xy.npz"} <= names
    rows = (out / "slider_crank_xy.csv").read_text().splitlines()
    assert rows[0] == "x_mm,y_mm,status,reasons,admissible,kappa,s_mm" and len(rows) == 34
