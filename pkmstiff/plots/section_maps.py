"""Section maps (Cobet chapter 2 display): a quantity as colour on its plane, the admissible region outlined."""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from pkmstiff.evaluation.sections import SectionResult
from pkmstiff.io.atomic import atomic_open, atomic_path
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
    return f"{name} [{pretty_unit(res.units[name])}]"


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
    with atomic_path(path) as tmp:
        p.screenshot(str(tmp))
    p.close()
    return path


#: display spellings of the units the quantities carry in ASCII (figures show µm, µrad, °, ·, ²)
_PRETTY_UNITS = (("N*m/urad", "N·m/µrad"), ("N*m", "N·m"), ("um", "µm"), ("urad", "µrad"), ("m/s^2", "m/s²"),
                 ("deg", "°"), ("^2", "²"), ("^3", "³"))


def pretty_unit(unit: str) -> str:
    """'N/um' -> 'N/µm', 'N*m/urad' -> 'N·m/µrad', 'deg' -> '°' (labels in figures)."""
    for a, b in _PRETTY_UNITS:
        unit = unit.replace(a, b)
    return unit


#: a tail beyond the 1st/99th percentile longer than this fraction of the percentile span is a hot spot
HOT_SPOT_TAIL = 0.5
#: positive values whose median lies in the lowest fraction of their range (one peak, the rest near the bottom)
#: and that span more than a decade get a logarithmic colour scale
LOG_MEDIAN_FRACTION = 0.15


@dataclass(frozen=True)
class ColourScale:
    """Colour limits, linear or logarithmic, and the note the colour bar carries ("" for a plain min..max scale)."""

    lo: float
    hi: float
    log: bool = False
    note: str = ""

    def norm(self):
        from matplotlib.colors import LogNorm, Normalize

        return LogNorm(self.lo, self.hi) if self.log else Normalize(self.lo, self.hi)

    def extend(self, values: np.ndarray) -> str:
        """Colour-bar arrows (matplotlib's ``extend``) for the values outside the limits."""
        return _extend(values, (self.lo, self.hi))

    def label_colorbar(self, cb, unit_label: str) -> None:
        """Colour-bar label with the note; a log scale gets plain ticks at 1, 2, 5 × 10^k."""
        cb.set_label(unit_label + (f"\n({self.note})" if self.note else ""))
        if self.log:
            from matplotlib.ticker import FormatStrFormatter

            k = np.arange(np.floor(np.log10(self.lo)), np.ceil(np.log10(self.hi)) + 1)
            ticks = (np.array([1.0, 2.0, 5.0])[None] * 10.0 ** k[:, None]).ravel()
            cb.set_ticks(ticks[(ticks >= self.lo) & (ticks <= self.hi)], labels=None)
            cb.ax.minorticks_off()
            cb.formatter = FormatStrFormatter("%g")
            cb.update_ticks()


def robust_clim(*arrays: np.ndarray) -> ColourScale:
    """Colour scale over the finite values of ``arrays`` that shows the structure when one hot spot dominates
    (e.g. k_z up to 184 N/µm where most of the map lies below 40):

    - an end whose tail beyond the 1st/99th percentile is longer than ``HOT_SPOT_TAIL`` times the 1…99 % span is
      cut at that percentile (the note gives the value the cut hides; the colour bar gets an arrow);
    - positive values that still span more than a decade with their median in the lowest ``LOG_MEDIAN_FRACTION``
      of the range get a logarithmic scale (note "log scale"), else the scale is linear.
    """
    finite = np.concatenate([np.ravel(a)[np.isfinite(np.ravel(a))] for a in arrays]) if arrays else np.array([])
    if not finite.size:
        return ColourScale(0.0, 1.0)
    lo, hi = float(finite.min()), float(finite.max())
    p1, p99 = (float(x) for x in np.percentile(finite, [1.0, 99.0]))
    span = p99 - p1
    notes = []
    if span > 0 and hi - p99 > HOT_SPOT_TAIL * span:
        notes.append(f"scale cut at the 99th percentile, max {hi:.4g}")
        hi = p99
    if span > 0 and p1 - lo > HOT_SPOT_TAIL * span:
        notes.append(f"scale cut at the 1st percentile, min {lo:.4g}")
        lo = p1
    inside = finite[(finite >= lo) & (finite <= hi)]
    log = bool(lo > 0 and hi > 10 * lo and float(np.median(inside)) - lo < LOG_MEDIAN_FRACTION * (hi - lo))
    if log:
        notes.insert(0, "log scale")
    if hi <= lo:
        lo, hi = lo - 0.5, hi + 0.5
    return ColourScale(lo, hi, log, "; ".join(notes))


