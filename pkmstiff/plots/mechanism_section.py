"""Maps of a mechanism section (:class:`pkmstiff.mechanisms.section.MechanismSection`): one quantity with the
inadmissible points greyed by reason, or the admissibility reasons alone (matplotlib ``Figure``, no backend chosen)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pkmstiff.io.atomic import atomic_path

MM = 1e3
#: map categories: admissible, then the first failing reason bit (pkmstiff.mechanisms.REASONS order)
_CATEGORIES = (("admissible", "#2ca02c"), ("no solution", "#7f7f7f"), ("singular", "#d62728"),
               ("joint limit", "#ff7f0e"), ("other working mode", "#9467bd"))


def _categories(sec) -> np.ndarray:
    from pkmstiff.mechanisms.evaluate import REASONS

    code = np.zeros(sec.reasons.shape, dtype=int)
    for k, bit in reversed(list(enumerate(REASONS.values(), start=1))):
        code[(sec.reasons & bit) > 0] = k
    return code


def _axes(sec, title: str, legend_in: float = 0.0):
    from pkmstiff.plots.section_maps import map_canvas

    u, v = sec.plane[0], sec.plane[1]
    aspect = (sec.v_values[-1] - sec.v_values[0]) / max(sec.u_values[-1] - sec.u_values[0], 1e-12)
    w = 5.2
    fig = map_canvas((w + 2.2 + legend_in, max(3.2, min(8.0, w * aspect + 1.2))))
    ax = fig.add_subplot()
    ax.set_aspect("equal")
    ax.set_xlabel(f"{u} [mm]")
    ax.set_ylabel(f"{v} [mm]")
    rng = (f"{u} {sec.u_values[0] * MM:g}…{sec.u_values[-1] * MM:g} mm, "
           f"{v} {sec.v_values[0] * MM:g}…{sec.v_values[-1] * MM:g} mm")
    if sec.settings.get("planar"):  # the machines' map title: plane, frame, window, orientation
        where = f"plane of motion (machine frame), {rng}\nphi = {np.degrees(sec.orientation[0]):g}°"
    else:
        normal = ({"x", "y", "z"} - set(sec.plane)).pop()
        ori = ", ".join(f"{np.degrees(a):g}°" for a in sec.orientation)
        tool = sec.settings.get("tool_length_mm")
        where = (f"{sec.plane.upper()} plane at {normal} = {sec.at * MM:g} mm (machine frame), {rng}\n"
                 f"a, b, c = {ori}" + ("" if tool is None else f", tool {tool:g} mm"))
    fig.suptitle(f"{sec.mechanism}: {where}", fontsize=9)
    ax.set_title(title, fontsize=10)
    return fig, ax


def plot_mechanism_reasons(sec, path: str | Path) -> Path:
    """PNG of the first failing check per raster point (categorical colours, legend outside the data)."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    code = _categories(sec)
    present = sorted({int(c) for c in np.unique(code)})
    index = np.searchsorted(present, code)
    colours = [_CATEGORIES[k][1] for k in present]
    # room for the legend beside the map: ~0.075 in per character of its longest label at 9 pt (constrained layout
    # otherwise pushes the equal-aspect axes and their y label against the left edge)
    longest = max(len(_CATEGORIES[k][0]) for k in present)
    fig, ax = _axes(sec, "admissibility: first failing check per point", max(0.0, 0.075 * (longest - 12)))
    ax.pcolormesh(sec.u_values * MM, sec.v_values * MM, index, shading="nearest", cmap=ListedColormap(colours),
                  vmin=-0.5, vmax=len(present) - 0.5)
    ax.legend(handles=[Patch(color=_CATEGORIES[k][1], label=_CATEGORIES[k][0]) for k in present],
              loc="center left", bbox_to_anchor=(1.02, 0.5), fontsize=9, frameon=False)
    return _save(fig, path)


def plot_mechanism_quantity(sec, name: str, path: str | Path) -> Path:
    """PNG of one quantity over the admissible points, drawn as the machines' section maps
    (:func:`pkmstiff.plots.section_maps.draw_map`: colour bar in the display unit, boundary of the admissible
    region, inadmissible points white)."""
    fig, _ = mechanism_quantity_figure(sec, name)
    return _save(fig, path)


def mechanism_quantity_figure(sec, name: str):
    """(figure, map axes) of :func:`plot_mechanism_quantity` (the app draws it and maps clicks through the axes)."""
    from pkmstiff.mechanisms.section import quantity_label
    from pkmstiff.plots.section_maps import draw_map

    fig, ax = _axes(sec, "")
    ax.set_xlim(sec.u_values[0] * MM, sec.u_values[-1] * MM)
    ax.set_ylim(sec.v_values[0] * MM, sec.v_values[-1] * MM)
    draw_map(fig, ax, sec.u_values, sec.v_values, sec.display(name), sec.ok, name, quantity_label(name),
             sec.units[name])
    return fig, ax


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    return path
