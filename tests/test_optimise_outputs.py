"""Design optimisation, outputs and objectives: the moving mass (closed forms from the machine files' component
data), categorical variables from a component catalogue, [[reference]] designs, the front plot and the HTML
comparison report, and design-file errors before any evaluation (catalogue, reference, infeasible bound)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pymoo")

from components.library import bundled_catalogues, load_catalogue
from pkmstiff.cli import main
from pkmstiff.errors import InputError
from pkmstiff.machine.variants import machine_with
from pkmstiff.optimise import EXAMPLES, MovingMassMeasure, load_design, optimise
from tests.report_checks import check_report

SELECTION = EXAMPLES / "pod_ballscrew_selection.toml"
GEOMETRY = EXAMPLES / "hexaglide_strut_lengths.toml"


def _mass(spec: str, overrides: dict | None = None) -> float:
    return MovingMassMeasure("m")(machine_with(spec, overrides or {}), {})


def test_moving_mass_closed_forms():
    # the Hexaglide (docs/user-guide/machines.md): platform 117.24 kg + 6 drives of 102.17 kg that already hold the
    # drive-side strut share (strut_mass_shares 0, 0); the sums are exact up to float rounding (1e-12 relative)
    assert _mass("hexaglide") == pytest.approx(117.24 + 6 * 102.17, rel=1e-12)
    # half/half strut shares add every strut once: 2 x 12.13 + 4 x 11.52 kg
    assert _mass("hexaglide:strut_mass_split") == pytest.approx(117.24 + 6 * 102.17 + 2 * 12.13 + 4 * 11.52,
                                                                rel=1e-12)
    # a carriage mass of the guide component (4 carriages per drive, one component for all six drives)
    assert _mass("hexaglide", {"components.schneeberger_35x4.mass": "3 kg"}) == pytest.approx(
        117.24 + 6 * (102.17 + 3.0), rel=1e-12)
    # the 6X: platform 250 kg + six apparent spindle masses J (2 pi / h)^2 (eq. 3.4), J = 12.57 kg cm^2/m x 1.586 m
    apparent = 12.57e-4 * 1.586 * (2 * math.pi / 0.040) ** 2
    assert _mass("hexapod_6x") == pytest.approx(250.0 + 6 * apparent, rel=1e-12)


def test_catalogue_loads_and_every_entry_builds():
    assert "pod_ballscrews" in bundled_catalogues()
    cat = load_catalogue("pod_ballscrews")
    assert list(cat.entries) == ["bs_32x20", "bs_32x40", "bs_40x20", "bs_40x40", "bs_50x20", "bs_50x40"]
    assert cat.title and cat.provenance
    assert len(load_catalogue("iwf_joints").entries) == 6


def test_catalogue_variable_sets_the_entry_and_its_mass():
    d = load_design(SELECTION)
    v = d.variables[0]
    assert v.catalogue == "pod_ballscrews" and v.values[0] == "bs_32x20" and len(v.values) == 6
    ov = v.overrides("bs_40x40")
    assert ov["chain_defaults.components.drive"] == "bs_40x40"
    m = machine_with(d.machine, ov)
    # the entry's apparent spindle mass: rho pi d^4 / 32 per length (19.73 kg cm^2/m as written) x 1.586 m x
    # (2 pi / 40 mm)^2, six times, plus the platform's 250 kg
    apparent = 19.73e-4 * 1.586 * (2 * math.pi / 0.040) ** 2
    assert MovingMassMeasure("m")(m, {}) == pytest.approx(250.0 + 6 * apparent, rel=1e-12)


def test_catalogue_entry_in_a_machine_file_written_for_the_front(tmp_path):
    from pkmstiff.machine import load_machine

    res = optimise(SELECTION, tmp_path / "o", budget=8, report=False)
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    for entry, c in zip(summary["front"], res.front):
        written = load_machine(entry["machine_file"])
        assert MovingMassMeasure("m")(written, {}) == pytest.approx(c.outputs["moving_mass [kg]"], rel=1e-12)


def _design(tmp_path: Path, text: str, name: str = "d.toml") -> Path:
    f = tmp_path / name
    f.write_text(text)
    return f


def _one_line_error(capsys, f: Path, out: Path, key: str, *found: str) -> str:
    assert main(["optimise", str(f), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"{f}:" in err and f"key '{key}'" in err and all(s in err for s in found), err
    assert not out.exists()  # nothing evaluated, nothing written
    return err


def test_value_not_in_the_catalogue_is_one_line_before_any_evaluation(tmp_path, capsys):
    text = SELECTION.read_text().replace('catalogue = "pod_ballscrews"',
                                         'catalogue = "pod_ballscrews"\nvalues = ["bs_40x40", "bs_63x10"]')
    f = _design(tmp_path, text)
    err = _one_line_error(capsys, f, tmp_path / "o", "variables[1].values", "bs_63x10", "bs_32x20, bs_32x40")
    line = int(err.split(f"{f}:")[1].split(":")[0])
    assert f.read_text().splitlines()[line - 1].startswith("values = ")  # the line of the key


def test_unknown_catalogue_and_bad_catalogue_entry(tmp_path, capsys):
    f = _design(tmp_path, SELECTION.read_text().replace('"pod_ballscrews"', '"no_such_catalogue"'))
    _one_line_error(capsys, f, tmp_path / "o", "variables[1].catalogue", "no_such_catalogue", "pod_ballscrews")
    cat = tmp_path / "screws.toml"
    cat.write_text('[s1]\nmodel = "constant_axial"\nk = "-5 N/um"\n')
    f = _design(tmp_path, SELECTION.read_text().replace('"pod_ballscrews"', '"screws.toml"'), "e.toml")
    _one_line_error(capsys, f, tmp_path / "o", "variables[1].catalogue", "s1.k")
    with pytest.raises(InputError, match="s1.k"):
        load_catalogue(cat)


def test_catalogue_only_for_categorical(tmp_path, capsys):
    text = GEOMETRY.read_text().replace('name = "l12"', 'name = "l12"\ncatalogue = "pod_ballscrews"')
    _one_line_error(capsys, _design(tmp_path, text), tmp_path / "o", "variables[1].catalogue", "continuous")


def test_bad_reference_is_one_line_before_any_evaluation(tmp_path, capsys):
    text = SELECTION.read_text().replace('option = "exact_drive_model"', 'option = "no_such_option"')
    _one_line_error(capsys, _design(tmp_path, text), tmp_path / "o", "reference[1].option", "no_such_option")
    text = SELECTION.read_text().replace('option = "exact_drive_model"', 'option = "x"\nmachine = "linapod"')
    _one_line_error(capsys, _design(tmp_path, text, "e.toml"), tmp_path / "o", "reference[1].option", "both")


@pytest.mark.parametrize("old, new, key", [
    ("min = 1.62 ", "min = 2.5 ", "constraints[1].min"),  # the XZ window: 17 x 13 points of 0.01 m² = 2.21 m²
])
def test_infeasible_everywhere_is_one_line_before_any_evaluation(tmp_path, capsys, old, new, key):
    f = _design(tmp_path, SELECTION.read_text().replace(old, new))
    _one_line_error(capsys, f, tmp_path / "o", key, "infeasible everywhere", "at most 2.21 m^2", "2.5")


def test_task_box_fraction_above_one_is_infeasible_everywhere(tmp_path, capsys):
    text = SELECTION.read_text() + ('\n[[constraints]]\nname = "task"\nkind = "task_box"\n'
                                    'box_mm = [[-50, -50, 1000], [50, 50, 1100]]\nmin = 1.5\n')
    _one_line_error(capsys, _design(tmp_path, text), tmp_path / "o", "constraints[2].min", "at most 1 1", "1.5")


def test_two_objective_run_writes_front_plot_references_and_report(tmp_path):
    import pandas as pd

    from pkmstiff.report.spec import load_spec  # noqa: F401 - the report package imports

    out = tmp_path / "o"
    res = optimise(SELECTION, out, budget=12)
    refs = {c["name"]: c for c in res.meta["references"]}
    assert [c["kind"] for c in res.meta["references"]] == ["base", "reference"]
    # the base design evaluated with the design's measures: the 6X's moving mass (closed form above)
    assert refs["base"]["outputs"]["moving_mass [kg]"] == pytest.approx(_mass("hexapod_6x"), rel=1e-12)
    assert refs["6X, eq. 3.3"]["machine"] == "hexapod_6x:exact_drive_model"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["references"][0]["name"] == "base"
    assert (out / "front.png").read_bytes()[:4] == b"\x89PNG"
    html = (out / "report" / "report.html").read_text()
    md = (out / "report" / "report.md").read_text()
    check_report(html, md)  # strict HTML5, no raw Markdown, no absolute paths, assumptions once
    front = pd.read_csv(out / "front.csv")
    # every compared design is a column of the comparison tables, the base first (the baseline)
    header = next(line for line in md.splitlines() if line.startswith("| Metric"))
    cols = [c.strip() for c in header.split("|")[3::2] if c.strip()]
    assert cols[:2] == ["base", "6X, eq. 3.3"] and set(cols[2:]) <= set(front["design"])
    # the run's numbers and the report's section statistics agree (the same request, the same machine files)
    row = next(line for line in md.splitlines() if line.startswith("| kx min"))
    base_kx = float(row.split("|")[3])
    assert base_kx == pytest.approx(refs["base"]["outputs"]["kx_min [N/um]"], rel=5e-4)  # 4 digits printed
    assert "Pareto front" in md and "front.png" in md


def test_single_objective_run_draws_the_bar_comparison(tmp_path):
    from PIL import Image

    out = tmp_path / "o"
    assert main(["optimise", "hexaglide_joint_orientation", "--out", str(out), "--budget", "4", "--quiet",
                 "--no-report"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    names = [c["name"] for c in summary["references"]]
    assert names == ["base", "Cobet Table 5.4"]
    ref = summary["references"][1]["outputs"]
    # the dissertation's orientation on the example's requested 10 mm raster: 31.54 N/um at 3543 points of 1 cm²
    # (docs/user-guide/optimise.md, studies.md study e); the area is a point count: exact to round-off
    assert ref["kx_mean [N/um]"] == pytest.approx(31.54, abs=0.01) and ref["admissible_area [m^2]"] == \
        pytest.approx(0.3543, abs=1e-9)
    w, h = Image.open(out / "front.png").size
    assert w > h  # one bar per design: a wide, low figure
    assert not (out / "report").exists()


def test_geometry_example_design_and_group_paths():
    d = load_design(GEOMETRY)
    assert [v.name for v in d.variables] == ["l12", "l56"]
    ov = d.overrides([1100.0, 1200.0])
    m = machine_with(d.machine, ov)
    np.testing.assert_allclose(m.chains.strut_length[[0, 1, 4, 5]], [1.1, 1.1, 1.2, 1.2], rtol=1e-12)
    assert [r.name for r in d.references] == ["Hexaglide", "variant 2"]


def test_joint_type_from_the_joint_catalogue(tmp_path):
    """A joint type's stiffness picked from the bundled IWF joint catalogue: the variant's drive joints use the
    entry's table (the same spline as the bundled table itself)."""
    from components.joint_tables import load_joint_table
    from pkmstiff.machine.roles import machine_components

    f = _design(tmp_path, 'machine = "hexaglide"\n[[variables]]\nname = "drive_joint"\nkind = "categorical"\n'
                          'catalogue = "iwf_joints"\nvalues = ["iwf_3dof_improved_measured", "iwf_3dof_old_fe"]\n'
                          'path = "joint_types.iwf_3dof.stiffness"\n'
                          '[[objectives]]\nname = "m"\nkind = "moving_mass"\n')
    d = load_design(f)
    m = machine_with(d.machine, d.overrides(["iwf_3dof_old_fe"]))
    joint = machine_components(m).drive_joint[0]
    table = load_joint_table("iwf_3dof_old_fe")
    assert joint.name == "iwf_3dof_old_fe" and Path(joint.table_name).stem == "iwf_3dof_old_fe"
    np.testing.assert_array_equal(joint.k_nodes, table.stiffness)  # the same file read the same way
    np.testing.assert_array_equal(joint.tilt_nodes, table.tilt)


def test_reference_names_are_distinct_columns(tmp_path, capsys):
    text = SELECTION.read_text().replace('name = "6X, eq. 3.3"', 'name = "base"')
    _one_line_error(capsys, _design(tmp_path, text), tmp_path / "o", "reference[1].name", "base")


def _f3(m) -> float:
    return ((m.tool.length - 0.15) / 0.1) ** 2


def test_three_objectives_draw_every_pair(tmp_path):
    """Three objectives: one panel per pair of objectives (3), side by side at 6.4 in x 150 dpi each."""
    from PIL import Image

    from pkmstiff.optimise import Design, FunctionMeasure, Objective, Variable

    from tests.test_optimise import _f1, _f2

    design = Design("hexaglide", (Variable("L", ("tool.length",), "continuous", (50.0,), (250.0,), "mm"),),
                    tuple(Objective(FunctionMeasure(n, "1", f)) for n, f in (("f1", _f1), ("f2", _f2), ("f3", _f3))),
                    budget=16, population=8)
    res = optimise(design, tmp_path / "o", report=False)
    assert len(res.front) >= 2
    w, h = Image.open(tmp_path / "o" / "front.png").size
    assert (w, h) == (3 * 960, 720)
