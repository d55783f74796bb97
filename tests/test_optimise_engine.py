"""The optimisation engine (pkmstiff.optimise.engine): CMA-ES on a closed form, the same run whatever the workers
(local processes, Dask), time budgets, coarse-to-fine, constraints relative to the base machine, and a real SIGINT
followed by ``--resume``."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pymoo")

from pkmstiff.cli import main
from pkmstiff.optimise import Design, FunctionMeasure, Objective, Variable, load_design, optimise
from pkmstiff.optimise.engine import CHECKPOINT, run_optimisation

ROOT = Path(__file__).resolve().parents[1]
L_STAR = 0.1234  # m


def _toy(m) -> float:
    """(L - L*)² [m²] of the tool length L: minimum 0 at L* = 123.4 mm."""
    return (m.tool.length - L_STAR) ** 2


def _slow_toy(m) -> float:
    time.sleep(0.05)
    return _toy(m)


def _length_design(**kw) -> Design:
    return Design("hexaglide", (Variable("L", ("tool.length",), "continuous", (50.0,), (250.0,), "mm"),),
                  (Objective(FunctionMeasure("f", "m^2", kw.pop("f", _toy))),), **kw)


#: the section of both measures: YZ plane at x = 0, tool length 0, K_U neglected (study e's)
PLANE = """\
plane = "yz"
at_mm = 0
range = "y=-300:1100,z=-1300:-400"
step_mm = {step}
tool_length_mm = 0
neglect_spindle = true
"""
#: a small real design: one mirrored drive-joint direction, mean k_x and admissible area of a coarse YZ section
SECTION = """\
machine = "hexaglide"
[optimiser]
algorithm = "de"
budget = {budget}
population = {population}
seed = 3
{extra}
[[variables]]
name = "a12"
kind = "direction"
paths = ["chains[1].drive_axis", "chains[2].drive_axis"]
mirror = [1, -1]
polar = [0, 90]
azimuth = [0, 360]
unit = "deg"

