"""Off-screen pyvista figures: section maps, three-plane figures, machine sketches, mode shapes (PNG/GIF).

Coordinates in figures are in mm, quantities in their display units (N/µm, Hz, deg, …).
"""

from __future__ import annotations

import os


def offscreen():
    """Import pyvista configured for off-screen rendering (no X server needed)."""
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True
    return pv
