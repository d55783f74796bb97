"""Where the parallel section path pays (issue 12, item 3): wall time of ``evaluate_section`` (quantity kx) serially
and with ``n_jobs=2`` for growing sections; the smallest size where the parallel run is faster is the threshold
``pkmstiff.evaluation.sections.PARALLEL_MIN_POINTS`` (worker start-up, imports and pickling cost seconds).

Usage: ``python benchmarks/bench_parallel_section.py [points ...]`` (default 10000 40000 160000).
"""

from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import numpy as np  # noqa: E402

from pkmstiff import load_machine  # noqa: E402
from pkmstiff.evaluation import sections  # noqa: E402


def main() -> None:
    sizes = [int(a) for a in sys.argv[1:]] or [10_000, 40_000, 160_000]
    m = load_machine("hexaglide")
    sections.evaluate_section(m, sections.axis_plane("yz", 0.0, (0.0, 0.1), (-1.0, -0.9), 0.01), ["kx"])
    old = sections.PARALLEL_MIN_POINTS
    sections.PARALLEL_MIN_POINTS = 0  # measure the parallel path itself
    try:
        for n in sizes:
            side = int(np.sqrt(n))
            step = 1.2 / side
            plane = sections.axis_plane("yz", 0.0, (-0.2, -0.2 + step * (side - 1)), (-1.13, -1.13 + step * (side - 1)),
                                        step)
            t = {}
            for jobs in (1, 2):
                t0 = time.perf_counter()
                sections.evaluate_section(m, plane, ["kx"], n_jobs=jobs, progress=False)
                t[jobs] = time.perf_counter() - t0
            print(f"{plane.points().shape[0]:>8d} points: serial {t[1]:7.2f} s, 2 processes {t[2]:7.2f} s, "
                  f"speed-up {t[1] / t[2]:5.2f} (cores {os.cpu_count()}, load {os.getloadavg()[0]:.1f})")
    finally:
        sections.PARALLEL_MIN_POINTS = old


if __name__ == "__main__":
    main()
