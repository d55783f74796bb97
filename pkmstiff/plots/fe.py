"""Off-screen pyvista images of deformed FE component models (PNG).

The deformation is magnified so that the largest displacement appears as ``magnified_fraction`` of the
model size; the colour shows the true displacement magnitude in µm; the undeformed shape is drawn as a
grey wireframe. Renders off-screen (``off_screen=True`` plotter).
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from pkmstiff.fe.export import FieldMesh
from pkmstiff.io.atomic import atomic_path


def deformed_image(fm: FieldMesh, path: str | Path, title: str = "", magnified_fraction: float = 0.08,
                   load_point: Sequence[float] | None = None, load_direction: Sequence[float] | None = None,
                   window_size: tuple[int, int] = (1000, 1000), view: str = "oblique") -> tuple[Path, float]:
    """Render ``fm`` deformed and write a PNG; returns (path, magnification factor used).

    ``view``: ``"oblique"`` (default, looking mostly along -y onto the tilt plane x-z), ``"xz"`` or ``"iso"``.
    """
    import pyvista as pv

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    n = fm.cells.shape[0]
    cells = np.hstack([np.full((n, 1), 8), fm.cells]).ravel()
    celltypes = np.full(n, pv.CellType.HEXAHEDRON, dtype=np.uint8)
    grid = pv.UnstructuredGrid(cells, celltypes, fm.points)
    umag = np.linalg.norm(fm.displacement, axis=1)  # colour: the displacement magnitude in µm
    grid.point_data["u"] = fm.displacement
    grid.point_data["displacement [µm]"] = umag * 1e6
    size = float(np.linalg.norm(fm.points.max(axis=0) - fm.points.min(axis=0)))
    scale = magnified_fraction * size / umag.max() if umag.max() > 0 else 1.0
    warped = grid.warp_by_vector("u", factor=scale)
    pl = pv.Plotter(off_screen=True, window_size=list(window_size))
    pl.set_background("white")
    pl.add_mesh(grid.extract_feature_edges(30), color="grey", opacity=0.6, line_width=1)
    top = float(umag.max() * 1e6)
    pl.add_mesh(warped, scalars="displacement [µm]", cmap="viridis", show_edges=True, edge_color="#303030",
                line_width=0.3, scalar_bar_args={"title": "displacement [µm]", "color": "black", "vertical": False,
                                                 "position_x": 0.22, "position_y": 0.03, "width": 0.7,
                                                 "height": 0.07, "title_font_size": 26, "label_font_size": 24,
                                                 "n_labels": 5, "fmt": "%.0f" if top >= 10 else "%.3g"})
    if load_point is not None and load_direction is not None:
        d = np.asarray(load_direction, float)
        d = d / np.linalg.norm(d)
        arrow = pv.Arrow(start=np.asarray(load_point, float), direction=d, scale=0.25 * size)
        pl.add_mesh(arrow, color="red")
    text = f"{title}\ndeformation magnified x{scale:.0f}" if title else f"deformation magnified x{scale:.0f}"
    pl.add_text(text, position="upper_left", font_size=14, color="black")
    centre = 0.5 * (fm.points.max(axis=0) + fm.points.min(axis=0))
    direction = {"iso": (1.0, 1.0, 1.0), "xz": (0.0, -1.0, 0.0), "oblique": (0.45, -1.0, 0.45)}[view]
    d = np.asarray(direction) / np.linalg.norm(direction)
    pl.camera_position = [tuple(centre + 2.5 * size * d), tuple(centre), (0.0, 0.0, 1.0)]
    pl.reset_camera()
    pl.camera.zoom(1.05)
    pos, foc, up = (np.asarray(v, float) for v in pl.camera_position)
    shift = -0.07 * size * up  # the colour bar takes the bottom rows: move the model up
    pl.camera_position = [tuple(pos + shift), tuple(foc + shift), tuple(up)]
    with atomic_path(path) as tmp:
        pl.screenshot(str(tmp))
    pl.close()
    return path, scale
