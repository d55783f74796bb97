"""Every CLI command against the classes of bad input of issue 12 (item 4).

For each case: exit status 2 (or 3 for a refused inadmissible pose), exactly one error line on stderr that names the
problem, no traceback, and nothing written (the working directory is unchanged). A command without a case here fails
:func:`test_every_command_has_fuzz_cases`, so a new command must add its own.
"""

from __future__ import annotations

import io
import os
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from pkmstiff.cli import _value_options, build_parser, join_negative_values, main
from pkmstiff.machine.loader import bundled_machine_dir
from tests.calibration_plans import ONE_CIRCLE_PLAN

HEX = str(bundled_machine_dir() / "hexaglide.toml")
POSE = "0,0,-1000,0,0,0"
SPEC = "studies/specs/hexaglide_variants.toml"
SWEEP = "studies/sweeps/hexaglide_strut_sweep.toml"
JOINT = "pkmstiff/fe/params/iwf_3dof_improved.toml"
PLATFORM = "pkmstiff/fe/params/hexaglide_platform.toml"
ROOT = Path(__file__).resolve().parents[1]

# (argv, exit status, text the error line must contain); placeholders in braces are files made by ``bad_files``.
CASES: dict[str, list[tuple[list[str], int, str]]] = {
    "components": [
        (["components", "no_such_model"], 2, "no_such_model"),
        (["components", "--bogus"], 2, "--bogus"),
    ],
    "machines": [
        (["machines", "no_such_machine"], 2, "no_such_machine"),
        (["machines", "{nonutf8}"], 2, "UTF-8"),
        (["machines", "{v7}"], 2, "format_version"),
        (["machines", "{absurd}"], 2, "plausible"),
    ],
    "app": [  # every refusal comes before the server starts
        (["app", "no_such_machine", "--no-browser"], 2, "no_such_machine"),
        (["app", "{nonutf8}", "--no-browser"], 2, "UTF-8"),
        (["app", "hexaglide:no_such_option", "--no-browser"], 2, "no_such_option"),
        (["app", "hexaglide", "--port", "70000", "--no-browser"], 2, "--port"),
        (["app", "hexaglide", "--out", "{file}", "--no-browser"], 2, "--out"),
    ],
    "demo": [
        (["demo", "--step", "0"], 2, "--step"),
        (["demo", "--step", "-5"], 2, "--step"),
        (["demo", "--out", "{file}"], 2, "--out"),
        (["demo", "--out", "{file}/sub"], 2, "--out"),
    ],
    "pose": [
        (["pose", "hexaglide", "--pose", "1,2"], 2, "six"),
        (["pose", "hexaglide", "--pose", "nan,0,-1000,0,0,0"], 2, "finite"),
        (["pose", "hexaglide", "--pose", "1e400,0,-1000,0,0,0"], 2, "finite"),
        (["pose", "{nonutf8}", "--pose", POSE], 2, "UTF-8"),
        (["pose", "{v7}", "--pose", POSE], 2, "format_version"),
        (["pose", "{absurd}", "--pose", POSE], 2, "plausible"),
        (["pose", "no_such_machine", "--pose", POSE], 2, "no_such_machine"),
        (["pose", "hexaglide"], 2, "--pose"),
        (["pose", "slider_crank", "--pose", "1,2"], 2, "--pose"),
        (["pose", "hybrid_tripod_wrist", "--pose", "0,0,nan,0,0,0"], 2, "--pose"),
        (["pose", "hybrid_tripod_wrist", "--poses", "{poses}"], 2, "--poses"),
        (["pose", "hexaglide", "--poses", "{nonutf8}"], 2, "UTF-8"),
        (["pose", "hexaglide", "--poses", "missing.csv"], 2, "missing.csv"),
        (["pose", "hexaglide", "--poses", "{poses}", "--out", "{dir}"], 2, "--out"),
        (["pose", "hexaglide", "--poses", "{poses}", "--out", "{existing_csv}"], 2, "--force"),
    ],
    "point": [
        # issue 22, faults 5: estimates before the work (budget fixed at 4 GB by the fixture)
        (["point", "hexaglide", "--poses", "{poses_2m}"], 2, "--poses: poses_2m.csv: 2,000,001 pose rows need"),
        (["point", "hexaglide", "--pose", "2000,0,-1000,0,0,0"], 3, "chain 1"),
        (["point", "hexaglide", "--pose", "0,0,-900,0,0,0"], 3, "collision"),
        (["point", "hexaglide", "--pose", "-100,300,-1000"], 2, "six"),
        (["point", "hexaglide", "--pose", POSE, "--modes", "-1"], 2, "--modes"),
        (["point", "hexaglide", "--pose", POSE, "--tool-length", "-5"], 2, "--tool-length"),
        (["point", "hexaglide", "--pose", POSE, "--figures", "{file}"], 2, "--figures"),
        (["point", "{nonutf8}", "--pose", POSE], 2, "UTF-8"),
        (["point", "{v7}", "--pose", POSE], 2, "format_version"),
        (["point", "hexaglide", "--poses", "{nonutf8}"], 2, "UTF-8"),
        (["point", "hexaglide", "--pose", POSE, "--modes", "two"], 2, "--modes"),
    ],
    "section": [
        (["section", "hexaglide", "--step", "0"], 2, "--step"),
        (["section", "hexaglide", "--step", "1e-6"], 2, "memory budget"),
        (["section", "hexaglide", "--jobs", "0"], 2, "--jobs"),
        (["section", "hexaglide", "--jobs", "1000"], 2, "--jobs"),
        (["section", "hexaglide", "--quantities", "tilt_drive_7"], 2, "tilt_drive_7"),
        (["section", "hexaglide", "--quantities", "no_such_quantity"], 2, "no_such_quantity"),
        (["section", "hexaglide", "--range", "y=5:1,z=-1200:-500"], 2, "--range"),
        (["section", "hexaglide", "--formats", "gif"], 2, "--formats"),
        (["section", "hexaglide", "--require", "U>>0.2"], 2, "--require"),
        (["section", "hexaglide", "--out", "{file}"], 2, "--out"),
        (["section", "hexaglide", "--out", "{section_out}", "--quantities", "kx"], 2, "--force"),
        (["section", "{nonutf8}"], 2, "UTF-8"),
        (["section", "hexaglide", "--orientation", "0,0"], 2, "--orientation"),
        (["section", "slider_crank", "--plane", "yz"], 2, "--plane"),
        (["section", "hybrid_tripod_wrist", "--quantities", "vmax_x"], 2, "vmax_x"),
        (["section", "hybrid_tripod_wrist", "--tool-length", "-5"], 2, "--tool-length"),
        (["section", "five_bar", "--plane", "xy", "--tool-length", "100"], 2, "--tool-length"),  # planar: no axis
        (["section", "hybrid_tripod_wrist", "--plane", "xy", "--range", "x=-10:10,y=0:10", "--step", "1e-4"], 2,
         "--step"),
        (["section", "hybrid_tripod_wrist", "--plane", "xy", "--range", "x=5:1,y=0:10"], 2, "--range"),
        (["section", "hybrid_tripod_wrist", "--formats", "gif"], 2, "--formats"),
        (["section", "hybrid_tripod_wrist", "--out", "{file}"], 2, "--out"),
    ],
    "quantities": [
        (["quantities", "--bogus"], 2, "--bogus"),
    ],
    "workspace": [
        (["workspace", "hexaglide", "--resolution", "0"], 2, "--resolution"),
        (["workspace", "hexaglide", "--resolution", "0.01"], 2, "memory budget"),
        (["workspace", "hexaglide", "--resolution", "20", "--refine", "-1"], 2, "--refine"),
        (["workspace", "hexaglide", "--resolution", "20", "--out", "{file}"], 2, "--out"),
        (["workspace", "hexaglide", "--resolution", "20", "--require", "nosuch>=1"], 2, "nosuch"),
        (["workspace", "hexaglide", "--resolution", "20", "--range", "q,1,2"], 2, "--range"),
        (["workspace", "{nonutf8}", "--resolution", "20"], 2, "UTF-8"),
    ],
    "rotation-map": [
        (["rotation-map", "hexaglide", "--range", "y=-200:800,z=-1200:-500", "--step", "50", "--increment", "1e-7"],
         2, "--increment"),
        (["rotation-map", "hexaglide", "--range", "y=-200:800,z=-1200:-500", "--step", "50", "--increment", "1e-7",
          "--verify"], 2, "memory budget"),
        (["rotation-map", "hexaglide", "--increment", "0"], 2, "--increment"),
        (["rotation-map", "hexaglide", "--out", "{file}"], 2, "--out"),
        (["rotation-map", "hexaglide", "--directions", "+q", "--u-range", "-100,100", "--v-range", "-1000,-900"],
         2, "--directions"),
        (["rotation-map", "{nonutf8}"], 2, "UTF-8"),
    ],
    "report": [
        (["report", "{report_fine_section}", "--out", "rep"], 2, "memory budget"),
        (["report", "{report_fine_workspace}", "--out", "rep"], 2, "memory budget"),
        (["report", "{nonutf8}", "--out", "rep"], 2, "UTF-8"),
        (["report", "missing.toml", "--out", "rep"], 2, "missing.toml"),
        (["report", SPEC, "--out", "{file}"], 2, "--out"),
        (["report", SPEC, "--out", "rep", "--jobs", "0"], 2, "--jobs"),
    ],
    "sweep": [
        (["sweep", "{huge_sweep}", "--out", "r.csv"], 2, "parameters (values per parameter)"),
        (["sweep", "{fine_section_sweep}", "--out", "r.csv"], 2, "evaluations (step_mm / resolution_mm)"),
        (["sweep", "{nonutf8}", "--out", "r.csv"], 2, "UTF-8"),
        (["sweep", "{bad_quantity_sweep}", "--out", "r.csv"], 2, "tilt_drive_7"),
        (["sweep", SWEEP, "--out", "{dir}"], 2, "--out"),
        (["sweep", SWEEP, "--out", "{existing_csv}"], 2, "--force"),
        (["sweep", SWEEP, "--out", "r.csv", "--jobs", "0"], 2, "--jobs"),
    ],
    "optimise": [
        (["optimise", "{nonutf8}", "--out", "opt"], 2, "UTF-8"),
        (["optimise", "missing.toml", "--out", "opt"], 2, "missing.toml"),
        (["optimise", "hexaglide_joint_orientation", "--out", "{file}"], 2, "--out"),
        (["optimise", "hexaglide_joint_orientation", "--out", "opt", "--budget", "0"], 2, "--budget"),
        (["optimise", "hexaglide_joint_orientation", "--out", "opt", "--jobs", "0"], 2, "--jobs"),
    ],
    "fe-joint": [
        (["fe-joint", JOINT, "--out", "t.csv", "--n-phi", "100000"], 2, "--n-phi"),
        (["fe-joint", JOINT, "--out", "t.csv", "--mesh-size", "0.1"], 2, "--mesh-size"),
        (["fe-joint", JOINT, "--out", "t.csv", "--mesh-size", "0.5"], 2, "--mesh-size"),
        (["fe-joint", JOINT, "--out", "t.csv", "--angles", "0:90:0.0001"], 2, "--angles"),
        (["fe-joint", "{nonutf8}", "--out", "t.csv"], 2, "UTF-8"),
        (["fe-joint", JOINT, "--out", "{dir}"], 2, "--out"),
        (["fe-joint", JOINT, "--out", "t.csv", "--mesh-size", "-1"], 2, "--mesh-size"),
        (["fe-joint", JOINT, "--out", "t.csv", "--angles", "5"], 2, "angles"),
        (["fe-joint", JOINT, "--out", "t.csv", "--mesh-size", "1"], 2, "memory budget"),
    ],
    "ballbar": [
        (["ballbar", "analyse", "{ballbar_10_revolutions}", "--memory-budget", "120MB"], 2, "sample rows need"),
        (["ballbar", "analyse", "missing.csv"], 2, "missing.csv"),
        (["ballbar", "analyse", "{nonutf8}"], 2, "UTF-8"),
        (["ballbar", "analyse", "{file}"], 2, "bar_length_mm"),
        (["ballbar", "analyse", "{file}", "--harmonics", "-3"], 2, "--harmonics"),
        (["ballbar", "analyse", "{tracker_file}"], 2, "needs a ball-bar measurement, found a tracker file"),
    ],
    "calibrate": [
        (["calibrate", "simulate", "felix", "--plan", "{plan_1e9}", "--errors", "example:felix_errors.toml", "--out",
          "m.csv"], 2, "paths[1].points"),
        (["calibrate", "identifiability", "felix", "--instrument", "tracker", "--plan", "{tracker_grid_1000}"], 2,
         "paths[1].points"),
        (["calibrate", "plan", "felix", "--instrument", "ballbar", "--points", "100000000", "--out", "p.toml"], 2,
         "--points"),
        (["calibrate", "identifiability", "no_such_machine", "--instrument", "ballbar"], 2, "no_such_machine"),
        (["calibrate", "identifiability", "felix", "--instrument", "laser"], 2, "--instrument"),
        (["calibrate", "identifiability", "felix", "--instrument", "ballbar", "--with", "bogus"], 2, "bogus"),
        (["calibrate", "identifiability", "felix", "--instrument", "ballbar", "--plan", "missing.toml"], 2,
         "missing.toml"),
        (["calibrate", "identifiability", "felix", "--instrument", "ballbar", "--plan", "{nonutf8}"], 2, "UTF-8"),
        (["calibrate", "identify", "felix", "--measurements", "missing.csv"], 2, "missing.csv"),
        (["calibrate", "identify", "felix", "--measurements", "{nonutf8}"], 2, "UTF-8"),
        (["calibrate", "identify", "felix", "--measurements", "{file}", "--method", "bogus"], 2, "--method"),
        (["calibrate", "check", "felix", "--measurements", "missing.csv"], 2, "missing.csv"),
        (["calibrate", "identify", "felix", "--measurements", "{file}", "--deflection", "bogus"], 2, "--deflection"),
        (["calibrate", "identify", "felix", "--measurements", "{file}", "--load", "1,2,3"], 2, "--load"),
        (["calibrate", "identify", "felix", "--measurements", "{file}", "--deflection", "gravity", "--load", "1,x"], 2,
         "--load"),
        (["calibrate", "check", "felix", "--measurements", "{file}", "--deflection", "bogus"], 2, "--deflection"),
        (["calibrate", "check", "felix", "--measurements", "{file}", "--load", "0,0,-10"], 2, "--load"),
        (["calibrate", "simulate", "felix", "--plan", "p.toml", "--out", "m.csv", "--deflection", "bogus"], 2,
         "--deflection"),
        (["calibrate", "simulate", "felix", "--plan", "missing.toml", "--errors", "e.toml", "--out", "m.csv"], 2,
         "missing.toml"),
        (["calibrate", "simulate", "felix", "--plan", "{nonutf8}", "--errors", "e.toml", "--out", "m.csv"], 2, "UTF-8"),
        (["calibrate", "plan", "felix", "--instrument", "ballbar", "--objective", "bogus", "--out", "p.toml"], 2,
         "--objective"),
        (["calibrate", "plan", "no_such", "--instrument", "ballbar", "--out", "p.toml"], 2, "no_such"),
        # tracker / 6-D pose measurement files and plans
        (["calibrate", "identify", "felix", "--measurements", "{bad_tracker}"], 2, "line 5, column 3 (py_mm)"),
        (["calibrate", "check", "felix", "--measurements", "{bad_tracker}"], 2, "line 5, column 3 (py_mm)"),
        (["calibrate", "identify", "felix", "--measurements", "{bad_pose}"], 2, "line 4, column 7 (rz_mrad)"),
        (["calibrate", "identify", "felix", "--measurements", "{tracker_with_bar}"], 2,
         "line 2: header key 'bar_length_mm' does not belong to a tracker file"),
        (["calibrate", "simulate", "felix", "--plan", "{tracker_plan}", "--noise", "procedure", "--out", "m.csv"], 2,
         "procedure"),
        (["calibrate", "simulate", "felix", "--plan", "{tracker_plan}", "--angle-accuracy", "100", "--out",
          "m.csv"], 2, "--angle-accuracy"),
        (["calibrate", "report", "felix", "--measurements", "missing.csv", "--out", "rep"], 2, "missing.csv"),
        (["calibrate", "report", "felix", "--measurements", "{nonutf8}", "--out", "rep"], 2, "UTF-8"),
        (["calibrate", "report", "felix", "--measurements", "{file}", "--out", "rep"], 2, "a_file"),
        (["calibrate", "report", "felix", "--measurements", "{file}", "--out", "rep", "--method", "bogus"], 2,
         "--method"),
        (["calibrate", "report", "felix", "--measurements", "{file}", "--out", "{file}"], 2, "--out"),
        (["calibrate", "report", "felix", "--measurements", "{file}", "--out", "{calreport}"], 2, "--force"),
        (["calibrate", "report", "felix", "--measurements", "{file}"], 2, "--out"),
        (["calibrate", "report", "no_such_machine", "--measurements", "{file}", "--out", "rep"], 2,
         "no_such_machine"),
        (["calibrate", "report", "felix", "--measurements", "{file}", "--out", "rep", "--plan", "missing.toml"], 2,
         "missing.toml"),
        (["calibrate", "report", "felix", "--measurements", "{file}", "--out", "rep", "--plan", "example:no.toml"],
         2, "example:felix_plan.toml"),
        (["calibrate", "report", "felix", "--measurements", "{file}", "--out", "rep", "--deflection", "wind"], 2,
         "--deflection"),
        (["calibrate", "report", "felix", "--measurements", "{file}", "--out", "rep", "--monte-carlo", "-3"], 2,
         "--monte-carlo"),
        (["calibrate", "simulate", "felix", "--plan", "example:no.toml", "--out", "m.csv"], 2, "example:"),
        (["calibrate", "simulate", "felix", "--plan", "example:felix_plan.toml", "--errors", "example:", "--out",
          "m.csv"], 2, "example"),
    ],
    "mechanism": [
        (["mechanism", "solve", "slider_crank", "--drives", "100", "--steps", "1000000000"], 2, "--steps"),
        (["mechanism", "solve", "no_such", "--drives", "1"], 2, "no_such"),
        (["mechanism", "solve", "slider_crank", "--drives", "abc"], 2, "--drives"),
        (["mechanism", "solve", "slider_crank"], 2, "--pose"),
        (["mechanism", "info", "{nonutf8}"], 2, "UTF-8"),
        (["mechanism", "range", "no_such"], 2, "no_such"),
    ],
    "fe-platform": [
        (["fe-platform", PLATFORM, "--out", "k.toml", "--mesh-size", "0.5"], 2, "--mesh-size"),
        (["fe-platform", PLATFORM, "--out", "k.txt"], 2, ".toml or .csv"),
        (["fe-platform", "{nonutf8}", "--out", "k.toml"], 2, "UTF-8"),
        (["fe-platform", PLATFORM, "--out", "{existing_csv}"], 2, "--force"),
    ],
}


