"""Benchmark (issue 5): a 200 x 200 YZ section of the Hexaglide with k_x, k_y, k_z and f1..f3, one core.

Target: <= 8 s. Run: ``python benchmarks/bench_section.py [n]`` (n x n raster, default 200).
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
from pkmstiff.evaluation.sections import Plane, evaluate_section  # noqa: E402


def main(n: int = 200) -> None:
    m = pkmstiff.load_machine("hexaglide")
    plane = Plane(origin=np.zeros(3), u_axis=np.array([0.0, 1.0, 0.0]), v_axis=np.array([0.0, 0.0, 1.0]),
                  u_values=np.linspace(-0.6, 0.8, n), v_values=np.linspace(-1.2, -0.5, n), u_name="y", v_name="z",
                  name="YZ plane at x = 0 mm")
    names = ["kx", "ky", "kz", "f1", "f2", "f3"]
    evaluate_section(m, Plane(plane.origin, plane.u_axis, plane.v_axis, plane.u_values[:20], plane.v_values[:20]),
                     names, tool_length=0.0, progress=False)  # warm-up (imports, JIT)
    t0, c0 = time.perf_counter(), time.process_time()
    res = evaluate_section(m, plane, names, tool_length=0.0, progress=False)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(f"{n} x {n} YZ section, quantities {','.join(names)}: {wall:.2f} s wall, {cpu:.2f} s CPU (one thread); "
          f"{res.ok.sum()} of {res.ok.size} points admissible")
    for q, st in res.statistics().items():
        print(f"  {q:<3} [{st['unit']}] min {st['min']:.4g} mean {st['mean']:.4g} max {st['max']:.4g}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200)
