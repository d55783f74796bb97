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
from pkmstiff.io.atomic import atomic_open, atomic_path, output_path, safe_stem
from pkmstiff.io.columns import column_name
from pkmstiff.io.ranges import parse_names, parse_numbers



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


def _announce_steps(args) -> None:
    """Refuse a continuation whose CPU time exceeds the time budget before it starts (cost line from 10,000 steps)."""
    from pkmstiff.cli.edges import announce, parse_budget
    from pkmstiff.evaluation.cost import MECHANISM_STEP_SECONDS, rows_cost

    steps = max(int(args.steps), 1)
    cost = rows_cost(steps, 0.0, MECHANISM_STEP_SECONDS, "continuation from home", "steps", "--steps")
    announce("mechanism", cost, parse_budget(None), quiet=args.json or steps < 10_000)


def _cmd(args) -> int:
    try:
        if args.action == "solve":
            if bool(args.pose) == bool(args.drives):
                raise _cli_error("solve: give either --pose (inverse kinematics) or --drives (forward kinematics)")
            if args.steps < 1:
                raise _cli_error(f"--steps: expected a positive number of continuation steps, found {args.steps}")
            _announce_steps(args)
            rep = solve_report(args.mechanism, args.pose, args.drives, args.steps)
        elif args.action == "range":
            rep = range_report(args.mechanism)
        else:
            rep = info_report(args.mechanism)
    except PkmstiffError as exc:
        raise _cli_error(str(exc)) from None
    if args.json:
        print(json.dumps(rep, indent=2))
        if args.action == "solve":
            _refuse_unsolved(rep)
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
    if args.action == "solve":
        _refuse_unsolved(rep)
    return 0


def _refuse_unsolved(rep: dict[str, Any]) -> None:
    """Exit status 3 (as ``point`` for an inadmissible pose) when a pose or drive set has no solution: the results
    are printed, the error line says which."""
    from pkmstiff.errors import InadmissiblePoseRefused

    bad = [i for i, r in enumerate(rep["results"]) if r["status"] not in ("converged", "singular")]
    if bad:
        raise InadmissiblePoseRefused(
            f"{rep['mechanism']}: no solution for {len(bad)} of {len(rep['results'])} "
            f"{'poses' if rep['mode'] == 'inverse' else 'drive sets'} (first [{bad[0]}]: "
            f"{rep['results'][bad[0]]['status']})")


def pose_report(name: str, pose_text: str) -> dict[str, Any]:
    """``pkmstiff pose MECHANISM --pose …``: the mechanism evaluated like a machine at one pose — status, drive
    values, condition number of ∂x/∂s, every limited joint's value against its limits, admissibility."""
    import pkmstiff.mechanisms as mm
    from pkmstiff.mechanisms.section import condition_numbers, kinematic_jacobian

    rep = solve_report(name, [pose_text])
    mech = _load(name)
    r = rep["results"][0]
    P = np.array([[v * (1e-3 if k.endswith("_mm") else math.pi / 180) for k, v in r["pose"].items()]])
    ev = mm.evaluate(mech, P)
    kap = condition_numbers(kinematic_jacobian(ev.solution))[0]
    joints = {}
    for i, jn in enumerate(ev.joint_names):
        jt = mech.joint(jn)
        u, s = _unit_scale("m" if jt.variable == "linear" else "rad")
        joints[jn] = {f"value_{u}": _num(ev.joint_values[0, i] * s), f"min_{u}": _num(jt.limits[0] * s),
                      f"max_{u}": _num(jt.limits[1] * s), "violated": bool(ev.violated[0, i])}
    r.update({"condition_number": _num(kap), "joints": joints})
    return {"mechanism": mech.name, "title": mech.title, **r}


