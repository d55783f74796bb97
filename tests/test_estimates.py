"""The cost model (pkmstiff.evaluation.cost) and the one place the commands refuse work (issue 22, item 3).

The estimate-vs-actual ratios of real runs are measured by benchmarks/bench_estimates.py (time on a shared machine is
too noisy for a test); here: the laws the model is built from, the counts it predicts (deterministic: evaluations,
points), and that work inside the budget is never refused while work beyond it is refused before it starts.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pkmstiff.cli.edges import announce, count_lines, human_seconds, time_budget
from pkmstiff.errors import ResourceError
from pkmstiff.evaluation import cost as cm
from pkmstiff.evaluation.requests import SectionRequest
from pkmstiff.workspace.requests import WorkspaceRequest

GB = 1 << 30


def test_octree_growth_law_scales_a_pilot_by_four_per_halving():
    """The octree's evaluations grow with the boundary area over eps²: a pilot at 4·eps predicts 16× its count."""
    c = cm.workspace_cost((5.0, 2.0, 1.0), 0.00625, pilot=(0.025, 21_918))
    assert c.count == 16 * 21_918
    assert c.bytes == pytest.approx(cm.BASE_BYTES + c.count * cm.OCTREE_BYTES + cm.CHUNK_BYTES, rel=1e-6)


def test_pilot_is_used_only_for_large_runs_and_stays_small():
    small = cm.octree_pilot_halvings((5.1, 1.7, 1.2), 0.05)
    assert small == 0  # ~13,500 expected evaluations: the box estimate is good enough
    k = cm.octree_pilot_halvings((5.1, 1.7, 1.2), 0.003125)
    assert k >= 2  # the pilot costs at most 1/16 of the run
    assert cm.octree_evaluations((5.1, 1.7, 1.2), 0.003125 * 2 ** k) <= 2 * cm.OCTREE_PILOT_EVALUATIONS


def test_hexaglide_3mm_workspace_estimate_matches_the_octree_and_fits_the_budget(hexaglide):
    """Issue 22: the 3.125 mm Hexaglide workspace (1,439,485 evaluations, 0.60 GB peak measured) was estimated at
    77.3 GB and refused. The pilot's growth law predicts its evaluations within 10 % (the boundary's area converges
    as eps shrinks), so the memory estimate stays under 1 GB and the run is never refused on a machine of 2 GB free."""
    c = WorkspaceRequest(0.003125).cost(hexaglide)
    assert c.count == pytest.approx(1_439_485, rel=0.1)
    assert c.bytes < 1 * GB
    announce("workspace", c, budget=2 * GB, quiet=True)  # does not raise


def test_workspace_estimate_counts_evaluations_of_a_real_run(hexaglide):
    """12.5 mm: the pilot-based count against the octree's own count (88,574 measured by the run below)."""
    req = WorkspaceRequest(0.0125)
    est = req.cost(hexaglide).count
    actual = req.evaluate(hexaglide).octree.evaluations
    assert est == pytest.approx(actual, rel=0.15)


def test_admissible_fraction_of_a_pilot_matches_the_section(hexaglide):
    """The sub-raster's admissible fraction estimates the section's (≤ 2000 points: sampling error ~0.02)."""
    from pkmstiff.evaluation.sections import evaluate_section

    req = SectionRequest("yz", 0.0, (-0.6, 0.8), (-1.25, -0.45), 0.01, ("kappa",))
    res = req.evaluate(hexaglide)
    pts = cm.plane_points(req.u_range, req.v_range, req.step, (0, 0, 0), (0, 1, 0), (0, 0, 1))
    assert len(pts) <= 1.2 * cm.PILOT_POINTS
    frac = cm.admissible_fraction(hexaglide, pts, (0, 0, 0))
    assert frac == pytest.approx(res.ok.mean(), abs=0.03)
    assert evaluate_section  # the same evaluation the request runs


def test_section_cost_charges_structure_quantities_per_admissible_point():
    kin = cm.section_cost(100_000, 0.4, 1, 0)
    struct = cm.section_cost(100_000, 0.4, 0, 1)
    empty = cm.section_cost(100_000, 0.0, 0, 1)
    assert struct.seconds - kin.seconds == pytest.approx(40_000 * (cm.STRUCTURE_SECONDS - cm.KINEMATIC_SECONDS))
    assert empty.seconds == pytest.approx(cm.BASE_SECONDS + 100_000 * cm.POSE_SECONDS)


