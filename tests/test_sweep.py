"""Parameter sweeps (pkmstiff.evaluation.sweep), machine variants by override (pkmstiff.machine.variants), sweep files."""

from __future__ import annotations

import csv
import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pkmstiff import load_machine
from pkmstiff.errors import ArgumentError, InputError, OverrideError
from pkmstiff.evaluation.sweep import (
    LogUniform,
    Normal,
    Parameter,
    Sweep,
    Uniform,
    grid_points,
    random_points,
    run_sweep,
)
from pkmstiff.machine.loader import raw_machine
from pkmstiff.machine.variants import apply_overrides, machine_with, parse_override_path
from pkmstiff.report.sweep_evaluations import Combined, PointValues, SectionStatistics

POSE = np.array([[0.0, 0.0, -1.0, 0.0, 0.0, 0.0]])
SWEEPS = Path(__file__).resolve().parents[1] / "studies" / "sweeps"


def _kx(machine) -> float:
    from pkmstiff.analysis import evaluate_structure

    return float(evaluate_structure(machine, POSE, tool_length=0.0, n_modes=1).stiffness[0, 0])


# ------------------------------------------------------------------------------------------------ machine variants
def test_no_overrides_equals_load_machine():
    name = "hexapod_6x:constant_drive_stiffness"
    a, b = load_machine(name), machine_with(name)  # without overrides: the (cached) load
    k = raw_machine(name)[0]["components"]["constant_strut"]["k"]
    c = machine_with(name, {"components.constant_strut.k": k})  # an override that changes nothing: the builder
    assert a.name == b.name == c.name and a.components == b.components == c.components
    assert _kx(a) == _kx(b) == _kx(c)  # same data: bit-identical


def test_overrides_equal_a_hand_edited_machine_file(tmp_path):
    """Round trip: overrides give the same machine as a file that extends the original with the same changes."""
    child = tmp_path / "edited.toml"
    child.write_text("""
format_version = 1
[machine]
name = "hexaglide"
extends = "hexaglide"
[components.strut_950]
k = "300 N/um"
[joint_types.iwf_3dof]
tilt_min = "7 deg"
[[chains]]
[[chains]]
[[chains]]
platform_joint = [0.31, -0.13, 0.15]
[[chains]]
[[chains]]
[[chains]]
""")
    edited = load_machine(child)
    over = machine_with("hexaglide", {"components.strut_950.k": "300 N/um", "joint_types.iwf_3dof.tilt_min": "7 deg",
                                      "chains[3].platform_joint": [0.31, -0.13, 0.15]})
    assert over.components == edited.components
    assert over.joint_types["iwf_3dof"].tilt_min == pytest.approx(math.radians(7), rel=1e-15)
    np.testing.assert_array_equal(over.chains.platform_joint, edited.chains.platform_joint)
    assert _kx(over) == _kx(edited)
    assert _kx(over) != _kx(load_machine("hexaglide"))  # the overrides did change the machine


def test_wildcard_sets_every_chain():
    m = machine_with("hexaglide", {"chains[*].strut_radius": "30 mm"})
    np.testing.assert_allclose(m.chains.strut_radius, 0.03, rtol=1e-15)


@pytest.mark.parametrize("overrides, exc, pattern", [
    ({"components.strut_95.k": 1}, InputError, r"key 'components.strut_95.k': expected an existing table "
                                                  r"'components.strut_95' \(keys at 'components': \[.*'strut_950'"),
    ({"components.strut_950.kk": 1}, InputError, r"key 'components.strut_950.kk'.*unknown parameter 'kk'"),
    ({"components.strut_950.k": "3 kg"}, InputError, r"key 'components.strut_950.k': expected a quantity with "
                                                           r"the dimension of N/m"),
    ({"chains[7].strut_radius": 0.1}, InputError, r"key 'chains\[7\].strut_radius': expected a 1-based index 1..6"),
    ({"joint_types.iwf_3dof.tilt_mni": 1}, InputError, r"key 'joint_types.iwf_3dof.tilt_mni': expected one of "
                                                             r"the keys"),
    ({"components..k": 1}, InputError, r"dotted keys"),
])
def test_invalid_override_gives_a_clear_error(overrides, exc, pattern):
    with pytest.raises(exc, match=pattern) as info:
        machine_with("hexaglide", overrides)
    assert "hexaglide.toml" in str(info.value) or "(override)" in str(info.value)