def _extend(values: np.ndarray, clim: tuple[float, float]) -> str:
    """Colour-bar arrows for values outside ``clim``."""
    finite = values[np.isfinite(values)]
    below = bool(finite.size and finite.min() < clim[0])
    above = bool(finite.size and finite.max() > clim[1])
    return {(False, False): "neither", (True, False): "min", (False, True): "max", (True, True): "both"}[(below, above)]


def _map_title(res: SectionResult) -> str:
    """Machine, plane, the window's real ranges, orientation and tool length; a clipping warning if any."""
    pl = res.plane
    ori = ", ".join(f"{v:g}°" for v in np.rad2deg(res.orientation))
    tool = "" if res.tool_length is None else f", tool {res.tool_length * MM:g} mm"
    rng = (f"{pl.u_name} {pl.u_values[0] * MM:g}…{pl.u_values[-1] * MM:g} mm, "
           f"{pl.v_name} {pl.v_values[0] * MM:g}…{pl.v_values[-1] * MM:g} mm")
    frame = getattr(res, "frame", {}).get("frame", "machine")
    title = f"{res.machine}: {pl.name} ({frame} frame), {rng}\na, b, c = {ori}{tool}"
    edges = res.touching_edges()
    if edges:
        title += f"\nwarning: the window clips the admissible region at {', '.join(edges)}"
    return title


def map_canvas(figsize: tuple[float, float], dpi: float | None = None):
    """A constrained-layout Figure for an equal-aspect map, with 8 pt (about 11 px) margins instead of the default 3 pt
    so that no tick label or axis label reaches the canvas edge. A legend beside such a map belongs to the axes
    (``ax.legend(loc="center left", bbox_to_anchor=(1.02, 0.5))``): a figure legend placed "outside right" lets
    constrained layout push the equal-aspect axes and its y label against the left edge."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained")
    fig.get_layout_engine().set(w_pad=8 / 72, h_pad=8 / 72)
    return fig


def _map_figure(res: SectionResult, window_size: tuple[int, int] | None, legend_width: float):
    """A matplotlib Figure sized to the plane's aspect (unless ``window_size`` in px is given) and its axes."""
    pl = res.plane
    if window_size is None:
        du = float(pl.u_values[-1] - pl.u_values[0]) or 1.0
        dv = float(pl.v_values[-1] - pl.v_values[0]) or 1.0
        width = 9.0
        height = float(np.clip((width - 1.2 - legend_width) * dv / du + 1.6, 3.5, 10.0))
        figsize = (width, height)
    else:
        figsize = (window_size[0] / 100, window_size[1] / 100)
    fig = map_canvas(figsize, dpi=100)
    ax = fig.add_subplot()
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel(f"{pl.u_name} [mm]")
    ax.set_ylabel(f"{pl.v_name} [mm]")
    ax.set_xlim(pl.u_values[0] * MM, pl.u_values[-1] * MM)
    ax.set_ylim(pl.v_values[0] * MM, pl.v_values[-1] * MM)
    return fig, ax


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, facecolor="white")
    return buf.getvalue()


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    with atomic_open(path, "wb") as fh:
        fh.write(_png(fig))
    return path


