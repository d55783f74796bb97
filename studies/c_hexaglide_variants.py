"""Study c — Hexaglide original vs Kirchner's variants 1 and 2 (Cobet 5.1, Table 5.1).

For each configuration (``hexaglide``, ``hexaglide_v1``, ``hexaglide_v2``; component data of the variants = the
original's, docs/user-guide/machines.md) the quantities of the dissertation's Table 5.1 (docs/user-guide/studies.md "5.1"):

* constant-orientation workspace at a = b = c = 0 and its volume (modified octree; the dissertation's tetrahedron
  method eq. 4.14 at eps = 3.125 mm, and the toolkit's surface-nets and divergence volumes on the same boundary);
* transmission quality U (eq. 4.75, w = 0.5 m / 20 deg from the machine files, eq. 5.1) on the YZ plane at x = 0:
  maximum and mean;
* static x-stiffness k_x at the TCP with a tool length of 150 mm on the YZ plane: maximum and mean;
* maximum tool velocity in y (eq. 4.79, drive speed 1 m/s) on the YZ plane: maximum and mean;
* the rotational workspace projections "+a over (b, c)" and "+b over (a, c)" at the dissertation's points and, because
  those points are given in the dissertation's report frame (middle guide), also at the centre of each
  configuration's YZ section.

Table 5.1 layout: absolute values and % of the original. Also the workspace without the static drive-load check
(B.13), since Kirchner's variants were optimised for the kinematics only.

Run: ``python studies/c_hexaglide_variants.py [--out DIR] [--fast]``
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study_common import (MapPanel, Stopwatch, machine_assumptions, parse_args, plot_maps,  # noqa: E402
                           shared_clim, write_outputs)

import pkmstiff  # noqa: E402
from pkmstiff import Figure, Report, StudyMachine, Table  # noqa: E402

# (label, machine); the first is the baseline of every table
VARIANTS = (("original", "hexaglide"), ("variant 1", "hexaglide_v1"), ("variant 2", "hexaglide_v2"))
BASELINE = VARIANTS[0][0]
# points of the rotational workspace in the dissertation (Cobet 5.1), m, in its report frame (middle guide)
DISSERTATION_POINTS = {"original": (0.0, 0.0, -0.900), "variant 1": (0.0, 0.0, -1.150),
                       "variant 2": (0.0, -0.200, -1.000)}
TOOL_LENGTH = 0.150  # m, Cobet 5.1: x-stiffness with a 150 mm tool
QUANTITIES = ("U", "kx", "vmax_y")
# YZ plane at x = 0 (m): covers the admissible regions of all three configurations (y -0.17…1.31 m) between the
# machine bed (z = -1.1 m) and the frame's upper limit z = -0.34 m of hexaglide.toml
Y_RANGE = (-0.30, 1.40)
Z_RANGE = (-1.30, -0.40)
NO_DRIVE_LOAD = ("drive_load",)  # admissibility checks left out of the kinematic variants
SETTINGS = {
    # eps: octree resolution (m); step: section raster (m); rot: rotational-workspace raster (deg) and increment
    "default": {"eps": 0.003125, "step": 0.005, "rot_u_step": 2.0, "rot_v_step": 4.0, "rot_increment": 1.0},
    "fast": {"eps": 0.025, "step": 0.025, "rot_u_step": 6.0, "rot_v_step": 12.0, "rot_increment": 2.0},
}
ROT_U_RANGE = (-30.0, 30.0)  # deg, first free angle (b for +a, a for +b)
ROT_V_RANGE = (-60.0, 60.0)  # deg, c
QLABEL = {"U": ("transmission quality U", "1"), "kx": ("k_x (tool 150 mm)", "N/um"),
          "vmax_y": ("v_max in y", "m/min")}

STUDY_ASSUMPTIONS = {
    "workspace volume": "the dissertation computed the volume with the tetrahedron method (eq. 4.14) at eps = "
                        "3.125 mm; the same octree boundary also gives the surface-nets volume (toolkit default, "
                        "converges quadratically) and the divergence volume (signed tetrahedron sum, correct for "
                        "workspaces that are not star-shaped about the point-cloud centre, where the unsigned "
                        "tetrahedron sum over-counts). All three are listed; % of the original per method",
    "workspace box": "octree start box = the chains' reach box cut to the frame limit of hexaglide.toml "
                     "(O' below the drive-joint plane z <= -0.15 m; no machine-bed cut, docs/user-guide/validation-hexaglide.md (reading 3)), "
                     "inherited by the variants",
    "section plane": "YZ plane at x = 0 (machine frame), y -300…1400 mm, z -1300…-400 mm: covers the admissible region of all "
                     "three "
                     "configurations; statistics over the admissible raster points only (raster not stated in "
                     "the dissertation)",
    "transmission weight": "w = 0.5 m / 20 deg = 1.432 m/rad from the machine files (eq. 5.1)",
    "velocity": "v_max in y = largest TCP speed along y with every drive at most 1 m/s (eq. 4.79), a = b = c = 0",
    "variants' component data": "the variants use the original's component data (Cobet 5.1); strut stiffness and "
                                "mass scaled with the strut length (EA = 3.26e8 N, 12.13 kg/m, docs/theory/kinematics.md)",
    "variants' hulls": "the variants' platform hulls are the convex hulls of the 3 + 3 printed vertices (Cobet "
                       "Tables C.3, C.4) - much smaller bodies than the original's 28-vertex hull, so the "
                       "strut-platform check cuts less of the variants' workspaces; three printed variant-1 "
                       "vertices break the vertex pattern in one sign (docs/theory/kinematics.md note 3, option pattern_hull, "
                       "not used)",
    "rotational workspace points": "the dissertation's points (original x = 0, y = 0, z = -900 mm; variant 1 "
                                   "z = -1150 mm; variant 2 y = -200, z = -1000 mm) are given in its report frame "
                                   "(origin at each configuration's middle guide, docs/user-guide/validation-hexaglide.md (reading 2)) and "
                                   "converted to the machine frame; the projections are also evaluated at the "
                                   "centroid of each configuration's admissible YZ section (nearest admissible "
                                   "raster point)",
    "rotational workspace raster": "+a over (b, c) and +b over (a, c) with b resp. a in -30…30 deg and c in "
                                   "-60…60 deg (the dissertation's ranges are not stated); search bound 90 deg",
}


def workspaces(machines: dict[str, StudyMachine], eps: float) -> dict[str, dict[str, pkmstiff.Workspace]]:
    """Constant-orientation workspaces (a = b = c = 0) with all checks and without B.13, per configuration."""
    out = {}
    for label, m in machines.items():
        out[label] = {
            "all": m.workspace(eps, (0.0, 0.0, 0.0)),
            "no_drive_load": m.workspace(eps, (0.0, 0.0, 0.0), skip_checks=NO_DRIVE_LOAD),
        }
    return out


def section(machine: StudyMachine, step: float, skip_checks: Sequence[str] = ()) -> pkmstiff.SectionMap:
    """U, k_x (tool 150 mm) and v_max,y on the YZ plane at x = 0 (machine frame)."""
    return machine.section("yz", at=0.0, step=step, quantities=list(QUANTITIES), u_range=Y_RANGE, v_range=Z_RANGE,
                           tool_length=TOOL_LENGTH, frame="machine", skip_checks=skip_checks)


def sections(machines: dict[str, StudyMachine], step: float) -> dict[str, pkmstiff.SectionMap]:
    """U, k_x (tool 150 mm) and v_max,y on the YZ plane for every configuration."""
    return {label: section(m, step) for label, m in machines.items()}


def kinematic_section(machine: StudyMachine, step: float) -> pkmstiff.SectionMap:
    """The section of :func:`sections` with every check except the static drive load (B.13)."""
    return section(machine, step, skip_checks=NO_DRIVE_LOAD)


def argmax_pose(res: pkmstiff.SectionMap, name: str) -> list[float]:
    """Position of O' (mm) where ``name`` is largest on the section."""
    v = np.where(res.ok, res.values[name], -np.inf)
    iv, iu = np.unravel_index(int(np.argmax(v)), v.shape)
    p = res.plane.origin + res.plane.u_values[iu] * res.plane.u_axis + res.plane.v_values[iv] * res.plane.v_axis
    return (p * 1e3).tolist()


