"""``pkmstiff demo``: stiffness and first eigenfrequency maps of the bundled Hexaglide (Cobet Figs. 4.25, 4.30).

YZ plane at x = 0, a = b = c = 0, tool length 0 with the platform-spindle stiffness K_U neglected (as the
dissertation's maps, Cobet 4.2.4; docs/user-guide/validation-hexaglide.md, reading: tool length 0): maps of k_x, k_y, k_z [N/µm] and f1 [Hz], a three-plane figure of
k_x with a sketch of the machine, VTU/CSV exports and a short Markdown + HTML summary, written to ``out/demo/``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from pkmstiff.evaluation.sections import (
    evaluate_section,
    evaluate_three_planes,
    near_singular_line,
    section_summary,
    statistics_line,
    three_planes,
)
from pkmstiff.machine.loader import load_machine
from pkmstiff.report.outputs import write_section_outputs

MACHINE = "hexaglide"
QUANTITIES = ("kx", "ky", "kz", "f1")
REFERENCE_POSE = (0.0, 0.0, -1.0, 0.0, 0.0, 0.0)  # the dissertation's measurement point, in its report frame


def output_files() -> list[str]:
    """Every file the demo writes into its output directory (README claims and the --force check use this list)."""
    stem = "hexaglide_yz"
    return ([f"{stem}_{q}.png" for q in QUANTITIES] + [f"{stem}.vtu", f"{stem}.csv", f"{stem}.json",
                                                       f"{stem}_statistics.json",
                                                       f"{stem}_admissibility.png", "hexaglide_three_planes_kx.png",
                                                       "summary.md", "summary.html"])


def run(args: argparse.Namespace) -> int:
    out = Path(getattr(args, "out", "out/demo"))
    quiet = bool(getattr(args, "quiet", False))
    step = float(getattr(args, "step", 10.0)) * 1e-3
    t0 = time.perf_counter()
    from pkmstiff.machine.frames import neglect_spindle, to_machine_frame
    from pkmstiff.workspace.windows import window_for

    machine = neglect_spindle(load_machine(MACHINE))  # K_U left out at tool length 0, as in the dissertation
    # report frame (origin at the middle guide, the dissertation's positions); the window is fitted to the admissible
    # YZ region (coarse pass + margin), so the maps show all of it
    plane = window_for(machine, "yz", 0.0, step, frame="report")
    res = evaluate_section(machine, plane, QUANTITIES, tool_length=0.0, progress=False if quiet else None,
                           frame="report")
    if res.clipping_warning():  # pragma: no cover (the fitted window has a margin of inadmissible points)
        print(f"  warning: {res.clipping_warning()}")
    files = write_section_outputs(res, out, ("png", "vtu", "csv"), "hexaglide_yz")
    planes = three_planes((0.0, 0.45, -0.9), (0.5, 0.7, 0.35), max(step, 0.02))  # machine frame
    three = evaluate_three_planes(machine, planes, ["kx"], tool_length=0.0, progress=False)
    from pkmstiff.plots.section_maps import plot_three_planes

    fig3 = plot_three_planes(three, "kx", machine, tuple(to_machine_frame(machine, REFERENCE_POSE, "report")),
                             out / "hexaglide_three_planes_kx.png")
    from pkmstiff.plots.section_maps import plot_reasons

    reasons_png = plot_reasons(res, out / "hexaglide_yz_admissibility.png")
    seconds = time.perf_counter() - t0
    info = section_summary(res, seconds)
    _write_summary(out, machine.display_title, info, [f for f in files if f.suffix == ".png"] + [reasons_png, fig3],
                   machine.assumptions)
    print(f"pkmstiff demo: {machine.display_title}, {plane.name} (report frame), {res.ok.sum()} of {res.ok.size} points "
          f"admissible, "
          f"{seconds:.1f} s")
    for n, st in info["statistics"].items():
        print(statistics_line(n, st))
    print(near_singular_line(info))
    n_data = len(output_files()) - 2  # besides summary.md and summary.html (the list is checked by a test)
    print(f"  wrote {out / 'summary.md'}, {out / 'summary.html'} and {n_data} figure/data files")
    return 0


_CAPTIONS = {"kx": "k_x, TCP stiffness in x", "ky": "k_y, TCP stiffness in y", "kz": "k_z, TCP stiffness in z",
             "f1": "first eigenfrequency", "admissibility": "admissibility: first failing check per point",
             "three_planes_kx": "k_x on three section planes, the machine ghosted at the reference pose"}


def _write_summary(out: Path, title: str, info: dict, images: list[Path], assumptions: dict[str, str]) -> None:
    """``summary.html`` (self-contained) and ``summary.md``, rendered by the report templates (one stylesheet)."""
    from pkmstiff.report.model import Figure, Report, Table
    from pkmstiff.report.render import write_report

    reasons = ", ".join(f"{k} {v}" for k, v in info["inadmissible_reasons"].items()) or "none"
    rep = Report(f"pkmstiff demo — {title}",
                 summary=f"{info['plane']} (report frame, origin at the middle guide), a = b = c = 0, tool length "
                         f"0 mm, K_U neglected (platform and spindle rigid, Cobet 4.2.4); "
                         f"{info['admissible_points']} of {info['points']} raster points admissible "
                         f"({info['admissible_area_m2']:.3f} m²); run time {info['run_time_s']:.1f} s.")
    # led by the 5 % quantile, mean and 95 % quantile: min and max are set by the near-singular points at the
    # workspace boundary (counted in the last column)
    table = Table("Statistics over the admissible points",
                  ["p5", "mean", "p95", "min", "p1", "max", "admissible points", "near-singular"])
    for n, st in info["statistics"].items():
        table.add(n, st["unit"].replace("um", "µm"), [*(st[k] for k in ("p5", "mean", "p95", "min", "p1", "max")),
                                                     st["count"], st["near_singular_points"]])
    note = ("p5 / p95: 5 % and 95 % quantiles over the admissible points (the headline figures); min and max are set "
            f"by the few points next to the singularity boundary. {near_singular_line(info).strip()}.")
    sec = rep.section("Section maps", f"{note}\n\nInadmissible points by reason: {reasons}.")
    sec.tables.append(table)
    for p in images:
        key = p.stem.removeprefix("hexaglide_yz_").removeprefix("hexaglide_")
        sec.figures.append(Figure(p, _CAPTIONS.get(key, p.stem)))
    rep.assumptions = dict(assumptions)
    rep.settings = {"machine": MACHINE, "plane": info["plane"], "frame": "report", "tool length [mm]": 0.0,
                    "quantities": list(QUANTITIES)}
    write_report(rep, out, stem="summary")
