"""Figures a user would put in a report (issue 12, item 5; issue 28, item 1): the drawing of every figure kind fills
at least 80 % of the canvas (bounding box of the non-background pixels), every text is at least 9 pt at print size
(matplotlib: at the figure's size in inches; pyvista: measured in the rendered image, tests/figure_checks.py), a
saved matplotlib figure keeps a background border of EDGE_PX pixels (nothing cut at the canvas edge), maps
carry µm/° units, titles state the real window ranges, colour scales show the structure where one hot spot dominates.

``test_every_figure_kind_fills_its_canvas_with_readable_text`` runs every figure kind of the package and of the
studies (map panels, component curves, rotation panels, the validation's cause maps; their own plot functions on small
inputs) with ``Figure.savefig`` and ``Plotter.screenshot`` watched: every saved figure and screenshot is checked;
``test_the_checks_fail_on_a_bad_figure`` shows that the checks can fail;
``test_every_docs_image_has_a_checked_figure_kind`` maps every PNG in docs/images to its kind (or to a reasoned
exclusion: browser screenshots), so that a new image without a checked kind fails.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.figure_checks import EDGE_PX, MIN_FILL, MIN_PT, edge_pixels, fill_fraction, pyvista_text_pt, smallest_text_pt


@pytest.fixture(scope="module")
def yz_section(hexaglide):
    from pkmstiff.evaluation.sections import evaluate_section
    from pkmstiff.workspace.windows import window_for

    return evaluate_section(hexaglide, window_for(hexaglide, "yz", 0.0, 0.04), ["kx"], tool_length=0.0)


def test_section_and_admissibility_maps_fill_the_canvas(tmp_path, yz_section):
    from pkmstiff.plots.section_maps import _map_title, plot_reasons, plot_section, pretty_unit

    assert fill_fraction(plot_section(yz_section, "kx", tmp_path / "kx.png")) >= MIN_FILL
    assert fill_fraction(plot_reasons(yz_section, tmp_path / "reasons.png")) >= MIN_FILL
    assert pretty_unit("N*m/urad") == "N·m/µrad" and pretty_unit("N/um") == "N/µm" and pretty_unit("deg") == "°"
    title = _map_title(yz_section)
    u = yz_section.plane.u_values
    assert f"{u[0] * 1e3:g}…{u[-1] * 1e3:g} mm" in title and "machine frame" in title


def test_three_planes_fill_the_canvas(tmp_path, hexaglide):
    from pkmstiff.evaluation.sections import evaluate_three_planes, three_planes
    from pkmstiff.plots.section_maps import plot_three_planes

    rs = evaluate_three_planes(hexaglide, three_planes((0, 0.1, -0.9), (0.5, 0.6, 0.3), 0.1), ["kappa"])
    path = plot_three_planes(rs, "kappa", hexaglide, [0, 0, -1.0, 0, 0, 0], tmp_path / "three.png",
                             window_size=(550, 450))
    assert fill_fraction(path) >= MIN_FILL


def test_mode_shape_fills_the_canvas_and_has_a_triad(tmp_path, hexaglide):
    from PIL import Image

    from pkmstiff.plots.modes import plot_mode_shape

    path = plot_mode_shape(hexaglide, np.array([0, 0.3, -0.9, 0, 0, 0]), tmp_path / "mode.png", mode=1)
    assert fill_fraction(path) >= MIN_FILL
    img = np.asarray(Image.open(path).convert("RGB")).astype(int)
    red = (img[..., 0] > 200) & (img[..., 1] < 60) & (img[..., 2] < 60)  # the x arrow of the axis triad
    assert red.sum() > 50


def test_workspace_figure_fills_the_canvas(tmp_path, hexaglide):
    from pkmstiff.plots.workspace import plot_workspace
    from pkmstiff.workspace.requests import WorkspaceRequest
    from pkmstiff.workspace.translational import DEFAULT_METHODS

    res = WorkspaceRequest(0.08, None, (), (0.0, 0.0, 0.0), DEFAULT_METHODS).evaluate(hexaglide)
    assert fill_fraction(plot_workspace(res, hexaglide, tmp_path / "ws.png", window_size=(800, 600))) >= MIN_FILL


def test_rotation_map_fills_the_canvas(tmp_path, hexaglide):
    from pkmstiff.plots.workspace import plot_rotation_maps
    from pkmstiff.workspace.requests import RotationMapRequest

    u = tuple(np.arange(-0.2, 0.61, 0.1))
    v = tuple(np.arange(-1.05, -0.49, 0.1))
    req = RotationMapRequest((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), u, v, ("+a",), (0.0, 0.0, 0.0),
                             np.radians(2.0), np.radians(60.0), (), "predictor_corrector")
    res = req.evaluate(hexaglide)
    path = plot_rotation_maps(res, tmp_path / "rot.png", ("y [mm]", "z [mm]"), (1e3, 1e3), "hexaglide: test")
    assert fill_fraction(path) >= MIN_FILL


def test_3d_axes_ticks_are_round_and_inside():
    # readable 3-D axes (issue 12 item 5): 3-6 ticks at a step of 1, 2, 2.5 or 5 x 10^k within the range
    from pkmstiff.plots.axes3d import nice_ticks

    for lo, hi in [(-158.0, 917.0), (-1224.0, -499.0), (-900.0, 900.0), (0.1, 0.37), (-250.0, 1150.0)]:
        t = nice_ticks(lo, hi)
        assert 3 <= t.size <= 6 and t[0] >= lo and t[-1] <= hi
        step = float(t[1] - t[0])
        mantissa = step / 10 ** np.floor(np.log10(step))
        assert np.isclose(mantissa, [1, 2, 2.5, 5]).any()
        np.testing.assert_allclose(np.diff(t), step, rtol=1e-12)  # evenly spaced up to round-off
        np.testing.assert_allclose(t / step, np.round(t / step), atol=1e-9)  # multiples of the step


def test_robust_colour_scale_shows_the_structure_around_a_hot_spot():
    from pkmstiff.plots.section_maps import robust_clim

    rng = np.random.default_rng(0)
    plain = rng.uniform(10.0, 40.0, 2000)
    sc = robust_clim(plain)
    assert (sc.lo, sc.hi, sc.log, sc.note) == (plain.min(), plain.max(), False, "")  # no hot spot: min..max
    spike = np.append(plain, 184.0)  # one point far above the rest: cut at the 99th percentile, said on the bar
    sc = robust_clim(spike)
    assert not sc.log and sc.hi == pytest.approx(np.percentile(spike, 99.0)) and "max 184" in sc.note
    skewed = np.exp(rng.normal(1.5, 0.8, 4000))  # log-normal: median near the bottom, more than a decade
    sc = robust_clim(skewed)
    assert sc.log and sc.lo == skewed.min() and sc.note.startswith("log scale")
    assert not robust_clim(np.append(plain, -1.0)).log  # a log scale only for positive values


def test_section_map_with_a_hot_spot_says_so_on_the_colour_bar(tmp_path, yz_section, monkeypatch):
    from matplotlib.figure import Figure

    from pkmstiff.plots import section_maps

    saved = {}
    monkeypatch.setattr(section_maps, "_save", lambda fig, path: saved.setdefault("fig", fig) and path)
    values = yz_section.display("kx").copy()
    ok = np.argwhere(np.isfinite(values))
    values[tuple(ok[0])] = 50 * np.nanmax(values)  # one hot spot
    monkeypatch.setattr(yz_section, "display", lambda name: values)
    section_maps.plot_section(yz_section, "kx", tmp_path / "kx.png")
    fig: Figure = saved["fig"]
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert any("99th percentile" in lab for lab in labels), labels
    assert smallest_text_pt(fig) >= MIN_PT


def test_mechanism_pictures_fill_the_canvas_and_have_readable_text(tmp_path):
    import pkmstiff.mechanisms as mm
    from pkmstiff.plots.mechanism import mechanism_figure

    sc = mm.load_mechanism("slider_crank")
    q = mm.forward(sc, [[0.0], [0.010], [-0.080]], steps=4).q
    fig = mechanism_figure(sc, q, tmp_path / "sc.png", labels=["home", "s = 10 mm", "s = -80 mm"])
    assert smallest_text_pt(fig) >= MIN_PT
    assert fill_fraction(tmp_path / "sc.png") >= MIN_FILL
    hyb = mm.load_mechanism("hybrid_tripod_wrist")
    q = mm.forward(hyb, [[0.0, 0.0, 0.0, 0.0, np.radians(20)], [0.05, -0.02, 0.01, 0.4, np.radians(40)]], steps=4).q
    fig = mechanism_figure(hyb, q, tmp_path / "hyb.png", labels=["home", "second"])
    assert smallest_text_pt(fig) >= MIN_PT
    assert fill_fraction(tmp_path / "hyb.png") >= MIN_FILL


def test_calibration_parameter_figure_shows_sigma_on_its_own_scale():
    from pkmstiff.plots.calibration import parameter_figure

    names = [f"p{i}" for i in range(6)]
    values = np.array([2e-3, -1e-3, 4e-3, 1e-3, 2e-4, -3e-4])  # mm-scale errors
    sigma = np.full(6, 5e-6)  # 5 µm: invisible as an error bar at the values' scale
    fig = parameter_figure(names, values, sigma, ["m"] * 4 + ["rad"] * 2)
    assert smallest_text_pt(fig) >= MIN_PT
    sigma_axes = [ax for ax in fig.axes if ax.get_xlabel().startswith("2σ")]
    assert [ax.get_xlabel() for ax in sigma_axes] == ["2σ [µm]", "2σ [µrad]"]
    widths = [p.get_width() for p in sigma_axes[0].patches]
    np.testing.assert_allclose(widths, 10.0)  # 2σ in µm


def test_ballbar_polar_figure_has_readable_text_and_plain_ticks():
    # an uncalibrated machine: deviations of millimetres, where "%+.3g" printed "+4e+03" on the radial axis
    from pkmstiff.calibration.ballbar import evaluate_circular_test
    from pkmstiff.plots.ballbar import polar_deviation_figure
    from tests.ballbar_synth import circle_run

    ccw = circle_run(0.15, 600, radius_error=3e-3, lobes={2: (2e-3, 0.0)})
    ev = evaluate_circular_test(ccw.positions, ccw.reading, (0, 0, 0), 0.15, direction=np.array(["ccw"] * 600))
    fig = polar_deviation_figure(ev)
    assert smallest_text_pt(fig) >= MIN_PT
    ticks = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    assert ticks and not any("e+" in t or "e-" in t for t in ticks), ticks


def test_rotation_map_colour_map_is_perceptual_with_zero_as_data(tmp_path, hexaglide, monkeypatch):
    from pkmstiff.plots import workspace as wsplots
    from pkmstiff.workspace.requests import RotationMapRequest

    u = tuple(np.arange(-0.2, 0.61, 0.2))
    v = tuple(np.arange(-1.05, -0.49, 0.2))
    req = RotationMapRequest((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), u, v, ("+a",), (0.0, 0.0, 0.0),
                             np.radians(5.0), np.radians(60.0), (), "predictor_corrector")
    res = req.evaluate(hexaglide)
    figs = []
    real = wsplots._figure
    monkeypatch.setattr(wsplots, "_figure", lambda size: figs.append(real(size)) or figs[-1])
    wsplots.plot_rotation_maps(res, tmp_path / "rot.png", ("y [mm]", "z [mm]"), (1e3, 1e3), "hexaglide: test")
    from pkmstiff.workspace.rotation import rotational_workspace_map

    rw = [rotational_workspace_map(hexaglide, (0.0, 0.4, -1.0), "+a", np.radians(np.arange(-30, 30.1, 15.0)),
                                   np.radians(np.arange(-60, 60.1, 30.0)))]
    wsplots.plot_rotational_workspace(rw, tmp_path / "rotws.png", "test")
    for fig in figs:  # the rotation maps and the rotational workspace at a point
        assert smallest_text_pt(fig) >= MIN_PT
        cs = [c for ax in fig.axes for c in ax.collections if c.get_array() is not None]
        assert cs and all(c.get_cmap().name == "viridis" for c in cs)
        white = np.array([1.0, 1.0, 1.0, 1.0])
        assert not np.allclose(cs[0].get_cmap()(0.0), white)  # 0° is a colour, not the background


def test_fe_joint_image_fills_the_canvas(tmp_path):
    from pathlib import Path

    from pkmstiff.cli.fe import joint_image
    from pkmstiff.fe.joints import build_joint_model, load_joint_parameters

    params = Path(__file__).resolve().parents[1] / "pkmstiff" / "fe" / "params" / "iwf_2dof_improved.toml"
    p = load_joint_parameters(params)
    path = joint_image(build_joint_model(p), 45.0, tmp_path / "joint.png")
    assert fill_fraction(path) >= MIN_FILL


def test_remaining_matplotlib_kinds_have_readable_text(tmp_path, monkeypatch):
    # the calibration path, the harmonic spectrum, volume over orientation and the convergence plot: >= 9 pt
    from pkmstiff.calibration.ballbar import evaluate_circular_test
    from pkmstiff.plots import workspace as wsplots
    from pkmstiff.plots.ballbar import harmonic_spectrum_figure
    from pkmstiff.plots.calibration import path_figure
    from tests.ballbar_synth import circle_run

    t = np.linspace(0, 2 * np.pi, 200)
    pts = np.column_stack([0.3 * np.cos(t), 0.3 * np.sin(t), 0.1 + 0 * t])
    assert smallest_text_pt(path_figure(pts, np.zeros(200, int), ["circle"], np.zeros(3))) >= MIN_PT
    run = circle_run(0.15, 600, radius_error=3e-6, lobes={3: (2e-6, 0.0)})
    ev = evaluate_circular_test(run.positions, run.reading, (0, 0, 0), 0.15, direction=np.array(["ccw"] * 600))
    assert smallest_text_pt(harmonic_spectrum_figure(ev)) >= MIN_PT
    figs = []
    real = wsplots._figure
    monkeypatch.setattr(wsplots, "_figure", lambda size: figs.append(real(size)) or figs[-1])
    ang = np.radians(np.arange(-10.0, 10.1, 5.0))
    wsplots.plot_volume_vs_orientation(ang, {"a": 0.3 - 0.001 * ang ** 2, "b": 0.29 - 0.002 * ang ** 2},
                                       tmp_path / "vol.png", "test")
    eps = np.array([50.0, 25.0, 12.5])
    wsplots.plot_convergence(eps, {"sphere": {"surface_nets": eps ** 2 * 1e-3, "tetrahedron": eps * 1e-2}},
                             tmp_path / "conv.png")
    assert len(figs) == 2 and all(smallest_text_pt(f) >= MIN_PT for f in figs)


# ------------------------------------------------------------------------------------------- every figure kind
def _study(name: str):
    """A study script (studies/NAME.py) as a module: its plot functions, driven here on small inputs."""
    import importlib
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "studies"))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.pop(0)


def _kind_section_maps(tmp, m, yz):
    from pkmstiff.plots.section_maps import plot_reasons, plot_section

    plot_section(yz, "kx", tmp / "kx.png")
    plot_reasons(yz, tmp / "reasons.png")


def _kind_three_planes(tmp, m, yz):
    from pkmstiff.evaluation.sections import evaluate_three_planes, three_planes
    from pkmstiff.plots.section_maps import plot_three_planes

    rs = evaluate_three_planes(m, three_planes((0, 0.1, -0.9), (0.5, 0.6, 0.3), 0.1), ["kx"])
    plot_three_planes(rs, "kx", m, [0, 0, -1.0, 0, 0, 0], tmp / "three.png")


def _kind_mode_shape(tmp, m, yz):
    from pkmstiff.plots.modes import plot_mode_shape

    plot_mode_shape(m, np.array([0, 0.3, -0.9, 0, 0, 0]), tmp / "mode.png")


def _kind_workspace(tmp, m, yz):
    from pkmstiff.plots.workspace import plot_workspace
    from pkmstiff.workspace.requests import WorkspaceRequest
    from pkmstiff.workspace.translational import DEFAULT_METHODS

    res = WorkspaceRequest(0.08, None, (), (0.0, 0.0, 0.0), DEFAULT_METHODS).evaluate(m)
    plot_workspace(res, m, tmp / "ws.png")


def _kind_rotation(tmp, m, yz):
    from pkmstiff.plots.workspace import plot_rotation_maps, plot_rotational_workspace
    from pkmstiff.workspace.requests import RotationMapRequest
    from pkmstiff.workspace.rotation import rotational_workspace_map

    u, v = tuple(np.arange(-0.2, 0.61, 0.2)), tuple(np.arange(-1.05, -0.49, 0.2))
    req = RotationMapRequest((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), u, v, ("+a",), (0.0, 0.0, 0.0),
                             np.radians(5.0), np.radians(60.0), (), "predictor_corrector")
    plot_rotation_maps(req.evaluate(m), tmp / "rot.png", ("y [mm]", "z [mm]"), (1e3, 1e3), "hexaglide: test")
    rw = [rotational_workspace_map(m, (0.0, 0.4, -1.0), d, np.radians(np.arange(-30, 30.1, 10.0)),
                                   np.radians(np.arange(-60, 60.1, 20.0))) for d in ("+a", "+b")]
    plot_rotational_workspace(rw, tmp / "rotws.png", "Hexaglide: rotational workspace")


def _kind_workspace_curves(tmp, m, yz):
    from pkmstiff.plots.workspace import plot_convergence, plot_volume_vs_orientation

    ang = np.radians(np.arange(-10.0, 10.1, 5.0))
    plot_volume_vs_orientation(ang, {"a": 0.3 - 0.001 * ang ** 2, "b": 0.29 - 0.002 * ang ** 2}, tmp / "vol.png",
                               "test")
    eps = np.array([50.0, 25.0, 12.5])
    plot_convergence(eps, {"sphere": {"surface_nets": eps ** 2 * 1e-3, "tetrahedron": eps * 1e-2}}, tmp / "conv.png")


def _kind_mechanisms(tmp, m, yz):
    import pkmstiff.mechanisms as mm
    from pkmstiff.cli import main
    from pkmstiff.plots.mechanism import mechanism_figure

    sc = mm.load_mechanism("slider_crank")
    mechanism_figure(sc, mm.forward(sc, [[0.0], [-0.080]], steps=4).q, tmp / "sc.png", labels=["home", "s = -80 mm"])
    assert main(["section", "hybrid_tripod_wrist", "--plane", "xy", "--at", "-1073.205", "--step", "40",
                 "--quantities", "kappa", "--out", str(tmp / "mech")]) == 0


def _kind_fe_joint(tmp, m, yz):
    from pathlib import Path

    from pkmstiff.cli.fe import joint_image
    from pkmstiff.fe.joints import build_joint_model, load_joint_parameters

    params = Path(__file__).resolve().parents[1] / "pkmstiff" / "fe" / "params" / "iwf_2dof_improved.toml"
    joint_image(build_joint_model(load_joint_parameters(params)), 45.0, tmp / "joint.png")


def _kind_calibration(tmp, m, yz):
    from pkmstiff.plots.calibration import parameter_figure, path_figure

    t = np.linspace(0, 2 * np.pi, 200)
    pts = np.column_stack([0.3 * np.cos(t), 0.3 * np.sin(t), 0.1 + 0 * t])
    path_figure(pts, np.zeros(200, int), ["circle"], np.zeros(3)).savefig(tmp / "path.png", dpi=100)
    parameter_figure([f"p{i}" for i in range(4)], np.array([2e-3, -1e-3, 2e-4, -3e-4]), np.full(4, 5e-6),
                     ["m", "m", "rad", "rad"]).savefig(tmp / "params.png", dpi=100)


def _kind_ballbar(tmp, m, yz):
    from pkmstiff.calibration.ballbar import evaluate_circular_test
    from pkmstiff.calibration.ballbar_diagnosis import diagnose
    from pkmstiff.plots.ballbar import save_ballbar_figures
    from tests.ballbar_synth import circle_run

    ccw = circle_run(0.15, 600, radius_error=3e-6, lobes={2: (8e-6, 0.3), 3: (2e-6, 0.0)}, noise=0.3e-6)
    cw = circle_run(0.15, 600, radius_error=3e-6, lobes={2: (8e-6, 0.3), 3: (2e-6, 0.0)}, noise=0.3e-6,
                    direction=-1, seed=1)
    ev = evaluate_circular_test(np.vstack([ccw.positions, cw.positions]), np.concatenate([ccw.reading, cw.reading]),
                                (0, 0, 0), 0.15, direction=np.array(["ccw"] * 600 + ["cw"] * 600))
    save_ballbar_figures(ev, tmp, "bb", diagnose(ev, tolerance=15e-6))


def _kind_api_plots(tmp, m, yz):
    import pkmstiff

    pts = pkmstiff.load_machine("hexaglide").point([[0, 0.1 * k, -1.0, 0, 0, 0] for k in range(4)])
    pts.plot("kx_N_per_um", path=str(tmp / "points.png"))


def _kind_study_maps(tmp, m, yz):
    common = _study("_study_common")
    MapPanel, plot_maps = common.MapPanel, common.plot_maps
    panels = [MapPanel(yz, yz.display("kx"), f"variant {k}: k_x", "N/um") for k in (1, 2)]
    plot_maps(panels, tmp / "study.png", "Study maps")


def _kind_optimise(tmp, m, yz):
    from pkmstiff.cli import main

    assert main(["optimise", "hexaglide_joint_orientation", "--out", str(tmp / "opt"), "--budget", "4", "--quiet",
                 "--no-report"]) == 0


def _kind_study_curves(tmp, m, yz):
    # the component curves of studies a (drive), b and d (joints) and study f's weak-point bars
    a, b, d, f = (_study(n) for n in ("a_hexapod_drive_model", "b_hexaglide_joint_model", "d_joint_components",
                                      "f_measurement_point"))
    lengths = np.linspace(1.2, 1.9, 8)
    a.plot_drive_curves({label: (40 + 10 * k) * 1e6 / lengths for k, (label, _) in enumerate(a.VARIANTS)}, lengths,
                        (1.4, 1.7), tmp / "a_drive.png")
    tilts = {label: {"tilt min": 10.0, "tilt max": 40.0, "tilt mean": 25.0} for label, _, _ in b.JOINTS}
    b.plot_joint_curves({b.BASELINE: m, b.CONSTANT: m}, tilts, tmp / "b_joints.png")
    d.plot_joint_curves({d.BASELINE: m}, tmp / "d_joints.png")
    keys = [(dd, L) for L in f.TOOL_LENGTHS for dd in f.DIRECTIONS]
    weak = {k: {"drive": 50.0, "drive_joint": 30.0, "platform_joint": 20.0} for k in keys}
    f.plot_weak_points({"measured": {"weak": weak}, "FE joints": {"weak": weak}}, tmp / "f_weak.png")


def _kind_study_c_panels(tmp, m, yz):
    # study c's rotational-workspace grid and its admissibility-reason maps
    c = _study("c_hexaglide_variants")
    u, v = np.radians(np.arange(-30.0, 30.1, 30.0)), np.radians(np.arange(-60.0, 60.1, 60.0))
    where = {"dissertation": (0.0, 0.4, -1.0), "centre": (0.0, 0.1, -0.9)}
    one = {w: {d: m.orientation_map(p, d, u_values=u, v_values=v, increment=np.radians(10.0)) for d in ("+a", "+b")}
           for w, p in where.items()}
    labels = [lab for lab, _ in c.VARIANTS]  # the study's rows, one machine's maps here
    rot, points = dict.fromkeys(labels, one), dict.fromkeys(labels, where)
    c.plot_rotational(rot, points, tmp / "c_rot.png")
    sec = m.section("yz", 0.0, 0.1, ())
    c.plot_reason_maps({"original": sec, "variant": sec}, tmp / "c_reasons.png")


def _kind_study_g_rotation(tmp, m, yz):
    g = _study("g_machine_comparison")
    # the Hexaglide's window of the study (about 1.1 m wide, 1.9 m high), coarse
    r = m.rotation_map("yz", at=0.0, step=0.1, u_range=(-0.2, 0.9), v_range=(-1.3, 0.6), increment=np.radians(10.0))
    labels = ("Hexaglide", "6X Hexapod", "Linapod", "Paralix")  # the study's four panels, one map here
    g.plot_rotation_panels(dict.fromkeys(labels, r), dict.fromkeys(labels, 0.0),
                           {lab: (-1.0, -0.7) if k == 0 else None for k, lab in enumerate(labels)}, tmp / "g_rot.png")


def _kind_study_e_tilts(tmp, m, yz):
    # study e's tilt distribution over the joint stiffness and its optimiser history (one short run of the study's
    # fast design, 4 evaluations, shown in the panels of two objectives; reference lines at made-up k_x values)
    from pkmstiff.optimise import run_optimisation

    e = _study("e_joint_orientation")
    sec = m.section("yz", 0.0, 0.1, e.TILTS)
    e.plot_tilts({"original": sec, "optimised": sec}, m, tmp / "e_tilts.png")
    run = run_optimisation(e.design("mean", fast=True), tmp / "e_run", budget=4)
    refs = {"original": 20.0, "published": 25.0}
    e.plot_history({"mean": run, "p05": run}, {"mean": refs, "p05": refs}, tmp / "e_history.png")


def _kind_validation_causes(tmp, m, yz):
    val = _study("validation_hexaglide")
    res = m.section("yz", 0.0, 0.1, (), u_range=(-0.7, 0.9), v_range=(-1.4, -0.1),
                                                     frame="report")
    b, c = val.boundary_causes(res)
    val.plot_cause_map(res, b, c, tmp / "causes.png", "Hexaglide: YZ section at x = 0 mm\nboundary causes")


FIGURE_KINDS = {f.__name__.removeprefix("_kind_"): f for f in (
    _kind_section_maps, _kind_three_planes, _kind_mode_shape, _kind_workspace, _kind_rotation, _kind_workspace_curves,
    _kind_mechanisms, _kind_fe_joint, _kind_calibration, _kind_ballbar, _kind_api_plots, _kind_study_maps,
    _kind_optimise, _kind_study_curves, _kind_study_c_panels, _kind_study_g_rotation, _kind_study_e_tilts,
    _kind_validation_causes)}


def _watch_figures(monkeypatch):
    """Record every matplotlib figure saved (with the file and its drawn edge pixels) and the measured text of every
    pyvista screenshot."""
    from pathlib import Path

    import pyvista as pv
    from matplotlib.figure import Figure

    seen = {"mpl": [], "pv": []}
    save, shot = Figure.savefig, pv.Plotter.screenshot

    def savefig(self, fname, *a, **k):
        out = save(self, fname, *a, **k)
        # the edge is read now: an atomic write renames the file right after
        png = isinstance(fname, (str, Path)) and str(fname).endswith(".png")
        seen["mpl"].append((self, fname, edge_pixels(fname) if png else None))
        return out

    def screenshot(self, filename=None, *a, **k):
        if filename is not None and not k.get("return_img"):
            seen["pv"].append((pyvista_text_pt(self), filename))
        return shot(self, filename, *a, **k)

    monkeypatch.setattr(Figure, "savefig", savefig)
    monkeypatch.setattr(pv.Plotter, "screenshot", screenshot)
    return seen


def _check_watched(seen, tmp_path) -> list[str]:
    """What is wrong with the watched figures: fill below MIN_FILL, text below MIN_PT, matplotlib drawing within
    EDGE_PX of the canvas edge (empty: all fine)."""
    from pathlib import Path

    bad = []
    files = sorted(p for p in Path(tmp_path).rglob("*.png"))
    assert files, "no figure written"
    for f in files:
        if fill_fraction(f) < MIN_FILL:
            bad.append(f"{f.name}: fill {fill_fraction(f):.2f} < {MIN_FILL}")
    for fig, fname, edge in seen["mpl"]:
        if smallest_text_pt(fig) < MIN_PT:
            bad.append(f"{Path(str(fname)).name}: text {smallest_text_pt(fig):.1f} pt < {MIN_PT}")
        if edge:
            bad.append(f"{Path(str(fname)).name}: edge {edge} px drawn within {EDGE_PX} px of the border")
    for sizes, fname in seen["pv"]:
        assert sizes, f"{fname}: no text found in the screenshot"
        small = {k: round(v, 1) for k, v in sizes.items() if v < MIN_PT}
        if small:
            bad.append(f"{Path(str(fname)).name}: text {small} pt < {MIN_PT}")
    return bad


@pytest.mark.parametrize("kind", list(FIGURE_KINDS))
def test_every_figure_kind_fills_its_canvas_with_readable_text(kind, tmp_path, hexaglide, yz_section, monkeypatch):
    seen = _watch_figures(monkeypatch)
    FIGURE_KINDS[kind](tmp_path, hexaglide, yz_section)
    assert seen["mpl"] or seen["pv"], f"{kind}: no figure saved through matplotlib or pyvista"
    assert _check_watched(seen, tmp_path) == []


def test_the_checks_fail_on_a_bad_figure(tmp_path, monkeypatch):
    # a matplotlib figure with 6 pt ticks and its drawing in one corner, one with its y label cut at the left edge,
    # a pyvista window with a small mesh in a corner and 4-px text: every check must report them
    import pyvista as pv
    from matplotlib.figure import Figure

    seen = _watch_figures(monkeypatch)
    fig = Figure(figsize=(6.0, 4.0))
    ax = fig.add_axes((0.02, 0.02, 0.2, 0.2))
    ax.plot([0, 1], [0, 1])
    ax.tick_params(labelsize=6)
    fig.savefig(tmp_path / "bad_mpl.png", dpi=100)
    cut = Figure(figsize=(6.0, 4.0))
    ax = cut.add_axes((0.03, 0.12, 0.9, 0.8))  # the y tick labels and label left of the canvas
    ax.plot([0, 1], [0, 1000])
    ax.set_ylabel("z [mm]", fontsize=10)
    cut.savefig(tmp_path / "cut_mpl.png", dpi=100)
    p = pv.Plotter(off_screen=True, window_size=(600, 400))
    p.set_background("white")
    p.add_mesh(pv.Sphere(radius=0.1, center=(2.0, 1.5, 0.0)), color="black")
    p.add_mesh(pv.Sphere(radius=0.001), color="white")  # keeps the camera wide: the black sphere sits in a corner
    p.camera_position = [(0, 0, 10), (0, 0, 0), (0, 1, 0)]
    p.add_text("tiny", position=(300, 200), font_size=3, color="black")
    p.screenshot(str(tmp_path / "bad_pv.png"))
    p.close()
    bad = _check_watched(seen, tmp_path)
    assert any(b.startswith("bad_mpl.png: fill") for b in bad) and any(b.startswith("bad_mpl.png: text") for b in bad)
    assert any(b.startswith("cut_mpl.png: edge") for b in bad)
    assert not any(b.startswith("bad_pv.png: edge") for b in bad)  # pyvista screenshots: no edge check
    assert any(b.startswith("bad_pv.png: fill") for b in bad) and any(b.startswith("bad_pv.png: text") for b in bad)


# ------------------------------------------------------------------------------------- every image in the docs
# Each PNG in docs/images and the figure kind that draws it (the kind's function above runs the same plot function
# on small inputs); a new image must be added here, to a kind or to DOCS_IMAGES_UNCHECKED with its reason.
DOCS_IMAGE_KINDS = {
    "section_maps": ["figures_admissibility", "figures_section_kx", "hexaglide_yz_admissibility",
                     "hexaglide_yz_deflection_gravity", "hexaglide_yz_f1", "hexaglide_yz_kx"],
    "three_planes": ["hexaglide_three_planes_kx"],
    "mode_shape": ["figures_mode1", "hexaglide_mode1", "study_f_mode1"],
    "workspace": ["figures_workspace", "workspace_hexaglide", "validation_hexaglide_workspace"],
    "rotation": ["workspace_rotation_map_yz", "workspace_rotational_point"],
    "workspace_curves": ["workspace_volume_convergence", "workspace_volume_vs_orientation"],
    "mechanisms": ["mechanism_slider_crank", "mechanism_hybrid", "mechanism_6rus_f1", "mechanism_6rus_kx",
                   "mechanism_hybrid_f1", "mechanism_hybrid_kx", "mechanism_section_admissibility",
                   "mechanism_section_kappa", "mechanism_bipod_f1", "mechanism_five_bar_modes"],
    "fe_joint": ["fe_joint_deformed"],
    "calibration": ["calibration_walkthrough_felix_parameters", "calibration_walkthrough_felix_path",
                    "calibration_walkthrough_hexaglide_path"],
    "ballbar": ["ballbar_diagnosis", "ballbar_polar", "ballbar_spectrum", "calibration_simulation_felix_polar",
                "calibration_walkthrough_felix_circle_after", "calibration_walkthrough_felix_circle_before",
                "calibration_walkthrough_felix_validation_after", "calibration_walkthrough_hexaglide_circle_after",
                "calibration_walkthrough_hexaglide_circle_before",
                "calibration_walkthrough_hexaglide_validation_after"],
    "study_maps": ["study_a_kz_maps", "study_b_kx_maps", "study_c_section_maps", "study_d_stiffness_maps",
                   "study_e_kx_tilt_maps"],
    "optimise": ["optimise_convergence", "optimise_front_geometry", "optimise_front_selection"],
    "study_g_rotation": ["study_g_rotation_a"],
    "validation_causes": ["validation_hexaglide_causes_xz", "validation_hexaglide_causes_yz"],
}
DOCS_IMAGES_UNCHECKED = {
    # browser screenshots of HTML pages: no figure kind draws them (their own tests take and check them)
    "app_start": "screenshot of `pkmstiff app` in headless Chromium (docs/make_images.py)",
    "app_point": "screenshot of `pkmstiff app` in headless Chromium (docs/make_images.py)",
    "app_mechanism": "screenshot of `pkmstiff app hexa_6rus` in headless Chromium (docs/make_images.py)",
    "demo_summary": "screenshot of the demo's summary.html in headless Chromium",
    "optimise_report": "screenshot of the optimisation's HTML report in headless Chromium",
    "report_calibration": "screenshot of the calibration HTML report in headless Chromium",
    "report_design": "screenshot of the design comparison HTML report in headless Chromium",
    "report_design_evaluation": "screenshot of the design comparison HTML report in headless Chromium",
}


def test_every_docs_image_has_a_checked_figure_kind():
    from pathlib import Path

    images = {p.stem for p in (Path(__file__).resolve().parents[1] / "docs" / "images").glob("*.png")}
    mapped = [name for names in DOCS_IMAGE_KINDS.values() for name in names]
    assert len(mapped) == len(set(mapped)) and not set(mapped) & set(DOCS_IMAGES_UNCHECKED), "an image listed twice"
    assert set(DOCS_IMAGE_KINDS) <= set(FIGURE_KINDS), set(DOCS_IMAGE_KINDS) - set(FIGURE_KINDS)
    unknown = images - set(mapped) - set(DOCS_IMAGES_UNCHECKED)
    assert not unknown, f"docs/images without a figure kind in tests/test_figures.py: {sorted(unknown)}"
    gone = (set(mapped) | set(DOCS_IMAGES_UNCHECKED)) - images
    assert not gone, f"listed but not in docs/images: {sorted(gone)}"