[[objectives]]
name = "kx_mean"
sense = "maximise"
kind = "section"
quantity = "kx"
statistic = "mean"
{section}
[[constraints]]
name = "admissible_area"
kind = "section"
quantity = "kx"
statistic = "area"
{section}{constraint}
"""


def _section_file(tmp_path: Path, budget: int = 16, population: int = 8, step: float = 100, extra: str = "",
                  constraint: str = "min = 0.3") -> Path:
    f = tmp_path / "design.toml"
    f.write_text(SECTION.format(budget=budget, population=population, extra=extra, constraint=constraint,
                                section=PLANE.format(step=step)))
    return f


def test_cmaes_finds_the_closed_form_optimum(tmp_path):
    res = optimise(_length_design(algorithm="cmaes", budget=200, population=8), tmp_path / "out")
    # the optimum is 123.4 mm; to 1e-3 mm (5e-6 of the range) within the budget (measured: 6e-8 mm after 200)
    assert res.best.values[0] == pytest.approx(1e3 * L_STAR, abs=1e-3)
    assert res.algorithm == "cmaes"


def test_jobs_and_dask_give_the_serial_run(tmp_path):
    """A generation's candidates in 2 local processes or on a Dask cluster: the serial run's history (the same
    candidates evaluated by the same code in any process: identical numbers)."""
    d = load_design(_section_file(tmp_path))
    serial = run_optimisation(d, tmp_path / "s")
    local = run_optimisation(d, tmp_path / "p", jobs=2)
    assert local.meta["parallel"] == "local"  # the candidates really went to the pool
    runs = [local]
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as c:
        runs.append(run_optimisation(d, tmp_path / "d", scheduler=c))
    assert runs[1].meta["parallel"].startswith(("Dask", "serial"))
    for r in runs:
        assert [c.key for c in r.history] == [c.key for c in serial.history]
        assert [c.outputs for c in r.history] == [c.outputs for c in serial.history]


def test_time_budget_stops_between_generations_with_the_best_so_far(tmp_path):
    design = _length_design(f=_slow_toy, budget=10_000, population=4, time_budget=0.4)
    res = optimise(design, tmp_path / "o")
    assert res.meta["stopped"] == "time budget of 0.4 s"
    assert 4 <= len(res.history) < 10_000 and len(res.history) % 4 == 0  # whole generations
    assert res.best.feasible(design) and (tmp_path / "o" / "front.csv").exists()
    assert res.best.values[0] == min((c for c in res.history), key=lambda c: c.outputs["f [m^2]"]).values[0]


def test_time_budget_from_the_design_file_and_the_cli(tmp_path, capsys):
    f = _section_file(tmp_path, budget=10_000, population=4, extra='time_budget = "5 min"')
    assert load_design(f).time_budget == 300.0
    out = tmp_path / "o"
    assert main(["optimise", str(f), "--out", str(out), "--time-budget", "0s", "--quiet"]) == 2  # not positive
    assert main(["optimise", str(f), "--out", str(out), "--time-budget", "1ms", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "4 evaluations (stopped: time budget of 0.001 s)" in text  # the first generation always runs
    bad = _section_file(tmp_path, extra='time_budget = "5 mm"')
    assert main(["optimise", str(bad), "--out", str(tmp_path / "b"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:" in err and "optimiser.time_budget" in err and "5 mm" in err


def test_coarse_to_fine_searches_coarse_and_reports_the_requested_raster(tmp_path):
    """The search evaluates the 100 mm raster; the best 3 are re-evaluated on the 50 mm raster the file asks for."""
    import pkmstiff
    from pkmstiff.machine.variants import machine_with

    f = _section_file(tmp_path, budget=12, population=6, step=50, extra="coarse_step_mm = 100\nrefine = 3")
    d = load_design(f)
    assert d.coarse_step == pytest.approx(0.1)
    res = optimise(d, tmp_path / "o")
    assert res.meta["refined"] == {"search_step_mm": 100.0, "candidates": 3}
    assert res.evaluated == len({c.key for c in res.history}) and res.reevaluated == len(res.refined) == 3

    def section(overrides, step):
        r = pkmstiff.StudyMachine.of(machine_with("hexaglide", overrides)).with_(neglect_spindle=True).section(
            "yz", 0.0, step, ["kx"], u_range=(-0.3, 1.1), v_range=(-1.3, -0.4), tool_length=0.0)
        return float(np.mean(r.display("kx")[r.ok])), float(np.count_nonzero(r.ok)) * step ** 2

    best = res.best
    # the same pipeline, other call path: equal to rounding (the mean of the same numbers in the same order)
    assert best.outputs["kx_mean [N/um]"] == pytest.approx(section(best.overrides, 0.05)[0], rel=1e-12)
    assert best.search_outputs["kx_mean [N/um]"] == pytest.approx(section(best.overrides, 0.1)[0], rel=1e-12)
    assert best.outputs["admissible_area [m^2]"] == pytest.approx(section(best.overrides, 0.05)[1], rel=1e-12)
    feasible = sorted({c.outputs["kx_mean [N/um]"] for c in res.history if c.feasible(d)}, reverse=True)
    assert best.search_outputs["kx_mean [N/um]"] >= feasible[min(2, len(feasible) - 1)]  # one of the 3 refined


def test_relative_constraint_is_a_fraction_of_the_base_on_each_raster(tmp_path):
    f = _section_file(tmp_path, budget=8, population=4, step=50, extra="coarse_step_mm = 100\nrefine = 2",
                      constraint='min = 0.9\nrelative_to = "base"')
    res = run_optimisation(load_design(f), tmp_path / "o")
    import pkmstiff

    r = pkmstiff.load_machine("hexaglide").with_(neglect_spindle=True).section(
        "yz", 0.0, 0.05, ["kx"], u_range=(-0.3, 1.1), v_range=(-1.3, -0.4), tool_length=0.0)
    base_area = float(np.count_nonzero(r.ok)) * 0.05 ** 2
    assert res.design.constraints[0].lower == pytest.approx(0.9 * base_area, rel=1e-12)  # the requested raster's
    assert res.best.outputs["admissible_area [m^2]"] >= 0.9 * base_area
    assert res.evaluated == len({c.key for c in res.history})  # the base machine is not counted
    assert res.reevaluated == len(res.refined) == 2


def test_progress_shows_the_best_feasible_value_so_far(tmp_path):
    """Each progress line (one per generation) names the best value among the feasible candidates so far."""
    design = _length_design(budget=12, population=4)
    lines: list[str] = []
    res = optimise(design, tmp_path / "o", progress=lines.append)
    assert len(lines) == 3
    for g, line in enumerate(lines):
        so_far = min(c.outputs["f [m^2]"] for c in res.history[:4 * (g + 1)])
        assert f"best feasible so far: f {so_far:.6g} m^2" in line, line


def test_cli_counts_search_cached_and_reevaluated_apart(tmp_path, capsys):
    """run + cached = the search's evaluations; the re-evaluated candidates are counted on their own."""
    f = _section_file(tmp_path, budget=12, population=6, step=50, extra="coarse_step_mm = 100\nrefine = 3")
    out = tmp_path / "o"
    assert main(["optimise", str(f), "--out", str(out), "--quiet", "--no-report"]) == 0
    line = capsys.readouterr().out.splitlines()[-1]
    run, cached = _run_line(line)
    summary = json.loads((out / "summary.json").read_text())
    assert run + cached == summary["evaluations"] == 12
    assert run == summary["evaluated"] and cached == summary["read_from_checkpoint"]
    assert "cached: repeated or read from the checkpoint; 3 re-evaluated on the requested raster after" in line, line
    assert summary["reevaluated_on_requested_raster"] == 3