def test_parse_override_path():
    assert parse_override_path("chains[3].platform_joint") == [("chains", 3), ("platform_joint", None)]
    assert parse_override_path("chains[*].label") == [("chains", "*"), ("label", None)]


@pytest.mark.parametrize("overrides", [
    {"components.strut_950.k": "300 N/um", "joint_types.iwf_3dof.tilt_min": "7 deg"},
    {"chains[3].platform_joint": [0.31, -0.13, 0.15], "chains[*].strut_radius": "30 mm"},
    {"chains[*].strut_radius": "30 mm", "chains[2].strut_radius": "20 mm", "chains[2].drive_axis": [0, 0, -1]},
    {"chains[1].drive_axis": [0.1, 0.0, -0.99], "chains[2].drive_axis": [-0.1, 0.0, -0.99]},
])
def test_shared_overrides_equal_the_deep_copy_and_leave_the_raw_data(overrides):
    """``share=True`` copies only the paths it changes: the same data as the deep copy (the optimiser's candidate
    keys hash it), and the raw data it shares stay as they were."""
    raw = raw_machine("hexaglide")[0]
    before = json.dumps(raw, sort_keys=True, default=repr)
    shared = apply_overrides(raw, overrides, share=True)
    assert shared == apply_overrides(raw, overrides)
    assert json.dumps(raw, sort_keys=True, default=repr) == before


def test_shared_overrides_give_the_same_errors():
    raw = raw_machine("hexaglide")[0]
    before = json.dumps(raw, sort_keys=True, default=repr)
    for bad in ({"chains[9].label": "x"}, {"nosuch.key": 1}, {"chains[1].nosuch.key": 1}):
        with pytest.raises(OverrideError) as deep:
            apply_overrides(raw, bad)
        with pytest.raises(OverrideError) as shared:
            apply_overrides(raw, bad, share=True)
        assert str(shared.value) == str(deep.value)
    assert json.dumps(raw, sort_keys=True, default=repr) == before


# ---------------------------------------------------------------------------------------------- grid and random
def test_grid_is_the_cartesian_product_first_slowest():
    pts = grid_points([Parameter("a.x", values=(1, 2)), Parameter("b.y", values=("p", "q", "r"))])
    assert pts == [{"a.x": a, "b.y": b} for a, b in itertools.product((1, 2), ("p", "q", "r"))]
    assert grid_points({"a.x": [1, 2, 3]}) == [{"a.x": 1}, {"a.x": 2}, {"a.x": 3}]
    with pytest.raises(ArgumentError, match="parameter 'a.x': a grid sweep needs a list of values"):
        grid_points([Parameter("a.x", distribution=Uniform(0, 1))])


def test_random_points_are_seeded_and_in_range():
    params = [Parameter("a.u", distribution=Uniform(2.0, 3.0)), Parameter("a.l", distribution=LogUniform(1.0, 1e3)),
              Parameter("a.n", distribution=Normal(0.0, 5.0, low=-1.0, high=1.0)),
              Parameter("a.c", values=(10, 20, 30))]
    a, b = random_points(params, 200, seed=7), random_points(params, 200, seed=7)
    assert a == b and a != random_points(params, 200, seed=8)
    u = np.array([p["a.u"] for p in a])
    lg = np.array([p["a.l"] for p in a])
    assert u.min() >= 2.0 and u.max() <= 3.0 and lg.min() >= 1.0 and lg.max() <= 1e3
    assert all(-1.0 <= p["a.n"] <= 1.0 for p in a) and {p["a.c"] for p in a} == {10, 20, 30}
    # log-uniform: log10 is uniform on [0, 3]; its mean 1.5 within 5 sigma (sigma = 3/sqrt(12)/sqrt(200) = 0.061)
    assert abs(np.log10(lg).mean() - 1.5) < 5 * 3 / math.sqrt(12) / math.sqrt(200)


