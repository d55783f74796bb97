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

from pkmstiff.errors import ArgumentError, PkmstiffError
from pkmstiff.io.atomic import output_path, safe_stem
from pkmstiff.io.ranges import parse_names, parse_numbers




def _num(x: float) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _values(text: str, count: int, what: str, opt: str) -> list[float]:

    return parse_numbers(text, count, opt, what)


def _f6(v: float | None) -> str:
    """Six decimals; rounding noise below the last digit prints as 0.000000, not −0.000000."""
    return "-" if v is None else f"{v if abs(v) >= 5e-7 else 0.0:.6f}"


def _unit_scale(unit: str) -> tuple[str, float]:
    return ("mm", 1e3) if unit == "m" else ("deg", 180.0 / math.pi)


def _load(name: str):
    from pkmstiff.mechanisms import load_mechanism

    return load_mechanism(name)


def _pose_names(mech) -> tuple[tuple[str, str], ...]:
    return (("x", "mm"), ("y", "mm"), ("z", "mm"), ("a", "deg"), ("b", "deg"), ("c", "deg")) if mech.dim == 3 \
        else (("x", "mm"), ("y", "mm"), ("phi", "deg"))


def _parse_poses(mech, texts: list[str], opt: str) -> np.ndarray:
    """Poses (N, pose_size) in SI from ``x,y,z,a,b,c`` texts in mm and degrees."""
    names = _pose_names(mech)
    P = np.array([_values(p, len(names), ",".join(f"{n} [{u}]" for n, u in names), opt) for p in texts])
    return P * np.array([1e-3 if u == "mm" else math.pi / 180 for _, u in names])[None]


def _parse_drives(mech, texts: list[str], opt: str) -> np.ndarray:
    """Drive values (N, n_drives) in SI from texts in mm / degrees."""
    units = [_unit_scale(u) for u in mech.drive_units]
    D = np.array([_values(d, len(mech.drives), ",".join(f"{n} [{u}]" for n, (u, _) in zip(mech.drive_names, units)),
                          opt) for d in texts])
    return D / np.array([s for _, s in units])[None]


def _start_configuration(mech, start_pose: str | None, start_drives: str | None, steps: int):
    """The configuration to continue from (assembly/working mode): IK of ``--start-pose`` or FK of
    ``--start-drives`` (from home), or None (home)."""
    import pkmstiff.mechanisms as mm

    if start_pose and start_drives:
        raise ArgumentError("solve: give at most one of --start-pose and --start-drives")
    if start_pose:
        sol = mm.inverse(mech, _parse_poses(mech, [start_pose], "--start-pose"), steps=steps)
        opt, what = "--start-pose", start_pose
    elif start_drives:
        sol = mm.forward(mech, _parse_drives(mech, [start_drives], "--start-drives"), steps=steps)
        opt, what = "--start-drives", start_drives
    else:
        return None
    if not sol.ok[0]:
        raise ArgumentError(f"{opt}: expected a start the mechanism reaches from home, found {what} ({sol.status[0]})")
    return sol.q


def _links(mech, q: np.ndarray) -> dict[str, dict[str, float | None]]:
    """Link frames of one configuration: position (mm) and angles φ (deg, wrapped to (−180, 180])."""
    from pkmstiff.mechanisms.model import COORDINATES

    D = mech.dim
    out = {}
    for li, ln in enumerate(mech.links):
        v = q[li].copy()
        v[D:] = (v[D:] + math.pi) % (2.0 * math.pi) - math.pi
        out[ln] = {f"{c}_{'mm' if i < D else 'deg'}": _num(v[i] * (1e3 if i < D else 180.0 / math.pi))
                   for i, c in enumerate(COORDINATES[D])}
    return out


