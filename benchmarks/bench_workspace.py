"""Benchmark (issue 6): Hexaglide workspace at constant orientation a = b = c = 0 by the modified octree.

Targets: eps = 12.5 mm in <= 3 s and eps = 1.5625 mm in <= 60 s on one core. Baseline (Cobet Table 4.3, 350 MHz
Pentium III): 45,884 points in 7:15 min at 12.5 mm, 3,011,531 points in 8:10 h at 1.5625 mm.

Run: ``python benchmarks/bench_workspace.py [eps_mm ...] [--box full|below]``. Measured (2-core machine shared
with other jobs): 12.5 mm: 98,945 points in 1.0 s; 1.5625 mm: 6,470,419 points in 48 s (29 s pose evaluation).

Box: ``below`` (default) = x in [-1.6, 1.6], y in [-0.4, 1.2], z in [-1.9, -0.3] m, the working region below the
guides with extents 12.5 mm * 2**k so that both resolutions result from repeated halving (spec §7.4); ``full`` = the
machine's reach box, which with the bundled Hexaglide data also contains an admissible mirror region above the
guides (no check of the model excludes it).
"""

import os
import sys as _sys

_sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))  # run from a clone

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import pkmstiff  # noqa: E402
from pkmstiff.workspace.translational import constant_orientation_workspace  # noqa: E402

BELOW = (np.array([-1.6, -0.4, -1.9]), np.array([1.6, 1.2, -0.3]))


def run(eps_mm: float, box_name: str = "below") -> dict:
    m = pkmstiff.load_machine("hexaglide")
    box = BELOW if box_name == "below" else None
    t0 = time.perf_counter()
    r = constant_orientation_workspace(m, eps_mm * 1e-3, box=box, methods=("surface_nets",))
    wall = time.perf_counter() - t0
    s = r.summary()
    print(f"eps = {eps_mm:g} mm ({box_name} box): {s['evaluations']:,} evaluated points "
          f"({s['boundary_points']:,} boundary points, {s['closure_voxels']:,} from the closure step) "
          f"in {wall:.2f} s = {s['evaluation_time_s']:.2f} s evaluation + {s['octree_overhead_s']:.2f} s octree/mesh; "
          f"{s['evaluations'] / s['evaluation_time_s']:,.0f} points/s")
    print("   volume [m^3]: " + ", ".join(f"{k} {v:.4f}" for k, v in s["volumes_m3"].items())
          + f"; touches box: {s['touches_initial_box']}")
    print("   new evaluations per level: " + ", ".join(f"{lv}:{n}" for lv, n in s["evaluations_per_level"]))
    return s


def main(argv: list[str]) -> None:
    box = "below"
    if "--box" in argv:
        i = argv.index("--box")
        box = argv[i + 1]
        argv = argv[:i] + argv[i + 2:]
    eps = [float(a) for a in argv] or [12.5, 1.5625]
    pkmstiff.load_machine("hexaglide")
    for e in eps:
        run(e, box)


if __name__ == "__main__":
    main(sys.argv[1:])