def _commands() -> list[str]:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    return list(sub.choices)


def test_every_command_has_fuzz_cases():
    missing = [c for c in _commands() if not CASES.get(c)]
    assert not missing, f"commands without fuzz cases in tests/test_cli_fuzz.py: {missing}"


@pytest.fixture
def bad_files(tmp_path, monkeypatch):
    """Bad input files in a fresh working directory (repository paths resolved from the repo root); the memory
    budget fixed at 4 GB, so that the estimate refusals do not depend on this machine's memory."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PKMSTIFF_MEMORY_BUDGET", "4GB")
    monkeypatch.delenv("PKMSTIFF_TIME_BUDGET", raising=False)
    for rel in ("studies", "pkmstiff"):
        os.symlink(ROOT / rel, tmp_path / rel)
    f = {}
    (tmp_path / "latin1.toml").write_bytes("name = 'Zürich'\n".encode("latin-1"))
    f["nonutf8"] = "latin1.toml"
    text = Path(HEX).read_text(encoding="utf-8")
    (tmp_path / "v7.toml").write_text(text.replace("format_version = 1", "format_version = 7"), encoding="utf-8")
    f["v7"] = "v7.toml"
    (tmp_path / "absurd.toml").write_text(text.replace('length = "0 mm"', "length = 1e300"), encoding="utf-8")
    f["absurd"] = "absurd.toml"
    (tmp_path / "a_file").write_text("x")
    f["file"] = "a_file"
    (tmp_path / "a_dir").mkdir()
    f["dir"] = "a_dir"
    (tmp_path / "poses.csv").write_text("0,0,-1000,0,0,0\n")
    f["poses"] = "poses.csv"
    (tmp_path / "old.csv").write_text("old result\n")
    f["existing_csv"] = "old.csv"
    (tmp_path / "sec").mkdir()
    (tmp_path / "sec" / "hexaglide_yz_statistics.json").write_text("{}")
    f["section_out"] = "sec"
    (tmp_path / "calrep").mkdir()
    (tmp_path / "calrep" / "report.html").write_text("old report")
    f["calreport"] = "calrep"
    sweep = (ROOT / SWEEP).read_text(encoding="utf-8").replace('"kx", "ky"', '"tilt_drive_7", "ky"')
    (tmp_path / "badq.toml").write_text(sweep, encoding="utf-8")
    f["bad_quantity_sweep"] = "badq.toml"
    head = "# instrument_type: tracker\n# machine: felix\n"
    (tmp_path / "bad_tracker.csv").write_text(head + "t_s,px_mm,py_mm,pz_mm,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg\n"
                                              "1,0,0,0,0,0,0,0,0,0\n2,0,zero,0,0,0,0,0,0,0\n")
    f["bad_tracker"] = "bad_tracker.csv"
    (tmp_path / "bad_pose.csv").write_text("# instrument_type: pose\n# machine: felix\n# target_mm: 0, 0, 0\n"
                                           "t_s,px_mm,py_mm,pz_mm,rx_urad,ry_urad,rz_mrad,x_mm,y_mm,z_mm,a_deg,"
                                           "b_deg,c_deg\n1,0,0,0,0,0,0,0,0,0,0,0,0\n")
    f["bad_pose"] = "bad_pose.csv"
    (tmp_path / "tracker_bar.csv").write_text("# instrument_type: tracker\n# bar_length_mm: 150\n"
                                              "t_s,px_mm,py_mm,pz_mm\n1,0,0,0\n")
    f["tracker_with_bar"] = "tracker_bar.csv"
    (tmp_path / "tracker.csv").write_text("# instrument_type: tracker\nt_s,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,px_mm,py_mm,"
                                          "pz_mm\n1,0,0,0,0,0,0,0,0,0\n")
    f["tracker_file"] = "tracker.csv"
    (tmp_path / "tracker_plan.toml").write_text('[plan]\ninstrument = "tracker"\n[[paths]]\nkind = "poses"\n'
                                                'positions = [[0, 0, 0]]\n')
    f["tracker_plan"] = "tracker_plan.toml"
    _resource_files(tmp_path, f)
    return tmp_path, f


def _resource_files(tmp_path: Path, f: dict[str, str]) -> None:
    """Inputs whose work would exhaust memory or time (issue 22, bad input 2 and 5): refused from the estimate."""
    (tmp_path / "poses_2m.csv").write_bytes(b"x_mm,y_mm,z_mm,a_deg,b_deg,c_deg\n" + b"0,0,-1000,0,0,0\n" * 2_000_000)
    f["poses_2m"] = "poses_2m.csv"
    paths = ["components.strut_950.k", "joint_types.iwf_3dof.tilt_min", "guides.y800.safety_margin",
             "guides.y400.safety_margin", "guides.y000.safety_margin", "limits.singularity_threshold"]
    values = ", ".join(str(1 + i) for i in range(100))
    (tmp_path / "huge_sweep.toml").write_text('[sweep]\nmachine = "hexaglide"\n' + "".join(
        f'[[parameters]]\npath = "{p}"\nvalues = [{values}]\n' for p in paths)
        + '[[evaluations]]\nkind = "point"\npose = [0, 0, -1000, 0, 0, 0]\nquantities = ["kx"]\n')
    f["huge_sweep"] = "huge_sweep.toml"
    sweep = (ROOT / SWEEP).read_text(encoding="utf-8").replace("step_mm = 25", "step_mm = 0.1")
    (tmp_path / "fine_sweep.toml").write_text(sweep, encoding="utf-8")
    f["fine_section_sweep"] = "fine_sweep.toml"
    spec = (ROOT / SPEC).read_text(encoding="utf-8")
    (tmp_path / "fine_section.toml").write_text(spec.replace("step_mm = 5", "step_mm = 0.2"), encoding="utf-8")
    (tmp_path / "fine_workspace.toml").write_text(spec.replace("resolution_mm = 3.125", "resolution_mm = 0.5"),
                                                  encoding="utf-8")
    f["report_fine_section"], f["report_fine_workspace"] = "fine_section.toml", "fine_workspace.toml"
    plan = (ROOT / "pkmstiff/calibration/examples/felix_plan.toml").read_text(encoding="utf-8")
    (tmp_path / "plan_1e9.toml").write_text(plan.replace("points = 360", "points = 1e9"), encoding="utf-8")
    f["plan_1e9"] = "plan_1e9.toml"
    (tmp_path / "grid_1000.toml").write_text('[plan]\ninstrument = "tracker"\n[[paths]]\nkind = "grid"\n'
                                             'half_width = "100 mm"\npoints = 1000\n')
    f["tracker_grid_1000"] = "grid_1000.toml"
    from pkmstiff.calibration.measurement_file import write_measurement
    from tests.ballbar_synth import SyntheticRun, circle_run, measurement_from_runs

    runs = [circle_run(n=4000, seed=i) for i in range(10)]
    run = SyntheticRun(*(np.concatenate([getattr(r, k) for r in runs])
                         for k in ("theta", "positions", "actual", "reading", "true_deviation")))
    write_measurement(tmp_path / "bb10.csv", measurement_from_runs({"ccw": run}))
    f["ballbar_10_revolutions"] = "bb10.csv"


def _snapshot(root: Path) -> dict[str, tuple[int, float]]:
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime)
            for p in root.rglob("*") if not p.is_symlink() and "pkmstiff" not in p.parts and "studies" not in p.parts}


@pytest.mark.parametrize("command, argv, status, text",
                         [(c, a, s, t) for c, cases in CASES.items() for a, s, t in cases],
                         ids=lambda v: " ".join(v) if isinstance(v, list) else str(v))
def test_bad_input_gives_one_line_and_writes_nothing(bad_files, capsys, command, argv, status, text):
    root, files = bad_files
    argv = [a.format(**files) for a in argv]
    before = _snapshot(root)
    code = main(argv)
    out, err = capsys.readouterr()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert "Traceback" not in err + out
    assert code == status, (code, err)
    assert len(lines) == 1, err
    assert lines[0].startswith(f"pkmstiff {command}: error: "), lines[0]
    assert text.lower() in lines[0].lower(), lines[0]
    assert _snapshot(root) == before, "a failed command wrote files"


def test_negative_values_accepted_by_every_vector_option():
    """``--OPTION -1,2,3`` is never 'expected one argument': every value option takes a leading minus sign."""
    parser = build_parser()
    opts = _value_options(parser)
    assert "--pose" in opts and "--u-range" in opts
    joined = join_negative_values(["pose", "hexaglide", "--pose", "-100,300,-1000,0,0,0"], opts)
    assert joined[-1] == "--pose=-100,300,-1000,0,0,0"
    args = parser.parse_args(joined)
    assert args.pose == "-100,300,-1000,0,0,0"
    args = parser.parse_args(join_negative_values(
        ["rotation-map", "hexaglide", "--u-range", "-30,30", "--v-range", "-1000,-900", "--at", "-5"], opts))
    assert (args.u_range, args.v_range, args.at) == ("-30,30", "-1000,-900", -5.0)


def test_negative_pose_runs(capsys):
    assert main(["pose", "hexaglide", "--pose", "-100,300,-1000,0,0,0"]) == 0
    assert "admissible: yes" in capsys.readouterr().out


def test_broken_pipe_is_quiet(monkeypatch, capsys):
    class Closed(io.StringIO):
        def write(self, s):
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(sys, "stdout", Closed())
    code = main(["machines"])
    assert code == 141
    assert "Traceback" not in capsys.readouterr().err


# ---------------------------------------------------------------------------------------------- files and faults
# Bad input files and file-system faults of issue 22 (item 7): exponent bombs, FIFOs, directories and symlink loops as
# input, a UTF-8 BOM, values that used to be accepted silently. Placeholders in braces are made by ``fault_files``.
FILE_CASES: list[tuple[str, list[str], int, str]] = [
    ("pose", ["pose", "{power_bomb}", "--pose", POSE], 2, "powers"),
    ("section", ["section", "{power_bomb}", "--step", "50"], 2, "powers"),
    # a FIFO as input blocks a reader forever; a directory or symlink loop "does not exist" was the wrong answer
    ("pose", ["pose", "{fifo_toml}", "--pose", POSE], 2, "FIFO"),
    ("point", ["point", "{fifo_toml}", "--pose", POSE], 2, "FIFO"),
    ("section", ["section", "{fifo_toml}"], 2, "FIFO"),
    ("workspace", ["workspace", "{fifo_toml}", "--resolution", "20"], 2, "FIFO"),
    ("rotation-map", ["rotation-map", "{fifo_toml}"], 2, "FIFO"),
    ("machines", ["machines", "{fifo_toml}"], 2, "FIFO"),
    ("pose", ["pose", "hexaglide", "--poses", "{fifo_csv}"], 2, "FIFO"),
    ("point", ["point", "hexaglide", "--poses", "{fifo_csv}"], 2, "FIFO"),
    ("calibrate", ["calibrate", "identify", "felix", "--measurements", "{fifo_csv}"], 2, "FIFO"),
    ("calibrate", ["calibrate", "simulate", "felix", "--plan", "{fifo_toml}", "--out", "m.csv"], 2, "FIFO"),
    ("ballbar", ["ballbar", "analyse", "{fifo_csv}"], 2, "FIFO"),
    ("sweep", ["sweep", "{fifo_toml}", "--out", "r.csv"], 2, "FIFO"),
    ("report", ["report", "{fifo_toml}", "--out", "rep"], 2, "FIFO"),
    ("fe-joint", ["fe-joint", "{fifo_toml}", "--out", "t.csv"], 2, "FIFO"),
    ("mechanism", ["mechanism", "info", "{fifo_toml}"], 2, "FIFO"),
    ("pose", ["pose", "{loop_toml}", "--pose", POSE], 2, "symbolic link loop"),
    ("pose", ["pose", "{dir_toml}", "--pose", POSE], 2, "a directory"),
    ("pose", ["pose", "hexaglide", "--poses", "{loop_csv}"], 2, "symbolic link loop"),
    ("pose", ["pose", "{deep_toml}", "--pose", POSE], 2, "nested"),
    ("pose", ["pose", "{seven_chains}", "--pose", POSE], 2, "key 'chains'"),
    ("workspace", ["workspace", "{tiny_guides}", "--resolution", "50"], 2, "reach boxes do not overlap"),
    ("section", ["section", "{tiny_guides}"], 2, "reach boxes do not overlap"),
    # values that were accepted silently or ended as internal errors (exit 1)
    ("pose", ["pose", "hexaglide", "--pose", "1e300,0,-1000,0,0,0"], 2, "|x| <= 100000 mm"),
    ("pose", ["pose", "hexaglide", "--pose", "0,0,-1000,1e9,0,0"], 2, "|a| <= 360 deg"),
    ("pose", ["pose", "hexaglide", "--pose", "0,0,-1000,720,0,0"], 2, "|a| <= 360 deg"),
    ("point", ["point", "hexaglide", "--pose", POSE, "--tool-length", "1e300"], 2, "--tool-length"),
    ("point", ["point", "hexaglide", "--pose", POSE, "--modes", "1000000000"], 2, "--modes"),
    ("point", ["point", "hexaglide", "--pose", POSE, "--modes", "1000000000", "--figures", "figs"], 2, "--modes"),
    ("section", ["section", "hexaglide", "--quantities", ""], 2, "--quantities"),
    ("section", ["section", "hexaglide", "--formats", "", "--out", "o"], 2, "--formats"),
    ("section", ["section", "slider_crank", "--plane", "xy", "--formats", ""], 2, "--formats"),
    ("fe-joint", ["fe-joint", JOINT, "--out", "t.csv", "--n-phi", "0"], 2, "n_phi"),
    ("fe-joint", ["fe-joint", JOINT, "--out", "t.csv", "--png", "j.png", "--png-angle", "nan"], 2, "png_angle"),
    ("mechanism", ["mechanism", "solve", "slider_crank", "--drives", "0.1", "--steps", "0"], 2, "--steps"),
    ("mechanism", ["mechanism", "solve", "slider_crank", "--drives", "0.1", "--steps", "-1"], 2, "--steps"),
    ("mechanism", ["mechanism", "solve", "slider_crank", "--drives", "100"], 3, "no solution"),
    ("workspace", ["workspace", "hexaglide", "--resolution", "20", "--memory-budget", "infGB"], 2, "--memory-budget"),
    ("workspace", ["workspace", "hexaglide", "--resolution", "20", "--memory-budget", "1e400GB"], 2,
     "--memory-budget"),
    ("workspace", ["workspace", "hexaglide", "--resolution", "1e300"], 2, "--resolution"),
    ("workspace", ["workspace", "hexaglide", "--resolution", "20", "--box=100,-100,-400,1200,-1900,-300"], 2,
     "xmin < xmax"),
    ("rotation-map", ["rotation-map", "hexaglide", "--increment", "1e300"], 2, "--increment"),
    ("calibrate", ["calibrate", "simulate", "felix", "--plan", "example:felix_plan.toml", "--out", "m.csv",
                   "--seed", "-1"], 2, "--seed"),
    ("calibrate", ["calibrate", "simulate", "felix", "--plan", "example:felix_plan.toml", "--out", "m.csv",
                   "--drift-tau", "0"], 2, "--drift-tau"),
    ("calibrate", ["calibrate", "simulate", "felix", "--plan", "example:felix_plan.toml", "--out", "m.csv",
                   "--resolution", "0"], 2, "--resolution"),
    ("calibrate", ["calibrate", "simulate", "felix", "--plan", "example:felix_plan.toml", "--out", "m.csv",
                   "--errors", "{empty_toml}"], 2, "[errors]"),
    ("calibrate", ["calibrate", "simulate", "felix", "--plan", "{plan_fraction}", "--out", "m.csv"], 2,
     "whole number"),
    ("calibrate", ["calibrate", "plan", "felix", "--instrument", "ballbar", "--out", "p.toml", "--turns", "0"], 2,
     "--turns"),
    ("calibrate", ["calibrate", "identify", "felix", "--measurements", "{file}", "--monte-carlo", "-1"], 2,
     "--monte-carlo"),
    ("calibrate", ["calibrate", "identify", "felix", "--measurements", "{file}", "--outlier-threshold", "nan"], 2,
     "--outlier-threshold"),
    ("calibrate", ["calibrate", "identify", "felix", "--measurements", "{file}", "--outlier-threshold", "-1"], 2,
     "--outlier-threshold"),
    ("calibrate", ["calibrate", "identify", "felix", "--measurements", "{file}", "--out", "cal.txt"], 2, ".toml"),
    ("sweep", ["sweep", "{extends_sweep}", "--out", "r.csv"], 2, "machine.extends"),
    # errors that came after the cost line, the progress output or all sweep tasks
    ("section", ["section", "hexaglide", "--out", "/proc/pkmstiff_out"], 2, "not writable"),
    ("workspace", ["workspace", "hexaglide", "--resolution", "20", "--out", "/sys/pkmstiff_out"], 2, "not writable"),
    ("section", ["section", "hexaglide", "--out", "{loop_dir}"], 2, "symbolic link"),
    ("sweep", ["sweep", "{bad_path_sweep}", "--out", "r.csv"], 2, "no_such_table"),
    # overwrites without --force
    ("calibrate", ["calibrate", "identify", "felix", "--measurements", "{file}", "--out", "{existing_toml}"], 2,
     "--force"),
    ("calibrate", ["calibrate", "simulate", "felix", "--plan", "example:felix_plan.toml", "--out",
                   "{existing_csv}"], 2, "--force"),
    ("calibrate", ["calibrate", "plan", "felix", "--instrument", "ballbar", "--out", "{existing_toml}"], 2,
     "--force"),
    ("point", ["point", "hexaglide", "--pose", POSE, "--figures", "{figures_out}"], 2, "--force"),
    ("fe-joint", ["fe-joint", JOINT, "--out", "t.csv", "--vtu", "{vtu_out}"], 2, "--force"),
    ("ballbar", ["ballbar", "analyse", "{file}", "--plot", "{plot_out}"], 2, "--force"),
    ("workspace", ["workspace", "hexaglide", "--resolution", "20", "--out", "{png_out}"], 2, "--force"),
    ("rotation-map", ["rotation-map", "hexaglide", "--out", "{png_out}"], 2, "--force"),
    ("section", ["section", "hexaglide", "--quantities", "kx", "--formats", "vtu", "--out", "{vtu_json_out}"], 2,
     "--force"),
    # a valid single-circle ball-bar file: rank 14 of the 36 identifiable parameters, refused before LM (it ran
    # 214-219 s before "LM did not converge")
    ("calibrate", ["calibrate", "identify", "felix", "--measurements", "{one_circle}"], 2, "rank 14"),
    ("calibrate", ["calibrate", "report", "felix", "--measurements", "{one_circle}", "--out", "rep"], 2, "rank 14"),
]

@pytest.fixture(scope="module")
def one_circle(tmp_path_factory) -> Path:
    """A valid Felix ball-bar measurement of one horizontal circle (simulated with the example errors)."""
    d = tmp_path_factory.mktemp("one_circle")
    (d / "plan.toml").write_text(ONE_CIRCLE_PLAN, encoding="utf-8")
    assert main(["calibrate", "simulate", "felix", "--plan", str(d / "plan.toml"), "--errors",
                 "example:felix_errors.toml", "--seed", "1", "--feed", "3000", "--sample-rate", "5", "--out",
                 str(d / "one.csv")]) == 0
    return d / "one.csv"


def test_single_circle_measurement_is_refused_within_seconds(one_circle, capsys):
    """The rank check runs on the measurement's own poses before any identification: well under 10 s (the
    identifiability of 326 readings takes about 1 s on one core; 10 s leaves room for a loaded test machine)."""
    import time

    for cmd in (["identify"], ["report", "--out", str(one_circle.parent / "rep")]):
        t0 = time.perf_counter()
        assert main(["calibrate", cmd[0], "felix", "--measurements", str(one_circle), *cmd[1:]]) == 2
        assert time.perf_counter() - t0 < 10.0
        err = capsys.readouterr().err
        assert "rank 14" in err and "36 base parameters of 42" in err and str(one_circle) in err
    assert not (one_circle.parent / "rep").exists()


@pytest.fixture
def fault_files(bad_files, one_circle):
    root, files = bad_files
    for suffix in (".csv", ".json"):  # the measurement and its header
        shutil.copy(one_circle.with_suffix(suffix), root / f"one_circle{suffix}")
    files["one_circle"] = "one_circle.csv"
    text = Path(HEX).read_text(encoding="utf-8")
    (root / "bomb.toml").write_text(text.replace('length = "0 mm"', 'length = "9**9**9 mm"'), encoding="utf-8")
    files["power_bomb"] = "bomb.toml"
    os.mkfifo(root / "pipe.toml")
    os.mkfifo(root / "pipe.csv")
    files.update(fifo_toml="pipe.toml", fifo_csv="pipe.csv")
    os.symlink("loop.toml", root / "loop.toml")
    os.symlink("loop.csv", root / "loop.csv")
    files.update(loop_toml="loop.toml", loop_csv="loop.csv")
    (root / "dir.toml").mkdir()
    files["dir_toml"] = "dir.toml"
    (root / "deep.toml").write_text("x = " + "[" * 3000 + "]" * 3000 + "\n")
    files["deep_toml"] = "deep.toml"
    (root / "empty.toml").write_text("")
    first, second = text.index("[[chains]]"), text.index("[[chains]]", text.index("[[chains]]") + 1)
    (root / "seven.toml").write_text(text[:first] + text[first:second] + text[first:], encoding="utf-8")
    files["seven_chains"] = "seven.toml"
    (root / "tiny.toml").write_text(text.replace("guide_length = 2.7", "guide_length = 1e-300"), encoding="utf-8")
    files["tiny_guides"] = "tiny.toml"
    files["empty_toml"] = "empty.toml"
    plan = (ROOT / "pkmstiff/calibration/examples/felix_plan.toml").read_text(encoding="utf-8")
    (root / "plan25.toml").write_text(re.sub(r"(?m)^points = .*$", "points = 2.5", plan), encoding="utf-8")
    files["plan_fraction"] = "plan25.toml"
    (root / "extends.toml").write_text('[sweep]\nmachine = "hexaglide"\n[[parameters]]\npath = "machine.extends"\n'
                                       'values = ["/etc/passwd"]\n[[evaluations]]\nkind = "point"\n'
                                       'quantities = ["kx"]\npose = [0, 0, -1000, 0, 0, 0]\n')
    files["extends_sweep"] = "extends.toml"
    (root / "badpath.toml").write_text((root / "extends.toml").read_text().replace("machine.extends",
                                                                                   "no_such_table.k"))
    files["bad_path_sweep"] = "badpath.toml"
    os.symlink("loopdir", root / "loopdir")
    files["loop_dir"] = "loopdir"
    (root / "old.toml").write_text("old result\n")
    files["existing_toml"] = "old.toml"
    for d, name in (("figs", "hexaglide_mode1.png"), ("vtu", "iwf_3dof_improved_tilt0.vtu"),
                    ("plots", "a_file_polar.png"), ("png", "workspace.png"), ("png", "rotation_map.png"),
                    ("vtujson", "hexaglide_yz.json")):
        (root / d).mkdir(exist_ok=True)
        (root / d / name).write_text("old result\n")
    files.update(figures_out="figs", vtu_out="vtu", plot_out="plots", png_out="png", vtu_json_out="vtujson")
    return root, files


@pytest.mark.parametrize("command, argv, status, text", FILE_CASES,
                         ids=lambda v: " ".join(v) if isinstance(v, list) else str(v))
def test_bad_file_or_fault_gives_one_line_and_writes_nothing(fault_files, capsys, command, argv, status, text):
    import signal

    class Hang(BaseException):  # not an OSError/Exception: the command line's handlers must not swallow it
        pass

    def hung(*_):
        raise Hang(f"{' '.join(argv)} still running after 60 s")

    old = signal.signal(signal.SIGALRM, hung)
    signal.alarm(60)
    try:
        test_bad_input_gives_one_line_and_writes_nothing(fault_files, capsys, command, argv, status, text)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
