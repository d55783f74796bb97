"""Start-up and single-pose benchmark (issue 12, item 6).

Prints
* the wall time of whole processes ``pkmstiff pose`` and ``pkmstiff point`` for one pose (best of ``--repeat``),
  next to a bare ``python -c pass`` (the interpreter's own start-up on this machine);
* the time of one pose through the Python API (:func:`pkmstiff.admissibility.evaluate_poses`, kinematics and every
  admissibility check): minimum and median of many calls after a warm-up.

Targets: process ≤ 0.6 s, one pose ≤ 200 µs. On a machine shared with other jobs the minimum is the fairer figure.
Usage: ``python benchmarks/bench_startup.py [--repeat 5]``
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

POSE = "0,300,-900,0,0,0"


def process_time(argv: list[str], repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(argv, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
        best = min(best, time.perf_counter() - t0)
    return best


def single_pose(n: int = 500) -> tuple[float, float]:
    import numpy as np

    from pkmstiff import load_machine
    from pkmstiff.admissibility.pipeline import evaluate_poses

    m = load_machine("hexaglide")
    p = np.array([[0.0, 0.3, -0.9, 0.0, 0.0, 0.0]])
    for _ in range(20):
        evaluate_poses(m, p)
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        evaluate_poses(m, p)
        ts.append(time.perf_counter() - t0)
    return min(ts), float(np.median(ts))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    py = sys.executable
    base = process_time([py, "-c", "pass"], args.repeat)
    pose = process_time([py, "-m", "pkmstiff.cli", "pose", "hexaglide", "--pose", POSE, "--json"], args.repeat)
    point = process_time([py, "-m", "pkmstiff.cli", "point", "hexaglide", "--pose", POSE, "--json"], args.repeat)
    print(f"python -c pass          {base:6.3f} s (interpreter start-up)")
    print(f"pkmstiff pose  (1 pose) {pose:6.3f} s wall, whole process (target 0.6 s)")
    print(f"pkmstiff point (1 pose) {point:6.3f} s wall, whole process (target 0.6 s)")
    lo, med = single_pose()
    print(f"evaluate_poses, 1 pose  {lo * 1e6:6.0f} µs min, {med * 1e6:6.0f} µs median (target 200 µs)")


if __name__ == "__main__":
    main()
