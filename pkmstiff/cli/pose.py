"""``pkmstiff pose``: kinematics and admissibility of one pose (mm and degrees on the command line)."""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pkmstiff.admissibility.checks import checks_left_out, checks_without, left_out_text
from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.errors import PoseArgumentError  # noqa: F401 (re-exported)
from pkmstiff.io.ranges import parse_numbers
from pkmstiff.machine.loader import load_machine


#: largest |x|, |y|, |z| of a pose (mm: 100 m, beyond every machine tool) and largest |a|, |b|, |c| (deg: one turn)
POSITION_LIMIT_MM = 1e5
ANGLE_LIMIT_DEG = 360.0


def parse_pose(text: str) -> np.ndarray:
    """Parse ``x,y,z,a,b,c`` (mm, mm, mm, deg, deg, deg) into an SI pose (m, rad); positions beyond
    :data:`POSITION_LIMIT_MM` and angles beyond :data:`ANGLE_LIMIT_DEG` are refused (a typo, not a pose)."""
    vals = parse_numbers(text, 6, "--pose", "x,y,z,a,b,c (mm, deg)", PoseArgumentError, count_text="six")
    for name, v in zip("xyzabc", vals):
        limit, unit = (POSITION_LIMIT_MM, "mm") if name in "xyz" else (ANGLE_LIMIT_DEG, "deg")
        if abs(v) > limit:
            raise PoseArgumentError(f"--pose: expected |{name}| <= {limit:g} {unit}, found {name} = {v:g} {unit}")
    return np.array([v * 1e-3 for v in vals[:3]] + [math.radians(v) for v in vals[3:]])


def _finite(x):
    """JSON-safe list: NaN/inf become null."""
    arr = np.asarray(x, dtype=float)
    return [None if not math.isfinite(v) else float(v) for v in arr.ravel()] if arr.ndim else \
        (None if not math.isfinite(float(arr)) else float(arr))


#: identifier of the JSON document ``pkmstiff pose --json`` prints (pkmstiff/schemas/pose.schema.json)
SCHEMA = "pkmstiff/pose/1"


def read_pose_file(path: str) -> np.ndarray:
    """Poses from a CSV file: one pose per line ``x,y,z,a,b,c`` (mm, deg); a header line and '#' comments are
    skipped. Returns (N, 6) SI poses; errors name the file and line."""
    from pkmstiff.errors import InputError

    from pkmstiff.io.inputs import input_file_problem

    poses = []
    problem = input_file_problem(path)
    if problem is not None:
        raise InputError(path, "(file)", "an existing pose file (CSV x,y,z,a,b,c in mm and deg)", problem)
    try:
        with open(path, encoding="utf-8-sig") as fh:
            lines = fh.read().splitlines()
    except UnicodeDecodeError as exc:
        raise InputError(path, "(file)", "a UTF-8 text pose file",
                         f"non-UTF-8 byte 0x{exc.object[exc.start]:02x} at offset {exc.start}") from None
    for i, line in enumerate(lines, 1):
        text = line.split("#", 1)[0].strip()
        if not text or (i == 1 and any(c.isalpha() for c in text)):
            continue
        try:
            poses.append(parse_pose(text))
        except PoseArgumentError:
            raise InputError(path, f"line {i}", "six finite numbers x,y,z,a,b,c (mm, deg)", text) from None
    if not poses:
        raise InputError(path, "(file)", "at least one pose line x,y,z,a,b,c (mm, deg)", "no pose")
    return np.array(poses)


def pose_rows(machine_name: str, poses_si: np.ndarray,
              skip_checks: Sequence[str] = ()) -> tuple[list[str], list[list]]:
    """CSV header and rows of a pose batch: pose (mm, deg), drive coordinates and strut lengths (mm), condition
    number, admissibility and reasons; vectorised over the poses (one pipeline call). ``skip_checks``: names of
    admissibility checks left out."""
    m = load_machine(machine_name)
    ev = evaluate_poses(m, poses_si, checks=checks_without(skip_checks, "--skip-check"))
    a = ev.admissibility
    n = m.n_chains
    head = ["x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg"] + [f"drive{i + 1}_mm" for i in range(n)] \
        + [f"strut{i + 1}_mm" for i in range(n)] + ["condition_number", "admissible", "reasons"]
    pose_out = np.column_stack([poses_si[:, :3] * 1e3, np.rad2deg(poses_si[:, 3:])])
    kappa = ev.kappa
    rows = []
    for i in range(len(poses_si)):
        rows.append([*pose_out[i], *(ev.drive[i] * 1e3), *(ev.strut_length[i] * 1e3), kappa[i], bool(a.ok[i]),
                     "; ".join(a.failing(i))])
    return head, rows


