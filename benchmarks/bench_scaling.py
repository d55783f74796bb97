"""How the heavy commands scale over workers (issue 25, item 4): wall time, speed-up and efficiency for 1, 2, …, N
workers side by side in one run, CPU time (this process and its workers), the per-worker start-up overhead and the
serial fraction s of an Amdahl fit T(n) = T(1) (s + (1 - s) / n) with the speed-up it predicts on 16 workers.

Comparable runs: every command is first run once untimed (``--jobs 1``, the same arguments), then timed. The first run
of a command in a process pays one-off costs that a later run does not: the numba kernels it uses are compiled (a
fresh checkout has no on-disk cache: about 10 s of CPU in the first 5 mm sweep for kernels that the small section run
first had not needed, such as the small-N pose kernel of its point evaluation) or loaded from the cache; the modules
it imports (a sweep builds machines from their files: scipy.spatial for the hull, the component splines, ≈ 0.7 s);
caches inside the process. Timed without the untimed run, whichever run came first paid them (a 25 mm sweep measured
1.73 s on 1 worker and 0.51 s on 2, 169 % efficiency; a 5 mm sweep 28.1 s of CPU serially against 12.2 s on 16
workers). The local workers are forked from this process after it, so they inherit the imports and loaded kernels
exactly as the serial run uses them. ``--repeat R`` runs each ``--jobs 1`` / ``--jobs 2`` pair (and each warm Dask run
with a serial one) R times, alternating, and keeps the fastest of each (on a shared machine other load only slows a run
down).

Besides the fit from wall times, each parallel run measures the serial fraction from CPU time: the CPU seconds of this
process (everything not in a worker: planning, sending, collecting, statistics, forks; not the work it does while its
workers run, such as a section's first chunk) over those of this process and its workers together. It does not
depend on how loaded the machine is, so it predicts the 16-worker speed-up even on a shared 2-core machine (``s_cpu``
and ``pred. 16 (cpu)`` in the table). For the pairs the CPU accounting also predicts the ``--jobs 2`` ratio on two
free cores (``pred. (cpu)``): T1 = CPU of the serial run, T2 = the serial CPU of this process + the larger of the
busiest worker's CPU and half of the parallel CPU (workers and the work here meanwhile).

A core check (at the start, after each pair's command and at the end) times the same compiled work pinned to each
core in turn: on a shared host one core can run 1.0-1.5× slower than the other from one second to the next (a busy
sibling elsewhere), which bounds what two workers can give, while a serial run may have had the faster core.

``--jobs 1`` against ``--jobs 2`` for every command with ``--jobs`` (section, workspace, rotation-map, report, sweep,
optimise) on work of 5 s or more serially on the 2-core machine runs after the table (``--no-pairs`` skips it); the
sizes are options (``--section-step``, ``--workspace-resolution``, ``--rotation-map-step``, ``--report-step``,
``--report-resolution``, ``--report-figures``, ``--sweep-step``, ``--optimise-budget``). ``--write`` lets the
section, workspace and rotation-map pairs write their files too (``--out``), as a user's run does: the files are
then part of the timed work.

Work (the commands themselves, run in this process through ``pkmstiff.cli.main``; the pool is stopped after each
run so every run pays its workers' start-up):
  section   ``section hexaglide --plane yz --step 1.25`` (window fitted to the workspace; --quick: 2.5 mm)
  sweep-5   the 12-task ``studies/sweeps/hexaglide_strut_sweep.toml`` with 5 mm sections (--quick: 10 mm)
  sweep-25  the same file as it is (25 mm sections)
  workspace ``workspace hexaglide --resolution 3.125`` (--quick: 6.25 mm)
``--dask`` adds sweep-25 and section on a local Dask cluster of N workers (started before the clock runs), once with
cold and once with warm workers.

Usage (from a clone, nothing installed): ``python benchmarks/bench_scaling.py [--max-workers N] [--workers 1,2,4]
[--quick] [--only section,sweep-25] [--no-table] [--pairs sweep,section] [--repeat R] [--dask] [--json out.json]``.
Default workers 1, 2, 4, … up to N = os.cpu_count(). Runs without pyvista (unless ``--report-figures``).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import platform
import re
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


def _sweep_argv(tmp: Path, step_mm: float) -> list[str]:
    """The 12-task sweep with ``step_mm`` sections (the same arguments in the table and the pairs: warmed once)."""
    path = SWEEP if step_mm == 25 else _sweep_file(tmp, step_mm)
    return ["sweep", str(path), "--force", "--out", str(tmp / f"sweep_{step_mm:g}.csv")]


def workloads(quick: bool, tmp: Path) -> dict[str, list[str]]:
    return {
        "section": ["section", "hexaglide", "--plane", "yz", "--step", "2.5" if quick else "1.25"],
        "sweep-5": _sweep_argv(tmp, 10 if quick else 5),
        "sweep-25": _sweep_argv(tmp, 25),
        # the workspace's cost line bounds memory from above (the whole lattice); the octree needs far less
        "workspace": ["workspace", "hexaglide", "--resolution", "6.25" if quick else "3.125",
                      "--memory-budget", "1TB"],
    }


PLANS: dict[str, str] = {}  # command line -> the plan it printed (cost line or the sweep's last line)
WARM: set[str] = set()  # commands (arguments without --jobs) already run once in this process


def _worker_cpu(pids: list[int]) -> list[float]:
    """CPU seconds (user + system) of each running local worker, from /proc (empty where there is no /proc)."""
    out = []
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        out.append((int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK"))  # utime, stime
    return out


#: the core check's work: the admissibility of this many random Hexaglide poses (fused kernel), pinned to each core
CORE_CHECK_POSES = 8192
CORE_CHECKS: list[dict] = []


def core_check(when: str, rounds: int = 5) -> dict | None:
    """Time the same compiled work pinned to each core in turn (median of ``rounds``) and print how much slower the
    slowest core is: on a shared host a core whose sibling is busy elsewhere runs slower for seconds at a time (the
    2-core machine: 1.0-1.5× apart from one second to the next), and a ``--jobs 2`` run then gets less than two
    cores' work while a serial run may have had the faster one. Linux only (None elsewhere)."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    import numpy as np

    from pkmstiff.admissibility import checks, fastpath
    from pkmstiff.admissibility.pipeline import admissible
    from pkmstiff.machine.loader import load_machine
    from pkmstiff.machine.roles import drive_load_data

    m = load_machine("hexaglide")
    if not fastpath.usable(m, 1):
        return None
    rng = np.random.default_rng(0)
    x = np.c_[rng.uniform([-0.1, 0.0, -1.1], [0.1, 0.8, -0.7], (CORE_CHECK_POSES, 3)), np.zeros((CORE_CHECK_POSES, 3))]
    load, mask = drive_load_data(m), os.sched_getaffinity(0)
    cores = sorted(mask)
    times: dict[int, list[float]] = {c: [] for c in cores}
    try:
        for _ in range(rounds):
            for c in cores:
                os.sched_setaffinity(0, {c})
                t0 = time.perf_counter()
                admissible(m, x, checks.ALL_CHECKS, load)
                times[c].append(time.perf_counter() - t0)
    finally:
        os.sched_setaffinity(0, mask)
    med = {c: sorted(v)[len(v) // 2] for c, v in times.items()}
    out = {"when": when, "median_s": med, "slowest_over_fastest": max(med.values()) / min(med.values())}
    CORE_CHECKS.append(out)
    print(f"core check ({when}): " + ", ".join(f"cpu{c} {t * 1e3:.0f} ms" for c, t in med.items())
          + f" for the same work; the slowest core takes {out['slowest_over_fastest']:.2f}× the fastest's time")
    return out


def warm_up(argv: list[str]) -> None:
    """Run ``argv`` once with ``--jobs 1``, untimed, unless it ran already: the one-off costs of its first run in this
    process (kernels compiled or loaded, imports, in-process caches) are then paid before any timed run."""
    key = " ".join(argv)
    if key not in WARM:
        run_once([*argv, "--jobs", "1"])
        WARM.add(key)


def run_once(argv: list[str]) -> dict[str, float]:
    """Wall s, CPU s (all), CPU s of this process (``parent_cpu_s``), of the local workers (``workers_cpu_s``) and of
    the busiest worker (``worker_max_cpu_s``) of one command, its workers started and stopped inside the
    measurement."""
    parallel.shutdown()
    out, err = io.StringIO(), io.StringIO()
    (p0, w0), m0, t0 = _cpu(), parallel.meanwhile_cpu_seconds(), time.perf_counter()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = cli(argv)
    each = _worker_cpu(parallel.worker_pids())  # before they stop: they are idle now
    parallel.shutdown()  # reaps the workers: their CPU time is counted
    wall, (p1, w1), m1 = time.perf_counter() - t0, _cpu(), parallel.meanwhile_cpu_seconds()
    if rc not in (0,):
        raise SystemExit(f"bench_scaling: {' '.join(argv)} exited {rc}: {err.getvalue().strip()[-300:]}")
    lines = [x for x in (err.getvalue() + out.getvalue()).splitlines() if x.startswith("pkmstiff ")]
    PLANS[" ".join(argv)] = " | ".join(lines)
    return {"wall_s": wall, "cpu_s": p1 - p0 + w1 - w0, "parent_cpu_s": p1 - p0, "workers_cpu_s": w1 - w0,
            "parent_meanwhile_cpu_s": m1 - m0, "worker_max_cpu_s": max(each, default=0.0), "workers": len(each)}


def cpu_serial_fraction(run: dict[str, float]) -> float:
    """Serial fraction from CPU time: this process's CPU, less what it spent on task work while its workers ran
    (a section's first chunk), over the whole CPU of a parallel run."""
    return (run["parent_cpu_s"] - run.get("parent_meanwhile_cpu_s", 0.0)) / max(run["cpu_s"], 1e-12)


def cpu_predicted_wall(run: dict[str, float]) -> float:
    """The wall time a parallel run's CPU accounting predicts on as many free cores as it had workers: this process's
    serial CPU, then the parallel phase, which lasts as long as the busiest worker or the parallel CPU (workers and
    the work here meanwhile) spread over the workers, whichever is longer."""
    meanwhile = run.get("parent_meanwhile_cpu_s", 0.0)
    n = max(int(run.get("workers", 0)), 1)
    return run["parent_cpu_s"] - meanwhile + max(run.get("worker_max_cpu_s", 0.0),
                                                 (run["workers_cpu_s"] + meanwhile) / n)


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


def hardware_ceiling(argv: list[str], n: int) -> dict[str, float]:
    """The speed-up the machine's cores allow on ``n`` workers, whatever the program: ``n`` copies of the serial run
    (``--jobs 1``) forked at once, each timing itself; ceiling = n × (one copy alone) / (mean copy among n). Below n
    where the copies slow each other down (shared caches and memory bandwidth, cores that are hyper-threads, a lower
    clock when all cores are busy): a parallel run's CPU grows the same way, which Amdahl's fit counts as serial
    work. Linux (fork) only: {} elsewhere."""
    if not hasattr(os, "fork"):
        return {}
    warm_up(argv)
    alone = min(run_once([*argv, "--jobs", "1"])["wall_s"] for _ in range(2))
    reader, writer = os.pipe()
    pids = []
    for _ in range(n):
        pid = os.fork()
        if pid == 0:  # a copy: one serial run, its wall time to the pipe
            code = 1
            try:
                os.close(reader)
                wall = run_once([*argv, "--jobs", "1"])["wall_s"]
                os.write(writer, f"{wall!r}\n".encode())
                code = 0
            finally:
                os._exit(code)
        pids.append(pid)
    os.close(writer)
    with os.fdopen(reader) as f:
        walls = [float(x) for x in f.read().split()]
    for pid in pids:
        os.waitpid(pid, 0)
    if len(walls) != n:
        raise SystemExit(f"bench_scaling: {len(walls)} of {n} simultaneous copies of {' '.join(argv)} finished")
    mean = sum(walls) / n
    return {"workers": n, "alone_s": alone, "copy_mean_s": mean, "copy_max_s": max(walls),
            "ceiling": n * alone / mean}


def amdahl(workers: list[int], speedups: list[float]) -> tuple[float, float]:
    """Least-squares serial fraction s of 1/S(n) = s (1 - 1/n) + 1/n and the speed-up it predicts on 16 workers."""
    num = sum((1 / sp - 1 / n) * (1 - 1 / n) for n, sp in zip(workers, speedups) if n > 1)
    den = sum((1 - 1 / n) ** 2 for n in workers if n > 1)
    s = min(max(num / den, 0.0), 1.0) if den else float("nan")
    return s, 1 / (s + (1 - s) / 16)


#: sizes of the pairs' work (full, --quick): each takes 5 s or more serially on the shared 2-core machine when idle
PAIR_SIZES: dict[str, tuple[float, float]] = {
    "section_step": (0.625, 1.25),  # mm
    "workspace_resolution": (2, 3.125),  # mm
    "rotation_map_step": (1.5625, 6.25),  # mm (2 mm: 4.2 s of CPU serially since the fused-kernel search, too little)
    "report_step": (5, 25),  # mm, the sections of the report with --fast
    "report_resolution": (6.25, 25),  # mm, its workspaces (with 5 mm sections ≈ 7 s of CPU serially)
    "sweep_step": (5, 10),  # mm, the sections of the 12-task sweep
    "optimise_budget": (96, 36),  # evaluations
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--max-workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--workers", default=None, help="comma-separated worker counts (default 1, 2, 4, … max)")
    ap.add_argument("--quick", action="store_true", help="coarser work throughout (about a third the time)")
    ap.add_argument("--only", default=None, help="comma-separated workloads (section, sweep-5, sweep-25, workspace)")
    ap.add_argument("--no-table", action="store_true", help="skip the table over 1, 2, … N workers")
    ap.add_argument("--dask", action="store_true", help="also sweep-25 and section on a local Dask cluster")
    ap.add_argument("--json", default=None, help="write the table also as JSON to this path")
    ap.add_argument("--no-pairs", action="store_true", help="skip --jobs 1 against --jobs 2 for every command")
    ap.add_argument("--pairs", default=None, help="comma-separated pairs (section, workspace, rotation-map, report, "
                                                  "sweep, optimise; default all)")
    ap.add_argument("--repeat", type=int, default=1, help="timed runs of each pair's --jobs 1 and --jobs 2, "
                                                          "alternating; the fastest of each counts (default 1)")
    for key, (full, quick) in PAIR_SIZES.items():
        ap.add_argument("--" + key.replace("_", "-"), type=float, default=None,
                        help=f"pair size (default {full:g}, --quick {quick:g})")
    ap.add_argument("--ceiling", default="section", help="comma-separated table workloads whose hardware ceiling "
                                                         "(n simultaneous serial copies) is measured on the most "
                                                         "workers (default section; 'none' for none)")
    ap.add_argument("--write", action="store_true", help="the section, workspace and rotation-map pairs also write "
                                                          "their files (--out), as a user's run does")
    ap.add_argument("--report-figures", action="store_true", help="the report pair with the 3-D workspace figures "
                                                                  "(needs pyvista)")
    a = ap.parse_args()
    sizes = {k: getattr(a, k) if getattr(a, k) is not None else (quick if a.quick else full)
             for k, (full, quick) in PAIR_SIZES.items()}
    counts = ([int(x) for x in a.workers.split(",")] if a.workers else
              sorted({min(2 ** k, a.max_workers) for k in range(a.max_workers.bit_length() + 1)}))
    if 1 not in counts:
        counts = [1, *counts]
    tmp = Path(tempfile.mkdtemp(prefix="bench_scaling_"))
    work = {} if a.no_table else workloads(a.quick, tmp)
    if a.only:
        work = {k: v for k, v in work.items() if k in a.only.split(",")}
    load0 = os.getloadavg()
    info = {"cpu_count": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version(),
            "quick": a.quick, "workers": counts, "load_average_start": load0, "pair_sizes": sizes,
            "repeat": a.repeat, "write": a.write, "method": "each command run once untimed (--jobs 1) before its timed runs"}
    print(f"bench_scaling: {os.cpu_count()} cores, load average {load0[0]:.1f} {load0[1]:.1f} {load0[2]:.1f}, "
          f"workers {counts}{', quick' if a.quick else ''}; every command runs once untimed before it is timed")
    run_once(["section", "hexaglide", "--plane", "yz", "--step", "50", "--quiet"])  # compiled kernels loaded once
    core_check("start")
    startup = {n: startup_overhead(n) for n in sorted({1, 2, max(counts)})}
    print("per-worker start-up overhead: " + ", ".join(f"{n} workers {s * 1e3:.0f} ms" for n, s in startup.items()))
    table: dict[str, dict] = {}
    for name, argv in work.items():
        warm_up(argv)
        rows = {n: run_once([*argv, "--jobs", str(n)]) for n in counts}
        table[name] = _scaling(argv, rows)
    ceilings = {name: hardware_ceiling(work[name], max(counts)) for name in (a.ceiling or "").split(",")
                if name in work and max(counts) > 1}
    for name, c in ceilings.items():
        if c:
            t = table[name]
            t["hardware_ceiling"] = c
            t["efficiency_of_ceiling"] = t["runs"][max(counts)]["speedup"] / c["ceiling"]
    if a.dask:
        table.update(_dask_runs(work, max(counts), a.repeat))
    if table:
        print(f"\n{'work':<20}" + "".join(f"{f'{n} w: wall s (eff.)':>20}" for n in counts)
              + f"{'s (wall fit)':>13}{'pred. 16':>9}{'s_cpu':>8}{'pred. 16 (cpu)':>15}")
    for name, t in table.items():
        cells = "".join(f"{_cell(t['runs'].get(n)):>20}" for n in counts)
        print(f"{name:<20}{cells}{t['serial_fraction']:>13.3f}{t['predicted_speedup_16']:>8.1f}×"
              f"{_num(t.get('serial_fraction_cpu'), '.3f'):>8}{_num(t.get('predicted_speedup_16_cpu'), '.1f')+'×':>15}")
    if table:
        print("CPU s, this process + local workers (Dask workers not counted): " + "; ".join(
            f"{name} " + ", ".join(f"{n} w {r['parent_cpu_s']:.2f}+{r['workers_cpu_s']:.1f}"
                                   for n, r in t["runs"].items()) for name, t in table.items()))
    for name, t in table.items():
        c = t.get("hardware_ceiling")
        if c:
            n = c["workers"]
            print(f"hardware ceiling, {name}: {n} serial copies at once take {c['copy_mean_s']:.2f} s each (max "
                  f"{c['copy_max_s']:.2f}) against {c['alone_s']:.2f} s alone: the cores deliver {c['ceiling']:.1f}× "
                  f"of {n}; the {n}-worker run's {t['runs'][n]['speedup']:.1f}× is "
                  f"{t['efficiency_of_ceiling'] * 100:.0f} % of that")
    chosen = a.pairs.split(",") if a.pairs else None
    pairs = {} if a.no_pairs else jobs_pairs(pair_workloads(sizes, a.report_figures, tmp, chosen, a.write), a.repeat)
    if pairs:
        print(f"\n--jobs 1 against --jobs 2 (work of 5 s or more serially; best of {a.repeat}):\n{'command':<14}"
              f"{'jobs 1 s':>10}{'jobs 2 s':>10}{'ratio':>8}{'median':>8}{'CPU 1 s':>9}{'CPU 2 s':>16}{'s_cpu':>7}"
              f"{'pred. (cpu)':>12}  plan of --jobs 2")
        for name, r in pairs.items():
            one, two = r["1"], r["2"]
            cpu2 = f"{two['parent_cpu_s']:.2f}+{two['workers_cpu_s']:.2f}"
            print(f"{name:<14}{one['wall_s']:>10.2f}{two['wall_s']:>10.2f}{r['ratio']:>7.2f}×{r['median_ratio']:>7.2f}×"
                  f"{one['cpu_s']:>9.2f}{cpu2:>16}{cpu_serial_fraction(two):>7.3f}{r['predicted_ratio_cpu']:>11.2f}×  "
                  f"{_plan_of(r['plan'])[:90]}")
        print("ratio: of the fastest runs; median: of the median runs; CPU 2 s: this process + its workers; "
              "pred. (cpu): the ratio the CPU accounting predicts on 2 free cores")
    core_check("end")
    info["load_average_end"] = os.getloadavg()
    print(f"load average at the end {info['load_average_end'][0]:.1f}")
    if a.json:
        Path(a.json).write_text(json.dumps({"machine": info, "startup_overhead_s_per_worker": startup,
                                            "work": table, "jobs_1_vs_2": pairs, "core_checks": CORE_CHECKS,
                                            "plans": PLANS}, indent=2,
                                           default=str))
        print(f"wrote {a.json}")


def _plan_of(lines: str) -> str:
    """The plan in a command's printed lines: the part that names the local workers, else the cost line's end."""
    m = re.search(r"\d+ local workers, [^;]*?\(≈ [^)]*\)", lines)
    return m.group(0) if m else lines.split(" | ")[0].split("; ", 1)[-1]


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


def _report_spec(tmp: Path, step_mm: float, resolution_mm: float, figures: bool) -> Path:
    """The Hexaglide variants report for --fast with ``step_mm`` sections and ``resolution_mm`` workspaces, with or
    without the 3-D workspace figures (without: pyvista is not needed)."""
    text = (ROOT / "studies" / "specs" / "hexaglide_variants.toml").read_text()
    text = text.replace("fast_step_mm = 25", f"fast_step_mm = {step_mm:g}").replace(
        "fast_resolution_mm = 25", f"fast_resolution_mm = {resolution_mm:g}")
    if not figures:
        text = text.replace("figures = true", "figures = false")
    path = tmp / "report_spec.toml"
    path.write_text(text)
    return path


def pair_workloads(sizes: dict[str, float], figures: bool, tmp: Path,
                   chosen: list[str] | None = None, write: bool = False) -> dict[str, list[str]]:
    """Every command with --jobs on work of ``sizes`` (:data:`PAIR_SIZES`). Not --quiet (but optimise): the cost line
    with the plan is kept. ``write``: the section, workspace and rotation map also write their files (``--out``),
    as a user's run does; the report, sweep and optimise always do."""
    out = {
        "section": ["section", "hexaglide", "--plane", "yz", "--step", f"{sizes['section_step']:g}"],
        "workspace": ["workspace", "hexaglide", "--resolution", f"{sizes['workspace_resolution']:g}",
                      "--memory-budget", "1TB"],
        "rotation-map": ["rotation-map", "hexaglide", "--plane", "yz", "--range", "y=-200:1100,z=-1250:-400",
                         "--step", f"{sizes['rotation_map_step']:g}", "--increment", "1"],
        "report": ["report", str(_report_spec(tmp, sizes["report_step"], sizes["report_resolution"], figures)),
                   "--fast", "--force", "--out", str(tmp / "report")],
        "sweep": _sweep_argv(tmp, sizes["sweep_step"]),
        # the workload of benchmarks/bench_optimise.py; its progress lines (one per generation) left out
        "optimise": ["optimise", "hexaglide_joint_orientation", "--out", str(tmp / "optimise"), "--budget",
                     f"{int(sizes['optimise_budget'])}", "--force", "--quiet", "--no-report"],
    }
    if write:
        for name in ("section", "workspace", "rotation-map"):
            out[name] += ["--out", str(tmp / f"{name}-files"), "--force"]
    return {k: v for k, v in out.items() if chosen is None or k in chosen}


def jobs_pairs(work: dict[str, list[str]], repeat: int = 1) -> dict[str, dict]:
    """--jobs 1 and --jobs 2 of every command, after one untimed run (:func:`warm_up`), ``repeat`` times alternating;
    the fastest run of each counts (``ratio``; ``median_ratio``: of the median runs, the lower median for an even
    ``repeat``). A core check (:func:`core_check`) follows each command."""
    out = {}
    for name, argv in work.items():
        try:
            warm_up(argv)
            runs: dict[int, list[dict[str, float]]] = {1: [], 2: []}
            for _ in range(repeat):
                for jobs in (1, 2):
                    runs[jobs].append(run_once([*argv, "--jobs", str(jobs)]))
        except (SystemExit, Exception) as exc:  # e.g. a library missing on this machine: say so, go on
            print(f"  {name}: skipped ({type(exc).__name__}: {str(exc)[-200:]})")
            continue
        one, two = (min(runs[jobs], key=lambda r: r["wall_s"]) for jobs in (1, 2))
        median = [sorted(r["wall_s"] for r in runs[jobs])[(repeat - 1) // 2] for jobs in (1, 2)]
        core_check(f"after {name}")
        out[name] = {"argv": argv, "1": one, "2": two, "ratio": one["wall_s"] / two["wall_s"],
                     "median_ratio": median[0] / median[1],
                     "predicted_ratio_cpu": one["cpu_s"] / max(cpu_predicted_wall(two), 1e-12),
                     "plan": PLANS.get(" ".join([*argv, "--jobs", "2"]), ""), "runs": runs}
    return out


def _wait_until_warm(address: str, n: int) -> None:
    """Warm the ``n`` workers of the cluster (import pkmstiff, load the kernels: what the cold run started in the
    background, if it connected at all) and wait for it, as a user's next run some time later finds them."""
    parallel.client(address).run(parallel.warm_up)
    # a worker whose background warm-up task (started by the cold run) the scheduler still lists as running is not
    # asked, so not counted warm (pkmstiff.evaluation.parallel._dask_workers): wait until the scheduler has heard
    warm, deadline = 0, time.perf_counter() + 30.0
    while time.perf_counter() < deadline:
        warm = len(parallel._dask_workers(address)[1])
        if warm == n:
            return
        time.sleep(0.1)
    raise SystemExit(f"bench_scaling: {warm} of the {n} Dask workers at {address} are warm 30 s after warming them")


def _dask_runs(work: dict[str, list[str]], n: int, repeat: int = 1) -> dict[str, dict]:
    """sweep-25 and section with ``--scheduler`` on a fresh local cluster of ``n`` single-threaded workers against
    serial: the first run finds the workers cold (small work then stays local while they warm up); once they are warm,
    ``repeat`` warm runs alternating with as many serial ones (the fastest of each counts, as for the pairs)."""
    from distributed import LocalCluster

    out = {}
    with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        for name in ("sweep-25", "section"):
            if name not in work:
                continue
            warm_up(work[name])
            on_dask = [*work[name], "--scheduler", cluster.scheduler_address]
            serial = [run_once([*work[name], "--jobs", "1"])]
            key = " ".join(on_dask)
            cold = (run_once(on_dask), PLANS.get(key, ""))  # each run's plan: PLANS keeps only the last
            _wait_until_warm(cluster.scheduler_address, n)  # as for a user's next run some seconds later
            warm = []
            for _ in range(repeat):
                warm.append((run_once(on_dask), PLANS.get(key, "")))
                serial.append(run_once([*work[name], "--jobs", "1"]))
            best = min(serial, key=lambda r: r["wall_s"])
            for state, (dask, plan) in (("cold", cold), ("warm", min(warm, key=lambda r: r[0]["wall_s"]))):
                t = _scaling(work[name], {1: best, n: dask})
                t.pop("serial_fraction_cpu", None)  # the Dask workers' CPU is not counted here
                t["plan"] = plan
                out[f"{name}/dask-{state}"] = t
        parallel.shutdown()  # the client closed before its cluster (else it tries to reconnect, and says so)
    return out


if __name__ == "__main__":
    main()
