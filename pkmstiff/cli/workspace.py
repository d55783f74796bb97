"""``pkmstiff workspace`` and ``pkmstiff rotation-map`` (mm and degrees on the command line)."""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.admissibility.checks import checks_without, left_out_text
from pkmstiff.errors import ArgumentError
from pkmstiff.io.atomic import atomic_open, atomic_write_text
from pkmstiff.machine.loader import load_machine

PLANES = {  # name -> (u axis, v axis, normal axis)
    "yz": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), 0),
    "xz": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), 1),
    "xy": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 2),
}



def _floats(text: str, n: int, option: str, what: str) -> list[float]:
    from pkmstiff.io.ranges import parse_numbers

    return parse_numbers(text, n, option, f"({what})")


def _range(text: str, option: str, unit: str) -> tuple[float, float]:
    lo, hi = _floats(text, 2, option, f"MIN,MAX in {unit}")
    if hi <= lo:
        raise ArgumentError(f"{option}: expected MIN < MAX ({unit}), found {text!r}")
    return lo, hi


def _axis_ranges(text: str, axes: str, unit: str, option: str = "--range",
                 required: bool = True) -> dict[str, tuple[float, float]]:
    from pkmstiff.io.ranges import parse_axis_ranges

    return parse_axis_ranges(text, axes, unit, option, required)


def _map_ranges(args: argparse.Namespace, axes: str, unit: str,
                default: dict[str, tuple[float, float]] | None = None) -> dict[str, tuple[float, float]]:
    """The two in-plane ranges of a rotation map from ``--range AXIS=LO:HI,AXIS=LO:HI`` or, deprecated, from
    ``--u-range``/``--v-range MIN,MAX`` (``axes``: the two axis letters; ``default`` when neither is given)."""
    from pkmstiff.cli.edges import old_range_form

    if args.range and (args.u_range or args.v_range):
        raise ArgumentError("--range: expected either --range or the old --u-range/--v-range, found both")
    if args.u_range or args.v_range:
        old = [(o, t) for o, t in (("--u-range", args.u_range), ("--v-range", args.v_range)) if t]
        bounds = {a: (_range(t, o, unit) if t else (default or {}).get(a)) for a, (o, t) in
                  zip(axes, (("--u-range", args.u_range), ("--v-range", args.v_range)))}
        if any(b is None for b in bounds.values()):
            raise ArgumentError(f"--range: expected {axes[0]}=LO:HI,{axes[1]}=LO:HI ({unit}) for the plane, "
                                f"found {' '.join(f'{o} {t}' for o, t in old)}")
        old_range_form("rotation-map", " ".join(o for o, _ in old), " ".join(t for _, t in old),
                       list(bounds), list(bounds.values()))
        return bounds
    if not args.range:
        if default is None:
            raise ArgumentError(f"--range: expected {axes[0]}=LO:HI,{axes[1]}=LO:HI in {unit} for a section plane")
        return default
    return _axis_ranges(args.range, axes, unit)


#: the largest length (mm) and angle (deg) a step, resolution or increment may have: beyond, a typo (1e300 overflowed
#: the cost estimate)
_LIMITS = {"mm": 1e4, "deg": 360.0}


def _positive(value: float, option: str, unit: str) -> float:
    if not (math.isfinite(value) and 0 < value <= _LIMITS[unit]):
        raise ArgumentError(f"{option}: expected a positive number up to {_LIMITS[unit]:g} {unit}, found {value!r}")
    return value


class _Progress:
    """tqdm bar over octree levels on a terminal; one line per level (at most every 10 s) when stderr is redirected;
    nothing with --quiet."""

    def __init__(self, enabled: bool, desc: str):
        self.bar = None
        self.enabled = enabled and sys.stderr.isatty()
        self.lines = enabled and not sys.stderr.isatty()
        self.desc = desc
        self.t0 = self.last = time.perf_counter()

    def __call__(self, level: int, lmax: int, evals: int) -> None:
        if self.lines:
            now = time.perf_counter()
            if now - self.last >= 10.0:
                self.last = now
                print(f"{self.desc}: level {level}/{lmax}, {evals:,} evaluations, {now - self.t0:.0f} s",
                      file=sys.stderr, flush=True)
            return
        if not self.enabled:
            return
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=lmax, desc=self.desc, unit="level", leave=False)
        self.bar.n = level
        self.bar.set_postfix(evaluations=evals)
        self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _requirements(args: argparse.Namespace) -> list[Any]:
    from pkmstiff.errors import ArgumentError
    from pkmstiff.workspace.requirements import parse_requirements

    try:
        return parse_requirements(args.require or [])
    except ArgumentError as exc:
        raise ArgumentError(f"--require: {exc}") from None