def section_centre(res: pkmstiff.SectionMap) -> tuple[float, float, float]:
    """The admissible raster point nearest to the centroid of the admissible region of the section (m)."""
    pts = res.plane.points()[res.ok.ravel()]
    c = pts.mean(axis=0)
    return tuple(float(v) for v in pts[np.argmin(np.linalg.norm(pts - c, axis=1))])


def point_status(m: StudyMachine, point: Sequence[float]) -> str:
    """'admissible' or the failing checks at (point, a = b = c = 0)."""
    ok, reasons = m.admissibility([*point, 0.0, 0.0, 0.0])
    return "admissible" if ok[0] else "; ".join(reasons[0])


def rotational(m: StudyMachine, point: Sequence[float], cfg: dict[str, float]) -> dict[str, Any]:
    """+a over (b, c) and +b over (a, c) at ``point`` (m)."""
    u = np.radians(np.arange(ROT_U_RANGE[0], ROT_U_RANGE[1] + 1e-9, cfg["rot_u_step"]))
    v = np.radians(np.arange(ROT_V_RANGE[0], ROT_V_RANGE[1] + 1e-9, cfg["rot_v_step"]))
    inc = math.radians(cfg["rot_increment"])
    return {d: m.orientation_map(point, d, u_values=u, v_values=v, increment=inc) for d in ("+a", "+b")}


