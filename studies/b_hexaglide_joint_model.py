"""Study b — Hexaglide joint model: constant vs angle-dependent joint stiffness (Cobet 3.2, Fig. 3.9, Table 3.2),
and the tilt-angle distributions of the first drive-side and platform-side joint (Cobet 3.2.5, Fig. 3.34, Table 3.4).

x-stiffness k_x of the Hexaglide on the YZ plane at x = 0 (a = b = c = 0, tool length 0) with

* angle-dependent joint stiffness: the improved joints, measured (bundled tables, docs/theory/components.md; the
  toolkit default and this study's baseline),
* constant joint stiffness: the 0° values of the same joints, 262 N/µm drive side (3 DOF) and 269 N/µm platform
  side (2 DOF) (``hexaglide:constant_joint_stiffness``).

Writes maps of k_x for both models and of their relative difference, tables of max/mean/min with % of the baseline
and the relative deviation, and the tilt angles of drive joint 1 and platform joint 1 with the joint stiffness at
their maximum, mean and minimum (spline of Cobet 3.2.5).

Run: ``python studies/b_hexaglide_joint_model.py [--out DIR] [--fast]``
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

BASELINE = "angle-dependent (measured)"
CONSTANT = "constant (0 deg values)"
VARIANTS = ((BASELINE, "hexaglide"), (CONSTANT, "hexaglide:constant_joint_stiffness"))
# YZ plane at x = 0 (m): the admissible region of the Hexaglide at a = b = c = 0 (y -170…1020 mm,
# z -1100…-420 mm between the machine bed and the frame limit) with a margin.
Y_RANGE = (-0.25, 1.10)
Z_RANGE = (-1.30, -0.40)
STEP = {"default": 0.005, "fast": 0.025}
CLIP_PERCENTILE = 95.0  # colour scale of the relative-difference map (a few points near the singular lower edge)
JOINTS = (("drive joint 1 (3 DOF)", "tilt_drive_1", "drive_joint"),
          ("platform joint 1 (2 DOF)", "tilt_platform_1", "platform_joint"))

STUDY_ASSUMPTIONS = {
    "baseline": "the angle-dependent (measured) joint model is the baseline: it is the dissertation's simulation "
                "basis (component data of chapter 3); the constant 0 deg model is the simplification compared "
                "against it, so its % and deviations state the error of the simplification",
    "constant joint stiffness": "0 deg values of the improved measured joints: 262 N/um (3-DOF, drive side), "
                                "269 N/um (2-DOF, platform side), docs/theory/components.md",
    "tool": "tool length 0 (TCP = O'); spindle and platform as in the machine file (K_P as K_U)",
    "plane extent": "YZ plane at x = 0 (machine frame), y -250…1100 mm, z -1300…-400 mm: the whole admissible "
                    "region at a = b = c = 0 (no machine-bed cut, docs/user-guide/validation-hexaglide.md (reading 3))",
    "spindle coupling": "K_U neglected at tool length 0 (platform and spindle rigid), as the dissertation's stiffness maps (Cobet 4.2.4, Fig. 4.25; docs/user-guide/validation-hexaglide.md (reading 4))",
}


def evaluate(fast: bool) -> dict[str, tuple[Any, pkmstiff.SectionMap]]:
    """k_x (both variants) and the tilt angles of joints 1 (baseline) on the plane (YZ at x = 0, machine frame):
    label -> (machine, result)."""
    out = {}
    for label, spec in VARIANTS:
        m = pkmstiff.load_machine(spec)
        names = ["kx"] + ([q for _, q, _ in JOINTS] if label == BASELINE else [])
        out[label] = (m, m.with_(neglect_spindle=True).section(
            "yz", at=0.0, step=STEP["fast" if fast else "default"], quantities=names, u_range=Y_RANGE,
            v_range=Z_RANGE, tool_length=0.0, frame="machine"))
    return out


def joint_stiffness(machine: Any, side: str, tilt_rad: np.ndarray) -> np.ndarray:
    """Stiffness (N/m) of chain 1's joint on ``side`` ("drive_joint" | "platform_joint") at axis-referenced tilts."""
    comp = getattr(machine.components_by_role(), side)[0]
    t = np.atleast_1d(np.asarray(tilt_rad, float))
    return np.asarray(comp.stiffness(pkmstiff.ComponentState(tilt=t, swivel=np.full_like(t, np.nan))), float)


def tilt_table(machine: Any, res: pkmstiff.SectionMap) -> dict[str, dict[str, float]]:
    """Per joint: max/mean/min tilt (deg) over the plane, the joint stiffness there (N/um), the plane-mean stiffness."""
    out = {}
    for label, q, side in JOINTS:
        tilt = np.deg2rad(res.display(q)[res.ok])
        tilt = tilt[np.isfinite(tilt)]
        picks = {"max": tilt.max(), "mean": tilt.mean(), "min": tilt.min()}
        k = joint_stiffness(machine, side, np.array(list(picks.values()))) / 1e6
        row = {f"tilt {key}": float(np.rad2deg(v)) for key, v in picks.items()}
        row.update({f"k at tilt {key}": float(kv) for key, kv in zip(picks, k)})
        row["k mean over the plane"] = float(np.mean(joint_stiffness(machine, side, tilt)) / 1e6)
        row["k at 0 deg"] = float(joint_stiffness(machine, side, np.zeros(1))[0] / 1e6)
        out[label] = row
    return out


