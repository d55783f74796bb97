"""``pkmstiff optimise DESIGN.toml --out DIR``: design optimisation over machine-file variables (pymoo)."""

from __future__ import annotations

import argparse
import sys


def _cmd_optimise(args: argparse.Namespace) -> int:
    import importlib.util

    from pkmstiff.cli.edges import check_jobs, check_output_dir
    from pkmstiff.errors import ArgumentError
    from pkmstiff.optimise.engine import INSTALL_HINT

    if importlib.util.find_spec("pymoo") is None:
        raise ArgumentError(INSTALL_HINT)
    check_jobs(args.jobs)
    check_output_dir(args.out)  # a directory (or creatable); a run already there is the engine's --resume/--force
    for opt, v, lo in (("--budget", args.budget, 1), ("--seed", args.seed, 0)):
        if v is not None and v < lo:
            raise ArgumentError(f"{opt}: expected a whole number >= {lo}, found {v}")
    from pkmstiff.optimise import load_design, optimise

    design = load_design(args.design_file)  # every check before any evaluation
    budget = design.budget if args.budget is None else args.budget
    if not args.quiet:
        print(f"pkmstiff optimise: {design.machine}, {len(design.variables)} variable(s), "
              f"{len(design.objectives)} objective(s), {len(design.constraints)} constraint(s), "
              f"{design.resolved_algorithm()}, budget {budget}, {args.jobs} process(es)")
    progress = None if args.quiet else (lambda line: print(f"  {line}", file=sys.stderr))
    res = optimise(design, args.out, jobs=args.jobs, budget=args.budget, seed=args.seed, resume=args.resume,
                   force=args.force, progress=progress, report=not args.no_report)
    best = res.best
    text = ", ".join(f"{o.measure.name} = {best.outputs[o.measure.label]:.6g} {o.measure.unit}"
                     for o in design.objectives)
    front = f"front of {len(res.front)} design(s); first: " if len(design.objectives) > 1 else "best: "
    print(f"pkmstiff optimise: {len(res.history)} evaluations ({res.evaluated} run, {res.cached} cached: repeated "
          f"or read from the checkpoint), {res.wall_time_s:.1f} s; {front}{text}; wrote "
          + ", ".join(res.meta["outputs"][k] for k in ("front", "front_plot", "report", "summary")
                      if k in res.meta["outputs"]))
    return 0


def add_commands(sub) -> None:
    p = sub.add_parser("optimise", help="optimise machine-file values (components, joint orientations, geometry)",
                       description="Optimise the variables of a design file (TOML: base machine, variables as "
                                   "dotted machine-file paths, objectives, constraints) with pymoo (DE, CMA-ES, "
                                   "NSGA-II); evaluations are cached and checkpointed in --out.")
    p.add_argument("design_file", help="design file (TOML) or a bundled example name (hexaglide_joint_orientation, "
                                       "pod_ballscrew_selection, hexaglide_strut_lengths)")
    p.add_argument("--out", required=True, help="output folder (front.csv, designs/, front.png, convergence.png, "
                                             "report/, summary.json)")
    p.add_argument("--jobs", type=int, default=1, help="local worker processes (-1: all cores; default 1)")
    p.add_argument("--budget", type=int, default=None, help="evaluations (default: the design file's)")
    p.add_argument("--seed", type=int, default=None, help="random seed (default: the design file's)")
    p.add_argument("--resume", action="store_true", help="continue the run checkpointed in --out")
    p.add_argument("--force", action="store_true", help="start afresh in an --out that holds a run")
    p.add_argument("--no-report", action="store_true", help="no HTML comparison report (report/report.html)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=_cmd_optimise)
