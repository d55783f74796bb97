"""The docs' figures that no command, docs page or study writes itself (``python docs/make_images.py [OUTDIR]
[NAME ...]`` from the repository root with pkmstiff importable; default docs/images, all names): the mode shape,
the mechanism pictures and section maps, the deformed FE joint, the screenshots of ``pkmstiff app`` and of both
report kinds (headless Chromium). The other figures in docs/images come from ``pkmstiff demo``
(hexaglide_yz_*, hexaglide_three_planes_kx), ``python -m pkmstiff.plots.workspace_figures``, ``pkmstiff calibrate
report`` (the calibration walk-through's commands) and ``studies/``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


def mode1(out: Path) -> Path:
    """Mode 1 of the Hexaglide at x, y, z = 0, 0, -1000 mm (docs/user-guide/structure.md)."""
    from pkmstiff.machine.loader import load_machine
    from pkmstiff.plots.modes import plot_mode_shape

    return plot_mode_shape(load_machine("hexaglide"), np.array([0, 0, -1.0, 0, 0, 0]), out / "hexaglide_mode1.png")


def mechanisms(out: Path) -> list[Path]:
    """The slider-crank at home, both dead centres and s = -80 mm; the hybrid machine at home and a second
    configuration (docs/user-guide/mechanisms.md)."""
    import pkmstiff.mechanisms as mm
    from pkmstiff.plots.mechanism import mechanism_figure

    sc = mm.load_mechanism("slider_crank")
    rng = mm.drive_ranges(sc)["s"]
    s = np.array([[0.0], [rng.max.value - 1e-9], [rng.min.value + 1e-9], [-0.08]])  # just inside the dead centres
    q = mm.forward(sc, s, steps=8).q
    files = [out / "mechanism_slider_crank.png", out / "mechanism_hybrid.png"]
    mechanism_figure(sc, q, files[0],
                              labels=["home", f"s = {s[1, 0] * 1e3:.2f} mm", f"s = {s[2, 0] * 1e3:.2f} mm",
                                      "s = -80 mm"],
                              title="Slider-crank (patent Fig. 3): home (solid), both dead centres and s = -80 mm")
    hyb = mm.load_mechanism("hybrid_tripod_wrist")
    d = np.array([[0.0, 0.0, 0.0, 0.0, np.radians(20)], [0.05, -0.02, 0.01, 0.4, np.radians(40)]])
    q = mm.forward(hyb, d, steps=4).q
    mechanism_figure(hyb, q, files[1], labels=["home", "second"],
                     title="Hybrid tripod with wrist: home (solid) and a second configuration")
    return files


def mechanism_sections(out: Path) -> list[Path]:
    """k_x and f1 of the 6-RUS at z = -400 mm and of the hybrid at its tool plane z = -1073.205 mm (orientation 0,
    window fitted, 10 mm raster; docs/user-guide/mechanisms.md, elastic model); f1 of the bipod's mechanism file in
    its plane of motion (20 mm raster; docs/user-guide/structure.md); the five-bar's admissibility with the other
    assembly mode (5 mm raster; docs/user-guide/mechanisms.md, working modes)."""
    import pkmstiff.mechanisms as mm
    from pkmstiff.mechanisms.section import evaluate_section, fit_window
    from pkmstiff.plots.mechanism_section import plot_mechanism_quantity

    files = []
    for name, stem, at in (("hexa_6rus", "mechanism_6rus", -0.4), ("hybrid_tripod_wrist", "mechanism_hybrid",
                                                                    -1.073205)):
        mech = mm.load_mechanism(name)
        u, v = fit_window(mech, "xy", at, np.zeros(3), 0.01)
        sec = evaluate_section(mech, "xy", at, u, v, 0.01, names=("kx", "f1"))
        files += [plot_mechanism_quantity(sec, q, out / f"{stem}_{q}.png") for q in ("kx", "f1")]
    bipod = mm.load_mechanism("bipod_generic")  # the planar example in its plane of motion (user-guide/structure.md)
    u, v = fit_window(bipod, "xy", 0.0, np.zeros(3), 0.02)
    sec = evaluate_section(bipod, "xy", 0.0, u, v, 0.02, names=("f1",))
    files.append(plot_mechanism_quantity(sec, "f1", out / "mechanism_bipod_f1.png"))
    from pkmstiff.plots.mechanism_section import plot_mechanism_reasons

    five = mm.load_mechanism("five_bar")
    sec = evaluate_section(five, "xy", 0.0, (-0.15, 0.35), (-0.1, 0.38), 0.005)
    files.append(plot_mechanism_reasons(sec, out / "mechanism_five_bar_modes.png"))
    return files


def fe_joint(out: Path) -> Path:
    """The improved 3-DOF drive-side joint at 45° tilt under 5 kN along the strut (docs/user-guide/fe.md)."""
    from pkmstiff.cli.fe import joint_image
    from pkmstiff.fe.joints import build_joint_model, load_joint_parameters

    params = Path(__file__).resolve().parents[1] / "pkmstiff" / "fe" / "params" / "iwf_3dof_improved.toml"
    return joint_image(build_joint_model(load_joint_parameters(params)), 45.0, out / "fe_joint_deformed.png")


def figures_page(out: Path) -> list[Path]:
    """docs/user-guide/figures.md: a k_x map and the admissibility map of the Hexaglide's YZ plane (window fitted,
    10 mm raster, tool length 0), mode 1 at x, y, z = 0, 300, -900 mm, the workspace at a 50 mm resolution."""
    from pkmstiff.evaluation.sections import evaluate_section
    from pkmstiff.machine.loader import load_machine
    from pkmstiff.plots.modes import plot_mode_shape
    from pkmstiff.plots.section_maps import plot_reasons, plot_section
    from pkmstiff.plots.workspace import plot_workspace
    from pkmstiff.workspace.requests import WorkspaceRequest
    from pkmstiff.workspace.translational import DEFAULT_METHODS
    from pkmstiff.workspace.windows import window_for

    m = load_machine("hexaglide")
    res = evaluate_section(m, window_for(m, "yz", 0.0, 0.01), ["kx"], tool_length=0.0, progress=False)
    ws = WorkspaceRequest(0.05, None, (), (0.0, 0.0, 0.0), DEFAULT_METHODS).evaluate(m)
    return [plot_section(res, "kx", out / "figures_section_kx.png"),
            plot_reasons(res, out / "figures_admissibility.png"),
            plot_mode_shape(m, np.array([0, 0.3, -0.9, 0, 0, 0]), out / "figures_mode1.png"),
            plot_workspace(ws, m, out / "figures_workspace.png")]


def app(out: Path) -> list[Path]:
    """docs/user-guide/app.md: ``pkmstiff app hexaglide`` in headless Chromium (tests/app_browser.py drives it as
    tests/test_app_browser.py does): the start (YZ plane, k_x), then the raster step 50 mm, a click on the admissible
    point nearest the middle of the map and mode 1 shown in the 3-D view; then ``pkmstiff app hexa_6rus`` (XY plane at
    z = −440 mm, a click, mode 1 over its links)."""
    import tempfile
    import time

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests import app_browser as ab

    def click_and_show_mode_1(driver, g: dict, u: float, v: float, path: Path) -> None:
        """Click the map at the fractions (u, v) of its axes, show mode 1 of the point analysis, screenshot."""
        u0, u1, v0, v1 = g["limits_mm"]
        ab.click_map(driver, u0 + u * (u1 - u0), v0 + v * (v1 - v0))
        ab.wait_for(driver, lambda d: ab.text(d, "k-kx") and ab.text(d, "status") == "ready", "the point analysis")
        first = ab.wait_for(driver, lambda d: d.find_element("css selector", "#modes li").text, "the modes")
        ab.choose(driver, "mode", f"1: {first}")
        ab.wait_for(driver, lambda d: "mode 1" in ab.text(d, "mode-shown"), "mode 1 in the 3-D view")
        time.sleep(1.0)
        driver.save_screenshot(str(path))

    files = [out / "app_start.png", out / "app_point.png", out / "app_mechanism.png"]
    with tempfile.TemporaryDirectory() as tmp, ab.running_app(Path(tmp)) as (url, _, _), ab.chromium() as driver:
        driver.get(url)
        g = ab.wait_map(driver)
        time.sleep(1.0)  # the 3-D view's first image
        driver.save_screenshot(str(files[0]))
        ab.type_into(driver, "step", "50")
        click_and_show_mode_1(driver, ab.wait_map(driver, g["version"]), 0.55, 0.45, files[1])
    with (tempfile.TemporaryDirectory() as tmp, ab.running_app(Path(tmp), "hexa_6rus", step_mm=20.0) as (url, _, _),
          ab.chromium() as driver):  # a mechanism: its links at a clicked point of the XY map at z = -440 mm
        driver.get(url)
        g = ab.wait_map(driver)
        ab.choose(driver, "plane", "xy")
        ab.type_into(driver, "at", "-440")
        click_and_show_mode_1(driver, ab.wait_map(driver, g["version"]), 0.65, 0.5, files[2])
    return files


def reports(out: Path) -> list[Path]:
    """docs/user-guide/reports.md: both report kinds as tests/test_app_browser.py builds and looks at them
    (tests/report_browser.py: a small design comparison and a small Felix calibration), headless Chromium at
    1400 px, the first 2000 px."""
    import tempfile

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests import app_browser as ab
    from tests import report_browser as rb

    files = [out / "report_design.png", out / "report_calibration.png"]
    with tempfile.TemporaryDirectory() as tmp, ab.chromium() as driver:
        for html, png in zip(rb.build_reports(Path(tmp)), files):
            problems = rb.look_at(driver, html, png)
            if problems:
                raise RuntimeError(f"{html.name}: {problems}")
    return files


FIGURES = {"mode1": mode1, "figures_page": figures_page, "mechanisms": mechanisms,
           "mechanism_sections": mechanism_sections, "fe_joint": fe_joint, "app": app, "reports": reports}


def main(out: str = "docs/images", *names: str) -> list[Path]:
    outdir = Path(out)
    files: list[Path] = []
    for n in names or FIGURES:
        r = FIGURES[n](outdir)
        files += r if isinstance(r, list) else [r]
    return files


if __name__ == "__main__":  # pragma: no cover
    for f in main(*sys.argv[1:]):
        print(f)