@settings(max_examples=50, deadline=None)
@given(st.floats(-1e6, 1e6), st.floats(1e-3, 1e6), st.integers(0, 2**32 - 1), st.integers(1, 50))
def test_uniform_samples_stay_in_bounds(low, width, seed, n):
    pts = random_points({"x.y": Uniform(low, low + width)}, n, seed)
    assert len(pts) == n and all(low <= p["x.y"] <= low + width for p in pts)


def test_parameter_units_and_columns():
    p = Parameter("components.strut_950.k", values=(300,), unit="N/um")
    assert p.column == "components.strut_950.k [N/um]" and p.override(300) == "300.0 N/um"
    assert Parameter("chains[1].label", values=("x",)).override("x") == "x"
    with pytest.raises(ArgumentError, match="with unit 'N/um' the values must be numbers"):
        Parameter("components.strut_950.k", values=("300 N/um",), unit="N/um")
    with pytest.raises(ArgumentError, match="expected a unit"):
        Parameter("components.strut_950.k", values=(1,), unit="furlongs per parsec^7 x")
    with pytest.raises(ArgumentError, match="a random sweep needs a positive number of samples"):
        Sweep("hexaglide", [Parameter("a.b", values=(1,))], _kx_eval, mode="random")
    with pytest.raises(ArgumentError, match="each path at most once"):
        Sweep("hexaglide", [Parameter("a.b", values=(1,)), Parameter("a.b", values=(2,))], _kx_eval)


def _kx_eval(machine):
    return {"kx [N/m]": _kx(machine)}


# -------------------------------------------------------------------------------------------------------- running
EVAL = Combined((PointValues((0, 0, -1000, 0, 0, 0), ("kx", "f1")),
                 SectionStatistics(("kx",), range="y=-200:800,z=-1100:-500", step_mm=100, statistics=("mean",))))


def _sweep() -> Sweep:
    return Sweep("hexaglide", [Parameter("components.strut_950.k", values=(150, 344, -5), unit="N/um"),
                               Parameter("components.strut_1000.k", values=(200, 326), unit="N/um")], EVAL)


def test_failing_tasks_are_recorded_and_physics_holds(tmp_path):
    res = run_sweep(_sweep())
    assert [r["task"] for r in res.rows] == list(range(6))
    bad = res.failed
    assert [r["task"] for r in bad] == [4, 5]  # k = -5 N/um for the last grid value of the first parameter
    assert all("key 'components.strut_950.k': expected positive values" in r["error"] for r in bad)
    assert all("kx [N/um]" not in r for r in bad)
    assert np.isnan(res.column("kx [N/um]")[4])
    ok = [r for r in res.rows if not r["error"]]
    kx = {(r["components.strut_950.k [N/um]"], r["components.strut_1000.k [N/um]"]): r["kx [N/um]"] for r in ok}
    # stiffer struts in series with the joints and drives: TCP stiffness rises in both parameters
    assert kx[(150, 200)] < kx[(344, 200)] and kx[(150, 200)] < kx[(150, 326)] < kx[(344, 326)]
    # the bundled machine's values (344, 326 N/um) give the unmodified machine's stiffness (same builder)
    assert kx[(344, 326)] == pytest.approx(_kx(load_machine("hexaglide")) / 1e6, rel=1e-12)
    # CSV round trip: a plain table (file column names), the metadata beside it, exact floats
    import json

    import pandas as pd

    path = res.to_csv(tmp_path / "s.csv")
    meta = json.loads(path.with_suffix(".json").read_text())
    assert meta["machine"] == "hexaglide" and str(meta["failed"]).startswith("2")
    assert meta["columns"]["kx_N_per_um"] == "kx [N/um]"
    rows = list(csv.DictReader(path.read_text().splitlines()))
    assert list(rows[0]) == list(meta["columns"]) and list(meta["columns"].values()) == res.columns
    assert float(rows[0]["kx_N_per_um"]) == res.rows[0]["kx [N/um]"] and rows[4]["kx_N_per_um"] == ""
    df = pd.read_csv(path)  # no options
    assert len(df) == 6 and df["kx_N_per_um"].isna().sum() == 2 and list(df.columns)[-1] == "error"


