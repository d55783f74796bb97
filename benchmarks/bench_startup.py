"""Start-up and single-pose benchmark (issue 12, item 6).

Prints
* the wall time of whole processes ``pkmstiff pose`` and ``pkmstiff point`` for one pose (best of ``--repeat``),
  next to a bare ``python -c pass`` (the interpreter's own start-up on this machine);
* the time of one pose through the Python API (:func:`pkmstiff.admissibility.evaluate_poses`, kinematics and every
  admissibility check): minimum and median of many calls after a warm-up past the switch to the compiled kernels
  (the small-N fast path, :mod:`pkmstiff.admissibility.fastpath`).

Targets: process ≤ 0.6 s, one pose ≤ 200 µs. On a machine shared with other jobs the minimum is the fairer figure;
the processes' CPU time (user + system, from ``getrusage``) is printed next to the wall time.

The processes run with Python's bytecode cache (``.pyc``), as an installed package does (pip compiles it at install
time); ``PYTHONDONTWRITEBYTECODE`` set in the calling environment would otherwise make every run compile all modules
(~0.3 s more) until ``.pyc`` files exist. ``--no-bytecode`` keeps that variable set (Python still reads ``.pyc`` files
written earlier: remove ``__pycache__`` first to measure a source-only start). The bundled machine is read from the user cache
(:mod:`pkmstiff.machine.cache`) after the first run.
Usage: ``python benchmarks/bench_startup.py [--repeat 5] [--no-bytecode]``
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, ROOT)

POSE = "0,300,-900,0,0,0"


def process_time(argv: list[str], repeat: int, bytecode: bool = True) -> tuple[float, float]:
    """Best wall time and best CPU time (user + system) of ``repeat`` runs of ``argv`` (after one warm-up run)."""
    env = dict(os.environ)
    if bytecode:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
    else:
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    subprocess.run(argv, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False, env=env)
    best, best_cpu = float("inf"), float("inf")
    for _ in range(repeat):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(argv, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False, env=env)
        best = min(best, time.perf_counter() - t0)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        best_cpu = min(best_cpu, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime))
    return best, best_cpu


def single_pose(n: int = 2000) -> tuple[float, float, float]:
    """Min and median wall time and median CPU time (s) of one pose through ``evaluate_poses``.

    The warm-up takes the process past the switch to the compiled kernels (:mod:`pkmstiff.kinematics.dispatch`), so
    the calls measured run the small-N fast path (:mod:`pkmstiff.admissibility.fastpath`) as a long-running session
    does; the first few poses of a process run the interpreted kernels (~1.5 ms per pose) instead.
    """
    import numpy as np

    from pkmstiff import load_machine
    from pkmstiff.admissibility.pipeline import evaluate_poses
    from pkmstiff.kinematics import dispatch

    m = load_machine("hexaglide")
    p = np.array([[0.0, 0.3, -0.9, 0.0, 0.0, 0.0]])
    for _ in range(dispatch.COMPILE_AFTER + 50):
        evaluate_poses(m, p)
    ts, cs = [], []
    for _ in range(n):
        c0 = time.process_time()
        t0 = time.perf_counter()
        evaluate_poses(m, p)
        ts.append(time.perf_counter() - t0)
        cs.append(time.process_time() - c0)
    return min(ts), float(np.median(ts)), float(np.median(cs))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--no-bytecode", action="store_true", help="run the processes without the .pyc cache")
    args = ap.parse_args()
    py = sys.executable
    bc = not args.no_bytecode
    base = process_time([py, "-c", "pass"], args.repeat, bc)
    numpy = process_time([py, "-c", "import numpy"], args.repeat, bc)
    pose = process_time([py, "-m", "pkmstiff.cli", "pose", "hexaglide", "--pose", POSE, "--json"], args.repeat, bc)
    point = process_time([py, "-m", "pkmstiff.cli", "point", "hexaglide", "--pose", POSE, "--json"], args.repeat, bc)
    print(f"(bytecode cache {'on' if bc else 'off'}; best of {args.repeat})")
    print(f"python -c pass          {base[0]:6.3f} s wall {base[1]:6.3f} s CPU (interpreter start-up)")
    print(f"python -c 'import numpy' {numpy[0]:5.3f} s wall {numpy[1]:6.3f} s CPU")
    print(f"pkmstiff pose  (1 pose) {pose[0]:6.3f} s wall {pose[1]:6.3f} s CPU, whole process (target 0.6 s)")
    print(f"pkmstiff point (1 pose) {point[0]:6.3f} s wall {point[1]:6.3f} s CPU, whole process (target 0.6 s)")
    lo, med, cpu = single_pose()
    print(f"evaluate_poses, 1 pose  {lo * 1e6:6.0f} µs min, {med * 1e6:6.0f} µs median wall, {cpu * 1e6:4.0f} µs median "
          f"CPU (target 200 µs)")


if __name__ == "__main__":
    main()
