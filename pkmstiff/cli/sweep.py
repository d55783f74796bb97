"""``pkmstiff sweep SWEEP.toml --out results.csv``: a parameter sweep, serial, in local processes or on Dask."""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

#: exit status when some (not all) sweep tasks failed; all failed: 2 like any other input error
EXIT_SOME_TASKS_FAILED = 4


def _cmd_sweep(args: argparse.Namespace) -> int:
    from pkmstiff.cli.edges import announce, check_jobs, check_output_file, parse_budget
    from pkmstiff.errors import CliError
    from pkmstiff.evaluation.cost import sweep_cost
    from pkmstiff.evaluation.sweep import SweepError, run_sweep, sidecar_path
    from pkmstiff.machine.loader import load_machine
    from pkmstiff.report.sweep_evaluations import evaluation_cost
    from pkmstiff.report.sweep_file import load_sweep

    check_jobs(args.jobs)
    budget = parse_budget(getattr(args, "memory_budget", None))
    out = check_output_file(args.out, "--out", getattr(args, "force", False), (".csv",))
    check_output_file(sidecar_path(out), "--out (its metadata)", getattr(args, "force", False), (".json",))
    sweep = load_sweep(args.sweep_file)
    _check_sweep_quantities(sweep, args.sweep_file)
    _check_sweep_paths(sweep, args.sweep_file)
    n = sweep.n_tasks
    try:
        task = evaluation_cost(sweep.evaluation, load_machine(sweep.machine))
    except (ValueError, KeyError) as exc:  # an evaluation the base machine cannot estimate: the tasks report it
        raise CliError(f"{args.sweep_file}: evaluations: {exc}") from None
    jobs = 1 if args.scheduler else (args.jobs if args.jobs > 0 else (os.cpu_count() or 1))
    cost = sweep_cost(n, task, min(jobs, max(n, 1)))
    size_key = "evaluations (step_mm / resolution_mm)" if task.bytes > budget else (
        "parameters (values per parameter)" if sweep.mode == "grid" else "sweep.samples")
    announce("sweep", cost.named(cost.what, f"{args.sweep_file}: {size_key}"), budget, quiet=args.quiet)
    where = f"Dask scheduler {args.scheduler}" if args.scheduler else (
        "serial" if args.jobs == 1 else f"{args.jobs if args.jobs > 0 else 'all'} local processes")
    if not args.quiet:
        print(f"pkmstiff sweep: {sweep.machine}, {sweep.mode}, {n} tasks, {where}")
    t0 = time.perf_counter()
    try:
        res = run_sweep(sweep, n_jobs=args.jobs, scheduler=args.scheduler or None, progress=not args.quiet)
    except SweepError as exc:
        raise CliError(str(exc)) from None
    failed = res.failed
    distinct: dict[str, list[int]] = {}
    for r in failed:
        distinct.setdefault(str(r["error"]), []).append(int(r["task"]))
    if failed and len(failed) == len(res.rows):
        first = next(iter(distinct))
        more = f" (and {len(distinct) - 1} other error(s))" if len(distinct) > 1 else ""
        raise CliError(f"all {len(res.rows)} tasks failed: {first}{more}; nothing written")
    path = res.to_csv(Path(out))
    plan = res.plan.text("tasks", "batches") if res.plan is not None else "serial"
    print(f"pkmstiff sweep: {len(res.rows) - len(failed)} of {len(res.rows)} tasks ok, "
          f"{time.perf_counter() - t0:.1f} s ({plan}); wrote {path} (metadata {sidecar_path(path)})")
    for err, tasks in distinct.items():  # one line per distinct error
        ids = ", ".join(map(str, tasks[:8])) + (", ..." if len(tasks) > 8 else "")
        print(f"  {len(tasks)} task(s) failed ({ids}): {err}")
    return EXIT_SOME_TASKS_FAILED if failed else 0


def _check_sweep_quantities(sweep, source: str) -> None:
    """Quantity names of every evaluation against the base machine, before any task runs (one error, not one per
    task)."""
    from pkmstiff.errors import CliError
    from pkmstiff.evaluation.quantities import UnknownQuantityError, check_quantity
    from pkmstiff.machine.loader import load_machine

    n_chains = load_machine(sweep.machine).n_chains
    stack = [sweep.evaluation]
    while stack:
        ev = stack.pop()
        stack.extend(getattr(ev, "parts", ()))
        for name in getattr(ev, "quantities", ()) or ():
            try:
                check_quantity(name, n_chains)
            except UnknownQuantityError as exc:
                raise CliError(f"{source}: evaluations: {exc}") from None


def _check_sweep_paths(sweep, source: str) -> None:
    """Every override path (base overrides and parameters) against the base machine file, before any task runs: a
    path that leads nowhere, or to a key resolved before overrides (``machine.extends``), is one error up front."""
    from pkmstiff.errors import CliError, OverrideError
    from pkmstiff.machine.variants import apply_overrides, raw_machine

    raw, src, _ = raw_machine(sweep.machine)
    paths = {**dict(sweep.base_overrides), **{p.path: None for p in sweep.parameters}}
    try:
        apply_overrides(raw, paths, src)
    except OverrideError as exc:
        raise CliError(f"{source}: parameters: {exc}") from None


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
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    from pkmstiff.cli.edges import add_budget_argument

    add_budget_argument(p)
    p.set_defaults(func=_cmd_sweep)
