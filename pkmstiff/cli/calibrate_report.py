"""``pkmstiff calibrate report`` (issue 17 item 5): identification, uncertainty, residuals, cross-validation and the
deflection contribution (:func:`pkmstiff.calibration.workflow.run_calibration`) as an HTML + Markdown report
(:mod:`pkmstiff.report.calibration`). Registered in :func:`pkmstiff.cli.calibrate.subcommands`."""

from __future__ import annotations

import argparse
from pathlib import Path

#: ``--deflection`` loads (= :data:`pkmstiff.calibration.workflow.DEFLECTION_LOADS`; not imported here so that
#: building the parser stays cheap)
DEFLECTION_LOADS = ("none", "gravity")


def report_command(args: argparse.Namespace) -> dict:
    """Everything ``calibrate report`` does; returns a JSON-ready summary (keys name their units)."""
    from pkmstiff.calibration.deflection import require_structure_model
    from pkmstiff.calibration.workflow import run_calibration
    from pkmstiff.cli.edges import check_output_dir, length_option
    from pkmstiff.errors import InputError
    from pkmstiff.machine import load_machine
    from pkmstiff.report.calibration import REPORT_FILES, write_calibration_report

    check_output_dir(args.out, "--out", args.force, REPORT_FILES)
    tolerance = length_option(args.tolerance, "--tolerance")
    if args.monte_carlo < 0:
        raise InputError("--monte-carlo", "monte_carlo", "a number of runs >= 0", args.monte_carlo)
    wants_deflection = args.deflection != "none"
    machine = load_machine(args.machine)
    if wants_deflection:  # fail before the identification, write nothing
        require_structure_model(machine)
    files = [args.measurements] if isinstance(args.measurements, str) else list(args.measurements)
    run = run_calibration(machine, files[0] if len(files) == 1 else files, plan_path=args.plan, validate=args.validate or (),
                          method=args.method, loss=args.loss, frame=args.frame, monte_carlo=args.monte_carlo,
                          deflection=args.deflection, with_=args.with_, robust=args.robust)
    paths = write_calibration_report(run, args.out, tolerance=tolerance)
    return {"machine": machine.name, "measurement_file": ", ".join(files), "n_readings": run.res.n_readings,
            "n_setups": max(1, len(run.setups)),
            "rank": run.res.rank, "n_parameters": run.params.n, "rms_before_um": run.run.before.rms * 1e6,
            "rms_after_um": run.run.after.rms * 1e6, "circles": len(run.circles),
            "validation": [{"file": v.path, "rms_nominal_um": v.before_stats.rms * 1e6,
                            "rms_calibrated_um": v.after_stats.rms * 1e6} for v in run.validations],
            "diagnostics": run.run.diagnostics.to_dict(),
            "html": str(paths["html"]), "md": str(paths["md"]), "figures": len(paths["figures"])}


def _cmd_report(args: argparse.Namespace) -> int:
    import json

    rep = report_command(args)
    if args.json:
        print(json.dumps(rep, indent=2))
        return 0
    print(f"{rep['machine']}: {rep['n_readings']} readings, rank {rep['rank']} of {rep['n_parameters']}, residual "
          f"RMS {rep['rms_before_um']:.4g} -> {rep['rms_after_um']:.4g} µm ({rep['circles']} circle"
          f"{'' if rep['circles'] == 1 else 's'} evaluated)")
    for v in rep["validation"]:
        print(f"  validation {Path(v['file']).name}: RMS {v['rms_nominal_um']:.4g} -> {v['rms_calibrated_um']:.4g} µm")
    print(f"model fit: {rep['diagnostics']['summary']}")
    print(f"wrote {rep['html']} and {rep['md']} ({rep['figures']} figures)")
    return 0


def _add_report(sub) -> None:
    from pkmstiff.calibration.identification import LOSSES, METHODS
    from pkmstiff.cli.calibrate import add_with_option
    from pkmstiff.cli.calibrate_identify import add_robust_option

    p = sub.add_parser("report", help="calibration report (HTML + Markdown): plan, identifiability, parameters, "
                                      "residuals, cross-validation",
                       description="Identify the machine from a ball-bar measurement (as calibrate identify) and "
                                   "write a self-contained HTML report and a Markdown twin with figures: the plan "
                                   "and its path, identifiability (rank, gauge freedoms, condition, O1-O5), the "
                                   "identified parameters with sigma, residuals before/after with polar plots per "
                                   "circle, residuals on validation measurements, and the deflection contribution.")
    p.add_argument("machine", help="nominal machine (bundled name or machine file)")
    p.add_argument("--measurements", required=True, nargs="+", metavar="MEAS.csv",
                   help="ball-bar measurement file(s): several files, or a file with a 'setup' column, are several "
                        "set-ups identified together (the report adds a Set-ups section)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (report.html, report.md, figures/)")
    p.add_argument("--plan", metavar="PLAN.toml", help="plan file of the measurement (described and drawn; "
                                                       "example:NAME for a bundled example)")
    p.add_argument("--validate", nargs="+", metavar="VALIDATION.csv",
                   help="measurement files not used for the identification (cross-validation)")
    p.add_argument("--method", choices=METHODS, default="lm")
    p.add_argument("--loss", choices=LOSSES, default="linear", help="robust loss (default linear: least squares)")
    add_robust_option(p)
    p.add_argument("--frame", choices=("cartesian", "cylindrical"), default="cartesian")
    p.add_argument("--monte-carlo", type=int, default=0, metavar="N", help="Monte-Carlo check of sigma with N runs")
    p.add_argument("--deflection", choices=DEFLECTION_LOADS, default="none",
                   help="gravity: subtract the structure model's gravity deflection from the readings before "
                        "identification and validation (as calibrate identify/check --deflection gravity) and report "
                        "its contribution and the bias it would cause (needs a machine with stiffness data); "
                        "default none: not computed")
    add_with_option(p, "identify with the machine (and fit anew on every validation file)")
    p.add_argument("--tolerance", metavar="LENGTH",
                   help="tolerance on the circular deviation G with its unit (e.g. 10um): band in the ball-bar "
                        "diagnostics plots, pass/fail per circle")
    p.add_argument("--force", action="store_true", help="overwrite an existing report in --out")
    p.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    p.set_defaults(func=_cmd_report)


SUBCOMMANDS = {"report": _add_report}
