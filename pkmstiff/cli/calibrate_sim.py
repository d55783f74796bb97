"""``pkmstiff calibrate simulate`` and ``pkmstiff calibrate plan`` (registered in :data:`pkmstiff.cli.calibrate.
SUBCOMMANDS`); lengths in mm, angles in degrees, feeds in mm/min on the command line, SI inside."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable

import numpy as np

from pkmstiff.errors import PkmstiffError


def _run(func: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    def wrapped(args: argparse.Namespace) -> int:
        from pkmstiff.cli import CliError

        try:
            return func(args)
        except PkmstiffError as exc:
            if isinstance(exc, ValueError):  # input errors: printed in one line by the CLI
                raise
            raise CliError(str(exc)) from None
    return wrapped


def read_errors(path: str | None, machine, plan):
    """Parameter set (with every set-up block of the plan's instrument) and the error vector of an error file:
    ``frame = "cartesian"|"cylindrical"`` (optional) and an ``[errors]`` table name = quantity."""
    from pkmstiff.calibration import error_model, parse_errors
    from pkmstiff.calibration.parameters import SETUP_TOKENS
    from pkmstiff.errors import CalibrationInputError
    from pkmstiff.io import check_keys, read_toml

    blocks = tuple(b for b, inst in SETUP_TOKENS.values() if plan.instrument in inst)
    if path is None:
        params = error_model(machine, setup=plan.setup, setup_blocks=blocks)
        return params, np.zeros(params.n)
    raw = check_keys(read_toml(path, CalibrationInputError, "error file"), {"frame", "errors", "description"}, path,
                     "", CalibrationInputError)
    params = error_model(machine, frame=str(raw.get("frame", "cartesian")), setup=plan.setup, setup_blocks=blocks)
    return params, parse_errors(raw.get("errors", {}), params, source=path)


def _noise(text: str) -> str | float:
    from pkmstiff.calibration.simulation import NOISE_MODELS
    from pkmstiff.errors import CalibrationInputError

    if text in NOISE_MODELS:
        return text
    try:
        v = float(text) * 1e-6
    except ValueError:
        raise CalibrationInputError("--noise", "noise", f"one of {', '.join(NOISE_MODELS)} or sigma in um",
                                    text) from None
    if not v >= 0:
        raise CalibrationInputError("--noise", "noise", "a non-negative sigma in um", text)
    return v


def simulate_command(args: argparse.Namespace) -> dict:
    """Everything ``calibrate simulate`` does; returns the JSON-ready summary (keys name their units)."""
    from pkmstiff.calibration import check_plan, read_plan
    from pkmstiff.calibration.measurement_file import write_measurement
    from pkmstiff.calibration.simulation import (
        InstrumentModel,
        SimulationOptions,
        range_error,
        simulate,
        to_measurement,
    )
    from pkmstiff.errors import CalibrationError, CalibrationInputError
    from pkmstiff.machine import load_machine

    machine = load_machine(args.machine)
    plan = read_plan(args.plan)
    if plan.instrument != "ballbar":
        raise CalibrationInputError(args.plan, "plan.instrument", "a ball-bar plan (the measurement CSV is a "
                                    "ball-bar file)", plan.instrument)
    check_plan(machine, plan)
    inst = InstrumentModel(sample_rate=args.sample_rate, range=(-args.range * 1e-3, args.range * 1e-3),
                           resolution=args.resolution * 1e-6, accuracy=args.accuracy * 1e-6)
    dirs = tuple(d.strip() for d in args.directions.split(",") if d.strip())
    opts = SimulationOptions(feed=args.feed / 60e3, directions=dirs, noise=_noise(args.noise),
                             quantise=not args.no_quantise, backlash=args.backlash * 1e-6, drift_dT=args.drift,
                             drift_tau=args.drift_tau, seed=args.seed)
    params, delta = read_errors(args.errors, machine, plan)
    res = simulate(machine, params, delta, plan, inst, opts)
    msg = range_error(plan, res, inst)
    if msg and not args.saturate:
        raise CalibrationError(msg + " (use --saturate to write them clipped at the range limits)")
    meas = to_measurement(machine, plan, res, inst, saturate=args.saturate)
    write_measurement(args.out, meas)
    dev = res.readings[:, 0] - plan.setup.bar_length
    return {"machine": machine.name, "plan": plan.name, "out": str(args.out), "n_samples": len(dev),
            "duration_s": float(res.samples.t[-1]), "reading_min_um": float(dev.min() * 1e6),
            "reading_max_um": float(dev.max() * 1e6), "range_violations": int(res.violations.size),
            "noise_sigma_um": float(res.sigma.max() * 1e6), "notes": res.notes}


def _cmd_simulate(args: argparse.Namespace) -> int:
    rep = simulate_command(args)
    if args.json:
        print(json.dumps(rep, indent=2))
    else:
        print(f"{rep['machine']}: plan '{rep['plan']}' -> {rep['out']}: {rep['n_samples']} samples over "
              f"{rep['duration_s']:.1f} s, readings {rep['reading_min_um']:+.2f} .. {rep['reading_max_um']:+.2f} um "
              f"(noise sigma {rep['noise_sigma_um']:.3g} um)"
              + (f", {rep['range_violations']} range violations clipped" if rep["range_violations"] else ""))
        for n in rep["notes"]:
            print("  " + n)
    return 0


def _add_simulate(sub) -> None:
    p = sub.add_parser("simulate", help="simulate a ball-bar measurement along a plan (writes a measurement CSV)",
                       description="Readings of the machine with the errors of --errors along a ball-bar plan: "
                                   "continuous runs at constant feed sampled at the instrument rate, white noise, "
                                   "quantisation, reversal backlash, thermal drift (Assumption), range check "
                                   "(Szatmari 4.3, Tab. 4.3-4.5). Defaults: QC10.")
    p.add_argument("machine", help="bundled machine name or machine file")
    p.add_argument("--plan", required=True, help="plan file (TOML, ball bar)")
    p.add_argument("--errors", help="error file (TOML: [errors] name = \"0.1 mm\"); default: nominal machine")
    p.add_argument("--out", required=True, help="measurement CSV to write")
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
    p.add_argument("--sample-rate", type=float, default=250.0, help="instrument sample rate in Hz (default 250)")
    p.add_argument("--range", type=float, default=1.0, help="instrument range +- in mm (default 1)")
    p.add_argument("--resolution", type=float, default=0.1, help="resolution in um (default 0.1)")
    p.add_argument("--accuracy", type=float, default=0.5, help="accuracy +- in um (default 0.5)")
    p.add_argument("--no-quantise", action="store_true", help="do not round readings to the resolution")
    p.add_argument("--saturate", action="store_true",
                   help="write out-of-range readings clipped at the range limits instead of failing")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    p.set_defaults(func=_run(_cmd_simulate))


SUBCOMMANDS: dict[str, Callable] = {"simulate": _add_simulate}
