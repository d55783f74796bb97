"""Estimate vs actual for every command with a cost line (issue 22, item 3): CPU time and peak memory.

Each case runs ``python -m pkmstiff.cli ...`` in a child process; the estimate is read from the cost line the command
prints on stderr ("about 293.1 MB and 4.8 s"), the actual CPU time (user + system) and peak resident memory from
``os.wait4`` of that child. The cost model (:mod:`pkmstiff.evaluation.cost`) estimates CPU seconds of one process,
so the ratio is taken against CPU time (wall time is printed too: on a shared machine it also holds the waiting).
Both ratios estimate / actual must lie within 0.5..2 (exit status 1 otherwise).

    python benchmarks/bench_estimates.py            # small and medium runs (~2 min CPU)
    python benchmarks/bench_estimates.py --large    # also the full Hexaglide report (3.125 mm workspace)
    python benchmarks/bench_estimates.py -k section # only cases whose name contains 'section'

Measured 2026-11-26 on the shared 2-core machine (load average 7.5..10: wall times 3..8x the CPU times; the workspace
and report rows again at load average 0.8..0.9 after the octree's time per evaluation was measured anew,
``cost.OCTREE_SECONDS`` 6 -> 3 us):

    case                           est s   CPU s t ratio   est MB   RSS MB m ratio
    section kappa 5 mm               1.2     1.4    0.84      265      228    1.16
    section kx,f1 2.5 mm             4.9     4.1    1.21      283      266    1.06
    section kx 5 mm + files          2.6     2.9    0.91      265      306    0.87   (files written faster, 9th stop)
    workspace 25 mm                  1.1     1.5    0.73      270      189    1.43
    workspace 6.25 mm                2.1     3.1    0.67      364      287    1.27
    workspace felix 12.5 mm          2.9     2.7    1.08      437      307    1.43
    workspace 25 mm + figure         2.8     3.9    0.71      610      602    1.01
    rotation-map pc 1 deg            1.3     1.5    0.88      260      221    1.18
    rotation-map pc 0.1 deg          2.8     2.2    1.29      260      221    1.17
    rotation-map plain 0.1 deg       2.8     2.0    1.40      260      237    1.10
    report --fast                    7.7     7.4    1.04      610      639    0.96
    fe-joint 3 angles                8.5     8.8    0.96      815      763    1.07
    fe-platform                     11.0    10.8    1.02     1229     1470    0.84
    point --poses 40k                3.8     3.8    1.01      373      385    0.97
    ballbar 200k rows                2.6     2.1    1.21      310      296    1.05
    sweep example                    2.3     2.5    0.93      260      251    1.04
    mechanism 10k steps              9.0    11.1    0.81      220      204    1.08
    workspace 3.125 mm (--large)     5.3     5.6    0.95      674      371    1.82
    report full (--large)           20.0    19.8    1.01     1014     1159    0.87
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_COST = re.compile(r"about ([\d.]+) (B|kB|MB|GB|TB) and ([\d.]+) (s|min|h)")
_BYTES = {"B": 1, "kB": 1 << 10, "MB": 1 << 20, "GB": 1 << 30, "TB": 1 << 40}
_SECONDS = {"s": 1, "min": 60, "h": 3600}


def _inputs(tmp: Path) -> None:
    """Input files of the file-driven cases (a pose batch, a ball-bar file of 25 revolutions)."""
    import numpy as np

    sys.path.insert(0, str(ROOT))
    rng = np.random.default_rng(0)
    poses = tmp / "poses.csv"
    y, z = rng.uniform(0, 700, 40_000), rng.uniform(-1200, -700, 40_000)
    poses.write_text("x_mm,y_mm,z_mm,a_deg,b_deg,c_deg\n" + "".join(f"0,{a:.3f},{b:.3f},0,0,0\n" for a, b in zip(y, z)))
    from pkmstiff.calibration.measurement_file import write_measurement
    from tests.ballbar_synth import SyntheticRun, circle_run, measurement_from_runs

    runs = [circle_run(n=4000, noise=0.5e-6, resolution=0.1e-6, seed=100 + i) for i in range(50)]
    run = SyntheticRun(*(np.concatenate([getattr(r, k) for r in runs])
                         for k in ("theta", "positions", "actual", "reading", "true_deviation")))
    write_measurement(tmp / "bb.csv", measurement_from_runs({"ccw": run}))


def cases(large: bool) -> list[tuple[str, list[str]]]:
    """(name, arguments after ``pkmstiff``); {out}, {poses}, {ballbar} are filled in by :func:`_inputs`."""
    c = [
        ("section kappa 5 mm", ["section", "hexaglide", "--step", "5", "--quantities", "kappa"]),
        ("section kx,f1 2.5 mm", ["section", "hexaglide", "--step", "2.5", "--quantities", "kx,f1"]),
        ("section kx 5 mm + files", ["section", "hexaglide", "--step", "5", "--quantities", "kx", "--out",
                                     "{out}/sec", "--force"]),
        ("workspace 25 mm", ["workspace", "hexaglide", "--resolution", "25"]),
        ("workspace 6.25 mm", ["workspace", "hexaglide", "--resolution", "6.25"]),
        ("workspace felix 12.5 mm", ["workspace", "felix", "--resolution", "12.5"]),
        ("workspace 25 mm + figure", ["workspace", "hexaglide", "--resolution", "25", "--out", "{out}/ws",
                                      "--force"]),
        ("rotation-map pc 1 deg", ["rotation-map", "hexaglide", "--range", "y=-200:800,z=-1200:-500",
                                   "--step", "50"]),
        ("rotation-map pc 0.1 deg", ["rotation-map", "hexaglide", "--range", "y=-200:800,z=-1200:-500",
                                     "--step", "50", "--increment", "0.1"]),
        ("rotation-map plain 0.1 deg", ["rotation-map", "hexaglide", "--range", "y=-200:800,z=-1200:-500",
                                        "--step", "50", "--increment", "0.1", "--method", "plain"]),
        ("report --fast", ["report", "studies/specs/hexaglide_variants.toml", "--out", "{out}/rep", "--force",
                           "--fast"]),
        ("fe-joint 3 angles", ["fe-joint", "iwf_3dof_improved", "--angles", "0:90:45", "--out", "{out}/j.csv",
                               "--force"]),
        ("fe-platform", ["fe-platform", "hexaglide_platform", "--out", "{out}/p.csv", "--force"]),
        ("point --poses 40k", ["point", "hexaglide", "--poses", "{poses}", "--out", "{out}/pt.csv", "--force"]),
        ("ballbar 200k rows", ["ballbar", "analyse", "{ballbar}"]),
        ("sweep example", ["sweep", "studies/sweeps/hexaglide_strut_sweep.toml", "--out", "{out}/sw.csv", "--force"]),
        ("mechanism 10k steps", ["mechanism", "solve", "slider_crank", "--drives", "20", "--steps", "10000"]),
    ]
    if large:
        c += [("workspace 3.125 mm", ["workspace", "hexaglide", "--resolution", "3.125"]),
              ("report full", ["report", "studies/specs/hexaglide_variants.toml", "--out", "{out}/rep2", "--force"])]
    return c


def run_case(argv: list[str]) -> dict[str, float]:
    """Run one command; its estimate (cost line), CPU time, wall time and peak RSS."""
    with tempfile.TemporaryFile("w+") as err:
        t0 = time.perf_counter()
        p = subprocess.Popen([sys.executable, "-m", "pkmstiff.cli", *argv], cwd=ROOT, stdout=subprocess.DEVNULL,
                             stderr=err, env={**os.environ, "PYTHONPATH": str(ROOT)})
        _, status, ru = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
        err.seek(0)
        text = err.read()
    m = _COST.search(text)
    if status or m is None:
        raise RuntimeError(f"pkmstiff {' '.join(argv)}: status {status}, no cost line in stderr:\n{text[-2000:]}")
    return {"est_s": float(m.group(3)) * _SECONDS[m.group(4)], "est_b": float(m.group(1)) * _BYTES[m.group(2)],
            "cpu_s": ru.ru_utime + ru.ru_stime, "wall_s": wall, "rss_b": ru.ru_maxrss * 1024.0}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--large", action="store_true", help="also the 3.125 mm workspace and the full report")
    ap.add_argument("-k", default="", help="only cases whose name contains this text")
    ap.add_argument("--make-inputs", metavar="DIR", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.make_inputs:
        _inputs(Path(args.make_inputs))
        return 0
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        # the inputs are made in a child: a child forked from a parent holding numpy and the data would report the
        # parent's resident pages as its own peak RSS
        subprocess.run([sys.executable, __file__, "--make-inputs", tmp], check=True, cwd=ROOT)
        files = {"poses": f"{tmp}/poses.csv", "ballbar": f"{tmp}/bb.csv", "out": f"{tmp}/out"}
        print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; ratios = estimate / actual "
              f"(CPU time of the process; peak RSS)")
        print(f"{'case':<28} {'est s':>7} {'CPU s':>7} {'wall s':>7} {'t ratio':>7} {'est MB':>8} {'RSS MB':>8} "
              f"{'m ratio':>7}")
        for name, argv in cases(args.large):
            if args.k not in name:
                continue
            r = run_case([a.format(**files) for a in argv])
            rt, rm = r["est_s"] / r["cpu_s"], r["est_b"] / r["rss_b"]
            ok = 0.5 <= rt <= 2 and 0.5 <= rm <= 2
            bad += not ok
            print(f"{name:<28} {r['est_s']:7.1f} {r['cpu_s']:7.1f} {r['wall_s']:7.1f} {rt:7.2f} "
                  f"{r['est_b'] / 2**20:8.0f} {r['rss_b'] / 2**20:8.0f} {rm:7.2f}{'' if ok else '  OUTSIDE 0.5..2'}",
                  flush=True)
        print(f"load average {os.getloadavg()[0]:.1f} at the end")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
