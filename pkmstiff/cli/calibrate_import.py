"""``pkmstiff calibrate import`` (raw ball-bar series -> measurement CSV), the NC program of ``calibrate plan --nc``
and the raw series of ``calibrate simulate --raw`` (issue 26 items 1, 2 and the end-to-end check). Registered in
:func:`pkmstiff.cli.calibrate.subcommands`; mm, mm/min, um, s on the command line, SI inside."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from pkmstiff.cli.calibrate import add_with_option
from pkmstiff.cli.edges import check_number, check_output_file


def add_nc_options(p: argparse.ArgumentParser, feed: bool = True) -> None:
    """The options that shape the measuring runs (:class:`~pkmstiff.calibration.nc_program.NCOptions`); the same
    on ``plan --nc``, ``simulate --raw`` and ``import``."""
    g = p.add_argument_group("measuring runs (NC program)")
    if feed:
        g.add_argument("--feed", type=float, default=None, help="programmed path feed in mm/min (default 500; import: "
                                                                "the raw files' feed_mm_min)")
        g.add_argument("--directions", default="ccw,cw", help="runs per path: ccw, cw or ccw,cw (default)")
    g.add_argument("--depth", type=float, default=0.5, help="feed-in/out depth: bar shortening in mm (default 0.5)")
    g.add_argument("--approach", type=float, default=5.0,
                   help="feed-in/out part at the full depth in mm, for acceleration (default 5)")
    g.add_argument("--ramp", type=float, default=2.0, help="feed-in/out radius ramp in mm (default 2)")
    g.add_argument("--overshoot", type=float, default=2.0, help="path continuation before the feed-out in mm "
                                                                "(default 2)")
    g.add_argument("--dwell", type=float, default=1.0, help="dwell before and after each run in s (default 1)")
    g.add_argument("--chord", type=float, default=1.0, help="largest chord error of the program points in um "
                                                            "(default 1)")


def nc_options(args: argparse.Namespace, feed: float | None = None):
    """:class:`NCOptions` (SI) from the command line (``feed`` in m/s overrides ``--feed``)."""
    from pkmstiff.calibration.nc_program import NCOptions

    for key, unit in (("depth", "mm"), ("approach", "mm"), ("ramp", "mm"), ("chord", "um")):
        check_number(getattr(args, key), "--" + key, 0, lo_open=True, unit=unit)
    check_number(args.overshoot, "--overshoot", 0, unit="mm")
    check_number(args.dwell, "--dwell", 0, unit="s")
    f = feed if feed is not None else (args.feed if args.feed is not None else 500.0) / 60e3
    dirs = tuple(d.strip() for d in args.directions.split(",") if d.strip())
    return NCOptions(feed=f, directions=dirs, depth=args.depth * 1e-3, approach=args.approach * 1e-3,
                     ramp=args.ramp * 1e-3, overshoot=args.overshoot * 1e-3, dwell=args.dwell, chord=args.chord * 1e-6)


def write_nc(path: str, plan, machine_name: str, args: argparse.Namespace, force: bool) -> dict:
    """Write the NC program of ``plan`` (``plan --nc``); the JSON-ready summary."""
    from pkmstiff.calibration.nc_program import program_runs, program_text
    from pkmstiff.io.atomic import atomic_write_text

    check_output_file(path, "--nc", force, (".nc", ".ngc", ".mpf", ".txt"))
    if args.feed is not None:
        check_number(args.feed, "--feed", 0, lo_open=True, unit="mm/min")
    opts = nc_options(args)
    runs = program_runs(plan, opts)
    atomic_write_text(path, program_text(plan, runs, opts, machine_name))
    return {"nc_program": path, "runs": len(runs), "program_points": int(sum(len(r.tcp) for r in runs)),
            "duration_s": float(sum(r.duration + 2 * opts.dwell for r in runs)), "feed_mm_min": opts.feed * 60e3}


def _plan_and_runs(args: argparse.Namespace, feed: float | None):
    from pkmstiff.calibration import check_plan, read_plan
    from pkmstiff.calibration.nc_program import parse_program, program_runs
    from pkmstiff.cli.calibrate_sim import plan_check
    from pkmstiff.errors import InputError
    from pkmstiff.io.inputs import input_file_problem
    from pkmstiff.machine import load_machine

    machine = load_machine(args.machine)
    plan = read_plan(args.plan, plan_check())
    check_plan(machine, plan)
    if getattr(args, "nc", None):
        problem = input_file_problem(args.nc)
        if problem is not None:
            raise InputError(args.nc, reason=f"expected the NC program, found {problem}")
        runs = parse_program(Path(args.nc).read_text(encoding="utf-8"), args.nc)
    else:
        runs = program_runs(plan, nc_options(args, feed))
    return machine, plan, runs


def import_command(args: argparse.Namespace) -> dict:
    """Everything ``calibrate import`` does; returns the JSON-ready summary (keys name their units)."""
    from pkmstiff.calibration.measurement_file import write_measurement
    from pkmstiff.calibration.raw_import import import_raw
    from pkmstiff.calibration.raw_series import read_raw
    from pkmstiff.errors import InputError

    out = check_output_file(args.out, "--out", args.force, (".csv",))
    check_output_file(out.with_suffix(".json"), "--out (its header file)", args.force, (".json",))
    for key, unit in (("feed", "mm/min"), ("sample_rate", "Hz"), ("bar_length", "mm"), ("max_residual", "um")):
        if getattr(args, key) is not None:
            check_number(getattr(args, key), "--" + key.replace("_", "-"), 0, lo_open=True, unit=unit)
    opts = {"sample_rate": args.sample_rate, "bar_length": None if args.bar_length is None else args.bar_length * 1e-3,
            "feed": None if args.feed is None else args.feed / 60e3, "direction": args.direction,
            "segment": args.segment, "run": args.run, "start_offset": args.start_offset, "unit": args.unit}
    series = [read_raw(f, opts) for f in args.raw]  # every file read before the work: bad input fails fast
    feeds = {s.feed for s in series if s.feed is not None}
    if args.nc is None and not feeds:
        raise InputError(args.raw[0], key="feed_mm_min", reason="expected the programmed feed (header "
                         "'# feed_mm_min: 500' or --feed)")
    if len(feeds) > 1:
        raise InputError(args.raw[0], key="feed_mm_min", reason=f"expected one feed for all runs, found "
                         f"{sorted(f * 60e3 for f in feeds)} mm/min")
    machine, plan, runs = _plan_and_runs(args, feeds.pop() if feeds else None)
    limit = None if args.max_residual is None else args.max_residual * 1e-6
    rounds = 0
    if args.refine:
        meas, syncs, rounds = _import_refined(args, machine, plan, runs, series, limit)
    else:
        meas, syncs = import_raw(machine, plan, runs, series, limit=limit)
    write_measurement(out, meas)
    return {"machine": machine.name, "plan": plan.name, "out": str(out), "n_samples": meas.n_samples,
            "runs": [s.to_dict() for s in syncs], "refine_rounds": rounds,
            "assumption": "constant path feed from the feed-in ramp to the feed-out ramp"}


def _import_refined(args: argparse.Namespace, machine, plan, runs, series, limit):
    """``import --refine``: synchronisation and identification (cartesian error model + ``--with``, Levenberg-
    Marquardt) iterated (:mod:`pkmstiff.calibration.sync_refine`)."""
    from pkmstiff.calibration import error_model, parse_with
    from pkmstiff.calibration.compensation import measurement_plan
    from pkmstiff.calibration.identification import identify
    from pkmstiff.calibration.sync_refine import import_refined

    params = error_model(machine, setup=plan.setup, setup_blocks=parse_with(args.with_, plan.instrument))

    def delta(meas):
        mp, y = measurement_plan(meas, machine.name, args.out)
        return identify(machine, params, mp, y, "lm").delta

    return import_refined(machine, plan, runs, series, delta, params, limit=limit)


def _cmd_import(args: argparse.Namespace) -> int:
    rep = import_command(args)
    if args.json:
        print(json.dumps(rep, indent=2))
        return 0
    print(f"{rep['machine']}: {len(rep['runs'])} raw series along plan '{rep['plan']}' -> {rep['out']}: "
          f"{rep['n_samples']} samples on the measuring paths")
    if rep["refine_rounds"]:
        print(f"synchronisation refined against the identified machine: {rep['refine_rounds']} rounds of "
              "re-synchronisation and identification (residuals and sigmas of the whole runs)")
    for r in rep["runs"]:
        print(f"  {Path(r['file']).name}: run {r['run']}, feed-in at t = {r['start_s']:.4f} s "
              f"({'given' if r['given'] else 'found'}, sigma {r['start_sigma_ms']:.2g} ms), synchronisation residual "
              f"{r['residual_um']:.2g} um, "
              f"feed-out {r['end_shift_ms']:+.2g} ms, {r['samples']} samples")
    return 0


def _add_import(sub) -> None:
    p = sub.add_parser("import", help="raw ball-bar series + plan -> measurement CSV (synchronised to the NC "
                                      "program's feed-in arcs)",
                       description="Tie raw ball-bar series (one file per run: deviation per line, or time and "
                                   "deviation) to the commanded poses of the plan's NC program: synchronise each run "
                                   "on its feed-in ramp, check the feed-out ramp, drop the feed-in, overshoot and "
                                   "feed-out arcs, write the measurement CSV (Assumption: constant feed).")
    p.add_argument("machine", help="bundled machine name or machine file")
    p.add_argument("raw", nargs="+", help="raw series files, one per run (in program order unless their header "
                                          "names run or segment and direction)")
    p.add_argument("--plan", required=True, help="the plan (TOML) the NC program was written from, or example:NAME")
    p.add_argument("--nc", help="the NC program that ran (default: rebuilt from the plan and the options below)")
    p.add_argument("--out", required=True, help="measurement CSV to write")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    g = p.add_argument_group("raw series (where the files' headers do not say)")
    g.add_argument("--sample-rate", type=float, help="sample rate in Hz")
    g.add_argument("--bar-length", type=float, help="nominal bar length in mm (checked against the plan)")
    g.add_argument("--direction", choices=("ccw", "cw"), help="direction of the run")
    g.add_argument("--segment", type=int, help="path segment of the plan (1-based)")
    g.add_argument("--run", type=int, help="run of the NC program (1-based)")
    g.add_argument("--start-offset", type=float, help="time of the feed-in start in the file, s (skips the search)")
    g.add_argument("--unit", choices=("mm", "um"), help="unit of the deviations (default mm)")
    g.add_argument("--max-residual", type=float, help="largest synchronisation residual in um (default max(4 "
                                                      "sigma, 1 um), sigma = accuracy/2)")
    add_nc_options(p)
    g = p.add_argument_group("refinement")
    g.add_argument("--refine", action="store_true", help="iterate: identify, re-synchronise every run on all its "
                                                         "samples against the identified machine, re-import, until "
                                                         "no start moves by more than 0.1 sigma")
    add_with_option(g, "identify with (for --refine)")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    p.set_defaults(func=_cmd_import)


def simulate_raw_command(args: argparse.Namespace, machine, plan, params, delta, device) -> dict:
    """``calibrate simulate --raw DIR``: one raw series per run of the plan's NC program (run<k>.txt)."""
    from pkmstiff.calibration.instruments.ball_bar import BallBar
    from pkmstiff.calibration.nc_program import program_runs
    from pkmstiff.calibration.raw_import import simulate_raw
    from pkmstiff.calibration.raw_series import write_raw
    from pkmstiff.cli.calibrate_sim import _noise
    from pkmstiff.errors import InputError

    if not isinstance(plan.instrument, BallBar):
        raise InputError(args.plan, "plan.instrument", "a ball-bar plan for --raw", plan.instrument.kind)
    folder = Path(args.raw)
    if folder.exists() and not folder.is_dir():
        raise InputError("--raw", "raw", "a folder for the raw series", f"{folder} (a file)")
    opts = nc_options(args)
    runs = program_runs(plan, opts)
    files = [folder / f"run{r.number}.txt" for r in runs]
    for f in files:
        check_output_file(f, "--raw", args.force, (".txt",))
    if args.start_delay is not None:
        check_number(args.start_delay, "--start-delay", 0, unit="s")
    noise = _noise(args.noise)
    sigma = float(device.sigma(noise, opts.feed)) if isinstance(noise, str) else float(noise)
    delays = None if args.start_delay is None else np.full(len(runs), args.start_delay)
    series = simulate_raw(machine, params, delta, plan, runs, sample_rate=device.sample_rate, sigma=sigma,
                          resolution=0.0 if args.no_quantise else device.resolution, delays=delays,
                          dwell=opts.dwell, seed=args.seed)
    folder.mkdir(parents=True, exist_ok=True)
    for f, s in zip(files, series):
        write_raw(f, s, note=f"simulated by pkmstiff, plan '{plan.name}'")
    return {"machine": machine.name, "plan": plan.name, "raw": [str(f) for f in files],
            "n_samples": int(sum(len(s.t) for s in series)), "noise_sigma_um": sigma * 1e6,
            "feed_mm_min": opts.feed * 60e3, "sample_rate_hz": device.sample_rate}


SUBCOMMANDS: dict[str, Callable] = {"import": _add_import}
