"""Readable axes for 3-D pyvista figures (issue 12 item 5): three labelled edges of the data box in mm.

VTK's cube-axes actor (``show_bounds``) puts its labels at evenly spaced, odd values (−158, 379, 917), in a small
font, and the end labels of the three axes overlap at the shared corner. Here each axis gets 3–6 ticks at a round
step (1, 2, 2.5 or 5 × 10^k mm) inside its range, labels in a large font placed outward from the box, and an axis title
with its unit at the middle of the edge (z: above the top of its labels, where no tick label can be); the edges are those on the camera's side of the box (bottom x and y edges,
a vertical silhouette edge for z), and tick labels next to the corner where two axes meet are left out.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np


def nice_ticks(lo: float, hi: float, max_ticks: int = 5) -> np.ndarray:
    """Round tick values within [lo, hi]: the smallest step 1, 2, 2.5 or 5 × 10^k giving at most ``max_ticks``."""
    span = hi - lo
    if not (math.isfinite(span) and span > 0):
        return np.array([lo])
    mag = 10.0 ** (math.floor(math.log10(span)) - 2)
    for step in (m * mag * 10.0 ** e for e in range(4) for m in (1, 2, 2.5, 5)):
        first, last = math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9)
        if last - first + 1 <= max_ticks:
            break
    return np.arange(first, last + 1) * step


def _fmt(v: float) -> str:
    return f"{v:.0f}" if abs(v - round(v)) < 1e-9 else f"{v:g}"


def add_mm_axes(plotter, bounds_mm: Sequence[float], view_direction: Sequence[float], font_size: int = 18,
                titles: tuple[str, str, str] = ("x [mm]", "y [mm]", "z [mm]"), color: str = "black",
                name: str | None = None) -> None:
    """Draw labelled x, y, z axes (mm) along three edges of the box ``bounds_mm`` (xmin, xmax, ymin, ymax, zmin,
    zmax) as seen from ``view_direction`` (from the focal point towards the camera); ``name``: a prefix for the
    actors' names, so that drawing the axes again under the same name replaces them."""
    import pyvista as pv

    b = np.asarray(bounds_mm, dtype=float).reshape(3, 2)
    d = np.asarray(view_direction, dtype=float)
    near = np.where(d >= 0, 1, 0)  # index of the box side facing the camera, per axis
    far = 1 - near
    size = float(np.linalg.norm(b[:, 1] - b[:, 0])) or 1.0
    off = 0.045 * size
    centre = b.mean(axis=1)
    # edge of each axis: (axis, fixed coordinates of the two other axes)
    x_edge = {1: b[1, near[1]], 2: b[2, 0]}
    y_edge = {0: b[0, near[0]], 2: b[2, 0]}
    z_edge = {0: b[0, near[0]], 1: b[1, far[1]]}
    corner_xy = np.array([b[0, near[0]], b[1, near[1]]])  # where the x and y edges meet
    lines, label_pts, labels, title_pts = [], [], [], []
    for axis, fixed in ((0, x_edge), (1, y_edge), (2, z_edge)):
        lo, hi = b[axis]
        start = np.empty(3)
        for k, v in fixed.items():
            start[k] = v
        start[axis] = lo
        end = start.copy()
        end[axis] = hi
        lines.append((start, end))
        outward = np.zeros(3)
        for k in fixed:
            outward[k] = np.sign(start[k] - centre[k]) or 1.0
        outward /= np.linalg.norm(outward)
        ticks = nice_ticks(lo, hi)
        for t in ticks:
            p = start.copy()
            p[axis] = t
            if axis < 2 and abs(t - corner_xy[axis]) < 0.12 * (hi - lo):
                continue  # next to the corner shared by the x and y axes: the other axis' labels sit there
            lines.append((p, p + 0.4 * off * outward))
            label_pts.append(p + 1.6 * off * outward)
            labels.append(_fmt(t))
        if axis < 2:
            mid = start.copy()
            mid[axis] = 0.5 * (lo + hi)
            title_pts.append(mid + 3.6 * off * outward)
        else:  # above the column of the z labels: beside them, a perspective view can put it on a label
            top = end + 1.6 * off * outward
            top[2] = ticks[-1] + 1.1 * off
            title_pts.append(top)
    segs = np.array([pt for seg in lines for pt in seg])
    cells = np.hstack([[2, 2 * i, 2 * i + 1] for i in range(len(lines))])
    nm = (lambda part: None) if name is None else (lambda part: f"{name}_{part}")  # noqa: E731
    plotter.add_mesh(pv.PolyData(segs, lines=cells), color=color, line_width=2, name=nm("lines"))
    plotter.add_point_labels(np.array(label_pts), labels, font_size=font_size, text_color=color, shape=None,
                             show_points=False, always_visible=True, justification_horizontal="center",
                             justification_vertical="center", name=nm("labels"))
    # invisible anchors: the camera's reset_camera frames the labels too, not only the data
    plotter.add_mesh(pv.PolyData(np.vstack([label_pts, title_pts])), opacity=0.0, point_size=1, name=nm("anchors"))
    plotter.add_point_labels(np.array(title_pts), list(titles), font_size=font_size + 2, text_color=color,
                             shape=None, show_points=False, always_visible=True, bold=True,
                             justification_horizontal="center", justification_vertical="center", name=nm("titles"))


def frame_camera(p, direction, box: np.ndarray | None, zoom: float = 1.0) -> None:
    """Look along ``-direction`` at the centre of ``box`` (3, 2) [mm] (default: everything drawn), framed so that
    the box and its axis labels fill the view; then zoom by ``zoom``."""
    bounds = np.array(p.bounds).reshape(3, 2) if box is None else np.asarray(box, float)
    focus = bounds.mean(axis=1)
    dist = 2.2 * float(np.linalg.norm(bounds[:, 1] - bounds[:, 0]))
    p.camera_position = [tuple(focus + dist * np.asarray(direction)), tuple(focus), (0.0, 0.0, 1.0)]
    pad = 0.18 * (bounds[:, 1] - bounds[:, 0])[:, None] * np.array([-1.0, 1.0])  # room for the axis labels
    p.reset_camera(bounds=(bounds + pad).ravel())
    p.camera.zoom(zoom)