def solve_report(name: str, poses: list[str] | None = None, drives: list[str] | None = None,
                 steps: int = 1, start_pose: str | None = None, start_drives: str | None = None) -> dict[str, Any]:
    """Everything ``pkmstiff mechanism solve`` prints, as a JSON-ready dict."""
    import pkmstiff.mechanisms as mm
    from pkmstiff.mechanisms.outputs import controlled_output_names

    mech = _load(name)
    units = [_unit_scale(u) for u in mech.drive_units]
    pose_names = _pose_names(mech)
    start = _start_configuration(mech, start_pose, start_drives, steps)
    results = []
    if poses:
        P = _parse_poses(mech, poses, "--pose")
        ev = mm.evaluate(mech, P, steps=steps, start=start)
        sol = ev.solution
        for i in range(len(P)):
            results.append({
                "status": str(sol.status[i]), "iterations": int(sol.iterations[i]),
                "admissible": bool(ev.admissible[i]), "reasons": mm.reason_names(ev.reasons[i]),
                "violated_joints": [n for n, v in zip(ev.joint_names, ev.violated[i]) if v],
                "pose": {f"{n}_{u}": _num(v * (1e3 if u == "mm" else 180 / math.pi))
                         for (n, u), v in zip(pose_names, P[i])},
                "drives": {f"{d}_{u}": _num(v * s) for d, (u, s), v in zip(mech.drive_names, units, ev.drives[i])},
                "output_condition_number": _num(sol.output_kappa[i]),
                "links": _links(mech, sol.q[i]) if sol.ok[i] else None,
            })
    else:
        D = _parse_drives(mech, drives or [], "--drives")
        sol = mm.forward(mech, D, steps=steps, start=start)
        outp = sol.poses if mech.output is not None else np.full((len(D), len(pose_names)), np.nan)
        for i in range(len(D)):
            results.append({
                "status": str(sol.status[i]), "iterations": int(sol.iterations[i]),
                "residual": _num(sol.residual[i]),
                # the drive values of the configuration found (not the request: a wrong root would show here)
                "drives": {f"{d}_{u}": _num(v * s) for d, (u, s), v in zip(mech.drive_names, units, sol.drives[i])},
                "pose": {f"{n}_{u}": _num(v * (1e3 if u == "mm" else 180 / math.pi))
                         for (n, u), v in zip(pose_names, outp[i])},
                "output_condition_number": _num(sol.output_kappa[i]),
                "links": _links(mech, sol.q[i]) if sol.ok[i] else None,
            })
    return {"mechanism": mech.name, "mode": "inverse" if poses else "forward",
            "controlled_outputs": list(controlled_output_names(mech)), "results": results}


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
            "mobility": i.mobility, "drives": list(i.drives), "assumptions": mech.assumptions,
            "forward_path": i.forward_path}


def _announce_steps(args) -> None:
    """Refuse a continuation whose CPU time exceeds the time budget before it starts (cost line from 10,000 steps)."""
    from pkmstiff.cli.edges import announce, parse_budget
    from pkmstiff.evaluation.cost import MECHANISM_STEP_SECONDS, rows_cost

    steps = max(int(args.steps), 1)
    cost = rows_cost(steps, 0.0, MECHANISM_STEP_SECONDS, "continuation from home", "steps", "--steps")
    announce("mechanism", cost, parse_budget(None), quiet=args.json or steps < 10_000)


#: suffixes of the derivative columns of a drive-path file (per s, s², s³)
_RATE_SUFFIX = ("", "_per_s", "_per_s2", "_per_s3")


def read_drive_path(mech, path: str) -> tuple[np.ndarray, list[np.ndarray]]:
    """Times t (N,) [s] and drive values with their first three time derivatives [(N, n_drives)] ×4 (SI) of a
    drive-path CSV: columns ``t_s``, one per drive ``<name>_mm`` / ``<name>_deg``, optionally
    ``<name>_<unit>_per_s``, ``…_per_s2``, ``…_per_s3``; derivatives not given come from a quintic interpolating
    spline through the samples (scipy ``make_interp_spline``, degree ≤ 5, not above samples − 1)."""
    import csv
    from pathlib import Path

    p = Path(path)
    if not p.is_file():
        raise ArgumentError(f"--drives-file: expected a CSV file, found {path!r} (no such file)")
    with open(p, newline="", encoding="utf-8") as fh:
        rows = [r for r in csv.reader(fh) if r and any(c.strip() for c in r)]
    if len(rows) < 2:
        raise ArgumentError(f"{path}: expected a header and at least one sample row, found {len(rows)} line(s)")
    head = [c.strip() for c in rows[0]]
    units = [_unit_scale(u) for u in mech.drive_units]
    need = ["t_s"] + [f"{n}_{u}" for n, (u, _) in zip(mech.drive_names, units)]
    missing = [c for c in need if c not in head]
    if missing:
        raise ArgumentError(f"{path}: line 1: expected columns {', '.join(need)} (derivatives optional: "
                            f"<column>_per_s, _per_s2, _per_s3), found {', '.join(head)}; missing {', '.join(missing)}")
    data = np.empty((len(rows) - 1, len(head)))
    for i, r in enumerate(rows[1:], start=2):
        if len(r) != len(head):
            raise ArgumentError(f"{path}: line {i}: expected {len(head)} values, found {len(r)}")
        for c, v in enumerate(r):
            try:
                data[i - 2, c] = float(v)
            except ValueError:
                raise ArgumentError(f"{path}: line {i}, column {head[c]}: expected a number, found {v!r}") from None
            if not math.isfinite(data[i - 2, c]):
                raise ArgumentError(f"{path}: line {i}, column {head[c]}: expected a finite number, found {v!r}")
    t = data[:, head.index("t_s")]
    if np.any(np.diff(t) <= 0):
        i = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 3
        raise ArgumentError(f"{path}: line {i}, column t_s: expected strictly increasing times [s], found "
                            f"{t[i - 2]:g} after {t[i - 3]:g}")
    out = [np.empty((t.size, len(units))) for _ in range(4)]
    for c, (n, (u, scale)) in enumerate(zip(mech.drive_names, units)):
        cols = [f"{n}_{u}{suf}" for suf in _RATE_SUFFIX]
        if all(col in head for col in cols):
            for k, col in enumerate(cols):
                out[k][:, c] = data[:, head.index(col)] / scale
            continue
        if t.size < 2:
            raise ArgumentError(f"{path}: column {cols[1]}: expected the rates (and _per_s2, _per_s3) of a single "
                                "sample, or at least two samples to interpolate, found neither")
        from scipy.interpolate import make_interp_spline

        spl = make_interp_spline(t, data[:, head.index(cols[0])] / scale, k=min(5, t.size - 1))
        for k in range(4):
            out[k][:, c] = spl(t, nu=k) if k <= spl.k else 0.0
    return t, out


