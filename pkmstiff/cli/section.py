"""``pkmstiff section``: quantities on a workspace section plane (mm and degrees on the command line)."""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

from pkmstiff.errors import ArgumentError
from pkmstiff.io.atomic import safe_stem

# the evaluation modules are imported inside the command functions: building the parser for another command
# (``pkmstiff pose``) must not pay for them

FORMATS = ("png", "vtu", "csv", "npz")




def _cmd_section(args: argparse.Namespace) -> int:
    from pkmstiff.cli.targets import Kind, dispatch

    return dispatch(args.machine, {Kind.SPATIAL: lambda _: _machine_section(args),
                                   Kind.MECHANISM: lambda _: _mechanism_section(args),
                                   Kind.PLANAR: lambda _: _planar_section(args)})


def _planar_section(args: argparse.Namespace) -> int:
    """A planar example: one line naming its mechanism file, whose section maps it (nothing computed)."""
    from pkmstiff.errors import ArgumentError

    raise ArgumentError(option="machine", expected=f"the mechanism file of the planar example for its section map in "
                        f"the plane of motion: pkmstiff section {args.machine}_generic (the same model: equal k, f, "
                        f"a_max; pkmstiff point {args.machine} analyses one point)", found=f"{args.machine} (a planar "
                        "example)")


def _mechanism_section(args: argparse.Namespace) -> int:
    """A generic mechanism: kinematic quantities and joint limits (issue 14)."""
    from pkmstiff.cli.mechanism import print_section, section_report

    rep = section_report(args)
    if args.json:
        print(json.dumps(rep, indent=2))
    else:
        print_section(rep)
    return 0


