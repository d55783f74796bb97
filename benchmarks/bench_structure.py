"""Benchmark of the PKM structure model on the Hexaglide (single-threaded).

Timed per pose: inverse kinematics + singularity check + joint angles + component stiffnesses (joint splines,
struts, drives, guides) + assembly of the 30-DOF model + TCP compliance + 6 lowest natural frequencies
(:func:`pkmstiff.analysis.evaluate_structure`).  Poses: random inside the Hexaglide workspace (x ±0.2 m,
y 0…0.4 m, z −1.0…−0.85 m, a, b, c ±3°).  Prints CPU-time and wall-time poses/s (on a machine shared with other
jobs the CPU time is the fairer figure) and, for the large batch, the peak resident memory of a fresh process.

Usage: ``python benchmarks/bench_structure.py [n_poses ...] [--chunk N] [--million] [--floor N]``
(default 10000 100000; ``--million`` runs a 1,000,000-pose batch in a subprocess and reports its peak RSS).

``--floor N`` (default 20000) times, side by side in one run, the batch structure analysis of N poses
(stiffness + 6 lowest frequencies) and the numpy floor of the same linear algebra: a stacked (N, 24, 24) ``solve``
with 6 right-hand sides and a stacked ``eigvalsh`` of (N, 24, 24) matrices; it prints their ratio (target ≤ 1.15).
"""

from __future__ import annotations

import os

os.environ["OMP_NUM_THREADS"] = "1"
os.environ["OPENBLAS_NUM_THREADS"] = "1"
os.environ["MKL_NUM_THREADS"] = "1"

import argparse  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from pkmstiff.analysis import evaluate_structure  # noqa: E402
from pkmstiff.machine.loader import load_machine  # noqa: E402


def hexaglide_poses(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo = [-0.2, 0.0, -1.0, -np.radians(3), -np.radians(3), -np.radians(3)]
    hi = [0.2, 0.4, -0.85, np.radians(3), np.radians(3), np.radians(3)]
    return rng.uniform(lo, hi, size=(n, 6))


def run(n_poses: int, chunk: int) -> None:
    machine = load_machine("hexaglide")
    poses = hexaglide_poses(n_poses)
    evaluate_structure(machine, poses[:chunk])  # warm-up (imports, caches, compiled kernels)
    t0, c0 = time.perf_counter(), time.process_time()
    res = evaluate_structure(machine, poses, tool_length=0.0, n_modes=6, chunk_size=chunk)
    t1, c1 = time.perf_counter(), time.process_time()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    ok = res.ok.mean()
    print(f"{n_poses:>9d} poses  chunk {chunk:>5d}  IK+components+assembly+TCP compliance+6 modes: "
          f"CPU {c1 - c0:7.2f} s = {n_poses / (c1 - c0):8.0f} poses/s   wall {t1 - t0:7.2f} s = "
          f"{n_poses / (t1 - t0):8.0f} poses/s   modelled {100 * ok:5.1f} %   max RSS {rss:7.1f} MiB   "
          f"median k_x {np.nanmedian(res.stiffness[:, 0]) / 1e6:6.2f} N/um, "
          f"f1 {np.nanmedian(res.frequencies_hz[:, 0]):6.2f} Hz")


def floor_ratio(n_poses: int, chunk: int, repeat: int = 5) -> float:
    """Best-of-``repeat`` CPU time of :func:`evaluate_structure` over the numpy floor (stacked 24×24 solve + eigvalsh),
    both on ``n_poses`` and measured alternately in the same process."""
    machine = load_machine("hexaglide")
    poses = hexaglide_poses(n_poses)
    rng = np.random.default_rng(1)
    a = rng.standard_normal((n_poses, 24, 24))
    spd = a @ np.swapaxes(a, 1, 2) + 24 * np.eye(24)
    rhs = rng.standard_normal((n_poses, 24, 6))
    evaluate_structure(machine, poses[:chunk])  # warm-up incl. the compiled kernels (numba cache)
    t_model, t_floor = float("inf"), float("inf")
    for _ in range(repeat):
        c0 = time.process_time()
        evaluate_structure(machine, poses, tool_length=0.0, n_modes=6, chunk_size=chunk)
        t_model = min(t_model, time.process_time() - c0)
        c0 = time.process_time()
        for s in range(0, n_poses, chunk):
            np.linalg.solve(spd[s:s + chunk], rhs[s:s + chunk])
            np.linalg.eigvalsh(spd[s:s + chunk])
        t_floor = min(t_floor, time.process_time() - c0)
    ratio = t_model / t_floor
    print(f"{n_poses:>9d} poses: structure analysis CPU {t_model:6.2f} s, numpy floor (24x24 solve + eigvalsh) "
          f"{t_floor:6.2f} s, batch/floor ratio {ratio:5.2f} (target 1.15)")
    return ratio


def million(chunk: int) -> None:
    """1e6 poses in a fresh interpreter so that its peak RSS is the batch's own footprint."""
    code = ("import sys; sys.argv = ['bench', '1000000', '--chunk', '%d']; "
            "import runpy; runpy.run_path(%r, run_name='__main__')" % (chunk, os.path.abspath(__file__)))
    subprocess.run([sys.executable, "-c", code], check=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("poses", nargs="*", type=int, default=[10_000, 100_000])
    ap.add_argument("--chunk", type=int, default=2048)
    ap.add_argument("--million", action="store_true", help="also run 1,000,000 poses in a subprocess (peak RSS)")
    ap.add_argument("--floor", type=int, default=20_000, metavar="N",
                    help="poses of the batch/floor comparison (0: skip; default 20000)")
    args = ap.parse_args()
    for n in args.poses:
        run(n, args.chunk)
    if args.floor:
        floor_ratio(args.floor, args.chunk)
    if args.million:
        million(args.chunk)


if __name__ == "__main__":
    main()
