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
        c = np.atleast_2d(np.asarray(fixed_ball, dtype=float)) * 1e3  # one ball (3,) or one per set-up (K, 3)
        ax3.scatter(c[:, 0], c[:, 1], c[:, 2], color="k", marker="*", s=80,
                    label="fixed ball" if len(c) == 1 else "fixed balls")
        ax2.scatter(c[:, 0], c[:, 1], color="k", marker="*", s=80)
    lo, hi = P.min(axis=0), P.max(axis=0)
    mid, half = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1.0)
    ax3.set_xlim(mid[0] - half, mid[0] + half)
    ax3.set_ylim(mid[1] - half, mid[1] + half)
    ax3.set_zlim(mid[2] - half, mid[2] + half)
    ax3.set_xlabel("x [mm]")
    ax3.set_ylabel("y [mm]")
    ax3.set_zlabel("z [mm]")
    ax3.legend(fontsize=9, loc="upper left")
    ax2.set_aspect("equal", adjustable="datalim")
    ax2.set_xlabel("x [mm]")
    ax2.set_ylabel("y [mm]")
    ax2.set_title("top view", fontsize=10)
    ax2.grid(True, lw=0.3)
    fig.suptitle(title, fontsize=11)
    return fig


def parameter_figure(names: Sequence[str], values: np.ndarray, sigma: np.ndarray, units: Sequence[str], *,
                     title: str = "Identified parameters and their 2σ") -> "Figure":
    """Horizontal bars of the identified values (lengths in mm, angles in mrad) and beside them their 2σ (µm, µrad),
    one row of panels per unit present. ``values``/``sigma`` in SI (m, rad)."""
    from matplotlib.figure import Figure

    v, s = np.asarray(values, dtype=float) * 1e3, np.asarray(sigma, dtype=float) * 1e3
    kinds = [(u, lab, small) for u, lab, small in (("m", "mm", "µm"), ("rad", "mrad", "µrad")) if u in units]
    n_rows = [sum(1 for x in units if x == u) for u, _, _ in kinds]
    # two columns: the identified values (mm, mrad) and, on their own scale, 2σ in µm / µrad; at the values'
    # scale the ±2σ bars of a well-identified parameter are narrower than a pixel
    fig = Figure(figsize=(9.0, 1.0 + 0.21 * sum(n_rows) + 0.7 * len(kinds)), layout="constrained")
    gs = fig.add_gridspec(len(kinds), 2, height_ratios=[max(n, 1) for n in n_rows], width_ratios=[3, 2])
    for k, (u, lab, small) in enumerate(kinds):
        ax = fig.add_subplot(gs[k, 0])
        idx = [i for i, x in enumerate(units) if x == u]
        y = np.arange(len(idx))[::-1]
        ax.barh(y, v[idx], color="tab:blue", alpha=0.75, height=0.7)
        ax.set_yticks(y)
        ax.set_yticklabels([names[i] for i in idx], fontsize=9)
        ax.axvline(0.0, color="k", lw=0.6)
        ax.set_xlabel(f"identified error [{lab}]")
        ax.grid(True, axis="x", lw=0.3)
        ax.set_ylim(-0.7, len(idx) - 0.3)
        ax2 = fig.add_subplot(gs[k, 1], sharey=ax)
        ax2.barh(y, 2 * s[idx] * 1e3, color="tab:orange", alpha=0.8, height=0.7)
        ax2.tick_params(labelleft=False)
        ax2.set_xlabel(f"2σ [{small}]")
        ax2.grid(True, axis="x", lw=0.3)
    fig.suptitle(title, fontsize=11)
    return fig
