"""Sub-commands ``pkmstiff fe-joint`` and ``pkmstiff fe-platform`` (mm and degrees on the command line).

``add_commands(subparsers)`` registers both on the main parser (``pkmstiff/cli.py``). Each command
function takes the parsed arguments and returns an exit code; bad input raises
:class:`~pkmstiff.units.InputError`, which the main CLI prints without a traceback.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any, Callable

import numpy as np

from pkmstiff.io.atomic import atomic_write_text, output_path, safe_stem
from pkmstiff.io.columns import sidecar_path
from pkmstiff.units import InputError

DEFAULT_ANGLES = "0:90:15"


def _positive_mm(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a length in mm, found {text!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"expected a positive length in mm, found {text!r}")
    return v


#: the platform's condensation to the 6×6 stiffness costs about two joint solves of the same size (measured)
PLATFORM_SOLVES = 2


def add_commands(subparsers: Any) -> None:
    """Add the ``fe-joint`` and ``fe-platform`` sub-commands to an argparse sub-parser collection."""
    from pkmstiff.cli.edges import add_budget_argument

    p = subparsers.add_parser(
        "fe-joint", help="FE sweep of a parametric joint over tilt angles -> joint stiffness table (CSV)",
        description="Mesh the joint of PARAMS.toml, compute its axial stiffness along the strut at each tilt angle "
                    "(scikit-fem, RBE2 + Guyan) and write a joint table (tilt_deg, k_N_per_um) with provenance.")
    p.add_argument("params", help="joint parameter file (TOML) or the name of a shipped one, e.g. "
                                   "iwf_3dof_improved (pkmstiff/fe/params/)")
    p.add_argument("--angles", default=DEFAULT_ANGLES,
                   help="tilt angles in deg: 'start:stop:step' (stop included) or 'a,b,c' (default 0:90:15)")
    p.add_argument("--out", required=True, help="output CSV table")
    p.add_argument("--name", default=None, help="table name (default: <joint name>_fe)")
    p.add_argument("--mesh-size", type=_positive_mm, default=None, help="element size in mm (default: from PARAMS)")
    p.add_argument("--n-phi", type=int, default=None, help="segments around circular parts (default: from PARAMS)")
    p.add_argument("--element", choices=("hex8", "hex20", "hex27"), default=None, help="element type")
    p.add_argument("--vtu", default=None, help="directory for VTU files of the deformed joint at each angle")
    p.add_argument("--png", default=None, help="PNG image of the deformed joint at --png-angle")
    p.add_argument("--png-angle", type=float, default=45.0, help="tilt angle in deg for --png (default 45)")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no result table")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    add_budget_argument(p)
    p.set_defaults(func=cmd_fe_joint)

    p = subparsers.add_parser(
        "fe-platform", help="FE model of a platform plate -> 6x6 stiffness at the spindle reference point",
        description="Mesh the platform of PARAMS.toml, couple the joint pads (supports) and the spindle bore (RBE2) "
                    "and condense (Guyan) to the 6x6 stiffness at the spindle reference point.")
    p.add_argument("params", help="platform parameter file (TOML) or the name of a shipped one, e.g. "
                                   "hexaglide_platform (pkmstiff/fe/params/)")
    p.add_argument("--out", required=True,
                   help="output: .toml (a [components.NAME] body_stiffness table for a machine file) or .csv (6x6)")
    p.add_argument("--name", default="platform_stiffness", help="component name in the TOML output")
    p.add_argument("--mesh-size", type=_positive_mm, default=None, help="element size in mm (default: from PARAMS)")
    p.add_argument("--vtu", default=None, help="VTU file of the platform deformed by a unit load case")
    p.add_argument("--quiet", action="store_true", help="no progress output and no result table")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    add_budget_argument(p)
    p.set_defaults(func=cmd_fe_platform)


def _progress(total: int, quiet: bool, desc: str) -> tuple[Callable[[float], None], Callable[[], None]]:
    """tqdm bar on stderr only when stderr is a terminal and not ``quiet``; otherwise silent."""
    if quiet or not sys.stderr.isatty():
        return (lambda _a: None), (lambda: None)
    from tqdm import tqdm

    bar = tqdm(total=total, desc=desc, unit="angle", file=sys.stderr)

    def step(a: float) -> None:
        bar.set_postfix_str(f"{a:g} deg")
        bar.update(1)

    return step, bar.close


def _announce_fe(command: str, p: Any, dofs: Callable[[Any], int], args: argparse.Namespace, solves: float,
                 option: str) -> None:
    """Estimate an FE run before meshing it: the DOFs of the file's own mesh (built once with the requested element,
    < 1 s) scaled to ``--mesh-size`` / ``--n-phi`` (:func:`~pkmstiff.evaluation.cost.fe_dofs`); refuse it above the
    budget, otherwise print the cost line."""
    from pkmstiff.cli.edges import announce, parse_budget
    from pkmstiff.evaluation.cost import fe_cost, fe_dofs

    budget = parse_budget(getattr(args, "memory_budget", None))
    n_phi0 = int(p["mesh"]["n_phi"])
    element = getattr(args, "element", None)
    n0 = dofs(p.with_mesh(element=element) if element else p)
    size = args.mesh_size * 1e-3 if args.mesh_size else p.mesh_size
    n = fe_dofs(n0, p.mesh_size, size, n_phi0, getattr(args, "n_phi", None) or n_phi0)
    if args.mesh_size and args.mesh_size * 1e-3 < p.mesh_size:
        option = "--mesh-size"
    elif (getattr(args, "n_phi", None) or 0) > n_phi0:
        option = "--n-phi"
    cost = fe_cost(n, solves, f"{p.name} at mesh size {size * 1e3:g} mm", option)
    announce(command, cost, budget, quiet=args.quiet)


def cmd_fe_joint(args: argparse.Namespace) -> int:
    """``pkmstiff fe-joint``: tilt sweep -> CSV joint table (+ optional VTU/PNG of the deformed joint)."""
    from pkmstiff.cli.edges import check_output_dir, check_output_file
    from pkmstiff.fe.export import field_mesh, write_sweep_table, write_vtu
    from pkmstiff.fe.joints import build_joint_model, load_joint_parameters, parse_angles, sweep

    check_output_file(args.out, "--out", getattr(args, "force", False), (".csv",))
    check_output_file(args.png, "--png", getattr(args, "force", False), (".png",))
    if args.png and not (math.isfinite(args.png_angle) and abs(args.png_angle) <= 180):
        raise InputError("--png-angle", "png_angle", "a finite tilt angle in -180..180 deg", args.png_angle)
    angles = parse_angles(args.angles)
    if len(angles) < 2:
        raise InputError("--angles", "angles", "at least 2 tilt angles (a joint table needs 2 support points)",
                         args.angles)
    p = load_joint_parameters(args.params)
    vtu_names = tuple(f"{safe_stem(p.name)}_tilt{a:g}.vtu" for a in angles)
    check_output_dir(args.vtu, "--vtu", getattr(args, "force", False), vtu_names)
    if args.n_phi is not None and args.n_phi < 8:
        raise InputError("--n-phi", "n_phi", "an integer >= 8", args.n_phi)
    _announce_fe("fe-joint", p, lambda q: build_joint_model(q).model.n_fe, args, len(angles), "--angles")
    if args.mesh_size is not None or args.n_phi or args.element:
        p = p.with_mesh(size=args.mesh_size * 1e-3 if args.mesh_size else None, element=args.element,
                        n_phi=args.n_phi)
    step, close = _progress(len(angles), args.quiet, p.name)
    try:
        res = sweep(p, angles, progress=step)
    finally:
        close()
    out = write_sweep_table(res, args.out, args.name)
    if not args.quiet:
        print(f"{p.name}: {res.n_dofs} DOFs, {res.seconds:.1f} s; table written to {out}")
        print("tilt_deg  k_N_per_um")
        for a, k in zip(res.tilt_deg, res.k_N_per_um):
            print(f"{a:8g}  {k:10.2f}")
    if args.vtu or args.png:
        jm = build_joint_model(p)
        if args.vtu:
            for a, name in zip(angles, vtu_names):
                sol, u, _ = jm.deformed(math.radians(a))
                path = write_vtu(field_mesh(jm.model, sol, u), output_path(args.vtu, name))
                if not args.quiet:
                    print(f"VTU written to {path}")
        if args.png:
            path = joint_image(jm, args.png_angle, args.png)
            if not args.quiet:
                print(f"image written to {path}")
    return 0


def joint_image(jm: Any, tilt_deg: float, path: str | Path) -> Path:
    """PNG of the joint deformed by its parameter-file load at ``tilt_deg``."""
    from pkmstiff.fe.export import field_mesh
    from pkmstiff.plots.fe import deformed_image

    th = math.radians(tilt_deg)
    sol, u, k = jm.deformed(th)
    R = jm.placements(th)["strut"][0]
    tip = R @ np.asarray(jm.model.references[0].point, float)
    F = float(jm.params["load"]["force"])
    title = (f"{jm.params.name}: tilt {tilt_deg:g} deg, {F / 1e3:g} kN along the strut, "
             f"k = {k / 1e6:.1f} N/µm")
    img, _ = deformed_image(field_mesh(jm.model, sol, u), path, title=title, load_point=tip,
                            load_direction=jm.strut_direction(th))
    return img


#: rows/columns of the 6x6 platform matrix CSV: force/displacement components at the spindle reference point
MATRIX_AXES = ("ux", "uy", "uz", "rx", "ry", "rz")


def write_matrix_csv(path: Path, K: np.ndarray, name: str) -> Path:
    """The 6x6 platform stiffness ``K`` (dissertation units, :func:`to_dissertation_units`) as a plain CSV:
    a ``row`` column (``ux`` ... ``rz``) and one column per matrix column; the units go to ``<name>.json``."""
    from pkmstiff.io.columns import write_table

    rows = [[a, *map(float, K[i])] for i, a in enumerate(MATRIX_AXES)]
    meta = {"platform": name, "quantity": "6x6 platform stiffness at the spindle reference point",
            "rows_and_columns": list(MATRIX_AXES),
            "units": {"translational (ux..uz x ux..uz)": "N/um",
                      "coupling (ux..uz x rx..rz, rx..rz x ux..uz)": "N/urad",
                      "rotational (rx..rz x rx..rz)": "N*m/urad"}}
    return write_table(path, ["row", *MATRIX_AXES], rows, meta, ".8g")


def cmd_fe_platform(args: argparse.Namespace) -> int:
    """``pkmstiff fe-platform``: 6x6 platform stiffness at the spindle reference point -> TOML or CSV."""
    from pkmstiff.cli.edges import check_output_file
    from pkmstiff.fe.export import field_mesh, write_vtu
    from pkmstiff.fe.platform import (
        build_platform_model,
        component_toml,
        load_platform_parameters,
        platform_stiffness,
        to_dissertation_units,
    )

    out = Path(args.out)
    if out.suffix not in (".toml", ".csv"):
        raise InputError("--out", "out", "a file name ending in .toml or .csv", args.out)
    check_output_file(args.out, "--out", getattr(args, "force", False), (".toml", ".csv"))
    if out.suffix == ".csv":
        check_output_file(sidecar_path(out), "--out (its metadata)", getattr(args, "force", False), (".json",))
    check_output_file(args.vtu, "--vtu", getattr(args, "force", False), (".vtu",))
    p = load_platform_parameters(args.params)
    _announce_fe("fe-platform", p, lambda q: build_platform_model(q).n_fe, args, PLATFORM_SOLVES, "--mesh-size")
    if args.mesh_size:
        p = p.with_mesh(size=args.mesh_size * 1e-3)
    if not args.quiet and sys.stderr.isatty():
        print(f"{p.name}: meshing and condensing ...", file=sys.stderr)
    res = platform_stiffness(p)
    out.parent.mkdir(parents=True, exist_ok=True)
    Kd = to_dissertation_units(res.K)
    if out.suffix == ".toml":
        atomic_write_text(out, component_toml(res, args.name))
    else:
        write_matrix_csv(out, Kd, p.name)
    if args.vtu:
        # unit load case: 1 kN along z' at the reference point
        f = np.zeros(6)
        f[2] = 1e3
        u = res.solution.displacement(np.linalg.solve(res.K, f))
        write_vtu(field_mesh(res.model, res.solution, u), args.vtu)
    if not args.quiet:
        print(f"{p.name}: {res.model.n_fe} DOFs, {res.seconds:.1f} s; written to {out}")
        print("diagonal: " + ", ".join(f"{v:.1f}" for v in np.diag(Kd)[:3]) + " N/um; "
              + ", ".join(f"{v:.1f}" for v in np.diag(Kd)[3:]) + " N*m/urad")
    return 0