def rot_stats(r: Any) -> dict[str, Any]:
    a = np.degrees(next(iter(r.angles.values())))
    fin = a[np.isfinite(a)]
    return {"admissible_orientations": int(fin.size), "raster_points": int(a.size),
            "max_deg": float(fin.max()) if fin.size else None, "mean_deg": float(fin.mean()) if fin.size else None}


def plot_rotational(rot: dict[str, dict[str, dict[str, Any]]], points: dict[str, dict[str, tuple]],
                    path: Path) -> Path:
    """Grid of the rotational-workspace projections: one row per configuration, columns (+a, +b) at the
    dissertation's point and at the section centre. Grey scale in deg; shaded = base orientation inadmissible."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = list(rot)
    cols = [(where, d) for where in ("dissertation", "centre") for d in ("+a", "+b")]
    # constrained layout: the figure title gets its own row above the panel titles, whatever the number of rows
    fig, axes = plt.subplots(len(labels), len(cols), figsize=(3.4 * len(cols) + 1.2, 2.9 * len(labels) + 0.6),
                             squeeze=False, layout="constrained")
    fig.get_layout_engine().set(w_pad=8 / 72, h_pad=12 / 72, hspace=0.02, wspace=0.04)
    vmax = max([float(np.nanmax(np.degrees(r.angle))) for lab in labels for w in rot[lab] for r in rot[lab][w].values()
                if np.isfinite(r.angle).any()] + [1.0])
    for i, lab in enumerate(labels):
        for j, (where, d) in enumerate(cols):
            ax = axes[i, j]
            r = rot[lab][where][d]
            a = np.degrees(r.angle)
            ax.set_facecolor("#f2d7d5")
            U, V = np.meshgrid(np.degrees(r.u_values), np.degrees(r.v_values))
            if np.isfinite(a).any():  # cells, not contours: isolated admissible orientations stay visible
                ax.pcolormesh(U, V, np.ma.masked_invalid(a), cmap="viridis", vmin=0.0, vmax=vmax, shading="nearest")
            else:
                ax.text(0.5, 0.5, "no admissible\norientation", ha="center", va="center", transform=ax.transAxes,
                        fontsize=9)
            p = np.asarray(points[lab][where]) * 1e3
            ax.set_title(f"{lab}: max. {d} at ({p[0]:.0f}, {p[1]:.0f}, {p[2]:.0f}) mm", fontsize=9)
            ax.set_xlim(U.min(), U.max())
            ax.set_ylim(V.min(), V.max())
            ax.set_xlabel(f"{r.settings['u_angle']} [deg]")
            ax.set_ylabel(f"{r.settings['v_angle']} [deg]")
    if any(np.isfinite(rot[lab][w][d].angle).any() for lab in labels for w in rot[lab] for d in ("+a", "+b")):
        fig.colorbar(plt.cm.ScalarMappable(norm=plt.Normalize(0.0, vmax), cmap="viridis"), ax=axes, shrink=0.6,
                     fraction=0.03, label="max. rotation [deg]")
    fig.suptitle("Rotational workspace: max. +a over (b, c) and max. +b over (a, c) "
                 "(shaded: base orientation inadmissible)", fontsize=10)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def plot_reason_maps(secs: dict[str, pkmstiff.SectionMap], path: Path) -> Path:
    """First failing admissibility check per raster point, one panel per configuration (categorical colours)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    colours = ["#2ca02c", "#d62728", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
               "#1f77b4", "#000000", "#aec7e8"]
    fig, axes = plt.subplots(1, len(secs), figsize=(4.6 * len(secs), 3.4), squeeze=False, constrained_layout=True)
    used: set[int] = set()
    for ax, (lab, r) in zip(axes[0], secs.items()):
        code, names = r.failing_check_codes()  # 0 = admissible, k = first failing check in bit order
        used |= set(np.unique(code).tolist())
        pl = r.plane
        ax.pcolormesh(pl.u_values * 1e3, pl.v_values * 1e3, code, cmap=ListedColormap(colours[:len(names)]),
                      vmin=-0.5, vmax=len(names) - 0.5, shading="nearest", rasterized=True)
        ax.set_aspect("equal")
        ax.set_title(f"{lab}: {int(r.ok.sum())} admissible points", fontsize=10)
        ax.set_xlabel("y [mm]")
        ax.set_ylabel("z [mm]")
    fig.legend(handles=[Patch(color=colours[k], label=names[k]) for k in sorted(used)], loc="outside lower center",
               ncol=min(6, len(used)), fontsize=9)
    fig.suptitle("YZ plane at x = 0, a = b = c = 0: first failing admissibility check", fontsize=11)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def table_51(caption: str, labels: list[str], volumes: dict[str, dict[str, float]],
             stats: dict[str, dict[str, dict[str, float]]]) -> Table:
    """Cobet Table 5.1 layout: volumes (three methods), max/mean of U, k_x, v_max,y; % of the original."""
    t = Table(caption, labels, baseline=BASELINE)
    t.add("workspace volume, tetrahedron method (eq. 4.14)", "m^3", [volumes[lab]["tetrahedron"] for lab in labels])
    t.add("workspace volume, surface nets (default)", "m^3", [volumes[lab]["surface_nets"] for lab in labels])
    t.add("workspace volume, divergence (signed)", "m^3", [volumes[lab]["divergence"] for lab in labels])
    for q in QUANTITIES:
        for key in ("max", "mean"):
            t.add(f"{QLABEL[q][0]} {key}", QLABEL[q][1], [stats[lab][q][key] for lab in labels])
    return t


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv, "c", "Hexaglide original vs variants 1 and 2 (Cobet 5.1, Table 5.1)")
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    mode = "fast" if args.fast else "default"
    cfg = SETTINGS[mode]
    sw = Stopwatch()
    machines = {lab: pkmstiff.load_machine(name) for lab, name in VARIANTS}
    labels = list(machines)

    ws = workspaces(machines, cfg["eps"])
    sw.lap("workspaces")
    secs = sections(machines, cfg["step"])
    stats = {lab: r.statistics() for lab, r in secs.items()}
    secs_kin = {lab: kinematic_section(m, cfg["step"]) for lab, m in machines.items()}
    stats_kin = {lab: r.statistics() for lab, r in secs_kin.items()}
    sw.lap("sections")
    diss = {lab: tuple(machines[lab].to_machine_frame(DISSERTATION_POINTS[lab], "report")) for lab in labels}
    points = {lab: {"dissertation": diss[lab], "centre": section_centre(secs[lab])} for lab in labels}
    status = {lab: point_status(machines[lab], diss[lab]) for lab in labels}
    rot = {lab: {where: rotational(machines[lab], p, cfg) for where, p in points[lab].items()} for lab in labels}
    rstats = {lab: {where: {d: rot_stats(r) for d, r in rot[lab][where].items()} for where in rot[lab]}
              for lab in labels}
    sw.lap("rotational workspaces")

    # ---------------------------------------------------------------------------------------------- figures
    fig_ws = [ws[lab]["all"].plot(out / f"c_workspace_{name}.png", window_size=(1000, 760))
              for lab, name in VARIANTS]
    panels = []
    for q in QUANTITIES:
        vals = {lab: secs[lab].display(q) for lab in labels}
        clim = shared_clim(*vals.values())
        for lab in labels:
            s = stats[lab][q]
            unit = "" if s["unit"] == "1" else f" {s['unit'].replace('um', 'µm')}"
            panels.append(MapPanel(secs[lab], vals[lab], f"{lab}: {QLABEL[q][0]}\nmax {s['max']:.4g}, "
                                   f"mean {s['mean']:.4g}{unit}", f"{q} [{s['unit']}]", clim=clim))
    fig_maps = plot_maps(panels, out / "c_section_maps.png",
                         "Hexaglide configurations, YZ plane at x = 0, a = b = c = 0 (k_x at tool length 150 mm)",
                         ncols=len(labels))
    fig_reasons = plot_reason_maps(secs, out / "c_admissibility.png")
    fig_rot = plot_rotational(rot, points, out / "c_rotational_workspace.png")
    sw.lap("figures")

    # ---------------------------------------------------------------------------------------------- report
    vol = {lab: ws[lab]["all"].volumes for lab in labels}
    vol_kin = {lab: ws[lab]["no_drive_load"].volume for lab in labels}
    vol_kin_all = {lab: ws[lab]["no_drive_load"].volumes for lab in labels}
    rep = Report(
        title="Study c: Hexaglide original vs variants 1 and 2 (Cobet 5.1, Table 5.1)",
        summary=(
            f"Workspace volume at a = b = c = 0 (surface nets, eps = {cfg['eps'] * 1e3:g} mm): original "
            f"{vol[BASELINE]['surface_nets']:.4f} m^3, variant 1 {vol['variant 1']['surface_nets']:.4f} m^3 "
            f"({100 * vol['variant 1']['surface_nets'] / vol[BASELINE]['surface_nets']:.0f} %), variant 2 "
            f"{vol['variant 2']['surface_nets']:.4f} m^3 "
            f"({100 * vol['variant 2']['surface_nets'] / vol[BASELINE]['surface_nets']:.0f} %). Mean k_x at a 150 mm "
            f"tool on the YZ plane: {stats[BASELINE]['kx']['mean']:.2f} / {stats['variant 1']['kx']['mean']:.2f} / "
            f"{stats['variant 2']['kx']['mean']:.2f} N/um; mean transmission quality "
            f"{stats[BASELINE]['U']['mean']:.4f} / {stats['variant 1']['U']['mean']:.4f} / "
            f"{stats['variant 2']['U']['mean']:.4f}; mean v_max in y {stats[BASELINE]['vmax_y']['mean']:.1f} / "
            f"{stats['variant 1']['vmax_y']['mean']:.1f} / {stats['variant 2']['vmax_y']['mean']:.1f} m/min "
            f"(original / variant 1 / variant 2). Without the static drive-load check (B.13) the volumes are "
            f"{vol_kin[BASELINE]:.4f} / {vol_kin['variant 1']:.4f} / {vol_kin['variant 2']:.4f} m^3: the drive "
            f"force limit removes " + " / ".join(
                f"{100 * (1 - vol[lab]['surface_nets'] / vol_kin[lab]):.0f} %" for lab in labels)
            + " of the kinematic workspace - the variants were optimised for the kinematics only."),
    )
    sec = rep.section(
        "Cobet Table 5.1: configurations compared",
        f"Workspace volume at a = b = c = 0 (octree eps = {cfg['eps'] * 1e3:g} mm); U, k_x and v_max in y on the YZ "
        f"plane at x = 0 (raster {cfg['step'] * 1e3:g} mm, maximum and mean over the admissible points), k_x at the "
        f"TCP of a {TOOL_LENGTH * 1e3:g} mm tool. Percentages: of the original.")
    sec.tables.append(table_51("Quantities of Cobet Table 5.1, all admissibility checks", labels,
                               {lab: ws[lab]["all"].volumes for lab in labels}, stats))
    sec.tables.append(table_51("Quantities of Cobet Table 5.1 without the static drive-load check (B.13): the "
                               "kinematic comparison", labels,
                               {lab: ws[lab]["no_drive_load"].volumes for lab in labels}, stats_kin))
    t2 = Table("Further figures (all checks; minima lie at the near-singular edge of the section)", labels, digits=4)
    t2.add("admissible area of the YZ section", "m^2", [stats[lab]["kx"]["admissible_area_m2"] for lab in labels])
    t2.add("admissible area of the YZ section without B.13", "m^2",
           [stats_kin[lab]["kx"]["admissible_area_m2"] for lab in labels])
    for q in QUANTITIES:
        t2.add(f"{QLABEL[q][0]} min", QLABEL[q][1], [stats[lab][q]["min"] for lab in labels])
    sec.tables.append(t2)
    sec.figures.append(Figure(fig_maps, "Transmission quality U (top), k_x at a 150 mm tool (middle) and v_max in y "
                                        "(bottom) on the YZ plane, shared colour scale per row. White: inadmissible; "
                                        "black line: boundary of the admissible region."))
    sec.figures.append(Figure(fig_reasons, "Why points of the YZ plane are inadmissible (first failing check). "
                                           "The variants lose much of the plane to the static drive load (B.13)."))

    sec_ws = rep.section(
        "Constant-orientation workspaces",
        "Closed boundary surfaces of the workspaces at a = b = c = 0 with the machine at a central pose "
        f"(eps = {cfg['eps'] * 1e3:g} mm). Bounding boxes (mm): " + "; ".join(
            f"{lab} x {b['min'][0]:.0f}…{b['max'][0]:.0f}, y {b['min'][1]:.0f}…{b['max'][1]:.0f}, "
            f"z {b['min'][2]:.0f}…{b['max'][2]:.0f}"
            for lab in labels for b in [ws[lab]["all"].statistics()["bounding_box_mm"]] if b) + ". Octree effort: " +
        "; ".join(f"{lab} {w['evaluations']:,} evaluations, {w['boundary_points']:,} boundary points, "
                  f"{w['run_time_s']:.1f} s" for lab in labels for w in [ws[lab]["all"].statistics()]) + ".")
    for lab, f in zip(labels, fig_ws):
        sec_ws.figures.append(Figure(f, f"Workspace of the {lab} at a = b = c = 0."))

    sec_rot = rep.section(
        "Rotational workspace at a point",
        "Maximum admissible +a as a function of (b, c) and maximum +b as a function of (a, c) (Cobet 5.1, docs/theory/workspace.md). "
        "Status of the dissertation's points at a = b = c = 0: " + "; ".join(
            f"{lab} {tuple(round(v * 1e3) for v in DISSERTATION_POINTS[lab])} mm (report frame; machine frame "
            f"{tuple(round(v * 1e3) for v in diss[lab])} mm): {status[lab]}" for lab in labels)
        + ". The second pair of columns uses the admissible raster point nearest to the centroid of each "
          "configuration's admissible YZ section: " + "; ".join(
            f"{lab} (0, {points[lab]['centre'][1] * 1e3:.0f}, {points[lab]['centre'][2] * 1e3:.0f}) mm"
            for lab in labels) + f". Raster of the (b, c) resp. (a, c) plane: {cfg['rot_u_step']:g} x "
          f"{cfg['rot_v_step']:g} deg, angle increment {cfg['rot_increment']:g} deg.")
    tr = Table("Rotational workspace: max. rotation over the (b, c) resp. (a, c) raster", labels)
    for where in ("dissertation", "centre"):
        for d in ("+a", "+b"):
            tr.add(f"{where} point: max. {d}", "deg", [rstats[lab][where][d]["max_deg"] for lab in labels])
            tr.add(f"{where} point: mean max. {d}", "deg", [rstats[lab][where][d]["mean_deg"] for lab in labels])
            tr.add(f"{where} point: admissible base orientations for {d}", "% of raster",
                   [100.0 * rstats[lab][where][d]["admissible_orientations"] / rstats[lab][where][d]["raster_points"]
                    for lab in labels])
    sec_rot.tables.append(tr)
    sec_rot.figures.append(Figure(fig_rot, "Rotational-workspace projections at the dissertation's points (left "
                                           "pair) and at the section centres (right pair)."))

    rep.assumptions.update(STUDY_ASSUMPTIONS)
    rep.assumptions.update(machine_assumptions(*machines.values()))
    rep.settings.update({
        "machines": {lab: name for lab, name in VARIANTS}, "baseline": BASELINE, "mode": mode,
        "workspace resolution eps [mm]": cfg["eps"] * 1e3, "workspace orientation a, b, c [deg]": [0, 0, 0],
        "workspace checks": list(pkmstiff.ALL_CHECKS), "plane": secs[BASELINE].plane.name,
        "y range [mm]": [Y_RANGE[0] * 1e3, Y_RANGE[1] * 1e3], "z range [mm]": [Z_RANGE[0] * 1e3, Z_RANGE[1] * 1e3],
        "raster step [mm]": cfg["step"] * 1e3, "raster points": int(secs[BASELINE].ok.size),
        "section orientation a, b, c [deg]": [0, 0, 0], "tool length for k_x [mm]": TOOL_LENGTH * 1e3,
        "transmission weight w [m/rad]": {lab: m.transmission_weight for lab, m in machines.items()},
        "rotational raster [deg]": {"first angle": [*ROT_U_RANGE, cfg["rot_u_step"]],
                                    "c": [*ROT_V_RANGE, cfg["rot_v_step"]], "increment": cfg["rot_increment"],
                                    "search bound": 90.0},
        "run time [s]": {**sw.laps},
    })
    results = {
        "study": "c", "fast": args.fast, "baseline": BASELINE, "resolution_mm": cfg["eps"] * 1e3,
        "step_mm": cfg["step"] * 1e3, "tool_length_mm": TOOL_LENGTH * 1e3,
        "volumes_m3": vol, "volumes_without_drive_load_m3": vol_kin_all,
        "section_stats_without_drive_load": {lab: {q: stats_kin[lab][q] for q in QUANTITIES} for lab in labels},
        "section_stats": {lab: {q: stats[lab][q] for q in QUANTITIES} for lab in labels},
        "argmax_mm": {lab: {q: argmax_pose(secs[lab], q) for q in QUANTITIES} for lab in labels},
        "workspaces": {lab: ws[lab]["all"].statistics() for lab in labels},
        "rotational_points_mm": {lab: {w: [v * 1e3 for v in p] for w, p in points[lab].items()} for lab in labels},
        "dissertation_point_status": status, "rotational": rstats,
        "plane": {"y_range_m": Y_RANGE, "z_range_m": Z_RANGE, "step_m": cfg["step"]},
    }
    rep.settings["run time [s]"]["total"] = sw.total
    paths = write_outputs(rep, out, results)
    print(f"study c: volume (surface nets, eps {cfg['eps'] * 1e3:g} mm) "
          + " / ".join(f"{vol[lab]['surface_nets']:.4f}" for lab in labels) + " m^3; k_x mean (tool 150 mm) "
          + " / ".join(f"{stats[lab]['kx']['mean']:.2f}" for lab in labels) + f" N/um; {sw.total:.1f} s; "
          f"wrote {paths['html']} and {paths['md']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
