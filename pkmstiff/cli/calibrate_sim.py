"""``pkmstiff calibrate simulate`` and ``pkmstiff calibrate plan`` (registered by
:func:`pkmstiff.cli.calibrate.subcommands`); lengths in mm, angles in degrees, feeds in mm/min on the command line, SI inside."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable

import numpy as np

from pkmstiff.cli.calibrate_import import add_nc_options
from pkmstiff.cli.edges import check_number, check_output_file
from pkmstiff.errors import ArgumentError
from pkmstiff.io.atomic import atomic_write_text


def read_errors(path: str | None, machine, plan):
    """Parameter set (with every set-up block of the plan's instrument) and the error vector of an error file:
    ``frame = "cartesian"|"cylindrical"`` (optional) and an ``[errors]`` table name = quantity."""
    from pkmstiff.calibration import error_model, parse_errors
    from pkmstiff.errors import InputError
    from pkmstiff.io import check_keys, read_toml

    blocks = tuple(plan.instrument.setup_tokens.values())
    if path is None:
        params = error_model(machine, setup=plan.setup, setup_blocks=blocks)
        return params, np.zeros(params.n)
    from pkmstiff.calibration.examples import resolve

    path = str(resolve(path))  # example:NAME -> a bundled error file
    raw = check_keys(read_toml(path, "error file"), {"frame", "errors", "description"}, path,
                     "")
    if not isinstance(raw.get("errors"), dict) or not raw["errors"]:
        raise InputError(path, "errors", "an [errors] table with at least one parameter = quantity "
                                    "(omit --errors for the nominal machine)", raw.get("errors", "missing"))
    if any(str(k).endswith(".backlash") for k in raw["errors"]):  # per-drive reversal backlash (issue 26 item 6)
        blocks += ("backlash",)
    params = error_model(machine, frame=str(raw.get("frame", "cartesian")), setup=plan.setup, setup_blocks=blocks)
    return params, parse_errors(raw["errors"], params, source=path)


def _noise(text: str) -> str | float:
    from pkmstiff.calibration.instruments.ball_bar import NOISE_MODELS
    from pkmstiff.errors import InputError

    if text in NOISE_MODELS:
        return text
    try:
        v = float(text) * 1e-6
    except ValueError:
        raise InputError("--noise", "noise", f"one of {', '.join(NOISE_MODELS)} or sigma in um",
                                    text) from None
    if not v >= 0:
        raise InputError("--noise", "noise", "a non-negative sigma in um", text)
    return v


def plan_check(command: str = "calibrate") -> Callable[[int, str], None]:
    """The cost check :func:`~pkmstiff.calibration.plans.read_plan` calls before building each path: refuse a plan
    whose poses exceed the memory or time budget (cost line from 10,000 poses)."""
    from pkmstiff.cli.edges import announce, parse_budget
    from pkmstiff.evaluation.cost import PLAN_POSE_BYTES, PLAN_POSE_SECONDS, rows_cost

    budget = parse_budget(None)

    def check(n: int, key: str) -> None:
        announce(command, rows_cost(n, PLAN_POSE_BYTES, PLAN_POSE_SECONDS, "measurement plan", "poses", key), budget,
                 quiet=n < 10_000)

    return check


def simulate_command(args: argparse.Namespace) -> dict:
    """Everything ``calibrate simulate`` does; returns the JSON-ready summary (keys name their units)."""
    raw = getattr(args, "raw", None)
    if (args.out is None) == (raw is None):
        raise ArgumentError("calibrate simulate: expected --out FILE.csv (a measurement) or --raw FOLDER (raw "
                            "ball-bar series), found " + ("both" if raw else "neither"))
    if raw is None:
        out = check_output_file(args.out, "--out", getattr(args, "force", False), (".csv",))
        check_output_file(out.with_suffix(".json"), "--out (its header file)", getattr(args, "force", False),
                          (".json",))
    check_number(args.seed, "--seed", 0)
    check_number(args.feed, "--feed", 0, lo_open=True, unit="mm/min")
    check_number(args.backlash, "--backlash", 0, unit="um")
    check_number(args.drift, "--drift", unit="K")
    check_number(args.drift_tau, "--drift-tau", 0, lo_open=True, unit="s")
    for opt in ("sample_rate", "range", "resolution", "accuracy", "angle_accuracy"):
        check_number(getattr(args, opt, None), "--" + opt.replace("_", "-"), 0, lo_open=True)
    from pkmstiff.calibration import check_plan, read_plan
    from pkmstiff.calibration.setups import PlanSet
    from pkmstiff.machine import load_machine

    machine = load_machine(args.machine)
    plans = read_plan(args.plan, plan_check())
    if not isinstance(plans, PlanSet):
        return _simulate_one(args, machine, plans, args.out)
    if raw is not None:
        raise ArgumentError(f"calibrate simulate --raw: expected a plan of one set-up, found {plans.n_setups} "
                            f"set-ups in {args.plan} (simulate each set-up's raw series from its own plan)")
    one_file = getattr(args, "one_file", False)
    outs = ([out] * plans.n_setups if one_file else
            [out.with_name(f"{out.stem}_setup{k + 1}{out.suffix}") for k in range(plans.n_setups)])
    for o in outs:  # every file is checked before the first is simulated
        check_output_file(o, "--out (one file per set-up)", getattr(args, "force", False), (".csv",))
        check_output_file(o.with_suffix(".json"), "--out (its header file)", getattr(args, "force", False),
                          (".json",))
    for part in plans.parts:
        check_plan(machine, part)
    metas: list | None = [] if one_file else None
    reps = [_simulate_one(args, machine, part, str(o), k, metas) for k, (part, o) in enumerate(zip(plans.parts, outs))]
    if metas is not None:  # --one-file: every set-up in one file, a 'setup' column names the rows' set-up
        from pkmstiff.calibration.measurement_file import write_measurement_setups

        write_measurement_setups(out, metas)
    return {"machine": machine.name, "plan": plans.name, "setups": reps}


def _simulate_one(args: argparse.Namespace, machine, plan, out: str, k: int = 0, metas: list | None = None) -> dict:
    """``calibrate simulate`` of one set-up's plan into the file ``out`` (appended to ``metas`` instead where given:
    ``--one-file``); set-up ``k`` draws its noise with the seed ``--seed`` + k (independent noise per set-up)."""
    from pkmstiff.calibration import check_plan
    from pkmstiff.calibration.measurement_file import write_measurement
    from pkmstiff.calibration.simulation import (
        SimulationOptions,
        check_samples,
        range_error,
        sample_plan,
        simulate,
        to_measurement,
    )

    check_plan(machine, plan)
    inst = _instrument(args, plan)
    raw = getattr(args, "raw", None)
    if raw is not None:  # raw ball-bar series along the plan's NC program (issue 26)
        from pkmstiff.cli.calibrate_import import simulate_raw_command

        params, delta = read_errors(args.errors, machine, plan)
        return simulate_raw_command(args, machine, plan, params, delta, inst)
    dirs = tuple(d.strip() for d in args.directions.split(",") if d.strip())
    opts = SimulationOptions(feed=args.feed / 60e3, directions=dirs, noise=_noise(args.noise),
                             quantise=not args.no_quantise, backlash=args.backlash * 1e-6, drift_dT=args.drift,
                             drift_tau=args.drift_tau,
                             seed=None if args.seed is None else args.seed + k, deflection=args.deflection)
    params, delta = read_errors(args.errors, machine, plan)
    smp = sample_plan(plan, inst, opts)
    check_samples(machine, plan, smp)  # the poses between the plan's nodes, too
    res = simulate(machine, params, delta, plan, inst, opts, samples=smp)
    msg = range_error(plan, res, inst)
    saturates = plan.instrument.saturates
    if msg and (not args.saturate or not saturates):
        raise ArgumentError(msg + (" (use --saturate to write them clipped at the range limits)"
                                      if saturates else ""))
    meas = to_measurement(machine, plan, res, inst, saturate=args.saturate)
    if metas is None:
        write_measurement(out, meas)
    else:
        metas.append(meas)
    rep = {"machine": machine.name, "plan": plan.name, "instrument": plan.instrument.kind, "out": str(out),
           "n_samples": len(res.readings), "duration_s": float(res.samples.t[-1])}
    rep.update(plan.instrument.simulation_summary(plan, res))
    rep.update({"range_violations": int(res.violations.size), "noise_sigma_um": float(res.sigma.max() * 1e6),
                "notes": res.notes})
    return rep


def _instrument(args: argparse.Namespace, plan):
    """The device of the plan's instrument with the command-line figures (mm, um, urad -> SI; defaults: QC10 ball
    bar, the assumed AT960-class tracker / 6-D device)."""
    def si(v: float | None, scale: float) -> float | None:
        return None if v is None else v * scale

    return plan.instrument.device(plan.setup, sample_rate=args.sample_rate, range=si(args.range, 1e-3),
                                  resolution=si(args.resolution, 1e-6), accuracy=si(args.accuracy, 1e-6),
                                  angle_accuracy=si(args.angle_accuracy, 1e-6))


def _cmd_simulate(args: argparse.Namespace) -> int:
    rep = simulate_command(args)
    if args.json:
        print(json.dumps(rep, indent=2))
        return 0
    if "raw" in rep:
        print(f"{rep['machine']}: plan '{rep['plan']}' -> {len(rep['raw'])} raw series ({', '.join(rep['raw'])}): "
              f"{rep['n_samples']} samples at {rep['sample_rate_hz']:g} Hz, feed {rep['feed_mm_min']:g} mm/min "
              f"(noise sigma {rep['noise_sigma_um']:.3g} µm)")
        return 0
    for one in rep.get("setups", [rep]):
        _print_simulation(one)
    return 0


def _print_simulation(rep: dict) -> None:
    if "reading_min_um" in rep:
        what = f"readings {rep['reading_min_um']:+.2f} .. {rep['reading_max_um']:+.2f} µm"
    else:
        what = f"position error up to {rep['position_error_max_um']:.2f} µm" + (
            f", orientation error up to {rep['orientation_error_max_urad']:.2f} µrad"
            if "orientation_error_max_urad" in rep else "")
    print(f"{rep['machine']}: plan '{rep['plan']}' -> {rep['out']}: {rep['n_samples']} samples over "
          f"{rep['duration_s']:.1f} s, {what} (noise sigma {rep['noise_sigma_um']:.3g} µm)"
          + (f", {rep['range_violations']} range violations clipped" if rep["range_violations"] else ""))
    for n in rep["notes"]:
        print("  " + n)


def _add_simulate(sub) -> None:
    p = sub.add_parser("simulate", help="simulate a ball-bar, tracker or 6-D pose measurement along a plan (writes "
                                        "a measurement CSV)",
                       description="Readings of the machine with the errors of --errors along a plan: "
                                   "continuous runs at constant feed sampled at the instrument rate (point sets: one "
                                   "reading per pose), white noise, quantisation, reversal backlash, thermal drift "
                                   "(Assumption), range check (Szatmari 4.3, Tab. 4.3-4.5). Defaults: QC10 ball bar; "
                                   "tracker / pose: assumed AT960-class figures (MPE 15 um + 6 um/m at 2 m, 1000 Hz, "
                                   "0.1 um; 6-D: 175 urad).")
    p.add_argument("machine", help="bundled machine name or machine file")
    p.add_argument("--plan", required=True,
                   help="plan file (TOML; ball bar, tracker or pose), or example:NAME (bundled example)")
    p.add_argument("--errors", help="error file (TOML: [errors] name = \"0.1 mm\"), or example:NAME (bundled "
                                    "example); default: nominal machine")
    p.add_argument("--out", help="measurement CSV to write")
    p.add_argument("--raw", metavar="FOLDER", help="instead of --out: write the raw ball-bar series of each run of "
                                                   "the plan's NC program as FOLDER/run<k>.txt (calibrate import)")
    p.add_argument("--start-delay", type=float, help="--raw: capture start to feed-in start in s (default: random "
                                                     "0.2-1.2 s per run from --seed)")
    p.add_argument("--one-file", action="store_true",
                   help="a plan of several set-ups: write them all to the one --out file (a 'setup' column; the "
                        "set-ups' definitions in its header) instead of one file OUT_setupK.csv per set-up")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    p.add_argument("--noise", default="instrument",
                   help="none | instrument (sigma = accuracy/2) | procedure (Tab. 4.5 vs feed, sigma = U/2) | "
                        "sigma in um (default instrument)")
    p.add_argument("--seed", type=int, default=None, help="random seed (reproducible noise)")
    p.add_argument("--feed", type=float, default=500.0, help="path feed in mm/min (default 500)")
    p.add_argument("--directions", default="ccw,cw", help="runs: ccw, cw or ccw,cw (default)")
    p.add_argument("--backlash", type=float, default=0.0, help="reversal backlash per drive in um (default 0)")
    p.add_argument("--drift", type=float, default=0.0,
                   help="thermal warm-up of the struts in K (Assumption: steel, first order; default 0)")
    p.add_argument("--drift-tau", type=float, default=1800.0, help="warm-up time constant in s (default 1800)")
    p.add_argument("--sample-rate", type=float, default=None,
                   help="instrument sample rate in Hz (default 250; tracker / pose 1000)")
    p.add_argument("--range", type=float, default=None,
                   help="instrument range +- in mm (default: the plan's measuring_range, 1 mm for a QC10); tracker / "
                        "pose: radius of the measuring volume in mm (default 20000)")
    p.add_argument("--resolution", type=float, default=None, help="resolution in um (default 0.1)")
    p.add_argument("--accuracy", type=float, default=None,
                   help="accuracy +- in um (default 0.5); tracker / pose: constant part of the MPE (default 15)")
    p.add_argument("--angle-accuracy", type=float, default=None,
                   help="pose (6-D) instrument: orientation MPE in urad (default 175 = 0.01 deg)")
    p.add_argument("--deflection", choices=("none", "gravity"), default="none",
                   help="gravity: add the machine's elastic deflection under its weight (structure model; needs "
                        "stiffness data) to the readings (default none)")
    p.add_argument("--no-quantise", action="store_true", help="do not round readings to the resolution")
    p.add_argument("--saturate", action="store_true",
                   help="write out-of-range readings clipped at the range limits instead of failing")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    add_nc_options(p, feed=False)
    p.set_defaults(func=_cmd_simulate)


def plan_command(args: argparse.Namespace) -> dict:
    """Everything ``calibrate plan`` does; writes the optimised plan (and with ``--nc`` its NC program) and returns
    the JSON-ready summary."""
    if getattr(args, "plan", None):  # the NC program of an existing plan, no optimisation (issue 26 item 2)
        from pkmstiff.calibration import check_plan, read_plan
        from pkmstiff.cli.calibrate_import import write_nc
        from pkmstiff.machine import load_machine

        if not args.nc or args.out:
            raise ArgumentError("calibrate plan --plan: expected --nc FILE (the NC program of that plan) and no --out")
        from pkmstiff.calibration.setups import PlanSet

        machine = load_machine(args.machine)
        plan = read_plan(args.plan, plan_check())
        if isinstance(plan, PlanSet):
            raise ArgumentError(f"calibrate plan --plan {args.plan} --nc: expected a plan of one set-up, found "
                                f"{plan.n_setups} set-ups (write one plan file per set-up for its NC program)")
        check_plan(machine, plan)
        return {"machine": machine.name, "plan": plan.name, **write_nc(args.nc, plan, machine.name, args, args.force)}
    if not args.out or not args.instrument:
        raise ArgumentError("calibrate plan: expected --instrument and --out FILE.toml (the optimised plan), or "
                            "--plan FILE --nc FILE")
    check_output_file(args.out, "--out", getattr(args, "force", False), (".toml",))
    if args.nc:
        check_output_file(args.nc, "--nc", getattr(args, "force", False), (".nc", ".ngc", ".mpf", ".txt"))
    check_number(args.seed, "--seed", 0)
    check_number(args.turns, "--turns", 0, lo_open=True)
    check_number(args.max_tilt, "--max-tilt", 0, 90, lo_open=True, unit="deg")

    from pkmstiff.calibration import Plan, Segment, default_plan, error_model, read_plan
    from pkmstiff.calibration.instruments import instrument
    from pkmstiff.calibration.planning import (
        HemisphereSpec,
        default_node_count,
        default_schedule,
        objective_label,
        optimise_hemisphere,
        optimise_pose_set,
        plan_toml,
        start_nodes,
    )
    from pkmstiff.errors import InadmissibleError, InputError
    from pkmstiff.machine import load_machine

    inst = instrument(args.instrument)
    machine = load_machine(args.machine)
    for key in ("starts", "iterations", "nodes", "points", "poses"):
        if getattr(args, key) is not None and getattr(args, key) < 1:
            raise InputError(f"--{key}", key, "a positive integer", getattr(args, key))
    max_tilt = np.radians(args.max_tilt)
    if inst.path_plans:
        plan_check()(args.points, "--points")
        if args.start:
            raise InputError("--start", "start", "no start plan for a ball bar (the hemisphere path of "
                                        "the default plan is used; its nodes are optimised)", args.start)
        d = default_plan(machine, inst)
        side = 1.0 if machine.tool.axis[2] <= 0 else -1.0
        tilt, torsion = default_schedule(d, side)
        spec = HemisphereSpec(d.setup, n=args.points, turns=args.turns, side=side, max_tilt=max_tilt,
                              max_torsion=max_tilt, tilt=tilt, torsion=torsion)
        nodes = args.nodes if args.nodes is not None else default_node_count(args.turns)
        params = error_model(machine, frame=args.frame)
        res = None
        for f in (0.6, 0.3, 0.15):  # a start whose every pose is admissible (tilt reduced until it is)
            nodes0 = start_nodes(nodes, f * max_tilt, 0.25 * f * max_tilt)
            try:
                res = optimise_hemisphere(machine, params, spec, nodes0, args.objective, starts=args.starts,
                                          seed=args.seed, max_iter=args.iterations, reference=spec.default_path())
                break
            except InadmissibleError:
                continue
        if res is None:
            raise InadmissibleError(f"machine '{machine.name}': no admissible start hemisphere path with "
                                   f"{nodes} nodes up to {args.max_tilt:g} deg tilt")
        what = "default orientation schedule (no optimum beat it)" if res.kept_reference else \
            f"optimised ({args.objective})"
        text = plan_toml(res.best_plan, f"{machine.name} hemisphere, {what}",
                         f"pkmstiff calibrate plan --objective {args.objective} --seed {args.seed}",
                         hemisphere=spec, nodes=None if res.kept_reference else res.best.x)
    else:
        plan0 = read_plan(args.start, plan_check()) if args.start else default_plan(machine, inst)
        if not args.start:  # a subset of the default grid: the gradient costs 12 plan evaluations per pose
            idx = np.unique(np.linspace(0, plan0.n_poses - 1, min(args.poses, plan0.n_poses)).round().astype(int))
            plan0 = Plan(f"{plan0.name}, {len(idx)} poses", plan0.setup, plan0.poses[idx],
                         (Segment("poses", 0, len(idx), "points"),))
        if plan0.instrument != inst:
            raise InputError(args.start, "plan.instrument", f"'{inst}'", plan0.instrument.kind)
        params = error_model(machine, frame=args.frame, setup=plan0.setup)
        res = optimise_pose_set(machine, params, plan0, args.objective, starts=args.starts, seed=args.seed,
                                max_iter=args.iterations, max_tilt=max_tilt)
        text = plan_toml(res.best_plan, f"{machine.name} pose set, optimised ({args.objective})",
                         f"pkmstiff calibrate plan --objective {args.objective} --seed {args.seed}")
    atomic_write_text(args.out, text)
    lab = args.objective if args.objective != "orthogonality" else "max_orthogonality"
    start = objective_label(args.objective, res.start_value)
    best = res.reference_value if res.kept_reference else res.best.value
    extra = {} if res.reference_value is None else {
        f"default_path_{lab}": objective_label(args.objective, res.reference_value),
        f"optimised_{lab}": objective_label(args.objective, res.best.value),
        "kept_default_path": res.kept_reference, "nodes": nodes}
    nc = {}
    if args.nc:
        from pkmstiff.cli.calibrate_import import write_nc

        nc = write_nc(args.nc, res.best_plan, machine.name, args, args.force)
    return {**nc, "machine": machine.name, "instrument": inst.kind, "objective": args.objective,
            "out": str(args.out), "seed": args.seed, "starts": args.starts,
            f"start_{lab}": start, **extra,
            f"best_{lab}": objective_label(args.objective, best),
            "distinct_optima": [{lab: objective_label(args.objective, o.value), "start": o.start,
                                 "iterations": o.iterations} for o in res.distinct],
            "lower_is_better": not args.objective.startswith("O")}


def _cmd_plan(args: argparse.Namespace) -> int:
    rep = plan_command(args)
    if args.json:
        print(json.dumps(rep, indent=2))
        return 0
    if "nc_program" in rep:
        print(f"{rep['machine']}: NC program of plan '{rep.get('plan', 'optimised')}' -> {rep['nc_program']}: "
              f"{rep['runs']} runs, {rep['program_points']} points, {rep['duration_s']:.1f} s at "
              f"{rep['feed_mm_min']:g} mm/min")
        if "objective" not in rep:
            return 0
    lab = args.objective if args.objective != "orthogonality" else "max_orthogonality"
    a, b = rep[f"start_{lab}"], rep[f"best_{lab}"]
    better = "lower" if rep["lower_is_better"] else "higher"
    print(f"{rep['machine']}, {rep['instrument']}: {lab} {a:.6g} (start plan) -> {b:.6g} (best of "
          f"{rep['starts']} starts, seed {rep['seed']}; {better} is better) -> {rep['out']}")
    if f"default_path_{lab}" in rep:
        print(f"{rep['nodes']} nodes; default path (unoptimised schedule) {lab} {rep[f'default_path_{lab}']:.6g}: "
              + ("no optimum beats it, the default path is written" if rep["kept_default_path"]
                 else "the optimised plan is better"))
    print(f"distinct optima ({len(rep['distinct_optima'])}): "
          + ", ".join(f"{o[lab]:.6g} (start {o['start']})" for o in rep["distinct_optima"]))
    return 0


def _add_plan(sub) -> None:
    from pkmstiff.calibration.instruments import kinds
    from pkmstiff.calibration.planning import OBJECTIVES

    p = sub.add_parser("plan", help="optimise a measurement plan (hemisphere nodes or a pose set)",
                       description="Ball bar: optimise the orientation nodes (B, L, D) of the hemisphere path "
                                   "(Szatmari 4.4.3, eq. 4.8). Tracker / pose: optimise the poses of a pose set "
                                   "(Denkena Gl. 90-92). Gradient method with Armijo steps on a barrier-augmented "
                                   "objective, admissibility as constraints, seeded multi-start.")
    p.add_argument("machine", help="bundled machine name or machine file")
    p.add_argument("--instrument", choices=kinds(), help="required unless --plan")
    p.add_argument("--objective", default="orthogonality", choices=OBJECTIVES,
                   help="cond (min), orthogonality (largest entry, min; eq. 4.8), O1..O5 (max)")
    p.add_argument("--out", help="plan file (TOML) to write")
    p.add_argument("--nc", metavar="FILE", help="also write the plan's measuring program as G-code (ball bar; "
                                                "docs: 'From a real ball-bar session')")
    p.add_argument("--plan", help="with --nc: the NC program of this plan file (or example:NAME), no optimisation")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out / --nc file")
    p.add_argument("--start", help="start pose set (TOML; tracker/pose); default: the instrument's default plan")
    p.add_argument("--poses", type=int, default=12,
                   help="tracker/pose without --start: poses taken from the default grid (default 12)")
    p.add_argument("--nodes", type=int, default=None,
                   help="orientation nodes of the hemisphere path (default: by the measured rule, "
                        "docs/user-guide/calibration-simulation.md)")
    p.add_argument("--points", type=int, default=240, help="poses of the hemisphere path (default 240)")
    p.add_argument("--turns", type=float, default=4.0, help="turns of the hemisphere spiral (default 4)")
    p.add_argument("--max-tilt", type=float, default=20.0, help="largest tilt B and torsion in deg (default 20)")
    p.add_argument("--starts", type=int, default=3, help="optimiser starts (default 3)")
    p.add_argument("--iterations", type=int, default=10, help="gradient iterations per start (default 10)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the starts (default 0)")
    p.add_argument("--frame", choices=("cartesian", "cylindrical"), default="cartesian")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    add_nc_options(p)
    p.set_defaults(func=_cmd_plan)


SUBCOMMANDS: dict[str, Callable] = {"simulate": _add_simulate, "plan": _add_plan}
