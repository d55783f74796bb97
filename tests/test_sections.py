"""Workspace sections: raster orientation, masking, statistics, plots, exports, parallel evaluation."""

import json

import meshio
import numpy as np
import pytest

import pkmstiff.evaluation.quantities as quantities
from pkmstiff.admissibility.checks import Reason
from pkmstiff.evaluation.export import to_csv, to_npz, to_vtk
from pkmstiff.evaluation.quantities import EvalContext, Quantity, register_quantity
from pkmstiff.evaluation.sections import SectionError, axis_plane, evaluate_section, general_plane


@pytest.fixture(scope="module")
def yz(hexaglide):
    plane = axis_plane("yz", 0.0, (-0.6, 0.8), (-1.2, -0.5), 0.05)
    return evaluate_section(hexaglide, plane, ["y", "z", "kappa", "tilt_drive_1"])


@pytest.fixture
def test_field(monkeypatch):
    """An analytic test field f = 2 y - 3 z + 0.5 (m), registered like any quantity for one test only."""
    monkeypatch.setattr(quantities, "_REGISTRY", dict(quantities._REGISTRY))
    register_quantity(Quantity("_test_field", "analytic test field", "m", "m",
                               lambda c: 2 * c.poses[:, 1] - 3 * c.poses[:, 2] + 0.5))


def test_raster_orientation(hexaglide, test_field):
    plane = axis_plane("yz", 0.1, (-0.2, 0.4), (-1.1, -0.9), 0.1)
    assert plane.shape == (3, 7)  # rows along v = z, columns along u = y
    res = evaluate_section(hexaglide, plane, ["_test_field", "x", "y", "z"])
    vv, uu = np.meshgrid(plane.v_values, plane.u_values, indexing="ij")
    expect = 2 * uu - 3 * vv + 0.5
    ok = res.ok
    assert ok.sum() >= 5
    np.testing.assert_allclose(res.values["_test_field"][ok], expect[ok], rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.values["x"][ok], 0.1, atol=1e-15)  # the plane sits at x = 0.1 m
    np.testing.assert_allclose(res.values["y"][ok], uu[ok], atol=1e-15)
    assert np.all(np.isnan(res.values["_test_field"][~ok]))
    # display unit of positions is mm
    np.testing.assert_allclose(res.display("z")[ok], vv[ok] * 1e3, rtol=1e-12)


def test_xz_and_general_planes(hexaglide):
    xz = axis_plane("xz", 0.2, (-0.3, 0.3), (-1.1, -0.8), 0.1)
    np.testing.assert_allclose(xz.points()[:, 1], 0.2)
    g = general_plane((0, 0.2, -1.0), (1, 1, 0), (0, 0, 1), (-0.1, 0.1), (-0.1, 0.1), 0.1)
    pts = g.points()
    # every raster point lies in the plane through the origin spanned by the two axes
    np.testing.assert_allclose((pts - [0, 0.2, -1.0]) @ np.cross(g.u_axis, g.v_axis), 0.0, atol=1e-15)
    with pytest.raises(SectionError, match="'yz', 'xz' or 'xy'"):
        axis_plane("ab", 0.0, (0, 1), (0, 1), 0.1)
    with pytest.raises(SectionError, match="lo < hi"):
        axis_plane("yz", 0.0, (1, 0), (0, 1), 0.1)


def test_masking_and_reasons(yz):
    assert yz.ok.any() and (~yz.ok).any()
    assert np.all((yz.reasons == 0) == yz.ok)
    for name in yz.values:
        assert np.all(np.isnan(yz.values[name][~yz.ok]))
        assert np.all(np.isfinite(yz.values[name][yz.ok]))
    counts = yz.reason_counts()
    assert counts["UNREACHABLE"] > 0  # the lower part of the raster is out of reach of the struts
    # a point far below is unreachable and carries only that reason
    iv, iu = 0, int(np.argmin(np.abs(yz.plane.u_values - 0.0)))
    assert yz.plane.v_values[iv] == pytest.approx(-1.2) and yz.plane.u_values[iu] == pytest.approx(0.0)
    assert yz.reasons[iv, iu] == int(Reason.UNREACHABLE)