# ------------------------------------------------------------------------------------------------------- workspace


#: files every workspace run with --out writes (the surface files only when a surface is made; the PNG unless --no-plot)
WORKSPACE_FILES = ("workspace.json", "boundary_points.csv", "workspace_surface.stl", "workspace_surface.vtp")


@contextmanager
def _octree_input_errors():
    """Bad octree/oracle input (and a box the chains cannot reach) are ArgumentErrors: the command line prints them
    in one line as they are (kept as the one place to add a translation should one be needed)."""
    yield


def _cmd_workspace(args: argparse.Namespace) -> int:
    from pkmstiff.cli.edges import announce, check_jobs, check_output_dir, old_range_form, parse_budget, predicted_plan
    from pkmstiff.evaluation.cost import FIGURE_3D_BYTES, FIGURE_3D_LIBRARY_SECONDS, FIGURE_3D_SECONDS
    from pkmstiff.evaluation.parallel import resolve_workers
    from pkmstiff.machine.frames import frame_text
    from pkmstiff.workspace.requests import WorkspaceRequest
    from pkmstiff.workspace.translational import DEFAULT_METHODS
    from pkmstiff.workspace.volume import HEADLINE_METHOD, METHOD_NOTES

    machine = load_machine(args.machine)
    eps = _positive(args.resolution, "--resolution", "mm") * 1e-3
    if args.refine < 0 or args.refine > 20:
        raise ArgumentError(f"--refine: expected 0..20 bisection steps, found {args.refine}")
    if not 1 <= args.min_level <= 8:
        raise ArgumentError(f"--min-level: expected an octree start level 1..8, found {args.min_level}")
    budget = parse_budget(getattr(args, "memory_budget", None))
    _requirements(args)
    jobs, scheduler = check_jobs(getattr(args, "jobs", 1)), getattr(args, "scheduler", None)
    check_output_dir(args.out, "--out", getattr(args, "force", False),
                     WORKSPACE_FILES + (() if args.no_plot else ("workspace.png",)))
    machine = load_machine(args.machine)
    ori = np.radians(_floats(args.orientation, 3, "--orientation", "three angles a,b,c in deg"))
    box = None
    if args.box:
        b = _floats(args.box, 6, "--box", "xmin,xmax,ymin,ymax,zmin,zmax in mm")
        flat = [f"{c}min < {c}max" for c, lo, hi in zip("xyz", b[0::2], b[1::2]) if not lo < hi]
        if flat:
            raise ArgumentError(f"--box: expected xmin,xmax,ymin,ymax,zmin,zmax in mm with {', '.join(flat)}, "
                                f"found {args.box!r}")
        box = (np.array(b[0::2]) * 1e-3, np.array(b[1::2]) * 1e-3)
    rng = None
    if args.range:
        text = args.range
        parts = text.split(",")
        if len(parts) == 3 and "=" not in text and parts[0].strip() in ("a", "b", "c"):  # old form ANGLE,MIN,MAX
            lo, hi = _floats(",".join(parts[1:]), 2, "--range", "ANGLE=MIN:MAX (deg)")
            text = old_range_form("workspace", "--range", text, [parts[0].strip()], [(lo, hi)])
        r = _axis_ranges(text, "abc", "deg", "--range", required=False)
        if len(r) != 1:
            raise ArgumentError(f"--range: expected one orientation angle ANGLE=MIN:MAX (deg), e.g. c=-30:30, "
                                f"found {args.range!r}")
        (axis, (lo, hi)), = r.items()
        rng = (axis, math.radians(lo), math.radians(hi))

    n_ori = 1 if rng is None else max(1, int((rng[2] - rng[1]) / math.radians(max(args.range_step, 1e-9))) + 1)
    range_step = math.radians(_positive(args.range_step, "--range-step", "deg"))
    options = {"orientation_range": rng, "range_step": range_step, "range_mode": args.range_mode,
               "refine_steps": args.refine, "min_level": args.min_level}
    req = WorkspaceRequest(eps, box, tuple(_requirements(args)), tuple(ori), DEFAULT_METHODS, frame=args.frame,
                           neglect_spindle=args.neglect_spindle, skip_checks=tuple(args.skip_check))
    with _octree_input_errors():
        # a pilot octree (in the workers too): input errors surface here, before the work
        cost = req.cost(machine, n_ori, n_jobs=jobs, scheduler=scheduler, **options)
    if args.out and not args.no_plot:
        cost = cost.plus(FIGURE_3D_LIBRARY_SECONDS + FIGURE_3D_SECONDS, FIGURE_3D_BYTES)
    # the octree's subtrees below a coarse level go to the workers, each task with about as many points
    plan = predicted_plan(int(cost.count), cost.seconds, jobs, scheduler, "points")
    announce("workspace", cost.named(f"octree at resolution {args.resolution:g} mm"), budget,
             quiet=args.quiet or args.json, plan=plan if plan == "serial" else f"octree subtrees: {plan}")
    progress = _Progress(not args.quiet, "octree")
    try:
        with _octree_input_errors():
            res = req.evaluate(machine, progress=progress, n_jobs=jobs, scheduler=scheduler, **options)
    finally:
        progress.close()
    summary = res.summary()
    files = _write_workspace(res, machine, Path(args.out), summary, plot=not args.no_plot,
                             threads=resolve_workers(args.jobs)) if args.out else {}
    summary["files"] = files
    if args.json:
        print(json.dumps(summary, indent=2))
        return 0
    if summary["bounding_box_mm"] is None:
        print(f"{machine.name}: no admissible point found in the initial box (resolution {args.resolution:g} mm, "
              f"{summary['evaluations']:,} evaluations); check --orientation, --require and --box")
        return 0
    lo, hi = summary["bounding_box_mm"]["min"], summary["bounding_box_mm"]["max"]
    varying = "" if rng is None else (f" with {rng[0]} varying over {math.degrees(rng[1]):g}..{math.degrees(rng[2]):g} "
                                      f"deg ({args.range_mode})")
    print(f"{machine.name}: workspace at a,b,c = {args.orientation} deg{varying}, positions in the "
          f"{frame_text(machine, args.frame)}"
          + (", K_U neglected (platform and spindle rigid)" if args.neglect_spindle else "")
          + (f", {left_out_text(args.skip_check)}" if args.skip_check else "")
          + f"; resolution {args.resolution:g} mm (effective "
          f"{', '.join(f'{h:.4g}' for h in summary['effective_resolution_mm'])} mm)")
    print(f"volume: {res.volume:.5f} m^3 (surface nets; the figure to quote)")
    others = [(k, v) for k, v in res.volumes.items() if k != HEADLINE_METHOD]
    if others:
        print("  cross-checks, not the volume to quote (docs/user-guide/workspace.md, volume methods):")
        for k, v in others:
            print(f"    {k:<12} {v:.5f} m^3: {METHOD_NOTES.get(k, '')}")
    print("bounding box [mm]: " + ", ".join(f"{c} {a:.1f}..{b:.1f}" for c, a, b in zip("xyz", lo, hi)))
    print(f"boundary points: {summary['boundary_points']:,}; evaluations: {summary['evaluations']:,}; "
          f"run time {summary['run_time_s']:.2f} s ({summary['evaluation_time_s']:.2f} s evaluating poses)")
    if summary["touches_initial_box"]:
        print("warning: the workspace touches the initial box; it is cut there (enlarge --box)")
    for name, p in files.items():
        print(f"{name}: {p}")
    return 0


