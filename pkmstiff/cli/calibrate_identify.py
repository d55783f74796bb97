"""``pkmstiff calibrate identify`` and ``pkmstiff calibrate check`` (issue 17 items 1–3): identification from a
ball-bar measurement file, uncertainty, the calibrated machine file, and residuals of any machine file against a
measurement. Registered in :func:`pkmstiff.cli.calibrate.subcommands`.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from pkmstiff.cli.edges import check_number, check_output_file


def identify_report(machine_name: str, measurements: str, method: str = "lm", loss: str = "linear",
                    out: str | None = None, monte_carlo: int = 0, frame: str = "cartesian",
                    outlier_threshold: float = 3.0, instrument: str | None = None, deflection: str = "none",
                    load: str | None = None, with_: str | None = None, accept_misfit: bool = False,
                    robust: str | None = None) -> dict:
    """Identify, estimate the uncertainty and (``out``) write the calibrated machine; a JSON-ready dict.
    The model-fit diagnostics are under ``diagnostics``; when the fit is inconsistent the calibrated machine is
    written only with ``accept_misfit``.
    ``deflection="gravity"``: the predicted deflection is subtracted from the readings and the bias an
    identification without it would have is reported (key ``deflection``, :mod:`pkmstiff.calibration.deflection`)."""
    from pkmstiff.calibration.compensation import write_calibrated_machine
    from pkmstiff.calibration.deflection import check_deflection
    from pkmstiff.calibration.workflow import identify_file
    from pkmstiff.errors import InputError
    from pkmstiff.machine import load_machine

    if check_deflection(deflection) == "none" and load is not None:
        raise InputError("--load", "load", "--deflection gravity together with --load", "--deflection none")
    wrench = parse_load(load)
    machine = load_machine(machine_name)
    files = measurements if isinstance(measurements, str) else list(measurements)
    measurements = files if isinstance(files, str) else files[0] if len(files) == 1 else ", ".join(files)
    run = identify_file(machine, files, method=method, loss=loss, frame=frame, monte_carlo=monte_carlo,
                        outlier_threshold=outlier_threshold, expected=instrument, deflection=deflection, load=wrench,
                        with_=with_, robust=robust)
    res, unc, defl = run.res, run.unc, run.deflection
    rep = res.to_dict()
    if defl is not None:
        rep["deflection"] = defl.report()
    rep["measurement_file"] = measurements
    rep["uncertainty"] = unc.to_dict()
    rep["diagnostics"] = run.diagnostics.to_dict()
    if out and (run.diagnostics.consistent or accept_misfit):
        subtracted = "none" if defl is None else "gravity" + ("" if load is None else f" + load {load} (N, N m)")
        write_calibrated_machine(out, res, unc, files, deflection=subtracted)
        rep["calibrated_machine_file"] = out
    return rep


def parse_load(text: str | None):
    """``--load "Fx,Fy,Fz[,Mx,My,Mz]"`` (N, N m) -> array (3,) or (6,), or None."""
    from pkmstiff.io.ranges import parse_numbers

    if text is None:
        return None
    n = text.count(",") + 1
    return np.array(parse_numbers(text, n if n in (3, 6) else 3, "--load", "Fx,Fy,Fz [N] or Fx,Fy,Fz,Mx,My,Mz "
                                  "[N, N m]", count_text="3 or 6"))


def add_robust_option(p: argparse.ArgumentParser) -> None:
    """``--robust huber|tukey`` of identify and report."""
    from pkmstiff.calibration.identification import ROBUST

    p.add_argument("--robust", choices=tuple(ROBUST), default=None,
                   help="down-weight outliers by iteratively reweighted least squares (Huber or Tukey weights; "
                        "sigma from Huber's covariance of the M-estimate); default: plain least squares")


def _print_deflection(d: dict) -> None:
    print(f"deflection ({d['model']}, subtracted): readings changed by RMS {d['rms_reading_um']:.4g} µm, max "
          f"{d['max_reading_um']:.4g} µm; TCP deflection up to {d['tcp_max_um']:.4g} µm, "
          f"{d['tcp_rotation_max_urad']:.4g} µrad")
    print(f"bias without the subtraction (predicted (J'J)^-1 J' dr / actual difference of the two "
          f"identifications), relative deviation {d['bias_relative_deviation'] * 100:.3g} %:")
    for b in d["bias"]:
        key, unit = ("mm", "mm") if "predicted_mm" in b else ("urad", "µrad")
        print(f"  {b['name']:32s} {b['predicted_' + key]:+.6f} / {b['actual_' + key]:+.6f} {unit}")
    print(f"residual RMS without / with the subtraction: {d['rms_after_uncorrected_um']:.4g} / "
          f"{d['rms_after_corrected_um']:.4g} µm")


def _print_identify(rep: dict) -> None:
    b, a = rep["residual_before"], rep["residual_after"]
    print(f"{rep['machine']}: {rep['n_readings']} readings from {rep['measurement_file']}, method {rep['method']} "
          f"(loss {rep['loss']}), {rep['iterations']} evaluations")
    print(f"identified {rep['rank']} base parameters of {rep['n_parameters']} (condition number "
          f"{rep['condition_number'] or float('inf'):.4g}); scaling: {rep['scaling']}")
    if rep["gauge_freedoms"]:
        print("held fixed (gauge freedoms): " + "; ".join(rep["gauge_freedoms"]))
    print(f"residual RMS {b['rms_um']:.4g} -> {a['rms_um']:.4g} µm, max {b['max_abs_um']:.4g} -> "
          f"{a['max_abs_um']:.4g} µm")
    sig = {p["name"]: p for p in rep["uncertainty"]["parameters"]}
    for row in rep["identified"]:
        key = "value_mm" if "value_mm" in row else "value_mrad"
        s = sig[row["name"]]
        skey = "sigma_um" if "sigma_um" in s else "sigma_urad"
        unit = "mm" if key == "value_mm" else "mrad"
        print(f"  {row['name']:32s} {row[key]:+.6f} {unit}  sigma {s[skey] * 1e-3:.3g} {unit}")
    c = rep["uncertainty"]["max_correlation"]
    print(f"largest correlation: {c['value']:.3f} ({' / '.join(c['pair'])})")
    if rep["outliers"]:
        print(f"outliers (|r| > threshold x s): {len(rep['outliers'])}, first at pose {rep['outliers'][0]['pose']}")
    if "robust" in rep:
        print(f"robust ({rep['robust']} weights, IRLS): scale {rep['robust_scale_um']:.4g} µm, "
              f"{rep['down_weighted']} readings down-weighted below 1/2; sigma from Huber's covariance")
    if "deflection" in rep:
        _print_deflection(rep["deflection"])
    _print_diagnostics(rep["diagnostics"])
    if "calibrated_machine_file" in rep:
        print(f"calibrated machine written to {rep['calibrated_machine_file']}")


def _print_diagnostics(d: dict) -> None:
    """One line (every test is in --json and the report), then one line per failed test."""
    chi = next(f for f in d["findings"] if f["key"] == "chi2")
    failed = [f for f in d["findings"] if f["failed"]]
    print(f"model fit: {'consistent' if d['consistent'] else 'INCONSISTENT'}, chi2/dof {chi['statistic']:.4g} "
          f"(limit {chi['threshold']:.4g}); {len(d['findings'])} tests at false-alarm probability {d['alpha']:g}, "
          f"{len(failed)} failed")
    for f in failed:
        print(f"  FAIL {f['title']}: {f['statistic']:.4g} (limit {f['threshold']:.4g})")


def _cmd_identify(args: argparse.Namespace) -> int:
    check_output_file(args.out, "--out", getattr(args, "force", False), (".toml",))
    check_number(args.monte_carlo, "--monte-carlo", 0, 100000, unit="runs")
    check_number(args.outlier_threshold, "--outlier-threshold", 0, lo_open=True)
    rep = identify_report(args.machine, args.measurements, args.method, args.loss, args.out, args.monte_carlo,
                          args.frame, args.outlier_threshold, args.instrument, args.deflection, args.load,
                          args.with_, args.accept_misfit, args.robust)
    if args.json:
        print(json.dumps(rep, indent=2, default=lambda o: o.tolist() if isinstance(o, np.ndarray) else str(o)))
    else:
        _print_identify(rep)
    if not rep["diagnostics"]["consistent"]:
        msg = rep["diagnostics"]["summary"]
        if not args.accept_misfit:
            print(f"error: {msg} (nothing written; --accept-misfit to accept the result)", file=sys.stderr)
            return MISFIT_EXIT
        print(f"warning (accepted): {msg}", file=sys.stderr)
    return 0


#: exit status of ``calibrate identify`` when the model does not fit the measurement (2: bad input, 3:
#: inadmissible/unreachable; 4: the readings are inconsistent with the model and the instrument's stated accuracy)
MISFIT_EXIT = 4


def check_report(machine_name: str, measurements: str, controller: str | None = None, deflection: str = "none",
                 load: str | None = None, with_: str | None = None) -> dict:
    """Residuals of a machine file against a measurement (JSON-ready dict, µm) and their model-fit diagnostics
    (key ``diagnostics``, :func:`~pkmstiff.calibration.workflow.check_diagnostics`); ``deflection="gravity"``
    subtracts the deflection of the machine under test at the poses it reaches from the readings first;
    ``with_`` (``--with`` tokens) fits those set-up parameters of the measurement first.  A file of several set-ups
    (:func:`~pkmstiff.calibration.measurement_file.read_measurement_setups`) is checked set-up by set-up (each with
    its own set-up parameters); the result holds the statistics of all readings and one entry per set-up
    (key ``setups``)."""
    from pkmstiff.calibration.deflection import check_deflection
    from pkmstiff.calibration.identification import residual_stats
    from pkmstiff.calibration.measurement_file import read_measurement_setups
    from pkmstiff.calibration.parameters import parse_with
    from pkmstiff.errors import InputError
    from pkmstiff.machine import load_machine

    if check_deflection(deflection) == "none" and load is not None:
        raise InputError("--load", "load", "--deflection gravity together with --load", "--deflection none")
    wrench = parse_load(load)
    machine = load_machine(machine_name)
    metas = read_measurement_setups(measurements)
    blocks = parse_with(with_, metas[0].instrument)
    ctrl_name = controller or machine.calibration.get("nominal_machine") or metas[0].machine or machine_name
    ctrl = load_machine(ctrl_name)
    parts = [_check_setup(machine, ctrl, meas, measurements, deflection, wrench, blocks) for meas in metas]
    if len(parts) == 1:
        return {"measurement_file": measurements, **parts[0][0]}
    residual = np.concatenate([r for _, r in parts])
    return {"measurement_file": measurements, "machine": machine.name, "controller": ctrl.name,
            "n_readings": int(residual.size), **residual_stats(residual),
            "setups": [{"setup": k, **rep} for k, (rep, _) in enumerate(parts, start=1)]}


def _check_setup(machine, ctrl, meas, path: str, deflection: str, wrench, blocks) -> tuple[dict, np.ndarray]:
    """(report dict, residual (m)) of one set-up of a measurement file (see :func:`check_report`)."""
    from pkmstiff.calibration.compensation import check, measurement_plan
    from pkmstiff.calibration.deflection import subtract_deflection
    from pkmstiff.calibration.workflow import check_diagnostics

    plan, y = measurement_plan(meas, ctrl.name, path)
    if deflection == "gravity":
        yc, dr = subtract_deflection(machine, ctrl, plan, y, wrench)
        res = check(machine, ctrl, plan, yc, blocks)
        rep = res.to_dict()
        rep["deflection"] = {"model": deflection, "rms_reading_um": float(np.sqrt(np.mean(dr ** 2))) * 1e6,
                             "max_reading_um": float(np.max(np.abs(dr))) * 1e6}
    else:
        res = check(machine, ctrl, plan, y, blocks)
        rep = res.to_dict()
    rep["diagnostics"] = check_diagnostics(machine, ctrl, meas, plan, res.residual, blocks).to_dict()
    return rep, res.residual


def _cmd_check(args: argparse.Namespace) -> int:
    rep = check_report(args.machine, args.measurements, args.controller, args.deflection, args.load, args.with_)
    if args.json:
        print(json.dumps(rep, indent=2))
        return 0
    print(f"{rep['machine']} against {rep['measurement_file']} ({rep['n_readings']} readings, commanded by "
          f"{rep['controller']}): residual RMS {rep['rms_um']:.4g} µm, max {rep['max_abs_um']:.4g} µm, "
          f"mean {rep['mean_um']:.4g} µm"
          + (f" (gravity deflection subtracted: RMS {rep['deflection']['rms_reading_um']:.4g} µm)"
             if "deflection" in rep else ""))
    for part in rep.get("setups", [rep]):
        if "setups" in rep:
            print(f"set-up {part['setup']} ({part['n_readings']} readings): residual RMS {part['rms_um']:.4g} µm, "
                  f"max {part['max_abs_um']:.4g} µm, mean {part['mean_um']:.4g} µm")
        if "setup_fitted" in part:
            print("set-up fitted to the measurement: " + ", ".join(
                f"{r['name']} {r['value_mm']:+.6f} mm" if "value_mm" in r else f"{r['name']} {r['value_mrad']:+.6f} mrad"
                for r in part["setup_fitted"]))
        _print_diagnostics(part["diagnostics"])
    return 0


def _add_identify(sub) -> None:
    from pkmstiff.calibration.identification import LOSSES, METHODS
    from pkmstiff.calibration.instruments import kinds
    from pkmstiff.cli.calibrate import add_with_option

    p = sub.add_parser("identify", help="identify the base parameters from a measurement",
                       description="Identify the machine's base error parameters from a ball-bar, laser-tracker or "
                                   "6-D pose measurement "
                                   "(Szatmari 4.6): Gauss-Newton, Levenberg-Marquardt, minimax (eq. 4.12) or a "
                                   "global stage with LM polish; sigma and correlations; optionally the "
                                   "calibrated machine file.")
    p.add_argument("machine", help="nominal machine (bundled name or machine file)")
    p.add_argument("--measurements", required=True, metavar="MEAS.csv", nargs="+",
                   help="measurement file (ball bar, tracker or pose; docs/user-guide/calibration-simulation.md); "
                        "several files (one set-up each: fixed-ball positions, bar lengths, tracker stations) are "
                        "identified together")
    p.add_argument("--method", choices=METHODS, default="lm")
    p.add_argument("--loss", choices=LOSSES, default="linear", help="robust loss (default linear: least squares)")
    add_robust_option(p)
    p.add_argument("--out", metavar="CALIBRATED.toml", help="write the calibrated machine file")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    p.add_argument("--monte-carlo", type=int, default=0, metavar="N", help="Monte-Carlo check with N runs")
    p.add_argument("--frame", choices=("cartesian", "cylindrical"), default="cartesian")
    p.add_argument("--instrument", choices=kinds(), default=None,
                   help="expected instrument of the measurement (default: the file's instrument_type)")
    p.add_argument("--deflection", choices=("none", "gravity"), default="none",
                   help="gravity: subtract the predicted elastic deflection under the machine's weight (structure "
                        "model) from the readings and report the bias it would cause otherwise (default none)")
    p.add_argument("--load", metavar="FX,FY,FZ[,MX,MY,MZ]",
                   help="with --deflection gravity: an extra load at the ball / target in N (and N m)")
    p.add_argument("--outlier-threshold", type=float, default=3.0, metavar="K",
                   help="report readings with |residual| > K s (default 3)")
    add_with_option(p, "identify with the machine (they belong to the measurement and are not written into the "
                       "calibrated machine)")
    p.add_argument("--accept-misfit", action="store_true",
                   help="write the calibrated machine and exit 0 although the model-fit diagnostics fail (without "
                        "it such a fit exits with status 4 and writes nothing)")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    p.set_defaults(func=_cmd_identify)


def _add_check(sub) -> None:
    from pkmstiff.cli.calibrate import add_with_option

    p = sub.add_parser("check", help="residuals of a machine file against a measurement",
                       description="Residuals of any machine file against a measurement: the readings it predicts "
                                   "for the drive values the nominal controller commanded.")
    p.add_argument("machine", help="machine file or bundled name (e.g. a calibrated machine)")
    p.add_argument("--measurements", required=True, metavar="MEAS.csv")
    p.add_argument("--controller", help="machine whose IK commanded the measurement (default: the nominal machine "
                                        "of a calibrated file, else the file's machine)")
    p.add_argument("--deflection", choices=("none", "gravity"), default="none",
                   help="gravity: subtract the predicted elastic deflection under the machine's weight (structure "
                        "model) from the readings (default none)")
    p.add_argument("--load", metavar="FX,FY,FZ[,MX,MY,MZ]",
                   help="with --deflection gravity: an extra load at the ball / target in N (and N m)")
    add_with_option(p, "fit to the measurement before the residuals are computed (the machine held fixed)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_check)


SUBCOMMANDS = {"identify": _add_identify, "check": _add_check}
