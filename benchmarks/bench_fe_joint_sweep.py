"""Benchmark (issue "Finite-element component models"): full 7-angle FE joint sweep at the default mesh.

Target: <= 60 s on one core, peak memory < 4 GB.
Run: ``python benchmarks/bench_fe_joint_sweep.py [PARAMS.toml ...] [--angles 0:90:15] [--check]``
(default: all four shipped IWF joints, ``pkmstiff/fe/params/iwf_*.toml``).

The sweep includes meshing, assembly of all part matrices, and per angle the ties, the constraint
transformation, the sparse LU factorisation and the Guyan condensation. Times are CPU times of this process
(``time.process_time``; BLAS and OpenMP limited to one thread, process pinned to one CPU), which on a shared
machine are not inflated by waiting for the CPU; wall-clock time is printed as well. Peak memory is the
process's maximum resident set size (``ru_maxrss``), i.e. including SuperLU's factor. ``--check`` exits
with status 1 if a sweep exceeds 60 s CPU or the peak memory exceeds 4 GB.
"""

import os
import sys as _sys

_sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))  # run from a clone

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core: must be set before numpy is imported
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import resource  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from pkmstiff.fe.joints import load_joint_parameters, parse_angles, sweep  # noqa: E402

PARAMS = Path(__file__).resolve().parents[1] / "pkmstiff" / "fe" / "params"
TARGET_S, TARGET_BYTES = 60.0, 4 * 1024**3


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("params", nargs="*", help="joint parameter files (default: all iwf_*.toml)")
    ap.add_argument("--angles", default="0:90:15", help="tilt angles in deg (default 0:90:15 = 7 angles)")
    ap.add_argument("--check", action="store_true", help="exit 1 if a target is missed")
    args = ap.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    files = [Path(p) for p in args.params] or sorted(PARAMS.glob("iwf_*.toml"))
    angles = parse_angles(args.angles)
    print(f"FE joint sweep, {len(angles)} angles, one core; load average {os.getloadavg()[0]:.1f}")
    ok = True
    for f in files:
        p = load_joint_parameters(f)
        c0, w0 = time.process_time(), time.perf_counter()
        res = sweep(p, angles)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: kB
        ok &= cpu <= TARGET_S and peak < TARGET_BYTES
        k = ", ".join(f"{v:.1f}" for v in res.k_N_per_um)
        print(f"{p.name:20s} {res.n_dofs:6d} DOFs  mesh {p.mesh_size * 1e3:g} mm  CPU {cpu:6.1f} s  "
              f"wall {wall:6.1f} s  peak RSS {peak / 1024**3:.2f} GB  k = [{k}] N/um")
    print(f"target: <= {TARGET_S:g} s per sweep on one core, < 4 GB: {'met' if ok else 'MISSED'}")
    return 0 if ok or not args.check else 1


if __name__ == "__main__":
    sys.exit(main())