def print_pose(rep: dict[str, Any]) -> None:
    ps = ", ".join(f"{k.rsplit('_', 1)[0]}={v:.3f} {k.rsplit('_', 1)[1]}" for k, v in rep["pose"].items())
    print(f"{rep['mechanism']} (mechanism) at {ps}: {rep['status']} ({rep['iterations']} Newton steps)")
    dr = ", ".join(f"{k.rsplit('_', 1)[0]} = {'-' if v is None else f'{v:.3f}'} {k.rsplit('_', 1)[1]}"
                   for k, v in rep["drives"].items())
    print(f"drives: {dr}")
    k = rep["condition_number"]
    print(f"condition number of dx/ds: {'inf' if k is None else f'{k:.4g}'}")
    for jn, j in rep["joints"].items():
        u = "mm" if "value_mm" in j else "deg"
        v, lo, hi = j[f"value_{u}"], j[f"min_{u}"], j[f"max_{u}"]
        lo_t = "-inf" if lo is None else f"{lo:g}"
        hi_t = "inf" if hi is None else f"{hi:g}"
        print(f"  joint {jn:<14} {'-' if v is None else f'{v:9.3f}'} {u}  limits {lo_t} .. {hi_t} {u}"
              f"{'  VIOLATED' if j['violated'] else ''}")
    if rep["admissible"]:
        print("admissible: yes")
    else:
        print("admissible: NO")
        for reason in rep["reasons"]:
            extra = f": {', '.join(rep['violated_joints'])}" if reason == "JOINT_LIMIT" else ""
            print(f"  - {reason}{extra}")


#: most raster points a mechanism section evaluates (each is an inverse kinematics by continuation from home)
SECTION_MAX_POINTS = 200_000


def section_report(args) -> dict[str, Any]:
    """``pkmstiff section MECHANISM …``: kinematic quantities and joint-limit admissibility on a plane, files
    written to ``--out``; returns the JSON-ready summary (lengths mm, angles deg, areas m²)."""
    import time
    from pathlib import Path

    from pkmstiff.errors import SectionArgumentError, SectionError
    from pkmstiff.io.ranges import parse_ranges, parse_triple_deg
    from pkmstiff.mechanisms.section import evaluate_section, fit_window, quantity_names

    mech = _load(args.machine)
    plane = args.plane.lower()
    for opt, given in (("--tool-length", args.tool_length is not None), ("--require", bool(args.require)),
                       ("--frame", args.frame != "machine"), ("--neglect-spindle", args.neglect_spindle),
                       ("--skip-check", bool(args.skip_check))):
        if given:
            raise _cli_error(f"{opt}: not available for a mechanism ('{mech.name}'): a mechanism section has the "
                             f"kinematic quantities {', '.join(quantity_names(mech))}")
    try:
        ranges = parse_ranges(args.range, plane) if args.range else None
        ori = parse_triple_deg(args.orientation, "--orientation")
    except (SectionArgumentError, SectionError, PkmstiffError) as exc:
        raise _cli_error(str(exc)) from None
    if not (args.step > 0 and math.isfinite(args.step)):
        raise _cli_error(f"--step: expected a positive step in mm, found {args.step}")
    if not math.isfinite(args.at):
        raise _cli_error(f"--at: expected a finite position in mm, found {args.at}")
    try:
        names = parse_names(args.quantities, "--quantities")
        formats = parse_names(args.formats, "--formats", ("png", "vtu", "csv", "npz"))
    except PkmstiffError as exc:
        raise _cli_error(str(exc)) from None
    step, at = args.step * 1e-3, args.at * 1e-3
    stem = f"{safe_stem(mech.name)}_{plane}"
    from pkmstiff.cli.edges import check_output_dir

    outs = ([f"{stem}_{n}.png" for n in names] + [f"{stem}_admissibility.png"] if "png" in formats else []) \
        + [f"{stem}.{f}" for f in ("csv", "npz") if f in formats]
    check_output_dir(args.out, "--out", getattr(args, "force", False), tuple(outs))
    if mech.dim == 2 and plane != "xy":
        raise _cli_error(f"--plane: mechanism '{mech.name}' is planar, its section plane is xy, found {plane}")
    t0 = time.process_time()
    try:
        known = quantity_names(mech)
        unknown = [n for n in names if n not in known]
        if unknown:
            raise _cli_error(f"--quantities: expected names from {', '.join(known)} for mechanism '{mech.name}', "
                             f"found {', '.join(unknown)}")
        fitted = ranges is None
        if fitted:
            (u0, u1), (v0, v1) = fit_window(mech, plane, at, ori, step)
        else:
            (u0, u1), (v0, v1) = ranges[plane[0]], ranges[plane[1]]
        n_points = (int((u1 - u0) / step + 1e-9) + 1) * (int((v1 - v0) / step + 1e-9) + 1)
        if n_points > SECTION_MAX_POINTS:
            raise _cli_error(f"--step: {n_points} raster points, expected at most {SECTION_MAX_POINTS} for a "
                             f"mechanism section (a larger step or a smaller --range)")
        sec = evaluate_section(mech, plane, at, (u0, u1), (v0, v1), step, ori, names)
    except PkmstiffError as exc:
        raise _cli_error(str(exc)) from None
    cpu = time.process_time() - t0
    files = _write_section(sec, Path(args.out), stem, formats) if args.out else []
    stats = sec.statistics()
    return {"mechanism": mech.name, "plane": plane, "at_mm": None if mech.dim == 2 else args.at,
            "orientation_deg": [float(np.degrees(a)) for a in ori],
            "window_mm": {plane[0]: [u0 * 1e3, sec.u_values[-1] * 1e3], plane[1]: [v0 * 1e3, sec.v_values[-1] * 1e3]},
            "window_fitted_to_workspace": fitted, "points": int(sec.ok.size),
            "admissible_points": int(sec.ok.sum()), "admissible_area_m2": float(sec.ok.sum()) * sec.cell_area,
            "statistics": stats, "inadmissible_reasons": {k: v for k, v in sec.reason_counts().items() if v},
            "cpu_seconds": cpu, "files": [str(p) for p in files]}


