"""``pkmstiff optimise DESIGN.toml --out DIR``: design optimisation over machine-file variables (pymoo)."""

from __future__ import annotations

import argparse
import sys


def _cmd_optimise(args: argparse.Namespace) -> int:
    import importlib.util

    from pkmstiff.cli.edges import check_jobs, check_output_dir
    from pkmstiff.errors import ArgumentError
    from pkmstiff.optimise.engine import CHECKPOINT, INSTALL_HINT

    if importlib.util.find_spec("pymoo") is None:
        raise ArgumentError(INSTALL_HINT)
    check_jobs(args.jobs)
    if args.scheduler and args.jobs != 1:
        raise ArgumentError(f"--jobs {args.jobs} and --scheduler: expected one of them (the cluster's workers "
                            f"evaluate the candidates), found both")
    check_output_dir(args.out)  # a directory (or creatable); a run already there is the engine's --resume/--force
    for opt, v, lo in (("--budget", args.budget, 1), ("--seed", args.seed, 0)):
        if v is not None and v < lo:
            raise ArgumentError(f"{opt}: expected a whole number >= {lo}, found {v}")
    from pkmstiff.optimise import load_design, optimise
    from pkmstiff.optimise.design_file import parse_duration

    time_budget = None if args.time_budget is None else parse_duration(args.time_budget, "--time-budget", "value")
    design = load_design(args.design_file)  # every check before any evaluation
    if args.scheduler:
        from pkmstiff.evaluation.parallel import client

        client(args.scheduler)  # an unreachable scheduler is exit 2 before any evaluation
    budget = design.budget if args.budget is None else args.budget
    tb = design.time_budget if time_budget is None else time_budget
    where = _plan(args.jobs, args.scheduler, not args.no_report)
    if not args.quiet:
        print(f"pkmstiff optimise: {design.machine}, {len(design.variables)} variable(s), "
              f"{len(design.objectives)} objective(s), {len(design.constraints)} constraint(s), "
              f"{design.resolved_algorithm()}, budget {budget} evaluations"
              + (f" or {tb:g} s" if tb is not None else "") + f", {where}")
    progress = None if args.quiet else (lambda line: print(f"  {line}", file=sys.stderr))
    try:
        res = optimise(design, args.out, jobs=args.jobs, scheduler=args.scheduler, budget=args.budget,
                       time_budget=time_budget, seed=args.seed, resume=args.resume, force=args.force,
                       progress=progress, report=not args.no_report)
    except KeyboardInterrupt:
        from pathlib import Path

        ckpt = Path(args.out) / CHECKPOINT
        n = sum(1 for _ in ckpt.open(encoding="utf-8")) if ckpt.exists() else 0
        print(f"pkmstiff optimise: interrupted; {ckpt} holds {n} evaluated candidate(s): rerun with --resume to "
              f"continue", file=sys.stderr)
        return 130
    best = res.best
    text = ", ".join(f"{o.measure.name} = {best.outputs[o.measure.label]:.6g} {o.measure.unit}"
                     for o in design.objectives)
    front = f"front of {len(res.front)} design(s); first: " if len(design.objectives) > 1 else "best: "
    stop = "" if res.meta["stopped"].startswith("budget of") else f" (stopped: {res.meta['stopped']})"
    refined = res.meta.get("refined")
    if refined and refined.get("time_budget_spent") and not args.quiet:
        print(f"pkmstiff optimise: time budget of {res.meta['time_budget_s']:g} s spent before the re-evaluation on "
              f"the requested raster ended; it went on until one re-evaluated design was feasible "
              f"({refined['candidates']} re-evaluated)", file=sys.stderr)
    fine = (f"; {res.reevaluated} re-evaluated on the requested raster after the search on "
            f"{refined['search_step_mm']:g} mm" if refined else "")
    print(f"pkmstiff optimise: {len(res.history)} evaluations{stop} ({res.evaluated} run, {res.cached} cached: "
          f"repeated or read from the checkpoint{fine}), {res.wall_time_s:.1f} s; {front}{text}; wrote "
          + ", ".join(res.meta["outputs"][k] for k in ("front", "front_plot", "report", "summary")
                      if k in res.meta["outputs"]))
    return 0


def _plan(jobs: int, scheduler: str | None, report: bool) -> str:
    """The cost line's parallel plan (:mod:`pkmstiff.optimise.engine`, :func:`pkmstiff.optimise.outputs.write_outputs`)."""
    from pkmstiff.evaluation.parallel import MIN_TASK_SECONDS

    extras = "the base design and the references as tasks beside the first batch on their raster"
    if scheduler:
        return f"Dask scheduler {scheduler}: candidates in tasks of at least {MIN_TASK_SECONDS:g} s, {extras}"
    if jobs == 1:
        return "1 process (serial)"
    return (f"{'all cores' if jobs == -1 else f'{jobs} local workers'}: one candidate per task, {extras}, "
            f"the figures in the pool{' while the comparison report builds' if report else ''}")


def add_commands(sub) -> None:
    p = sub.add_parser("optimise", help="optimise machine-file values (components, joint orientations, geometry)",
                       description="Optimise the variables of a design file (TOML: base machine, variables as "
                                   "dotted machine-file paths, objectives, constraints) with pymoo (DE, CMA-ES, "
                                   "NSGA-II); evaluations are cached and checkpointed in --out.")
    p.add_argument("design_file", help="design file (TOML) or a bundled example name (hexaglide_joint_orientation, "
                                       "pod_ballscrew_selection, hexaglide_strut_lengths)")
    p.add_argument("--out", required=True, help="output folder (front.csv, designs/, front.png, convergence.png, "
                                             "report/, summary.json)")
    p.add_argument("--jobs", type=int, default=1,
                   help="local worker processes evaluating the candidates of a generation (-1: all cores; default 1)")
    p.add_argument("--scheduler", default=None, metavar="ADDR",
                   help="Dask scheduler address, e.g. tcp://10.0.0.5:8786: the cluster evaluates the candidates "
                        "(needs pip install 'pkmstiff[dask]')")
    p.add_argument("--budget", type=int, default=None, help="evaluations (default: the design file's)")
    p.add_argument("--time-budget", default=None, metavar="DURATION",
                   help="stop the search after this time, checked between generations (e.g. 300s, '5 min'; "
                        "default: the design file's time_budget, else none); the re-evaluation on the requested "
                        "raster (coarse_step_mm) follows the search and keeps to what is left where it can, but "
                        "runs until one re-evaluated design is feasible")
    p.add_argument("--seed", type=int, default=None, help="random seed (default: the design file's)")
    p.add_argument("--resume", action="store_true", help="continue the run checkpointed in --out")
    p.add_argument("--force", action="store_true", help="start afresh in an --out that holds a run")
    p.add_argument("--no-report", action="store_true", help="no HTML comparison report (report/report.html)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=_cmd_optimise)
