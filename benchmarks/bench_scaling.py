"""How the heavy commands scale over workers (issue 25, item 4): wall time, speed-up and efficiency for 1, 2, …, N
workers side by side in one run, CPU time (this process and its workers), the per-worker start-up overhead and the
serial fraction s of an Amdahl fit T(n) = T(1) (s + (1 - s) / n) with the speed-up it predicts on 16 workers.

Work (the commands themselves, run in this process through ``pkmstiff.cli.main``; the pool is stopped after each
run so every run pays its workers' start-up):
  section   ``section hexaglide --plane yz --step 1.25`` (window fitted to the workspace; --quick: 2.5 mm)
  sweep-5   the 12-task ``studies/sweeps/hexaglide_strut_sweep.toml`` with 5 mm sections (--quick: 10 mm)
  sweep-25  the same file as it is (25 mm sections)
  workspace ``workspace hexaglide --resolution 3.125`` (--quick: 6.25 mm)
``--dask`` adds sweep-25 and section on a local Dask cluster of N workers (started before the clock runs), once with
cold and once with warm workers.

Usage (from a clone, nothing installed): ``python benchmarks/bench_scaling.py [--max-workers N] [--workers 1,2,4]
[--quick] [--only section,sweep-25] [--dask] [--json out.json]``. Default workers 1, 2, 4, … up to N = os.cpu_count();
on a 16-core machine the default run takes about 5–8 minutes, --quick about a third of that.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pkmstiff.cli import main as cli  # noqa: E402
from pkmstiff.evaluation import parallel  # noqa: E402

SWEEP = ROOT / "studies" / "sweeps" / "hexaglide_strut_sweep.toml"


def _cpu() -> float:
    """CPU seconds of this process and of its finished (reaped) children."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def _sweep_file(tmp: Path, step_mm: float) -> Path:
    text = SWEEP.read_text().replace("step_mm = 25", f"step_mm = {step_mm:g}")
    path = tmp / f"sweep_{step_mm:g}.toml"
    path.write_text(text)
    return path


def workloads(quick: bool, tmp: Path) -> dict[str, list[str]]:
    return {
        "section": ["section", "hexaglide", "--plane", "yz", "--step", "2.5" if quick else "1.25"],
        "sweep-5": ["sweep", str(_sweep_file(tmp, 10 if quick else 5)), "--force", "--out",
                    str(tmp / "s5.csv")],
        "sweep-25": ["sweep", str(SWEEP), "--force", "--out", str(tmp / "s25.csv")],
        # the workspace's cost line bounds memory from above (the whole lattice); the octree needs far less
        "workspace": ["workspace", "hexaglide", "--resolution", "6.25" if quick else "3.125",
                      "--memory-budget", "1TB"],
    }


PLANS: dict[str, str] = {}  # command line -> the plan it printed (cost line or the sweep's last line)


def run_once(argv: list[str]) -> tuple[float, float]:
    """(wall s, CPU s) of one command, its workers started and stopped inside the measurement."""
    parallel.shutdown()
    out, err = io.StringIO(), io.StringIO()
    c0, t0 = _cpu(), time.perf_counter()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = cli(argv)
    parallel.shutdown()  # reaps the workers: their CPU time is counted
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    if rc not in (0,):
        raise SystemExit(f"bench_scaling: {' '.join(argv)} exited {rc}: {err.getvalue().strip()[-300:]}")
    lines = [x for x in (err.getvalue() + out.getvalue()).splitlines() if x.startswith("pkmstiff ")]
    PLANS[" ".join(argv)] = lines[-1] if lines else ""
    return wall, cpu


def startup_overhead(n: int, repeats: int = 3) -> float:
    """Seconds per worker to start a pool of ``n`` workers and have each answer (best of ``repeats``)."""
    best = float("inf")
    for _ in range(repeats):
        parallel.shutdown()
        t0 = time.perf_counter()
        parallel.start_workers(n)
        best = min(best, (time.perf_counter() - t0) / n)
    parallel.shutdown()
    return best