def pose_report(machine_name: str, pose_si: np.ndarray, frame: str = "machine",
                skip_checks: Sequence[str] = ()) -> dict:
    """Everything ``pkmstiff pose`` prints, as a JSON-ready dict whose keys name their units.

    ``pose_si`` is given in ``frame`` (:mod:`pkmstiff.machine.frames`); points in the output are in the same frame.
    ``skip_checks``: names of admissibility checks left out (stated as ``checks_left_out``).
    """
    from pkmstiff.machine.frames import frame_metadata, from_machine_frame, to_machine_frame

    m = load_machine(machine_name)
    given = np.asarray(pose_si, float)
    pose_si = to_machine_frame(m, given, frame)
    checks = checks_without(skip_checks, "--skip-check")
    ev = evaluate_poses(m, pose_si[None], checks=checks)
    a = ev.admissibility
    deg = np.rad2deg
    rep = {
        "schema": SCHEMA,
        "machine": m.name,
        "machine_type": m.kind,
        **frame_metadata(m, frame),
        "pose": {"x_mm": given[0] * 1e3, "y_mm": given[1] * 1e3, "z_mm": given[2] * 1e3,
                 "a_deg": deg(given[3]), "b_deg": deg(given[4]), "c_deg": deg(given[5])},
        "pose_machine_frame": {"x_mm": pose_si[0] * 1e3, "y_mm": pose_si[1] * 1e3, "z_mm": pose_si[2] * 1e3},
        "drive_coordinates_m": _finite(ev.drive[0]),
        "drive_coordinate_meaning": "distance of the drive from its guide start" if m.kind == "glide"
        else "strut length",
        "strut_lengths_m": _finite(ev.strut_length[0]),
        "drive_joint_points_m": [_finite(v) for v in from_machine_frame(m, ev.drive_point[0], frame)],
        "platform_joint_points_m": [_finite(v) for v in from_machine_frame(m, ev.platform_point[0], frame)],
        "condition_number": _finite(ev.kappa[0]),
        "static_drive_loads_N": None if ev.drive_loads is None else _finite(ev.drive_loads[0]),
        "admissible": bool(a.ok[0]),
        "reasons": a.failing(0),
        "skipped_checks": a.skipped(),
        "checks_left_out": checks_left_out(checks),
    }
    for side in ("drive", "platform"):
        types = m.chains.drive_joint_type if side == "drive" else m.chains.platform_joint_type
        rep[f"{side}_joint_convention"] = [m.joint_types[t].convention for t in types]
        for qty in ("swivel", "tilt", "tilt_axis", "tilt_normal"):
            rep[f"{side}_joint_{qty}_deg"] = _finite(deg(ev.angles[f"{side}_{qty}"][0]))
    return rep


def _frame_line(rep: dict) -> str:
    """``machine frame`` or ``report frame, origin 0, 400, 0 mm: middle guide ...`` from a report's frame keys."""
    if rep.get("frame", "machine") == "machine":
        return "machine frame"
    o = rep["frame_origin_mm"]
    return f"report frame, origin {o[0]:g}, {o[1]:g}, {o[2]:g} mm in the machine frame: {rep['frame_note']}"


def _fmt(values, scale=1.0, digits=2):
    return "  ".join(f"{'n/a':>8}" if v is None else f"{v * scale:8.{digits}f}" for v in values)


def _cmd_pose(args: argparse.Namespace) -> int:
    from pkmstiff.errors import CliError

    if (args.pose is None) == (getattr(args, "poses", None) is None):
        raise CliError("expected exactly one of --pose x,y,z,a,b,c and --poses FILE.csv")
    from pkmstiff.cli.targets import Kind, dispatch

    return dispatch(args.machine, {Kind.SPATIAL: lambda _: _machine_pose(args),
                                   Kind.MECHANISM: lambda _: _mechanism_pose(args)})


def _mechanism_pose(args: argparse.Namespace) -> int:
    """A generic mechanism evaluated like a machine (issue 14)."""
    from pkmstiff.cli.mechanism import pose_report as mechanism_pose_report
    from pkmstiff.cli.mechanism import print_pose
    from pkmstiff.errors import CliError

    if args.skip_check:
        raise CliError(f"--skip-check: not available for the mechanism '{args.machine}' (its admissibility is "
                       "the joint limits)")
    if args.pose is None:
        raise CliError(f"--poses: not available for the mechanism '{args.machine}'; give --pose (or use "
                       "'pkmstiff mechanism solve' with several --pose)")
    rep = mechanism_pose_report(args.machine, args.pose)
    if args.json:
        print(json.dumps(rep, indent=2))
    else:
        print_pose(rep)
    return 0


