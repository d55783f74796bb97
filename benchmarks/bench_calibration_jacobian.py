"""Benchmark: identification Jacobian for 1,000 poses × 42 parameters (Felix, ball bar) — target ≤ 20 ms on one core.

Threads are pinned to one before numpy is imported (OMP/OpenBLAS/MKL environment variables, and threadpoolctl if
installed). Run from the repository root: ``python benchmarks/bench_calibration_jacobian.py``.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

try:
    from threadpoolctl import threadpool_limits
except ImportError:  # the environment variables above already pin BLAS to one thread
    threadpool_limits = None

import pkmstiff
from pkmstiff.calibration import Setup, error_model, hemisphere_plan, identification_jacobian

TARGET_MS = 20.0


def main() -> float:
    m = pkmstiff.load_machine("felix")
    setup = Setup("ballbar", target=np.zeros(3), fixed_ball=np.zeros(3), bar_length=0.3)
    plan = hemisphere_plan(setup, n=1000)
    params = error_model(m)
    assert params.n == 42
    identification_jacobian(m, params, plan)  # warm-up (imports, caches)
    times = []
    for _ in range(30):
        t0 = time.perf_counter()
        jac = identification_jacobian(m, params, plan)
        times.append(time.perf_counter() - t0)
    best, med = 1e3 * min(times), 1e3 * float(np.median(times))
    print(f"identification Jacobian {jac.J.shape[0]} readings x {jac.J.shape[1]} parameters (1,000 poses, ball bar, "
          f"Felix): median {med:.2f} ms, best {best:.2f} ms (target <= {TARGET_MS:g} ms, one core)")
    return med


if __name__ == "__main__":
    if threadpool_limits is not None:
        with threadpool_limits(limits=1):
            main()
    else:
        main()
