"""Off-screen pyvista figures: section maps, three-plane figures, machine sketches, mode shapes (PNG/GIF).

Coordinates in figures are in mm, quantities in their display units (N/µm, Hz, deg, …). Every plotter is created
with ``off_screen=True``; the library sets no global state. On a machine without a display, choose VTK's EGL
window at the edge (the command line does) to avoid VTK's X-server warning:
``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow``.
"""

from __future__ import annotations


def offscreen():
    """Import pyvista (lazily: it is heavy); every plotter of the toolkit renders off-screen."""
    import pyvista as pv

    return pv