def _machine_section(args: argparse.Namespace) -> int:
    from pkmstiff.cli.targets import check_start_pose

    check_start_pose(args.machine, args.start_pose)
    from pkmstiff.cli.edges import announce, check_jobs, check_output_dir, parse_budget, predicted_plan
    from pkmstiff.evaluation.cost import PLOT_LIBRARY_SECONDS, PNG_SECONDS
    from pkmstiff.evaluation.quantities import get_quantity
    from pkmstiff.evaluation.requests import SectionRequest
    from pkmstiff.evaluation.sections import (
        axis_plane,
        evaluate_section,
        near_singular_line,
        section_summary,
        statistics_line,
    )
    from pkmstiff.io.ranges import parse_names, parse_ranges, parse_triple_deg
    from pkmstiff.machine.loader import load_machine
    from pkmstiff.admissibility.checks import checks_without, left_out_text
    from pkmstiff.evaluation.parallel import resolve_workers
    from pkmstiff.report.outputs import write_section_outputs

    plane_kind = (args.plane or "yz").lower()
    try:
        ranges = parse_ranges(args.range, plane_kind) if args.range else None
        ori = parse_triple_deg(args.orientation, "--orientation")
        names = parse_names(args.quantities, "--quantities")
        for n in names:
            get_quantity(n)
        formats = parse_names(args.formats, "--formats", FORMATS)
        if not (args.step > 0 and math.isfinite(args.step)):
            raise ArgumentError(f"--step: expected a positive step in mm, found {args.step}")
        if not math.isfinite(args.at):
            raise ArgumentError(f"--at: expected a finite position in mm, found {args.at}")
        if args.tool_length is not None and not (math.isfinite(args.tool_length) and args.tool_length >= 0):
            raise ArgumentError(f"--tool-length: expected a length >= 0 mm, found {args.tool_length}")
        requirements = _requirements(getattr(args, "require", None))
        checks = checks_without(args.skip_check, "--skip-check")
    except ArgumentError as exc:
        raise ArgumentError(str(exc)) from None
    check_jobs(args.jobs)
    budget = parse_budget(getattr(args, "memory_budget", None))
    from pkmstiff.machine.frames import frame_text, neglect_spindle

    machine = neglect_spindle(load_machine(args.machine), args.neglect_spindle)
    from pkmstiff.evaluation.quantities import check_quantity

    for n in names:
        check_quantity(n, machine.n_chains)
    stem = f"{safe_stem(machine.name)}_{plane_kind}"
    check_output_dir(args.out, "--out", getattr(args, "force", False), _output_names(stem, names, formats, getattr(args, "reasons_map", False)))
    step = args.step * 1e-3
    if ranges is None:
        from pkmstiff.workspace.windows import window_ranges

        w = window_ranges(machine, plane_kind, args.at * 1e-3, args.step * 1e-3, ori, args.frame, checks,
                          n_jobs=args.jobs, scheduler=getattr(args, "scheduler", None))
        ranges, fitted, fraction = dict(zip(plane_kind, (w.u_range, w.v_range))), True, w.admissible_fraction
    else:
        fitted, fraction = False, None
    all_names = list(dict.fromkeys(names + [r.quantity for r in requirements]))
    window = ", ".join(f"{a} {lo * 1e3:g}..{hi * 1e3:g} mm" for a, (lo, hi) in ranges.items())
    fmts = formats if args.out else []
    cost = SectionRequest(plane_kind, args.at * 1e-3, ranges[plane_kind[0]], ranges[plane_kind[1]], step,
                          tuple(all_names), tuple(ori), frame=args.frame, skip_checks=tuple(args.skip_check)).cost(
        machine, len(names) if "png" in fmts else 0, write=bool(set(fmts) & {"vtu", "csv", "npz"}),
        admissible_fraction=fraction)
    if "png" in fmts or getattr(args, "reasons_map", False):
        cost = cost.plus(PLOT_LIBRARY_SECONDS + (PNG_SECONDS if getattr(args, "reasons_map", False) else 0.0))
    plan = predicted_plan(int(cost.count), cost.seconds, args.jobs, getattr(args, "scheduler", None), "points",
                          granule=4096)
    announce("section", cost.named(f"{plane_kind.upper()} window {window}"
                                   f"{' (fitted to the workspace)' if fitted else ''}"),
             budget, quiet=args.quiet or args.json, plan=plan)
    plane = axis_plane(plane_kind, args.at * 1e-3, ranges[plane_kind[0]], ranges[plane_kind[1]], step)
    t0 = time.perf_counter()
    res = evaluate_section(machine, plane, all_names, orientation=ori,
                           tool_length=None if args.tool_length is None else args.tool_length * 1e-3,
                           n_jobs=args.jobs, progress=False if args.quiet else None, frame=args.frame,
                           checks=checks, scheduler=getattr(args, "scheduler", None))
    failed_requirements = _apply_requirements(res, requirements)
    for extra in set(all_names) - set(names):
        for d in (res.values, res.units, res.si_units, res.labels):
            d.pop(extra, None)
    res.settings["window_fitted_to_workspace"] = fitted
    seconds = time.perf_counter() - t0
    paths = write_section_outputs(res, Path(args.out), formats, stem, progress=False if args.quiet else None,
                                  threads=resolve_workers(args.jobs)) \
        if args.out else []
    if args.out and getattr(args, "reasons_map", False):
        from pkmstiff.plots.section_maps import plot_reasons

        paths.append(plot_reasons(res, Path(args.out) / f"{stem}_admissibility.png"))
    summary = section_summary(res, seconds)
    summary["window_fitted_to_workspace"] = fitted
    if requirements:
        summary["requirements"] = {"texts": [r.text for r in requirements], "points_failing": failed_requirements}
    if args.json:
        summary["files"] = [str(p) for p in paths]
        print(json.dumps(summary, indent=2))
        return 0
    print(f"{res.machine}: {res.plane.name} ({frame_text(machine, args.frame)}), window {window}"
          f"{' (fitted)' if fitted else ''}: {res.ok.sum()} of {res.ok.size} points admissible "
          f"({float(res.ok.sum()) * plane.cell_area:.4g} m²), {seconds:.2f} s"
          + (", K_U neglected (platform and spindle rigid)" if args.neglect_spindle else "")
          + (f", {left_out_text(summary['checks_left_out'])}" if summary["checks_left_out"] else ""))
    for w in summary["warnings"]:
        print(f"  warning: {w}")
    if requirements:
        print(f"  requirements {', '.join(r.text for r in requirements)}: {failed_requirements} admissible points "
              f"fail them (masked)")
    for n, st in summary["statistics"].items():
        print(statistics_line(n, st))
    print(near_singular_line(summary))
    reasons = {k: v for k, v in res.reason_counts().items() if v}
    if reasons:
        print("  inadmissible points by reason: " + ", ".join(f"{k} {v}" for k, v in reasons.items()))
    for p in paths:
        print(f"  wrote {p}")
    return 0


def _output_names(stem: str, names: list[str], formats: list[str], reasons_map: bool) -> tuple[str, ...]:
    """The files a section writes into --out (checked for overwriting before the work)."""
    out = [f"{stem}_{n}.png" for n in names] if "png" in formats else []
    out += [f"{stem}.{f}" for f in ("vtu", "csv", "npz") if f in formats] + [f"{stem}_statistics.json"]
    if "vtu" in formats or "csv" in formats:
        out.append(f"{stem}.json")  # the metadata of the VTU and CSV
    if reasons_map:
        out.append(f"{stem}_admissibility.png")
    return tuple(out)


def _requirements(texts: list[str] | None) -> list:
    if not texts:
        return []
    from pkmstiff.workspace.requirements import parse_requirements
    from pkmstiff.errors import ArgumentError

    try:
        return parse_requirements(texts)
    except ArgumentError as exc:
        raise ArgumentError(f"--require: {exc}") from None


