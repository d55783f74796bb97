"""Leaving named admissibility checks out (issue 23; spec machines.md §1.7 item 9): the helper, every command
(``--skip-check NAME``), the request, report-spec and sweep-file keys, and that every output states the checks
left out."""

from __future__ import annotations

import json

import numpy as np
import pytest

import pkmstiff
from pkmstiff.admissibility.checks import ALL_CHECKS, CHECK_TEXT, checks_left_out, checks_without, left_out_text
from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.errors import InputError
from pkmstiff.evaluation.requests import PointRequest, SectionRequest

HG = pkmstiff.load_machine("hexaglide")
#: a machine-frame pose on the upper flank of the YZ section that fails only the strut-platform check (the band
#: of machines.md §1.7 item 9: struts 5 and 6 pass next to the hull faces at their own joints)
BAND_POSE = (0.0, 0.0, -0.85, 0.0, 0.0, 0.0)
SKIP = "platform_collision"


def _cli(capsys, *argv: str) -> tuple[int, str, str]:
    from pkmstiff.cli import main

    rc = main(list(argv))
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_the_band_pose_fails_only_the_platform_check():
    a = evaluate_poses(HG, np.array([BAND_POSE])).admissibility
    assert not a.ok[0] and a.reasons[0] == int(a.checks["platform_collision"].reason)
    assert evaluate_poses(HG, np.array([BAND_POSE]), checks=checks_without([SKIP])).ok[0]


def test_checks_without_keeps_the_order_and_rejects_unknown_names():
    assert checks_without() == ALL_CHECKS
    assert checks_without([SKIP, "frame"]) == tuple(c for c in ALL_CHECKS if c not in (SKIP, "frame"))
    assert checks_left_out(checks_without(["drive_load", "frame"])) == ["frame", "drive_load"]
    assert left_out_text([]) == "" and left_out_text(["drive_load", "frame"]).endswith("frame, drive_load")
    with pytest.raises(InputError, match="platform_collision") as exc:
        checks_without(["platform"], "spec.toml", "variants[1].skip_checks")
    assert "spec.toml" in str(exc.value) and "variants[1].skip_checks" in str(exc.value)
    assert set(CHECK_TEXT) == set(ALL_CHECKS)


def test_requests_leave_the_check_out_and_say_so():
    with_check = PointRequest(BAND_POSE, ("kx",), 0.0).evaluate(HG)
    without = PointRequest(BAND_POSE, ("kx",), 0.0, skip_checks=(SKIP,)).evaluate(HG)
    assert not with_check.admissible and with_check.checks_left_out == ()
    assert without.admissible and without.checks_left_out == (SKIP,) and without.values["kx"] > 0
    sec = {"plane": "yz", "at": 0.0, "u_range": (-0.1, 0.2), "v_range": (-0.9, -0.8), "step": 0.05,
           "quantities": ("kx",)}
    a = SectionRequest(**sec).evaluate(HG)
    b = SectionRequest(**sec, skip_checks=(SKIP,)).evaluate(HG)
    # leaving a check out only adds admissible points; values where both are admissible are the same numbers
    assert b.ok.sum() > a.ok.sum() and not (a.ok & ~b.ok).any()
    np.testing.assert_array_equal(a.values["kx"][a.ok], b.values["kx"][a.ok])
    assert b.settings["checks_left_out"] == [SKIP] and a.settings["checks_left_out"] == []
    with pytest.raises(InputError, match="skip_checks"):
        SectionRequest(**sec, skip_checks=("hull",)).evaluate(HG)


def test_cli_pose_and_point(capsys):
    pose = ",".join(f"{v * 1e3:g}" for v in BAND_POSE[:3]) + ",0,0,0"
    rc, out, _ = _cli(capsys, "pose", "hexaglide", "--pose", pose, "--skip-check", SKIP, "--json")
    rep = json.loads(out)
    assert rc == 0 and rep["admissible"] and rep["checks_left_out"] == [SKIP]
    rc, out, _ = _cli(capsys, "pose", "hexaglide", "--pose", pose)
    assert "admissible: NO" in out and "left out" not in out
    rc, out, _ = _cli(capsys, "pose", "hexaglide", "--pose", pose, "--skip-check", SKIP)
    assert "admissible: yes" in out and f"admissibility checks left out: {SKIP}" in out
    rc, out, _ = _cli(capsys, "point", "hexaglide", "--pose", pose, "--modes", "0", "--json")
    assert rc == 3  # inadmissible: refused
    rc, out, _ = _cli(capsys, "point", "hexaglide", "--pose", pose, "--modes", "0", "--skip-check", SKIP, "--json")
    rep = json.loads(out)
    assert rc == 0 and rep["admissible"] and rep["checks_left_out"] == [SKIP]


