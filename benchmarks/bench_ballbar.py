"""Fourier evaluation of a ball-bar run (issue 16 target: 10,000 samples ≤ 10 ms).

Run from the repository root:  ``python benchmarks/bench_ballbar.py [--n 10000] [--repeat 50]``

A synthetic 150 mm circle (centre offset, ellipse, 3- and 4-lobe form, QC10-level noise 0.5 µm, 0.1 µm quantisation)
is evaluated by (a) the Fourier stage alone — harmonics by FFT (Szatmári §4.5.2), automatic choice of n (region-B
rule), filtered reconstruction at all samples — on uniform samples and on jittered samples (sorting + periodic
interpolation), and (b) the full circular-test evaluation (plane, deviations, LSQ circle fit, G/F, harmonics). The
best of ``--repeat`` runs is reported (wall clock, one thread).
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

from pkmstiff.calibration.ballbar import (choose_harmonics, evaluate_circular_test, fourier_harmonics,  # noqa: E402
                                          reconstruct)

TARGET_MS = 10.0


def synthetic(n: int, jitter: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    R = 0.15
    th = 2 * np.pi / n * (np.arange(n) + rng.uniform(-jitter, jitter, n))
    radial = 3e-6 + 5e-6 * np.cos(2 * th) + 2e-6 * np.cos(3 * th - 0.5) + 1.2e-6 * np.cos(4 * th - 2.0)
    u = np.column_stack([np.cos(th), np.sin(th), np.zeros(n)])
    actual = (R + radial)[:, None] * u + np.array([15e-6, 9e-6, 0.0])
    reading = np.linalg.norm(actual, axis=1) - R + rng.normal(0, 0.5e-6, n)
    reading = np.round(reading / 1e-7) * 1e-7
    return th, R * u, reading


def best_ms(fn, repeat: int) -> float:
    fn()  # warm-up
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best * 1e3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10_000, help="samples per run (default 10000)")
    ap.add_argument("--repeat", type=int, default=50, help="timed repetitions, best reported (default 50)")
    args = ap.parse_args()
    for label, jitter in (("uniform samples", 0.0), ("jittered samples", 0.4)):
        th, P, reading = synthetic(args.n, jitter)

        def fourier() -> int:
            h = fourier_harmonics(th, reading)
            c = choose_harmonics(h)
            reconstruct(h, th, c.n)
            return c.n

        n_chosen = fourier()
        ms = best_ms(fourier, args.repeat)
        verdict = "OK" if ms <= TARGET_MS else "TOO SLOW"
        print(f"Fourier evaluation, {args.n} {label}: {ms:.2f} ms (target <= {TARGET_MS:g} ms: {verdict}); "
              f"n = {n_chosen} harmonics chosen")
        ms_full = best_ms(lambda: evaluate_circular_test(P, reading, (0, 0, 0), 0.15), max(args.repeat // 5, 3))
        print(f"full circular-test evaluation (fit, G/F, harmonics), {args.n} {label}: {ms_full:.2f} ms")


if __name__ == "__main__":
    main()