def amdahl(workers: list[int], speedups: list[float]) -> tuple[float, float]:
    """Least-squares serial fraction s of 1/S(n) = s (1 - 1/n) + 1/n and the speed-up it predicts on 16 workers."""
    num = sum((1 / sp - 1 / n) * (1 - 1 / n) for n, sp in zip(workers, speedups) if n > 1)
    den = sum((1 - 1 / n) ** 2 for n in workers if n > 1)
    s = min(max(num / den, 0.0), 1.0) if den else float("nan")
    return s, 1 / (s + (1 - s) / 16)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--max-workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--workers", default=None, help="comma-separated worker counts (default 1, 2, 4, … max)")
    ap.add_argument("--quick", action="store_true", help="coarser section/sweep/workspace (about a third the time)")
    ap.add_argument("--only", default=None, help="comma-separated workloads (section, sweep-5, sweep-25, workspace)")
    ap.add_argument("--dask", action="store_true", help="also sweep-25 and section on a local Dask cluster")
    ap.add_argument("--json", default=None, help="write the table also as JSON to this path")
    a = ap.parse_args()
    counts = ([int(x) for x in a.workers.split(",")] if a.workers else
              sorted({min(2 ** k, a.max_workers) for k in range(a.max_workers.bit_length() + 1)}))
    if 1 not in counts:
        counts = [1, *counts]
    tmp = Path(tempfile.mkdtemp(prefix="bench_scaling_"))
    work = workloads(a.quick, tmp)
    if a.only:
        work = {k: v for k, v in work.items() if k in a.only.split(",")}
    load0 = os.getloadavg()
    info = {"cpu_count": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version(),
            "quick": a.quick, "workers": counts, "load_average_start": load0}
    print(f"bench_scaling: {os.cpu_count()} cores, load average {load0[0]:.1f} {load0[1]:.1f} {load0[2]:.1f}, "
          f"workers {counts}{', quick' if a.quick else ''}")
    run_once(["section", "hexaglide", "--plane", "yz", "--step", "50", "--quiet"])  # compiled kernels loaded once
    startup = {n: startup_overhead(n) for n in sorted({1, 2, max(counts)})}
    print("per-worker start-up overhead: " + ", ".join(f"{n} workers {s * 1e3:.0f} ms" for n, s in startup.items()))
    table: dict[str, dict] = {}
    for name, argv in work.items():
        rows = {}
        for n in counts:
            wall, cpu = run_once([*argv, "--jobs", str(n)])
            rows[n] = {"wall_s": wall, "cpu_s": cpu}
        t1 = rows[1]["wall_s"]
        for n, r in rows.items():
            r["speedup"] = t1 / r["wall_s"]
            r["efficiency"] = r["speedup"] / n
        s, pred = amdahl(list(rows), [r["speedup"] for r in rows.values()])
        table[name] = {"argv": argv, "runs": rows, "serial_fraction": s, "predicted_speedup_16": pred}
    if a.dask:
        table.update(_dask_runs(work, max(counts)))
    print(f"\n{'work':<12}" + "".join(f"{f'{n} w: wall s (eff.)':>22}" for n in counts)
          + f"{'serial frac.':>14}{'pred. 16 w':>12}")
    for name, t in table.items():
        cells = "".join(f"{_cell(t['runs'].get(n)):>22}" for n in counts)
        print(f"{name:<12}{cells}{t['serial_fraction']:>14.3f}{t['predicted_speedup_16']:>11.1f}×")
    print("CPU s (this process + local workers; Dask workers not counted): " + "; ".join(
        f"{name} " + ", ".join(f"{n} w {r['cpu_s']:.1f}" for n, r in t["runs"].items()) for name, t in table.items()))
    info["load_average_end"] = os.getloadavg()
    print(f"load average at the end {info['load_average_end'][0]:.1f}")
    if a.json:
        Path(a.json).write_text(json.dumps({"machine": info, "startup_overhead_s_per_worker": startup,
                                            "work": table, "plans": PLANS}, indent=2, default=str))
        print(f"wrote {a.json}")


def _cell(r: dict | None) -> str:
    return "–" if r is None else f"{r['wall_s']:.2f} ({r['efficiency'] * 100:.0f} %)"


def _dask_runs(work: dict[str, list[str]], n: int) -> dict[str, dict]:
    """sweep-25 and section with ``--scheduler`` on a fresh local cluster of ``n`` single-threaded workers against
    serial: the first run finds the workers cold (small work then stays local while they warm up), the second warm."""
    from distributed import LocalCluster

    out = {}
    with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        for name in ("sweep-25", "section"):
            if name not in work:
                continue
            serial = run_once([*work[name], "--jobs", "1"])
            for state in ("cold", "warm"):
                dask = run_once([*work[name], "--scheduler", cluster.scheduler_address])
                r = {1: {"wall_s": serial[0], "cpu_s": serial[1], "speedup": 1.0, "efficiency": 1.0},
                     n: {"wall_s": dask[0], "cpu_s": dask[1], "speedup": serial[0] / dask[0],
                         "efficiency": serial[0] / dask[0] / n}}
                s, pred = amdahl([1, n], [1.0, serial[0] / dask[0]])
                out[f"{name}/dask-{state}"] = {"argv": work[name], "runs": r, "serial_fraction": s,
                                               "predicted_speedup_16": pred}
    return out


if __name__ == "__main__":
    main()