def test_cli_batches_state_the_checks_in_the_json_beside_the_csv(capsys, tmp_path):
    """The checks left out go to ``<out>.json`` (``pandas.read_csv`` reads the CSV with no options), or to stderr
    when the CSV goes to stdout."""
    import pandas as pd

    f = tmp_path / "poses.csv"
    f.write_text("x,y,z,a,b,c\n0,0,-850,0,0,0\n")
    for cmd in ("pose", "point"):
        rc, out, err = _cli(capsys, cmd, "hexaglide", "--poses", str(f), "--skip-check", SKIP)
        lines = out.splitlines()
        assert rc == 0 and f"admissibility checks left out: {SKIP}" in err and not out.startswith("#")
        assert lines[1].split(",")[lines[0].split(",").index("admissible")] == "True"
        csv_out = tmp_path / f"{cmd}.csv"
        rc, _, _ = _cli(capsys, cmd, "hexaglide", "--poses", str(f), "--skip-check", SKIP, "--out", str(csv_out))
        table = pd.read_csv(csv_out)
        assert rc == 0 and list(table.columns[:6]) == ["x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg"]
        assert bool(table["admissible"].iloc[0]) and table["z_mm"].iloc[0] == -850
        assert json.loads(csv_out.with_suffix(".json").read_text())["checks_left_out"] == [SKIP]


def test_cli_section_states_the_checks_left_out(capsys):
    args = ("section", "hexaglide", "--plane", "yz", "--range", "y=-100:200,z=-900:-800", "--step", "50",
            "--tool-length", "0", "--neglect-spindle", "--quantities", "kx,kz", "--quiet")
    rc, out, _ = _cli(capsys, *args, "--json")
    base = json.loads(out)
    rc, out, _ = _cli(capsys, *args, "--skip-check", SKIP, "--json")
    rep = json.loads(out)
    assert rc == 0 and rep["checks_left_out"] == [SKIP] and base["checks_left_out"] == []
    assert rep["admissible_points"] > base["admissible_points"]
    assert "PLATFORM_COLLISION" in base["inadmissible_reasons"] and "PLATFORM_COLLISION" not in \
        rep["inadmissible_reasons"]
    rc, out, _ = _cli(capsys, *args, "--skip-check", SKIP)
    assert rc == 0 and f"admissibility checks left out: {SKIP}" in out.splitlines()[0]


def test_cli_section_files_state_the_checks_left_out(capsys, tmp_path):
    rc, _, _ = _cli(capsys, "section", "hexaglide", "--range", "y=-100:200,z=-900:-800", "--step", "50",
                    "--quantities", "kappa", "--skip-check", SKIP, "--skip-check", "drive_load", "--quiet",
                    "--out", str(tmp_path), "--formats", "csv")
    assert rc == 0
    settings = json.loads((tmp_path / "hexaglide_yz.json").read_text())["settings"]  # the CSV's metadata
    assert settings["checks_left_out"] == [SKIP, "drive_load"] and SKIP not in settings["checks"]
    stats = json.loads((tmp_path / "hexaglide_yz_statistics.json").read_text())
    assert stats["checks_left_out"] == [SKIP, "drive_load"]


def test_cli_workspace_and_rotation_map(capsys):
    rc, out, _ = _cli(capsys, "workspace", "hexaglide", "--resolution", "100", "--skip-check", SKIP, "--json",
                      "--quiet")
    rep = json.loads(out)
    assert rc == 0 and rep["settings"]["checks_left_out"] == [SKIP]
    rc, out, _ = _cli(capsys, "rotation-map", "hexaglide", "--plane", "yz", "--u-range", "-100,200",
                      "--v-range", "-900,-800", "--step", "50", "--directions", "+a", "--increment", "5",
                      "--skip-check", SKIP, "--json")
    rep = json.loads(out)
    assert rc == 0 and rep["settings"]["checks_left_out"] == [SKIP]
    rc, out, _ = _cli(capsys, "rotation-map", "hexaglide", "--point", "0,0,-850", "--directions", "+a",
                      "--step", "30", "--increment", "5", "--skip-check", SKIP, "--json")
    assert rc == 0 and json.loads(out)["settings"]["checks_left_out"] == [SKIP]


@pytest.mark.parametrize("cmd", [("pose", "hexaglide", "--pose", "0,0,-900,0,0,0"),
                                 ("point", "hexaglide", "--pose", "0,0,-900,0,0,0"),
                                 ("section", "hexaglide", "--range", "y=0:100,z=-900:-800"),
                                 ("workspace", "hexaglide", "--resolution", "100"),
                                 ("rotation-map", "hexaglide", "--point", "0,0,-900")])
