"""Study g — kinematic comparison of the 6X Hexapod, Linapod, Paralix and Hexaglide (Cobet 5.2).

For each machine (docs/user-guide/studies.md "5.2"):

* the constant-orientation workspace at a = b = c = 0 and its volume at one common octree resolution (surface nets,
  the dissertation's tetrahedron method eq. 4.14 and the signed divergence sum), with figures (the 6X and the
  Linapod also seen from above, onto the X-Y plane);
* the usable part where the data admit unusable positions: the Linapod's machine table lies at z = 0 and the
  workspace below it is not usable (Cobet 5.2); the 6X data admit platform positions above the plane of its lower
  drive joints (the platform inside the frame), which the frame of the real machine excludes (study assumption);
* the maximum admissible rotation angle in +a on the YZ plane at x = 0 (Paralix: on the plane x = -2000 mm, as in
  the dissertation), maximum and mean, by the predictor-corrector search of ``rotation_angle_map``.

Run: ``python studies/g_machine_comparison.py [--out DIR] [--fast]``
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study_common import Stopwatch, machine_assumptions, parse_args, write_outputs  # noqa: E402

import pkmstiff  # noqa: E402
from pkmstiff import StudyMachine as Machine  # noqa: E402
from pkmstiff import Figure, Report, RotationMap, Table, Workspace  # noqa: E402

# (label, machine, x of the YZ section plane [m]); the Hexaglide, the dissertation's machine, is the baseline
MACHINES = (("Hexaglide", "hexaglide", 0.0), ("6X Hexapod", "hexapod_6x", 0.0), ("Linapod", "linapod", 0.0),
            ("Paralix", "paralix", -2.0))
BASELINE = MACHINES[0][0]
SETTINGS = {
    # eps: octree resolution (m); step: raster of the rotation map (m); increment (deg)
    "default": {"eps": 0.00625, "step": 0.025, "increment": 1.0},
    "fast": {"eps": 0.05, "step": 0.1, "increment": 3.0},
}
MAX_ANGLE = 90.0  # deg, search bound of the rotation maps
MARGIN = 0.05  # m around the workspace's bounding box for the usable-part box and the section raster

STUDY_ASSUMPTIONS = {
    "resolution": "one octree resolution for all machines, 6.25 mm (--fast 50 mm); the dissertation used 3.125 mm "
                  "- the surface-nets volume differs by < 0.5 % between the two on these machines (checked for "
                  "the Hexaglide in study c: 0.2692 vs 0.2701 m^3); volumes by surface nets (default), the "
                  "tetrahedron method (eq. 4.14, the dissertation's) and the signed divergence sum",
    "whole vs usable": "'whole' = the workspace the geometry admits (the machine without its frame limits), "
                       "'usable' = with the frame limits of the machine file: Linapod machine table at z = 0 "
                       "(Cobet 5.2, O' z >= 0 at tool length 0); 6X platform joints below the plane of the lower "
                       "drive joints, z <= 2.300 - 0.495 = 1.805 m (without it the data admit O' up to z = 3.2 m); "
                       "Hexaglide O' below the drive-joint plane z <= -0.15 m (without it the data admit a mirror "
                       "workspace above the guides; no machine-bed cut, docs/user-guide/validation-hexaglide.md (reading 3))",
    "rotation maps": "maximum admissible +a (rotation about x) from a = b = c = 0 in steps of the increment up to a "
                     "search bound of 90 deg (points at the bound are counted), YZ plane at x = 0 (Paralix "
                     "x = -2000 mm), raster = the workspace's bounding box in y and z plus 50 mm; mean over the "
                     "raster points whose base orientation is admissible",
    "geometry-only machines": "Linapod and Paralix: only the geometry is published (docs/user-guide/machines.md): "
                              "no joint angle limits, no masses (the static drive-load check B.13 is skipped), no "
                              "drive spacing limits; the Paralix has no hull and the Linapod's hull check is off by "
                              "default (see its machine-file assumptions) - their workspaces and rotation angles are "
                              "bounded by reach and strut collisions only and are upper bounds",
    "6X data": "the 6X has the INA coupled joint limit B.6 on the platform side, strut lengths 1.28-2.57 m, no hull "
               "(no strut-platform check) and the drive-load check with an assumed 250 kg platform (machine file)",
    "Hexaglide data": "the Hexaglide includes every check of its file (frame: O' z <= -0.15 m, no bed cut; hull; "
                      "drive spacing; 5 deg minimum drive-joint tilt with vertical drive-joint axes; drive load "
                      "with platform and struts, docs/user-guide/validation-hexaglide.md)",
}


def without_frame(machine: Machine) -> Machine:
    """A copy of ``machine`` without frame limits: the workspace its geometry admits."""
    free = dataclasses.replace(machine.limits, position_min=np.full(3, -np.inf), position_max=np.full(3, np.inf))
    return dataclasses.replace(machine, limits=free)


def usable_limits(machine: Machine) -> tuple[float, float] | None:
    """(z_min, z_max) of the machine file's frame (m), or None where the file sets no frame in z."""
    lo, hi = float(machine.limits.position_min[2]), float(machine.limits.position_max[2])
    return None if np.isinf(lo) and np.isinf(hi) else (lo, hi)