def plot_section(res: SectionResult, name: str, path: str | Path, window_size: tuple[int, int] | None = None,
                 cmap: str = "viridis", clim: tuple[float, float] | None = None) -> Path:
    """Write a PNG of quantity ``name`` on its plane: colour map, admissible outline, axes in mm at round steps,
    colour bar outside the data, title with the real window ranges, orientation and frame.

    Inadmissible points are white; the black line is the boundary of the admissible region. Without ``clim`` the
    colour scale is ``robust_clim``'s (log or cut where one hot spot dominates, said on the colour bar).
    ``window_size`` (px) fixes
    the canvas; by default it follows the plane's aspect so that the map fills the figure.
    """
    return _save(section_figure(res, name, window_size, cmap, clim)[0], path)


def section_png(res: SectionResult, name: str, window_size: tuple[int, int] | None = None, cmap: str = "viridis",
                clim: tuple[float, float] | None = None) -> bytes:
    """The PNG bytes of :func:`plot_section` (the report renders its maps in its worker pool and writes them
    here)."""
    return _png(section_figure(res, name, window_size, cmap, clim)[0])


def section_figure(res: SectionResult, name: str, window_size: tuple[int, int] | None = None, cmap: str = "viridis",
                   clim: tuple[float, float] | None = None):
    """The matplotlib Figure of :func:`plot_section` and its map axes (data coordinates in mm), not yet saved (the
    browser app maps clicks on the picture back to the plane through the axes)."""
    fig, ax = _map_figure(res, window_size, 1.3)
    draw_map(fig, ax, res.plane.u_values, res.plane.v_values, res.display(name), res.ok, name, res.labels[name],
             res.units[name], cmap, clim)
    fig.suptitle(_map_title(res), fontsize=9)
    return fig, ax


def draw_map(fig, ax, u_values: np.ndarray, v_values: np.ndarray, values: np.ndarray, ok: np.ndarray, name: str,
             label: str, unit: str, cmap: str = "viridis", clim: tuple[float, float] | None = None) -> None:
    """One quantity's map on ``ax`` (raster u, v in m; display values, NaN = white): colour scale of
    :func:`robust_clim` unless ``clim``, the boundary of the admissible region ``ok`` as a black line, colour bar
    ``name [unit]`` outside the data and the title ``label [unit]`` (``unit`` in ASCII, shown by
    :func:`pretty_unit`) — the maps of machine and mechanism sections."""
    u, v = u_values * MM, v_values * MM
    scale = robust_clim(values) if clim is None else ColourScale(*clim)
    clim = (scale.lo, scale.hi)
    mesh = ax.pcolormesh(u, v, np.ma.masked_invalid(values), shading="nearest", cmap=cmap, norm=scale.norm())
    if ok.any() and not ok.all():
        ax.contour(u, v, ok.astype(float), levels=[0.5], colors="black", linewidths=1.2)
    unit = pretty_unit(unit)
    cb = fig.colorbar(mesh, ax=ax, fraction=0.06, pad=0.02, extend=_extend(values, clim))
    scale.label_colorbar(cb, f"{name} [{unit}]")
    ax.set_title(f"{label} [{unit}]", fontsize=10)


