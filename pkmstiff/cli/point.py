"""``pkmstiff point``: stiffness, modes, weak points and kinetostatics at one pose (mm and degrees on the command line).

Spatial machines (``pkmstiff machines``): ``--pose x,y,z,a,b,c``; planar examples (``biglide``, ``bipod``):
``--pose x,y``.  Output units: N/µm, N·m/µrad, Hz, %, m/min and m/s, m/s², N; ``--json`` prints one object whose
keys name their units.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from pkmstiff.errors import ArgumentError, InadmissibleError
from pkmstiff.io.atomic import output_path, safe_stem
from pkmstiff.io.ranges import parse_numbers
from pkmstiff.machine.loader import load_machine

WEAK_POINT_DIRECTIONS = ("x", "y", "z")
#: identifier of the JSON document ``pkmstiff point --json`` prints (pkmstiff/schemas/point.schema.json)
SCHEMA = "pkmstiff/point/1"
#: units of the rows/columns of ``stiffness_matrix_SI`` (twist ux, uy, uz, rx, ry, rz at the TCP)
STIFFNESS_MATRIX_UNITS = "K[0:3,0:3] N/m, K[0:3,3:6] N/rad, K[3:6,0:3] N*m/m, K[3:6,3:6] N*m/rad"




def _num(x: Any) -> Any:
    """JSON-safe number or list (NaN/inf → null)."""
    arr = np.asarray(x, dtype=float)
    if arr.ndim == 0:
        v = float(arr)
        return v if math.isfinite(v) else None
    return [_num(v) for v in arr]


def parse_values(text: str, count: int, what: str) -> list[float]:
    return parse_numbers(text, count, "--pose", what)


#: longest tool (mm) and most natural frequencies ``point`` accepts (a 10 m tool or 100 modes is a typo, not a study)
TOOL_LENGTH_LIMIT_MM = 1e4
MODES_LIMIT = 100


def check_point_options(tool_length_mm: float | None, n_modes: int) -> None:
    """``--tool-length`` 0..:data:`TOOL_LENGTH_LIMIT_MM` mm and ``--modes`` 0..:data:`MODES_LIMIT` (0: no modes)."""
    if tool_length_mm is not None and not (math.isfinite(tool_length_mm)
                                           and 0 <= tool_length_mm <= TOOL_LENGTH_LIMIT_MM):
        raise ArgumentError(f"--tool-length: expected a length 0..{TOOL_LENGTH_LIMIT_MM:g} mm, "
                                 f"found {tool_length_mm!r}")
    if not 0 <= n_modes <= MODES_LIMIT:
        raise ArgumentError(f"--modes: expected an integer 0..{MODES_LIMIT} (0: no modal analysis), "
                                 f"found {n_modes}")


def _refuse(machine: str, where: str, reasons: list[str]) -> InadmissibleError:
    return InadmissibleError(
        f"{machine} at {where} is not admissible: {'; '.join(reasons) or 'not modelled'}; "
        f"nothing analysed (--allow-inadmissible analyses it anyway and marks the results)")


def point_report(machine_name: str, pose_text: str, tool_length_mm: float | None = None, n_modes: int = 6,
                 neglect_spindle: bool = False, frame: str = "machine", allow_inadmissible: bool = True,
                 skip_checks: Sequence[str] = (), start_pose: str | None = None) -> dict:
    """Everything ``pkmstiff point`` prints, as a JSON-ready dict whose keys name their units
    (schema ``pkmstiff/schemas/point.schema.json``).

    The pose is given in ``frame`` (:mod:`pkmstiff.machine.frames`; spatial machines only). Admissibility (every
    check of docs/theory/admissibility.md) comes first; with ``allow_inadmissible=False`` an inadmissible pose raises
    :class:`~pkmstiff.errors.InadmissibleError` (exit status 3) before any analysis. ``skip_checks``: names
    of admissibility checks left out (stated as ``checks_left_out``). ``start_pose`` (mechanisms only): the pose
    whose working mode the solution keeps.
    """
    check_point_options(tool_length_mm, n_modes)
    from pkmstiff.admissibility.checks import checks_without
    from pkmstiff.cli.targets import Kind, check_start_pose, dispatch

    checks = checks_without(skip_checks, "--skip-check")
    check_start_pose(machine_name, start_pose)

    def planar(_: object) -> dict:
        if skip_checks:
            raise ArgumentError(f"--skip-check: not available for the planar example '{machine_name}'")
        return _planar_report(machine_name, parse_values(pose_text, 2, "x,y (mm)"), allow_inadmissible)

    def mechanism(_: object) -> dict:
        from pkmstiff.cli.mechanism import point_report as mechanism_report

        return mechanism_report(machine_name, pose_text, n_modes, allow_inadmissible,
                                {"--neglect-spindle": neglect_spindle, "--frame": frame != "machine",
                                 "--skip-check": bool(skip_checks)}, tool_length_mm, start_pose)

    return dispatch(machine_name, {
        Kind.SPATIAL: lambda _: _machine_report(machine_name, pose_text, tool_length_mm, n_modes, neglect_spindle,
                                                frame, allow_inadmissible, checks),
        Kind.PLANAR: planar, Kind.MECHANISM: mechanism})


def _machine_report(machine_name: str, pose_text: str, tool_length_mm: float | None, n_modes: int,
                    neglect_spindle: bool, frame: str, allow_inadmissible: bool, checks: tuple[str, ...]) -> dict:
    """:func:`point_report` of a spatial machine."""
    from pkmstiff.admissibility.checks import checks_left_out
    from pkmstiff.admissibility.pipeline import evaluate_poses
    from pkmstiff.analysis import kinetostatics, modal_analysis, tcp_compliance, weak_points
    from pkmstiff.cli.pose import parse_pose
    from pkmstiff.structure import StructureOptions, build_structure

    pose = parse_pose(pose_text)
    from pkmstiff.machine.frames import frame_metadata, to_machine_frame

    m = load_machine(machine_name)
    given = pose
    pose = to_machine_frame(m, given, frame)
    # the one pose evaluation: the structure and the kinetostatics reuse it
    ev = evaluate_poses(m, pose[None], checks=checks)
    adm = ev.admissibility
    admissible, reasons = bool(adm.ok[0]), adm.failing(0)
    pose_out = {"x_mm": given[0] * 1e3, "y_mm": given[1] * 1e3, "z_mm": given[2] * 1e3,
                "a_deg": math.degrees(given[3]), "b_deg": math.degrees(given[4]), "c_deg": math.degrees(given[5])}
    if not admissible and not allow_inadmissible:
        raise _refuse(m.name, ", ".join(f"{k.split('_')[0]} = {v:g} {k.split('_')[1]}" for k, v in pose_out.items())
                      + f" ({frame} frame)", reasons)
    tl = None if tool_length_mm is None else tool_length_mm * 1e-3
    st = build_structure(m, ev, StructureOptions(load_platform=neglect_spindle))  # K_U rigid for the load only
    ks = kinetostatics(m, ev)
    rep: dict[str, Any] = {
        "schema": SCHEMA,
        "machine": m.name, "machine_type": m.kind,
        **frame_metadata(m, frame),
        "pose": pose_out,
        "pose_machine_frame": {"x_mm": pose[0] * 1e3, "y_mm": pose[1] * 1e3, "z_mm": pose[2] * 1e3},
        "admissible": admissible, "reasons": reasons,
        "analysed_although_inadmissible": not admissible,
        "skipped_checks": adm.skipped(),
        "checks_left_out": checks_left_out(checks),
        "tool_length_mm": (m.tool.length if tl is None else tl) * 1e3,
        "neglect_spindle": neglect_spindle,
        "modelled": bool(st.ok[0]), "model_reasons": st.failing(0),
        "model": {"bodies": [] if st.empty else st.model.body_names, "dof": 0 if st.empty else st.model.n_dof,
                  "tcp_body": st.tcp_body},
    }
    comp = tcp_compliance(st, tl)[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        diag = 1.0 / np.diagonal(comp)
    if np.all(np.isfinite(comp)):
        rep["stiffness_matrix_SI"] = _num(np.linalg.inv(comp))
    else:
        rep["stiffness_matrix_SI"] = None
    rep["stiffness_matrix_SI_units"] = STIFFNESS_MATRIX_UNITS
    rep["k_N_per_um"] = {ax: _num(diag[i] / 1e6) for i, ax in enumerate("xyz")}
    rep["rotational_stiffness_Nm_per_urad"] = {ax: _num(diag[3 + i] / 1e6) for i, ax in enumerate("xyz")}
    rep["weak_points_percent"] = {}
    for d in WEAK_POINT_DIRECTIONS:
        wp = weak_points(st, d, tl)
        rep["weak_points_percent"][d] = {lab: _num(100 * wp.component_shares[0, j])
                                         for j, lab in enumerate(wp.component_labels)}
    if n_modes and not st.empty:
        from pkmstiff.multibody import dynamic_dofs

        k = min(n_modes, dynamic_dofs(st.model))
        ma = modal_analysis(st, k, shapes=False)
        rep["frequencies_Hz"] = _num(ma.frequencies_hz[0])
        rep["mode_descriptions"] = [ma.description(0, i) for i in range(k)]
    else:
        rep["frequencies_Hz"], rep["mode_descriptions"] = [], []
    rep["transmission_quality"] = _num(ks.transmission_quality[0])
    rep["transmission_weight_m_per_rad"] = ks.weight
    rep["v_max_m_per_s"] = {lab: _num(ks.v_max[0, i]) for i, lab in enumerate(ks.velocity_labels)}
    rep["v_max_m_per_min"] = {lab: _num(ks.v_max[0, i] * 60) for i, lab in enumerate(ks.velocity_labels)}
    rep["v_limiting_drive"] = {lab: _drive(ks.v_limiting[0, i]) for i, lab in enumerate(ks.velocity_labels)}
    rep["a_max_m_per_s2"] = {lab: _num(ks.a_max[0, i]) for i, lab in enumerate(ks.acceleration_labels)}
    rep["a_limiting_drive"] = {lab: _drive(ks.a_limiting[0, i]) for i, lab in enumerate(ks.acceleration_labels)}
    rep["a_infeasible"] = {lab: bool(ks.a_infeasible[0, i]) for i, lab in enumerate(ks.acceleration_labels)}
    rep["static_drive_loads_N"] = _num(ks.drive_loads[0])
    rep["notes"] = ks.notes
    return rep


def _drive(i: Any) -> int | None:
    return None if int(i) < 0 else int(i) + 1  # 1-based drive numbers in the output


def _planar_report(name: str, xy_mm: list[float], allow_inadmissible: bool = True) -> dict:
    from pkmstiff.analysis.planar import (
        load_planar,
        planar_kinetostatics,
        planar_modes,
        planar_stiffness,
        planar_structure,
    )

    pm = load_planar(name)
    pos = np.array([xy_mm]) * 1e-3
    ps = planar_structure(pm, pos)
    k = planar_stiffness(ps)[0]
    md = planar_modes(ps)
    kin = planar_kinetostatics(pm, pos, directions=((1, 0), (0, 1), (-1, 0), (0, -1)))
    from pkmstiff.admissibility.checks import reason_names

    labels = ["x", "y", "-x", "-y"]
    modelled, reasons = bool(ps.index.size), reason_names(int(ps.reasons[0]))
    if not modelled and not allow_inadmissible:
        raise _refuse(pm.name, f"x = {xy_mm[0]:g} mm, y = {xy_mm[1]:g} mm", reasons)
    return {
        "schema": SCHEMA,
        "machine": pm.name, "machine_type": f"planar {pm.kind}",
        "frame": "machine", "frame_origin_mm": [0.0, 0.0, 0.0],  # planar machines have only their own frame
        "pose": {"x_mm": xy_mm[0], "y_mm": xy_mm[1]},
        "admissible": modelled, "reasons": reasons, "analysed_although_inadmissible": not modelled,
        "modelled": modelled, "model_reasons": reasons,
        "k_N_per_um": {"x": _num(k[0, 0] / 1e6), "y": _num(k[1, 1] / 1e6)},
        "stiffness_matrix_SI": _num(k),
        "stiffness_matrix_SI_units": "N/m (planar x, y)",
        "stiffness_matrix_N_per_um": _num(k / 1e6),
        "frequencies_Hz": _num(md.frequencies_hz[0]),
        "transmission_quality": _num(kin.transmission_quality[0]),
        "v_max_m_per_s": {lab: _num(kin.v_max[0, i]) for i, lab in enumerate(labels[:2])},
        "v_max_m_per_min": {lab: _num(60 * kin.v_max[0, i]) for i, lab in enumerate(labels[:2])},
        "a_max_m_per_s2": {lab: _num(kin.a_max[0, i]) for i, lab in enumerate(labels)},
        "a_limiting_drive": {lab: _drive(kin.a_limiting[0, i]) for i, lab in enumerate(labels)},
        "static_drive_loads_N": _num(kin.drive_loads[0]),
    }


def _f(v: Any, fmt: str = "8.3f") -> str:
    return f"{'n/a':>8}" if v is None else format(v, fmt)


def _print_report(rep: dict) -> None:
    import builtins

    p = rep["pose"]
    where = ", ".join(f"{k.split('_')[0]}={v:.3f} {k.split('_')[1]}" for k, v in p.items())
    from pkmstiff.cli.pose import _frame_line

    builtins.print(f"{rep['machine']} ({rep['machine_type']}) at {where} ({_frame_line(rep)})"
                   + (f", tool length {rep['tool_length_mm']:.1f} mm" if "tool_length_mm" in rep else "")
                   + (", K_U neglected (platform and spindle rigid)" if rep.get("neglect_spindle") else ""))
    if rep.get("checks_left_out"):
        from pkmstiff.admissibility.checks import left_out_text

        builtins.print(left_out_text(rep["checks_left_out"]))
    if rep.get("drives"):
        builtins.print("drives: " + ", ".join(f"{k.rsplit('_', 1)[0]} = {_f(v, '.3f')} {k.rsplit('_', 1)[1]}"
                                              for k, v in rep["drives"].items()))
    if rep["admissible"]:
        builtins.print("admissible: yes")
    else:
        builtins.print("admissible: NO (analysed anyway: --allow-inadmissible; every result line is marked)")
        for r in rep["reasons"]:
            builtins.print(f"  - {r}")
    mark = "" if rep["admissible"] else "[INADMISSIBLE] "

    def print(text: str = "") -> None:  # noqa: A001 (marks every result line of an inadmissible pose)
        builtins.print(mark + text)

    if not rep["modelled"]:
        print("pose not modelled: " + "; ".join(rep["model_reasons"]))
    k = rep["k_N_per_um"]
    print("static stiffness at the TCP:  " + "   ".join(f"k_{a} = {_f(v, '.3f')} N/µm" for a, v in k.items()))
    if "rotational_stiffness_Nm_per_urad" in rep:
        r = rep["rotational_stiffness_Nm_per_urad"]
        print("rotational stiffness:         " + "   ".join(f"k_r{a} = {_f(v, '.3f')} N·m/µrad" for a, v in r.items()))
    if rep.get("frequencies_Hz"):
        print("natural frequencies:")
        descr = rep.get("mode_descriptions") or [""] * len(rep["frequencies_Hz"])
        for i, (f, d) in enumerate(zip(rep["frequencies_Hz"], descr)):
            print(f"  {i + 1:2d}  {_f(f, '8.2f')} Hz  {d}")
    if rep.get("weak_points_percent"):
        wp = rep["weak_points_percent"]
        dirs = list(wp)
        labels = list(next(iter(wp.values())))
        print(f"weak points (share of the TCP compliance for a force along {', '.join(dirs)}) [%]:")
        print(f"  {'component':<18}" + "".join(f"{d:>9}" for d in dirs))
        for lab in labels:
            print(f"  {lab:<18}" + "".join(_f(wp[d][lab], '9.1f') for d in dirs))
    tq = rep["transmission_quality"]
    w = rep.get("transmission_weight_m_per_rad")
    print(f"transmission quality: {_f(tq, '.4f')}" + (f"  (w = {w:.4f} m/rad)" if w else ""))
    vs, vm = rep["v_max_m_per_s"], rep["v_max_m_per_min"]
    print("maximum velocity:     " + "   ".join(f"{d}: {_f(vm[d], '.1f')} m/min ({_f(vs[d], '.3f')} m/s)"
                                            for d in vs))
    am, lim = rep["a_max_m_per_s2"], rep["a_limiting_drive"]
    print("maximum acceleration: " + "   ".join(
        f"{d}: {_f(am[d], '.2f')} m/s²" + (f" (drive {lim[d]})" if lim.get(d) else "") for d in am))
    loads, torques = rep["static_drive_loads_N"], rep.get("static_drive_torques_Nm")
    if torques is not None:  # a mechanism with rotary drives: each drive in its unit
        print("static drive loads:   " + "  ".join(f"{_f(t, '.2f')} N·m" if f is None else f"{_f(f, '.1f')} N"
                                                  for f, t in zip(loads, torques)))
    elif loads is not None:
        print("static drive loads:   " + "  ".join(_f(v, '.1f') for v in loads) + " N")
    for note in rep.get("notes", []):
        print(f"  note: {note}")


def point_rows(machine_name: str, poses_si: np.ndarray, tool_length_mm: float | None = None,
               n_modes: int = 1, skip_checks: Sequence[str] = ()) -> tuple[list[str], list[list]]:
    """CSV header and rows of a point batch (one structure batch over all poses): pose (mm, deg), admissibility and
    reasons, TCP stiffness k_x, k_y, k_z (N/µm) and the lowest ``n_modes`` natural frequencies (Hz). Inadmissible
    poses get empty result cells (never a silent number). ``skip_checks``: admissibility checks left out."""
    from pkmstiff.admissibility.checks import checks_without
    from pkmstiff.admissibility.pipeline import evaluate_poses
    from pkmstiff.analysis import natural_frequencies, tcp_compliance
    from pkmstiff.cli.targets import Kind, resolve
    from pkmstiff.structure import build_structure

    if resolve(machine_name).kind is Kind.MECHANISM:
        from pkmstiff.cli.mechanism import point_rows as mechanism_rows

        return mechanism_rows(machine_name, poses_si, n_modes, {"--skip-check": bool(skip_checks)}, tool_length_mm)
    m = load_machine(machine_name)
    adm = evaluate_poses(m, poses_si, checks=checks_without(skip_checks, "--skip-check")).admissibility
    ok = adm.ok
    n = len(poses_si)
    k = np.full((n, 3), np.nan)
    f = np.full((n, n_modes), np.nan)
    if ok.any():
        st = build_structure(m, poses_si[ok])
        comp = tcp_compliance(st, None if tool_length_mm is None else tool_length_mm * 1e-3)
        with np.errstate(divide="ignore", invalid="ignore"):
            k[ok] = 1.0 / np.diagonal(comp, axis1=1, axis2=2)[:, :3] / 1e6
        if n_modes:
            f[ok] = natural_frequencies(st, n_modes)
    head = ["x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg", "admissible", "reasons", "kx_N_per_um",
            "ky_N_per_um", "kz_N_per_um"] + [f"f{i + 1}_Hz" for i in range(n_modes)]
    pose_out = np.column_stack([poses_si[:, :3] * 1e3, np.rad2deg(poses_si[:, 3:])])
    rows = [[*pose_out[i], bool(ok[i]), "; ".join(adm.failing(i)), *k[i], *f[i]] for i in range(n)]
    return head, rows


def _point_batch(args: argparse.Namespace) -> int:
    from pkmstiff.cli.edges import announce, count_lines, parse_budget
    from pkmstiff.cli.pose import check_batch_out, read_pose_file, write_batch
    from pkmstiff.evaluation.cost import POINT_ROW_BYTES, POINT_ROW_SECONDS, rows_cost

    check_point_options(args.tool_length, args.modes)
    out = check_batch_out(args)
    rows = count_lines(args.poses)
    announce("point", rows_cost(rows, POINT_ROW_BYTES, POINT_ROW_SECONDS, f"{args.poses}", "pose rows", "--poses"),
             parse_budget(getattr(args, "memory_budget", None)), quiet=rows < 10_000)
    poses = read_pose_file(args.poses)
    head, rows = point_rows(args.machine, poses, args.tool_length, args.modes, args.skip_check)
    write_batch(out, head, rows, args, "point")
    if out:
        print(f"pkmstiff point: {len(rows)} poses ({sum(r[6] for r in rows)} admissible, analysed); wrote {out}")
    return 0


def _cmd_point(args: argparse.Namespace) -> int:
    from pkmstiff.cli.edges import check_output_dir
    from pkmstiff.errors import ArgumentError

    if (args.pose is None) == (getattr(args, "poses", None) is None):
        raise ArgumentError("expected exactly one of --pose x,y,z,a,b,c and --poses FILE.csv")
    if getattr(args, "poses", None) is not None:
        if getattr(args, "start_pose", None) is not None:
            raise ArgumentError("--start-pose: expected with --pose (one pose), found with --poses FILE (a batch "
                                "keeps home's working mode)")
        return _point_batch(args)
    check_point_options(args.tool_length, args.modes)
    if args.figures is not None:
        if args.modes == 0:
            raise ArgumentError("--figures: expected --modes 1 or more (one mode-shape figure per mode), found 0")
        check_output_dir(args.figures, "--figures", getattr(args, "force", False), _figure_names(args))
    try:
        rep = point_report(args.machine, args.pose, args.tool_length, args.modes, args.neglect_spindle,
                           args.frame, allow_inadmissible=getattr(args, "allow_inadmissible", False),
                           skip_checks=args.skip_check, start_pose=args.start_pose)
    except ArgumentError as exc:
        from pkmstiff.errors import ArgumentError

        raise ArgumentError(str(exc)) from None
    # no mode shapes where the structure model is not built (unreachable, singular or not positive definite)
    figures = _mode_figures(args) if args.figures and rep["modelled"] else []
    if figures:
        rep["figures"] = [str(f) for f in figures]
    if args.json:
        print(json.dumps(rep, indent=2))
    else:
        _print_report(rep)
        for f in figures:
            print(f"wrote {f}")
        if args.figures and not rep["modelled"]:
            print("no mode-shape figures: the pose is not modelled")
    return 0


def _mode_figures(args: argparse.Namespace) -> list:
    """Mode-shape PNGs of the lowest ``--modes`` modes (and a GIF of mode 1 with ``--gif``) into ``--figures``."""
    from pathlib import Path

    from pkmstiff.cli.pose import parse_pose
    from pkmstiff.cli.targets import Kind, resolve
    from pkmstiff.machine.frames import neglect_spindle, to_machine_frame
    from pkmstiff.machine.loader import load_machine
    from pkmstiff.plots.modes import animate_mode_shape, plot_mode_shape

    if resolve(args.machine).kind is Kind.MECHANISM:
        from pkmstiff.cli.mechanism import mode_figures

        return mode_figures(args.machine, args.pose, args.modes, args.figures, _figure_names(args), args.tool_length,
                            args.start_pose)
    machine = neglect_spindle(load_machine(args.machine), args.neglect_spindle)
    pose = to_machine_frame(machine, parse_pose(args.pose), args.frame)
    out = Path(args.figures)
    names = _figure_names(args)
    files = [plot_mode_shape(machine, pose, output_path(out, names[k - 1]), mode=k) for k in range(1, args.modes + 1)]
    if args.gif:
        files.append(animate_mode_shape(machine, pose, output_path(out, names[-1]), mode=1))
    return files


def _figure_names(args: argparse.Namespace) -> tuple[str, ...]:
    """The file names ``--figures`` writes: ``<machine>_mode<k>.png`` (and ``<machine>_mode1.gif`` with ``--gif``)."""
    from pkmstiff.cli.targets import Kind, resolve

    kind = resolve(args.machine).kind
    if kind is Kind.PLANAR:
        return ()
    if kind is Kind.MECHANISM:
        if args.gif:
            raise ArgumentError(f"--gif: not available for a mechanism ('{args.machine}'): --figures writes one PNG "
                                "per mode")
        from pkmstiff.mechanisms import load_mechanism

        stem = safe_stem(load_mechanism(args.machine).name)
    else:
        stem = safe_stem(load_machine(args.machine).name)
    return tuple(f"{stem}_mode{k}.png" for k in range(1, args.modes + 1)) + ((f"{stem}_mode1.gif",) if args.gif else ())


def add_commands(sub: Any) -> None:
    p = sub.add_parser("point", help="stiffness, modes, weak points and kinetostatics at one pose",
                       description="Structure model (spindle, platform, drives) at one pose: TCP stiffness, natural "
                                   "frequencies with mode descriptions, weak points, transmission quality, maximum "
                                   "velocity and acceleration, static drive loads. Units on the command line: mm and "
                                   "degrees.")
    p.add_argument("machine", help="bundled machine name (see 'pkmstiff machines'), machine file, a planar "
                                   "example ('biglide', 'bipod'), or a mechanism with an [elastic] table (stiffness "
                                   "at its output point)")
    p.add_argument("--pose", default=None, help="x,y,z,a,b,c in mm and degrees, e.g. 0,0,-1000,0,0,0 "
                                                "(planar examples: x,y in mm)")
    p.add_argument("--poses", default=None, metavar="FILE",
                   help="a batch: CSV file with one pose x,y,z,a,b,c (mm, deg) per line; prints CSV (k_x, k_y, k_z, "
                        "f1..; empty cells for inadmissible poses)")
    p.add_argument("--out", default=None, metavar="FILE.csv", help="with --poses: write the CSV here")
    p.add_argument("--force", action="store_true", help="overwrite existing output files (--out, --figures)")
    p.add_argument("--tool-length", type=float, default=None, metavar="MM",
                   help="tool length in mm (default: machine file; a mechanism: from its output point along the "
                        "tool axis, [output] axis or -z)")
    p.add_argument("--modes", type=int, default=6, metavar="N",
                   help=f"number of natural frequencies, 0..{MODES_LIMIT} (0: none; default 6)")
    from pkmstiff.cli.edges import add_budget_argument
    from pkmstiff.cli.frame_options import add_frame_argument, add_skip_check_argument, add_spindle_argument

    add_spindle_argument(p)
    add_frame_argument(p)
    add_skip_check_argument(p)
    add_budget_argument(p)
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    p.add_argument("--figures", metavar="DIR", default=None,
                   help="write mode-shape figures (PNG, one per mode) into DIR (spatial machines and mechanisms)")
    p.add_argument("--gif", action="store_true", help="with --figures: also an animated GIF of mode 1")
    p.add_argument("--start-pose", default=None, metavar="POSE",
                   help="a mechanism: keep the working/assembly mode of this pose (x,y,z,a,b,c mm/deg; planar x,y,phi), "
                        "reached from home, instead of home's")
    p.add_argument("--allow-inadmissible", action="store_true",
                   help="analyse an inadmissible pose anyway (every result is marked); default: refuse, exit 3")
    p.set_defaults(func=_cmd_point)