def workspaces(machines: dict[str, Machine], names: dict[str, str], eps: float) -> dict[str, dict[str, Any]]:
    """Whole workspace (geometry only, no frame) and, where the file sets a frame, the usable part per machine."""
    out: dict[str, dict[str, Any]] = {}
    for lab, m in machines.items():
        lim = usable_limits(m)
        whole = without_frame(m).workspace(eps)
        usable = None
        if lim is not None:
            lo, hi = whole.bounding_box()
            lo, hi = lo - MARGIN, hi + MARGIN
            lo[2], hi[2] = max(lo[2], lim[0] - MARGIN), min(hi[2], lim[1] + MARGIN)
            usable = m.workspace(eps, box=(lo, hi), fit_box=True)
        out[lab] = {"whole": whole, "usable": usable, "limits": lim}
    return out


def rotation_map(machine: Machine, ws: Workspace, x: float, cfg: dict[str, float]) -> RotationMap:
    """Maximum +a on the YZ plane at ``x`` (machine frame) over the workspace's y-z bounding box (+ margin), on a
    raster aligned to multiples of the step."""
    lo, hi = ws.bounding_box()
    step = cfg["step"]
    u0, v0 = math.floor((lo[1] - MARGIN) / step) * step, math.floor((lo[2] - MARGIN) / step) * step
    return machine.rotation_map("yz", at=x, step=step, u_range=(u0, hi[1] + MARGIN), v_range=(v0, hi[2] + MARGIN),
                                directions=["+a"], increment=math.radians(cfg["increment"]),
                                max_angle=math.radians(MAX_ANGLE), frame="machine")


def map_stats(r: RotationMap, zlim: tuple[float, float] | None = None) -> dict[str, Any]:
    """Max/mean of +a (deg) over the admissible raster points (optionally only z_min <= z <= z_max)."""
    a = np.degrees(r.angle("+a"))
    keep = np.isfinite(a)
    if zlim is not None:
        keep &= ((r.v_values >= zlim[0]) & (r.v_values <= zlim[1]))[:, None]
    v = a[keep]
    cell = float(np.mean(np.diff(r.u_values)) * np.mean(np.diff(r.v_values)))
    return {"max_deg": float(v.max()) if v.size else None, "mean_deg": float(v.mean()) if v.size else None,
            "min_deg": float(v.min()) if v.size else None, "points": int(v.size),
            "admissible_area_m2": v.size * cell, "at_bound": int((r.at_limit["+a"] & keep).sum())}