def _write_workspace(res, machine, out: Path, summary: dict, plot: bool, threads: int = 1) -> dict[str, str]:
    """boundary_points.csv, the surface (STL, VTP), the PNG and workspace.json (``summary`` with the file list).
    ``threads`` > 1: the CSV, STL and VTP are written on ``threads`` - 1 threads while the figure is drawn here
    (VTK's writers and the CSV's row kernel release the GIL; the figure's VTK window stays on this thread)."""
    from concurrent.futures import ThreadPoolExecutor
    from contextlib import nullcontext

    from pkmstiff.io.numeric_csv import distinct_rows, write_numeric_csv

    out.mkdir(parents=True, exist_ok=True)
    pts = (res.boundary_points - np.asarray(res.frame.get("frame_origin_mm", [0, 0, 0]), float) * 1e-3) * 1e3
    # positions in the result's frame (stated in workspace.json), each once: neighbouring leaf voxels can share the
    # centroid of their admissible corners (eq. 4.1), which would repeat a row
    pts = np.round(pts, 4)
    pts = pts[distinct_rows(pts)[0]] if pts.size else pts

    def points_csv() -> Path:
        p = out / "boundary_points.csv"
        with atomic_open(p, "wb") as fh:
            write_numeric_csv(fh, ["x_mm", "y_mm", "z_mm"], list(pts.T), "")
        return p

    jobs = {f"boundary points (eq. 4.1, mm, {res.frame.get('frame', 'machine')} frame)": points_csv}
    if res.surface is not None and res.surface.triangles.shape[0]:
        jobs["surface STL (mm)"] = lambda: res.surface.save(out / "workspace_surface.stl", scale=1e3)
        jobs["surface VTK (mm)"] = lambda: res.surface.save(out / "workspace_surface.vtp", scale=1e3)
    with ThreadPoolExecutor(threads - 1) if threads > 1 else nullcontext() as ex:  # --jobs 1: here, in turn
        futures = {name: ex.submit(job) for name, job in jobs.items()} if ex else {}
        files = {name: str(job()) for name, job in jobs.items() if name not in futures}
        figure = None
        if plot:
            from pkmstiff.plots.workspace import plot_workspace

            figure = plot_workspace(res, machine, out / "workspace.png")
        files.update({name: str(f.result()) for name, f in futures.items()})
    if figure is not None:
        files["figure"] = str(figure)
    summary["boundary_points_distinct"] = int(pts.shape[0])  # the rows of boundary_points.csv
    summary["files"] = files
    atomic_write_text(out / "workspace.json", json.dumps(summary, indent=2))
    files["summary JSON"] = str(out / "workspace.json")
    return files


