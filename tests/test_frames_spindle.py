"""Report frame, K_U switch and the evidence-based Hexaglide readings (issue 13; spec machines.md §1.7,
models.md §6.1 eq. 4.75 note)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import pkmstiff
from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.analysis import evaluate_structure
from pkmstiff.errors import InputError
from pkmstiff.evaluation.requests import PointRequest, SectionRequest
from pkmstiff.machine.frames import (NEGLECT_SPINDLE_NOTE, frame_metadata, from_machine_frame, neglect_spindle,
                                     spindle_neglected, to_machine_frame)
from pkmstiff.machine.roles import drive_load_data, machine_components
from pkmstiff.structure import StructureOptions

HG = pkmstiff.load_machine("hexaglide")
MIDDLE_GUIDE = {"hexaglide": 0.400, "hexaglide_v1": 0.353, "hexaglide_v2": 0.722}  # machines.md §1.7 item 2


@pytest.mark.parametrize("name,y", sorted(MIDDLE_GUIDE.items()))
def test_report_origin_is_the_middle_guide(name, y):
    m = pkmstiff.load_machine(name)
    np.testing.assert_array_equal(m.report_origin, [0.0, y, 0.0])
    md = frame_metadata(m, "report")
    assert md["frame"] == "report" and md["frame_origin_mm"] == pytest.approx([0.0, 1e3 * y, 0.0])
    assert frame_metadata(m, "machine")["frame_origin_mm"] == [0.0, 0.0, 0.0]


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-5, 5, allow_nan=False), min_size=6, max_size=6))
def test_frame_round_trip(pose):
    """to/from the machine frame are inverse translations of the position; angles unchanged (exact up to one
    rounding of the addition: 1e-15 m)."""
    x = np.array(pose)
    xm = to_machine_frame(HG, x, "report")
    np.testing.assert_allclose(xm[:3] - x[:3], HG.report_origin, atol=1e-14)
    np.testing.assert_array_equal(xm[3:], x[3:])
    np.testing.assert_allclose(from_machine_frame(HG, xm, "report"), x, atol=1e-14)
    np.testing.assert_array_equal(to_machine_frame(HG, x, "machine"), x)


def test_unknown_frame_is_an_input_error():
    with pytest.raises(InputError, match="frame"):
        to_machine_frame(HG, np.zeros(3), "table")
    with pytest.raises(InputError):
        PointRequest((0, 0, -1, 0, 0, 0), ("kappa",), frame="bed").evaluate(HG)


def test_point_request_in_the_report_frame_equals_the_machine_frame():
    rep = PointRequest((0.0, 0.0, -1.0, 0.0, 0.0, 0.0), ("kx", "U"), 0.0, frame="report").evaluate(HG)
    mac = PointRequest((0.0, 0.4, -1.0, 0.0, 0.0, 0.0), ("kx", "U"), 0.0).evaluate(HG)
    assert rep.admissible and rep.values == mac.values  # same pose: identical numbers
    assert rep.pose_machine[:3] == pytest.approx((0.0, 0.4, -1.0), abs=1e-15) and rep.frame == "report"


def test_section_in_the_report_frame_is_the_shifted_machine_section():
    a = SectionRequest("yz", 0.0, (-0.3, 0.3), (-1.1, -0.7), 0.1, ("U",), frame="report").evaluate(HG)
    b = SectionRequest("yz", 0.0, (0.1, 0.7), (-1.1, -0.7), 0.1, ("U",)).evaluate(HG)
    np.testing.assert_array_equal(a.ok, b.ok)
    # raster positions differ by one rounding of the origin shift (1e-16 m): U equal to 1e-12 relative
    np.testing.assert_allclose(a.values["U"], b.values["U"], rtol=1e-12)
    assert a.metadata()["frame"] == "report" and "report frame" in a.metadata()["note"]


def test_neglect_spindle_equals_rigid_k_u_load_on_the_platform():
    """Dropping the platform_spindle role gives the same TCP stiffness and frequencies as loading the platform
    (K_U rigid, spec models.md §5.1 option); same assembly, round-off only (1e-9)."""
    x = to_machine_frame(HG, np.array([[0, 0, -1.0, 0, 0, 0], [0.1, 0.1, -0.9, 0.05, 0, 0]]), "report")
    for tl in (0.0, 0.15):
        a = evaluate_structure(HG, x, tool_length=tl, n_modes=3, options=StructureOptions(load_platform=True))
        b = evaluate_structure(neglect_spindle(HG), x, tool_length=tl, n_modes=3)
        np.testing.assert_allclose(b.stiffness, a.stiffness, rtol=1e-9)
        np.testing.assert_allclose(b.frequencies_hz, a.frequencies_hz, rtol=1e-9)
    m = neglect_spindle(HG)
    assert spindle_neglected(m) and not spindle_neglected(HG) and m.spindle_neglected and not HG.spindle_neglected
    # a typed field, not text in the title: the title stays the file's, the displayed title says so
    assert m.title == HG.title and m.display_title == f"{HG.title} [{NEGLECT_SPINDLE_NOTE}]"
    assert HG.display_title == HG.title
    assert machine_components(m).platform_spindle is None
    assert neglect_spindle(HG, False) is HG


def test_k_u_in_series_along_the_tool_axis():
    """A z force on the tool axis exerts no moment about O' (a = b = c = 0): 1/k_z(K_U) = 1/k_z(no K_U) + 1/588
    N/um (K_U z entry, machines.md §1.4); closed form, round-off only."""
    x = to_machine_frame(HG, np.array([[0, 0, -1.0, 0, 0, 0]]), "report")
    kz = evaluate_structure(HG, x, tool_length=0.0, n_modes=0).stiffness[0, 2] / 1e6
    kz0 = evaluate_structure(neglect_spindle(HG), x, tool_length=0.0, n_modes=0).stiffness[0, 2] / 1e6
    assert 1 / kz == pytest.approx(1 / kz0 + 1 / 588.0, rel=1e-9)


def test_drive_load_carries_platform_and_struts():
    """B.13 moved mass = 117.24 kg + six struts 2 x 12.13 + 4 x 11.52 kg (machines.md §1.7 item 5); the static drive
    loads scale with the moved mass (CoG at O'): ratio exact up to round-off."""
    d = drive_load_data(HG)
    assert d.moved_mass == pytest.approx(117.24 + 2 * 12.13 + 4 * 11.52, rel=1e-12)
    old = pkmstiff.load_machine("hexaglide:drive_load_platform_only")
    assert drive_load_data(old).moved_mass == pytest.approx(117.24, rel=1e-12)
    x = to_machine_frame(HG, np.array([[0, 0, -1.0, 0, 0, 0], [0.2, 0.1, -0.8, 0, 0, 0]]), "report")
    a, b = evaluate_poses(HG, x).drive_loads, evaluate_poses(old, x).drive_loads
    np.testing.assert_allclose(a, b * d.moved_mass / 117.24, rtol=1e-10)


def test_transmission_quality_forms():
    """U = kappa^-1/2 by default, 1/kappa with option transmission_inverse_kappa (models.md §6.1 note)."""
    x = to_machine_frame(HG, np.array([[0, 0, -1.0, 0, 0, 0], [0.1, 0.2, -0.9, 0, 0, 0]]), "report")
    u = PointRequest(tuple(x[0]), ("U",)).evaluate(HG).values["U"]
    inv = pkmstiff.load_machine("hexaglide:transmission_inverse_kappa")
    u1 = PointRequest(tuple(x[0]), ("U",)).evaluate(inv).values["U"]
    assert u == pytest.approx(np.sqrt(u1), rel=1e-12) and 0 < u1 < u < 1


def test_previous_readings_are_options():
    m = pkmstiff.load_machine("hexaglide")
    np.testing.assert_allclose(m.chains.drive_axis, np.tile([0.0, 0.0, -1.0], (6, 1)))
    assert np.isneginf(m.limits.position_min[2]) and m.limits.position_max[2] == pytest.approx(-0.15)
    p = pkmstiff.load_machine("hexaglide:printed_values")
    np.testing.assert_allclose(p.chains.drive_axis, np.tile([-1.0, 0.0, 0.0], (6, 1)))
    old = pkmstiff.load_machine("hexaglide:previous_readings")
    assert old.transmission_form == "inverse_kappa" and old.limits.drive_load_strut_mass == 0.0
    assert old.limits.position_min[2] == pytest.approx(-1.1) and old.limits.position_max[2] == pytest.approx(-0.34)
    # variants inherit the corrected axes; variant 1 keeps its own printed m'_6 in printed_values
    v1 = pkmstiff.load_machine("hexaglide_v1:printed_values")
    np.testing.assert_allclose(v1.chains.drive_axis[:, 0], -1.0)
    np.testing.assert_allclose(v1.chains.platform_axis[5, :2], np.array([0.430, -0.903]) / np.hypot(0.430, 0.903))
    for key in ("chains[*].drive_axis", "machine.report_origin", "limits.drive_load_strut_mass",
                "machine.transmission_form", "limits.frame.z_min"):
        assert key in m.assumptions and "\n" not in m.assumptions[key]


def test_bad_machine_keys(tmp_path):
    from pkmstiff.errors import MachineFileError

    for extra, key in (('[machine]\ntransmission_form = "sqrt"', "transmission_form"),
                       ('[limits]\ndrive_load_strut_mass = 2.0', "drive_load_strut_mass")):
        f = tmp_path / "m.toml"
        head, table = extra.split("\n")
        sect = "machine" if "machine" in head else "limits"
        text = f'format_version = 1\n[machine]\nname = "x"\nextends = "hexaglide"\n'
        text += (table + "\n") if sect == "machine" else f"[limits]\n{table}\n"
        f.write_text(text)
        with pytest.raises(MachineFileError, match=key):
            pkmstiff.load_machine(f)


def test_cli_frame_and_spindle_options(capsys):
    from pkmstiff.cli import main

    assert main(["pose", "hexaglide", "--pose", "0,0,-900,0,0,0", "--frame", "report", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["admissible"] and rep["frame"] == "report" and rep["pose_machine_frame"]["y_mm"] == pytest.approx(400)
    assert main(["point", "hexaglide", "--pose", "0,0,-1000,0,0,0", "--frame", "report", "--neglect-spindle",
                 "--tool-length", "0", "--modes", "0", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["neglect_spindle"] and rep["frame_origin_mm"] == pytest.approx([0, 400, 0])
    assert main(["section", "hexaglide", "--frame", "report", "--range", "y=-100:100,z=-1000:-900", "--step", "100",
                 "--quantities", "kx", "--tool-length", "0", "--neglect-spindle", "--json", "--quiet"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["frame"] == "report" and rep["neglect_spindle"] and rep["admissible_points"] > 0
    # argparse rejects an unknown frame (choices): one error line, exit status 2
    assert main(["section", "hexaglide", "--frame", "bed", "--range", "y=0:1,z=-1:0"]) == 2


def test_report_spec_frame_key(tmp_path):
    from pkmstiff.errors import PkmstiffError
    from pkmstiff.report.spec import load_spec

    f = tmp_path / "s.toml"
    base = ('[report]\ntitle = "t"\nframe = "%s"\n[[variants]]\nname = "a"\nmachine = "hexaglide"\n'
            'neglect_spindle = true\n[[points]]\npose = [0, 0, -1000, 0, 0, 0]\nquantities = ["kx"]\n')
    f.write_text(base % "report")
    spec = load_spec(f)
    assert spec.frame == "report" and spec.variants[0].neglect_spindle
    f.write_text(base % "table")
    with pytest.raises(PkmstiffError, match="report.frame"):
        load_spec(f)


def test_drive_mass_holds_the_strut_share():
    """machines.md §1.7 item 10: by default the structure model adds no strut mass (drive 102.17 kg, platform
    117.24 kg as printed, eq. 3.10/3.11); option strut_mass_split adds half of each strut at either joint; an explicit
    StructureOptions share overrides the machine's (that fraction at the drive, the rest at the platform)."""
    from pkmstiff.structure import StructureOptions, structure_layout

    struts = np.array([12.13, 12.13, 11.52, 11.52, 11.52, 11.52])
    lay = structure_layout(HG)
    assert HG.strut_mass_shares == (0.0, 0.0)
    np.testing.assert_allclose(lay.drive_mass, 102.17, rtol=1e-12)
    assert lay.platform.mass == pytest.approx(117.24, rel=1e-12)
    split = pkmstiff.load_machine("hexaglide:strut_mass_split")
    lay2 = structure_layout(split)
    np.testing.assert_allclose(lay2.drive_mass, 102.17 + 0.5 * struts, rtol=1e-12)
    assert lay2.platform.mass == pytest.approx(117.24 + 0.5 * struts.sum(), rel=1e-12)
    lay3 = structure_layout(HG, StructureOptions(strut_mass_to_drive=1.0))
    np.testing.assert_allclose(lay3.drive_mass, 102.17 + struts, rtol=1e-12)
    assert lay3.platform.mass == pytest.approx(117.24, rel=1e-12)
    assert pkmstiff.load_machine("hexaglide:previous_readings").strut_mass_shares == (0.5, 0.5)
    assert pkmstiff.load_machine("hexaglide_v1").strut_mass_shares == (0.0, 0.0)  # inherited
    assert pkmstiff.load_machine("hexapod_6x").strut_mass_shares == (0.5, 0.5)  # other machines unchanged
    assert "machine.strut_mass_shares" in HG.assumptions and "\n" not in HG.assumptions["machine.strut_mass_shares"]
    # lighter moving masses: every frequency at the Table 5.8 pose rises, the stiffness is unchanged
    x = to_machine_frame(HG, np.array([[0, 0, -1.0, 0, 0, 0]]), "report")
    a = evaluate_structure(neglect_spindle(HG), x, tool_length=0.0, n_modes=3)
    b = evaluate_structure(neglect_spindle(split), x, tool_length=0.0, n_modes=3)
    assert np.all(a.frequencies_hz > b.frequencies_hz)
    # the strut point masses move the platform's CoG (its reference point): same stiffness up to round-off
    np.testing.assert_allclose(a.stiffness, b.stiffness, rtol=1e-9)


@pytest.mark.parametrize("shares", ["{ drive = 0.6, platform = 0.6 }", "{ drive = -0.1, platform = 0.0 }",
                                    "{ drive = 0.5, rest = 0.5 }", "0.5"])
def test_bad_strut_mass_shares(tmp_path, shares):
    from pkmstiff.errors import MachineFileError

    f = tmp_path / "m.toml"
    f.write_text(f'format_version = 1\n[machine]\nname = "x"\nextends = "hexaglide"\nstrut_mass_shares = {shares}\n')
    with pytest.raises(MachineFileError, match="strut_mass_shares"):
        pkmstiff.load_machine(f)