def _write_section(sec, out, stem: str, formats: list[str]) -> list:
    """PNG maps (each quantity and the admissibility reasons), CSV and NPZ of a mechanism section in ``out``."""
    import csv

    paths = []
    out.mkdir(parents=True, exist_ok=True)
    if "png" in formats:
        from pkmstiff.plots.mechanism_section import plot_mechanism_quantity, plot_mechanism_reasons

        paths += [plot_mechanism_quantity(sec, n, output_path(out, f"{stem}_{n}.png")) for n in sec.values]
        paths.append(plot_mechanism_reasons(sec, output_path(out, f"{stem}_admissibility.png")))
    U, V = np.meshgrid(sec.u_values, sec.v_values)
    u, v = sec.plane[0], sec.plane[1]
    if "csv" in formats:
        p = output_path(out, f"{stem}.csv")
        with atomic_open(p, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow([f"{u}_mm", f"{v}_mm", "status", "reasons", "admissible"]
                       + [column_name(n, sec.units[n]) for n in sec.values])
            cols = [sec.display(n).ravel() for n in sec.values]
            for i in range(U.size):
                w.writerow([f"{U.flat[i] * 1e3:.6g}", f"{V.flat[i] * 1e3:.6g}", sec.status.flat[i],
                            int(sec.reasons.flat[i]), int(sec.ok.flat[i])]
                           + ["" if not np.isfinite(c[i]) else f"{c[i]:.6g}" for c in cols])
        paths.append(p)
    if "npz" in formats:
        p = output_path(out, f"{stem}.npz")
        with atomic_path(p) as tmp:
            np.savez_compressed(tmp, **{f"{u}_mm": sec.u_values * 1e3, f"{v}_mm": sec.v_values * 1e3,
                                        "reasons": sec.reasons, "admissible": sec.ok},
                                **{column_name(n, sec.units[n]): sec.display(n) for n in sec.values})
        paths.append(p)
    return paths


def print_section(rep: dict[str, Any]) -> None:
    """The text output of a mechanism section (no timings: the lines are reproducible)."""
    win = ", ".join(f"{a} {lo:g}..{hi:g} mm" for a, (lo, hi) in rep["window_mm"].items())
    where = "plane of motion" if rep["at_mm"] is None else \
        f"{rep['plane']} plane at {({'x', 'y', 'z'} - set(rep['plane'])).pop()} = {rep['at_mm']:g} mm"
    ori = ",".join(f"{a:g}" for a in rep["orientation_deg"])
    print(f"{rep['mechanism']} (mechanism): {where}, orientation {ori} deg, window {win}"
          f"{' (fitted)' if rep['window_fitted_to_workspace'] else ''}: {rep['admissible_points']} of "
          f"{rep['points']} points admissible ({rep['admissible_area_m2']:.4g} m²)")
    for n, st in rep["statistics"].items():
        if st["count"]:
            print(f"  {n:<16} [{st['unit']}]  min {st['min']:.4g}  mean {st['mean']:.4g}  max {st['max']:.4g}")
        else:
            print(f"  {n:<16} [{st['unit']}]  no admissible point")
    if rep["inadmissible_reasons"]:
        print("  inadmissible points by reason: "
              + ", ".join(f"{k} {v}" for k, v in rep["inadmissible_reasons"].items()))
    for p in rep["files"]:
        print(f"  wrote {p}")


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