def _apply_requirements(res, requirements: list) -> int:
    """Mask the points that fail a requirement (they become inadmissible, values NaN); return their number."""
    if not requirements:
        return 0
    import numpy as np

    from pkmstiff.workspace.requirements import _OPS

    meets = np.ones(res.ok.shape, bool)
    for r in requirements:
        vals = res.values[r.quantity]
        with np.errstate(invalid="ignore"):
            meets &= _OPS[r.op](vals, r.limit_si) & np.isfinite(vals)
    failing = res.ok & ~meets
    res.ok = res.ok & meets
    for v in res.values.values():
        v[failing] = np.nan
    return int(failing.sum())


def _cmd_quantities(args: argparse.Namespace) -> int:
    from pkmstiff.evaluation.quantities import _FAMILIES, available_quantities

    examples = {ex: pat.pattern.removesuffix("\\Z") for pat, _, ex in _FAMILIES}
    from pkmstiff.admissibility.checks import CHECK_TEXT

    for name, desc in available_quantities().items():
        print(f"{name:<20} {desc}" + (f"  (family {examples[name]})" if name in examples else ""))
    print("\nadmissibility checks (names for --skip-check and skip_checks):")
    for name, desc in CHECK_TEXT.items():
        print(f"{name:<20} {desc}")
    return 0


def add_commands(sub) -> None:
    p = sub.add_parser("section", help="evaluate quantities on a workspace section plane",
                       description="Quantities on a section plane, masked by the admissibility checks (all unless "
                                   "--skip-check leaves some out). "
                                   "Lengths in mm, angles in degrees. See 'pkmstiff quantities' for names.")
    p.add_argument("machine", help="bundled machine name or machine file; or a mechanism (name or file): then the "
                                   "quantities are kappa, the drive names and, with an [elastic] table, kx…krz, fN "
                                   "and share_* (see 'pkmstiff mechanism')")
    p.add_argument("--plane", default=None, choices=["yz", "xz", "xy", "YZ", "XZ", "XY"],
                   help="section plane (default yz; xy, the plane of motion, for a planar mechanism)")
    p.add_argument("--at", type=float, default=0.0, help="position of the plane along its normal axis [mm]")
    p.add_argument("--start-pose", default=None, metavar="POSE",
                   help="a mechanism: map the working/assembly mode of this pose (x,y,z,a,b,c mm/deg; planar x,y,phi), "
                        "reached from home, instead of home's")
    p.add_argument("--range", default=None,
                   help="in-plane ranges in mm, e.g. y=-600:800,z=-1200:-500 (default: fitted to the admissible "
                        "region by a coarse pass, plus a margin)")
    p.add_argument("--step", type=float, default=10.0, help="raster step [mm] (default 10)")
    p.add_argument("--orientation", default="0,0,0", help="tool orientation a,b,c [deg] (default 0,0,0)")
    p.add_argument("--tool-length", type=float, default=None, help="tool length [mm] (default: machine file)")
    p.add_argument("--quantities", default="kappa", help="comma-separated quantity names, e.g. kx,ky,kz,f1")
    p.add_argument("--out", default=None, help="output directory for PNG/VTU/CSV/NPZ (none: print only)")
    p.add_argument("--formats", default="png,vtu,csv,npz", help="output formats (default png,vtu,csv,npz)")
    p.add_argument("--jobs", type=int, default=1, help="parallel processes (-1: all cores)")
    p.add_argument("--scheduler", default=None, metavar="ADDR",
                   help="Dask scheduler address, e.g. tcp://10.0.0.5:8786: evaluate on that cluster (--jobs ignored)")
    p.add_argument("--json", action="store_true", help="print per-quantity statistics as JSON (with units)")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no cost line")
    p.add_argument("--require", action="append", metavar="REQ",
                   help="mask points failing a requirement, e.g. 'U>=0.2', 'kx>=20 N/um' (repeatable)")
    p.add_argument("--reasons-map", action="store_true",
                   help="with --out: also a PNG map of the admissibility reasons")
    p.add_argument("--memory-budget", default=None, metavar="SIZE",
                   help="refuse above this memory estimate, e.g. 4GB or 0.8 (fraction of the available memory; "
                        "default 0.5)")
    p.add_argument("--force", action="store_true", help="overwrite existing output files in --out")
    from pkmstiff.cli.frame_options import add_frame_argument, add_skip_check_argument, add_spindle_argument

    add_frame_argument(p)
    add_spindle_argument(p)
    add_skip_check_argument(p)
    p.set_defaults(func=_cmd_section)
    q = sub.add_parser("quantities", help="list the quantities that sections and requirements can use, and the "
                                          "admissibility check names")
    q.set_defaults(func=_cmd_quantities)