def plot_rotation_panels(maps: dict[str, RotationMap], xs: dict[str, float],
                         usable: dict[str, tuple[float, float] | None], path: Path) -> Path:
    """One panel of max. +a per machine (viridis: 0° is a colour, not the background), shared scale; dashed:
    usable-part limit."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = list(maps)
    fig, axes = plt.subplots(1, len(labels), figsize=(4.2 * len(labels) + 1.0, 5.6), squeeze=False)
    fig.subplots_adjust(left=0.05, right=0.9, bottom=0.1, top=0.86, wspace=0.35)
    levels = np.linspace(0.0, MAX_ANGLE, 19)
    for ax, lab in zip(axes[0], labels):
        r = maps[lab]
        a = np.degrees(r.angle("+a"))
        ax.set_facecolor("#f2d7d5")
        U, V = np.meshgrid(r.u_values * 1e3, r.v_values * 1e3)
        if np.isfinite(a).any():
            ax.contourf(U, V, np.ma.masked_invalid(a), levels=levels, cmap="viridis")
            st = map_stats(r)
            ax.set_title(f"{lab}, x = {xs[lab] * 1e3:.0f} mm\nmax {st['max_deg']:.0f} deg, "
                         f"mean {st['mean_deg']:.1f} deg", fontsize=10)
        lim = usable[lab]
        if lim is not None:
            for z in lim:
                if np.isfinite(z):
                    ax.axhline(z * 1e3, color="C0", ls="--", lw=1.2)
        ax.set_xlim(U.min(), U.max())
        ax.set_ylim(V.min(), V.max())
        ax.set_aspect("equal")
        ax.set_xlabel("y [mm]")
        ax.set_ylabel("z [mm]")
    fig.colorbar(plt.cm.ScalarMappable(norm=plt.Normalize(0.0, MAX_ANGLE), cmap="viridis"),
                 cax=fig.add_axes((0.92, 0.2, 0.012, 0.6)), label="max. +a [deg]")
    fig.suptitle("Maximum admissible rotation +a from a = b = c = 0 (shaded: base orientation inadmissible; "
                 "dashed: limit of the usable part)", fontsize=11)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv, "g", "Kinematic comparison of 6X, Linapod, Paralix and Hexaglide (Cobet 5.2)")
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    mode = "fast" if args.fast else "default"
    cfg = SETTINGS[mode]
    sw = Stopwatch()
    names = {lab: name for lab, name, _ in MACHINES}
    xs = {lab: x for lab, _, x in MACHINES}
    machines = {lab: pkmstiff.load_machine(name) for lab, name in names.items()}
    labels = list(machines)

    ws = workspaces(machines, names, cfg["eps"])
    sw.lap("workspaces")
    maps = {lab: rotation_map(machines[lab], ws[lab]["whole"], xs[lab], cfg) for lab in labels}
    rs = {lab: map_stats(maps[lab]) for lab in labels}
    rs_usable = {lab: map_stats(maps[lab], ws[lab]["limits"]) for lab in labels}
    sw.lap("rotation maps")

    # ---------------------------------------------------------------------------------------------- figures
    figs_ws = []
    for lab in labels:
        name = names[lab]
        figs_ws.append((ws[lab]["whole"].plot(out / f"g_workspace_{name}.png", window_size=(900, 700)),
                        f"{lab}: workspace at a = b = c = 0."))
        if name in ("hexapod_6x", "linapod"):
            figs_ws.append((ws[lab]["whole"].plot(out / f"g_workspace_{name}_xy.png",
                                                  # almost from above: a view along z clashes with the view-up vector
                                                  window_size=(900, 700), view=(0.0, -0.02, 1.0)),
                            f"{lab}: workspace seen from above (X-Y plane)."))
        if ws[lab]["usable"] is not None:
            figs_ws.append((ws[lab]["usable"].plot(out / f"g_workspace_{name}_usable.png", window_size=(900, 700)),
                            f"{lab}: usable part of the workspace."))
    fig_rot = plot_rotation_panels(maps, xs, {lab: ws[lab]["limits"] for lab in labels}, out / "g_rotation_a.png")
    sw.lap("figures")

    # ---------------------------------------------------------------------------------------------- report
    vol = {lab: ws[lab]["whole"].volumes for lab in labels}
    vol_use = {lab: (ws[lab]["usable"] or ws[lab]["whole"]).volumes for lab in labels}
    rep = Report(
        title="Study g: kinematic comparison of Hexaglide, 6X Hexapod, Linapod and Paralix (Cobet 5.2)",
        summary=("Workspace volume at a = b = c = 0 (surface nets, eps = " f"{cfg['eps'] * 1e3:g} mm; usable part in "
                 "brackets): " + "; ".join(
                     f"{lab} {vol[lab]['surface_nets']:.3f} m^3"
                     + (f" ({vol_use[lab]['surface_nets']:.3f} m^3)" if ws[lab]["usable"] is not None else "")
                     for lab in labels)
                 + ". Maximum admissible +a on the section plane, max / mean: " + "; ".join(
                     f"{lab} {rs[lab]['max_deg']:.0f} / {rs[lab]['mean_deg']:.1f} deg" for lab in labels)
                 + ". Linapod and Paralix are described by their geometry only (no joint limits, masses or "
                   "platform-hull check), so their values are upper bounds."),
    )
    sec = rep.section(
        "Workspace volumes and +a rotation",
        f"Constant-orientation workspaces at a = b = c = 0, octree resolution {cfg['eps'] * 1e3:g} mm for every "
        f"machine. Rotation maps: raster {cfg['step'] * 1e3:g} mm, increment {cfg['increment']:g} deg, search bound "
        f"{MAX_ANGLE:g} deg. Usable part: Linapod z >= 0 (machine table), 6X z <= "
        f"{ws['6X Hexapod']['limits'][1] * 1e3:.0f} mm (platform below its lower drive joints); Hexaglide and "
        "Paralix: the whole workspace. Percentages: of the Hexaglide.")
    t = Table("Workspace volumes and maximum +a rotation (Cobet 5.2)", labels, baseline=BASELINE)
    t.add("workspace volume, tetrahedron method (eq. 4.14)", "m^3", [vol[lab]["tetrahedron"] for lab in labels])
    t.add("workspace volume, surface nets (default)", "m^3", [vol[lab]["surface_nets"] for lab in labels])
    t.add("workspace volume, divergence (signed)", "m^3", [vol[lab]["divergence"] for lab in labels])
    t.add("usable workspace volume, surface nets", "m^3", [vol_use[lab]["surface_nets"] for lab in labels])
    t.add("usable workspace volume, tetrahedron method", "m^3", [vol_use[lab]["tetrahedron"] for lab in labels])
    t.add("max. +a on the plane: max", "deg", [rs[lab]["max_deg"] for lab in labels])
    t.add("max. +a on the plane: mean", "deg", [rs[lab]["mean_deg"] for lab in labels])
    t.add("max. +a, usable part: max", "deg", [rs_usable[lab]["max_deg"] for lab in labels])
    t.add("max. +a, usable part: mean", "deg", [rs_usable[lab]["mean_deg"] for lab in labels])
    t.add("admissible area of the section plane", "m^2", [rs[lab]["admissible_area_m2"] for lab in labels])
    t.add("share of the section at the 90 deg search bound", "%",
          [100.0 * rs[lab]["at_bound"] / max(rs[lab]["points"], 1) for lab in labels])
    sec.tables.append(t)
    sec.figures.append(Figure(fig_rot, "Maximum admissible +a (grey scale, deg) on the YZ plane of every machine "
                                       "(Paralix at x = -2000 mm); shaded: the base orientation a = b = c = 0 is "
                                       "inadmissible; dashed: limit of the usable part."))
    sec_ws = rep.section(
        "Workspaces",
        "Closed boundary surfaces at a = b = c = 0 with the machine at a central pose. Bounding boxes (mm): "
        + "; ".join(
            f"{lab} x {b['min'][0]:.0f}…{b['max'][0]:.0f}, y {b['min'][1]:.0f}…{b['max'][1]:.0f}, "
            f"z {b['min'][2]:.0f}…{b['max'][2]:.0f}" for lab in labels
            for b in [ws[lab]["whole"].statistics()["bounding_box_mm"]] if b)
        + ". Octree effort: " + "; ".join(
            f"{lab} {s['evaluations']:,} evaluations, {s['run_time_s']:.1f} s" for lab in labels
            for s in [ws[lab]["whole"].statistics()]) + ".")
    for path, caption in figs_ws:
        sec_ws.figures.append(Figure(path, caption))

    rep.assumptions.update(STUDY_ASSUMPTIONS)
    rep.assumptions.update(machine_assumptions(*machines.values()))
    rep.settings.update({
        "machines": names, "baseline": BASELINE, "mode": mode, "workspace resolution eps [mm]": cfg["eps"] * 1e3,
        "orientation a, b, c [deg]": [0, 0, 0], "tool length [mm]": 0.0,
        "section planes x [mm]": {lab: x * 1e3 for lab, x in xs.items()},
        "rotation raster [mm]": cfg["step"] * 1e3, "rotation increment [deg]": cfg["increment"],
        "rotation search bound [deg]": MAX_ANGLE, "rotation method": "predictor_corrector",
        "usable part z limits [mm]": {lab: None if ws[lab]["limits"] is None else
                                      [float(v * 1e3) for v in ws[lab]["limits"]] for lab in labels},
        "run time [s]": {**sw.laps},
    })
    results = {
        "study": "g", "fast": args.fast, "baseline": BASELINE, "resolution_mm": cfg["eps"] * 1e3,
        "volumes_m3": vol, "usable_volumes_m3": {lab: vol_use[lab] for lab in labels},
        "usable_z_limits_m": {lab: ws[lab]["limits"] for lab in labels},
        "rotation_plus_a": rs, "rotation_plus_a_usable": rs_usable,
        "rotation_maps": {lab: {"x_m": xs[lab], "y_m": maps[lab].u_values, "z_m": maps[lab].v_values,
                                "angle_deg": np.where(np.isfinite(maps[lab].angle("+a")),
                                                      np.degrees(maps[lab].angle("+a")), -1.0), "note": "-1 = base orientation inadmissible"}
                          for lab in labels},
        "workspaces": {lab: ws[lab]["whole"].statistics() for lab in labels},
        "settings": cfg,
    }
    rep.settings["run time [s]"]["total"] = sw.total
    paths = write_outputs(rep, out, results)
    print("study g: volume (surface nets) " + ", ".join(f"{lab} {vol[lab]['surface_nets']:.3f}" for lab in labels)
          + " m^3; +a max/mean " + ", ".join(f"{lab} {rs[lab]['max_deg']:.0f}/{rs[lab]['mean_deg']:.1f}"
                                              for lab in labels)
          + f" deg; {sw.total:.1f} s; wrote {paths['html']} and {paths['md']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
