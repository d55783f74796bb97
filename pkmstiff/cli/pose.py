"""``pkmstiff pose``: kinematics and admissibility of one pose (mm and degrees on the command line)."""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.errors import PoseArgumentError  # noqa: F401 (re-exported)
from pkmstiff.machine.loader import load_machine


def parse_pose(text: str) -> np.ndarray:
    """Parse ``x,y,z,a,b,c`` (mm, mm, mm, deg, deg, deg) into an SI pose (m, rad)."""
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise PoseArgumentError(f"--pose: expected six numbers x,y,z,a,b,c (mm, deg), found {text!r}") from None
    if len(vals) != 6 or not all(math.isfinite(v) for v in vals):
        raise PoseArgumentError(f"--pose: expected six finite numbers x,y,z,a,b,c (mm, deg), found {text!r}")
    return np.array([v * 1e-3 for v in vals[:3]] + [math.radians(v) for v in vals[3:]])


def _finite(x):
    """JSON-safe list: NaN/inf become null."""
    arr = np.asarray(x, dtype=float)
    return [None if not math.isfinite(v) else float(v) for v in arr.ravel()] if arr.ndim else \
        (None if not math.isfinite(float(arr)) else float(arr))


def pose_report(machine_name: str, pose_si: np.ndarray, frame: str = "machine") -> dict:
    """Everything ``pkmstiff pose`` prints, as a JSON-ready dict whose keys name their units.

    ``pose_si`` is given in ``frame`` (:mod:`pkmstiff.machine.frames`); points in the output are in the same frame.
    """
    from pkmstiff.machine.frames import frame_metadata, from_machine_frame, to_machine_frame

    m = load_machine(machine_name)
    given = np.asarray(pose_si, float)
    pose_si = to_machine_frame(m, given, frame)
    ev = evaluate_poses(m, pose_si[None])
    a = ev.admissibility
    deg = np.rad2deg
    rep = {
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
    try:
        pose = parse_pose(args.pose)
    except PoseArgumentError as exc:
        from pkmstiff.cli import CliError
        raise CliError(str(exc)) from None
    rep = pose_report(args.machine, pose, args.frame)
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
    return 0


def add_commands(sub) -> None:
    p = sub.add_parser("pose", help="kinematics and admissibility of one pose",
                       description="Drive coordinates, strut lengths, joint angles, condition number and "
                                   "admissibility of one pose. Units on the command line: mm and degrees.")
    p.add_argument("machine", help="bundled machine name (see 'pkmstiff machines') or path to a machine file")
    p.add_argument("--pose", required=True, help="x,y,z,a,b,c in mm and degrees, e.g. 0,0,-1000,0,0,0")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    from pkmstiff.cli.frame_options import add_frame_argument

    add_frame_argument(p)
    p.set_defaults(func=_cmd_pose)
