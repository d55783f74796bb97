"""``pkmstiff mechanism solve|range|info``: generic link-and-joint mechanisms (lengths mm, angles degrees).

``solve NAME --pose x,y,z,a,b,c`` (planar ``x,y,phi``; repeatable) runs the inverse kinematics and reports the drive
values, status and joint-limit admissibility of each pose — a mechanism evaluated like a machine by ``pkmstiff
pose``; ``solve NAME --drives v1,v2,…`` (linear drives in mm, angular drives in degrees) runs the forward kinematics.
``range NAME`` prints each drive's interval (continuation to the singular ends); ``info NAME`` prints links,
joints, equation count, rank and mobility.  ``--json`` keys name their units.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from pkmstiff.errors import PkmstiffError
from pkmstiff.io.ranges import parse_numbers


def _cli_error(msg: str):
    from pkmstiff.cli import CliError

    return CliError(msg)


def _num(x: float) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _values(text: str, count: int, what: str, opt: str) -> list[float]:
    from pkmstiff.errors import CliError

    return parse_numbers(text, count, opt, what, CliError)


def _unit_scale(unit: str) -> tuple[str, float]:
    return ("mm", 1e3) if unit == "m" else ("deg", 180.0 / math.pi)


def _load(name: str):
    from pkmstiff.mechanisms import load_mechanism

    return load_mechanism(name)


def solve_report(name: str, poses: list[str] | None = None, drives: list[str] | None = None,
                 steps: int = 1) -> dict[str, Any]:
    """Everything ``pkmstiff mechanism solve`` prints, as a JSON-ready dict."""
    import pkmstiff.mechanisms as mm

    mech = _load(name)
    units = [_unit_scale(u) for u in mech.drive_units]
    pose_names = (("x", "mm"), ("y", "mm"), ("z", "mm"), ("a", "deg"), ("b", "deg"), ("c", "deg")) if mech.dim == 3 \
        else (("x", "mm"), ("y", "mm"), ("phi", "deg"))
    results = []
    if poses:
        P = np.array([_values(p, len(pose_names), ",".join(f"{n} [{u}]" for n, u in pose_names), "--pose")
                      for p in poses])
        P = np.array([[v * (1e-3 if u == "mm" else math.pi / 180) for v, (_, u) in zip(row, pose_names)]
                      for row in P])
        ev = mm.evaluate(mech, P, steps=steps)
        sol = ev.solution
        for i in range(len(P)):
            results.append({
                "status": str(sol.status[i]), "iterations": int(sol.iterations[i]),
                "admissible": bool(ev.admissible[i]), "reasons": mm.reason_names(ev.reasons[i]),
                "violated_joints": [n for n, v in zip(ev.joint_names, ev.violated[i]) if v],
                "pose": {f"{n}_{u}": _num(v * (1e3 if u == "mm" else 180 / math.pi))
                         for (n, u), v in zip(pose_names, P[i])},
                "drives": {f"{d}_{u}": _num(v * s) for d, (u, s), v in zip(mech.drive_names, units, ev.drives[i])},
            })
    else:
        nd = len(mech.drives)
        D = np.array([_values(d, nd, ",".join(f"{n} [{u}]" for n, (u, _) in zip(mech.drive_names, units)),
                              "--drives") for d in drives or []])
        D = D / np.array([s for _, s in units])[None]
        sol = mm.forward(mech, D, steps=steps)
        outp = sol.poses if mech.output is not None else np.full((len(D), len(pose_names)), np.nan)
        for i in range(len(D)):
            results.append({
                "status": str(sol.status[i]), "iterations": int(sol.iterations[i]),
                "residual": _num(sol.residual[i]),
                "drives": {f"{d}_{u}": _num(v * s) for d, (u, s), v in zip(mech.drive_names, units, D[i])},
                "pose": {f"{n}_{u}": _num(v * (1e3 if u == "mm" else 180 / math.pi))
                         for (n, u), v in zip(pose_names, outp[i])},
            })
    return {"mechanism": mech.name, "mode": "inverse" if poses else "forward", "results": results}


def range_report(name: str) -> dict[str, Any]:
    import pkmstiff.mechanisms as mm

    mech = _load(name)
    rng = mm.drive_ranges(mech)
    out = {}
    for d, r in rng.items():
        u, s = _unit_scale(r.unit)
        out[d] = {"min": _num(r.min.value * s), "max": _num(r.max.value * s), "unit": u,
                  "min_end": r.min.kind, "max_end": r.max.kind,
                  "min_sigma_ratio": _num(r.min.sigma_ratio), "max_sigma_ratio": _num(r.max.sigma_ratio)}
    return {"mechanism": mech.name, "drives": out}


def info_report(name: str) -> dict[str, Any]:
    import pkmstiff.mechanisms as mm

    mech = _load(name)
    i = mm.info(mech)
    return {"mechanism": mech.name, "title": mech.title, "dimension": i.dimension, "links": list(i.links),
            "joints": i.joints, "unknowns": i.unknowns, "equations": i.equations, "rank": i.rank,
            "mobility": i.mobility, "drives": list(i.drives), "assumptions": mech.assumptions}


def _cmd(args) -> int:
    try:
        if args.action == "solve":
            if bool(args.pose) == bool(args.drives):
                raise _cli_error("solve: give either --pose (inverse kinematics) or --drives (forward kinematics)")
            rep = solve_report(args.mechanism, args.pose, args.drives, args.steps)
        elif args.action == "range":
            rep = range_report(args.mechanism)
        else:
            rep = info_report(args.mechanism)
    except PkmstiffError as exc:
        raise _cli_error(str(exc)) from None
    if args.json:
        print(json.dumps(rep, indent=2))
        return 0
    if args.action == "info":
        print(f"{rep['mechanism']}: {rep['title']} ({'spatial' if rep['dimension'] == 3 else 'planar'})")
        print(f"  links {len(rep['links'])}: {', '.join(rep['links'])}")
        for j in rep["joints"]:
            print(f"  joint {j['name']}: {j['type']} {j['links'][0]}-{j['links'][1]}"
                  + (f" (drive {j['drive']})" if j["drive"] else ""))
        print(f"  unknowns {rep['unknowns']}, equations {rep['equations']}, rank {rep['rank']}, "
              f"mobility {rep['mobility']}")
    elif args.action == "range":
        for d, r in rep["drives"].items():
            print(f"{d}: {r['min']:.6f} .. {r['max']:.6f} {r['unit']} (ends: {r['min_end']}, {r['max_end']})")
    else:
        for i, r in enumerate(rep["results"]):
            dr = ", ".join(f"{k} = {'-' if v is None else f'{v:.6f}'}" for k, v in r["drives"].items())
            ps = ", ".join(f"{k} = {'-' if v is None else f'{v:.6f}'}" for k, v in r["pose"].items())
            extra = ""
            if "admissible" in r:
                extra = f", admissible {r['admissible']}" + (f" ({', '.join(r['reasons'])})" if r["reasons"] else "")
            print(f"[{i}] {r['status']}{extra}\n    drives: {dr}\n    pose: {ps}")
    return 0


def add_commands(sub: Any) -> None:
    p = sub.add_parser("mechanism", help="generic link-and-joint mechanisms: solve, drive ranges, structure",
                       description="Generic mechanisms (DE 10 2004 026 707 A1): inverse kinematics of poses "
                                   "(--pose, mm/deg; status, drive values and joint-limit admissibility as 'pkmstiff "
                                   "pose'), forward kinematics of drive values (--drives; mm for linear, deg for "
                                   "angular drives), drive ranges, links/joints/rank/mobility.")
    p.add_argument("action", choices=("solve", "range", "info"))
    p.add_argument("mechanism", help="bundled mechanism name (slider_crank, hybrid_tripod_wrist, …) or file")
    p.add_argument("--pose", action="append", help="x,y,z,a,b,c in mm and degrees (planar x,y,phi); repeatable")
    p.add_argument("--drives", action="append", help="drive values in file order (mm / deg); repeatable")
    p.add_argument("--steps", type=int, default=1, help="continuation steps from home (default 1)")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    p.set_defaults(func=_cmd)
