"""Figures a user would put in a report (issue 12, item 5): the drawing of every figure kind fills at least 80 % of
the canvas (bounding box of the non-background pixels), maps carry µm/° units, titles state the real window ranges.

The fill fraction is the area of the bounding box of pixels that differ from the corner (background) colour by more
than 30 (sum over RGB, out of 765) divided by the canvas area; antialiasing halos stay below that threshold.
"""

from __future__ import annotations

import numpy as np
import pytest

MIN_FILL = 0.80


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
