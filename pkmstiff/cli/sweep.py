"""``pkmstiff sweep SWEEP.toml --out results.csv``: a parameter sweep, serial, in local processes or on Dask."""

from __future__ import annotations

import argparse
import time
from pathlib import Path


def _cmd_sweep(args: argparse.Namespace) -> int:
    from pkmstiff.errors import CliError
    from pkmstiff.evaluation.sweep import SweepError, run_sweep
    from pkmstiff.report.sweep_file import load_sweep

    sweep = load_sweep(args.sweep_file)
    n = len(sweep.points())
    where = f"Dask scheduler {args.scheduler}" if args.scheduler else (
        "serial" if args.jobs == 1 else f"{args.jobs if args.jobs > 0 else 'all'} local processes")
    if not args.quiet:
        print(f"pkmstiff sweep: {sweep.machine}, {sweep.mode}, {n} tasks, {where}")
    t0 = time.perf_counter()
    try:
        res = run_sweep(sweep, n_jobs=args.jobs, scheduler=args.scheduler or None, progress=not args.quiet)
    except SweepError as exc:
        raise CliError(str(exc)) from None
    path = res.to_csv(Path(args.out))
    failed = res.failed
    print(f"pkmstiff sweep: {len(res.rows) - len(failed)} of {len(res.rows)} tasks ok, "
          f"{time.perf_counter() - t0:.1f} s; wrote {path}")
    for r in failed[:5]:
        print(f"  task {r['task']} failed: {r['error']}")
    if len(failed) > 5:
        print(f"  ... and {len(failed) - 5} more (column 'error' of the CSV)")
    return 0


def add_commands(sub) -> None:
    p = sub.add_parser("sweep", help="run a parameter sweep over machine-file values (grid or random)",
                       description="Run the tasks of a sweep file (TOML: base machine, parameters as dotted "
                                   "machine-file paths, evaluations) serially, in local processes (--jobs) or on a "
                                   "Dask cluster (--scheduler), and write one CSV row per task.")
    p.add_argument("sweep_file", help="sweep file (TOML)")
    p.add_argument("--out", required=True, help="result CSV file")
    p.add_argument("--jobs", type=int, default=1, help="local worker processes (-1: all cores; default 1)")
    p.add_argument("--scheduler", default=None,
                   help="Dask scheduler address, e.g. tcp://10.0.0.5:8786 (needs pip install 'pkmstiff[dask]')")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_sweep)
