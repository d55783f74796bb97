"""``pkmstiff calibrate identifiability``: text and JSON output, TOML plans, one-line errors for bad input."""

import json

import numpy as np
import pytest

import pkmstiff
from pkmstiff.calibration import Plan, Setup, check_plan, error_model, identification_jacobian, read_plan
from pkmstiff.cli import main
from pkmstiff.errors import InadmissibleError, InputError

PLAN = """
[plan]
name = "felix circles"
instrument = "ballbar"

[setup]
fixed_ball = ["0 mm", "0 mm", "0 mm"]
target = [0, 0, 0]
bar_length = "300 mm"

[[paths]]
kind = "circle"
plane = "XY"
points = 36

[[paths]]
kind = "circle"
plane = "XZ"
points = 36
tilt = "10 deg"
tilt_azimuth = "90 deg"
"""


def _run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_text_output_names_the_lemma(capsys):
    code, out, _ = _run(capsys, "calibrate", "identifiability", "felix", "--instrument", "ballbar")
    assert code == 0
    assert "parameters: 42   rank: 36" in out
    assert "base frame rotation about the fixed-ball centre (3 DOF)" in out
    assert "platform frame rotation about the moving-ball centre (3 DOF)" in out
    assert "largest orthogonality entry" in out and "O5 =" in out


def test_json_keys_and_units(capsys):
    code, out, _ = _run(capsys, "calibrate", "identifiability", "felix", "--instrument", "ballbar", "--with",
                        "ball-offset,bar-offset", "--frame", "cylindrical", "--json")
    assert code == 0
    rep = json.loads(out)
    for key in ("n_parameters", "rank", "gauge_freedoms", "condition_number", "max_orthogonality",
                "max_orthogonality_pair", "observability", "base_parameters"):
        assert key in rep
    assert rep["n_parameters"] == 46 and rep["frame"] == "cylindrical"
    assert set(rep["observability"]) == {"O1", "O2", "O3", "O4", "O5"}
    assert rep["setup"]["bar_length_mm"] == pytest.approx(300.0)
    assert sum(g["dof"] for g in rep["gauge_freedoms"]) == rep["n_parameters"] - rep["rank"]


def test_toml_plan(tmp_path, capsys):
    path = tmp_path / "plan.toml"
    path.write_text(PLAN)
    plan = read_plan(path)
    assert plan.n_poses == 72 and plan.setup.bar_length == pytest.approx(0.3)
    code, out, _ = _run(capsys, "calibrate", "identifiability", "felix", "--instrument", "ballbar", "--plan",
                        str(path), "--json")
    assert code == 0 and json.loads(out)["plan"]["n_poses"] == 72


@pytest.mark.parametrize("text, needle", [
    (PLAN.replace('instrument = "ballbar"', 'instrument = "laser"'), "plan.instrument"),
    (PLAN.replace('bar_length = "300 mm"', 'bar_length = "300 kg"'), "setup.bar_length"),
    (PLAN.replace('plane = "XY"', 'plane = "XY"\nradius_typo = 1'), "paths[1].radius_typo"),
    (PLAN.replace("[[paths]]", "[[paths]]\nkind = \"spiral\"", 1).replace('kind = "circle"\nplane = "XY"',
                                                                         'plane = "XY"', 1), "paths[1].kind"),
    ("[plan\n", "valid TOML"),
])
def test_malformed_plans_give_one_line_errors(tmp_path, capsys, text, needle):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    code, _, err = _run(capsys, "calibrate", "identifiability", "felix", "--instrument", "ballbar", "--plan",
                        str(path))
    assert code == 2
    assert err.count("\n") == 1 and needle in err and "Traceback" not in err


def test_unreachable_plan_lists_poses_and_checks(tmp_path, capsys):
    path = tmp_path / "far.toml"
    path.write_text(PLAN.replace('fixed_ball = ["0 mm", "0 mm", "0 mm"]', 'fixed_ball = ["900 mm", "0 mm", "0 mm"]'))
    code, _, err = _run(capsys, "calibrate", "identifiability", "felix", "--instrument", "ballbar", "--plan",
                        str(path))
    assert code == 3 and err.count("\n") == 1
    assert "not admissible on felix" in err and "pose " in err and "strut length outside its range" in err


def test_unknown_with_token_and_instrument(capsys):
    code, _, err = _run(capsys, "calibrate", "identifiability", "felix", "--instrument", "tracker", "--with",
                        "fixed-ball")
    assert code == 2 and "set-up parameter of the tracker" in err and err.count("\n") == 1


def test_plan_outside_the_ballbar_range():
    m = pkmstiff.load_machine("felix")
    setup = Setup("ballbar", target=np.zeros(3), fixed_ball=np.zeros(3), bar_length=0.3)
    poses = np.array([[0.3, 0.0, 0.0, 0, 0, 0], [0.3021, 0.0, 0.0, 0, 0, 0]])  # 2.1 mm too long: > ±1 mm
    with pytest.raises(InadmissibleError, match=r"outside its range 300 ± 1 mm, first pose 2"):
        check_plan(m, Plan("p", setup, poses))


def test_singular_setups_are_one_line_errors():
    m = pkmstiff.load_machine("felix")
    setup = Setup("ballbar", target=np.zeros(3), fixed_ball=np.zeros(3), bar_length=0.3)
    with pytest.raises(InadmissibleError, match="moving ball coincides with the fixed ball"):
        identification_jacobian(m, error_model(m), Plan("p", setup, np.zeros((1, 6))))
    # a platform turned so far that the inverse Jacobian is singular (struts in a common plane): the plan check
    # names the singularity
    singular = Plan("p", setup, np.array([[0.3, 0, 0, 0, 0, np.pi / 2]]))
    with pytest.raises(InadmissibleError) as err:
        check_plan(m, singular)
    assert "\n" not in str(err.value) and "singular pose" in str(err.value)
    with pytest.raises(InadmissibleError, match="singular set-up, 1 poses singular on felix"):
        identification_jacobian(m, error_model(m), singular)
    with pytest.raises(InputError, match="fixed-ball position and a positive bar length"):
        Setup("ballbar", target=np.zeros(3))


def test_pose_list_plan_and_concat(tmp_path):
    path = tmp_path / "poses.toml"
    path.write_text("""
[plan]
instrument = "tracker"
[setup]
target = ["0 mm", "0 mm", "-100 mm"]
[[paths]]
kind = "poses"
positions = { value = [[0, 0, 300], [300, 0, 0]], unit = "mm" }
angles = { value = [[0, 0, 0], [0, 10, 0]], unit = "deg" }
""")
    plan = read_plan(path)
    np.testing.assert_allclose(plan.poses[1], [0.3, 0, 0, 0, np.radians(10), 0], rtol=1e-15)
    np.testing.assert_allclose(plan.setup.target, [0, 0, -0.1], rtol=1e-15)
    other = Plan("b", Setup("tracker", target=np.zeros(3)), plan.poses)
    with pytest.raises(InputError, match="same instrument set-up"):
        plan.concat(other)
    assert plan.concat(Plan("c", plan.setup, plan.poses)).n_poses == 4
