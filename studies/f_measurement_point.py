"""Study f — Hexaglide at the measurement point x = y = 0, z = -1000 mm, a = b = c = 0 (Cobet 5.5, Tables 5.7, 5.8,
Fig. 5.32).

Static stiffness k_x, k_y, k_z at the TCP for tool lengths 0 and 150 mm, the first three eigenfrequencies with the
dominant platform motion, kinetic- and strain-energy shares, the mode shapes, and the weak points (each component's
share of the TCP compliance), for two simulations of the dissertation's comparison:

* joints measured on the test rig (``hexaglide``, the bundled default and this study's baseline),
* FE-based joints (``hexaglide:fe_based_joints``): platform joints from Cobet Table 3.3
  (``hexaglide_2dof_improved_fe``); the 3-DOF FE curve is unpublished, so the toolkit's own FE sweep
  ``iwf_3dof_improved_fe`` is used for the drive joints.

The dissertation also compares with measurements on the machine; the spec gives no measured values, so only the two
simulations are compared.

Run: ``python studies/f_measurement_point.py [--out DIR] [--fast]`` (``--fast`` skips the GIF of mode 1).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study_common import (Stopwatch, machine_assumptions, parse_args, relative_deviation_percent,  # noqa: E402
                           write_outputs)

import pkmstiff  # noqa: E402
from pkmstiff import Figure, Report, Table  # noqa: E402

MEASURED = "test-rig joints (measured)"
FE = "FE-based joints"
VARIANTS = ((MEASURED, "hexaglide"), (FE, "hexaglide:fe_based_joints"))
BASELINE = MEASURED
POSE = np.array([0.0, 0.0, -1.0, 0.0, 0.0, 0.0])  # x, y, z [m], a, b, c [rad] in the report frame (middle guide)
TOOL_LENGTHS = (0.0, 0.150)  # m
DIRECTIONS = ("x", "y", "z")
N_MODES = 3

STUDY_ASSUMPTIONS = {
    "baseline": "the model with the measured (test-rig) joints is the baseline: it is the dissertation's simulation "
                "basis and the toolkit default",
    "FE-based joints": "Cobet 5.5's 'simulation with FE-based joint stiffness': 2-DOF platform joints from Cobet "
                       "Table 3.3; the 3-DOF FE curve is published only graphically and at 45 deg, so the toolkit's "
                       "own FE sweep iwf_3dof_improved_fe (a plausible design, not the IWF geometry) is used",
    "measured machine values": "Cobet Tables 5.7/5.8 also list measurements on the machine; the spec gives none, "
                               "so only the two simulations are compared",
    "tool length": "Cobet 5.5 does not state the tool length of the stiffness measurement: 0 and 150 mm are both "
                   "given; the tool points along -z' from O'; at tool length 0 K_U is neglected (platform and "
                   "spindle rigid) as in the dissertation's stiffness maps (Cobet 4.2.4; docs/user-guide/validation-hexaglide.md (reading 4))",
    "pose": "x = y = 0, z = -1000 mm in the dissertation's report frame (origin at the middle guide, y = 400 mm "
            "in the machine frame; docs/user-guide/validation-hexaglide.md (reading 2))",
    "frequencies": "undamped eigenfrequencies of the 30-DOF rigid-body model (docs/theory/structure.md, meaningful below about "
                   "250 Hz); modes do not depend on the tool length (rigid tool, massless)",
}


def _percent(shares: np.ndarray) -> list[float]:
    """Shares (fractions) in %; round-off below 1e-9 % (e.g. the unloaded massless spindle binding) shown as 0."""
    pct = 100.0 * np.asarray(shares, float)
    return np.where(np.abs(pct) < 1e-9, 0.0, pct).tolist()


def analyse(spec: str) -> dict[str, Any]:
    """Stiffness, modes, weak points and joint angles/stiffness of ``spec`` at ``POSE`` (SI inside, display out)."""
    m = pkmstiff.load_machine(spec)
    n = m.n_chains
    tilts = [f"tilt_{side}_{i}" for side in ("drive", "platform") for i in range(1, n + 1)]
    # the pose is in the report frame; at tool length 0 the TCP is loaded with K_U rigid (neglect_spindle)
    pts = {L: m.point(POSE, frame="report", tool_length=L, n_modes=N_MODES, weak_point_directions=DIRECTIONS,
                      quantities=tilts, neglect_spindle=L == 0.0) for L in TOOL_LENGTHS}
    p = pts[TOOL_LENGTHS[0]]
    if not bool(p.modelled[0]):
        raise RuntimeError(f"{spec}: the measurement pose is not modelled: {p.reasons[0]}")
    stiffness = {}
    weak = {}
    for L, pt in pts.items():
        stiffness[L] = {d: float(pt.stiffness[0, i]) / 1e6 for i, d in enumerate(DIRECTIONS)}  # N/um
        for d in DIRECTIONS:
            weak[(d, L)] = dict(zip(pt.weak_points[d], _percent([v[0] for v in pt.weak_points[d].values()])))
    drives = [b for b in p.mode_kinetic if b.startswith("drive")]
    modes = []
    for k in range(N_MODES):
        modes.append({
            "f_hz": float(p.frequencies_hz[0, k]), "description": p.mode_descriptions[0][k],
            "kinetic_percent": {"platform": 100.0 * float(p.mode_kinetic["platform"][0, k]),
                                "drives (sum)": 100.0 * float(sum(p.mode_kinetic[b][0, k] for b in drives))},
            "strain_percent": dict(zip(p.mode_strain, _percent([v[0, k] for v in p.mode_strain.values()]))),
        })
    mc = m.components_by_role()
    joints = {}
    for side, comps in (("drive", mc.drive_joint), ("platform", mc.platform_joint)):
        tilt = np.array([p.quantities[f"tilt_{side}_{i}"][0] for i in range(1, n + 1)])
        joints[side] = {"tilt_deg": np.rad2deg(tilt).tolist(),
                        "k_N_per_um": [float(c.stiffness(pkmstiff.ComponentState(tilt=tilt[i:i + 1],
                                                                                 swivel=np.full(1, np.nan)))[0]) / 1e6
                                       for i, c in enumerate(comps)]}
    return {"machine": m, "stiffness": stiffness, "weak": weak, "modes": modes, "joints": joints}


def plot_weak_points(results: dict[str, dict[str, Any]], path: Path) -> Path:
    """Stacked bars of the component shares of the TCP compliance (x, y, z; tool 0 and 150 mm) per variant."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(5.2 * len(results), 4.0), constrained_layout=True,
                             sharey=True)
    axes = np.atleast_1d(axes)
    for ax, (label, r) in zip(axes, results.items()):
        keys = [(d, L) for L in TOOL_LENGTHS for d in DIRECTIONS]
        comps = list(r["weak"][keys[0]])
        bottom = np.zeros(len(keys))
        for c in comps:
            vals = np.array([r["weak"][k][c] for k in keys])
            ax.bar(range(len(keys)), vals, bottom=bottom, label=c.replace("_", " "))
            bottom += vals
        ax.set_xticks(range(len(keys)), [f"{d}\n{L * 1e3:g} mm" for d, L in keys])
        ax.set_title(label, fontsize=10)
        ax.set_ylabel("share of the TCP compliance [%]")
        ax.set_ylim(0, 100)
    axes[-1].legend(fontsize=9, loc="center left", bbox_to_anchor=(1.0, 0.5))
    fig.suptitle("Hexaglide at x = y = 0, z = -1000 mm: weak points (load direction, tool length)", fontsize=11)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv, "f", "Hexaglide at the measurement point x = y = 0, z = -1000 mm (Cobet 5.5)")
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    sw = Stopwatch()
    res = {label: analyse(spec) for label, spec in VARIANTS}
    sw.lap("analysis")
    labels = [lab for lab, _ in VARIANTS]
    base, fe = res[BASELINE], res[FE]

    # ---------------------------------------------------------------------------------------------- figures
    # POSE is given in the report frame
    mode_figs = [base["machine"].plot_mode_shape(POSE, out / f"f_mode{k + 1}.png", mode=k + 1, frame="report")
                 for k in range(N_MODES)]
    fe_mode1 = fe["machine"].plot_mode_shape(POSE, out / "f_mode1_fe_joints.png", mode=1, frame="report")
    gif = None
    if not args.fast:
        gif = base["machine"].plot_mode_shape(POSE, out / "f_mode1.gif", mode=1, frame="report", animate=True,
                                              frames=16)
    fig_weak = plot_weak_points(res, out / "f_weak_points.png")
    sw.lap("figures")

    # ---------------------------------------------------------------------------------------------- report
    s0, s150 = base["stiffness"][0.0], base["stiffness"][0.150]
    rep = Report(
        title="Study f: Hexaglide at the measurement point x = y = 0, z = -1000 mm (Cobet 5.5, Tables 5.7, 5.8)",
        summary=(f"With the measured joints the TCP stiffness is k_x = {s0['x']:.2f}, k_y = {s0['y']:.2f}, "
                 f"k_z = {s0['z']:.2f} N/um at tool length 0 and {s150['x']:.2f} / {s150['y']:.2f} / "
                 f"{s150['z']:.2f} N/um at 150 mm; the first three eigenfrequencies are "
                 + ", ".join(f"{mo['f_hz']:.1f} Hz ({mo['description']})" for mo in base["modes"])
                 + ". With the FE-based joints: k_x, k_y, k_z = "
                 + " / ".join(f"{fe['stiffness'][0.0][d]:.2f}" for d in DIRECTIONS) + " N/um (tool 0), f1..f3 = "
                 + " / ".join(f"{mo['f_hz']:.1f}" for mo in fe["modes"]) + " Hz."),
    )
    sec = rep.section("Static stiffness at the TCP (Cobet Table 5.7)",
                      "k = force / displacement in the force direction at the TCP (docs/theory/structure.md); tool along -z' from "
                      "O', pose x = y = 0, z = -1000 mm, a = b = c = 0. k_z does not depend on the tool length here "
                      "(a force along the tool axis exerts no moment about O'). Percentages refer to the measured "
                      "joints.")
    t = Table("TCP stiffness at x = y = 0, z = -1000 mm", labels, baseline=BASELINE)
    for L in TOOL_LENGTHS:
        for d in DIRECTIONS:
            t.add(f"k_{d}, tool length {L * 1e3:g} mm", "N/um", [res[lab]["stiffness"][L][d] for lab in labels])
    sec.tables.append(t)
    tj = Table("Joint tilt angles (axis-referenced) and joint stiffness at the pose",
               [f"chain {i + 1}" for i in range(6)], digits=4)
    for side in ("drive", "platform"):
        tj.add(f"{side} joint tilt", "deg", base["joints"][side]["tilt_deg"])
        for lab in labels:
            tj.add(f"{side} joint k, {lab}", "N/um", res[lab]["joints"][side]["k_N_per_um"])
    sec.tables.append(tj)

    sec2 = rep.section("Eigenfrequencies and mode shapes (Cobet Table 5.8, Fig. 5.32)",
                       "First three undamped eigenfrequencies. Description = dominant motion of the platform "
                       "(its share of the platform's kinetic energy); kinetic-energy shares per body and "
                       "strain-energy shares per component kind, in % of the mode's total.")
    tf = Table("Eigenfrequencies at x = y = 0, z = -1000 mm", labels, baseline=BASELINE)
    for k in range(N_MODES):
        tf.add(f"f{k + 1}", "Hz", [res[lab]["modes"][k]["f_hz"] for lab in labels])
    sec2.tables.append(tf)
    for lab in labels:
        te = Table(f"Energy shares of the modes, {lab}", [f"mode {k + 1}" for k in range(N_MODES)], digits=3)
        modes = res[lab]["modes"]
        te.add("frequency", "Hz", [mo["f_hz"] for mo in modes])
        for key in modes[0]["kinetic_percent"]:
            te.add(f"kinetic energy, {key}", "%", [mo["kinetic_percent"][key] for mo in modes])
        for key in modes[0]["strain_percent"]:
            te.add(f"strain energy, {key.replace('_', ' ')}", "%", [mo["strain_percent"][key] for mo in modes])
        sec2.tables.append(te)
    sec2.text += "\n\n" + "\n\n".join(
        f"{lab}: " + "; ".join(f"mode {k + 1} at {mo['f_hz']:.2f} Hz: {mo['description']}"
                               for k, mo in enumerate(res[lab]["modes"])) + "." for lab in labels)
    if gif is not None:
        sec2.text += f"\n\nAn animation of mode 1 (measured joints) is written beside the report: {gif.name}."
    for k, fig in enumerate(mode_figs):
        sec2.figures.append(Figure(fig, f"Mode {k + 1} with the measured joints ({base['modes'][k]['f_hz']:.2f} Hz, "
                                        f"{base['modes'][k]['description']}); grey: undeformed, displacements scaled "
                                        "to 80 mm peak."))
    sec2.figures.append(Figure(fe_mode1, f"Mode 1 with the FE-based joints ({fe['modes'][0]['f_hz']:.2f} Hz, "
                                         f"{fe['modes'][0]['description']})."))

    sec3 = rep.section("Weak points",
                       "Share of each component kind in the TCP compliance for a unit force in x, y, z (strain "
                       "energy of the load case = compliance in its direction, docs/theory/structure.md); columns = load direction "
                       "and tool length. Each column sums to 100 %.")
    keys = [(d, L) for L in TOOL_LENGTHS for d in DIRECTIONS]
    for lab in labels:
        w = res[lab]["weak"]
        tw = Table(f"Weak points, {lab}", [f"{d}, tool {L * 1e3:g} mm" for d, L in keys], digits=3)
        for comp in w[keys[0]]:
            tw.add(comp.replace("_", " "), "%", [w[k][comp] for k in keys])
        sec3.tables.append(tw)
    sec3.figures.append(Figure(fig_weak, "Component shares of the TCP compliance per load direction and tool length."))

    rep.assumptions.update(STUDY_ASSUMPTIONS)
    rep.assumptions.update(machine_assumptions(*(r["machine"] for r in res.values())))
    rep.settings.update({
        "machines": {lab: spec for lab, spec in VARIANTS}, "baseline": BASELINE,
        "pose x, y, z [mm]": (POSE[:3] * 1e3).tolist(), "orientation a, b, c [deg]": [0, 0, 0],
        "tool lengths [mm]": [L * 1e3 for L in TOOL_LENGTHS], "modes": N_MODES,
        "mode": "fast" if args.fast else "default", "run time [s]": {**sw.laps},
    })
    results = {
        "study": "f", "fast": args.fast, "baseline": BASELINE, "pose_m_rad": POSE.tolist(),
        "stiffness_N_per_um": {lab: {f"tool_{L * 1e3:g}_mm": res[lab]["stiffness"][L] for L in TOOL_LENGTHS}
                               for lab in labels},
        "deviation_percent": {f"k_{d}_tool_{L * 1e3:g}_mm": relative_deviation_percent(
            fe["stiffness"][L][d], base["stiffness"][L][d]) for L in TOOL_LENGTHS for d in DIRECTIONS},
        "modes": {lab: res[lab]["modes"] for lab in labels},
        "weak_points_percent": {lab: {f"{d}_tool_{L * 1e3:g}_mm": res[lab]["weak"][(d, L)] for d, L in keys}
                                for lab in labels},
        "joints": {lab: res[lab]["joints"] for lab in labels},
    }
    rep.settings["run time [s]"]["total"] = sw.total
    paths = write_outputs(rep, out, results)
    f_base = " / ".join(f"{mo['f_hz']:.1f}" for mo in base["modes"])
    f_fe = " / ".join(f"{mo['f_hz']:.1f}" for mo in fe["modes"])
    k_fe = " / ".join(f"{fe['stiffness'][0.0][d]:.2f}" for d in DIRECTIONS)
    print(f"study f: measured joints k_x/k_y/k_z {s0['x']:.2f}/{s0['y']:.2f}/{s0['z']:.2f} N/um (tool 0), "
          f"f1..f3 {f_base} Hz; FE-based joints {k_fe} N/um, {f_fe} Hz; {sw.total:.1f} s; wrote {paths['html']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
