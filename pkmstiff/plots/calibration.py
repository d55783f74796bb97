"""Calibration figures: the measuring path of a plan (3-D, with the fixed ball) and the identified parameters with
their σ (matplotlib ``Figure``, no backend switch; the report layer saves them)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure


def path_figure(points: np.ndarray, groups: np.ndarray, labels: Sequence[str], fixed_ball: np.ndarray | None = None,
                *, title: str = "Measuring path") -> "Figure":
    """3-D view and top view of the moving-ball centres ``points`` (N, 3) [m] in time order, drawn in mm, one
    colour per group (``groups`` (N,) index into ``labels``); the fixed ball as a black star.

    Consecutive samples of one group are joined by lines; a jump between groups is not drawn.
    """
    from matplotlib.figure import Figure

    P = np.asarray(points, dtype=float) * 1e3
    g = np.asarray(groups, dtype=int)
    fig = Figure(figsize=(10.0, 4.6), layout="constrained")
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    ax2 = fig.add_subplot(1, 2, 2)
    colours = [f"C{k % 10}" for k in range(len(labels))]
    for k, lab in enumerate(labels):
        sel = np.flatnonzero(g == k)
        if not sel.size:
            continue
        # break the line where samples of the group are not consecutive (another run in between)
        cuts = np.flatnonzero(np.diff(sel) > 1) + 1
        first = True
        for part in np.split(sel, cuts):
            ax3.plot(P[part, 0], P[part, 1], P[part, 2], color=colours[k], lw=0.9, label=lab if first else None)
            ax2.plot(P[part, 0], P[part, 1], color=colours[k], lw=0.9)
            first = False
    if fixed_ball is not None:
        c = np.asarray(fixed_ball, dtype=float) * 1e3
        ax3.scatter([c[0]], [c[1]], [c[2]], color="k", marker="*", s=80, label="fixed ball")
        ax2.scatter([c[0]], [c[1]], color="k", marker="*", s=80)
    lo, hi = P.min(axis=0), P.max(axis=0)
    mid, half = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1.0)
    ax3.set_xlim(mid[0] - half, mid[0] + half)
    ax3.set_ylim(mid[1] - half, mid[1] + half)
    ax3.set_zlim(mid[2] - half, mid[2] + half)
    ax3.set_xlabel("x [mm]")
    ax3.set_ylabel("y [mm]")
    ax3.set_zlabel("z [mm]")
    ax3.legend(fontsize=7.5, loc="upper left")
    ax2.set_aspect("equal", adjustable="datalim")
    ax2.set_xlabel("x [mm]")
    ax2.set_ylabel("y [mm]")
    ax2.set_title("top view", fontsize=10)
    ax2.grid(True, lw=0.3)
    fig.suptitle(title, fontsize=11)
    return fig


def parameter_figure(names: Sequence[str], values: np.ndarray, sigma: np.ndarray, units: Sequence[str], *,
                     title: str = "Identified parameters (±2σ)") -> "Figure":
    """Horizontal bars of the identified values with ±2σ error bars: lengths in mm, angles in mrad (one panel per
    unit present). ``values``/``sigma`` in SI (m, rad)."""
    from matplotlib.figure import Figure

    v, s = np.asarray(values, dtype=float) * 1e3, np.asarray(sigma, dtype=float) * 1e3
    kinds = [(u, lab) for u, lab in (("m", "mm"), ("rad", "mrad")) if u in units]
    n_rows = [sum(1 for x in units if x == u) for u, _ in kinds]
    fig = Figure(figsize=(8.0, 1.2 + 0.16 * sum(n_rows) + 0.6 * len(kinds)), layout="constrained")
    gs = fig.add_gridspec(len(kinds), 1, height_ratios=[max(n, 1) for n in n_rows])
    for k, (u, lab) in enumerate(kinds):
        ax = fig.add_subplot(gs[k, 0])
        idx = [i for i, x in enumerate(units) if x == u]
        y = np.arange(len(idx))[::-1]
        ax.barh(y, v[idx], xerr=2 * s[idx], color="tab:blue", alpha=0.7, ecolor="k", capsize=1.5, height=0.7)
        ax.set_yticks(y)
        ax.set_yticklabels([names[i] for i in idx], fontsize=6.5)
        ax.axvline(0.0, color="k", lw=0.6)
        ax.set_xlabel(f"identified error [{lab}]")
        ax.grid(True, axis="x", lw=0.3)
        ax.set_ylim(-0.7, len(idx) - 0.3)
    fig.suptitle(title, fontsize=11)
    return fig