def test_refinement_keeps_to_a_spent_time_budget_until_one_is_feasible(tmp_path, capsys):
    """With the time budget spent by the search, the re-evaluation goes one candidate at a time (one worker) and
    stops at the first that is feasible on the requested raster, not after ``refine`` = 6; the CLI says so."""
    f = _section_file(tmp_path, budget=10_000, population=6, step=50,
                      extra='coarse_step_mm = 100\nrefine = 6\ntime_budget = "1ms"')
    d = load_design(f)
    res = optimise(d, tmp_path / "o", report=False)
    assert res.meta["refined"]["time_budget_spent"] is True
    feas = [c.feasible(res.design) for c in res.refined]
    assert feas == [False] * (len(feas) - 1) + [True]
    assert len(res.refined) < 6 or feas[:6] == [False] * 5 + [True]
    assert main(["optimise", str(f), "--out", str(tmp_path / "c"), "--no-report"]) == 0
    err = capsys.readouterr().err
    assert "time budget of 0.001 s spent before the re-evaluation on the requested raster ended" in err


def test_convergence_judges_each_raster_by_its_own_constraint(tmp_path, monkeypatch):
    """History values come from the search raster and are coloured by the search design's constraints; the
    re-evaluated ones by the requested design's. A candidate feasible on one and not on the other shows it."""
    import dataclasses

    from pkmstiff.optimise import outputs
    from pkmstiff.optimise.engine import Candidate

    f = _section_file(tmp_path, budget=8, population=4, step=50, extra="coarse_step_mm = 100\nrefine = 2")
    res = optimise(load_design(f), tmp_path / "o", report=False)
    calls = []
    real = outputs.convergence_series
    monkeypatch.setattr(outputs, "convergence_series", lambda c, d, j: calls.append((c, d)) or real(c, d, j))
    outputs._convergence_png(res, tmp_path / "c.png")
    assert calls[0][0] is res.history and calls[0][1] is res.search_design
    assert calls[1][0] is res.refined and calls[1][1] is res.design
    # the same outputs, feasible against a 0.3 m^2 bound and not against 0.4 m^2
    c = Candidate("k", [], {}, {"kx_mean [N/um]": 1.0, "admissible_area [m^2]": 0.35})
    lo = res.design
    hi = dataclasses.replace(lo, constraints=(dataclasses.replace(lo.constraints[0], lower=0.4),))
    assert real([c], lo, 0)[1].tolist() == [True] and real([c], hi, 0)[1].tolist() == [False]
    assert real([c], lo, 0)[0].tolist() == [-1.0]  # maximised: the minimised sense


def _sigint_default() -> None:
    """In the child before exec: SIGINT handled by default, so Python turns it into KeyboardInterrupt. A command
    started in the background by a non-interactive shell (``cmd &``, as CI runners do) inherits SIGINT ignored, and
    Python keeps an ignored SIGINT ignored: the run would never see the Ctrl-C this test sends."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _checkpoint_lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def _run_line(text: str) -> tuple[int, int]:
    """(run, cached) of the CLI's final line."""
    part = text.split("evaluations (")[1]
    return int(part.split(" run")[0]), int(part.split(", ")[1].split(" cached")[0])


