"""Throughput of the component models for large pose batches.

Run: ``python benchmarks/bench_components.py [N]`` (default N = 1 000 000 poses). Prints the best of three
wall-clock times per model and the resulting poses per second.
"""

from __future__ import annotations

import os as _os
import sys as _sys

_sys.path.insert(0, _os.path.join(_os.path.dirname(_os.path.abspath(__file__)), ".."))  # run from a clone

import sys
import time
from typing import Callable

import numpy as np

from components import ComponentState, series
from components.guides import drive_frame, drive_frame_stiffness, local_drive_stiffness
from components.registry import build_component


def best_of(fn: Callable[[], object], repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(n: int) -> None:
    rng = np.random.default_rng(0)
    state = ComponentState(tilt=rng.uniform(0, np.pi / 2, n), swivel=rng.uniform(0, np.pi / 2, n),
                           strut_length=rng.uniform(1.28, 2.57, n), drive_position=rng.uniform(0, 1, n))
    src = "bench"
    cases = {
        "joint_table (1-D spline)": build_component("j", {"model": "joint_table",
                                                          "table": "hexaglide_3dof_improved_measured"}, source=src),
        "joint_table_swivel_tilt (7x7 grid)": build_component("g", {
            "model": "joint_table_swivel_tilt", "swivel": {"value": list(range(0, 91, 15)), "unit": "deg"},
            "tilt": {"value": list(range(0, 91, 15)), "unit": "deg"},
            "stiffness": {"value": (100 + rng.uniform(0, 50, (7, 7))).tolist(), "unit": "N/um"}}, source=src),
        "joint_analytic_3_30": build_component("a", {"model": "joint_analytic_3_30", "k_AaL": "600 N/um",
                                                     "k_BrL": "500 N/um", "k_CrL": "500 N/um", "k_CaL": "600 N/um"},
                                               source=src),
        "telescopic_ballscrew_6x (fit)": build_component("t", {"model": "telescopic_ballscrew_6x"}, source=src),
        "telescopic_ballscrew_6x (exact)": build_component("t", {"model": "telescopic_ballscrew_6x",
                                                                 "drive_model": "exact_3_3"}, source=src),
        "ballscrew_fixed_fixed": build_component("b", {"model": "ballscrew_fixed_fixed", "k_aL": "650 N/um",
                                                       "k_M": "210 N/um", "spindle_EA": "211 N*m/um",
                                                       "spindle_length": "1 m"}, source=src),
    }
    print(f"N = {n} poses")
    for label, comp in cases.items():
        t = best_of(lambda c=comp: c.stiffness(state))
        print(f"{label:40s} {t * 1e3:9.1f} ms  {n / t / 1e6:7.2f} M poses/s")
    K = local_drive_stiffness(rng.uniform(1e7, 1e8, n), 4.52e9, 6.8e9)
    R = drive_frame(rng.normal(size=(n, 3)))
    t = best_of(lambda: drive_frame_stiffness(K, R))
    print(f"{'drive_frame_stiffness (N,3,3)':40s} {t * 1e3:9.1f} ms  {n / t / 1e6:7.2f} M poses/s")
    t = best_of(lambda: series(K, K))
    print(f"{'series of two (N,3,3) matrices':40s} {t * 1e3:9.1f} ms  {n / t / 1e6:7.2f} M poses/s")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000)
