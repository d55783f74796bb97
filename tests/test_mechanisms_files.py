"""Mechanism files: bundled files load, inconsistent joints give one-line errors naming the joint; CLI."""

from __future__ import annotations

import json

import pytest

import pkmstiff.mechanisms as mm
from pkmstiff.cli import main
from pkmstiff.errors import InputError

BASE = """
format_version = 1
[mechanism]
name = "t"
dimension = 2
links = ["0", "1", "2", "3"]
ground = "0"
[[joints]]
name = "A"
type = "revolute"
links = ["0", "1"]
point = [0.04, 0.02]
[[joints]]
name = "B"
type = "revolute"
links = ["1", "2"]
point = [0.07, 0.07]
[[joints]]
name = "C"
type = "revolute"
links = ["2", "3"]
point = [0.115, 0.055]
[[joints]]
name = "slider"
type = "prismatic"
links = ["0", "3"]
point = [0.115, 0.02]
axis = [1, 0]
drive = "s"
"""


def _write(tmp_path, text):
    p = tmp_path / "m.toml"
    p.write_text(text)
    return p


def _error(tmp_path, text) -> str:
    with pytest.raises(InputError) as ei:
        mm.load_mechanism(_write(tmp_path, text))
    msg = str(ei.value)
    assert "\n" not in msg  # one line
    return msg


def test_bundled_mechanisms_load():
    names = mm.bundled_mechanisms()
    assert {"slider_crank", "five_bar", "hybrid_tripod_wrist", "hexaglide_generic", "hexapod_6x_generic",
            "hexapod_6ups", "hexa_6rus", "biglide_generic", "bipod_generic"} <= set(names)
    mob = {n: mm.info(mm.load_mechanism(n)).mobility for n in names}
    assert mob == {"slider_crank": 1, "five_bar": 2, "hybrid_tripod_wrist": 5, "hexaglide_generic": 6,
                   "hexapod_6x_generic": 6, "hexapod_6ups": 6, "hexa_6rus": 6, "biglide_generic": 2,
                   "bipod_generic": 2}


def test_valid_base_file(tmp_path):
    assert mm.info(mm.load_mechanism(_write(tmp_path, BASE))).mobility == 1


def test_unknown_link_names_the_joint(tmp_path):
    msg = _error(tmp_path, BASE.replace('links = ["2", "3"]', 'links = ["2", "4"]'))
    assert "joints[2] (C).links" in msg and "unknown link '4'" in msg


def test_unconnected_link_names_a_joint(tmp_path):
    text = BASE.replace('links = ["0", "1", "2", "3"]', 'links = ["0", "1", "2", "3", "4", "5"]') + """
[[joints]]
name = "island"
type = "revolute"
links = ["4", "5"]
point = [0.3, 0.3]
"""
    msg = _error(tmp_path, text)
    assert "not connected" in msg and "joint 'island'" in msg


def test_overconstrained_rigid_structure_names_the_joint(tmp_path):
    text = BASE + """
[[joints]]
name = "extra_pin"
type = "revolute"
links = ["1", "0"]
point = [0.07, 0.07]
"""
    msg = _error(tmp_path, text)
    assert "joint 'extra_pin'" in msg and "over-constrained" in msg


def test_cardan_axes_must_be_perpendicular(tmp_path):
    text = """
[mechanism]
name = "c"
links = ["g", "a"]
[[joints]]
name = "u"
type = "cardan"
links = ["g", "a"]
point = [0, 0, 0]
axes = [[1, 0, 0], [1, 1, 0]]
"""
    msg = _error(tmp_path, text)
    assert "joints[0] (u).axes" in msg and "perpendicular" in msg


@pytest.mark.parametrize("patch, key", [
    (('type = "prismatic"', 'type = "screw"'), "joints[3] (slider).type"),
    (('point = [0.04, 0.02]', 'point = [0.04]'), "joints[0] (A).point"),
    (('drive = "s"', 'drive = { name = "s", offset = "3 kg" }'), "joints[3] (slider).drive.offset"),
])
def test_bad_values_name_file_and_key(tmp_path, patch, key):
    assert key in _error(tmp_path, BASE.replace(*patch))


def test_cli_range_json(capsys):
    assert main(["mechanism", "range", "slider_crank", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    s = rep["drives"]["s"]
    assert s["unit"] == "mm" and s["min"] < -174 and 24 < s["max"] < 25  # dead centres -174.78 / 24.78 mm


def test_cli_solve_and_info(capsys):
    # one drive set without a solution: the results are printed, the exit status is 3 (as for an inadmissible pose)
    assert main(["mechanism", "solve", "slider_crank", "--drives", "10", "--drives", "40", "--json"]) == 3
    out, err = capsys.readouterr()
    rep = json.loads(out)
    assert [r["status"] for r in rep["results"]] == ["converged", "no_solution"]
    assert "no solution for 1 of 2 drive sets" in err and len(err.strip().splitlines()) == 1
    assert abs(rep["results"][0]["pose"]["x_mm"] - 125.0) < 1e-9  # slider point moves with the drive
    assert main(["mechanism", "info", "hybrid_tripod_wrist", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["mobility"] == 5
    assert main(["mechanism", "solve", "hybrid_tripod_wrist", "--pose", "0,100,-1073.205,10,0,0", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)["results"][0]
    assert r["status"] == "converged" and r["admissible"]


def test_cli_errors_are_one_line(capsys):
    assert main(["mechanism", "info", "no_such_mechanism"]) == 2
    assert main(["mechanism", "solve", "slider_crank", "--drives", "1,2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(line.startswith("pkmstiff mechanism: error:") for line in err)


def test_is_mechanism(tmp_path):
    assert mm.is_mechanism("slider_crank") and not mm.is_mechanism("hexaglide")
    assert mm.is_mechanism(_write(tmp_path, BASE))
    other = tmp_path / "machine.toml"
    other.write_text("[machine]\nname = 'x'\n")
    assert not mm.is_mechanism(other)
