"""Workspace of a bundled machine: convergence over the resolution, reach box, CLI (spec models.md §7.3-§7.5)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pkmstiff import load_machine
from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.cli import main
from pkmstiff.workspace.translational import constant_orientation_workspace, fit_box, reach_box

# the working region of the Hexaglide below its guides; extents 12.5 mm * 2**k (spec §7.4: halving)
BELOW = (np.array([-1.6, -0.4, -1.9]), np.array([1.6, 1.2, -0.3]))


@pytest.fixture(scope="module")
def hexaglide_runs(hexaglide):
    return {eps: constant_orientation_workspace(hexaglide, eps, box=BELOW, methods=("surface_nets", "divergence"))
            for eps in (0.0125, 0.00625)}


def test_volume_converged_within_one_percent(hexaglide_runs):
    v1, v2 = (hexaglide_runs[e].volume for e in (0.0125, 0.00625))
    assert v2 > 0.1  # a real workspace (m^3)
    assert abs(v1 / v2 - 1) < 0.01  # issue 6: < 1 % between two resolutions in the converged range
    # the eq. 4.1 surface converges from below and more slowly (half a voxel inside the boundary)
    d1, d2 = (hexaglide_runs[e].volumes["divergence"] for e in (0.0125, 0.00625))
    assert d1 < d2 < v2


def test_boundary_is_closed_and_separates_admissible_from_inadmissible(hexaglide, hexaglide_runs):
    res = hexaglide_runs[0.0125]
    assert not res.octree.touches_box
    assert res.surface.is_closed()
    o = res.octree
    # every leaf has both kinds of corners, and the stored corner values are the pipeline's
    n = o.leaf_corners.sum(axis=1)
    assert np.all((n > 0) & (n < 8))
    rng = np.random.default_rng(0)
    pick = rng.choice(o.leaf_index.shape[0], 300, replace=False)
    corners = o.point(o.leaf_index[pick][:, None, :] + np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1]
                                                                  for c in range(8)])[None]).reshape(-1, 3)
    ok = evaluate_poses(hexaglide, np.column_stack([corners, np.zeros((len(corners), 3))])).ok
    assert np.array_equal(ok.reshape(-1, 8), o.leaf_corners[pick])
    # boundary points (eq. 4.1) are inside the reported bounding box, which lies inside the initial box
    lo, hi = res.bounding_box()
    assert np.all(lo >= BELOW[0]) and np.all(hi <= BELOW[1])


def test_reach_box_contains_every_admissible_pose(hexaglide):
    lo, hi = reach_box(hexaglide)
    rng = np.random.default_rng(1)
    wide_lo, wide_hi = lo - 1.0, hi + 1.0
    x = np.column_stack([rng.uniform(wide_lo, wide_hi, (40_000, 3)), np.zeros((40_000, 3))])
    ok = evaluate_poses(hexaglide, x).ok
    assert ok.sum() > 100  # about 0.5 % of this wide box is admissible
    assert np.all((x[ok, :3] >= lo) & (x[ok, :3] <= hi))
    flo, fhi = fit_box(lo, hi, 0.0125)
    ext = (fhi - flo) / 0.0125
    assert np.all(flo <= lo) and np.all(fhi >= hi)
    assert np.allclose(np.log2(ext), np.round(np.log2(ext)))  # extents = eps * 2**k
    assert np.allclose(fit_box(flo, fhi, 0.00625)[0], flo)  # nested lattices for eps / 2


def test_requirement_shrinks_the_workspace(hexaglide):
    base = constant_orientation_workspace(hexaglide, 0.05, box=BELOW, methods=("surface_nets",))
    strict = constant_orientation_workspace(hexaglide, 0.05, box=BELOW, methods=("surface_nets",),
                                            requirements=["kappa<=60"])
    assert 0 < strict.volume < base.volume
    assert strict.stats["requirement_poses"] > 0


def test_cli_workspace_json_and_files(tmp_path, capsys):
    out = tmp_path / "ws"
    code = main(["workspace", "hexaglide", "--resolution", "50", "--box=-1600,1600,-400,1200,-1900,-300",
                 "--out", str(out), "--json", "--quiet", "--no-plot"])
    assert code == 0
    rep = json.loads(capsys.readouterr().out)
    for key in ("volume_m3", "bounding_box_mm", "boundary_points", "evaluations", "run_time_s"):
        assert key in rep
    assert rep["effective_resolution_mm"] == [50.0, 50.0, 50.0]
    assert (out / "workspace_surface.stl").stat().st_size > 0
    pts = np.loadtxt(out / "boundary_points.csv", delimiter=",", skiprows=1)
    assert pts.shape == (rep["boundary_points_distinct"], 3)
    assert rep["boundary_points_distinct"] <= rep["boundary_points"]
    assert np.unique(pts, axis=0).shape == pts.shape  # each point once (neighbouring leaves can share a centroid)
    assert np.all(pts.min(axis=0) >= np.array(rep["bounding_box_mm"]["min"]) - 1e-3)


def test_cli_rotation_map_and_errors(tmp_path, capsys):
    code = main(["rotation-map", "hexaglide", "--plane", "yz", "--at", "0", "--range", "y=0:600,z=-1100:-800",
                 "--step", "100", "--directions", "+a,-b", "--increment", "3",
                 "--json", "--out", str(tmp_path), "--no-plot"])
    assert code == 0
    rep = json.loads(capsys.readouterr().out)
    assert set(rep["angles"]) == {"+a", "-b"} and rep["increment_deg"] == pytest.approx(3.0, rel=1e-12)
    table = pd.read_csv(tmp_path / "rotation_map_pa.csv")  # plain CSV, one row per raster point
    assert list(table.columns) == ["y_mm", "z_mm", "max_angle_deg"] and len(table) == 4 * 7
    assert np.allclose(table["y_mm"].to_numpy()[:7], np.arange(0, 601, 100), atol=1e-9)
    grid = table["max_angle_deg"].to_numpy().reshape(4, 7)
    assert json.loads((tmp_path / "rotation_map_pa.json").read_text())["direction"] == "+a"
    assert np.nanmax(grid) == pytest.approx(rep["angles"]["+a"]["max_deg"])
    assert np.allclose(grid[np.isfinite(grid)] / 3.0, np.rint(grid[np.isfinite(grid)] / 3.0), atol=1e-6)  # lattice
    assert main(["workspace", "hexaglide", "--resolution", "-5"]) == 2
    assert main(["workspace", "hexaglide", "--resolution", "50", "--require", "kappa<=abc"]) == 2
    assert main(["rotation-map", "hexaglide", "--u-range", "0,600", "--v-range=-1100,-800",
                 "--directions", "+x"]) == 2
    err = capsys.readouterr().err
    assert "--resolution" in err and "--require" in err and "--directions" in err


def test_figures_are_written(tmp_path, hexaglide):
    from pkmstiff.plots.workspace import plot_workspace

    res = constant_orientation_workspace(hexaglide, 0.1, box=BELOW, methods=("surface_nets",))
    png = plot_workspace(res, hexaglide, tmp_path / "ws.png", window_size=(400, 300))
    assert png.stat().st_size > 10_000  # a rendered image, not an empty canvas
    pytest.importorskip("matplotlib")
    from pkmstiff.plots.workspace import plot_rotation_maps
    from pkmstiff.workspace.rotation import rotation_angle_map

    rm = rotation_angle_map(hexaglide, [0, 0, 0], [0, 1, 0], [0, 0, 1], np.arange(0.0, 0.61, 0.2),
                            np.arange(-1.1, -0.79, 0.1), direction=("+a", "-a"), increment=np.radians(5))
    assert plot_rotation_maps(rm, tmp_path / "rm.png").stat().st_size > 10_000


def test_thin_workspace_is_found_by_a_finer_start_grid():
    # The Linapod's usable workspace (0 <= z <= ~0.7 m above its table) is thinner than the 0.8 m spacing of the
    # level-3 start grid of its default box; the octree must start finer instead of reporting an empty workspace.
    from pkmstiff.workspace.translational import constant_orientation_workspace

    ws = constant_orientation_workspace(load_machine("linapod"), 0.05, (0.0, 0.0, 0.0))
    assert ws.settings["start_level"] > 3
    assert ws.volume > 0.5  # m^3; 0.657 m^3 at 25 mm


@pytest.mark.parametrize("name", ["hexaglide", "hexapod_6x"])
@pytest.mark.parametrize(("checks_left_out", "prefilter"), [((), True), ((), False), (("drive_range",), True),
                                                            (("drive_load", "singularity"), True)])
def test_fused_kernel_gives_the_staged_admissibility_and_counts(monkeypatch, name, checks_left_out, prefilter):
    """The octree oracle's fused path (no requirements; a batch of up to FUSED_CHUNK poses in one call, a larger one
    after the prefilter): the same admissibility and the same counters per pose and in total (poses, full-pipeline
    poses: those the prefilter of inverse kinematics and drive ranges lets through) as the staged array path, on
    poses around the workspace that fail every kind of check (unreachable ones included)."""
    import pkmstiff.admissibility.checks as adm
    from pkmstiff.admissibility import fastpath
    from pkmstiff.workspace import oracle as O

    m = load_machine(name)
    checks = adm.checks_without(checks_left_out, "test")
    lo, hi = reach_box(m)
    rng = np.random.default_rng(21)
    n = 9000
    poses = np.concatenate([lo - 0.1 + rng.random((n, 3)) * (hi - lo + 0.2), rng.normal(scale=0.15, size=(n, 3))], 1)
    evaluate_poses(m, poses[:5000])  # the compiled kernels loaded: the fused path applies
    assert fastpath.usable(m, 1)

    def run(k):
        st, per = O.EvaluationStats(), np.zeros((k, 3), np.int64)
        ok = O.staged_admissible(m, poses[:k], checks, (), st, prefilter, 4000, per_pose=per)
        return ok, per, (st.poses, st.full_pipeline, st.requirement_poses)

    sizes = (fastpath.FUSED_CHUNK, n)  # one call; chunks of 4000 poses, each prefiltered, then in calls
    fused = [run(k) for k in sizes]
    monkeypatch.setattr(fastpath, "usable", lambda machine, n_poses: False)
    for k, f, staged in zip(sizes, fused, [run(k) for k in sizes]):
        assert np.array_equal(f[0], staged[0]) and np.array_equal(f[1], staged[1]) and f[2] == staged[2]
        assert 0 < f[0].sum() < k  # admissible and inadmissible poses both occur
        filtered = prefilter and "drive_range" in checks
        assert (0 < f[2][1] < k) if filtered else f[2][1] == k  # ... and the prefilter rules some out
