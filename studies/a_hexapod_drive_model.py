"""Study a — 6X Hexapod drive model: constant vs stroke-dependent drive stiffness (Cobet 3.1, Fig. 3.1).

z-stiffness k_z of the 6X on the YZ plane at x = 0 (a = b = c = 0, tool length 0, platform ideally rigid) with
three drive models of the telescopic ball-screw struts (docs/user-guide/studies.md "3.1", docs/user-guide/machines.md):

* stroke-dependent, quadratic fit eq. 3.22 over the effective spindle length (``hexapod_6x``, the toolkit default
  and this study's baseline),
* constant 250 N/µm, the dissertation's comparison value (``hexapod_6x:constant_drive_stiffness``),
* stroke-dependent, exact eq. 3.3 (``hexapod_6x:exact_drive_model``) for reference.

Writes maps of k_z for both models and of their relative difference, tables of max/mean/min with % of the
baseline and the relative deviation of mean and max, and the drive-stiffness curves over the strut length.

Run: ``python studies/a_hexapod_drive_model.py [--out DIR] [--fast]``
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study_common import (MapPanel, Stopwatch, add_stat_rows, common_mask, deviation_colours,  # noqa: E402
                           machine_assumptions, masked_stats, parse_args, plot_maps, relative_deviation_percent,
                           shared_clim, write_outputs)

import pkmstiff  # noqa: E402
from pkmstiff import Figure, Report, Table  # noqa: E402

# (label, machine spec); the first is the baseline
VARIANTS = (
    ("stroke-dependent (fit eq. 3.22)", "hexapod_6x"),
    ("constant 250 N/um", "hexapod_6x:constant_drive_stiffness"),
    ("stroke-dependent (exact eq. 3.3)", "hexapod_6x:exact_drive_model"),
)
BASELINE = VARIANTS[0][0]
CONSTANT = VARIANTS[1][0]
# YZ plane at x = 0 (m). Extent: the connected admissible region of the 6X at a = b = c = 0 (y -0.745…0.81 m,
# z from 0.34 m) up to z = 1.80 m, where the upper platform joints (z' = 0.495 m) reach the plane of the lower
# drive joints (z = 2.30 m); above it the data admit poses with the platform between the drive joints.
Y_RANGE = (-0.80, 0.85)
Z_RANGE = (0.30, 1.80)
STEP = {"default": 0.005, "fast": 0.025}
DRIVES = [f"drive_{i}" for i in range(1, 7)]

STUDY_ASSUMPTIONS = {
    "baseline": "the stroke-dependent drive model (fit eq. 3.22) is the baseline: it is the model the dissertation "
                "derives and uses in its 6X simulations; the constant 250 N/um is the simplification compared "
                "against it, so its % and deviations state the error the simplification makes",
    "plane extent": "YZ plane at x = 0, y -800…850 mm, z 300…1800 mm: the connected admissible region at "
                    "a = b = c = 0 below z = 1800 mm (upper platform joints, z' = 495 mm, below the lower drive "
                    "joints at z = 2300 mm; the 6X file has no frame limits)",
    "6X joints": "the 6X joints are rigid: INA joint stiffness values are not published (docs/theory/components.md)",
    "platform": "platform ideally rigid (Cobet 3.3.2); tool length 0 (TCP = O')",
    "strut length to l_eff": "l_eff = 0.12 m + (l - 1.28 m) (docs/user-guide/machines.md note)",
}


def section(m: pkmstiff.StudyMachine, fast: bool) -> pkmstiff.SectionMap:
    """k_z and the strut lengths on the section plane of the study (YZ at x = 0, machine frame)."""
    return m.section("yz", at=0.0, step=STEP["fast" if fast else "default"], quantities=["kz", *DRIVES],
                     u_range=Y_RANGE, v_range=Z_RANGE, tool_length=0.0, frame="machine")


def evaluate(fast: bool) -> dict[str, tuple[Any, pkmstiff.SectionMap]]:
    """k_z and the strut lengths on the plane for every variant: label -> (machine, SectionMap)."""
    out = {}
    for label, spec in VARIANTS:
        m = pkmstiff.load_machine(spec)
        out[label] = (m, section(m, fast))
    return out


def drive_curves(machines: dict[str, Any], lengths: np.ndarray) -> dict[str, np.ndarray]:
    """Drive stiffness (N/m) of chain 1 of every variant over the strut lengths ``lengths`` (m)."""
    state = pkmstiff.ComponentState(drive_position=lengths, strut_length=lengths)
    return {label: np.asarray(m.components_by_role().drive[0].stiffness(state), float) for label, m in machines.items()}


def plot_drive_curves(curves: dict[str, np.ndarray], lengths: np.ndarray, used: tuple[float, float],
                      path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0), constrained_layout=True)
    for label, k in curves.items():
        ax.plot(lengths * 1e3, k / 1e6, label=label, lw=2 if label == BASELINE else 1.5,
                ls="--" if "exact" in label else "-")
    ax.axvspan(used[0] * 1e3, used[1] * 1e3, color="0.85", zorder=0, label="strut lengths on the plane")
    ax.set_xlabel("strut length l [mm]  (l_eff = l - 1160 mm)")
    ax.set_ylabel("drive stiffness k_A [N/um]")
    ax.set_title("6X telescopic strut: drive stiffness over the strut length")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=9)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv, "a", "6X Hexapod: constant vs stroke-dependent drive stiffness (Cobet 3.1)")
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    sw = Stopwatch()
    res = evaluate(args.fast)
    sw.lap("evaluation")
    base_m, base = res[BASELINE]
    const = res[CONSTANT][1]
    labels = [label for label, _ in VARIANTS]
    ok = common_mask(r for _, r in res.values())  # the drive model could change the drive-load check (B.13)
    stats = {label: masked_stats(r.display("kz"), ok) for label, (_, r) in res.items()}
    admissible = {label: int(r.ok.sum()) for label, (_, r) in res.items()}

    # relative deviation of the constant model from the baseline: pointwise and of the statistics
    k_base, k_const = base.display("kz"), const.display("kz")
    rel = 100.0 * (k_const - k_base) / k_base
    rel_ok = rel[ok & np.isfinite(rel)]
    dev = {label: {key: relative_deviation_percent(stats[label][key], stats[BASELINE][key])
                   for key in ("max", "mean", "min")} for label in labels}
    strut = np.stack([base.values[d][ok] for d in DRIVES])  # m
    used = (float(strut.min()), float(strut.max()))

    # ---------------------------------------------------------------------------------------------- figures
    clim = shared_clim(k_base, k_const)
    fig_maps = plot_maps([
        MapPanel(base, k_base, f"k_z, {BASELINE}", "k_z [N/um]", clim=clim),
        MapPanel(base, k_const, f"k_z, {CONSTANT}", "k_z [N/um]", clim=clim),
        MapPanel(base, rel, "(constant - fit 3.22) / fit 3.22", "relative difference [%]",
                 *deviation_colours(rel)),
    ], out / "a_kz_maps.png", "6X Hexapod, YZ plane at x = 0 mm, a = b = c = 0, tool length 0: z-stiffness")
    lengths = np.linspace(1.28, 2.57, 200)
    machines = {label: m for label, (m, _) in res.items()}
    curves = drive_curves(machines, lengths)
    k_used = drive_curves(machines, np.array(used))  # at the shortest / longest strut on the plane
    fig_drive = plot_drive_curves(curves, lengths, used, out / "a_drive_stiffness.png")
    sw.lap("figures")

    # ---------------------------------------------------------------------------------------------- report
    rep = Report(
        title="Study a: 6X Hexapod, constant vs stroke-dependent drive stiffness (Cobet 3.1, Fig. 3.1)",
        summary=(f"With the constant drive stiffness of 250 N/um the mean z-stiffness on the YZ plane deviates by "
                 f"{dev[CONSTANT]['mean']:+.1f} % and the maximum by {dev[CONSTANT]['max']:+.1f} % from the "
                 f"stroke-dependent model (fit eq. 3.22, baseline); pointwise the deviation ranges from "
                 f"{rel_ok.min():+.1f} % to {rel_ok.max():+.1f} % (mean {rel_ok.mean():+.1f} %). "
                 f"The strut lengths on the plane span {used[0] * 1e3:.0f}-{used[1] * 1e3:.0f} mm, where the "
                 f"ball-screw drive stiffness (fit eq. 3.22) varies between {k_used[BASELINE][1] / 1e6:.0f} and "
                 f"{k_used[BASELINE][0] / 1e6:.0f} N/um."),
    )
    sec = rep.section("z-stiffness on the YZ plane",
                      "k_z = force / displacement in z at the TCP (tool length 0, TCP = O'), evaluated at the "
                      f"{stats[BASELINE]['count']} raster points admissible for every variant (admissible per "
                      f"variant: {', '.join(f'{lab} {n}' for lab, n in admissible.items())}). Percentages refer to "
                      "the stroke-dependent model (fit eq. 3.22), the baseline.")
    t = Table("k_z on the YZ plane at x = 0 (admissible points)", labels, baseline=BASELINE)
    add_stat_rows(t, "k_z", "N/um", [stats[lab] for lab in labels])
    sec.tables.append(t)
    td = Table("Relative deviation from the stroke-dependent model (fit eq. 3.22)", labels[1:], digits=3)
    td.add("deviation of mean k_z", "%", [dev[lab]["mean"] for lab in labels[1:]])
    td.add("deviation of max k_z", "%", [dev[lab]["max"] for lab in labels[1:]])
    td.add("deviation of min k_z", "%", [dev[lab]["min"] for lab in labels[1:]])
    rel_exact = 100.0 * (res[labels[2]][1].display("kz") - k_base) / k_base
    rel_exact_ok = rel_exact[ok & np.isfinite(rel_exact)]
    for key, fn in (("min", np.min), ("mean", np.mean), ("max", np.max)):
        td.add(f"pointwise deviation, {key}", "%", [float(fn(rel_ok)), float(fn(rel_exact_ok))])
    sec.tables.append(td)
    sec.figures.append(Figure(fig_maps, "k_z of the stroke-dependent (left) and the constant (middle) drive model "
                                        "on a shared colour scale, and their relative difference (right). White: "
                                        "inadmissible; black line: boundary of the admissible region."))
    sec2 = rep.section("Drive models",
                       "Drive stiffness of one telescopic strut over its length: quadratic fit eq. 3.22 "
                       "(k_A = 85.3 x^2 - 248.14 x + 285.53 N/um, x = l_eff in m), exact series eq. 3.3 "
                       "(2 k_aL = 1300, k_Sp = 211/l_eff N m/um, k_M = 410 N/um) and the constant 250 N/um. "
                       "The grey band is the range of strut lengths that occurs on the plane.")
    tk = Table("Drive stiffness at the shortest and longest strut on the plane", labels)
    for j in (0, 1):
        tk.add(f"k_A at l = {used[j] * 1e3:.0f} mm", "N/um", [k_used[lab][j] / 1e6 for lab in labels])
    sec2.tables.append(tk)
    sec2.figures.append(Figure(fig_drive, "Drive stiffness of the telescopic strut over the strut length."))

    rep.assumptions.update(STUDY_ASSUMPTIONS)
    rep.assumptions.update(machine_assumptions(*(m for m, _ in res.values())))
    pl = base.plane
    rep.settings.update({
        "machines": {lab: spec for lab, spec in VARIANTS}, "baseline": BASELINE,
        "plane": pl.name, "y range [mm]": [Y_RANGE[0] * 1e3, Y_RANGE[1] * 1e3],
        "z range [mm]": [Z_RANGE[0] * 1e3, Z_RANGE[1] * 1e3],
        "raster step [mm]": STEP["fast" if args.fast else "default"] * 1e3,
        "raster points": int(base.ok.size), "orientation a, b, c [deg]": [0, 0, 0], "tool length [mm]": 0.0,
        "mode": "fast" if args.fast else "default", "run time [s]": {**sw.laps},
    })
    results = {
        "study": "a", "fast": args.fast, "baseline": BASELINE, "unit": "N/um",
        "kz_stats": stats, "admissible_points": admissible, "deviation_percent": dev,
        "pointwise_deviation_percent": {"min": float(rel_ok.min()), "mean": float(rel_ok.mean()),
                                        "max": float(rel_ok.max())},
        "strut_length_range_mm": [used[0] * 1e3, used[1] * 1e3],
        "plane": {"y_range_m": Y_RANGE, "z_range_m": Z_RANGE, "step_m": STEP["fast" if args.fast else "default"]},
    }
    sw.lap("report data")
    rep.settings["run time [s]"]["total"] = sw.total
    paths = write_outputs(rep, out, results)
    print(f"study a: k_z mean {stats[BASELINE]['mean']:.1f} N/um (fit 3.22) vs {stats[CONSTANT]['mean']:.1f} N/um "
          f"(constant), deviation of the mean {dev[CONSTANT]['mean']:+.1f} %, "
          f"of the max {dev[CONSTANT]['max']:+.1f} %; "
          f"{sw.total:.1f} s; wrote {paths['html']} and {paths['md']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
