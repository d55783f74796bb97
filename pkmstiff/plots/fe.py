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
                   window_size: tuple[int, int] = (1400, 1000), view: str = "oblique") -> tuple[Path, float]:
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
    umag = np.linalg.norm(fm.displacement, axis=1)
    grid.point_data["u"] = fm.displacement
    grid.point_data["|u| [um]"] = umag * 1e6
    size = float(np.linalg.norm(fm.points.max(axis=0) - fm.points.min(axis=0)))
    scale = magnified_fraction * size / umag.max() if umag.max() > 0 else 1.0
    warped = grid.warp_by_vector("u", factor=scale)
    pl = pv.Plotter(off_screen=True, window_size=list(window_size))
    pl.set_background("white")
    pl.add_mesh(grid.extract_feature_edges(30), color="grey", opacity=0.6, line_width=1)
    pl.add_mesh(warped, scalars="|u| [um]", cmap="viridis", show_edges=True, edge_color="#303030",
                line_width=0.3, scalar_bar_args={"title": "|u| [um]", "color": "black", "vertical": True,
                                                 "position_x": 0.86, "position_y": 0.15, "height": 0.7})
    if load_point is not None and load_direction is not None:
        d = np.asarray(load_direction, float)
        d = d / np.linalg.norm(d)
        arrow = pv.Arrow(start=np.asarray(load_point, float), direction=d, scale=0.25 * size)
        pl.add_mesh(arrow, color="red")
    text = f"{title}\ndeformation magnified x{scale:.0f}" if title else f"deformation magnified x{scale:.0f}"
    pl.add_text(text, position="upper_left", font_size=11, color="black")
    centre = 0.5 * (fm.points.max(axis=0) + fm.points.min(axis=0))
    direction = {"iso": (1.0, 1.0, 1.0), "xz": (0.0, -1.0, 0.0), "oblique": (0.45, -1.0, 0.45)}[view]
    d = np.asarray(direction) / np.linalg.norm(direction)
    pl.camera_position = [tuple(centre + 2.5 * size * d), tuple(centre), (0.0, 0.0, 1.0)]
    pl.reset_camera()
    pl.camera.zoom(1.1)
    with atomic_path(path) as tmp:
        pl.screenshot(str(tmp))
    pl.close()
    return path, scale
