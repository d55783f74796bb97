"""``pkmstiff ballbar analyse MEAS.csv``: circular-test evaluation of a ball-bar measurement file.

Prints the ISO 230-4 style figures (G, F, H), centre offset, radius deviation, circularity (least-squares and
minimum-zone centre) and the Fourier
harmonics (Szatmári eq. 4.9/4.10) per direction; ``--json`` prints one object whose keys name their units (µm, mm,
deg); ``--plot DIR`` writes the polar deviation plot and the harmonic spectrum as PNG, and the diagnostics page
(:mod:`pkmstiff.calibration.ballbar_diagnosis`: the error sources of ball-bar software with their share of G, the
polar plot with the ``--tolerance`` band).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.cli.edges import check_output_dir, length_option
from pkmstiff.errors import ArgumentError, InputError


def _harmonics_arg(text: str) -> int | str:
    if text == "auto":
        return "auto"
    try:
        n = int(text)
    except ValueError:
        raise ArgumentError(option="--harmonics", expected="a non-negative integer or 'auto'", found=text) from None
    if n < 0:
        raise ArgumentError(option="--harmonics", expected="a non-negative integer or 'auto'", found=text)
    return n


def _clean(x: Any) -> Any:
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_clean(v) for v in x]
    return x


def _start_pose(text: str | None) -> list[float] | None:
    from pkmstiff.io.ranges import parse_numbers

    if text is None:
        return None
    vals = parse_numbers(text, 6, "--start-pose", "x,y,z,a,b,c (mm, deg)")
    return [v * 1e-3 for v in vals[:3]] + [math.radians(v) for v in vals[3:]]


def analyse_file(path: str, harmonics: int | str = "auto", plot_dir: str | None = None,
                 alpha: float = 0.01, machine: str | None = None, start_pose: str | None = None,
                 tolerance: float | None = None, lead: float | None = None) -> dict[str, Any]:
    """Everything ``pkmstiff ballbar analyse`` prints, as a JSON-ready dict (keys name their units); ``tolerance``
    [m] on G and the screw ``lead`` [m] go to the diagnosis."""
    from pkmstiff.calibration.ballbar import evaluate_measurement
    from pkmstiff.calibration.ballbar_diagnosis import diagnose
    from pkmstiff.calibration.measurement_file import read_measurement

    meas = read_measurement(path)
    model = None
    x0 = _start_pose(start_pose)
    if meas.poses is None and x0 is not None:
        from pkmstiff.machine.loader import load_machine

        name = machine or meas.machine
        if not name:
            raise InputError(reason="a drive-only file needs a machine: give --machine or the header key 'machine'",
                               file=str(path))
        model = load_machine(name)
    ev = evaluate_measurement(meas, harmonics=harmonics, alpha=alpha, machine=model, start_pose=x0,
                              source=str(path))
    feed = None if meas.feed is None or not np.all(np.isfinite(meas.feed)) else float(np.median(meas.feed))
    diag = diagnose(ev, tolerance=tolerance, lead=lead, feed=feed)
    out = {"file": str(path), "machine": meas.machine, "instrument": meas.device, "samples": meas.n_samples,
           **ev.to_dict(), "diagnosis": diag.to_dict()}
    if plot_dir is not None:
        from pkmstiff.plots.ballbar import save_ballbar_figures

        out["plots"] = [str(p) for p in save_ballbar_figures(ev, plot_dir, Path(path).stem, diag)]
    return _clean(out)


def _print_text(rep: dict[str, Any]) -> None:
    print(f"{rep['file']}: {rep['samples']} samples, machine {rep['machine'] or '-'}, instrument "
          f"{rep['instrument']}, bar {rep['bar_length_mm']:g} mm, plane {rep['plane']}")
    for lab, r in rep["runs"].items():
        h = r["harmonics"]
        print(f"  {lab.upper():>3}: G {r['circular_deviation_G_um']:8.3f} µm (min zone "
              f"{r['circular_deviation_G_min_zone_um']:.3f} µm)   F max {r['radial_deviation_F_max_um']:+8.3f}"
              f" µm  F min {r['radial_deviation_F_min_um']:+8.3f} µm")
        off = r["centre_offset_um"]
        print(f"       centre offset ({off[0]:+.3f}, {off[1]:+.3f}) µm = {r['centre_offset_magnitude_um']:.3f} µm,"
              f" radius deviation {r['radius_deviation_um']:+.3f} µm, fit rms {r['fit_rms_um']:.3f} µm")
        rule = h["rule"]
        extra = (f", noise sd {h['noise_sd_um']:.3f} µm, threshold {h['threshold_um']:.3f} µm"
                 if rule == "auto" else "")
        print(f"       harmonics: n = {h['n']} ({rule}{extra}); residual rms {r['filtered_rms_residual_um']:.3f} µm")
        for k, (a, p) in enumerate(zip(h["amplitude_um"], h["phase_deg"])):
            amp = f"{a:+10.4f}".replace("-0.0000", "+0.0000")  # no negative zero for a rounded-away A0
            print(f"         A{k:<2} {amp} µm   phi {p:7.2f} deg")
    if rep["hysteresis_H_um"] is not None:
        print(f"  hysteresis H {rep['hysteresis_H_um']:.3f} µm, circularity {rep['circularity_um']:.3f} µm "
              f"(least squares), {rep['circularity_min_zone_um']:.3f} µm (minimum zone)")
    else:
        print(f"  circularity {rep['circularity_um']:.3f} µm (least squares), {rep['circularity_min_zone_um']:.3f} µm "
              "(minimum zone; one direction only: no hysteresis)")
    _print_diagnosis(rep["diagnosis"])
    for p in rep.get("plots", []):
        print(f"  wrote {p}")


def _print_diagnosis(d: dict[str, Any]) -> None:
    print("  diagnosis (classic circle error model; share = peak-to-valley of the source / G of its run):")
    for s in d["sources"]:
        print(f"    {s['label']:<22} {s['value']:+9.3f} ± {s['sigma']:.3f} {s['unit']:<5} "
              f"{s['share_of_G_percent']:5.1f} % of G")
    print(f"    {'unexplained':<22} {d['residual_pv_um']:9.3f} µm p-v    {d['residual_share_of_G_percent']:5.1f} % "
          f"of G (rms {d['residual_rms_um']:.3f} µm)")
    for name, why in d["not_fitted"].items():
        print(f"    {name}: not fitted, {why}")
    if d["tolerance_um"] is not None:
        verdicts = ", ".join(f"{lab.upper()} {'pass' if ok else 'FAIL'}" for lab, ok in d["passed"].items())
        print(f"  tolerance G <= {d['tolerance_um']:g} µm: {verdicts}")


def _cmd_analyse(args: argparse.Namespace) -> int:
    harmonics = _harmonics_arg(args.harmonics)
    if not 0.0 < args.alpha < 1.0:
        raise ArgumentError(option="--alpha", expected="a probability in (0, 1)", found=args.alpha)
    tolerance = length_option(args.tolerance, "--tolerance")
    lead = length_option(args.lead, "--lead")
    if args.plot is not None:
        stem = Path(args.file).stem
        check_output_dir(args.plot, "--plot", args.force,
                         tuple(f"{stem}_{k}.png" for k in ("polar", "spectrum", "diagnosis")))
    from pkmstiff.cli.edges import announce, count_lines, parse_budget
    from pkmstiff.evaluation.cost import BALLBAR_BASE_BYTES, BALLBAR_ROW_BYTES, BALLBAR_ROW_SECONDS, rows_cost

    rows = count_lines(args.file)
    cost = rows_cost(rows, BALLBAR_ROW_BYTES, BALLBAR_ROW_SECONDS, args.file, "sample rows", "file",
                     base_bytes=BALLBAR_BASE_BYTES)
    announce("ballbar", cost, parse_budget(getattr(args, "memory_budget", None)), quiet=args.json or rows < 100_000)
    rep = analyse_file(args.file, harmonics=harmonics, plot_dir=args.plot, alpha=args.alpha, machine=args.machine,
                       start_pose=args.start_pose, tolerance=tolerance, lead=lead)
    if args.json:
        print(json.dumps(rep, indent=2))
    else:
        _print_text(rep)
    return 0


def add_commands(sub: Any) -> None:
    p = sub.add_parser("ballbar", help="ball-bar (double ball bar) circular tests",
                       description="Ball-bar circular tests (Szatmári §2.2.3.1, §4.5): evaluation of measurement files.")
    bsub = p.add_subparsers(dest="ballbar_command", metavar="SUBCOMMAND")
    a = bsub.add_parser("analyse", help="evaluate a measurement CSV: G, F, H, centre offset, Fourier harmonics",
                        description="Least-squares circle, centre offset, radius deviation, circularity, circular "
                                    "deviation G, radial deviation F, hysteresis H and Fourier harmonics A0..An with "
                                    "phases per direction. Output lengths in µm (text) or with unit-suffixed keys "
                                    "(--json).")
    a.add_argument("file", help="measurement CSV (format: docs/user-guide/ballbar.md)")
    a.add_argument("--harmonics", default="auto",
                   help="number of harmonics of the filtered reconstruction, or 'auto' (region-B rule; default)")
    a.add_argument("--alpha", type=float, default=0.01,
                   help="false-alarm probability of the automatic choice (default 0.01)")
    a.add_argument("--machine", help="machine for a drive-only file (default: the file's 'machine' header)")
    a.add_argument("--start-pose", metavar="x,y,z,a,b,c",
                   help="start pose (mm, deg) of the forward kinematics for a drive-only file")
    a.add_argument("--tolerance", metavar="LENGTH",
                   help="tolerance on the circular deviation G with its unit (e.g. 10um): band in the diagnostics "
                        "plot, pass/fail per run")
    a.add_argument("--lead", metavar="LENGTH",
                   help="lead of the axis screws with its unit (e.g. 10mm): fits the cyclic error")
    a.add_argument("--plot", metavar="DIR",
                   help="write the polar deviation plot, harmonic spectrum and diagnostics page (PNG) here")
    a.add_argument("--force", action="store_true", help="overwrite existing plots in --plot")
    a.add_argument("--json", action="store_true", help="print one JSON object (keys name their units)")
    from pkmstiff.cli.edges import add_budget_argument

    add_budget_argument(a)
    a.set_defaults(func=_cmd_analyse)
