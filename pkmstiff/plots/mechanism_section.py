"""Maps of a mechanism section (:class:`pkmstiff.mechanisms.section.MechanismSection`): one quantity with the
inadmissible points greyed by reason, or the admissibility reasons alone (matplotlib ``Figure``, no backend chosen)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pkmstiff.io.atomic import atomic_path

MM = 1e3
#: map categories: admissible, then the first failing reason bit (pkmstiff.mechanisms.REASONS order)
_CATEGORIES = (("admissible", "#2ca02c"), ("no solution", "#7f7f7f"), ("singular", "#d62728"),
               ("joint limit", "#ff7f0e"))


def _categories(sec) -> np.ndarray:
    from pkmstiff.mechanisms.evaluate import REASONS

    code = np.zeros(sec.reasons.shape, dtype=int)
    for k, bit in reversed(list(enumerate(REASONS.values(), start=1))):
        code[(sec.reasons & bit) > 0] = k
    return code


def _axes(sec, title: str):
    from matplotlib.figure import Figure

    u, v = sec.plane[0], sec.plane[1]
    nu, nv = sec.u_values.size, sec.v_values.size
    aspect = (sec.v_values[-1] - sec.v_values[0]) / max(sec.u_values[-1] - sec.u_values[0], 1e-12)
    w = 5.2
    fig = Figure(figsize=(w + 2.2, max(3.2, min(8.0, w * aspect + 1.2))), layout="constrained")
    ax = fig.add_subplot()
    ax.set_aspect("equal")
    ax.set_xlabel(f"{u} [mm]")
    ax.set_ylabel(f"{v} [mm]")
    if sec.settings.get("planar"):
        where = f"plane of motion\nphi = {np.degrees(sec.orientation[0]):g} deg"
    else:
        normal = ({"x", "y", "z"} - set(sec.plane)).pop()
        ori = ", ".join(f"{np.degrees(a):g}" for a in sec.orientation)
        where = f"{sec.plane} plane at {normal} = {sec.at * MM:g} mm\norientation a,b,c = {ori} deg"
    fig.suptitle(f"{sec.mechanism}: {where}, {nu}×{nv} points", fontsize=9)
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
    fig, ax = _axes(sec, "admissibility: first failing check per point")
    ax.pcolormesh(sec.u_values * MM, sec.v_values * MM, index, shading="nearest", cmap=ListedColormap(colours),
                  vmin=-0.5, vmax=len(present) - 0.5)
    fig.legend(handles=[Patch(color=_CATEGORIES[k][1], label=_CATEGORIES[k][0]) for k in present],
               loc="outside right center", fontsize=9, frameon=False)
    return _save(fig, path)


def plot_mechanism_quantity(sec, name: str, path: str | Path) -> Path:
    """PNG of one quantity over the admissible points (colour bar in its display unit); others light grey."""
    vals = sec.display(name)
    fig, ax = _axes(sec, f"{name} [{sec.units[name]}]")
    ax.pcolormesh(sec.u_values * MM, sec.v_values * MM, np.where(sec.ok, np.nan, 1.0), shading="nearest",
                  cmap="Greys", vmin=0.0, vmax=4.0)
    finite = np.isfinite(vals)
    if finite.any():
        m = ax.pcolormesh(sec.u_values * MM, sec.v_values * MM, np.ma.masked_invalid(vals), shading="nearest",
                          cmap="viridis")
        fig.colorbar(m, ax=ax, label=f"{name} [{sec.units[name]}]")
    return _save(fig, path)


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    return path
