"""Figures a user would put in a report (issue 12, item 5; issue 28, item 1): the drawing of every figure kind fills
at least 80 % of the canvas (bounding box of the non-background pixels), maps carry µm/° units, titles state the real
window ranges, every text of a matplotlib figure is at least 9 pt at the figure's print size, colour scales show
the structure where one hot spot dominates.

The fill fraction is the area of the bounding box of pixels that differ from the corner (background) colour by more
than 30 (sum over RGB, out of 765) divided by the canvas area; antialiasing halos stay below that threshold.
"""

from __future__ import annotations

import numpy as np
import pytest

MIN_FILL = 0.80
MIN_PT = 9.0  # readable at print size: the figure is printed at its own size in inches (points are 1/72 in)


def smallest_text_pt(fig) -> float:
    """Smallest font size [pt] of the visible, non-empty texts of a matplotlib figure (ticks, labels, legends)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    FigureCanvasAgg(fig)
    fig.draw_without_rendering()
    sizes = [t.get_fontsize() for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]
    assert sizes, "figure without text"
    return min(sizes)


def fill_fraction(path) -> float:
    from PIL import Image

    img = np.asarray(Image.open(path).convert("RGB")).astype(int)
    mask = np.abs(img - img[0, 0]).sum(axis=2) > 30
    ys, xs = np.nonzero(mask)
    assert ys.size, f"{path} is blank"
    return (ys.max() - ys.min() + 1) * (xs.max() - xs.min() + 1) / mask.size


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
    fig = figs[0]
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