def path_report(name: str, drives_file: str, start_pose: str | None = None,
                start_drives: str | None = None) -> tuple[dict[str, Any], list[list[str]]]:
    """``pkmstiff mechanism path``: positions, velocities, accelerations and jerk of the output pose (and status)
    along a drive path (patent claim 9, :func:`pkmstiff.mechanisms.path.path_derivatives`); returns the JSON-ready
    summary and the CSV rows (header first)."""
    import pkmstiff.mechanisms as mm
    from pkmstiff.mechanisms.modes import signature
    from pkmstiff.mechanisms.path import path_derivatives
    from pkmstiff.mechanisms.section import mode_status

    mech = _load(name)
    t, sv = read_drive_path(mech, drives_file)
    start = _start_configuration(mech, start_pose, start_drives, 1)
    # the path is followed sample after sample (each solve starts from the previous configuration found in the start's
    # working and assembly mode; a sample whose configuration flipped into another is ``other_mode``)
    start_sig, ref = signature(mech, mm.home(mech) if start is None else start)[0], None
    q = []
    for i in range(t.size):
        sol_i = mm.forward(mech, sv[0][i:i + 1], start=start)
        sol_i.status, ref = mode_status(mech, sol_i, start_sig, ref)
        q.append(sol_i)
        if sol_i.ok[0]:
            start = sol_i.q
    status = np.array([s.status[0] for s in q])
    sol = mm.Solution(mech, np.concatenate([s.q for s in q]), status, np.concatenate([s.iterations for s in q]),
                      np.concatenate([s.residual for s in q]), np.concatenate([s.rank for s in q]), q[0].n_free,
                      np.concatenate([s.rcond for s in q]), np.concatenate([s.sigma_ratio for s in q]),
                      np.concatenate([s.output_kappa for s in q]))
    pd = path_derivatives(mech, *sv, solution=sol)
    units = [_unit_scale(u) for u in mech.drive_units]
    header = ["t_s", "status"] + [f"{n}_{u}" for n, (u, _) in zip(mech.drive_names, units)]
    pose_names = _pose_names(mech) if mech.output is not None else ()
    for k in range(4):
        header += [f"{n}_{u}{_RATE_SUFFIX[k]}" for n, u in pose_names]
    rows = [header]
    for i in range(t.size):
        row = [f"{t[i]:.9g}", str(status[i])] + [f"{v * s:.9g}" for v, (_, s) in zip(sv[0][i], units)]
        for k in range(4):
            row += ["" if not np.isfinite(v) else f"{v * (1e3 if u == 'mm' else 180 / math.pi):.9g}"
                    for v, (_, u) in zip(pd.pose[k, i] if pd.pose is not None else [], pose_names)]
        rows.append(row)
    peak = {}
    if pd.pose is not None:
        for k, what in ((1, "velocity"), (2, "acceleration"), (3, "jerk")):
            lin = np.nanmax(np.linalg.norm(pd.point[k], axis=-1)) * 1e3 if np.isfinite(pd.point[k]).any() else None
            peak[f"max_point_{what}_mm_per_s{'' if k == 1 else k}"] = _num(lin) if lin is not None else None
    rep = {"mechanism": mech.name, "samples": int(t.size), "t_s": [float(t[0]), float(t[-1])],
           "status": {s_: int(np.sum(status == s_)) for s_ in mm.STATUS if np.any(status == s_)}, **peak}
    return rep, rows


def _write_csv(rows: list[list[str]], path: str) -> None:
    """The rows as CSV, written atomically (whole file or none)."""
    import csv

    from pkmstiff.io.atomic import atomic_open

    with atomic_open(path, "w", newline="", encoding="utf-8") as fh:
        csv.writer(fh).writerows(rows)


