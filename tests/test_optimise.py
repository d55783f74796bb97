"""Design optimisation (pkmstiff.optimise): known optima through the whole engine (machine variants built from the
machine file, cached, checkpointed), the Pareto front of a two-objective toy, resume, outputs, and design-file errors
before any evaluation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pymoo")

from pkmstiff.cli import main
from pkmstiff.optimise import EXAMPLES, Constraint, Design, FunctionMeasure, Objective, Variable, load_design, optimise
from pkmstiff.optimise.engine import CHECKPOINT, run_optimisation

EXAMPLE = EXAMPLES / "hexaglide_joint_orientation.toml"
L_STAR = 0.1234  # m, the toy optimum


def _toy(m) -> float:
    """(L - L*)² [m²] of the machine's tool length L: minimum 0 at L* (a closed form of a machine-file value)."""
    return (m.tool.length - L_STAR) ** 2


def _f1(m) -> float:
    return ((m.tool.length - 0.1) / 0.1) ** 2


def _f2(m) -> float:
    return ((m.tool.length - 0.2) / 0.1) ** 2


def _length_variable() -> Variable:
    return Variable("L", ("tool.length",), "continuous", (50.0,), (250.0,), "mm")


@pytest.mark.parametrize("algorithm, budget", [("de", 300)])
def test_single_objective_finds_the_closed_form_optimum(tmp_path, algorithm, budget):
    design = Design("hexaglide", (_length_variable(),), (Objective(FunctionMeasure("f", "m^2", _toy)),),
                    algorithm=algorithm, budget=budget, population=10)
    res = optimise(design, tmp_path / "out")
    # the optimum is 123.4 mm; found to 1e-3 mm (1e-5 of the range) within the budget (measured: DE 300 -> 4e-7 mm)
    assert res.best.values[0] == pytest.approx(1e3 * L_STAR, abs=1e-3)
    front = __import__("pandas").read_csv(tmp_path / "out" / "front.csv")
    assert front["L_mm"][0] == pytest.approx(res.best.values[0], rel=1e-12)


def test_two_objective_front_hypervolume(tmp_path):
    """f1 = s², f2 = (s - 1)² with s = (L - 0.1 m)/0.1 m: the front is f2 = (√f1 - 1)², f1 in [0, 1]; its
    hypervolume to the reference point (1, 1) is ∫₀¹ 1 - (√u - 1)² du = 5/6."""
    from pymoo.indicators.hv import HV

    design = Design("hexaglide", (_length_variable(),),
                    (Objective(FunctionMeasure("f1", "1", _f1)), Objective(FunctionMeasure("f2", "1", _f2))),
                    budget=200, population=40)
    res = optimise(design, tmp_path / "out")
    F = np.array([c.objective_vector(design) for c in res.front])
    hv = HV(ref_point=np.array([1.0, 1.0]))(F)
    # 2 %: a front of ~40 points spaced evenly in s loses ~1/(2·40) of the area between the points
    assert hv == pytest.approx(5 / 6, rel=0.02)
    assert all(100.0 - 1.0 <= c.values[0] <= 200.0 + 1.0 for c in res.front)  # the Pareto set is 100..200 mm


def test_constraint_never_reports_an_infeasible_best(tmp_path):
    """Minimise (L - L*)² subject to L >= 0.2 m: the best is on the bound, never the unconstrained L*."""
    design = Design("hexaglide", (_length_variable(),), (Objective(FunctionMeasure("f", "m^2", _toy)),),
                    (Constraint(FunctionMeasure("L", "m", _length), lower=0.2),), budget=120, population=10)
    res = optimise(design, tmp_path / "out")
    assert res.best.values[0] >= 200.0
    assert res.best.values[0] == pytest.approx(200.0, abs=0.5)  # DE approaches the active bound from inside


def _length(m) -> float:
    return m.tool.length


def test_resume_reevaluates_nothing_cached(tmp_path):
    design = Design("hexaglide", (_length_variable(),), (Objective(FunctionMeasure("f", "m^2", _toy)),),
                    budget=40, population=10)
    full = run_optimisation(design, tmp_path / "full")
    out = tmp_path / "cut"
    run_optimisation(design, out)
    lines = (out / CHECKPOINT).read_text().splitlines()
    # an interruption after 15 evaluations, killed while writing the 16th line
    (out / CHECKPOINT).write_text("\n".join(lines[:15]) + "\n" + lines[15][:20])
    with pytest.raises(Exception, match="--resume"):
        run_optimisation(design, out)  # an existing run is neither continued nor overwritten silently
    res = run_optimisation(design, out, resume=True)
    assert res.evaluated == full.evaluated - 15  # the 15 checkpointed candidates are read, not evaluated
    assert [c.key for c in res.history] == [c.key for c in full.history]  # same seed: the same candidates
    assert res.best.values == full.best.values
    again = run_optimisation(design, out, resume=True)
    assert again.evaluated == 0


