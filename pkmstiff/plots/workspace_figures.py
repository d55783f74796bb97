"""Example figures of the README (``python -m pkmstiff.plots.workspace_figures [OUTDIR]``, default docs/images).

Hexaglide (bundled data): constant-orientation workspace at eps = 12.5 mm with the machine sketch, maximum rotation
angles on the Y-Z plane at x = 0, rotational workspace at x = 0, y = 400, z = -1000 mm (as Cobet Figs. 4.4, 4.5), volume
over the tool orientation, and the volume convergence on the sphere and cube of the dissertation.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from pkmstiff import load_machine
from pkmstiff.plots.workspace import (
    plot_convergence,
    plot_rotation_maps,
    plot_rotational_workspace,
    plot_volume_vs_orientation,
    plot_workspace,
)
from pkmstiff.workspace.rotation import SIX_DIRECTIONS, rotation_angle_map, rotational_workspace_map
from pkmstiff.workspace.translational import constant_orientation_workspace, volume_vs_orientation
from pkmstiff.workspace.validation import volume_convergence

BELOW = (np.array([-1.6, -0.4, -1.9]), np.array([1.6, 1.2, -0.3]))  # Hexaglide working region below the guides


def main(out: str = "docs/images") -> list[Path]:
    outdir = Path(out)
    m = load_machine("hexaglide")
    files = []
    res = constant_orientation_workspace(m, 0.0125, box=BELOW)
    files.append(plot_workspace(res, m, outdir / "workspace_hexaglide.png", view=(-1.0, -1.6, 0.5)))
    u = np.arange(-0.2, 1.1001, 0.025)
    v = np.arange(-1.25, -0.4, 0.025)
    rm = rotation_angle_map(m, [0, 0, 0], [0, 1, 0], [0, 0, 1], u, v, (0, 0, 0), SIX_DIRECTIONS, math.radians(1.0))
    files.append(plot_rotation_maps(rm, outdir / "workspace_rotation_map_yz.png", ("y [mm]", "z [mm]"),
                                    title="Hexaglide: max. admissible rotation angles on the Y-Z plane at x = 0\n"
                                          f"(increment 1 deg; predictor-corrector: "
                                          f"{sum(rm.evaluations.values()):,} evaluations instead of "
                                          f"{sum(rm.plain_sequential.values()):,})"))
    rw = [rotational_workspace_map(m, (0.0, 0.4, -1.0), d, np.radians(np.arange(-30, 30.1, 1.0)),
                                   np.radians(np.arange(-60, 60.1, 2.0))) for d in ("+a", "+b")]
    files.append(plot_rotational_workspace(rw, outdir / "workspace_rotational_point.png",
                                           "Hexaglide: rotational workspace at x = 0, y = 400, z = -1000 mm"))
    ang = np.radians(np.arange(-20.0, 20.1, 2.5))
    vols = volume_vs_orientation(m, ang, resolution=0.025, box=BELOW)
    files.append(plot_volume_vs_orientation(ang, vols, outdir / "workspace_volume_vs_orientation.png",
                                            "Hexaglide: workspace volume over the tool orientation (eps = 25 mm)"))
    eps = np.array([50.0, 25.0, 12.5, 6.25, 3.125])
    conv = volume_convergence(eps * 1e-3, refine_steps=(0, 3))
    errs = {b: {k: v for k, v in d.items() if not k.startswith("evaluations")} for b, d in conv.items()}
    files.append(plot_convergence(eps, errs, outdir / "workspace_volume_convergence.png"))
    return files


if __name__ == "__main__":  # pragma: no cover
    for f in main(*sys.argv[1:]):
        print(f)