def plot_joint_curves(machines: dict[str, Any], tilts: dict[str, dict[str, float]], path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    deg = np.linspace(0.0, 90.0, 181)
    for ax, (jlabel, _, side) in zip(axes, JOINTS):
        for label, m in machines.items():
            ax.plot(deg, joint_stiffness(m, side, np.deg2rad(deg)) / 1e6, label=label,
                    lw=2 if label == BASELINE else 1.5)
        t = tilts[jlabel]
        ax.axvspan(t["tilt min"], t["tilt max"], color="0.85", zorder=0, label="tilt range on the plane")
        ax.axvline(t["tilt mean"], color="0.4", ls=":", label="mean tilt on the plane")
        ax.set_title(f"{jlabel}")
        ax.set_xlabel("tilt angle (axis-referenced) [deg]")
        ax.set_ylabel("joint stiffness [N/um]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=9)
    fig.suptitle("Hexaglide joint stiffness over the tilt angle (spline of Cobet 3.2.5)", fontsize=11)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv, "b", "Hexaglide: constant vs angle-dependent joint stiffness (Cobet 3.2)")
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    sw = Stopwatch()
    res = evaluate(args.fast)
    sw.lap("evaluation")
    base_m, base = res[BASELINE]
    const = res[CONSTANT][1]
    labels = [label for label, _ in VARIANTS]
    ok = common_mask(r for _, r in res.values())
    stats = {label: masked_stats(r.display("kx"), ok) for label, (_, r) in res.items()}
    admissible = {label: int(r.ok.sum()) for label, (_, r) in res.items()}
    dev = {key: relative_deviation_percent(stats[CONSTANT][key], stats[BASELINE][key])
           for key in ("max", "mean", "min")}
    k_base, k_const = base.display("kx"), const.display("kx")
    rel = 100.0 * (k_const - k_base) / k_base
    rel_ok = rel[ok & np.isfinite(rel)]
    tilts = tilt_table(base_m, base)

    # ---------------------------------------------------------------------------------------------- figures
    clim = shared_clim(k_base, k_const)
    rel_cmap, rel_clim = deviation_colours(rel, CLIP_PERCENTILE)
    fig_maps = plot_maps([
        MapPanel(base, k_base, f"k_x, {BASELINE}", "k_x [N/um]", clim=clim),
        MapPanel(base, k_const, f"k_x, {CONSTANT}", "k_x [N/um]", clim=clim),
        MapPanel(base, rel, "(constant - angle-dep.) / angle-dep.", "relative difference [%]", cmap=rel_cmap,
                 clim=rel_clim),
    ], out / "b_kx_maps.png", "Hexaglide, YZ plane at x = 0 mm, a = b = c = 0, tool length 0: x-stiffness")
    fig_tilt = plot_maps([MapPanel(base, base.display(q), f"tilt of {jl}", "tilt [deg]", cmap="plasma")
                          for jl, q, _ in JOINTS],
                         out / "b_tilt_maps.png",
                         "Hexaglide, YZ plane at x = 0 mm: joint tilt angles (axis-referenced)")
    fig_joint = plot_joint_curves({lab: m for lab, (m, _) in res.items()}, tilts, out / "b_joint_curves.png")
    sw.lap("figures")

    # ---------------------------------------------------------------------------------------------- report
    dj, pj = (tilts[j[0]] for j in JOINTS)
    rep = Report(
        title="Study b: Hexaglide, constant vs angle-dependent joint stiffness (Cobet 3.2, Fig. 3.9, Tables 3.2, 3.4)",
        summary=(f"With constant joint stiffness (0 deg values) the mean x-stiffness on the YZ plane deviates by "
                 f"{dev['mean']:+.1f} % and the maximum by {dev['max']:+.1f} % from the angle-dependent model "
                 f"(baseline); pointwise the constant model is {rel_ok.min():+.1f} % to {rel_ok.max():+.1f} % off "
                 f"(mean {rel_ok.mean():+.1f} %). Drive joint 1 tilts between {dj['tilt min']:.1f} and "
                 f"{dj['tilt max']:.1f} deg (mean {dj['tilt mean']:.1f} deg, stiffness {dj['k at tilt mean']:.0f} N/um "
                 f"there against 262 N/um at 0 deg); platform joint 1 between {pj['tilt min']:.1f} and "
                 f"{pj['tilt max']:.1f} deg (mean {pj['tilt mean']:.1f} deg, {pj['k at tilt mean']:.0f} N/um)."),
    )
    sec = rep.section("x-stiffness on the YZ plane (Cobet Fig. 3.9, Table 3.2)",
                      f"k_x = force / displacement in x at the TCP (tool length 0), at the {stats[BASELINE]['count']} "
                      "raster points admissible for both variants (admissible per variant: "
                      f"{', '.join(f'{lab} {n}' for lab, n in admissible.items())}). Percentages refer to the "
                      "angle-dependent model, the baseline. The minimum lies at the lower edge of the "
                      "region, where the Hexaglide approaches a singularity of the second kind (k_x tends to 0 "
                      "although the condition number stays moderate); it is reported as computed.")
    t = Table("k_x on the YZ plane at x = 0 (admissible points)", labels, baseline=BASELINE)
    add_stat_rows(t, "k_x", "N/um", [stats[lab] for lab in labels])
    sec.tables.append(t)
    td = Table("Relative deviation of the constant model from the angle-dependent model", [CONSTANT], digits=3)
    for key in ("mean", "max", "min"):
        td.add(f"deviation of {key} k_x", "%", [dev[key]])
    for key, fn in (("min", np.min), ("mean", np.mean), ("max", np.max)):
        td.add(f"pointwise deviation, {key}", "%", [float(fn(rel_ok))])
    sec.tables.append(td)
    sec.figures.append(Figure(fig_maps, "k_x with angle-dependent (left) and constant (middle) joint stiffness on a "
                                        "shared colour scale, and their relative difference (right; colour "
                                        "scale clipped at the "
                                        f"{CLIP_PERCENTILE:g}th percentile of its magnitude, maximum "
                                        f"{rel_ok.max():.0f} %). White: inadmissible; black line: boundary of "
                                        "the admissible region."))
    sec2 = rep.section("Joint tilt angles (Cobet 3.2.5, Fig. 3.34, Table 3.4)",
                       "Axis-referenced tilt angle (0 deg = strut along the first joint axis) of the first drive-side "
                       "(3 DOF) and the first platform-side (2 DOF) joint over the admissible points of the plane, "
                       "and the measured joint stiffness at the maximum, mean and minimum tilt (clamped cubic spline, "
                       "end slopes = secants, Cobet 3.2.5). The drive-joint tilt is limited to >= 5 deg (Cobet 5.4).")
    tt = Table("Tilt angles of joints 1 and the joint stiffness at these angles", [j[0] for j in JOINTS])
    for key, unit in (("tilt max", "deg"), ("tilt mean", "deg"), ("tilt min", "deg"), ("k at tilt max", "N/um"),
                      ("k at tilt mean", "N/um"), ("k at tilt min", "N/um"), ("k mean over the plane", "N/um"),
                      ("k at 0 deg", "N/um")):
        tt.add(key, unit, [tilts[j[0]][key] for j in JOINTS])
    sec2.tables.append(tt)
    sec2.figures.append(Figure(fig_tilt, "Tilt angle of drive joint 1 (left) and platform joint 1 (right) on the "
                                         "YZ plane."))
    sec2.figures.append(Figure(fig_joint, "Joint stiffness curves (angle-dependent: measured improved joints; "
                                          "constant: their 0 deg values) with the tilt range on the plane (grey) "
                                          "and the mean tilt (dotted)."))

    rep.assumptions.update(STUDY_ASSUMPTIONS)
    rep.assumptions.update(machine_assumptions(*(m for m, _ in res.values())))
    step = STEP["fast" if args.fast else "default"]
    rep.settings.update({
        "machines": {lab: spec for lab, spec in VARIANTS}, "baseline": BASELINE, "plane": base.plane.name,
        "y range [mm]": [Y_RANGE[0] * 1e3, Y_RANGE[1] * 1e3], "z range [mm]": [Z_RANGE[0] * 1e3, Z_RANGE[1] * 1e3],
        "raster step [mm]": step * 1e3, "raster points": int(base.ok.size), "orientation a, b, c [deg]": [0, 0, 0],
        "tool length [mm]": 0.0, "mode": "fast" if args.fast else "default", "run time [s]": {**sw.laps},
    })
    results = {
        "study": "b", "fast": args.fast, "baseline": BASELINE, "unit": "N/um", "kx_stats": stats,
        "admissible_points": admissible,
        "deviation_percent": dev,
        "pointwise_deviation_percent": {"min": float(rel_ok.min()), "mean": float(rel_ok.mean()),
                                        "max": float(rel_ok.max())},
        "tilt_table": tilts, "plane": {"y_range_m": Y_RANGE, "z_range_m": Z_RANGE, "step_m": step},
    }
    rep.settings["run time [s]"]["total"] = sw.total
    paths = write_outputs(rep, out, results)
    print(f"study b: k_x mean {stats[BASELINE]['mean']:.2f} N/um (angle-dependent) vs {stats[CONSTANT]['mean']:.2f} "
          f"N/um (constant), deviation of the mean {dev['mean']:+.1f} %, of the max {dev['max']:+.1f} %; "
          f"{sw.total:.1f} s; wrote {paths['html']} and {paths['md']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