def test_work_in_one_process_counts_its_start_once_and_peaks_do_not_add():
    a = cm.rows_cost(10, 1e6, 1.0, "a", "rows", "--a")
    b = cm.rows_cost(20, 2e6, 1.0, "b", "rows", "--b")
    both = cm.total([a, b], "a then b")
    assert both.seconds == pytest.approx(a.seconds + b.seconds - cm.BASE_SECONDS)
    assert both.bytes == max(a.bytes, b.bytes)


def test_fe_cost_follows_the_fill_in_law():
    """Memory ∝ n^(4/3), time per solve ∝ n^(5/3) above the process base."""
    c1, c8 = cm.fe_cost(1e5), cm.fe_cost(8e5)
    assert (c8.bytes - cm.FE_BASE_BYTES) / (c1.bytes - cm.FE_BASE_BYTES) == pytest.approx(8 ** (4 / 3))
    assert (c8.seconds - cm.FE_BASE_SECONDS) / (c1.seconds - cm.FE_BASE_SECONDS) == pytest.approx(8 ** (5 / 3))
    assert cm.fe_dofs(28_527, 0.015, 0.0075, 24, 24) == pytest.approx(8 * 28_527)


def test_rotation_map_cost_grows_with_the_increments():
    coarse = cm.rotation_map_cost(315, 0.46, 35, 6, math.radians(1), math.radians(90), plain=False)
    fine = cm.rotation_map_cost(315, 0.46, 35, 6, math.radians(1e-7), math.radians(90), plain=False)
    assert fine.seconds > 1e4 * coarse.seconds
    verify = cm.rotation_map_cost(315, 0.46, 35, 6, math.radians(1e-7), math.radians(90), plain=False, verify=True)
    assert verify.bytes > 100 * GB


def test_sweep_cost_counts_tasks_without_expanding_them():
    task = cm.rows_cost(1, 0.0, cm.POINT_SECONDS, "a point", "points", "")
    c = cm.sweep_cost(100 ** 6, task)
    assert c.count == 10 ** 12 and c.bytes > 1e15


def test_announce_refuses_above_the_budget_naming_option_estimate_and_budget(capsys):
    c = cm.rows_cost(1e6, 1e4, 1e-6, "poses.csv", "pose rows", "--poses")
    with pytest.raises(ResourceError, match=r"^--poses: poses\.csv: 1,000,000 pose rows need about 9\.5 GB, more "
                                             r"than the memory budget of 4\.0 GB"):
        announce("point", c, budget=4 * GB)
    announce("point", c, budget=16 * GB)
    assert (f"pkmstiff point: poses.csv: 1,000,000 pose rows, about 9.5 GB and {human_seconds(c.seconds)} of CPU"
            in capsys.readouterr().err)


def test_time_budget_from_the_environment(monkeypatch):
    c = cm.rows_cost(1e6, 0.0, 1.0, "steps", "steps", "--steps")  # 1e6 s of CPU time
    monkeypatch.delenv("PKMSTIFF_TIME_BUDGET", raising=False)
    assert time_budget() == 24 * 3600.0
    with pytest.raises(ResourceError, match="--steps: .* of CPU time, more than the time budget of 24.0 h"):
        announce("mechanism", c, budget=100 * GB)
    monkeypatch.setenv("PKMSTIFF_TIME_BUDGET", "2e6")
    announce("mechanism", c, budget=100 * GB, quiet=True)
    monkeypatch.setenv("PKMSTIFF_TIME_BUDGET", "nan")
    assert time_budget() == 24 * 3600.0


def test_count_lines_reads_blocks(tmp_path):
    p = tmp_path / "rows.csv"
    p.write_bytes(b"h\n" + b"1,2\n" * 3_000_000)
    assert count_lines(p) == 3_000_001
    assert count_lines(tmp_path / "missing.csv") == 0
    assert count_lines(tmp_path) == 0


def test_section_request_cost_has_the_raster_count(hexaglide):
    req = SectionRequest("yz", 0.0, (-0.6, 0.8), (-1.2, -0.5), 0.001, ("kx", "f1"))
    c = req.cost(hexaglide)
    assert c.count == 1401 * 701
    assert c.option == "--step" and np.isfinite(c.seconds)
