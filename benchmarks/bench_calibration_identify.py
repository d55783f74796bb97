"""Benchmark: identification of Felix's 42 error parameters (ball bar, rank 36) from 1,000 and 10,000 readings
(issue 17 targets: <= 1 s and <= 5 s on one core). Includes the identifiability analysis (base parameters,
gauge freedoms) and the uncertainty; errors up to 1.75 mm on the base parameters, 0.5 µm noise. Then (no target)
the gravity deflection of the readings and the deflection-aware identification on the Hexaglide (issue 17 item 4).

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
    deflection()
    return 0 if ok else 1


def deflection() -> None:
    """Deflection-aware calibration (issue 17 item 4, no target): the gravity deflection's reading change Δr
    (structure-model solve per pose) and the identification with Δr subtracted, on the Hexaglide (Felix has no
    stiffness data). CPU time (process_time), best of 3."""
    from pkmstiff.calibration.deflection import identify_with_deflection, reading_deflection

    m = load_machine("hexaglide")
    ref = default_plan(m, "ballbar")
    params = error_model(m, setup=ref.setup)
    for n in (1000, 10000):
        plan = hemisphere_plan(ref.setup, n=n, tilt=np.radians(5), torsion=np.radians(5), side=1.0,
                               name=f"hemisphere {n}")
        best = np.inf
        for _ in range(3):
            t0 = time.process_time()
            dr = reading_deflection(m, plan)
            best = min(best, time.process_time() - t0)
        print(f"hexaglide gravity deflection of {n} ball-bar readings: {best:.3f} s CPU "
              f"(RMS {np.sqrt(np.mean(dr ** 2)) * 1e6:.1f} um)")
        if n == 1000:
            base = params.indices(identifiability(m, params, plan).base_parameters)
            d = np.zeros(params.n)
            d[base] = np.random.default_rng(0).uniform(-2e-4, 2e-4, base.size)
            y = simulate_readings(m, params, d, plan) + reading_deflection(m, plan, params, d)[:, None]
            t0 = time.process_time()
            res, _ = identify_with_deflection(m, params, plan, y)
            print(f"  identification with the deflection subtracted ({res.rank} base parameters, re-evaluated at "
                  f"the estimate): {time.process_time() - t0:.2f} s CPU, error {np.max(np.abs(res.delta - d)):.1e} m")


if __name__ == "__main__":
    raise SystemExit(main())