def plot_three_planes(results: Sequence[SectionResult], name: str, machine: Machine, reference_pose, path: str | Path,
                      window_size=(1100, 900), cmap: str = "viridis") -> Path:
    """Three section planes in 3-D (shared colour scale) with a sketch of the machine at ``reference_pose``."""
    pv = offscreen()
    p = pv.Plotter(off_screen=True, window_size=window_size)
    vals = [r.display(name) for r in results]
    finite = np.concatenate([v[np.isfinite(v)] for v in vals]) if vals else np.array([])
    clim = (float(finite.min()), float(finite.max())) if finite.size and finite.max() > finite.min() else None
    data_bounds = []
    for k, (r, v) in enumerate(zip(results, vals)):
        grid = _plane_grid(r, in_3d=True, pv=pv)
        data_bounds.append(np.reshape(grid.bounds, (3, 2)))
        grid.point_data[name] = v.ravel()
        # horizontal bar in the top right corner: its title above its values (no collision with the axes)
        p.add_mesh(grid, scalars=name, cmap=cmap, clim=clim, nan_opacity=0.0, show_scalar_bar=(k == 0),
                   scalar_bar_args={"title": quantity_title(results[0], name), "vertical": False,
                                    "position_x": 0.52, "position_y": 0.83, "width": 0.45, "height": 0.06,
                                    "title_font_size": 22, "label_font_size": 20, "color": "black",
                                    # an even number of values: none under the centred title
                                    "n_labels": 4, "fmt": "%.0f" if clim and clim[1] >= 10 else "%.3g"})
    # the machine ghosted (light, transparent) so that the planes in front of and behind it stay visible
    add_sketch(p, machine, reference_pose, opacity=0.2, colour="gray")
    direction = np.array([1.0, -1.4, 0.8]) / np.linalg.norm([1.0, -1.4, 0.8])  # front right, from above
    from pkmstiff.plots.axes3d import add_mm_axes, frame_camera

    box = None
    if data_bounds:  # axes around the section planes (the machine sketch reaches far beyond them)
        box = np.column_stack([np.min([b[:, 0] for b in data_bounds], axis=0),
                               np.max([b[:, 1] for b in data_bounds], axis=0)])
        add_mm_axes(p, box.ravel(), direction)
    p.add_text(f"{results[0].machine}: {name} on three section planes (machine ghosted grey)",
               position=(0.02, 0.955), viewport=True, font_size=13, color="black")  # a margin to the left edge
    p.set_background("white")
    frame_camera(p, direction, box, zoom=1.3)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        p.screenshot(str(tmp))
    p.close()
    return path


def plot_reasons(res: SectionResult, path: str | Path, window_size: tuple[int, int] | None = None) -> Path:
    """Write a PNG showing, per raster point, the first failing admissibility check (categorical colours; the legend
    sits outside the data)."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    from pkmstiff.admissibility.checks import Reason

    reasons = list(Reason)
    code = np.zeros(res.reasons.shape)  # 0 = admissible, k = first failing reason (bit order)
    for k, r in reversed(list(enumerate(reasons, start=1))):
        code[(res.reasons & int(r)) > 0] = k
    present = [0] + sorted({int(c) for c in np.unique(code) if c > 0})
    names = ["admissible"] + [reasons[k - 1].name.lower().replace("_", " ") for k in present[1:]]
    index = np.searchsorted(present, code)  # compact categories 0..len(present)-1
    colours = ["#2ca02c", "#d62728", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
               "#1f77b4", "#000000"][:len(present)]
    fig, ax = _map_figure(res, window_size, 1.8)
    ax.pcolormesh(res.plane.u_values * MM, res.plane.v_values * MM, index, shading="nearest",
                  cmap=ListedColormap(colours), vmin=-0.5, vmax=len(present) - 0.5)
    handles = [Patch(color=c, label=n) for c, n in zip(colours, names)]
    near = res.near_singular
    if near.any():  # the singularity margin: admissible, but κ above a fraction of the threshold
        from matplotlib.lines import Line2D

        vv, uu = np.nonzero(near)
        ax.scatter(res.plane.u_values[uu] * MM, res.plane.v_values[vv] * MM, s=9, marker="x", c="black",
                   linewidths=0.8, zorder=3)
        handles.append(Line2D([], [], ls="", marker="x", color="black",
                              label=f"near-singular ({int(near.sum())}):\nkappa > {res.settings['near_singular_kappa']:.3g}"))
    ax.legend(handles=handles, loc="center left", bbox_to_anchor=(1.02, 0.5), fontsize=9, frameon=False)
    ax.set_title("admissibility: first failing check per point", fontsize=10)
    fig.suptitle(_map_title(res), fontsize=9)
    return _save(fig, path)
