"""Validation — the bundled Hexaglide against the dissertation's published results (issue 13; docs/user-guide/validation-hexaglide.md).

Published values (Cobet 2003), positions in the report frame (origin at the middle guide, docs/user-guide/validation-hexaglide.md (reading 2)):

* Table 5.7 — static stiffness at x = y = 0, z = -1000 mm, a = b = c = 0: measured; simulated with FE-based joints;
  simulated with measured (test-rig) joints;
* Table 5.8 — the first three eigenfrequencies at the same pose (same three columns);
* Table 5.1 — original / variant 1 / variant 2 on the Y-Z plane at x = 0: workspace volume (compared as ratios only,
  docs/user-guide/validation-hexaglide.md (reading 8)), transmission quality max/mean, x-stiffness (tool 150 mm) max/mean, y-velocity max/mean;
* the dissertation's named positions (Tables 5.7/5.8 pose, the rotational-workspace points, the 5.3 measuring point):
  admissible in the report frame;
* the shape of the original's workspace at a = b = c = 0 (Cobet 5.1) with a boundary-cause map (which check limits
  each boundary point).

Nothing is fitted: the inputs are the bundled machine files and component tables. Every deviation above 5 % gets a
one-line explanation; where a published value depends on a choice the dissertation does not publish (mass
distribution, K_U, tool length, hull), the table shows the range of our result over that choice instead of picking
the value that fits. Stiffness at tool length 0 leaves K_U out, as the dissertation did (Cobet 4.2.4; docs/user-guide/validation-hexaglide.md (reading 4)); Table 5.1's x-stiffness (tool 150 mm) keeps it.

Run: ``python studies/validation_hexaglide.py [--out DIR] [--fast]`` (``--fast``: coarse rasters, CI).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _study_common import Stopwatch, machine_assumptions, parse_args, write_outputs  # noqa: E402

import pkmstiff  # noqa: E402

#: verdict threshold: |deviation| <= 5 % agrees (issue 13)
AGREE_PERCENT = 5.0
#: table columns of the comparison (the CI test checks them)
COLUMNS = ("source", "quantity", "unit", "published", "ours", "deviation", "deviation_percent", "verdict",
           "joint_data", "sensitivity", "explanation")

POSE_57 = (0.0, 0.0, -1.000, 0.0, 0.0, 0.0)  # report frame (m, rad): Cobet 5.5, Tables 5.7, 5.8
NAMED_POINTS = (  # (label, machine, position in the report frame [m])
    ("Tables 5.7/5.8 measuring pose", "hexaglide", (0.0, 0.0, -1.000)),
    ("5.3 frequency-response measuring point", "hexaglide", (0.0, 0.0, -0.950)),
    ("5.1 rotational workspace, original", "hexaglide", (0.0, 0.0, -0.900)),
    ("5.1 rotational workspace, variant 1", "hexaglide_v1", (0.0, 0.0, -1.150)),
    ("5.1 rotational workspace, variant 2", "hexaglide_v2", (0.0, -0.200, -1.000)),
)
MEASURED, FE_BASED = "measured joints", "FE-based joints"
JOINT_OPTIONS = {MEASURED: (), FE_BASED: ("fe_based_joints",)}
JOINT_TEXT = {MEASURED: "measured improved joints, 3-DOF and 2-DOF (docs/theory/components.md)",
              FE_BASED: "2-DOF: Cobet Table 3.3 FE (docs/theory/components.md); 3-DOF: toolkit FE sweep "
                        "iwf_3dof_improved_fe (the dissertation's 3-DOF FE curve is unpublished)"}

PUBLISHED_57 = {"measurement": (32.5, 2.5, 50.0), FE_BASED: (27.5, 2.6, 36.1), MEASURED: (33.8, 2.7, 50.9)}
PUBLISHED_58 = {"measurement": (27.5, 51.0, 79.0), FE_BASED: (21.9, 36.4, 58.6), MEASURED: (26.3, 49.1, 76.7)}
VARIANTS = (("original", "hexaglide"), ("variant 1", "hexaglide_v1"), ("variant 2", "hexaglide_v2"))
PUBLISHED_51 = {  # Cobet Table 5.1, original / variant 1 / variant 2
    ("U", "max"): (0.287, 0.273, 0.286), ("U", "mean"): (0.183, 0.110, 0.190),
    ("kx", "max"): (17.84, 31.49, 51.44), ("kx", "mean"): (11.52, 9.82, 24.36),
    ("vmax_y", "max"): (256.8, 166.2, 130.8), ("vmax_y", "mean"): (102.0, 80.4, 65.4),
}
PUBLISHED_VOLUME_RATIO = {"variant 1": 43.4, "variant 2": 54.2}  # % of the original (Cobet Table 5.1)
LABEL_51 = {"U": ("transmission quality U", "1"), "kx": ("x-stiffness (tool 150 mm)", "N/um"),
            "vmax_y": ("y-velocity", "m/min")}
TOOL_51 = 0.150  # m
#: readings of the strut masses (the platform-side share is unpublished): label -> StructureOptions.strut_mass_to_drive
#: (None: the machine file's, no extra strut mass, machines.md §1.7 item 10; a number: that fraction at the drive
#: joint, the rest at the platform joint)
MASS_READINGS = {"no extra strut mass": None, "struts 0/100 % drive/platform": 0.0, "struts half/half": 0.5,
                 "struts 100/0 % drive/platform": 1.0}
MAIN_MASS = "no extra strut mass"
#: the published section statistics were computed without the strut-platform check (machines.md §1.7 item 9)
SKIP_51 = ("platform_collision",)
#: platform inertia scalings shown as the sensitivity of the frequencies (M_P's rotational units are not printed)
INERTIA_SCALES = (1.0, 1.0 / 2.2, 1.0 / 4.0)
#: published TCP y-stiffness range at the Table 5.7 pose (N/um: measurement 2.5, simulation 2.7) and platform mass
PUBLISHED_KY = (2.5, 2.7)
PLATFORM_MASS = 117.24  # kg, eq. 3.11

# YZ plane at x = 0 in the report frame: covers the admissible region of all three configurations (m)
Y_RANGE = (-1.10, 1.10)
Z_RANGE = (-1.70, -0.15)
SETTINGS = {"default": {"step": 0.005, "eps": 0.003125, "cause_step": 0.005, "shape_eps": 0.0125},
            "fast": {"step": 0.05, "eps": 0.05, "cause_step": 0.025, "shape_eps": 0.05}}

#: one-line explanations of deviations above 5 % (key: source, quantity); written from the model, never fitted
EXPLANATIONS = {
    ("Table 5.7 measurement", "k_x"): "measurement vs model: the model has no frame, bed or guide-rail compliance "
                                      "and idealised joints; within our K_U / tool-length range",
    ("Table 5.7 measurement", "k_y"): "k_y ≈ 3 N/um is dominated by the drives' axial 25 N/um seen through a weak y "
                                      "transmission; the dissertation's own simulations are 8 % above the "
                                      "measurement too",
    ("Table 5.7 measurement", "k_z"): "k_z is dominated by the 3-DOF drive joints (tilt 43-46 deg here); their "
                                      "spline between the published support points (docs/theory/components.md) is "
                                      "reconstructed",
    ("Table 5.7 FE-based joints", "k_"): "drive-joint tilts are 43-46 deg at this pose; the toolkit's 3-DOF FE sweep "
                                         "gives 46.6 N/um at 45 deg, the dissertation's only published 3-DOF FE "
                                         "point 5000 N / 153.8 um = 32.5 N/um (docs/theory/components.md): ours is stiffer",
    ("Table 5.7 measured joints", "k_x"): "within our K_U / tool-length range (Table 5.7 does not state either); "
                                          "joint spline reconstructed from published points",
    ("Table 5.7 measured joints", "k_y"): "k_y ≈ 3 N/um is dominated by the drives' axial 25 N/um seen through a weak "
                                          "y transmission; cause of the remaining +23 % not identified",
    ("Table 5.7 measured joints", "k_z"): "k_z is dominated by the 3-DOF drive joints (tilt 43-46 deg); their spline "
                                          "between the published support points (docs/theory/components.md) is "
                                          "reconstructed, not measured",
    ("Table 5.8 FE-based joints", "f1"): "within our range over the unpublished strut-mass split (17.9-23.8 Hz)",
    ("Table 5.8", "f1"): "mode 1 is a rotation about an x-axis 0.73 m below O' (as Cobet describes; mode-shape "
                         "table); Rayleigh's quotient bounds f1 by sqrt(k_y / m_P) / 2 pi = 23.2-24.2 Hz for the "
                         "published k_y 2.5-2.7 N/um and m_P = 117.24 kg, so the published masses cannot give "
                         "26.3-27.5 Hz (ours reaches 24.9 Hz through our higher k_y of 3.33 N/um)",
    ("Table 5.8", "f"): "modes 2 and 3 rotate the platform about a y-axis 63 mm below O' and an x-axis 0.12 m from "
                        "O': set by M_P's rotational entries (units not printed, read as kg m^2 about O') and the "
                        "unpublished CoG; no uniform inertia scaling reaches f2 and f3 together (1/2.2: 50.8 / "
                        "64.9 Hz, 1/4: 58.5 / 68.3 Hz)",
    ("Table 5.1 variant 2", "volume ratio"): "ratio only (docs/user-guide/validation-hexaglide.md (reading 8)); the variants' hulls are 3+3-point "
                                             "guesses (§1.7 item 7) and their strut masses (drive-load limit) are "
                                             "assumed (EA/l, 12.13 kg/m)",
    ("Table 5.1 variant 1", "U max"): "our U on variant 1 is almost constant (max 0.128, 95th percentile 0.127) "
                                      "while the mean agrees (+1.6 %); cause not identified",
    ("Table 5.1", "U max"): "maximum over our admissible Y-Z area (original: at y = -80, z = -960 mm); the "
                            "published maximum needs a better-conditioned pose than any on our plane; cause not "
                            "identified",
    ("Table 5.1", "U mean"): "means depend on the admissible area; the variants' hulls (3+3 points) and drive-load "
                             "limits (assumed strut masses) are uncertain",
    ("Table 5.1 original", "kx max"): "our maximum lies at the lower workspace edge (y = 150, z = -1075 mm; 95th "
                                      "percentile 33.5 N/um) where the drive joints are nearly vertical and stiff; "
                                      "the mean agrees (-4.7 %)",
    ("Table 5.1", "kx"): "variants: strut stiffness and mass assumed (EA/l, 12.13 kg/m; docs/user-guide/machines.md) and K_U's "
                         "rotational unit unprinted (sensitivity column); cause of the variant differences not "
                         "identified",
    ("Table 5.1 variant 1", "vmax_y"): "our variant-1 admissible area (0.146 m^2 on the plane) lies in a region of "
                                       "high y-speed; the published mean is 37 % lower; cause not identified",
    ("Table 5.1", "vmax_y"): "v_max,y grows towards the y-singular edge, so max and mean depend on where the "
                             "admissible area ends (hull, drive load) and on the raster",
}


def verdict(rel: float, in_range: bool | None = None) -> str:
    """``agrees`` (|dev| <= 5 %), ``within sensitivity`` (published inside our range over unpublished choices),
    else ``deviates``."""
    if np.isfinite(rel) and abs(rel) <= AGREE_PERCENT:
        return "agrees"
    if in_range:
        return "within sensitivity"
    return "deviates"


def explanation(source: str, quantity: str, rel: float) -> str:
    """The one-line explanation of a deviation above 5 % (empty when the value agrees)."""
    if np.isfinite(rel) and abs(rel) <= AGREE_PERCENT:
        return ""
    for (src, q), text in EXPLANATIONS.items():
        if source.startswith(src) and (quantity == q or quantity.startswith(q)):
            return text
    return "UNEXPLAINED deviation"


def row(source: str, quantity: str, unit: str, published: float, ours: float, joint_data: str,
        sensitivity: Sequence[float] = (), sensitivity_text: str = "") -> dict[str, Any]:
    """One comparison row: published vs ours, absolute and in %, verdict, explanation, sensitivity range."""
    dev = ours - published
    rel = 100.0 * dev / published if published else float("nan")
    rng = [float(np.nanmin(sensitivity)), float(np.nanmax(sensitivity))] if len(sensitivity) else None
    inside = None if rng is None else bool(rng[0] <= published <= rng[1])
    return {"source": source, "quantity": quantity, "unit": unit, "published": float(published),
            "ours": float(ours), "deviation": float(dev), "deviation_percent": float(rel),
            "verdict": verdict(rel, inside), "joint_data": joint_data,
            "sensitivity": "" if rng is None else f"{rng[0]:.4g} … {rng[1]:.4g} ({sensitivity_text})",
            "sensitivity_range": rng, "explanation": explanation(source, quantity, rel)}


# --------------------------------------------------------------------------------------------- Tables 5.7, 5.8
def point_results() -> dict[str, Any]:
    """Stiffness and the first three frequencies at the Tables 5.7/5.8 pose for both joint data sets, with the
    sensitivity to K_U / tool length (stiffness) and to the strut-mass split (frequencies)."""
    out: dict[str, Any] = {}
    for joints, opts in JOINT_OPTIONS.items():
        m = pkmstiff.load_machine("hexaglide", opts)
        k = {}
        for key, mach, tl in (("K_U neglected, tool 0", m.with_(neglect_spindle=True), 0.0),
                              ("K_U kept, tool 0", m, 0.0), ("K_U kept, tool 150 mm", m, TOOL_51)):
            k[key] = (stiffness_only(mach, tl).stiffness[0, :3] / 1e6).tolist()
        f = {}
        for label, share in MASS_READINGS.items():
            r = m.with_(neglect_spindle=True).point(POSE_57, "report", tool_length=0.0, n_modes=3,
                                                     weak_point_directions=(), kinetostatics=False,
                                                     structure={"strut_mass_to_drive": share})
            f[label] = r.frequencies_hz[0].tolist()
        out[joints] = {"stiffness_N_per_um": k, "frequencies_hz_by_strut_mass": f,
                       "pose_machine_frame_m": m.to_machine_frame(POSE_57[:3], "report").tolist()}
    return out


def stiffness_only(m: pkmstiff.StudyMachine, tool_length: float) -> pkmstiff.PointResults:
    """The TCP stiffness of ``m`` at the Tables 5.7/5.8 pose (no modes, weak points or kinetostatics)."""
    return m.point(POSE_57, "report", tool_length=tool_length, n_modes=0, weak_point_directions=(),
                   kinetostatics=False)


def mode_shapes(n_modes: int = 6) -> dict[str, Any]:
    """Mode-shape description at the Tables 5.7/5.8 pose (measured joints, tool 0, K_U neglected): per mode the
    frequency, the platform's dominant motion (kinetic-energy share) and its instantaneous screw axis (direction,
    the point nearest O' in the report frame, distance from O', pitch); plus the sensitivity of f1..f3 to the
    platform inertias and the Rayleigh bound of f1 from the published k_y."""
    m = pkmstiff.load_machine("hexaglide").with_(neglect_spindle=True)
    res = m.point(POSE_57, "report", tool_length=0.0, n_modes=n_modes, weak_point_directions=(),
                  kinetostatics=False)
    o = np.asarray(POSE_57[:3])
    rows = []
    for k in range(n_modes):
        d, p = res.mode_axis_direction[0, k], res.mode_axis_point[0, k]
        d = d * np.sign(d[np.argmax(np.abs(d))])  # sign of the largest component positive
        rows.append({"mode": k + 1, "frequency_hz": float(res.frequencies_hz[0, k]),
                     "dominant_motion": res.mode_descriptions[0][k], "axis_direction": (d.round(3) + 0.0).tolist(),
                     "axis_point_report_frame_mm": ((p * 1e3).round(0) + 0.0).tolist(),
                     "axis_below_O_mm": float((o[2] - p[2]) * 1e3),
                     "axis_distance_from_O_mm": float(np.linalg.norm(np.cross(o - p, d)) * 1e3),
                     "pitch_mm_per_rad": float(res.mode_axis_pitch[0, k] * 1e3)})
    inertia = {}
    base = np.asarray(m.components["platform"]["inertia"], float)
    for s in INERTIA_SCALES:
        mi = m.with_(components={"platform": {"inertia": (base * s).tolist()}})
        inertia[f"{s:.4g}"] = mi.point(POSE_57, "report", tool_length=0.0, n_modes=3, weak_point_directions=(),
                                       kinetostatics=False).frequencies_hz[0].tolist()
    ky_ours = float(stiffness_only(m, 0.0).stiffness[0, 1])
    bound = {f"{ky:g} N/um (published)": _rayleigh_f1(ky * 1e6) for ky in PUBLISHED_KY}
    bound[f"{ky_ours / 1e6:.3g} N/um (ours)"] = _rayleigh_f1(ky_ours)
    return {"modes": rows, "frequencies_hz_by_inertia_scale": inertia, "rayleigh_bound_f1_hz_by_k_y": bound}


def _rayleigh_f1(k_y: float) -> float:
    """Upper bound of f1 [Hz] from Rayleigh's quotient with the static deflection under a y-force at O' (tool 0) as
    trial shape: its strain energy is F²/(2 k_y), its kinetic energy at least that of the platform mass at O'
    (CoG at O'), so ω1² <= k_y / m_P."""
    return math.sqrt(k_y / PLATFORM_MASS) / (2.0 * math.pi)


def point_rows(pr: dict[str, Any]) -> list[dict[str, Any]]:
    rows = []
    main_k, main_f = "K_U neglected, tool 0", MAIN_MASS
    for col in ("measurement", FE_BASED, MEASURED):
        joints = MEASURED if col == "measurement" else col
        res = pr[joints]
        src = f"Table 5.7 {col}"
        for i, ax in enumerate("xyz"):
            sens = [v[i] for v in res["stiffness_N_per_um"].values()]
            rows.append(row(src, f"k_{ax}", "N/um", PUBLISHED_57[col][i], res["stiffness_N_per_um"][main_k][i],
                            JOINT_TEXT[joints], sens, "K_U neglected/kept, tool 0/150 mm"))
        src = f"Table 5.8 {col}"
        for i in range(3):
            sens = [v[i] for v in res["frequencies_hz_by_strut_mass"].values()]
            rows.append(row(src, f"f{i + 1}", "Hz", PUBLISHED_58[col][i],
                            res["frequencies_hz_by_strut_mass"][main_f][i], JOINT_TEXT[joints], sens,
                            "no extra strut mass, or struts split 0…100 % drive/platform"))
    return rows


# ---------------------------------------------------------------------------------------------------- Table 5.1
def variant_results(step: float, eps: float) -> dict[str, Any]:
    """Section statistics (U, k_x with 150 mm tool, v_max,y) on the report-frame YZ plane without the strut-platform
    check, as the dissertation computed them (machines.md §1.7 item 9), with the check as sensitivity and the share
    of the area it removes; and the workspace volumes (all checks) of the three configurations."""
    out: dict[str, Any] = {}
    names = ("U", "kx", "vmax_y")
    for label, name in VARIANTS:
        m = pkmstiff.load_machine(name)
        res = yz_section(m, step, names, skip_checks=SKIP_51)
        hull = yz_section(m, step, names)
        # K_U's rotational entries have no printed unit (docs/user-guide/machines.md note 3): N*m/urad (bundled) vs N*mm/urad
        mku = m.with_(components={"platform_stiffness": {"rotational_unit": "N*mm/urad"}})
        ku = yz_section(mku, step, ("kx",), skip_checks=SKIP_51)
        ws = m.workspace(eps, frame="report", methods=("surface_nets",))
        out[label] = {"checks_left_out": list(SKIP_51), "stats": res.statistics(),
                      "stats_with_platform_check": hull.statistics(), "stats_ku_nmm": ku.statistics(),
                      "area_m2": float(res.ok.sum()) * res.plane.cell_area,
                      "area_with_platform_check_m2": float(hull.ok.sum()) * res.plane.cell_area,
                      "platform_check_removes_percent": 100.0 * (1.0 - hull.ok.sum() / max(res.ok.sum(), 1)),
                      "volume_m3": ws.volume, "workspace": ws.statistics()}
    return out


def yz_section(m: pkmstiff.StudyMachine, step: float, names: Sequence[str],
               skip_checks: Sequence[str] = ()) -> pkmstiff.SectionMap:
    """Table 5.1's Y-Z plane at x = 0 (report frame), tool 150 mm."""
    return m.section("yz", 0.0, step, names, u_range=Y_RANGE, v_range=Z_RANGE, tool_length=TOOL_51,
                     frame="report", skip_checks=skip_checks)


def variant_rows(vr: dict[str, Any]) -> list[dict[str, Any]]:
    rows = []
    base = vr["original"]["volume_m3"]
    for label in ("variant 1", "variant 2"):
        ours = 100.0 * vr[label]["volume_m3"] / base
        rows.append(row(f"Table 5.1 {label}", "volume ratio", "% of original", PUBLISHED_VOLUME_RATIO[label], ours,
                        "kinematics only"))
    for (q, stat), pub in PUBLISHED_51.items():
        name, unit = LABEL_51[q]
        for k, (label, _) in enumerate(VARIANTS):
            ours = vr[label]["stats"][q][stat]
            sens = [ours, vr[label]["stats_with_platform_check"][q][stat]]
            text = "without/with the strut-platform check"
            if q == "kx":
                sens.append(vr[label]["stats_ku_nmm"][q][stat])
                text += "; K_U rotational unit N*m/urad or N*mm/urad"
            rows.append(row(f"Table 5.1 {label}", f"{q} {stat}", unit, pub[k], ours,
                            JOINT_TEXT[MEASURED] if q == "kx" else "kinematics only", sens, text))
    return rows


# ------------------------------------------------------------------------------------------------ named points
def named_points() -> list[dict[str, Any]]:
    """Admissibility of the dissertation's named positions in the report frame (a = b = c = 0)."""
    out = []
    for label, name, pos in NAMED_POINTS:
        m = pkmstiff.load_machine(name)
        ok, failing = m.admissibility([*pos, 0.0, 0.0, 0.0], "report")
        out.append({"point": label, "machine": name, "report_frame_mm": [1e3 * v for v in pos],
                    "machine_frame_mm": (m.to_machine_frame(pos, "report") * 1e3).tolist(), "admissible": bool(ok[0]),
                    "failing": failing[0]})
    return out


# ----------------------------------------------------------------------------------- workspace shape, causes
#: reason bits shown in the boundary-cause map, in priority order for ties; colours
CAUSES = (("UNREACHABLE", "strut length (unreachable)", "#1f77b4"),
          ("DRIVE_RANGE", "drive travel", "#17becf"),
          ("DRIVE_SPACING", "drive spacing", "#9467bd"),
          ("JOINT_ANGLE", "joint angle", "#2ca02c"),
          ("STRUT_COLLISION", "strut-strut collision", "#8c564b"),
          ("PLATFORM_COLLISION", "strut-platform collision", "#d62728"),
          ("DRIVE_LOAD", "static drive load (gravity)", "#ff7f0e"),
          ("SINGULAR", "singularity", "#7f7f7f"),
          ("FRAME", "frame limit", "#bcbd22"))


def boundary_causes(res: pkmstiff.SectionMap) -> tuple[np.ndarray, np.ndarray]:
    """(boundary mask, cause index into :data:`CAUSES` or -1) on a section: a boundary point is an admissible raster
    point with an inadmissible 4-neighbour; its cause is the check failing at most of those neighbours."""
    ok = res.ok
    fails = np.stack([res.fails(name) for name, _, _ in CAUSES])  # (causes, nv, nu)
    nv, nu = ok.shape
    counts = np.zeros((len(CAUSES), nv, nu), int)
    boundary = np.zeros_like(ok)
    for dv, du in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        nb_ok = np.ones_like(ok)
        nb_fails = np.zeros_like(fails)
        sv = slice(max(dv, 0), nv + min(dv, 0))
        su = slice(max(du, 0), nu + min(du, 0))
        tv = slice(max(-dv, 0), nv + min(-dv, 0))
        tu = slice(max(-du, 0), nu + min(-du, 0))
        nb_ok[tv, tu] = ok[sv, su]
        nb_fails[:, tv, tu] = fails[:, sv, su]
        edge = ok & ~nb_ok
        boundary |= edge
        counts += edge & nb_fails
    cause = np.where(boundary & (counts.max(axis=0) > 0), counts.argmax(axis=0), -1)
    return boundary, cause


def cause_summary(res: pkmstiff.SectionMap, boundary: np.ndarray, cause: np.ndarray, axis: int) -> dict[str, Any]:
    """Boundary points per cause, split into the upper boundary (highest admissible z per column) and the rest."""
    vals = res.plane.u_values * 1e3
    nv, nu = res.ok.shape
    upper = np.zeros_like(boundary)
    lower = np.zeros_like(boundary)
    for j in range(nu):
        col = np.nonzero(res.ok[:, j])[0]
        if col.size:
            upper[col[-1], j] = True
            lower[col[0], j] = True
    out: dict[str, Any] = {}
    for part, mask in (("upper boundary", upper & boundary), ("lower boundary", lower & boundary),
                       ("all boundary points", boundary)):
        out[part] = {CAUSES[k][1]: int(np.count_nonzero(mask & (cause == k))) for k in range(len(CAUSES))
                     if np.any(mask & (cause == k))}
    # per-u cause of the upper boundary (report-frame coordinate of the plane's first axis, mm)
    ub = []
    for j in range(nu):
        i = np.nonzero(upper[:, j] & boundary[:, j])[0]
        if i.size and cause[i[0], j] >= 0:
            ub.append((float(vals[j]), CAUSES[cause[i[0], j]][1], float(res.plane.v_values[i[0]] * 1e3)))
    out["upper boundary by position (u_mm, cause, z_mm)"] = ub
    return out


def band_causes(ub: list[tuple[float, str, float]], lo: float, hi: float) -> dict[str, int]:
    """Causes of the upper boundary for lo <= u <= hi (mm)."""
    out: dict[str, int] = {}
    for u, c, _ in ub:
        if lo <= u <= hi:
            out[c] = out.get(c, 0) + 1
    return out


def plot_cause_map(res: pkmstiff.SectionMap, boundary: np.ndarray, cause: np.ndarray, path: Path, title: str) -> Path:
    """Admissible area (grey), boundary points coloured by their limiting check (report frame, mm)."""
    from matplotlib.figure import Figure as MplFigure
    from matplotlib.lines import Line2D

    pl = res.plane
    u, v = pl.u_values * 1e3, pl.v_values * 1e3
    aspect = (v[-1] - v[0]) / (u[-1] - u[0])
    fig = MplFigure(figsize=(8.6, 1.2 + 5.4 * min(aspect, 1.2)), constrained_layout=True)
    ax = fig.add_subplot()
    ax.pcolormesh(u, v, np.where(res.ok, 1.0, np.nan), cmap="Greys", vmin=0, vmax=2.5, shading="nearest",
                  rasterized=True)
    uu, vv = np.meshgrid(u, v)
    handles = []
    for k, (_, text, colour) in enumerate(CAUSES):
        sel = boundary & (cause == k)
        if sel.any():
            ax.scatter(uu[sel], vv[sel], s=6 if pl.u_values.size > 100 else 18, color=colour, marker="s",
                       linewidths=0)
            handles.append(Line2D([], [], color=colour, marker="s", linestyle="", label=f"{text} ({sel.sum()})"))
    ax.set_aspect("equal")
    ax.set_xlabel(f"{pl.u_name} [mm] (report frame)")
    ax.set_ylabel(f"{pl.v_name} [mm] (report frame)")
    ax.set_title(title, fontsize=11)
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=10, title="limiting check",
              title_fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")  # the legend sits outside the axes
    return path


def workspace_shape(step: float, shape_eps: float, out: Path, figures: bool
                    ) -> tuple[dict[str, Any], list[pkmstiff.Figure]]:
    """Original Hexaglide at a = b = c = 0: YZ section at x = 0 and XZ section at y = 85 mm (report frame) with
    boundary causes, and the 3-D workspace (Cobet 5.1 shape)."""
    m = pkmstiff.load_machine("hexaglide")
    planes = {"yz": ("yz", 0.0, (-0.70, 0.90), (-1.40, -0.10)), "xz": ("xz", 0.085, (-1.10, 1.10), (-1.40, -0.10))}
    info: dict[str, Any] = {}
    figs: list[pkmstiff.Figure] = []
    for key, (kind, at, ur, vr) in planes.items():
        res = m.section(kind, at, step, (), u_range=ur, v_range=vr, frame="report")
        b, c = boundary_causes(res)
        s = cause_summary(res, b, c, 0)
        s["admissible_area_m2"] = float(res.ok.sum()) * res.plane.cell_area
        s["inadmissible_points_by_reason"] = {k: v for k, v in res.reason_counts().items() if v}
        if key == "yz":
            ub = s["upper boundary by position (u_mm, cause, z_mm)"]
            s["upper boundary causes, -10 <= y <= 180 mm"] = band_causes(ub, -10.0, 180.0)
            s["upper boundary causes, y < -10 mm"] = band_causes(ub, -1e9, -10.0 - 1e-9)
            s["upper boundary causes, y > 180 mm"] = band_causes(ub, 180.0 + 1e-9, 1e9)
            # without the drive-load check: what limits the middle band then
            nodl = m.section(kind, at, step, (), u_range=ur, v_range=vr, frame="report", skip_checks=("drive_load",))
            b2, c2 = boundary_causes(nodl)
            s2 = cause_summary(nodl, b2, c2, 0)
            s["without drive-load check: upper boundary causes, -10 <= y <= 180 mm"] = band_causes(
                s2["upper boundary by position (u_mm, cause, z_mm)"], -10.0, 180.0)
            hull = m.section(kind, at, step, (), u_range=ur, v_range=vr, frame="report", skip_checks=SKIP_51)
            s["share of the area excluded by the strut-platform check (percent of the admissible area without it)"] = (
                100.0 * (1.0 - res.ok.sum() / max(hull.ok.sum(), 1)))
        info[key] = s
        if figures:
            where = f"x = {at * 1e3:g} mm" if kind == "yz" else f"y = {at * 1e3:g} mm"
            p = plot_cause_map(res, b, c, out / f"hexaglide_boundary_causes_{kind}.png",
                               f"Hexaglide (original), a = b = c = 0: {kind.upper()} section at {where}\n"
                               f"boundary points coloured by the limiting check")
            figs.append(pkmstiff.Figure(p, f"Boundary-cause map, {kind.upper()} section at {where} (report frame): "
                                           "grey = admissible; each boundary point coloured by the check failing at "
                                           "most of its inadmissible neighbours."))
    ws = m.workspace(shape_eps, frame="report", methods=("surface_nets",))
    lo, hi = ws.statistics()["bounding_box_mm"]["min"], ws.statistics()["bounding_box_mm"]["max"]
    info["workspace"] = {"volume_m3": ws.volume, "bounding_box_mm_report_frame": {"min": lo, "max": hi},
                         "resolution_mm": shape_eps * 1e3}
    if figures:
        try:
            p = ws.plot(out / "hexaglide_workspace.png")
            figs.append(pkmstiff.Figure(p, f"Constant-orientation workspace of the original Hexaglide at a = b = c = 0 "
                                           f"(resolution {shape_eps * 1e3:g} mm), machine at a central pose."))
        except Exception as exc:  # pragma: no cover - rendering back-end missing
            info["workspace"]["figure_error"] = str(exc)
    return info, figs


# ---------------------------------------------------------------------------------------------------- report
def mode_text(modes: dict[str, Any]) -> str:
    """The mode-shape section's text: what each of the first three modes is and what bounds f1."""
    r = modes["modes"]
    inert = modes["frequencies_hz_by_inertia_scale"]
    bound = modes["rayleigh_bound_f1_hz_by_k_y"]
    intro = ("Measured joints, tool length 0, K_U neglected, no extra strut mass. Each mode's platform motion is a "
             "rotation about its instantaneous axis (Chasles; the axis point is the one nearest O', report frame) "
             "plus a translation along it (pitch); the dominant motion is the largest share of the platform's "
             "kinetic energy.")
    shapes = (f"Mode 1 ({r[0]['frequency_hz']:.2f} Hz) is a rotation about an axis along {r[0]['axis_direction']} "
              f"{r[0]['axis_below_O_mm'] / 1e3:.2f} m below O' (as Cobet describes): the platform swings sideways, "
              f"so its kinetic energy is mostly y-translation ({r[0]['dominant_motion']}). Modes 2 and 3 "
              f"({r[1]['frequency_hz']:.2f}, {r[2]['frequency_hz']:.2f} Hz) rotate about axes along "
              f"{r[1]['axis_direction']} and {r[2]['axis_direction']} passing "
              f"{r[1]['axis_distance_from_O_mm']:.0f} and {r[2]['axis_distance_from_O_mm']:.0f} mm from O'.")
    rayleigh = ("f1 is bounded by Rayleigh's quotient (trial shape: the static deflection under a y-force at O'): "
                "f1 <= sqrt(k_y / m_P) / 2 pi with m_P = 117.24 kg gives "
                + ", ".join(f"{v:.1f} Hz for k_y = {k}" for k, v in bound.items())
                + ": the published f1 (26.3-27.5 Hz) is out of reach of the published k_y and platform mass, "
                "whatever the inertias and the mass distribution.")
    inertia = ("Sensitivity of f1, f2, f3 to the platform inertias (M_P's rotational entries, units not printed): "
               + "; ".join(f"x {float(s):.3g}: " + " / ".join(f"{v:.1f}" for v in f) + " Hz" for s, f in inert.items())
               + ". Smaller inertias raise f2 and f3 but no uniform scaling reaches the published f2 and f3 "
               "together; nothing is tuned (machines.md §1.7 item 11).")
    return f"{intro}\n\n{shapes}\n\n{rayleigh}\n\n{inertia}"


def markdown_table(rows: list[dict[str, Any]]) -> str:
    """The comparison table as Markdown (one row per published value)."""
    head = ("| source | quantity | unit | published | ours | deviation | % | verdict | joint data | sensitivity "
            "| explanation |\n|---|---|---|---|---|---|---|---|---|---|---|\n")
    lines = [f"| {r['source']} | {r['quantity']} | {r['unit']} | {r['published']:.4g} | {r['ours']:.4g} | "
             f"{r['deviation']:+.3g} | {r['deviation_percent']:+.1f} | {r['verdict']} | {r['joint_data']} | "
             f"{r['sensitivity']} | {r['explanation']} |" for r in rows]
    return head + "\n".join(lines) + "\n"


def build(fast: bool, out: Path, figures: bool = True) -> tuple[pkmstiff.Report, dict[str, Any]]:
    cfg = SETTINGS["fast" if fast else "default"]
    sw = Stopwatch()
    pr = point_results()
    modes = mode_shapes()
    sw.lap("tables 5.7, 5.8")
    vr = variant_results(cfg["step"], cfg["eps"])
    sw.lap("table 5.1")
    pts = named_points()
    shape, figs = workspace_shape(cfg["cause_step"], cfg["shape_eps"], out, figures)
    sw.lap("workspace shape")
    rows = point_rows(pr) + variant_rows(vr)

    m0 = pkmstiff.load_machine("hexaglide")
    rep = pkmstiff.Report("Validation: the bundled Hexaglide against Cobet 2003 (Tables 5.1, 5.7, 5.8)")
    rep.summary = ("Published values side by side with the toolkit's, absolute and in %, with a verdict (agrees: "
                   f"|deviation| <= {AGREE_PERCENT:g} %; within sensitivity: the published value lies inside our "
                   "range over an unpublished modelling choice) and a one-line explanation for every deviation "
                   "above 5 %. Nothing is fitted. Positions in the " + m0.frame_description("report") + ".")
    sec = rep.section("Comparison table", "Tables 5.7 (static stiffness) and 5.8 (eigenfrequencies) at x = y = 0, "
                      "z = -1000 mm, a = b = c = 0 (report frame), tool length 0 with K_U neglected (Cobet 4.2.4); "
                      "frequencies without extra strut mass (the drive mass 102.17 kg holds the drive-side strut "
                      "share, machines.md §1.7 item 10). Table 5.1 on the Y-Z plane at x = 0 (report frame), tool "
                      "150 mm for k_x (K_U kept), admissibility checks left out: " + ", ".join(SKIP_51) + " (the published section statistics "
                      "need points that the check excludes, machines.md §1.7 item 9; it removes "
                      + " / ".join(f"{vr[lab]['platform_check_removes_percent']:.1f} %" for lab, _ in VARIANTS)
                      + " of the admissible area of the original / variant 1 / variant 2: the sensitivity column "
                      "shows the statistics with it); volumes with every check, as ratios only "
                      "(docs/user-guide/validation-hexaglide.md item 8).\n\n" + "\n\n".join(
                          f"{r['source']} {r['quantity']}: published {r['published']:.4g}, ours {r['ours']:.4g} "
                          f"{r['unit']} ({r['deviation_percent']:+.1f} %, {r['verdict']})"
                          + (f" — {r['explanation']}" if r['explanation'] else "")
                          + (f"; sensitivity {r['sensitivity']}" if r['sensitivity'] else "") for r in rows))
    for src in sorted({r["source"] for r in rows}):
        t = pkmstiff.Table(src, ["published", "ours"], baseline="published", digits=4)
        for r in rows:
            if r["source"] == src:
                t.add(f"{r['quantity']} ({r['verdict']})", r["unit"], [r["published"], r["ours"]])
        sec.tables.append(t)
    ms = rep.section("Mode shapes at the Tables 5.7/5.8 pose", mode_text(modes))
    t = pkmstiff.Table("Mode shapes: platform motion and its instantaneous axis (report frame)",
              ["f [Hz]", "axis y [mm]", "axis z [mm]", "axis below O' [mm]", "pitch [mm/rad]"], digits=4)
    for r in modes["modes"]:
        p = r["axis_point_report_frame_mm"]
        t.add(f"mode {r['mode']}: {r['dominant_motion']}, axis along {r['axis_direction']}", "",
              [r["frequency_hz"], p[1], p[2], r["axis_below_O_mm"], r["pitch_mm_per_rad"]])
    ms.tables.append(t)
    rep.section("Named positions (report frame)", "\n\n".join(
        f"{p['point']} ({p['machine']}): x, y, z = {', '.join(f'{v:g}' for v in p['report_frame_mm'])} mm "
        f"(machine frame {', '.join(f'{v:g}' for v in p['machine_frame_mm'])} mm): "
        + ("admissible" if p["admissible"] else "NOT admissible: " + "; ".join(p["failing"])) for p in pts))
    yz = shape["yz"]
    s = rep.section("Workspace shape of the original (Cobet 5.1)", "\n\n".join([
        "Published: a half-cylinder along x; lower boundary from the strut lengths, upper flanks from joint angles "
        "and strut-platform collisions, the middle band of the upper boundary (y ≈ -10…180 mm) from gravity (static "
        "drive load), ±x ends from the drive travel.",
        f"Ours, YZ section: upper boundary causes {yz['upper boundary causes, y < -10 mm']} (y < -10 mm), "
        f"{yz['upper boundary causes, -10 <= y <= 180 mm']} (-10…180 mm), "
        f"{yz['upper boundary causes, y > 180 mm']} (y > 180 mm); lower boundary {yz['lower boundary']}. "
        f"Without the drive-load check the middle band is limited by "
        f"{yz['without drive-load check: upper boundary causes, -10 <= y <= 180 mm']}.",
        f"XZ section at y = 85 mm: boundary causes {shape['xz']['all boundary points']}.",
        "Strut-platform check (uncertain hull, §1.7 item 7): excludes "
        f"{yz['share of the area excluded by the strut-platform check (percent of the admissible area without it)']:.1f}"
        " % of the YZ section's area admissible without it.",
        f"Workspace volume {shape['workspace']['volume_m3']:.4f} m^3 at {shape['workspace']['resolution_mm']:g} mm, "
        f"bounding box (report frame) {shape['workspace']['bounding_box_mm_report_frame']} mm."]))
    s.figures.extend(figs)
    rep.assumptions = {
        "validation: verdict": f"agrees if |deviation| <= {AGREE_PERCENT:g} %",
        "validation: K_U": "stiffness at tool length 0 without K_U (Cobet 4.2.4, Fig. 4.25; docs/user-guide/validation-hexaglide.md (reading 4)); "
                           "Table 5.7 does not state the tool length: K_U kept and tool 150 mm shown as sensitivity",
        "validation: mass distribution": "no extra strut mass (machines.md §1.7 item 10: the drive mass holds the "
                                         "drive-side strut share); struts split 0/50/100 % drive/platform as "
                                         "sensitivity (unpublished)",
        "validation: section checks": "Table 5.1 statistics without the strut-platform check (machines.md §1.7 "
                                      "item 9); with it as sensitivity",
        "validation: section": f"Y-Z plane at x = 0, y {Y_RANGE[0] * 1e3:g}…{Y_RANGE[1] * 1e3:g} mm, "
                               f"z {Z_RANGE[0] * 1e3:g}…{Z_RANGE[1] * 1e3:g} mm (report frame), raster "
                               f"{cfg['step'] * 1e3:g} mm (unpublished); statistics over admissible points",
        **machine_assumptions(*(pkmstiff.load_machine(n) for _, n in VARIANTS),
                              pkmstiff.load_machine("hexaglide:fe_based_joints")),
    }
    rep.settings = {"mode": "fast" if fast else "default", **{k: v for k, v in cfg.items()}, "run_time_s": sw.laps}
    results = {"columns": list(COLUMNS), "rows": rows, "named_points": pts, "point_results": pr,
               "mode_shapes": modes,
               "variant_results": {k: {kk: vv for kk, vv in v.items() if kk != "workspace"} for k, v in vr.items()},
               "workspace_shape": shape, "fast": fast}
    return rep, results


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    args = parse_args(argv, "validation_hexaglide", __doc__.splitlines()[0])
    rep, results = build(args.fast, args.out)
    paths = write_outputs(rep, args.out, results)
    (args.out / "comparison.md").write_text(markdown_table(results["rows"]), encoding="utf-8")
    print(markdown_table(results["rows"]))
    for p in results["named_points"]:
        print(f"{p['point']}: {'admissible' if p['admissible'] else 'NOT admissible ' + '; '.join(p['failing'])}")
    print("wrote", ", ".join(str(p) for p in paths.values()))
    return results


if __name__ == "__main__":
    main()
