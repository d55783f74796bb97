"""Throughput of the vectorised kinematics chain on one core: IK + J_C⁻¹ + condition number (Hexaglide).

Run from the repository root:  ``python benchmarks/bench_kinematics.py [--n 200000] [--chunk 8192]``

Poses are drawn uniformly in a box around the Hexaglide workspace centre (x ±0.4 m, y 0.3 ± 0.3 m,
z −1.0 ± 0.2 m, a, b, c ±15°), so ~15 % of them are unreachable, as in a workspace scan.  Every stage
is timed over all poses in chunks of ``--chunk`` poses (bounded memory); the best of ``--repeat``
runs is reported, as wall-clock and as CPU time of this process (on a shared machine the wall-clock
time includes waiting for the CPU).
"""

from __future__ import annotations

import os as _os
import sys as _sys

_sys.path.insert(0, _os.path.join(_os.path.dirname(_os.path.abspath(__file__)), ".."))  # run from a clone

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # single thread: must be set before numpy is imported
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from pkmstiff.kinematics.joint_angles import joint_angles  # noqa: E402
from pkmstiff.kinematics import (  # noqa: E402
    chunk_slices,
    condition_number,
    inverse_jacobian,
    inverse_kinematics,
    jacobian_and_condition,
    singular_mask,
)
from pkmstiff.machine.loader import load_machine  # noqa: E402


def sample_poses(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    poses = np.empty((n, 6))
    poses[:, :3] = np.array([0.0, 0.3, -1.0]) + rng.uniform(-1.0, 1.0, (n, 3)) * [0.4, 0.3, 0.2]
    poses[:, 3:] = rng.uniform(-1.0, 1.0, (n, 3)) * np.deg2rad(15.0)
    return poses


def run(machine, poses, chunk: int, stage: str) -> tuple[float, float]:
    """(wall, CPU) seconds of one pass over all poses."""
    t0, c0 = time.perf_counter(), time.process_time()
    for s in chunk_slices(poses.shape[0], chunk):
        ik = inverse_kinematics(machine, poses[s])
        if stage == "ik":
            continue
        jinv = inverse_jacobian(machine, ik)
        if stage == "ik+jinv+kappa":
            condition_number(jinv, chunk_size=chunk)
        elif stage == "ik+jinv+kappa(svd)":
            condition_number(jinv, chunk_size=chunk, method="svd")
        elif stage == "ik+jinv+J_C+kappa":
            jacobian_and_condition(jinv, chunk_size=chunk)
        elif stage == "ik+jinv+singular_mask":
            singular_mask(machine, jinv, chunk_size=chunk)
        elif stage == "ik+joint_angles":
            joint_angles(machine, ik)
    return time.perf_counter() - t0, time.process_time() - c0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200_000, help="number of poses (default 200000)")
    ap.add_argument("--chunk", type=int, default=4096, help="poses per chunk (default 4096)")
    ap.add_argument("--repeat", type=int, default=5, help="repetitions, best is reported (default 5)")
    ap.add_argument("--machine", default="hexaglide")
    args = ap.parse_args()

    machine = load_machine(args.machine)
    poses = sample_poses(args.n)
    ik = inverse_kinematics(machine, poses[:20000])
    print(f"machine {machine.name}: {args.n} poses, chunk {args.chunk}, "
          f"{ik.all_reachable.mean():.1%} reachable, single thread (OMP/OPENBLAS_NUM_THREADS=1)")
    print("  stage                      wall: poses/s   µs/pose |  CPU: poses/s   µs/pose")
    stages = ["ik", "ik+jinv", "ik+jinv+kappa", "ik+jinv+kappa(svd)", "ik+jinv+J_C+kappa", "ik+jinv+singular_mask",
              "ik+joint_angles"]
    for stage in stages:
        n = args.n if "svd" not in stage else min(args.n, 50_000)
        run(machine, poses[: min(n, args.chunk)], args.chunk, stage)  # warm-up
        times = [run(machine, poses[:n], args.chunk, stage) for _ in range(args.repeat)]
        wall, cpu = min(t[0] for t in times), min(t[1] for t in times)
        print(f"  {stage:24s} {n / wall:12,.0f} {wall * 1e6 / n:8.2f} | {n / cpu:12,.0f} {cpu * 1e6 / n:8.2f}")


if __name__ == "__main__":
    main()
