"""``pkmstiff report SPEC.toml --out DIR``: a comparison report of machine variants from a report spec."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def _cmd_report(args: argparse.Namespace) -> int:
    from pkmstiff.cli.edges import announce, check_jobs, check_output_dir, parse_budget
    from pkmstiff.report.build import run_spec

    check_jobs(args.jobs)
    budget = parse_budget(getattr(args, "memory_budget", None))
    check_output_dir(args.out, "--out", getattr(args, "force", False), ("report.html", "report.md"))
    t0 = time.perf_counter()

    def log(msg: str) -> None:
        if not args.quiet:
            print(f"  [{time.perf_counter() - t0:6.1f} s] {msg}", file=sys.stderr, flush=True)

    paths = run_spec(args.spec, Path(args.out), fast=args.fast, n_jobs=args.jobs, log=log,
                     scheduler=getattr(args, "scheduler", None),
                     check=lambda cost, plan: announce("report", cost, budget, quiet=args.quiet, plan=plan))
    print(f"pkmstiff report: wrote {paths['html']} and {paths['md']} ({time.perf_counter() - t0:.1f} s)")
    return 0


def add_commands(sub) -> None:
    p = sub.add_parser("report", help="compare machine variants from a report spec (HTML + Markdown report)",
                       description="Evaluate the variants, sections, workspace and points of a report spec (TOML; "
                                   "lengths in mm, angles in degrees) and write a self-contained HTML report and a "
                                   "Markdown twin with figures.")
    p.add_argument("spec", help="report spec file (TOML), e.g. studies/specs/hexaglide_variants.toml")
    p.add_argument("--out", required=True, help="output directory (report.html, report.md, figures)")
    p.add_argument("--fast", action="store_true",
                   help="coarse raster/resolution from the spec's [options] fast_step_mm / fast_resolution_mm")
    p.add_argument("--jobs", type=int, default=None,
                   help="parallel processes for the evaluations and the section maps (default: spec)")
    p.add_argument("--scheduler", default=None, metavar="ADDR",
                   help="Dask scheduler address, e.g. tcp://10.0.0.5:8786: evaluate sections and workspace there")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.add_argument("--force", action="store_true", help="overwrite an existing report in --out")
    from pkmstiff.cli.edges import add_budget_argument

    add_budget_argument(p)
    p.set_defaults(func=_cmd_report)