# ---------------------------------------------------------------------------------------------------- rotation map


def _cmd_rotation_map(args: argparse.Namespace) -> int:
    from pkmstiff.cli.edges import announce, check_jobs, check_output_dir, parse_budget, predicted_plan
    from pkmstiff.errors import ArgumentError
    from pkmstiff.evaluation.cost import (
        BASE_SECONDS,
        admissible_fraction,
        plane_points,
        rotation_base_seconds,
        rotation_map_cost,
    )
    from pkmstiff.evaluation.sections import raster, raster_count
    from pkmstiff.machine.frames import frame_metadata, frame_text, neglect_spindle, to_machine_frame
    from pkmstiff.workspace.requests import RotationMapRequest
    from pkmstiff.workspace.rotation import DIRECTIONS, FUSED_CHUNK, direction_group, rotational_workspace_map

    machine = neglect_spindle(load_machine(args.machine), args.neglect_spindle)
    inc = math.radians(_positive(args.increment, "--increment", "deg"))
    check_output_dir(args.out, "--out", getattr(args, "force", False),
                     ("rotation_map.json",) + (() if args.no_plot else ("rotation_map.png",))
                     + tuple(f"{_map_name(d.strip())}.{ext}" for d in args.directions.split(",") if d.strip()
                             for ext in ("csv", "json")))
    _requirements(args)
    machine = load_machine(args.machine)
    amax = math.radians(_positive(args.max_angle, "--max-angle", "deg"))
    ori = np.radians(_floats(args.orientation, 3, "--orientation", "three angles a,b,c in deg"))
    dirs = [d.strip() for d in args.directions.split(",") if d.strip()]
    bad = [d for d in dirs if d not in DIRECTIONS]
    if bad or not dirs:
        raise ArgumentError(f"--directions: expected a comma-separated list of {', '.join(DIRECTIONS)}, "
                            f"found {args.directions!r}")
    method = {"pc": "predictor_corrector", "predictor_corrector": "predictor_corrector", "plain": "plain"}[args.method]
    budget = parse_budget(getattr(args, "memory_budget", None))
    jobs, scheduler = check_jobs(args.jobs), args.scheduler
    if args.point:
        if len(dirs) != 1 or len(dirs[0]) != 2:
            raise ArgumentError("--point (rotational workspace): expected exactly one single-axis direction, "
                                f"e.g. --directions +a, found {args.directions!r}")
        others = [c for c in "abc" if c != dirs[0][1]]
        axes, unit = "".join(others), "deg"
        rng = _map_ranges(args, axes, unit, {others[0]: (-30.0, 30.0), others[1]: (-60.0, 60.0)})
    else:
        if args.plane not in PLANES:
            raise ArgumentError(f"--plane: expected one of {', '.join(PLANES)}, found {args.plane!r}")
        axes, unit = args.plane, "mm"
        rng = _map_ranges(args, axes, unit)
    step = _positive(args.step, "--step", unit)
    (u0, u1), (v0, v1) = rng[axes[0]], rng[axes[1]]
    nu, nv = raster_count(u0, u1, step), raster_count(v0, v1, step)
    frac = 1.0  # at a point every raster orientation may be admissible
    if not args.point:  # the admissible fraction of the plane at the base orientation, on a sub-raster
        ua, va, normal = PLANES[args.plane]
        origin = np.zeros(3)
        origin[normal] = args.at * 1e-3
        pts = plane_points((u0 * 1e-3, u1 * 1e-3), (v0 * 1e-3, v1 * 1e-3), step * 1e-3,
                           to_machine_frame(machine, origin, args.frame), ua, va)
        frac = admissible_fraction(machine, pts, ori, checks_without(args.skip_check, "--skip-check"))
    cost = rotation_map_cost(nu * nv, frac, nu + nv - 1, len(dirs), inc, amax, method == "plain", args.verify)
    base_s = rotation_base_seconds(nu * nv)
    rest = max(nu * nv - FUSED_CHUNK, 0)  # the first chunk of the base check runs here, timed
    base_plan = predicted_plan(rest, base_s * rest / (nu * nv), jobs, scheduler, "points", FUSED_CHUNK)
    search_plan = predicted_plan(len(dirs), cost.seconds - BASE_SECONDS - base_s, jobs, scheduler, "directions",
                                 direction_group(len(dirs), jobs, scheduler))
    plan = f"base check {base_plan}; search {search_plan}"
    announce("rotation-map", cost.named(f"{len(dirs)} direction(s) on {nu * nv:,} raster points, increment "
                                        f"{args.increment:g} deg"), budget, quiet=args.quiet or args.json, plan=plan)
    t0 = time.perf_counter()
    try:
        if args.point:
            point = np.array(_floats(args.point, 3, "--point", "x,y,z in mm")) * 1e-3
            u = np.radians(raster(*rng[others[0]], step))
            v = np.radians(raster(*rng[others[1]], step))
            res = rotational_workspace_map(machine, to_machine_frame(machine, point, args.frame), dirs[0], u, v, ori,
                                           inc, amax,
                                           requirements=_requirements(args), method=method, verify=args.verify,
                                           checks=checks_without(args.skip_check, "--skip-check"))
            labels, scale = (f"{others[0]} [deg]", f"{others[1]} [deg]"), (180 / math.pi, 180 / math.pi)
            title = (f"{machine.name}: max. rotation {dirs[0]} at x,y,z = {args.point} mm "
                     f"({frame_text(machine, args.frame).split(' (')[0]})")
        else:
            u = raster(*rng[args.plane[0]], step) * 1e-3
            v = raster(*rng[args.plane[1]], step) * 1e-3
            req = RotationMapRequest(tuple(origin), tuple(ua), tuple(va), tuple(u), tuple(v), tuple(dirs), tuple(ori),
                                     inc, amax, tuple(_requirements(args)), method, frame=args.frame,
                                     skip_checks=tuple(args.skip_check))
            res = req.evaluate(machine, verify=args.verify, n_jobs=jobs, scheduler=scheduler)
            labels = (f"{args.plane[0]} [mm]", f"{args.plane[1]} [mm]")
            scale = (1e3, 1e3)
            title = (f"{machine.name}: max. rotation angles on the {args.plane.upper()} plane at "
                     f"{'xyz'[normal]} = {args.at:g} mm ({frame_text(machine, args.frame).split(' (')[0]}), "
                     f"base a, b, c = {args.orientation} deg")
    except ArgumentError as exc:
        raise ArgumentError(str(exc)) from None
    run = time.perf_counter() - t0
    summary = res.summary()
    frame = frame_metadata(machine, args.frame)
    summary.update({"machine": machine.name, "run_time_s": run, **frame,
                    "neglect_spindle": bool(args.neglect_spindle)})
    files: dict[str, str] = {}
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        for d, a in res.angles.items():
            p = out / f"{_map_name(d)}.csv"
            _write_map(p, res.u_values * scale[0], res.v_values * scale[1], np.degrees(a), labels,
                       {"machine": machine.name, "direction": d, "title": title,
                        "max_angle_deg": f"largest admissible rotation {d} from the base orientation on the "
                                         f"{args.increment:g} deg lattice; empty: base orientation inadmissible",
                        "increment_deg": args.increment, "max_search_deg": args.max_angle,
                        "checks_left_out": list(args.skip_check), **frame})
            files[f"map {d} (deg)"] = str(p)
        if not args.no_plot:
            from pkmstiff.plots.workspace import plot_rotation_maps

            files["figure"] = str(plot_rotation_maps(res, out / "rotation_map.png", labels, scale, title))
        summary["files"] = files
        atomic_write_text(out / "rotation_map.json", json.dumps(summary, indent=2))
        files["summary JSON"] = str(out / "rotation_map.json")
    if args.json:
        print(json.dumps(summary, indent=2))
        return 0
    print(title + (f" ({left_out_text(args.skip_check)})" if args.skip_check else ""))
    print(f"{summary['admissible_points']} of {res.base_ok.size} raster points admissible at the base orientation; "
          f"increment {args.increment:g} deg, max {args.max_angle:g} deg, method {method}; run time {run:.2f} s")
    for d, st in summary["angles"].items():
        ev = summary["evaluations"][d]
        mx = "n/a" if st["max_deg"] is None else f"{st['max_deg']:.1f}"
        mn = "n/a" if st["mean_deg"] is None else f"{st['mean_deg']:.1f}"
        print(f"  {d:>5}: max {mx} deg, mean {mn} deg; {ev['evaluations']:,} evaluations "
              f"(plain search {ev['plain_sequential']:,}, saved {100 * ev['saved_fraction']:.0f} %)")
    for name, p in files.items():
        print(f"{name}: {p}")
    return 0