def test_example_runs_and_writes_outputs(tmp_path, capsys):
    import pandas as pd

    from pkmstiff.machine import load_machine
    from pkmstiff.machine.variants import machine_with

    out = tmp_path / "opt"
    assert main(["optimise", str(EXAMPLE), "--out", str(out), "--budget", "24", "--quiet"]) == 0
    assert "best: kx_mean" in capsys.readouterr().out
    front = pd.read_csv(out / "front.csv")
    assert list(front.columns[:3]) == ["design", "a12_polar_deg", "a12_azimuth_deg"]
    assert front["admissible_area_m2"][0] >= 0.355 - 1e-9 and front["feasible"][0] == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["evaluations"] == 24
    best = summary["front"][0]
    written = load_machine(best["machine_file"])
    variant = machine_with("hexaglide", best["overrides"])
    np.testing.assert_allclose(written.chains.drive_axis, variant.chains.drive_axis, rtol=0, atol=1e-15)
    hist = pd.read_csv(out / "history.csv")
    # the example searches on 25 mm and re-evaluates its best on the requested 10 mm raster: the best design is one
    # of the history's (on the search raster), its front row carries the 10 mm values
    assert len(hist) == 24
    row = hist[(hist["a12_polar_deg"] == front["a12_polar_deg"][0])
               & (hist["a56_azimuth_deg"] == front["a56_azimuth_deg"][0])]
    assert len(row) >= 1 and row["feasible"].iloc[0] == 1
    assert summary["front"][0]["variables"]["kx_mean [N/um]"] == pytest.approx(front["kx_mean_N_per_um"][0], rel=1e-12)
    assert (out / "convergence.png").read_bytes()[:4] == b"\x89PNG"


def test_nothing_feasible_is_exit_3(tmp_path, capsys):
    # twice the original's admissible area (0.38 m² of the 1.26 m² window): no orientation adds admissible points
    text = EXAMPLE.read_text().replace("min = 0.95", "min = 2.0")
    f = tmp_path / "d.toml"
    f.write_text(text)
    assert main(["optimise", str(f), "--out", str(tmp_path / "o"), "--budget", "4", "--quiet"]) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no feasible design" in err
    assert not (tmp_path / "o" / "front.csv").exists()


def _variable_file(tmp_path, table: str) -> Path:
    text = EXAMPLE.read_text()
    start = text.index("[[variables]]")
    f = tmp_path / "bad.toml"
    f.write_text(text[:start] + table + "\n\n" + text[start:])
    return f


@pytest.mark.parametrize("table, key, found", [
    ('[[variables]]\nname = "k"\npath = "components.nope.k"\nlow = 1\nhigh = 2\nunit = "N/um"', "variables[1].path",
     "nope"),
    ('[[variables]]\nname = "k"\npath = "components.strut_950.k"\nlow = 500\nhigh = 200\nunit = "N/um"',
     "variables[1].high", "200"),
    ('[[variables]]\nname = "k"\npath = "components.strut_950.k"\nlow = 200\nhigh = 500\nunit = "mm"',
     "variables[1].unit", "mm"),
    (('[[variables]]\nname = "t"\npath = "components.iwf_3dof_improved.table"\nkind = "categorical"\n'
      'values = ["hexaglide_3dof_improved_measured", "no_such_table"]'), "variables[1].values", "no_such_table"),
])
def test_bad_design_file_one_line_before_any_evaluation(tmp_path, capsys, table, key, found):
    f = _variable_file(tmp_path, table)
    out = tmp_path / "o"
    assert main(["optimise", str(f), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    line = f.read_text().splitlines().index(table.splitlines()[0]) + 1
    assert f"{f}:" in err and f"key '{key}'" in err and found in err, err
    assert int(err.split(f"{f}:")[1].split(":")[0]) >= line  # the line of the key, within its table
    assert not out.exists()  # nothing evaluated, nothing written


def test_design_file_loads_and_python_entry_point(tmp_path):
    import pkmstiff

    d = load_design(EXAMPLE)
    assert d.n_var == 6 and d.objectives[0].sense == "maximise"
    # both objectives' sections share one request: evaluated once per candidate
    assert d.objectives[0].measure.request is d.constraints[0].measure.request
    assert callable(pkmstiff.optimise)


def test_jobs_give_the_same_run(tmp_path):
    """Candidates evaluated in 2 local processes (the sweep's machinery) give the serial run's history."""
    design = Design("hexaglide", (_length_variable(),), (Objective(FunctionMeasure("f", "m^2", _toy)),),
                    budget=16, population=8)
    serial = run_optimisation(design, tmp_path / "s")
    parallel = run_optimisation(design, tmp_path / "p", jobs=2)
    assert [c.key for c in parallel.history] == [c.key for c in serial.history]
    assert [c.outputs for c in parallel.history] == [c.outputs for c in serial.history]  # same code, same inputs


def test_point_objective_task_box_constraint_and_component_variable(tmp_path):
    from pkmstiff.io import read_toml

    f = tmp_path / "d.toml"
    f.write_text('machine = "hexaglide"\n[optimiser]\nbudget = 4\npopulation = 2\n'
                 '[[variables]]\nname = "k"\npath = "components.strut_950.k"\nlow = 200\nhigh = 500\nunit = "N/um"\n'
                 '[[objectives]]\nname = "kx_point"\nsense = "maximise"\nkind = "point"\nquantity = "kx"\n'
                 'pose = [0, 400, -1000, 0, 0, 0]\n'
                 '[[constraints]]\nname = "task"\nkind = "task_box"\nbox_mm = [[-50, 350, -1050], [50, 450, -950]]\n'
                 'step_mm = 50\nmin = 1\n')
    res = optimise(f, tmp_path / "o")
    assert res.best.outputs["task [1]"] == 1.0 and res.best.outputs["kx_point [N/um]"] > 0
    written = read_toml(tmp_path / "o" / "designs" / "design_001.toml")
    assert written["machine"]["extends"] == "hexaglide"
    assert written["components"]["strut_950"]["k"] == res.best.overrides["components.strut_950.k"]