def test_statistics_on_a_synthetic_field(hexaglide, test_field):
    plane = axis_plane("yz", 0.0, (-0.6, 0.8), (-1.2, -0.5), 0.05)
    res = evaluate_section(hexaglide, plane, ["_test_field"])
    vv, uu = np.meshgrid(plane.v_values, plane.u_values, indexing="ij")
    f = (2 * uu - 3 * vv + 0.5)[res.ok]
    st = res.statistics()["_test_field"]
    assert st["min"] == pytest.approx(f.min(), abs=1e-12)
    assert st["max"] == pytest.approx(f.max(), abs=1e-12)
    assert st["mean"] == pytest.approx(f.mean(), abs=1e-12)
    assert st["count"] == res.ok.sum()
    # area: one 50 mm x 50 mm cell per admissible point
    assert st["admissible_area_m2"] == pytest.approx(res.ok.sum() * 0.05 * 0.05, rel=1e-12)
    assert st["unit"] == "m"


def test_parallel_equals_serial(hexaglide):
    plane = axis_plane("yz", 0.0, (-0.6, 0.8), (-1.2, -0.5), 0.02)
    a = evaluate_section(hexaglide, plane, ["kappa", "tilt_platform_3"], chunk_size=500)
    b = evaluate_section(hexaglide, plane, ["kappa", "tilt_platform_3"], chunk_size=500, n_jobs=2)
    np.testing.assert_array_equal(a.ok, b.ok)
    np.testing.assert_array_equal(a.reasons, b.reasons)
    for n in a.values:
        np.testing.assert_array_equal(a.values[n], b.values[n])  # bitwise: chunks are independent


def test_vtk_round_trip(tmp_path, yz):
    path = to_vtk(yz, tmp_path / "section.vtu")
    assert json.loads(path.with_suffix(".json").read_text())["machine"] == "hexaglide"
    mesh = meshio.read(path)
    nv, nu = yz.plane.shape
    np.testing.assert_allclose(mesh.points, yz.plane.points() * 1e3, rtol=0, atol=1e-9)
    got = mesh.point_data["tilt_drive_1_deg"].ravel()
    np.testing.assert_allclose(got, yz.display("tilt_drive_1").ravel(), rtol=1e-12, equal_nan=True)
    np.testing.assert_array_equal(mesh.point_data["reason_code"].ravel(), yz.reasons.ravel())


def test_csv_and_npz(tmp_path, yz):
    import pandas as pd

    p = to_csv(yz, tmp_path / "s.csv")
    meta = json.loads(p.with_suffix(".json").read_text())  # the metadata beside the table
    assert meta["machine"] == "hexaglide" and meta["units"]["kappa"] == "1"
    assert meta["columns"]["tilt_drive_1_deg"] == {"quantity": "tilt_drive_1", "unit": "deg"}
    df = pd.read_csv(p)  # no options: a plain table
    assert {"x_mm", "y_mm", "z_mm", "u_mm", "v_mm", "tilt_drive_1_deg", "kappa"} <= set(df.columns)
    assert len(df) == yz.ok.size
    np.testing.assert_allclose(df["tilt_drive_1_deg"], yz.display("tilt_drive_1").ravel(), rtol=1e-9,
                               equal_nan=True)  # 10 significant digits written
    z = np.load(to_npz(yz, tmp_path / "s.npz"))
    np.testing.assert_array_equal(z["tilt_drive_1_deg"], yz.display("tilt_drive_1"))
    assert json.loads(str(z["metadata"]))["orientation_deg"] == [0.0, 0.0, 0.0]


def test_png_written_and_not_blank(tmp_path, yz, hexaglide):
    from PIL import Image

    from pkmstiff.evaluation.sections import evaluate_three_planes, three_planes
    from pkmstiff.plots.section_maps import plot_section, plot_three_planes

    path = plot_section(yz, "tilt_drive_1", tmp_path / "map.png", window_size=(500, 380))
    img = np.asarray(Image.open(path).convert("RGB"), float)
    assert img.shape[0] == 380 and img.std() > 10  # not a uniform image
    colourful = (img.max(axis=2) - img.min(axis=2)) > 60  # pixels of the colour map (not grey/white/black)
    assert colourful.mean() > 0.05
    rs = evaluate_three_planes(hexaglide, three_planes((0, 0.1, -0.9), (0.5, 0.6, 0.3), 0.1), ["kappa"])
    p3 = plot_three_planes(rs, "kappa", hexaglide, [0, 0, -1.0, 0, 0, 0], tmp_path / "three.png",
                           window_size=(500, 400))
    assert np.asarray(Image.open(p3).convert("L"), float).std() > 10