def _process(machine) -> dict[str, float]:
    import os

    return {"pid": float(os.getpid()), "kx": _kx(machine)}


def test_local_pool_runs_every_task_on_the_workers():
    # a task run here shared a core with a worker and left one worker a task more (12 tasks on 2 workers: 5 + 6 + 1
    # here); now the 12 tasks go to the workers in batches, about four per worker, and the plan keeps their mean time
    import os

    sweep = Sweep("hexaglide", [Parameter("components.strut_950.k", values=tuple(range(200, 440, 20)), unit="N/um")],
                  _process)
    res = run_sweep(sweep, n_jobs=2)
    pids = {r["pid"] for r in res.rows}
    assert not res.failed and [r["task"] for r in res.rows] == list(range(12))
    assert float(os.getpid()) not in pids and 1 <= len(pids) <= 2
    assert (res.plan.items, res.plan.workers, res.plan.tasks, res.plan.task_items) == (12, 2, 6, 2)
    assert 0 < res.plan.item_seconds < 60
    # the rows are those of the serial run (the pid aside), bit for bit: the same pure task function; stiffer struts,
    # stiffer machine
    kx = [r["kx"] for r in res.rows]
    assert kx == [r["kx"] for r in run_sweep(sweep).rows] and all(np.diff(kx) > 0)


def test_serial_parallel_and_dask_give_identical_rows():
    distributed = pytest.importorskip("dask.distributed")
    sweep = _sweep()
    serial = run_sweep(sweep)
    local = run_sweep(sweep, n_jobs=2)
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                                  dashboard_address=None) as cluster:
        dask = run_sweep(sweep, scheduler=cluster.scheduler_address)  # the documented path: a scheduler address
    assert serial.rows == local.rows == dask.rows  # bit-identical: the same pure task function everywhere
    assert len(serial.failed) == 2


def test_sweep_file_and_cli(tmp_path):
    import argparse

    import pkmstiff.cli.sweep as cli_sweep
    from pkmstiff.errors import InputError
    from pkmstiff.report.sweep_file import load_sweep

    s = load_sweep(SWEEPS / "hexaglide_strut_sweep.toml")
    assert len(s.tasks()) == 12 and s.tasks()[0].overrides == {"components.strut_950.k": "150.0 N/um",
                                                               "joint_types.iwf_3dof.tilt_min": "5.0 deg"}
    f = tmp_path / "s.toml"
    f.write_text("""
[sweep]
machine = "hexaglide"
mode = "random"
samples = 3
seed = 1
[[parameters]]
path = "components.strut_950.k"
unit = "N/um"
distribution = "uniform"
low = 200
high = 400
[[evaluations]]
kind = "point"
pose = [0, 0, -1000, 0, 0, 0]
quantities = ["kx"]
""")
    parser = argparse.ArgumentParser()
    cli_sweep.add_commands(parser.add_subparsers())
    args = parser.parse_args(["sweep", str(f), "--out", str(tmp_path / "r.csv"), "--quiet"])
    assert args.func(args) == 0
    rows = list(csv.DictReader((tmp_path / "r.csv").read_text().splitlines()))
    assert len(rows) == 3 and all(200 <= float(r["components.strut_950.k_N_per_um"]) <= 400 for r in rows)
    assert all(r["error"] == "" and float(r["kx_N_per_um"]) > 0 for r in rows)
    f.write_text(f.read_text().replace('distribution = "uniform"', 'distribution = "gaussian"'))
    with pytest.raises(InputError, match=r"key 'parameters\[1\].distribution'"):
        load_sweep(f)
    f.write_text(f.read_text().replace('kind = "point"', 'kind = "point"\ncolour = 2'))
    with pytest.raises(InputError, match=r"key 'parameters\[1\].distribution'|key 'evaluations\[1\].colour'"):
        load_sweep(f)
