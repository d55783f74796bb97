"""Benchmark (issue 2): IK + inverse Jacobian + condition number + joint angles + all admissibility checks.

Target: >= 100,000 poses/s for the Hexaglide on one core. Run: ``python benchmarks/bench_admissibility.py [N]``.
Poses are random over the Hexaglide's working region (y, z section box, small rotations), so collisions and
out-of-range chains occur as in a real map.
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import pkmstiff  # noqa: E402
from pkmstiff.poses import evaluate_poses  # noqa: E402


def main(n: int = 200_000, machine: str = "hexaglide") -> None:
    m = pkmstiff.load_machine(machine)
    rng = np.random.default_rng(0)
    poses = np.column_stack([
        rng.uniform(-0.4, 0.4, n), rng.uniform(-0.6, 0.8, n), rng.uniform(-1.2, -0.5, n),
        rng.uniform(-0.1, 0.1, n), rng.uniform(-0.1, 0.1, n), rng.uniform(-0.1, 0.1, n),
    ])
    evaluate_poses(m, poses[:1000])  # warm-up
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        ev = evaluate_poses(m, poses)
        best = min(best, time.perf_counter() - t0)
    s = ev.admissibility.summary()
    print(f"{machine}: {n} poses in {best:.3f} s -> {n / best:,.0f} poses/s (one thread; best of 3)")
    print(f"admissible {s['admissible']} of {n}; reasons: "
          + ", ".join(f"{k}={v}" for k, v in s.items() if k not in ("poses", "admissible") and v))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200_000, sys.argv[2] if len(sys.argv) > 2 else "hexaglide")
