"""``pkmstiff report --jobs N`` (issue 25): whole evaluations and section maps as tasks of the worker pool give the
same report and the same figure bytes as a serial run; the cost line states the plan."""

from __future__ import annotations

import importlib.util
from dataclasses import replace
from pathlib import Path

import pytest

from pkmstiff.cli import main
from pkmstiff.errors import ResourceError
from pkmstiff.evaluation import parallel
from pkmstiff.report import tasks
from pkmstiff.report.build import build_report, report_plan
from pkmstiff.report.spec import load_spec

HAS_PYVISTA = importlib.util.find_spec("pyvista") is not None

SPEC = """
[report]
title = "jobs"
baseline = "orig"

[[variants]]
name = "orig"
machine = "hexaglide"
tool_length_mm = 150

[[variants]]
name = "v1"
machine = "hexaglide_v1"
tool_length_mm = 150

[workspace]
resolution_mm = 50
methods = ["surface_nets", "tetrahedron"]
figures = FIGURES

[[sections]]
plane = "yz"
at_mm = 0
range = "y=-600:1600,z=-1300:-300"
step_mm = 50
quantities = ["U", "kx"]
statistics = ["max", "mean"]
maps = true

[[points]]
pose = [0, 0, -1000, 0, 0, 0]
quantities = ["kx"]
"""


def _spec(tmp_path: Path, figures: bool) -> Path:
    p = tmp_path / "spec.toml"
    p.write_text(SPEC.replace("FIGURES", "true" if figures else "false"))
    return p


def _report_lines(folder: Path) -> list[str]:
    """report.md without the lines that name the run (date, run time, jobs)."""
    return [x for x in (folder / "report.md").read_text(encoding="utf-8").splitlines()
            if not x.startswith(("*pkmstiff ", "| run time |", "| date |", "| jobs |"))]


@pytest.mark.parametrize("figures", [False, pytest.param(True, marks=pytest.mark.skipif(
    not HAS_PYVISTA, reason="the 3-D workspace figures need pyvista"))])
def test_report_and_figures_are_the_same_bytes_for_jobs_1_and_2(tmp_path, capsys, figures):
    spec = _spec(tmp_path, figures)
    for jobs in ("1", "2"):
        assert main(["report", str(spec), "--out", str(tmp_path / jobs), "--jobs", jobs]) == 0
    err = capsys.readouterr().err
    # 2 variants x (workspace + section) = 4 evaluations: two per worker, so each is one task
    assert ("; on 2 local workers: 4 evaluations (workspace, sections) as one task each; 4 maps as one task each once "
            "their section is done" + ("; 2 workspace figures here meanwhile" if figures else "")) in err
    assert "; sections and workspace serially, each split into tasks by its measured cost; figures here" in err
    one, two = _report_lines(tmp_path / "1"), _report_lines(tmp_path / "2")
    assert len(one) > 50 and one == two
    pngs = sorted(p.relative_to(tmp_path / "1") for p in (tmp_path / "1").rglob("*.png"))
    assert len(pngs) == 4 + (2 if figures else 0)  # 2 quantities x 2 variants (+ a workspace figure each)
    for rel in pngs:
        assert (tmp_path / "1" / rel).read_bytes() == (tmp_path / "2" / rel).read_bytes(), rel
    assert not list((tmp_path / "2").rglob("*.tmp*"))  # written atomically: no temporary file left


def test_report_plan_chooses_whole_tasks_from_two_evaluations_per_worker(tmp_path):
    spec = load_spec(_spec(tmp_path, False))  # 2 variants: 4 evaluations, 4 maps
    whole = report_plan(spec, 2)
    assert whole.whole and whole.pool and (whole.evaluations, whole.maps, whole.figures_3d) == (4, 4, 0)
    split = report_plan(spec, 3)  # 4 evaluations < 2 x 3 workers: each evaluation splits itself
    assert not split.whole and split.pool
    assert split.text() == ("sections and workspace on 3 local workers, each split into tasks by its measured cost; "
                            "4 maps as one task each once their section is done")
    serial = report_plan(spec, 1)
    assert not serial.pool and serial.text().endswith("; figures here")
    assert tasks.report_plan(2, "tcp://127.0.0.1:8786", 4, 4, 2).text() == (
        "sections and workspace on the Dask cluster tcp://127.0.0.1:8786, each split into tasks by its measured cost; "
        "figures here")


def test_peak_memory_of_whole_tasks_adds_the_evaluations_that_run_at_once():
    plan = tasks.report_plan(2, None, 6, 0, 0)
    assert tasks.cost_bytes(100.0, 40.0, plan) == 140.0  # this process's peak + one more evaluation
    assert tasks.cost_bytes(100.0, 40.0, tasks.report_plan(1, None, 6, 0, 0)) == 100.0


def test_an_error_in_a_worker_task_reaches_the_caller(tmp_path, monkeypatch):
    from pkmstiff.evaluation.requests import SectionRequest

    def broken(self, machine, **kw):
        raise ResourceError("section: broken on purpose")

    parallel.shutdown()  # workers forked after the patch run it
    monkeypatch.setattr(SectionRequest, "evaluate", broken)
    try:
        with pytest.raises(ResourceError, match="broken on purpose"):
            build_report(load_spec(_spec(tmp_path, False)), tmp_path / "out", n_jobs=2)
    finally:
        parallel.shutdown()  # no patched worker is left for later tests
    assert not (tmp_path / "out" / "maps").exists()


def test_a_section_result_travels_compactly_and_arrives_bit_for_bit():
    """Between processes a section's NaN-filled arrays travel as their admissible entries only (a fraction of the
    raster) and are rebuilt with the same bits; an array with a value where a point is inadmissible travels whole."""
    import pickle

    import numpy as np

    from pkmstiff.evaluation.requests import SectionRequest
    from pkmstiff.machine.loader import load_machine

    res = SectionRequest("yz", 0.0, (-0.6, 1.6), (-1.3, -0.3), 0.05, ("U", "kx"), (0.0, 0.0, 0.0),
                         0.15).evaluate(load_machine("hexaglide"))
    assert 0 < res.ok.sum() < res.ok.size / 2
    data = pickle.dumps(tasks.Compact(res))
    assert len(data) < 0.6 * len(pickle.dumps(res))
    back = pickle.loads(data)

    def same(a, b):
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()

    assert type(back) is type(res) and same(back.ok, res.ok) and same(back.reasons, res.reasons)
    assert same(back.kappa, res.kappa) and all(same(back.values[k], res.values[k]) for k in res.values)
    odd = res.values["U"].copy()
    odd[~res.ok] = 0.0  # not the NaN the section writes: sent as it is
    moved = pickle.loads(pickle.dumps(tasks.Compact(replace(res, values={"U": odd}))))
    assert same(moved.values["U"], odd)
