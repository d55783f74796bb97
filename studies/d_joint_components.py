"""Study d — component optimisation: old vs improved Hexaglide joints (Cobet 5.3, Fig. 5.27, Tables 5.2, 5.3).

Static stiffness k_x, k_y, k_z on the YZ plane at x = 0 (a = b = c = 0, tool length 0) and the first three
eigenfrequencies with mode descriptions at x = y = 0, z = -1000 mm (the pose of Cobet 5.5) and z = -950 mm (where
the dissertation measured the frequency responses of Table 5.3), for

* old joints, FE (``hexaglide:old_joints_fe``: the toolkit's FE sweeps ``iwf_3dof_old_fe``, ``iwf_2dof_old_fe``;
  masses of the old joints) — the baseline (the design before the component optimisation),
* improved joints, FE (``hexaglide:improved_joints_fe``: ``iwf_3dof_improved_fe``, ``iwf_2dof_improved_fe``),
* improved joints, measured (``hexaglide``, the bundled default) for reference.

The improved (steel) joints are heavier by 2.35 kg (3 DOF) and 1.8 kg (2 DOF) (docs/theory/components.md); the bundled
masses include the improved joints, so the old variant removes these masses. To separate the effects of stiffness
and mass on the frequencies, the frequency table also has the improved FE joints with the old masses.

Run: ``python studies/d_joint_components.py [--out DIR] [--fast]``
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study_common import (MapPanel, Stopwatch, add_stat_rows, common_mask, machine_assumptions,  # noqa: E402
                           masked_stats, parse_args, plot_maps, relative_deviation_percent, shared_clim,
                           write_outputs)

import pkmstiff  # noqa: E402
from pkmstiff import Figure, Report, Table  # noqa: E402

OLD = "old joints (FE)"
IMPROVED_FE = "improved joints (FE)"
MEASURED = "improved joints (measured)"
STIFF_ONLY = "improved FE stiffness, old masses"
VARIANTS = ((OLD, "hexaglide:old_joints_fe"), (IMPROVED_FE, "hexaglide:improved_joints_fe"),
            (MEASURED, "hexaglide"))
# frequency table only: the stiffness change without the mass change
FREQ_VARIANTS = ((OLD, "hexaglide:old_joints_fe"), (STIFF_ONLY, "hexaglide:improved_joints_fe,old_joint_masses"),
                 (IMPROVED_FE, "hexaglide:improved_joints_fe"), (MEASURED, "hexaglide"))
BASELINE = OLD
Y_RANGE = (-0.25, 1.10)
Z_RANGE = (-1.30, -0.40)
STEP = {"default": 0.005, "fast": 0.025}
QUANTITIES = ("kx", "ky", "kz")
POSES_MM = {"z = -1000 mm (Cobet 5.5)": (0.0, 0.0, -1000.0),
            "z = -950 mm (FRF measurement, Table 5.3)": (0.0, 0.0, -950.0)}
N_MODES = 3

STUDY_ASSUMPTIONS = {
    "baseline": "the old joints are the baseline: the design before the dissertation's component optimisation",
    "old joint stiffness": "the old joints' measured curves are published only graphically (Cobet Fig. 3.32) and "
                           "as single FE points: the toolkit's own FE sweeps of plausible old designs "
                           "(iwf_3dof_old_fe, iwf_2dof_old_fe) are used, so this study cannot reproduce the "
                           "dissertation's numbers exactly (docs/user-guide/studies.md, 5.3 note)",
    "joint masses": "the bundled drive (102.17 kg) and platform (117.24 kg) masses include the improved joints; "
                    "the old joints are lighter by 2.35 kg (3-DOF, per drive) and 1.8 kg (2-DOF, removed as a point "
                    "mass at each platform joint, with the platform CoG and inertia updated) (docs/theory/components.md)",
    "tool": "tool length 0 (TCP = O') for the stiffness (Cobet 5.3 does not restate it; consistent with 4.2.4)",
    "spindle coupling": "K_U neglected at tool length 0 (platform and spindle rigid), as the dissertation's stiffness maps (Cobet 4.2.4, Fig. 4.25; docs/user-guide/validation-hexaglide.md (reading 4))",
    "modal poses": "positions of the dissertation, in its report frame (origin at the middle guide, docs/user-guide/validation-hexaglide.md "
                   "item 2); the section plane is given in the machine frame",
    "frequencies": "undamped eigenfrequencies of the 30-DOF rigid-body model (docs/theory/structure.md); the dissertation's "
                   "Table 5.3 values are measured frequency-response peaks at z = -950 mm",
}


def evaluate_sections(fast: bool) -> dict[str, tuple[Any, pkmstiff.SectionMap]]:
    """k_x, k_y, k_z on the plane (YZ at x = 0, machine frame) for every joint variant: label -> (machine, result)."""
    out = {}
    for label, spec in VARIANTS:
        m = pkmstiff.load_machine(spec)
        out[label] = (m, m.with_(neglect_spindle=True).section(
            "yz", at=0.0, step=STEP["fast" if fast else "default"], quantities=list(QUANTITIES), u_range=Y_RANGE,
            v_range=Z_RANGE, tool_length=0.0, frame="machine"))
    return out


def evaluate_modes(spec: str) -> dict[str, Any]:
    """First three eigenfrequencies (Hz) and platform-motion descriptions at the poses of ``POSES_MM``."""
    m = pkmstiff.load_machine(spec)
    # POSES_MM are the dissertation's positions, i.e. in the report frame (origin at the middle guide)
    poses = np.array([[x / 1e3, y / 1e3, z / 1e3, 0.0, 0.0, 0.0] for x, y, z in POSES_MM.values()])
    p = m.point(poses, frame="report", n_modes=N_MODES)
    return {pose: {"f_hz": [float(f) for f in p.frequencies_hz[i]], "description": p.mode_descriptions[i]}
            for i, pose in enumerate(POSES_MM)}


def plot_joint_curves(machines: dict[str, Any], path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    deg = np.linspace(0.0, 90.0, 181)
    state = pkmstiff.ComponentState(tilt=np.deg2rad(deg), swivel=np.full(deg.size, np.nan))
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    for ax, side, title in zip(axes, ("drive_joint", "platform_joint"),
                               ("drive-side joint (3 DOF)", "platform-side joint (2 DOF)")):
        for label, m in machines.items():
            comp = getattr(m.components_by_role(), side)[0]
            ax.plot(deg, np.asarray(comp.stiffness(state)) / 1e6, label=label, lw=2 if label == BASELINE else 1.5)
        ax.set_title(title)
        ax.set_xlabel("tilt angle (axis-referenced) [deg]")
        ax.set_ylabel("joint stiffness [N/um]")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=9)
    fig.suptitle("Joint stiffness of the variants (spline of Cobet 3.2.5)", fontsize=11)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv, "d", "Hexaglide component optimisation: old vs improved joints (Cobet 5.3)")
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    sw = Stopwatch()
    res = evaluate_sections(args.fast)
    sw.lap("sections")
    modes = {label: evaluate_modes(spec) for label, spec in FREQ_VARIANTS}
    sw.lap("modal analysis")
    labels = [lab for lab, _ in VARIANTS]
    # the old joints' lower masses relax the static drive-load check (B.13): compare on the common points
    ok = common_mask(r for _, r in res.values())
    stats = {q: {lab: masked_stats(r.display(q), ok) for lab, (_, r) in res.items()} for q in QUANTITIES}
    admissible = {label: int(r.ok.sum()) for label, (_, r) in res.items()}
    dev = {q: {lab: {key: relative_deviation_percent(stats[q][lab][key], stats[q][BASELINE][key])
                     for key in ("max", "mean")} for lab in labels[1:]} for q in QUANTITIES}
    base = res[BASELINE][1]
    ratio = {}  # pointwise improved FE / old
    for q in QUANTITIES:
        r = res[IMPROVED_FE][1].display(q) / base.display(q)
        r = r[ok & np.isfinite(r)]
        ratio[q] = {"min": float(r.min()), "mean": float(r.mean()), "max": float(r.max())}

    # ---------------------------------------------------------------------------------------------- figures
    panels = []
    for q in QUANTITIES:
        vals = [r.display(q) for _, r in res.values()]
        clim = shared_clim(*vals)
        panels += [MapPanel(r, v, f"{q}, {lab}", f"{q} [N/um]", clim=clim)
                   for (lab, (_, r)), v in zip(res.items(), vals)]
    fig_maps = plot_maps(panels, out / "d_stiffness_maps.png",
                         "Hexaglide, YZ plane at x = 0 mm, a = b = c = 0, tool length 0: old vs improved joints",
                         ncols=3)
    fig_joint = plot_joint_curves({lab: m for lab, (m, _) in res.items()}, out / "d_joint_curves.png")
    sw.lap("figures")

    # ---------------------------------------------------------------------------------------------- report
    fl = [lab for lab, _ in FREQ_VARIANTS]
    p1000 = list(POSES_MM)[0]
    f_old, f_new = modes[OLD][p1000]["f_hz"], modes[IMPROVED_FE][p1000]["f_hz"]
    rep = Report(
        title="Study d: Hexaglide component optimisation, old vs improved joints (Cobet 5.3, Tables 5.2, 5.3)",
        summary=(f"Replacing the old joints by the improved ones (both from the toolkit's FE sweeps) raises the mean "
                 f"stiffness on the YZ plane by {dev['kx'][IMPROVED_FE]['mean']:+.1f} % in x, "
                 f"{dev['ky'][IMPROVED_FE]['mean']:+.1f} % in y and {dev['kz'][IMPROVED_FE]['mean']:+.1f} % in z "
                 f"(maximum: {dev['kx'][IMPROVED_FE]['max']:+.1f} / {dev['ky'][IMPROVED_FE]['max']:+.1f} / "
                 f"{dev['kz'][IMPROVED_FE]['max']:+.1f} %). At x = y = 0, z = -1000 mm the first three "
                 f"eigenfrequencies change from {f_old[0]:.1f} / {f_old[1]:.1f} / {f_old[2]:.1f} Hz to "
                 f"{f_new[0]:.1f} / {f_new[1]:.1f} / {f_new[2]:.1f} Hz "
                 f"({relative_deviation_percent(f_new[0], f_old[0]):+.1f} / "
                 f"{relative_deviation_percent(f_new[1], f_old[1]):+.1f} / "
                 f"{relative_deviation_percent(f_new[2], f_old[2]):+.1f} %), including the 2.35 kg / 1.8 kg "
                 f"heavier joints."),
    )
    sec = rep.section("Static stiffness on the YZ plane (Cobet Fig. 5.27, Table 5.2)",
                      f"k = force / displacement at the TCP (tool length 0) over the {stats['kx'][BASELINE]['count']} "
                      "raster points admissible for every variant (admissible per variant: "
                      f"{', '.join(f'{lab} {n}' for lab, n in admissible.items())}; the lighter old joints relax the "
                      "static drive-load check B.13). Percentages refer to the old joints.")
    t = Table("Stiffness max/mean (min) on the YZ plane at x = 0", labels, baseline=BASELINE)
    for q in QUANTITIES:
        add_stat_rows(t, f"k_{q[1]}", "N/um", [stats[q][lab] for lab in labels])
    sec.tables.append(t)
    tr = Table("Pointwise ratio improved FE / old FE joints over the plane", ["min", "mean", "max"], digits=3)
    for q in QUANTITIES:
        tr.add(f"k_{q[1]} ratio", "-", [ratio[q]["min"], ratio[q]["mean"], ratio[q]["max"]])
    sec.tables.append(tr)
    sec.figures.append(Figure(fig_maps, "k_x (top), k_y (middle), k_z (bottom) for the old FE joints (left), the "
                                        "improved FE joints (middle) and the improved measured joints (right); one "
                                        "colour scale per row. White: inadmissible."))
    sec.figures.append(Figure(fig_joint, "Joint stiffness curves of the variants."))

    sec2 = rep.section("Eigenfrequencies at x = y = 0 (Cobet Table 5.3)",
                       "First three undamped eigenfrequencies of the structure model at a = b = c = 0. The column "
                       f"'{STIFF_ONLY}' isolates the stiffness effect: the difference to '{IMPROVED_FE}' is the "
                       "effect of the heavier improved joints alone. Mode descriptions name the dominant platform "
                       "motion (share of the platform's kinetic energy).")
    for pose in POSES_MM:
        tf = Table(f"Eigenfrequencies at {pose}", fl, baseline=BASELINE)
        for k in range(N_MODES):
            tf.add(f"f{k + 1}", "Hz", [modes[lab][pose]["f_hz"][k] for lab in fl])
        sec2.tables.append(tf)
    lines = []
    for pose in POSES_MM:
        for lab in fl:
            d = modes[lab][pose]
            lines.append(f"{pose}, {lab}: " + "; ".join(f"f{k + 1} = {d['f_hz'][k]:.2f} Hz {d['description'][k]}"
                                                         for k in range(N_MODES)) + ".")
    sec2.text += "\n\n" + "\n\n".join(lines)

    rep.assumptions.update(STUDY_ASSUMPTIONS)
    rep.assumptions.update(machine_assumptions(*(pkmstiff.load_machine(spec) for _, spec in FREQ_VARIANTS)))
    step = STEP["fast" if args.fast else "default"]
    rep.settings.update({
        "machines": {lab: spec for lab, spec in FREQ_VARIANTS}, "baseline": BASELINE, "plane": base.plane.name,
        "y range [mm]": [Y_RANGE[0] * 1e3, Y_RANGE[1] * 1e3], "z range [mm]": [Z_RANGE[0] * 1e3, Z_RANGE[1] * 1e3],
        "raster step [mm]": step * 1e3, "raster points": int(base.ok.size), "orientation a, b, c [deg]": [0, 0, 0],
        "tool length [mm]": 0.0, "modal poses x, y, z [mm]": list(POSES_MM.values()), "modes": N_MODES,
        "mode": "fast" if args.fast else "default", "run time [s]": {**sw.laps},
    })
    results = {
        "study": "d", "fast": args.fast, "baseline": BASELINE, "unit": "N/um", "stiffness_stats": stats,
        "admissible_points": admissible,
        "deviation_percent": dev, "pointwise_ratio_improved_fe_over_old": ratio, "modes": modes,
        "plane": {"y_range_m": Y_RANGE, "z_range_m": Z_RANGE, "step_m": step},
    }
    rep.settings["run time [s]"]["total"] = sw.total
    paths = write_outputs(rep, out, results)
    print(f"study d: mean k_x/k_y/k_z improved FE vs old {dev['kx'][IMPROVED_FE]['mean']:+.1f} / "
          f"{dev['ky'][IMPROVED_FE]['mean']:+.1f} / {dev['kz'][IMPROVED_FE]['mean']:+.1f} %, f1..f3 at z = -1000 mm "
          f"{f_old[0]:.1f}/{f_old[1]:.1f}/{f_old[2]:.1f} -> {f_new[0]:.1f}/{f_new[1]:.1f}/{f_new[2]:.1f} Hz; "
          f"{sw.total:.1f} s; wrote {paths['html']} and {paths['md']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