def test_unknown_quantity(hexaglide):
    from pkmstiff.evaluation.quantities import UnknownQuantityError

    plane = axis_plane("yz", 0.0, (0, 0.1), (-1.0, -0.9), 0.1)
    with pytest.raises(UnknownQuantityError, match="unknown quantity 'kq'.*tilt_drive_1"):
        evaluate_section(hexaglide, plane, ["kq"])


def test_context_cache_shares_work(hexaglide):
    from pkmstiff.admissibility.pipeline import evaluate_poses

    calls = []
    ctx = EvalContext(hexaglide, evaluate_poses(hexaglide, [[0, 0, -1.0, 0, 0, 0]]))
    for _ in range(3):
        ctx.cached("k", lambda: calls.append(1) or 42)
    assert calls == [1]


def test_structure_quantities_match_the_point_analysis(hexaglide):
    from pkmstiff.admissibility.pipeline import evaluate_poses
    from pkmstiff.analysis import evaluate_structure
    from pkmstiff.evaluation.quantities import evaluate_quantities

    poses = np.array([[0, 0, -1.0, 0, 0, 0], [0, 0.3, -0.95, 0, 0, 0]])
    ctx = EvalContext(hexaglide, evaluate_poses(hexaglide, poses), tool_length=0.15)
    q = evaluate_quantities(ctx, ["kx", "ky", "kz", "krz", "f1", "f7", "kmin"] +
                            [f"share_{c}_x" for c in ("drive", "guide", "drive_joint", "strut", "platform_joint",
                                                      "platform_spindle")])
    ref = evaluate_structure(hexaglide, poses, tool_length=0.15, n_modes=7)
    np.testing.assert_allclose(q["kx"], ref.stiffness[:, 0], rtol=1e-12)
    np.testing.assert_allclose(q["krz"], ref.stiffness[:, 5], rtol=1e-12)
    np.testing.assert_allclose(q["f7"], ref.frequencies_hz[:, 6], rtol=1e-12)
    np.testing.assert_allclose(q["f1"], ref.frequencies_hz[:, 0], rtol=1e-12)
    # the weakest translational direction is never stiffer than an axis direction
    assert np.all(q["kmin"] <= np.minimum(np.minimum(q["kx"], q["ky"]), q["kz"]) * (1 + 1e-12))
    # component shares of the x-compliance sum to one (energy shares, spec §5.1 weak points)
    total = sum(v for k, v in q.items() if k.startswith("share_"))
    np.testing.assert_allclose(total, 1.0, rtol=1e-9)


def test_section_of_structure_quantities(hexaglide):
    plane = axis_plane("yz", 0.0, (-0.1, 0.1), (-1.05, -0.95), 0.05)
    res = evaluate_section(hexaglide, plane, ["kx", "f1"], tool_length=0.0)
    assert res.ok[1, 2] and res.ok.sum() >= 10
    centre = res.values["kx"][1, 2]  # v = -1.0 m is row 1, u = 0 is column 2
    from pkmstiff.analysis import evaluate_structure

    ref = evaluate_structure(hexaglide, [[0, 0, -1.0, 0, 0, 0]], tool_length=0.0)
    assert centre == pytest.approx(ref.stiffness[0, 0], rel=1e-12)
    assert res.units["kx"] == "N/um" and res.display("kx")[1, 2] == pytest.approx(centre * 1e-6)


def test_mode_shape_figure_and_gif(tmp_path, hexaglide):
    from PIL import Image

    from pkmstiff.analysis.modal import modal_analysis
    from pkmstiff.plots.modes import animate_mode_shape, mode_shape, plot_mode_shape
    from pkmstiff.structure import build_structure

    pose = [0.0, 0.0, -1.0, 0.0, 0.0, 0.0]
    ms = mode_shape(hexaglide, pose, 2)
    ref = modal_analysis(build_structure(hexaglide, [pose]), 6)
    assert ms.frequency_hz == pytest.approx(ref.frequencies_hz[0, 1], rel=1e-12)
    assert ms.description == ref.description(0, 1)
    # the platform moves as a rigid body: the distances between its joints are preserved to first order
    d0 = np.linalg.norm(ms.p[0] - ms.p[3])
    eps = 1e-6
    d1 = np.linalg.norm(ms.p[0] + eps * ms.dp[0] - ms.p[3] - eps * ms.dp[3])
    assert abs(d1 - d0) < 1e-3 * eps * np.abs(ms.dp).max()
    png = plot_mode_shape(hexaglide, pose, tmp_path / "mode.png", mode=1, window_size=(400, 320))
    assert np.asarray(Image.open(png).convert("L"), float).std() > 10
    gif = animate_mode_shape(hexaglide, pose, tmp_path / "mode.gif", mode=1, frames=4, window_size=(240, 200))
    with Image.open(gif) as im:
        assert im.n_frames == 4