def test_unknown_check_name_is_one_line_exit_2(capsys, cmd):
    rc, out, err = _cli(capsys, *cmd, "--skip-check", "platform")
    assert rc == 2 and not out
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "platform" in lines[0] and all(c in lines[0] for c in ALL_CHECKS)


def test_quantities_lists_the_check_names(capsys):
    rc, out, _ = _cli(capsys, "quantities")
    listed = out.split("admissibility checks", 1)[1]
    assert rc == 0 and all(f"\n{c} " in listed for c in ALL_CHECKS)


def test_schemas_name_the_checks():
    from importlib.resources import files

    for name in ("pose", "point"):
        schema = json.loads((files("pkmstiff") / "schemas" / f"{name}.schema.json").read_text())
        assert tuple(schema["properties"]["checks_left_out"]["items"]["enum"]) == ALL_CHECKS


def test_report_spec_variant_key(tmp_path):
    from pkmstiff.errors import PkmstiffError
    from pkmstiff.report.build import build_report
    from pkmstiff.report.spec import load_spec

    f = tmp_path / "s.toml"
    base = ('[report]\ntitle = "t"\n[[variants]]\nname = "a"\nmachine = "hexaglide"\nskip_checks = %s\n'
            '[[points]]\npose = [0, 0, -850, 0, 0, 0]\nquantities = ["kx"]\ntool_length_mm = 0\n')
    f.write_text(base % f'["{SKIP}"]')
    spec = load_spec(f)
    assert spec.variants[0].skip_checks == (SKIP,)
    rep = build_report(spec, tmp_path / "out")
    assert rep.settings["variant a"]["checks_left_out"] == [SKIP]
    assert f"admissibility checks left out: {SKIP}" in "\n".join(s.text for s in rep.sections)
    row = next(r for t in rep.sections[0].tables for r in t.rows if r.label.startswith("kx"))
    assert row.values[0] is not None and row.values[0] > 0  # admissible once the check is left out
    f.write_text(base % '["hull"]')
    with pytest.raises(PkmstiffError, match=r"variants\[1\]\.skip_checks.*platform_collision"):
        load_spec(f)


def test_sweep_file_key(tmp_path):
    from pkmstiff.errors import SweepFileError
    from pkmstiff.report.sweep_file import load_sweep

    f = tmp_path / "s.toml"
    base = ('[sweep]\nmachine = "hexaglide"\n[[parameters]]\npath = "components.strut_950.k"\nunit = "N/um"\n'
            'values = [344]\n[[evaluations]]\nkind = "point"\npose = [0, 0, -850, 0, 0, 0]\nquantities = ["kx"]\n'
            'tool_length_mm = 0\nskip_checks = %s\n')
    f.write_text(base % f'["{SKIP}"]')
    sw = load_sweep(f)
    assert sw.evaluation.skip_checks == (SKIP,) and SKIP in repr(sw.evaluation)
    assert sw.evaluation(HG)["kx [N/um]"] > 0
    f.write_text(base % '["hull"]')
    with pytest.raises(SweepFileError, match="skip_checks"):
        load_sweep(f)
    for kind, extra in (("section", 'range = "y=-100:200,z=-900:-800"\nstep_mm = 50\nquantities = ["kx"]\n'),
                        ("workspace", "resolution_mm = 100\n")):
        f.write_text(base.split("[[evaluations]]")[0]
                     + f'[[evaluations]]\nkind = "{kind}"\n{extra}skip_checks = ["{SKIP}"]\n')
        assert load_sweep(f).evaluation.skip_checks == (SKIP,)


def test_cli_section_window_fits_the_region_without_the_check(capsys):
    """Without --range the window is fitted to the region of the checks applied: without the static drive-load check
    the middle band of the upper boundary reaches up to the drive-joint plane (docs/user-guide/validation-hexaglide.md),
    far above the window of all checks; the fitted window still holds the whole region (no admissible point on its
    edge)."""
    args = ("section", "hexaglide", "--step", "50", "--quantities", "kappa", "--json", "--quiet")
    rc, out, _ = _cli(capsys, *args)
    base = json.loads(out)
    rc, out, _ = _cli(capsys, *args, "--skip-check", "drive_load")
    rep = json.loads(out)
    assert rc == 0 and rep["window_fitted_to_workspace"] and rep["window_touches_admissible_region"] == []
    assert rep["window_mm"]["z"][1] > base["window_mm"]["z"][1] + 100  # mm: the band reaches higher
    assert "DRIVE_LOAD" not in rep["inadmissible_reasons"]
