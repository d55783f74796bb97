"""Pictures of generic mechanisms (matplotlib, off-screen: ``Figure`` + ``savefig``, no backend chosen).

Every link is drawn as the polygon through the world positions of its joint points (and the output point); joints
are dots, driven joints squares, guide axes of the ground (prismatic, point-on-axis joints) thin lines.  Several
configurations can be overlaid (the first one solid, the others faded).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pkmstiff.io.atomic import atomic_path
from pkmstiff.mechanisms.constraints import Frames
from pkmstiff.mechanisms.model import Mechanism

MM = 1e3


def _link_points(mech: Mechanism) -> dict[int, list[np.ndarray]]:
    pts: dict[int, list[np.ndarray]] = {i: [] for i in range(len(mech.links))}
    for jt in mech.joints:
        if jt.type in ("fixed", "equal_orientation", "common_axis", "perpendicular_axes"):
            continue
        for li in set(jt.links):
            pts[li].append(jt.point)
    if mech.output is not None:
        pts[mech.output.link].append(mech.output.point)
    return pts


def mechanism_figure(mech: Mechanism, q: np.ndarray, path: str | Path | None = None, title: str | None = None,
                     labels: list[str] | None = None, guide_length: float = 0.3, elev: float = 20.0,
                     azim: float = -60.0):
    """Figure of configurations q (K, L, d) (or one (L, d)); saved as PNG to ``path`` if given. Axes in mm."""
    from matplotlib.figure import Figure

    q = np.asarray(q, dtype=float)
    q = q[None] if q.ndim == 2 else q
    D = mech.dim
    F = Frames(q, D)
    every = np.concatenate([(F.t[:, li][:, None] + np.einsum("kij,pj->kpi", F.R[:, li], np.array(pl))).reshape(-1, D)
                            for li, pl in _link_points(mech).items() if pl]) * MM
    every = every[np.isfinite(every).all(axis=1)]
    lo, hi = every.min(axis=0), every.max(axis=0)
    margin = 0.08 * float(np.max(hi - lo)) + 5.0  # mm: room for the joint dots and the labels under the output
    if D == 2:  # canvas shaped like the drawing of the links (guides cut at it), legend to its right
        lo, hi = lo - margin * np.array([1.0, 2.0]), hi + margin
        figsize = (8.0, float(np.clip(1.3 + 6.4 * (hi[1] - lo[1]) / (hi[0] - lo[0]), 2.4, 7.0)))
    else:
        figsize = (8.0, 6.4)
    fig = Figure(figsize=figsize, layout="constrained")
    ax = fig.add_subplot(111, projection="3d" if D == 3 else None)
    pts = _link_points(mech)
    colours = [f"C{i % 10}" for i in range(len(mech.links))]
    for kk in range(q.shape[0]):
        alpha = 1.0 if kk == 0 else 0.35
        for li, plist in pts.items():
            if not plist or li in mech.ground:
                continue
            P = np.array(plist)
            w = (F.t[kk, li][None] + P @ F.R[kk, li].T) * MM
            if len(w) > 2 and D == 2:
                w = np.vstack([w, w[:1]])
            ax.plot(*w.T, "-", color=colours[li], lw=2.2, alpha=alpha,
                    label=mech.links[li] if kk == 0 else None)
        for jt in mech.joints:
            if jt.type in ("fixed", "equal_orientation", "common_axis", "perpendicular_axes"):
                continue
            j = jt.links[0]
            w = (F.t[kk, j] + F.R[kk, j] @ jt.point) * MM
            ax.plot(*w[:, None], "s" if jt.drive is not None else "o", color="k", ms=5 if jt.drive else 4,
                    alpha=alpha)
            if kk == 0 and j in mech.ground and jt.axis is not None and jt.variable == "linear":
                seg = np.array([jt.point - guide_length * jt.axis, jt.point + guide_length * jt.axis]) * MM
                ax.plot(*seg.T, ":", color="0.4", lw=1.0)
        if mech.output is not None:
            o = mech.output
            w = (F.t[kk, o.link] + F.R[kk, o.link] @ o.point) * MM
            if D == 3:  # labels at the output points overlap in 3-D: the legend names each configuration
                ax.plot(*w[:, None], "*^so"[kk % 4], color="crimson", ms=10, alpha=max(alpha, 0.6),
                        label=f"output: {labels[kk]}" if labels else ("output" if kk == 0 else None))
            else:
                ax.plot(*w[:, None], "*", color="crimson", ms=10, alpha=alpha, label="output" if kk == 0 else None)
                if labels:
                    ax.annotate(labels[kk], w, fontsize=9, alpha=max(alpha, 0.7), xytext=(0, -14 - 11 * (kk % 2)),
                                textcoords="offset points", ha="center")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    if D == 3:
        ax.set_zlabel("z [mm]")
        ax.view_init(elev=elev, azim=azim)
        ax.set_xlim3d(lo[0] - margin, hi[0] + margin)
        ax.set_ylim3d(lo[1] - margin, hi[1] + margin)
        ax.set_zlim3d(lo[2] - margin, hi[2] + margin)
        ax.set_aspect("equal")  # the box follows the drawing's extent, no empty cube around it
    else:
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        ax.grid(True, lw=0.3)
    ax.set_title(title or mech.title, fontsize=10)
    fig.legend(fontsize=9, loc="outside right upper", title="links", title_fontsize=9, frameon=False)
    if path is not None:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110, facecolor="white")
    return fig
