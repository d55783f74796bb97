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
    from pkmstiff.mechanisms.modeshape import link_points

    return {li: [p for p, _ in pl] for li, pl in link_points(mech).items()}


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


def _triad(ax, lo: np.ndarray, size: float, dim: int) -> None:
    """Axes x, y (, z) as red, green (, blue) arrows with labels at the lower corner of the drawing (mm)."""
    length = 0.15 * size
    origin = lo - 0.05 * size
    for k, colour in enumerate(("red", "green", "blue")[:dim]):
        d = np.zeros(dim)
        d[k] = length
        if dim == 3:
            ax.quiver(*origin, *d, color=colour, lw=2, arrow_length_ratio=0.25)
        else:
            ax.annotate("", origin + d, origin, arrowprops={"arrowstyle": "-|>", "color": colour, "lw": 2})
        ax.text(*(origin + 1.2 * d), "xyz"[k], color=colour, fontsize=10)


def mechanism_mode_figure(mech: Mechanism, shape, path: str | Path, title: str, amplitude: float | None = None,
                          elev: float = 20.0, azim: float = -60.0) -> Path:
    """PNG of a mode shape (:class:`~pkmstiff.mechanisms.modeshape.MechanismModeShape`): the undeformed links
    (grey) and the links displaced by the mode scaled to ``amplitude`` [m] peak displacement (orange; default a
    tenth of the drawing's size), axes in mm (the scale), an x, y, z triad and a legend stating the amplitude and
    the scale factor — the machines' mode-shape figure (:func:`pkmstiff.plots.modes.plot_mode_shape`)."""
    from matplotlib.figure import Figure

    D = mech.dim
    world = {li: w[:, :D] * MM for li, w in shape.world.items()}
    every = np.concatenate(list(world.values()))
    lo, hi = every.min(axis=0), every.max(axis=0)
    size = float(np.max(hi - lo))
    amplitude = 0.1 * size / MM if amplitude is None else amplitude
    factor = shape.scale_for(amplitude)
    fig = Figure(figsize=(8.0, 6.6), layout="constrained")
    ax = fig.add_subplot(111, projection="3d" if D == 3 else None)
    for k, (li, w) in enumerate(world.items()):
        moved = w + factor * shape.displacement[li][:, :D] * MM
        for pts, colour, lw, label in ((w, "0.6", 1.6, "undeformed" if k == 0 else None),
                                       (moved, "darkorange", 2.4, f"mode {shape.mode}" if k == 0 else None)):
            closed = np.vstack([pts, pts[:1]]) if len(pts) > 2 else pts
            ax.plot(*closed.T, "-", color=colour, lw=lw, label=label)
            ax.plot(*pts.T, "o", color=colour, ms=3)
    margin = 0.12 * size + 5.0
    _triad(ax, lo, size, D)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    if D == 3:
        ax.set_zlabel("z [mm]")
        ax.view_init(elev=elev, azim=azim)
        for setter, a in ((ax.set_xlim3d, 0), (ax.set_ylim3d, 1), (ax.set_zlim3d, 2)):
            setter(lo[a] - margin, hi[a] + margin)
        ax.set_aspect("equal")
    else:
        ax.set_xlim(lo[0] - margin, hi[0] + margin)
        ax.set_ylim(lo[1] - margin, hi[1] + margin)
        ax.set_aspect("equal")
        ax.grid(True, lw=0.3)
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper right", fontsize=9, frameon=False,
              title=f"mode {shape.mode} scaled to {amplitude * MM:.3g} mm peak displacement (x{factor:.3g})",
              title_fontsize=9)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, facecolor="white")
    return path
