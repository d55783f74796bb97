"""``pkmstiff section``: quantities on a workspace section plane (mm and degrees on the command line)."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from pkmstiff.errors import SectionArgumentError  # noqa: F401 (re-exported)
from pkmstiff.evaluation.quantities import UnknownQuantityError, available_quantities, get_quantity
from pkmstiff.evaluation.sections import SectionError, axis_plane, evaluate_section, section_summary
from pkmstiff.io.ranges import parse_ranges, parse_triple_deg
from pkmstiff.machine.loader import load_machine
from pkmstiff.report.outputs import write_section_outputs

FORMATS = ("png", "vtu", "csv", "npz")




def _cmd_section(args: argparse.Namespace) -> int:
    from pkmstiff.errors import CliError

    try:
        ranges = parse_ranges(args.range, args.plane.lower())
        ori = parse_triple_deg(args.orientation, "--orientation")
        names = [q.strip() for q in args.quantities.split(",") if q.strip()]
        for n in names:
            get_quantity(n)
        formats = [f.strip() for f in args.formats.split(",") if f.strip()]
        bad = set(formats) - set(FORMATS)
        if bad:
            raise SectionArgumentError(f"--formats: expected a subset of {','.join(FORMATS)}, found {sorted(bad)}")
        if not (args.step > 0):
            raise SectionArgumentError(f"--step: expected a positive step in mm, found {args.step}")
        plane_kind = args.plane.lower()
        plane = axis_plane(plane_kind, args.at * 1e-3, ranges[plane_kind[0]], ranges[plane_kind[1]], args.step * 1e-3)
    except (SectionArgumentError, SectionError, UnknownQuantityError) as exc:
        raise CliError(str(exc)) from None
    from pkmstiff.machine.frames import frame_text, neglect_spindle

    machine = neglect_spindle(load_machine(args.machine), args.neglect_spindle)
    t0 = time.perf_counter()
    res = evaluate_section(machine, plane, names, orientation=ori,
                           tool_length=None if args.tool_length is None else args.tool_length * 1e-3,
                           n_jobs=args.jobs, progress=False if args.quiet else None, frame=args.frame)
    seconds = time.perf_counter() - t0
    stem = f"{machine.name.replace(':', '_')}_{plane_kind}"
    paths = write_section_outputs(res, Path(args.out), formats, stem) if args.out else []
    if args.json:
        print(json.dumps(section_summary(res, seconds), indent=2))
        return 0
    print(f"{res.machine}: {res.plane.name} ({frame_text(machine, args.frame)}), {res.ok.sum()} of {res.ok.size} "
          f"points admissible ({float(res.ok.sum()) * plane.cell_area:.4g} m²), {seconds:.2f} s"
          + (", K_U neglected (platform and spindle rigid)" if args.neglect_spindle else ""))
    for n, st in res.statistics().items():
        print(f"  {n:<16} [{st['unit']}]  min {st['min']:.4g}  mean {st['mean']:.4g}  max {st['max']:.4g}")
    reasons = {k: v for k, v in res.reason_counts().items() if v}
    if reasons:
        print("  inadmissible points by reason: " + ", ".join(f"{k} {v}" for k, v in reasons.items()))
    for p in paths:
        print(f"  wrote {p}")
    return 0


def _cmd_quantities(args: argparse.Namespace) -> int:
    for name, desc in available_quantities().items():
        print(f"{name:<20} {desc}")
    return 0


def add_commands(sub) -> None:
    p = sub.add_parser("section", help="evaluate quantities on a workspace section plane",
                       description="Quantities on a section plane, masked by all admissibility checks. "
                                   "Lengths in mm, angles in degrees. See 'pkmstiff quantities' for names.")
    p.add_argument("machine", help="bundled machine name or machine file")
    p.add_argument("--plane", default="yz", choices=["yz", "xz", "xy", "YZ", "XZ", "XY"], help="section plane")
    p.add_argument("--at", type=float, default=0.0, help="position of the plane along its normal axis [mm]")
    p.add_argument("--range", required=True, help="in-plane ranges in mm, e.g. y=-600:800,z=-1200:-500")
    p.add_argument("--step", type=float, default=10.0, help="raster step [mm] (default 10)")
    p.add_argument("--orientation", default="0,0,0", help="tool orientation a,b,c [deg] (default 0,0,0)")
    p.add_argument("--tool-length", type=float, default=None, help="tool length [mm] (default: machine file)")
    p.add_argument("--quantities", default="kappa", help="comma-separated quantity names, e.g. kx,ky,kz,f1")
    p.add_argument("--out", default=None, help="output directory for PNG/VTU/CSV/NPZ (none: print only)")
    p.add_argument("--formats", default="png,vtu,csv,npz", help="output formats (default png,vtu,csv,npz)")
    p.add_argument("--jobs", type=int, default=1, help="parallel processes (-1: all cores)")
    p.add_argument("--json", action="store_true", help="print per-quantity statistics as JSON (with units)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    from pkmstiff.cli.frame_options import add_frame_argument, add_spindle_argument

    add_frame_argument(p)
    add_spindle_argument(p)
    p.set_defaults(func=_cmd_section)
    q = sub.add_parser("quantities", help="list the quantities that sections and requirements can use")
    q.set_defaults(func=_cmd_quantities)
