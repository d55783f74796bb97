"""Parallel ``pkmstiff optimise`` (issues 24, 25): one run with ``--jobs 1`` and ``--jobs 2``, side by side, for the
whole command and for the optimisation itself.

Work: the bundled ``hexaglide_joint_orientation`` example (six drive-joint angles, mean k_x and admissible area of the
YZ section, CMA-ES with 12 candidates per generation, searched on its 25 mm raster and the best 10 re-evaluated on 10
mm, the base design and the dissertation's orientation as references) with a budget of 96 evaluations (8
generations), run through ``pkmstiff.cli.main`` in this process, with the comparison report (``--no-report``: without).
Before any timed run, one run of each job count warms the imports and compiled kernels (so neither pays one-off
costs in the timed runs). The runs then alternate (1, 2, 1, 2, ...) ``--repeat`` times each and the fastest of each is
compared: on a shared machine the other load only slows a run down. The worker pool is stopped after each run, so
every parallel run pays its workers' start-up and their CPU time is counted (``RUSAGE_CHILDREN`` once reaped).

Two wall times per run: the whole command (start-up checks, the search, the re-evaluation on the requested raster,
base and references, CSV files, figures, the comparison report, summary) and the optimisation itself (the time the
command prints: the search and the re-evaluation), whose ratio is the engine's parallel efficiency.

CPU accounting (independent of other load on the machine, which stretches wall times): the CPU seconds of this
process and of its workers, and a *predicted* wall time on an idle machine with ``--cores`` cores: a thread samples
every process's CPU time every 0.1 s, and each interval counts ``max(sum / cores, largest)`` — the time that work
needs on idle cores, where a single busy process (a serial part) counts in full. The predicted ratio is
``prediction(jobs 1) / prediction(jobs 2)`` for the fastest runs.

Usage (from a clone, nothing installed): ``python benchmarks/bench_optimise.py [--budget 96] [--repeat 2]
[--no-report]``. Target (issue 25): whole command wall(jobs 1) / wall(jobs 2) >= 1.8 on an idle 2-core machine.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import multiprocessing
import os
import resource
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pkmstiff.cli import main as cli  # noqa: E402
from pkmstiff.evaluation import parallel  # noqa: E402

TARGET = 1.8


class CpuSampler(threading.Thread):
    """Samples the CPU time of this process (less this thread's own) and of its child processes every ``period``
    seconds (``/proc/<pid>/task/<tid>/schedstat``: nanoseconds, so that a process that ran a few milliseconds of an
    interval on a loaded machine still counts as busy in it); :attr:`predicted` is the wall time the sampled work
    needs on ``cores`` idle cores (s)."""

    def __init__(self, cores: int, period: float = 0.1) -> None:
        super().__init__(daemon=True)
        self.cores, self.period, self.predicted = cores, period, 0.0
        self._done = threading.Event()

    @staticmethod
    def _cpu(pid: int, skip: int = -1) -> float:
        total = 0
        for task in Path(f"/proc/{pid}/task").iterdir():
            if int(task.name) != skip:
                with contextlib.suppress(OSError):
                    total += int((task / "schedstat").read_text().split()[0])
        return total * 1e-9

    def _read(self) -> dict[int, float]:
        out = {0: self._cpu(os.getpid(), threading.get_native_id())}
        try:
            children = multiprocessing.active_children()
        except RuntimeError:  # the pool added a worker while we looked: next time
            children = []
        for p in children:
            with contextlib.suppress(OSError):
                out[p.pid] = self._cpu(p.pid)
        return out

    def run(self) -> None:
        prev = self._read()
        while not self._done.wait(self.period):
            cur = self._read()
            d = [max(v - prev.get(k, v), 0.0) for k, v in cur.items()]
            self.predicted += max(sum(d) / self.cores, max(d))
            prev = cur

    def stop(self) -> float:
        self._done.set()
        self.join()
        return self.predicted


def _cpu() -> tuple[float, float]:
    """CPU seconds of this process and of its finished (reaped) children."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime, b.ru_utime + b.ru_stime


@dataclass
class Run:
    wall: float  # whole command (s)
    engine: float  # the optimisation, as the command prints it (s)
    parent_cpu: float
    workers_cpu: float
    predicted: float  # wall on idle cores from the sampled CPU (s)
    line: str  # the command's last line

    @property
    def cpu(self) -> float:
        return self.parent_cpu + self.workers_cpu


def run(jobs: int, budget: int, tmp: Path, report: bool, cores: int) -> Run:
    """One run with ``jobs`` processes, its workers started and stopped inside the measurement."""
    out = tmp / f"jobs{jobs}"
    buf = io.StringIO()
    parallel.shutdown()
    sampler = CpuSampler(cores)
    (p0, c0), w0 = _cpu(), time.perf_counter()
    sampler.start()
    with contextlib.redirect_stdout(buf):
        status = cli(["optimise", "hexaglide_joint_orientation", "--out", str(out), "--budget", str(budget),
                      "--jobs", str(jobs), "--force", "--quiet"] + ([] if report else ["--no-report"]))
    wall = time.perf_counter() - w0
    predicted = sampler.stop()
    parallel.shutdown()  # reap the workers: their CPU time is counted
    p1, c1 = _cpu()
    if status != 0:
        raise SystemExit(f"pkmstiff optimise --jobs {jobs} exited with {status}")
    line = buf.getvalue().strip().splitlines()[-1]
    engine = float(line.split(" s; best")[0].rsplit(", ", 1)[1])  # "..., 12.3 s; best: ..."
    return Run(wall, engine, p1 - p0, c1 - c0, predicted, line)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=int, default=96, help="evaluations per run (default 96, >= 32)")
    ap.add_argument("--repeat", type=int, default=2, help="runs per job count, alternating (default 2)")
    ap.add_argument("--no-report", action="store_true", help="without the HTML comparison report")
    ap.add_argument("--cores", type=int, default=2, help="idle cores of the CPU prediction (default 2)")
    args = ap.parse_args()
    report = not args.no_report
    print(f"pkmstiff optimise hexaglide_joint_orientation --budget {args.budget}"
          f"{'' if report else ' --no-report'}; {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    best: dict[int, Run] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for jobs in (1, 2):  # imports, compiled kernels and plotting warm for both before any timed run
            run(jobs, 12, Path(tmp), report, args.cores)
        for k in range(args.repeat):
            for jobs in (1, 2):
                r = run(jobs, args.budget, Path(tmp), report, args.cores)
                print(f"  run {k + 1}, --jobs {jobs}: wall {r.wall:6.2f} s (optimisation {r.engine:6.2f} s), CPU "
                      f"{r.parent_cpu:5.2f} + {r.workers_cpu:5.2f} s (this process + workers; CPU / wall "
                      f"{r.cpu / r.wall:.2f}), predicted on {args.cores} idle cores {r.predicted:6.2f} s")
                if jobs not in best or r.wall < best[jobs].wall:
                    best[jobs] = r
    one, two = best[1], best[2]
    same = one.line.split("; best: ")[1].split(";")[0] == two.line.split("; best: ")[1].split(";")[0]
    print(f"{'':34s}{'--jobs 1':>10s}{'--jobs 2':>10s}{'ratio':>8s}")
    print(f"{'whole command wall [s]':34s}{one.wall:10.2f}{two.wall:10.2f}{one.wall / two.wall:8.2f}"
          f"   (target >= {TARGET})")
    print(f"{'optimisation wall [s]':34s}{one.engine:10.2f}{two.engine:10.2f}{one.engine / two.engine:8.2f}")
    print(f"{'CPU, this process [s]':34s}{one.parent_cpu:10.2f}{two.parent_cpu:10.2f}")
    print(f"{'CPU, workers [s]':34s}{one.workers_cpu:10.2f}{two.workers_cpu:10.2f}")
    print(f"{'CPU, all [s]':34s}{one.cpu:10.2f}{two.cpu:10.2f}{two.cpu / one.cpu:8.2f}")
    print(f"{f'predicted wall, {args.cores} idle cores [s]':34s}{one.predicted:10.2f}{two.predicted:10.2f}"
          f"{one.predicted / two.predicted:8.2f}   (whole command, from the sampled CPU)")
    print(f"same best: {same}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
