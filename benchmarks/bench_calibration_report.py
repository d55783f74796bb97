"""Benchmark: ``pkmstiff calibrate report`` on the walkthrough's Felix data (docs/user-guide/calibration-walkthrough.md):
2,000 simulated ball-bar readings (hemisphere + circle, example errors up to 1.75 mm, QC10 noise) and a validation
file of two circles. Prints the CPU time (best of 3, one core) of the computation (identification, uncertainty,
identifiability, validation) and of the report (figures + HTML/Markdown). No target in the issue; the figure is quoted
in the walkthrough.

Run from the repository root: ``OMP_NUM_THREADS=1 python benchmarks/bench_calibration_report.py``.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one core

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pkmstiff import load_machine  # noqa: E402
from pkmstiff.cli import main as cli  # noqa: E402
from pkmstiff.calibration.workflow import run_calibration  # noqa: E402
from pkmstiff.report.calibration import write_calibration_report  # noqa: E402


def main() -> int:
    with tempfile.TemporaryDirectory() as d:
        dd = Path(d)
        for plan, out, seed in (("felix_plan", "felix.csv", 1), ("felix_validation", "val.csv", 2)):
            assert cli(["calibrate", "simulate", "felix", "--plan", f"example:{plan}.toml", "--errors",
                        "example:felix_errors.toml", "--seed", str(seed), "--feed", "2000", "--sample-rate", "5",
                        "--out", str(dd / out)]) == 0
        m = load_machine("felix")
        best_c = best_r = float("inf")
        for k in range(3):
            t0 = time.process_time()
            run = run_calibration(m, str(dd / "felix.csv"), plan_path="example:felix_plan.toml",
                                  validate=[str(dd / "val.csv")])
            t1 = time.process_time()
            paths = write_calibration_report(run, dd / f"rep{k}")
            t2 = time.process_time()
            best_c, best_r = min(best_c, t1 - t0), min(best_r, t2 - t1)
        print(f"calibrate report, Felix, {run.res.n_readings} readings + {run.validations[0].before.size} validation "
              f"readings: computation {best_c:.2f} s CPU, report and {len(paths['figures'])} figures "
              f"{best_r:.2f} s CPU (best of 3)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