def test_statistics_quantiles_on_a_synthetic_field(hexaglide, test_field):
    """p1, p5, p95, p99 are numpy's linear quantiles of the admissible values (1e-12 m: the same arithmetic on the
    same values) and ordered min <= p1 <= p5 <= mean-range <= p95 <= p99 <= max."""
    plane = axis_plane("yz", 0.0, (-0.6, 0.8), (-1.2, -0.5), 0.05)
    res = evaluate_section(hexaglide, plane, ["_test_field"])
    vv, uu = np.meshgrid(plane.v_values, plane.u_values, indexing="ij")
    f = (2 * uu - 3 * vv + 0.5)[res.ok]
    st = res.statistics()["_test_field"]
    for key, q in (("p1", 0.01), ("p5", 0.05), ("p95", 0.95), ("p99", 0.99)):
        assert st[key] == pytest.approx(np.quantile(f, q), abs=1e-12)
    assert st["min"] <= st["p1"] <= st["p5"] <= st["p95"] <= st["p99"] <= st["max"]


def test_near_singular_points_are_counted_and_do_not_set_the_quantiles(hexaglide):
    """Issue 22 item 4: next to the singularity boundary k_x and f1 fall towards zero while the pose stays admissible.
    The points with κ above NEAR_SINGULAR_FRACTION × threshold are the ones near_singular marks (exactly the κ test
    on the stored κ), their count is in the statistics and the summary, they stay admissible (the spec's threshold
    is the rule), and the 5 % quantile is not set by them: it lies above every near-singular value."""
    from pkmstiff.admissibility.checks import NEAR_SINGULAR_FRACTION
    from pkmstiff.evaluation.sections import section_summary
    from pkmstiff.machine.frames import neglect_spindle
    from pkmstiff.workspace.windows import window_for

    m = neglect_spindle(hexaglide)
    res = evaluate_section(m, window_for(m, "yz", 0.0, 0.01, frame="report"), ["kx", "f1"], tool_length=0.0,
                           frame="report")
    limit = NEAR_SINGULAR_FRACTION * m.limits.singularity_threshold
    near = res.near_singular
    with np.errstate(invalid="ignore"):
        assert np.array_equal(near, res.ok & (res.kappa > limit))
    assert near.sum() >= 1 and np.all(res.ok[near]) and np.all(res.kappa[res.ok] <= m.limits.singularity_threshold)
    st = res.statistics()
    kx, f1 = res.display("kx"), res.display("f1")
    for name, vals in (("kx", kx), ("f1", f1)):
        assert st[name]["near_singular_points"] == near.sum()
        assert st[name]["min"] == vals[near].min()  # the degenerate points set the minimum ...
        assert st[name]["p5"] > vals[near].max()  # ... but not the headline 5 % quantile
    summary = section_summary(res)
    assert summary["near_singular"]["points"] == near.sum()
    assert summary["near_singular"]["kappa_above"] == pytest.approx(limit, rel=1e-15)


def test_writing_large_outputs_shows_progress(tmp_path, yz, capsys, monkeypatch):
    """Issue 22: writing the files of a large section reports progress per file (a line every PROGRESS_INTERVAL_S
    when stderr is not a terminal; the interval is set to 0 here so that every file prints one)."""
    from pkmstiff.evaluation import progress
    from pkmstiff.report.outputs import write_section_outputs

    monkeypatch.setattr(progress, "PROGRESS_INTERVAL_S", 0.0)
    paths = write_section_outputs(yz, tmp_path, ("vtu", "csv", "npz"), "s", progress=True)
    err = capsys.readouterr().err.splitlines()
    assert [ln.split(" (")[1].split(")")[0] for ln in err] == ["0/3 files", "1/3 files", "2/3 files"]
    assert all(p.exists() for p in paths)
    write_section_outputs(yz, tmp_path, ("csv",), "t")  # a small section: no progress by default
    assert capsys.readouterr().err == ""
