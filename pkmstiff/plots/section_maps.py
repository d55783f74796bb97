"""Section maps (Cobet chapter 2 display): a quantity as colour on its plane, the admissible region outlined."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from pkmstiff.evaluation.sections import SectionResult
from pkmstiff.machine.model import Machine
from pkmstiff.plots import offscreen
from pkmstiff.plots.sketch import add_sketch

MM = 1e3


def _plane_grid(res: SectionResult, in_3d: bool, pv):
    """StructuredGrid of the raster in mm: 3-D machine coordinates, or plane coordinates (u, v, 0)."""
    pl = res.plane
    if in_3d:
        pts = pl.points() * MM
    else:
        uu, vv = np.meshgrid(pl.u_values * MM, pl.v_values * MM)
        pts = np.column_stack([uu.ravel(), vv.ravel(), np.zeros(uu.size)])
    nv, nu = pl.shape
    grid = pv.StructuredGrid()
    grid.points = pts
    grid.dimensions = (nu, nv, 1)
    return grid


def _title(res: SectionResult) -> str:
    ori = ", ".join(f"{v:g}" for v in np.rad2deg(res.orientation))
    tool = "" if res.tool_length is None else f", tool {res.tool_length * MM:g} mm"
    frame = getattr(res, "frame", {}).get("frame", "machine")
    return f"{res.machine}: {res.plane.name} ({frame} frame), a,b,c = {ori} deg{tool}"


def quantity_title(res: SectionResult, name: str) -> str:
    return f"{name} [{res.units[name]}]"


def _finish_plane_plot(p, res: SectionResult, subtitle: str, path: str | Path) -> Path:
    """Axes in mm along the plane's two axes, title, 2-D view; write the PNG."""
    u, v = res.plane.u_name, res.plane.v_name
    p.show_bounds(xtitle=f"{u} [mm]", ytitle=f"{v} [mm]", ztitle="", show_zaxis=False, grid=False,
                  location="outer", ticks="outside", font_size=12, n_xlabels=5, n_ylabels=5, use_2d=True)
    p.add_text(f"{_title(res)}\n{subtitle}", position="upper_left", font_size=11, color="black")
    p.set_background("white")
    p.view_xy()
    p.enable_parallel_projection()
    p.camera.zoom(0.92)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    p.screenshot(str(path))
    p.close()
    return path


def plot_section(res: SectionResult, name: str, path: str | Path, window_size=(1000, 760), cmap: str = "viridis",
                 clim: tuple[float, float] | None = None) -> Path:
    """Write a PNG of quantity ``name`` on its plane: colour map, admissible outline, axes in mm, colour bar.

    Inadmissible points are transparent; the black line is the boundary of the admissible region.
    """
    pv = offscreen()
    grid = _plane_grid(res, in_3d=False, pv=pv)
    values = res.display(name)
    grid.point_data[name] = values.ravel()
    grid.point_data["admissible"] = res.ok.astype(float).ravel()
    p = pv.Plotter(off_screen=True, window_size=window_size)
    finite = values[np.isfinite(values)]
    if clim is None and finite.size:
        clim = (float(finite.min()), float(finite.max())) if finite.max() > finite.min() else \
            (float(finite.min()) - 0.5, float(finite.max()) + 0.5)
    p.add_mesh(grid, scalars=name, cmap=cmap, clim=clim, nan_opacity=0.0, show_scalar_bar=True,
               scalar_bar_args={"title": quantity_title(res, name), "vertical": True, "position_x": 0.86,
                                "position_y": 0.15, "height": 0.7, "width": 0.08, "title_font_size": 16,
                                "label_font_size": 14, "fmt": "%.4g"})
    if res.ok.any() and not res.ok.all():
        outline = grid.contour([0.5], scalars="admissible")
        if outline.n_points:
            p.add_mesh(outline, color="black", line_width=3)
    border = grid.outline()
    p.add_mesh(border, color="gray", line_width=1)
    return _finish_plane_plot(p, res, f"{res.labels[name]} [{res.units[name]}]", path)


def plot_three_planes(results: Sequence[SectionResult], name: str, machine: Machine, reference_pose, path: str | Path,
                      window_size=(1100, 900), cmap: str = "viridis") -> Path:
    """Three section planes in 3-D (shared colour scale) with a sketch of the machine at ``reference_pose``."""
    pv = offscreen()
    p = pv.Plotter(off_screen=True, window_size=window_size)
    vals = [r.display(name) for r in results]
    finite = np.concatenate([v[np.isfinite(v)] for v in vals]) if vals else np.array([])
    clim = (float(finite.min()), float(finite.max())) if finite.size and finite.max() > finite.min() else None
    for k, (r, v) in enumerate(zip(results, vals)):
        grid = _plane_grid(r, in_3d=True, pv=pv)
        grid.point_data[name] = v.ravel()
        p.add_mesh(grid, scalars=name, cmap=cmap, clim=clim, nan_opacity=0.0, show_scalar_bar=(k == 0),
                   scalar_bar_args={"title": quantity_title(results[0], name), "vertical": True,
                                    "position_x": 0.87, "position_y": 0.2, "height": 0.6, "fmt": "%.4g"})
    add_sketch(p, machine, reference_pose, opacity=0.9)
    p.show_bounds(xtitle="x [mm]", ytitle="y [mm]", ztitle="z [mm]", grid=False, location="outer", font_size=10)
    p.add_text(f"{results[0].machine}: {name} on three section planes", position="upper_left", font_size=11,
               color="black")
    p.set_background("white")
    bounds = np.array(p.bounds).reshape(3, 2)
    focus = bounds.mean(axis=1)
    dist = 2.2 * float(np.linalg.norm(bounds[:, 1] - bounds[:, 0]))
    direction = np.array([1.0, -1.4, 0.8]) / np.linalg.norm([1.0, -1.4, 0.8])  # front right, from above
    p.camera_position = [tuple(focus + dist * direction), tuple(focus), (0.0, 0.0, 1.0)]
    p.camera.zoom(1.5)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    p.screenshot(str(path))
    p.close()
    return path


def plot_reasons(res: SectionResult, path: str | Path, window_size=(1000, 760)) -> Path:
    """Write a PNG showing, per raster point, the first failing admissibility check (categorical colours)."""
    from pkmstiff.admissibility.checks import Reason

    pv = offscreen()
    grid = _plane_grid(res, in_3d=False, pv=pv)
    reasons = list(Reason)
    code = np.zeros(res.reasons.shape)  # 0 = admissible, k = first failing reason (bit order)
    for k, r in reversed(list(enumerate(reasons, start=1))):
        code[(res.reasons & int(r)) > 0] = k
    present = [0] + sorted({int(c) for c in np.unique(code) if c > 0})
    names = ["admissible"] + [reasons[k - 1].name.lower().replace("_", " ") for k in present[1:]]
    index = np.searchsorted(present, code)  # compact categories 0..len(present)-1
    grid.point_data["reason"] = index.ravel().astype(float)
    colours = ["#2ca02c", "#d62728", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
               "#1f77b4", "#000000"]
    p = pv.Plotter(off_screen=True, window_size=window_size)
    p.add_mesh(grid, scalars="reason", cmap=colours[:len(present)], clim=(-0.5, len(present) - 0.5),
               show_scalar_bar=False, interpolate_before_map=False)
    p.add_legend([[n, colours[i]] for i, n in enumerate(names)], bcolor="white", face="rectangle", size=(0.28, 0.3),
                 loc="upper right")
    return _finish_plane_plot(p, res, "admissibility: first failing check per point", path)