@pytest.mark.parametrize("jobs", [1, 2])
def test_sigint_then_resume_reevaluates_nothing_checkpointed(tmp_path, jobs):
    """``pkmstiff optimise`` as a subprocess, Ctrl-C (SIGINT to its process group, as a terminal sends it) after
    some generations are checkpointed: exit 130 with one line, a valid checkpoint; ``--resume`` then evaluates only
    the candidates the checkpoint lacks (counted against an uninterrupted run of the same budget)."""
    f = _section_file(tmp_path, budget=2000, population=4)
    out = tmp_path / "o"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "pkmstiff.cli", "optimise", str(f), "--out", str(out), "--jobs", str(jobs)]
    proc = subprocess.Popen(cmd, env=env, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=_sigint_default)
    deadline = time.monotonic() + 120
    while len(_checkpoint_lines(out / CHECKPOINT)) < 8 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    lines = [ln for ln in err.splitlines() if not ln.startswith("  ")]  # progress lines are indented
    assert len(lines) == 1 and "interrupted" in lines[0] and "--resume" in lines[0], err
    assert "Traceback" not in err
    done = _checkpoint_lines(out / CHECKPOINT)  # every line valid JSON (a torn line would raise here)
    assert [r for r in done if not r["values"]] == done[:1]  # the base machine (for the report), with generation 1
    n = len(done) - 1
    # whole generations: the checkpoint holds the first g generations of an uninterrupted run, each candidate once
    # (a generation may repeat an earlier candidate, which is read, not evaluated nor written again)
    keys = [c.key for c in run_optimisation(load_design(f), tmp_path / "reference", budget=n + 8).history]
    whole = [list(dict.fromkeys(keys[:4 * g])) for g in range(1, len(keys) // 4 + 1)]
    assert 8 <= n < 2000 and [r["key"] for r in done[1:]] in whole, (n, len(whole))

    budget = n + 8  # the checkpointed generations and two more
    resumed = subprocess.run([*cmd, "--resume", "--budget", str(budget)], env=env, cwd=ROOT, capture_output=True,
                             text=True, timeout=120, check=False)
    assert resumed.returncode == 0, resumed.stderr
    fresh = subprocess.run([*cmd[:6], str(tmp_path / "fresh"), "--budget", str(budget)], env=env, cwd=ROOT,
                           capture_output=True, text=True, timeout=120, check=False)
    run_resumed, cached_resumed = _run_line(resumed.stdout)
    run_fresh, cached_fresh = _run_line(fresh.stdout)
    assert run_resumed == run_fresh - n  # the n checkpointed candidates are read, not evaluated
    assert cached_resumed == cached_fresh + n
    front = (out / "front.csv").read_text()
    assert front == (tmp_path / "fresh" / "front.csv").read_text().replace(str(tmp_path / "fresh"), str(out))


def test_jobs_and_scheduler_together_is_one_line_before_any_evaluation(tmp_path, capsys):
    f = _section_file(tmp_path)
    assert main(["optimise", str(f), "--out", str(tmp_path / "o"), "--jobs", "2", "--scheduler",
                 "tcp://127.0.0.1:1", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--scheduler" in err
    assert not (tmp_path / "o").exists()


def test_base_and_references_are_tasks_beside_the_first_batch(tmp_path):
    """``optimise`` with 2 local processes: the base design and the reference are evaluated as tasks (checkpointed,
    not counted) and give the serial run's values; every output file but the report's run data is the same bytes."""
    extra = 'coarse_step_mm = 200\nrefine = 2\n[[reference]]\nname = "Cobet"\noption = "optimised_drive_joints"\n'
    f = _section_file(tmp_path, budget=8, population=4, extra=extra)
    runs = [optimise(f, tmp_path / f"j{jobs}", jobs=jobs, report=False) for jobs in (1, 2)]
    assert runs[1].meta["parallel"] == "local"
    assert runs[0].meta["references"] == runs[1].meta["references"]
    assert [c["name"] for c in runs[0].meta["references"]] == ["base", "Cobet"]
    for name in ("front.png", "convergence.png", "history.csv"):
        assert (tmp_path / "j1" / name).read_bytes() == (tmp_path / "j2" / name).read_bytes(), name
    ckpt = _checkpoint_lines(tmp_path / "j2" / CHECKPOINT)
    assert sum(1 for r in ckpt if not r["values"]) == 2  # base and reference on the requested raster, once each
    assert runs[1].evaluated + runs[1].cached == 8