def _map_name(direction: str) -> str:
    """The file stem of one direction's map: ``rotation_map_pa`` (``.csv`` and its ``.json``) for +a."""
    return f"rotation_map_{direction.replace('+', 'p').replace('-', 'm')}"


def _write_map(path: Path, u: np.ndarray, v: np.ndarray, deg: np.ndarray, labels: tuple[str, str],
               meta: dict[str, Any]) -> None:
    """One direction's map as a plain CSV, one row per raster point (``v`` outer, ``u`` inner): the two raster
    coordinates named by the column rule (``y_mm``, ``z_mm``; ``b_deg``, ``c_deg`` at a point) and
    ``max_angle_deg`` (empty = inadmissible base orientation); ``meta`` goes to ``<name>.json`` beside it."""
    from pkmstiff.io.columns import label_column, write_column_table

    U, V = np.meshgrid(np.asarray(u, float), np.asarray(v, float))
    write_column_table(path, [label_column(labels[0]), label_column(labels[1]), "max_angle_deg"],
                       [U.ravel(), V.ravel(), np.asarray(deg, dtype=float).ravel()], meta, ".6g")


def add_commands(sub: Any) -> None:
    p = sub.add_parser(
        "workspace", help="workspace boundary, volume and surface by the modified octree",
        description="Workspace at constant orientation (or with one variable orientation range) by the modified "
                    "octree (Cobet 4.1.4): volume [m^3], bounding box, boundary points, closed surface (STL/VTK, mm). "
                    "Units on the command line: mm and degrees.")
    p.add_argument("machine", help="bundled machine name or path to a machine file")
    p.add_argument("--resolution", type=float, required=True, help="resolution eps in mm (e.g. 12.5)")
    p.add_argument("--orientation", default="0,0,0", help="tool orientation a,b,c in deg (default 0,0,0)")
    p.add_argument("--require", action="append", metavar="REQ",
                   help="extra requirement, e.g. 'U>=0.2', 'kappa<=100', 'kx>=20 N/um' (repeatable)")
    p.add_argument("--box", help="initial box xmin,xmax,ymin,ymax,zmin,zmax in mm (default: the chains' reach box)")
    p.add_argument("--range", metavar="ANGLE=LO:HI",
                   help="variable orientation range in deg, e.g. c=-30:30 (the old form c,-30,30 is deprecated)")
    p.add_argument("--range-step", type=float, default=2.0, help="sampling step of --range in deg (default 2)")
    p.add_argument("--range-mode", choices=("all", "any"), default="all",
                   help="'all' samples admissible (Merlet) or 'any' (choose the angle) (default all)")
    p.add_argument("--refine", type=int, default=0,
                   help="bisection steps along boundary edges for the volume (default 0)")
    p.add_argument("--min-level", type=int, default=3, help="octree start level (default 3 = 8 voxels per axis)")
    p.add_argument("--jobs", type=int, default=1,
                   help="parallel processes for the octree levels' evaluations (-1: all cores; default 1)")
    p.add_argument("--scheduler", default=None, metavar="ADDR",
                   help="Dask scheduler address, e.g. tcp://10.0.0.5:8786: evaluate the levels on that cluster")
    p.add_argument("--out", help="output directory (boundary points CSV, STL/VTK surface, PNG, JSON)")
    p.add_argument("--no-plot", action="store_true", help="no PNG figure")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--memory-budget", default=None, metavar="SIZE",
                   help="refuse above this memory estimate, e.g. 4GB or 0.8 (fraction of the available memory)")
    p.add_argument("--force", action="store_true", help="overwrite an earlier result in --out")
    from pkmstiff.cli.frame_options import add_frame_argument, add_skip_check_argument, add_spindle_argument

    add_frame_argument(p)
    add_spindle_argument(p)
    add_skip_check_argument(p)
    p.set_defaults(func=_cmd_workspace)

    p = sub.add_parser(
        "rotation-map", help="maximum admissible rotation angles on a section plane or at a point",
        description="Maximum admissible rotation angles in +a, -a, +b, -b, +a+b, -a-b on a section plane by the "
                    "2-D predictor-corrector (Cobet 4.1.5), or with --point the rotational workspace at a point "
                    "(max. +a over (b, c) or max. +b over (a, c)). Units: mm and degrees.")
    p.add_argument("machine", help="bundled machine name or path to a machine file")
    p.add_argument("--plane", default="yz", help="section plane yz, xz or xy (default yz)")
    p.add_argument("--at", type=float, default=0.0, help="plane position along its normal in mm (default 0)")
    p.add_argument("--range", metavar="AXIS=LO:HI,AXIS=LO:HI",
                   help="the two in-plane ranges, e.g. y=-200:1100,z=-1100:-800 (mm; with --point: the two other "
                        "angles in deg, default e.g. b=-30:30,c=-60:60 for +a)")
    p.add_argument("--u-range", help=argparse.SUPPRESS)  # deprecated: MIN,MAX of the first in-plane axis
    p.add_argument("--v-range", help=argparse.SUPPRESS)  # deprecated: MIN,MAX of the second in-plane axis
    p.add_argument("--step", type=float, default=25.0, help="raster step (mm; with --point: deg) (default 25)")
    p.add_argument("--point", help="x,y,z in mm: rotational workspace at this point instead of a plane")
    p.add_argument("--directions", default="+a,-a,+b,-b,+a+b,-a-b", help="comma-separated directions")
    p.add_argument("--increment", type=float, default=1.0, help="angle increment in deg (default 1)")
    p.add_argument("--max-angle", type=float, default=90.0, help="search bound in deg (default 90)")
    p.add_argument("--orientation", default="0,0,0", help="base orientation a,b,c in deg (default 0,0,0)")
    p.add_argument("--method", choices=("pc", "predictor_corrector", "plain"), default="pc",
                   help="predictor-corrector (default) or plain incremental search")
    p.add_argument("--verify", action="store_true", help="check every increment below the result (gaps)")
    p.add_argument("--require", action="append", metavar="REQ", help="extra requirement, e.g. 'U>=0.2' (repeatable)")
    p.add_argument("--out", help="output directory (CSV maps in deg, PNG, JSON)")
    p.add_argument("--no-plot", action="store_true", help="no PNG figure")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument("--jobs", type=int, default=1,
                   help="parallel processes: the directions are searched side by side (-1: all cores; default 1)")
    p.add_argument("--scheduler", default=None, metavar="ADDR",
                   help="Dask scheduler address, e.g. tcp://10.0.0.5:8786: search the directions on that cluster")
    p.add_argument("--force", action="store_true", help="overwrite an earlier result in --out")
    from pkmstiff.cli.edges import add_budget_argument
    from pkmstiff.cli.frame_options import add_frame_argument, add_skip_check_argument, add_spindle_argument

    add_budget_argument(p)
    add_frame_argument(p)
    add_spindle_argument(p)
    add_skip_check_argument(p)
    p.set_defaults(func=_cmd_rotation_map)


__all__: Sequence[str] = ("add_commands",)
