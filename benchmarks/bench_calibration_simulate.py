"""Benchmark: 10,000 simulated ball-bar samples (Felix, 150 mm circle, 42 machine errors + set-up errors, noise,
quantisation, backlash and thermal drift) — target ≤ 1 s on one core.

Threads are pinned to one before numpy is imported. Run from the repository root:
``python benchmarks/bench_calibration_simulate.py``.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

import pkmstiff
from pkmstiff.calibration import Setup, circle_plan, error_model
from pkmstiff.calibration.instruments import BallbarDevice
from pkmstiff.calibration.simulation import SimulationOptions, sample_plan, simulate

TARGET_S = 1.0
N = 10_000


def main() -> None:
    m = pkmstiff.load_machine("felix")
    setup = Setup("ballbar", target=m.tool.tip(), fixed_ball=np.zeros(3), bar_length=0.15)
    plan = circle_plan(setup, n=72)
    params = error_model(m, setup=setup, setup_blocks=("ball_offset", "bar_offset"))
    delta = np.random.default_rng(0).normal(size=params.n) * 2e-5
    circumference = 72 * 2 * 0.15 * np.sin(np.pi / 72)  # the 72-gon the samples follow
    # one ccw run with exactly N samples at 250 samples/s
    opts = SimulationOptions(feed=circumference * 250.0 / N, directions=("ccw",), backlash=4e-6, drift_dT=0.5,
                             seed=1)
    inst = BallbarDevice()
    simulate(m, params, delta, plan, inst, opts)  # warm-up (numba kernels, imports)
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        res = simulate(m, params, delta, plan, inst, opts)
        best = min(best, time.perf_counter() - t0)
    n = len(res.readings)
    print(f"simulate {n} ball-bar samples (Felix, 42 + 4 errors, noise, quantisation, backlash, drift): "
          f"{best:.3f} s (target <= {TARGET_S:g} s) {'OK' if best <= TARGET_S else 'SLOW'}")
    smp_t = min(_time(lambda: sample_plan(plan, inst, opts)) for _ in range(3))
    print(f"  of which sampling the plan: {smp_t:.3f} s")


def _time(f) -> float:
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
