"""``pkmstiff calibrate …``: kinematic calibration (lengths in mm, angles in degrees on the command line).

Sub-commands are registered in :data:`SUBCOMMANDS` (name -> function adding its parser), so that ``simulate``,
``plan``, ``identify``, ``check`` and ``report`` can be added next to ``identifiability``.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable

import numpy as np


def identifiability_report(machine_name: str, instrument: str, plan_path: str | None = None,
                           with_: str | None = None, frame: str = "cartesian",
                           fixed_balls: list[str] | None = None, placed_by_machine: bool = False) -> dict:
    """Everything ``pkmstiff calibrate identifiability`` prints, as a JSON-ready dict (keys name their units).
    ``fixed_balls`` (``--fixed-ball X,Y,Z`` in mm, repeatable): the plan measured once about each of these fixed
    balls (moved rigidly), identified together; ``placed_by_machine``: the machine places each of them."""
    from pkmstiff.calibration import check_plan, default_plan, identifiability, parse_with, read_plan
    from pkmstiff.calibration.instruments import BALL_BAR
    from pkmstiff.calibration.instruments import instrument as lookup
    from pkmstiff.calibration.setups import PlanSet, moved_plan, setups_error_model, setups_of
    from pkmstiff.errors import InputError
    from pkmstiff.io.ranges import parse_numbers
    from pkmstiff.machine import load_machine

    inst = lookup(instrument)
    machine = load_machine(machine_name)
    if plan_path:
        from pkmstiff.cli.calibrate_sim import plan_check

        plan = read_plan(plan_path, plan_check())
        if plan.instrument != inst:
            raise InputError(plan_path, "plan.instrument", f"'{inst}' (as --instrument)",
                                        plan.instrument.kind)
    else:
        plan = default_plan(machine, inst)
    if fixed_balls or placed_by_machine:
        if isinstance(plan, PlanSet) or plan.setup.fixed_ball is None:
            raise InputError("--fixed-ball", "plan", "a ball-bar plan of one set-up to move",
                             "a plan of several set-ups" if isinstance(plan, PlanSet) else f"a {inst} plan")
        balls = [np.array(parse_numbers(b, 3, "--fixed-ball", "X,Y,Z in mm")) * 1e-3 for b in fixed_balls or ()]
        plan = PlanSet(plan.name, tuple(moved_plan(plan, b, placed_by_machine)
                                        for b in (balls or [plan.setup.fixed_ball])))
    for part in plan.parts if isinstance(plan, PlanSet) else (plan,):
        check_plan(machine, part)
    blocks = parse_with(with_, inst)
    first = plan.parts[0] if isinstance(plan, PlanSet) else plan
    if "backlash" in blocks and first.instrument is BALL_BAR:
        from pkmstiff.calibration.nc_program import programmed_plan

        # backlash: the drives' directions of motion are those of the NC program's runs
        plan = (PlanSet(plan.name, tuple(programmed_plan(part) for part in plan.parts)) if isinstance(plan, PlanSet)
                else programmed_plan(plan))
        first = plan.parts[0] if isinstance(plan, PlanSet) else plan
    params = setups_error_model(machine, plan, frame, blocks)
    res = identifiability(machine, params, plan)
    programmed = bool(first.segments) and first.segments[0].label.endswith(" ccw")
    out = {"machine": machine.name, "instrument": inst.kind,
           "plan": {"name": plan.name, "n_poses": plan.n_poses, "source": plan_path or "default",
                    "runs": "as programmed" if programmed else "as given"},
           "setups": [_setup_dict(st) for st in setups_of(plan)]}
    out["setup"] = out["setups"][0]
    out.update(res.to_dict())
    return out


def _setup_dict(st) -> dict:
    """A set-up in mm (keys name their units)."""
    out = {"target_mm": (st.target * 1e3).tolist()}
    if st.fixed_ball is not None:
        out.update({"fixed_ball_mm": (st.fixed_ball * 1e3).tolist(), "bar_length_mm": st.bar_length * 1e3,
                    "placed_by_machine": st.placing_pose is not None})
    return out


#: unnamed parameter combinations printed in the text output (all of them are in the JSON output)
MAX_UNNAMED = 5


def _print_identifiability(rep: dict) -> None:
    runs = " in both directions, as the NC program runs it" if rep["plan"].get("runs") == "as programmed" else ""
    print(f"{rep['machine']}, {rep['instrument']}: plan '{rep['plan']['name']}'{runs} ({rep['plan']['n_poses']} poses, "
          f"{rep['n_readings']} readings), {rep['frame']} parameters")
    if len(rep["setups"]) > 1:
        print(f"set-ups ({len(rep['setups'])}): " + "; ".join(
            "fixed ball (" + ", ".join(f"{v:g}" for v in st["fixed_ball_mm"]) + f") mm, bar {st['bar_length_mm']:g} mm"
            + (" (placed by the machine)" if st["placed_by_machine"] else "") if "fixed_ball_mm" in st else
            "target (" + ", ".join(f"{v:g}" for v in st["target_mm"]) + ") mm" for st in rep["setups"]))
    print(f"parameters: {rep['n_parameters']}   rank: {rep['rank']} (singular-value gap "
          f"{rep['gap_ratio']:.3g})   not identifiable: {rep['null_dimension']}")
    if rep["gauge_freedoms"]:
        print("gauge freedoms (directions no reading sees):")
        named = [g for g in rep["gauge_freedoms"] if g["kind"] != "unnamed"]
        unnamed = [g for g in rep["gauge_freedoms"] if g["kind"] == "unnamed"]
        for g in named + unnamed[:MAX_UNNAMED]:
            print(f"  - {g['label']}")
        if len(unnamed) > MAX_UNNAMED:
            print(f"  - ... and {len(unnamed) - MAX_UNNAMED} more parameter combinations (all in --json)")
    cn = rep["condition_number"]
    print(f"condition number (scaled Jacobian, identifiable part): {'inf' if cn is None else f'{cn:.4g}'}")
    cb = rep["condition_number_base"]
    print(f"condition number of the base-parameter columns: {'inf' if cb is None else f'{cb:.4g}'}")
    a, b = rep["max_orthogonality_pair"]
    print(f"largest orthogonality entry: {rep['max_orthogonality']:.6f} ({a} / {b})")
    print("observability: " + "  ".join(f"{k} = {v:.4g}" for k, v in rep["observability"].items()))
    print(f"base parameters ({len(rep['base_parameters'])}): " + ", ".join(rep["base_parameters"]))


def add_with_option(p: argparse.ArgumentParser, what: str = "include") -> None:
    """The ``--with LIST`` option (set-up and instrument parameters) of identifiability, identify, check, report."""
    p.add_argument("--with", dest="with_", metavar="LIST",
                   help=f"set-up parameters to {what}: ball-offset,fixed-ball,bar-offset (ball bar), "
                        "target-offset,instrument-frame (tracker, pose); backlash (per-drive reversal backlash, "
                        "any instrument)")


def _cmd_identifiability(args: argparse.Namespace) -> int:
    rep = identifiability_report(args.machine, args.instrument, args.plan, args.with_, args.frame, args.fixed_ball,
                                 args.placed_by_machine)
    if args.json:
        print(json.dumps(rep, indent=2, default=lambda o: o.tolist() if isinstance(o, np.ndarray) else str(o)))
    else:
        _print_identifiability(rep)
    return 0


def _add_identifiability(sub) -> None:
    from pkmstiff.calibration.instruments import kinds

    p = sub.add_parser("identifiability", help="rank, gauge freedoms, condition and orthogonality of a plan",
                       description="What an instrument can identify on a machine: parameter count, rank (gap in "
                                   "the singular values), base parameters, named gauge freedoms, condition "
                                   "number, largest orthogonality entry and O1-O5 (Szatmari 4.4.2).")
    p.add_argument("machine", help="bundled machine name or machine file")
    p.add_argument("--instrument", required=True, choices=kinds())
    p.add_argument("--plan", help="plan file (TOML); default: the instrument's default plan")
    add_with_option(p)
    p.add_argument("--fixed-ball", action="append", metavar="X,Y,Z",
                   help="measure the (ball-bar) plan about this fixed ball in mm, moved rigidly; repeat for several "
                        "set-ups identified together")
    p.add_argument("--placed-by-machine", action="store_true",
                   help="the machine places each fixed ball (centre mount driven there in the tool cup): its "
                        "position follows the machine's errors")
    p.add_argument("--frame", choices=("cartesian", "cylindrical"), default="cartesian",
                   help="frame of the joint-position parameters (default cartesian)")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    p.set_defaults(func=_cmd_identifiability)


def subcommands() -> dict[str, Callable]:
    """The ``calibrate`` sub-commands, name -> parser builder, in the order a calibration runs."""
    from pkmstiff.cli.calibrate_identify import SUBCOMMANDS as identify  # identify, check (issue 17)
    from pkmstiff.cli.calibrate_import import SUBCOMMANDS as raw_import  # import (issue 26)
    from pkmstiff.cli.calibrate_report import SUBCOMMANDS as report  # report (issue 17 item 5)
    from pkmstiff.cli.calibrate_sim import SUBCOMMANDS as simulation  # simulate, plan (issue 16)

    return {"identifiability": _add_identifiability, **simulation, **raw_import, **identify, **report}


def add_commands(sub) -> None:
    p = sub.add_parser("calibrate", help="kinematic calibration: identifiability, planning, simulation, identification",
                       description="Kinematic calibration of parallel machines (Szatmari 2007, Denkena et al. "
                                   "2008). Units on the command line: mm and degrees.")
    csub = p.add_subparsers(dest="calibrate_command", metavar="SUBCOMMAND")
    for add in subcommands().values():
        add(csub)
    p.set_defaults(func=lambda args: (p.print_help(), 0)[1])