def _machine_pose(args: argparse.Namespace) -> int:
    from pkmstiff.errors import CliError

    if getattr(args, "poses", None) is not None:
        return _pose_batch(args)
    try:
        pose = parse_pose(args.pose)
    except PoseArgumentError as exc:
        raise CliError(str(exc)) from None
    rep = pose_report(args.machine, pose, args.frame, args.skip_check)
    if args.json:
        print(json.dumps(rep, indent=2))
        return 0
    p = rep["pose"]
    print(f"{rep['machine']} ({rep['machine_type']}) at x={p['x_mm']:.3f} mm, y={p['y_mm']:.3f} mm, "
          f"z={p['z_mm']:.3f} mm, a={p['a_deg']:.3f} deg, b={p['b_deg']:.3f} deg, c={p['c_deg']:.3f} deg "
          f"({_frame_line(rep)})")
    n = len(rep["strut_lengths_m"])
    rows = [("chain", None), ("drive coordinate [mm]", (rep["drive_coordinates_m"], 1e3)),
            ("strut length [mm]", (rep["strut_lengths_m"], 1e3))]
    for side in ("drive", "platform"):
        conv = rep[f"{side}_joint_convention"][0]
        rows += [(f"{side} joint swivel [deg]", (rep[f"{side}_joint_swivel_deg"], 1.0)),
                 (f"{side} joint tilt [deg] ({conv})", (rep[f"{side}_joint_tilt_deg"], 1.0))]
    if rep["static_drive_loads_N"] is not None:
        rows.append(("static drive load [N]", (rep["static_drive_loads_N"], 1.0)))
    width = max(len(label) for label, _ in rows) + 2
    for label, vals in rows:
        body = "  ".join(f"{i + 1:>8d}" for i in range(n)) if vals is None else _fmt(vals[0], vals[1])
        print(f"{label:<{width}}{body}")
    k = rep["condition_number"]
    print(f"condition number of J^-1: {'inf' if k is None else f'{k:.4g}'}")
    if rep["admissible"]:
        print("admissible: yes")
    else:
        print("admissible: NO")
        for r in rep["reasons"]:
            print(f"  - {r}")
    for name, why in rep["skipped_checks"].items():
        print(f"  (check '{name}' skipped: {why})")
    if rep["checks_left_out"]:
        print(f"  ({left_out_text(rep['checks_left_out'])})")
    return 0


def _pose_batch(args: argparse.Namespace) -> int:
    """``--poses FILE``: one CSV row per pose to stdout or ``--out``."""
    out = check_batch_out(args)
    poses = read_pose_file(args.poses)
    head, rows = pose_rows(args.machine, poses, args.skip_check)
    write_batch(out, head, rows, args, "pose")
    if out:
        print(f"pkmstiff pose: {len(rows)} poses ({sum(r[-2] for r in rows)} admissible); wrote {out}")
    return 0


def check_batch_out(args: argparse.Namespace) -> Path | None:
    """The ``--out`` CSV of a ``--poses`` batch and its JSON metadata beside it, checked before any work."""
    from pkmstiff.cli.edges import check_output_file
    from pkmstiff.io.columns import sidecar_path

    if not args.out:
        return None
    force = getattr(args, "force", False)
    out = check_output_file(args.out, "--out", force, (".csv",))
    check_output_file(sidecar_path(out), "--out (its metadata)", force, (".json",))
    return Path(out)


def write_batch(out: Path | None, head: Sequence[str], rows: list[list], args: argparse.Namespace,
                command: str) -> None:
    """A ``--poses`` batch as a plain CSV (``pandas.read_csv`` with no options; floats to 6 digits, empty = no value)
    to ``out`` with its metadata (machine, pose file, checks left out) in ``<out>.json``, or to stdout with the
    checks left out stated on stderr."""
    import sys

    from pkmstiff.io.columns import write_csv, write_table

    if out is None:
        if args.skip_check:
            print(f"pkmstiff {command}: {left_out_text(args.skip_check)}", file=sys.stderr)
        write_csv(sys.stdout, head, rows, ".6g")
        return
    meta = {"command": f"pkmstiff {command}", "machine": str(args.machine), "poses_file": str(args.poses),
            "checks_left_out": list(args.skip_check)}
    write_table(out, head, rows, meta, ".6g")


def add_commands(sub) -> None:
    p = sub.add_parser("pose", help="kinematics and admissibility of one pose",
                       description="Drive coordinates, strut lengths, joint angles, condition number and "
                                   "admissibility of one pose. Units on the command line: mm and degrees.")
    p.add_argument("machine", help="bundled machine name (see 'pkmstiff machines') or path to a machine file; or a "
                                   "mechanism name or file (status, drives, condition number, joint limits)")
    p.add_argument("--pose", default=None, help="x,y,z,a,b,c in mm and degrees, e.g. 0,0,-1000,0,0,0 (planar "
                                                "mechanism: x,y,phi)")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    p.add_argument("--poses", default=None, metavar="FILE",
                   help="a batch: CSV file with one pose x,y,z,a,b,c (mm, deg) per line; prints CSV")
    p.add_argument("--out", default=None, metavar="FILE.csv", help="with --poses: write the CSV here")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    from pkmstiff.cli.frame_options import add_frame_argument, add_skip_check_argument

    add_frame_argument(p)
    add_skip_check_argument(p)
    p.set_defaults(func=_cmd_pose)
