"""How the heavy commands scale over workers (issue 25, item 4): wall time, speed-up and efficiency for 1, 2, …, N
workers side by side in one run, CPU time (this process and its workers), the per-worker start-up overhead and the
serial fraction s of an Amdahl fit T(n) = T(1) (s + (1 - s) / n) with the speed-up it predicts on 16 workers.

Besides the fit from wall times, each parallel run measures the serial fraction from CPU time: the CPU seconds of this
process (everything not in a worker: the first chunk, planning, sending, collecting, statistics, forks; not the work
it does while its workers run, such as a sweep's first task) over those of this process and its workers together. It does not depend on how loaded the machine is, so it
predicts the 16-worker speed-up even on a shared 2-core machine (``s_cpu`` and ``pred. 16 (cpu)`` in the table).

``--jobs 1`` against ``--jobs 2`` for every command with ``--jobs`` (section, workspace, rotation-map, report, sweep)
on work of about 5 s or more runs after the table (``--no-pairs`` skips it).

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
on a 16-core machine the default run takes about 3–4 minutes, --quick about a third of that. Runs without pyvista.
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


def _cpu() -> tuple[float, float]:
    """CPU seconds of this process and of its finished (reaped) children (the local workers)."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime, b.ru_utime + b.ru_stime


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


def run_once(argv: list[str]) -> dict[str, float]:
    """Wall s, CPU s (all), CPU s of this process (``parent_cpu_s``) and of the local workers (``workers_cpu_s``) of
    one command, its workers started and stopped inside the measurement."""
    parallel.shutdown()
    out, err = io.StringIO(), io.StringIO()
    (p0, w0), m0, t0 = _cpu(), parallel.meanwhile_cpu_seconds(), time.perf_counter()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = cli(argv)
    parallel.shutdown()  # reaps the workers: their CPU time is counted
    wall, (p1, w1), m1 = time.perf_counter() - t0, _cpu(), parallel.meanwhile_cpu_seconds()
    if rc not in (0,):
        raise SystemExit(f"bench_scaling: {' '.join(argv)} exited {rc}: {err.getvalue().strip()[-300:]}")
    lines = [x for x in (err.getvalue() + out.getvalue()).splitlines() if x.startswith("pkmstiff ")]
    PLANS[" ".join(argv)] = " | ".join(lines)
    return {"wall_s": wall, "cpu_s": p1 - p0 + w1 - w0, "parent_cpu_s": p1 - p0, "workers_cpu_s": w1 - w0,
            "parent_meanwhile_cpu_s": m1 - m0}


def cpu_serial_fraction(run: dict[str, float]) -> float:
    """Serial fraction from CPU time: this process's CPU, less what it spent on task work while its workers ran
    (a sweep's first task), over the whole CPU of a parallel run."""
    return (run["parent_cpu_s"] - run.get("parent_meanwhile_cpu_s", 0.0)) / max(run["cpu_s"], 1e-12)


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
    ap.add_argument("--no-pairs", action="store_true", help="skip --jobs 1 against --jobs 2 for every command")
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
        rows = {n: run_once([*argv, "--jobs", str(n)]) for n in counts}
        table[name] = _scaling(argv, rows)
    if a.dask:
        table.update(_dask_runs(work, max(counts)))
    print(f"\n{'work':<20}" + "".join(f"{f'{n} w: wall s (eff.)':>20}" for n in counts)
          + f"{'s (wall fit)':>13}{'pred. 16':>9}{'s_cpu':>8}{'pred. 16 (cpu)':>15}")
    for name, t in table.items():
        cells = "".join(f"{_cell(t['runs'].get(n)):>20}" for n in counts)
        print(f"{name:<20}{cells}{t['serial_fraction']:>13.3f}{t['predicted_speedup_16']:>8.1f}×"
              f"{_num(t.get('serial_fraction_cpu'), '.3f'):>8}{_num(t.get('predicted_speedup_16_cpu'), '.1f')+'×':>15}")
    print("CPU s, this process + local workers (Dask workers not counted): " + "; ".join(
        f"{name} " + ", ".join(f"{n} w {r['parent_cpu_s']:.2f}+{r['workers_cpu_s']:.1f}" for n, r in t["runs"].items())
        for name, t in table.items()))
    pairs = {} if a.no_pairs else jobs_pairs(a.quick, tmp, table)
    if pairs:
        print(f"\n--jobs 1 against --jobs 2 (work of about 5 s or more serially):\n{'command':<14}{'jobs 1 s':>10}"
              f"{'jobs 2 s':>10}{'ratio':>8}{'s_cpu':>8}  plan of --jobs 2")
        for name, r in pairs.items():
            print(f"{name:<14}{r['1']['wall_s']:>10.2f}{r['2']['wall_s']:>10.2f}{r['ratio']:>7.2f}×"
                  f"{cpu_serial_fraction(r['2']):>8.3f}  {r['plan'].split(' | ')[0].split('; ', 1)[-1][:110]}")
    info["load_average_end"] = os.getloadavg()
    print(f"load average at the end {info['load_average_end'][0]:.1f}")
    if a.json:
        Path(a.json).write_text(json.dumps({"machine": info, "startup_overhead_s_per_worker": startup,
                                            "work": table, "jobs_1_vs_2": pairs, "plans": PLANS}, indent=2,
                                           default=str))
        print(f"wrote {a.json}")