def _cmd(args) -> int:
    try:
        if args.action == "solve":
            if bool(args.pose) == bool(args.drives):
                raise ArgumentError("solve: give either --pose (inverse kinematics) or --drives (forward kinematics)")
            if args.steps < 1:
                raise ArgumentError(f"--steps: expected a positive number of continuation steps, found {args.steps}")
            _announce_steps(args)
            rep = solve_report(args.mechanism, args.pose, args.drives, args.steps, args.start_pose,
                               args.start_drives)
        elif args.action == "path":
            if not args.drives_file:
                raise ArgumentError("path: expected --drives-file FILE.csv (columns t_s and the drive names)")
            from pkmstiff.cli.edges import check_output_file

            check_output_file(args.out, "--out", args.force, (".csv",))
            rep, rows = path_report(args.mechanism, args.drives_file, args.start_pose, args.start_drives)
            if args.out:
                _write_csv(rows, args.out)
                rep["files"] = [args.out]
        elif args.action == "range":
            rep = range_report(args.mechanism)
        else:
            rep = info_report(args.mechanism)
    except PkmstiffError as exc:
        raise ArgumentError(str(exc)) from None
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
        if rep["forward_path"] == "length_legs":
            print("  forward kinematics: Newton on the output link's 6 coordinates, legs in closed form")
    elif args.action == "path":
        st = ", ".join(f"{k} {v}" for k, v in rep["status"].items())
        print(f"{rep['mechanism']}: {rep['samples']} samples, t = {rep['t_s'][0]:g} .. {rep['t_s'][1]:g} s: {st}")
        for k, v in rep.items():
            if k.startswith("max_point_"):
                what, unit = k[len("max_point_"):].split("_", 1)
                print(f"  max |{what}| of the output point: {'-' if v is None else f'{v:.6g}'} "
                      f"{unit.replace('_per_', '/').replace('s2', 's^2').replace('s3', 's^3')}")
        for f in rep.get("files", []):
            print(f"  wrote {f}")
    elif args.action == "range":
        for d, r in rep["drives"].items():
            lo = "-inf" if r["min"] is None else f"{r['min']:.6f}"
            hi = "inf" if r["max"] is None else f"{r['max']:.6f}"
            print(f"{d}: {lo} .. {hi} {r['unit']} (ends: {r['min_end']}, {r['max_end']})")
    else:
        for i, r in enumerate(rep["results"]):
            dr = ", ".join(f"{k} = {_f6(v)}" for k, v in r["drives"].items())
            ps = ", ".join(f"{k} = {_f6(v)}" for k, v in r["pose"].items())
            extra = ""
            if "admissible" in r:
                extra = f", admissible {r['admissible']}" + (f" ({', '.join(r['reasons'])})" if r["reasons"] else "")
            k = r["output_condition_number"]
            kap = "" if not rep["controlled_outputs"] else \
                f"\n    condition number of the controlled outputs ({', '.join(rep['controlled_outputs'])}): " \
                f"{'inf' if k is None else f'{k:.4g}'}"
            print(f"[{i}] {r['status']}{extra}\n    drives: {dr}\n    pose: {ps}{kap}")
            if args.links and r["links"]:
                for ln, v in r["links"].items():
                    print(f"    link {ln}: " + ", ".join(f"{c.rsplit('_', 1)[0]} = {_f6(x)} {c.rsplit('_', 1)[1]}"
                                                         for c, x in v.items()))
    if args.action == "solve":
        _refuse_unsolved(rep)
    return 0


