"""Checks of a figure a user would put in a report (tests/test_figures.py): canvas fill and text size, for matplotlib
figures and pyvista screenshots alike.

* **Fill**: the area of the bounding box of the pixels that differ from the corner (background) colour by more than
  30 (sum over RGB, out of 765) over the canvas area; antialiasing halos stay below that threshold.
* **Edge** (matplotlib figures): the outermost :data:`EDGE_PX` pixels of the saved image are all background (within
  the same 30 of the corner colour): nothing is cut at the canvas edge and no label touches it. Not applied to pyvista
  screenshots: their 3-D scene is framed by the camera, and a plane or a machine part may run off the window on
  purpose.
* **Text, matplotlib**: the smallest font size [pt] of the visible, non-empty texts at the figure's own size in
  inches (points are 1/72 in).
* **Text, pyvista**: VTK's font sizes are not what it draws (corner annotations and scalar bars scale with the
  window), so the text is measured in the rendered image: each text-carrying actor (text, corner annotation, scalar
  bar, point labels, cube axes) is hidden in turn and the pixels that change are its glyphs; the 75th percentile of
  the heights of their connected pieces is read as the cap height, 0.733 of the font size (VTK's font drawn at 30 px:
  capitals and digits 22 px, x-height 17 px, brackets 26 px). The estimate errs low (a text of lower-case letters
  only reads 23 % small), never high unless a text is all brackets. A screenshot is printed at
  :data:`PRINT_PX_PER_IN` pixels per inch, the density of the matplotlib figures (saved at 100–130 dpi), so
  font size [pt] = cap height [px] / 0.733 / PRINT_PX_PER_IN · 72.
"""

from __future__ import annotations

import numpy as np

MIN_FILL = 0.80
MIN_PT = 9.0  # readable at print size
EDGE_PX = 2  # background border a saved matplotlib figure keeps
PRINT_PX_PER_IN = 100.0
CAP_HEIGHT = 22.0 / 30.0  # cap height / font size of VTK's text (measured: 22 px at a 30 px font)


def _drawn(path_or_img) -> np.ndarray:
    """Mask of the pixels that differ from the corner (background) colour by more than 30 (sum over RGB)."""
    from PIL import Image

    img = path_or_img if isinstance(path_or_img, np.ndarray) else np.asarray(Image.open(path_or_img).convert("RGB"))
    img = img[..., :3].astype(int)
    return np.abs(img - img[0, 0]).sum(axis=2) > 30


def edge_pixels(path_or_img, width: int = EDGE_PX) -> int:
    """Number of drawn pixels in the outermost ``width`` pixels of the image (0: a clean background border)."""
    mask = _drawn(path_or_img)
    inner = np.zeros_like(mask)
    inner[width:-width, width:-width] = True
    return int((mask & ~inner).sum())


def fill_fraction(path_or_img) -> float:
    mask = _drawn(path_or_img)
    ys, xs = np.nonzero(mask)
    assert ys.size, "blank image"
    return (ys.max() - ys.min() + 1) * (xs.max() - xs.min() + 1) / mask.size


def smallest_text_pt(fig) -> float:
    """Smallest font size [pt] of the visible, non-empty texts of a matplotlib figure (ticks, labels, legends)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    if fig.canvas is None or not hasattr(fig.canvas, "get_renderer"):
        FigureCanvasAgg(fig)
    fig.draw_without_rendering()
    sizes = [t.get_fontsize() for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]
    assert sizes, "figure without text"
    return min(sizes)


def _text_actors(plotter) -> list:
    import vtk

    ren = plotter.renderer
    found = []
    text_kinds = (vtk.vtkTextActor, vtk.vtkCornerAnnotation, vtk.vtkScalarBarActor, vtk.vtkCubeAxesActor,
                  vtk.vtkCubeAxesActor2D)
    label_mappers = (vtk.vtkLabelPlacementMapper, vtk.vtkLabeledDataMapper)
    for a in ren.actors.values():
        if isinstance(a, text_kinds) or (isinstance(a, vtk.vtkActor2D) and isinstance(a.GetMapper(), label_mappers)):
            found.append(a)
    axes = getattr(ren, "cube_axes_actor", None)
    if axes is not None and axes not in found:
        found.append(axes)
    return [a for a in found if a.GetVisibility()]


def _cap_height_px(diff: np.ndarray) -> float | None:
    from scipy import ndimage

    lab, n = ndimage.label(diff)
    if n == 0:
        return None
    heights = np.array([s[0].stop - s[0].start for s in ndimage.find_objects(lab)])
    widths = np.array([s[1].stop - s[1].start for s in ndimage.find_objects(lab)])
    glyphs = heights[(heights >= 2) & (widths <= 4 * heights)]  # a colour band or an axis line is no glyph
    return float(np.percentile(glyphs, 75)) if glyphs.size else None


def pyvista_text_pt(plotter) -> dict[str, float]:
    """Font size [pt] at print size of each visible text-carrying actor of a pyvista plotter, measured in the
    rendered image (module docstring); call it before the plotter's screenshot."""
    def grab() -> np.ndarray:
        plotter.render_window.Render()  # pyvista's render() waits for the first show(); render directly
        return np.asarray(plotter.screenshot(return_img=True)).astype(int)

    base = grab()
    out: dict[str, float] = {}
    for k, actor in enumerate(_text_actors(plotter)):
        actor.VisibilityOff()
        img = grab()
        actor.VisibilityOn()
        px = _cap_height_px(np.abs(img - base).sum(axis=2) > 60)
        if px is not None:
            out[f"{k}:{actor.GetClassName()}"] = px / CAP_HEIGHT / PRINT_PX_PER_IN * 72.0
    plotter.render_window.Render()
    return out