def _cell(r: dict | None) -> str:
    return "–" if r is None else f"{r['wall_s']:.2f} ({r['efficiency'] * 100:.0f} %)"


def _num(x: float | None, fmt: str) -> str:
    return "–" if x is None else format(x, fmt)


def _scaling(argv: list[str], rows: dict[int, dict[str, float]]) -> dict:
    """Speed-up, efficiency, the Amdahl fit of the wall times and the serial fraction from CPU time (the parallel run
    with the most workers that ran in parallel) of one workload's runs."""
    t1 = rows[1]["wall_s"]
    for n, r in rows.items():
        r["speedup"] = t1 / r["wall_s"]
        r["efficiency"] = r["speedup"] / n
    s, pred = amdahl(list(rows), [r["speedup"] for r in rows.values()])
    out = {"argv": argv, "runs": rows, "serial_fraction": s, "predicted_speedup_16": pred}
    par = [r for n, r in rows.items() if n > 1 and r["workers_cpu_s"] > 0]
    if par:
        s_cpu = cpu_serial_fraction(par[-1])
        out.update({"serial_fraction_cpu": s_cpu, "predicted_speedup_16_cpu": 1 / (s_cpu + (1 - s_cpu) / 16)})
    return out


def _report_spec(tmp: Path, quick: bool) -> Path:
    """The Hexaglide variants report with --fast at 10 mm sections and 12.5 mm workspaces (--quick: the spec's 25 mm),
    without the 3-D workspace figures (pyvista is not needed)."""
    text = (ROOT / "studies" / "specs" / "hexaglide_variants.toml").read_text().replace("figures = true",
                                                                                       "figures = false")
    if not quick:
        text = text.replace("fast_step_mm = 25", "fast_step_mm = 10").replace("fast_resolution_mm = 25",
                                                                            "fast_resolution_mm = 12.5")
    path = tmp / "report_spec.toml"
    path.write_text(text)
    return path


def pair_workloads(quick: bool, tmp: Path) -> dict[str, list[str]]:
    """Every command with --jobs on work of about 5 s or more serially on one core of the 16-core machine (--quick:
    less). Not --quiet: the cost line with the plan is kept."""
    return {
        "section": ["section", "hexaglide", "--plane", "yz", "--step", "1.25" if quick else "0.625"],
        "workspace": ["workspace", "hexaglide", "--resolution", "3.125" if quick else "2", "--memory-budget", "1TB"],
        "rotation-map": ["rotation-map", "hexaglide", "--plane", "yz", "--range", "y=-200:1100,z=-1250:-400",
                         "--step", "6.25" if quick else "3.125", "--increment", "1"],
        "report": ["report", str(_report_spec(tmp, quick)), "--fast", "--force", "--out", str(tmp / "report")],
        "sweep": ["sweep", str(_sweep_file(tmp, 10 if quick else 5)), "--force", "--out", str(tmp / "pair.csv")],
    }


def jobs_pairs(quick: bool, tmp: Path, table: dict) -> dict[str, dict]:
    """--jobs 1 and --jobs 2 of every command (a sweep-5 pair already in the table is reused)."""
    out = {}
    for name, argv in pair_workloads(quick, tmp).items():
        if name == "sweep" and "sweep-5" in table and 2 in table["sweep-5"]["runs"]:
            one, two = table["sweep-5"]["runs"][1], table["sweep-5"]["runs"][2]
            argv = table["sweep-5"]["argv"]
        else:
            try:
                one, two = run_once([*argv, "--jobs", "1"]), run_once([*argv, "--jobs", "2"])
            except (SystemExit, Exception) as exc:  # e.g. a library missing on this machine: say so, go on
                print(f"  {name}: skipped ({type(exc).__name__}: {str(exc)[-200:]})")
                continue
        out[name] = {"argv": argv, "1": one, "2": two, "ratio": one["wall_s"] / two["wall_s"],
                     "plan": PLANS.get(" ".join([*argv, "--jobs", "2"]), "")}
    return out


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
                t = _scaling(work[name], {1: serial, n: dask})
                t.pop("serial_fraction_cpu", None)  # the Dask workers' CPU is not counted here
                t["plan"] = PLANS.get(" ".join([*work[name], "--scheduler", cluster.scheduler_address]), "")
                out[f"{name}/dask-{state}"] = t
    return out


if __name__ == "__main__":
    main()