def _refuse_unsolved(rep: dict[str, Any]) -> None:
    """Exit status 3 (as ``point`` for an inadmissible pose) when a pose or drive set has no solution: the results
    are printed, the error line says which."""
    from pkmstiff.errors import InadmissibleError

    bad = [i for i, r in enumerate(rep["results"]) if r["status"] not in ("converged", "singular")]
    if bad:
        raise InadmissibleError(
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
    r.update({"condition_number": _num(kap), "joints": joints, "controlled_outputs": rep["controlled_outputs"]})
    return {"mechanism": mech.name, "title": mech.title, **r}


def print_pose(rep: dict[str, Any]) -> None:
    ps = ", ".join(f"{k.rsplit('_', 1)[0]}={v:.3f} {k.rsplit('_', 1)[1]}" for k, v in rep["pose"].items())
    print(f"{rep['mechanism']} (mechanism) at {ps}: {rep['status']} ({rep['iterations']} Newton steps)")
    dr = ", ".join(f"{k.rsplit('_', 1)[0]} = {'-' if v is None else f'{v:.3f}'} {k.rsplit('_', 1)[1]}"
                   for k, v in rep["drives"].items())
    print(f"drives: {dr}")
    k = rep["condition_number"]
    print(f"condition number of dx/ds: {'inf' if k is None else f'{k:.4g}'}")
    k = rep["output_condition_number"]
    if rep["controlled_outputs"]:
        print(f"condition number of the controlled outputs ({', '.join(rep['controlled_outputs'])}): "
              f"{'inf' if k is None else f'{k:.4g}'}")
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

    from pkmstiff.errors import ArgumentError
    from pkmstiff.io.ranges import parse_ranges, parse_triple_deg
    from pkmstiff.mechanisms.section import check_quantities, evaluate_section, fit_window, quantity_names
    from pkmstiff.mechanisms.stiffness import tool_point
    from pkmstiff.report.mechanism_section import section_where, write_mechanism_section

    mech = _load(args.machine)
    plane = (args.plane or ("xy" if mech.dim == 2 else "yz")).lower()  # a planar mechanism: its plane of motion
    if mech.dim == 2 and plane != "xy":
        raise ArgumentError(f"--plane: mechanism '{mech.name}' is planar (it moves in the xy plane): expected xy, "
                            f"found {plane}")
    for opt, given in (("--require", bool(args.require)),
                       ("--frame", args.frame != "machine"), ("--neglect-spindle", args.neglect_spindle),
                       ("--skip-check", bool(args.skip_check))):
        if given:
            raise ArgumentError(f"{opt}: not available for a mechanism ('{mech.name}'): a mechanism section has the "
                                f"quantities {', '.join(quantity_names(mech))}")
    ranges = parse_ranges(args.range, plane) if args.range else None
    ori = parse_triple_deg(args.orientation, "--orientation")
    if not (args.step > 0 and math.isfinite(args.step)):
        raise ArgumentError(f"--step: expected a positive step in mm, found {args.step}")
    if not math.isfinite(args.at):
        raise ArgumentError(f"--at: expected a finite position in mm, found {args.at}")
    names = parse_names(args.quantities, "--quantities")
    formats = parse_names(args.formats, "--formats", ("png", "vtu", "csv", "npz"))
    step, at = args.step * 1e-3, args.at * 1e-3
    if args.tool_length is not None:
        from pkmstiff.cli.point import check_point_options

        check_point_options(args.tool_length, 0)
        if mech.elastic is None:
            raise ArgumentError(f"--tool-length: mechanism '{mech.name}' has no [elastic] table (the tool length "
                                "moves the point of the stiffness quantities)")
    tip = tool_point(mech, args.tool_length) if mech.elastic is not None else None
    start = _start_configuration(mech, args.start_pose, None, 1)  # None: home's working mode
    stem = f"{safe_stem(mech.name)}_{plane}"
    from pkmstiff.cli.edges import check_output_dir

    outs = ([f"{stem}_{n}.png" for n in names] + [f"{stem}_admissibility.png"] if "png" in formats else []) \
        + [f"{stem}.{f}" for f in ("csv", "npz") if f in formats] + ([f"{stem}.json"] if "csv" in formats else [])
    check_output_dir(args.out, "--out", getattr(args, "force", False), tuple(outs))
    t0 = time.process_time()
    try:
        check_quantities(mech, names)
        fitted = ranges is None
        if fitted:
            (u0, u1), (v0, v1) = fit_window(mech, plane, at, ori, step, start=None if start is None else start[0])
        else:
            (u0, u1), (v0, v1) = ranges[plane[0]], ranges[plane[1]]
        n_points = (int((u1 - u0) / step + 1e-9) + 1) * (int((v1 - v0) / step + 1e-9) + 1)
        if n_points > SECTION_MAX_POINTS:
            raise ArgumentError(f"--step: {n_points} raster points, expected at most {SECTION_MAX_POINTS} for a "
                                f"mechanism section (a larger step or a smaller --range)")
        sec = evaluate_section(mech, plane, at, (u0, u1), (v0, v1), step, ori, names, tip,
                               None if start is None else start[0])
        if tip is not None:
            sec.settings["tool_length_mm"] = float(args.tool_length)
    except PkmstiffError as exc:
        raise ArgumentError(str(exc)) from None
    cpu = time.process_time() - t0
    where = section_where(mech, plane, args.at, ori, args.tool_length if tip is not None else None)
    if start is not None:  # validated by _start_configuration
        where["start_pose_mm_deg"] = [float(v) for v in args.start_pose.split(",")]
    files = write_mechanism_section(sec, Path(args.out), stem, formats, where) if args.out else []
    stats = sec.statistics()
    return {**where,
            "window_mm": {plane[0]: [u0 * 1e3, sec.u_values[-1] * 1e3], plane[1]: [v0 * 1e3, sec.v_values[-1] * 1e3]},
            "window_fitted_to_workspace": fitted, "points": int(sec.ok.size),
            "admissible_points": int(sec.ok.sum()), "admissible_area_m2": float(sec.ok.sum()) * sec.cell_area,
            "statistics": stats, "inadmissible_reasons": {k: v for k, v in sec.reason_counts().items() if v},
            "cpu_seconds": cpu, "files": [str(p) for p in files]}


def print_section(rep: dict[str, Any]) -> None:
    """The text output of a mechanism section (no timings: the lines are reproducible)."""
    win = ", ".join(f"{a} {lo:g}..{hi:g} mm" for a, (lo, hi) in rep["window_mm"].items())
    where = "plane of motion" if rep["at_mm"] is None else \
        f"{rep['plane']} plane at {({'x', 'y', 'z'} - set(rep['plane'])).pop()} = {rep['at_mm']:g} mm"
    ori = ",".join(f"{a:g}" for a in rep["orientation_deg"])
    tool = f", tool {rep['tool_length_mm']:g} mm" if "tool_length_mm" in rep else ""
    if "start_pose_mm_deg" in rep:
        tool += f", working mode of the pose {','.join(f'{v:g}' for v in rep['start_pose_mm_deg'])}"
    print(f"{rep['mechanism']} (mechanism): {where}, orientation {ori} deg{tool}, window {win}"
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
    p.add_argument("action", choices=("solve", "path", "range", "info"))
    p.add_argument("mechanism", help="bundled mechanism name (slider_crank, hybrid_tripod_wrist, …) or file")
    p.add_argument("--pose", action="append", help="x,y,z,a,b,c in mm and degrees (planar x,y,phi); repeatable")
    p.add_argument("--drives", action="append", help="drive values in file order (mm / deg); repeatable")
    p.add_argument("--steps", type=int, default=1,
                   help="continuation steps from home or the start (default 1; steps that change an angle by more "
                        "than 15 deg or a length by more than 1/4 of the mechanism's size are subdivided)")
    p.add_argument("--start-pose", help="solve from the configuration of this pose (x,y,z,a,b,c mm/deg) instead of "
                                        "home: chooses the assembly/working mode")
    p.add_argument("--start-drives", help="solve from the configuration of these drive values (mm/deg) instead of "
                                          "home: chooses the assembly/working mode")
    p.add_argument("--drives-file", help="path: CSV of a drive path (columns t_s, <drive>_mm or <drive>_deg, "
                                         "optionally <column>_per_s, _per_s2, _per_s3)")
    p.add_argument("--out", help="path: CSV of pose, velocity, acceleration and jerk per sample")
    p.add_argument("--force", action="store_true", help="overwrite --out")
    p.add_argument("--links", action="store_true",
                   help="also print every link frame (position mm, angles phi_x, phi_y, phi_z deg, R = Rz Ry Rx)")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    p.set_defaults(func=_cmd)


def _elastic_mechanism(name: str, unavailable: dict[str, bool]):
    """The mechanism ``name`` if it has elastic data and no machine-only option was given (else one line, exit 2)."""
    mech = _load(name)
    for opt, given in unavailable.items():
        if given:
            raise ArgumentError(f"{opt}: not available for a mechanism ('{mech.name}'): the stiffness is evaluated at "
                                "the output point of the mechanism file")
    if mech.elastic is None:
        raise ArgumentError(f"mechanism '{mech.name}' has no [elastic] table: no stiffness model (see "
                            "docs/user-guide/mechanisms.md, elastic model)")
    return mech


def point_rows(name: str, poses_si: np.ndarray, n_modes: int, unavailable: dict[str, bool],
               tool_length_mm: float | None = None) -> tuple[list[str], list[list]]:
    """``pkmstiff point MECHANISM --poses FILE``: the machines' CSV columns (pose mm/deg, admissible, reasons,
    k_x, k_y, k_z N/µm, f1… Hz); empty result cells where a pose is inadmissible or not modelled."""
    from pkmstiff.mechanisms import evaluate, inverse, reason_names
    from pkmstiff.mechanisms.section import mode_filter
    from pkmstiff.mechanisms.stiffness import evaluate_mechanism, take, tool_point
    from pkmstiff.mechanisms.structure import STATUS_BITS

    mech = _elastic_mechanism(name, unavailable)
    if mech.dim != 3:
        raise ArgumentError(f"--poses: a file of x,y,z,a,b,c poses is for spatial mechanisms; '{mech.name}' is planar "
                            "(use --pose x,y,phi)")
    tip = tool_point(mech, tool_length_mm)
    ev = evaluate(mech, poses_si, solution=mode_filter(mech, inverse(mech, poses_si)))  # in home's working mode
    ok = np.flatnonzero(ev.admissible)
    n = len(poses_si)
    k = np.full((n, 3), np.nan)
    f = np.full((n, n_modes), np.nan)
    status = np.zeros(n, np.uint8)
    if ok.size:
        res = evaluate_mechanism(mech, take(ev.solution, ok), n_modes, point=tip)
        k[ok], f[ok], status[ok] = res.stiffness[:, :3] / 1e6, res.frequencies_hz, res.status
    head = ["x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg", "admissible", "reasons", "kx_N_per_um",
            "ky_N_per_um", "kz_N_per_um"] + [f"f{i + 1}_Hz" for i in range(n_modes)]
    pose_out = np.column_stack([poses_si[:, :3] * 1e3, np.rad2deg(poses_si[:, 3:])])
    rows = []
    for i in range(n):
        why = [r.lower().replace("_", " ") for r in reason_names(int(ev.reasons[i]))]
        why += [b.lower().replace("_", " ") for b, bit in STATUS_BITS.items() if int(status[i]) & bit]
        rows.append([*pose_out[i], bool(ev.admissible[i]), "; ".join(why), *k[i], *f[i]])
    return head, rows


def _solve_point(mech, pose: np.ndarray, start_pose: str | None):
    """The configuration of ``point`` at one pose: that of a section at the same point, in the working mode of home
    or of ``--start-pose`` (:func:`pkmstiff.mechanisms.section.solve_in_mode`)."""
    from pkmstiff.mechanisms.section import solve_in_mode

    start = _start_configuration(mech, start_pose, None, 1)
    return solve_in_mode(mech, pose, None if start is None else start[0])


def point_report(name: str, pose_text: str, n_modes: int, allow_inadmissible: bool,
                 unavailable: dict[str, bool], tool_length_mm: float | None = None,
                 start_pose: str | None = None) -> dict[str, Any]:
    """``pkmstiff point MECHANISM --pose …``: the elastic model (issue 27) at one pose, as the machines' report
    (schema ``pkmstiff/point/1``: stiffness N/µm and N·m/µrad at the output point or the tool tip
    ``tool_length_mm`` along the tool axis, frequencies Hz, weak points %, kinetostatics of
    :mod:`pkmstiff.mechanisms.kinetostatics`). A planar mechanism reports x, y (and the rotation about z) only.
    ``unavailable``: machine-only options given; ``start_pose``: the pose (mm, deg) whose working mode is kept
    (default home)."""
    import pkmstiff.multibody as sde
    from pkmstiff.cli.point import SCHEMA, STIFFNESS_MATRIX_UNITS, _num, _refuse
    from pkmstiff.mechanisms import evaluate, reason_names
    from pkmstiff.mechanisms.stiffness import evaluate_mechanism, tool_point
    from pkmstiff.mechanisms.structure import LABELS, STATUS_BITS, mechanism_structure

    mech = _elastic_mechanism(name, unavailable)
    tip = tool_point(mech, tool_length_mm)
    pose = _parse_poses(mech, [pose_text], "--pose")
    ev = evaluate(mech, pose, solution=_solve_point(mech, pose, start_pose))
    reasons = reason_names(int(ev.reasons[0]))
    names = _pose_names(mech)
    pose_out = {f"{n}_{u}": float(v * (1e3 if u == "mm" else 180 / math.pi)) for (n, u), v in zip(names, pose[0])}
    if reasons and not allow_inadmissible:
        raise _refuse(mech.name, ", ".join(f"{n} = {v:g} {u}" for (n, u), v in
                                           zip(names, pose_out.values())), [r.lower().replace("_", " ")
                                                                            for r in reasons])
    ms = mechanism_structure(mech, solution=ev.solution, point=tip) if ev.solution.ok[0] else None
    if ms is not None and ms.model is not None:  # at most the dynamic DOFs (massless and bound ones excluded)
        n_modes = min(n_modes, sde.dynamic_dofs(ms.model))
    axes = "xyz"[:mech.dim]  # a planar mechanism has no z stiffness, no z weak points
    res = evaluate_mechanism(mech, ev.solution, n_modes, tuple(axes), point=tip)
    comp = res.compliance[0]
    rot = ms is not None and ms.model is not None and isinstance(ms.model.body(ms.load_body), sde.RigidBody)
    rep: dict[str, Any] = {
        "schema": SCHEMA, "machine": mech.name, "machine_type": "mechanism" if mech.dim == 3 else "planar mechanism",
        "frame": "machine", "frame_origin_mm": [0.0, 0.0, 0.0], "pose": pose_out,
        "admissible": not reasons, "reasons": [r.lower().replace("_", " ") for r in reasons],
        "analysed_although_inadmissible": bool(reasons),
    }
    if tip is not None:
        rep["tool_length_mm"] = float(tool_length_mm)
    rep.update({
        "modelled": bool(res.ok[0]), "model_reasons": [k.lower().replace("_", " ") for k, b in STATUS_BITS.items()
                                                       if int(res.status[0]) & b],
        "model": {"bodies": [] if ms is None else ms.model.body_names, "dof": 0 if ms is None else ms.model.n_dof,
                  "constraints": 0 if ms is None else ms.model.n_constraints,
                  "tcp_body": "" if ms is None else ms.load_body},
        "drives": {f"{n}_{'mm' if u == 'm' else 'deg'}": _num(v * (1e3 if u == "m" else 180 / math.pi))
                   for n, u, v in zip(mech.drive_names, mech.drive_units, ev.drives[0])},
    })
    # the directions the model moves in: planar x, y (and the rotation about z); spatial 6 or 3 (a point mass)
    dirs = ([0, 1] + ([5] if rot else [])) if mech.dim == 2 else list(range(6 if rot else 3))
    dirs = [d for d in dirs if not comp[d, d] == 0.0]  # a direction held rigidly (bipod_generic's rotation): no K
    sub = comp[np.ix_(dirs, dirs)]
    rep["stiffness_matrix_SI"] = _num(np.linalg.inv(sub)) if np.all(np.isfinite(sub)) else None
    labels = ("x", "y", "z", "rx", "ry", "rz")
    rep["stiffness_matrix_SI_units"] = (STIFFNESS_MATRIX_UNITS if rot and mech.dim == 3 else
                                        f"N/m, N/rad, N*m/rad over ({', '.join(labels[i] for i in dirs)})")
    rep["k_N_per_um"] = {ax: _num(res.stiffness[0, i] / 1e6) for i, ax in enumerate(axes)}
    if rot:
        rep["rotational_stiffness_Nm_per_urad"] = {ax: _num(res.stiffness[0, 3 + i] / 1e6) for i, ax in
                                                   enumerate("xyz") if mech.dim == 3 or ax == "z"}
    rep["weak_points_percent"] = {dd: {lab: _num(100 * res.shares[dd][0, j]) for j, lab in enumerate(LABELS)}
                                  for dd in axes}
    rep["frequencies_Hz"] = _num(res.frequencies_hz[0]) if n_modes else []
    rep["mode_descriptions"] = []
    if n_modes and rot and res.ok[0]:
        mr = sde.modes(ms.model, n_modes, shapes=True)
        idx, share = sde.describe_modes(ms.model, mr.shapes, ms.output_body)
        rep["mode_descriptions"] = [sde.mode_label(idx[0, k], share[0, k]) for k in range(n_modes)]
    rep.update(_kinetostatics_report(mech, ev.solution))
    return rep


def _kinetostatics_report(mech, sol) -> dict[str, Any]:
    """The machines' kinetostatic keys of ``point`` for a mechanism (:mod:`pkmstiff.mechanisms.kinetostatics`);
    static loads of rotary drives in N·m (``static_drive_torques_Nm``, null for linear drives and vice versa)."""
    from pkmstiff.cli.point import _drive, _num
    from pkmstiff.mechanisms.kinetostatics import mechanism_kinetostatics

    ks = mechanism_kinetostatics(mech, sol)
    loads = ks.drive_loads[0]
    out = {"transmission_quality": _num(ks.transmission_quality[0]), "transmission_weight_m_per_rad": ks.weight,
           "controlled_outputs": list(ks.outputs),
           "v_max_m_per_s": {lab: _num(ks.v_max[0, i]) for i, lab in enumerate(ks.velocity_labels)},
           "v_max_m_per_min": {lab: _num(ks.v_max[0, i] * 60) for i, lab in enumerate(ks.velocity_labels)},
           "v_limiting_drive": {lab: _drive(ks.v_limiting[0, i]) for i, lab in enumerate(ks.velocity_labels)},
           "a_max_m_per_s2": {lab: _num(ks.a_max[0, i]) for i, lab in enumerate(ks.acceleration_labels)},
           "a_limiting_drive": {lab: _drive(ks.a_limiting[0, i]) for i, lab in enumerate(ks.acceleration_labels)},
           "a_infeasible": {lab: bool(ks.a_infeasible[0, i]) for i, lab in enumerate(ks.acceleration_labels)},
           "static_drive_loads_N": _num(np.where(ks.rotary, np.nan, loads)),
           "notes": ks.notes}
    if ks.rotary.any():
        out["static_drive_torques_Nm"] = _num(np.where(ks.rotary, loads, np.nan))
    return out


def mode_figures(name: str, pose_text: str, n_modes: int, out: str, names: tuple[str, ...],
                 tool_length_mm: float | None = None, start_pose: str | None = None) -> list:
    """``pkmstiff point MECHANISM --figures DIR``: one mode-shape PNG per mode (``names``) of the elastic model at
    the pose (:func:`pkmstiff.plots.mechanism.mechanism_mode_figure`)."""
    from pathlib import Path

    from pkmstiff.mechanisms.modeshape import mode_shapes
    from pkmstiff.mechanisms.stiffness import tool_point
    from pkmstiff.plots.mechanism import mechanism_mode_figure

    mech = _elastic_mechanism(name, {})
    pose = _parse_poses(mech, [pose_text], "--pose")
    sol = _solve_point(mech, pose, start_pose)
    if not sol.ok[0]:
        return []
    where = ", ".join(f"{n} = {v * (1e3 if u == 'mm' else 180 / math.pi):g} {u}"
                      for (n, u), v in zip(_pose_names(mech), pose[0]))
    files = []
    for ms in mode_shapes(mech, sol, n_modes, tool_point(mech, tool_length_mm)):
        title = (f"{mech.name}: mode {ms.mode}, {ms.frequency_hz:.2f} Hz"
                 + (f", {ms.description}" if ms.description else "") + f"\npose {where}")
        files.append(mechanism_mode_figure(mech, ms, output_path(Path(out), names[ms.mode - 1]), title))
    return files
