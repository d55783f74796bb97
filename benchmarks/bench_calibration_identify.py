"""Benchmark: identification of Felix's 42 error parameters (ball bar, rank 36) from 1,000 and 10,000 readings
(issue 17 targets: <= 1 s and <= 5 s on one core). Includes the identifiability analysis (base parameters,
gauge freedoms) and the uncertainty; errors up to 1.75 mm on the base parameters, 0.5 µm noise.

Run from the repository root: ``OMP_NUM_THREADS=1 python benchmarks/bench_calibration_identify.py``.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one core

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pkmstiff import load_machine
from pkmstiff.calibration import default_plan, error_model, hemisphere_plan, identifiability, simulate_readings
from pkmstiff.calibration.identification import identify
from pkmstiff.calibration.uncertainty import uncertainty

TARGETS = {1000: 1.0, 10000: 5.0}


def main() -> int:
    m = load_machine("felix")
    ref = default_plan(m, "ballbar")
    params = error_model(m, setup=ref.setup)
    ok = True
    for n, target in TARGETS.items():
        side = 1.0 if m.tool.axis[2] <= 0 else -1.0
        plan = hemisphere_plan(ref.setup, n=n, tilt=np.radians(20), torsion=np.radians(15), side=side,
                               name=f"hemisphere {n}")
        base = params.indices(identifiability(m, params, plan).base_parameters)  # this plan's base parameters
        d = np.zeros(params.n)
        d[base] = np.random.default_rng(0).uniform(-1.75e-3, 1.75e-3, base.size)
        y = simulate_readings(m, params, d, plan) + np.random.default_rng(1).normal(0, 5e-7, (n, 1))
        best = np.inf
        for _ in range(3):
            t0 = time.perf_counter()
            res = identify(m, params, plan, y, "lm")
            unc = uncertainty(res)
            best = min(best, time.perf_counter() - t0)
        err = np.max(np.abs(res.delta - d)[base] / unc.sigma)
        ok &= best <= target
        print(f"{params.n} parameters (rank {res.rank}) from {n} readings: {best:.3f} s (target {target:g} s), "
              f"largest error/sigma {err:.2f}, RMS {res.to_dict()['residual_after']['rms_um']:.3f} um")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
