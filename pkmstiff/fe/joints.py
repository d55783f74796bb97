"""Parametric FE models of the IWF Hexaglide joints and the tilt sweep (docs/theory/components.md).

Layout (joint frame: origin at the joint centre, first joint axis = z, tilt axis = y; the strut
direction at tilt angle theta is u = (sin theta, 0, cos theta), i.e. the axis-referenced tilt of
docs/theory/kinematics.md with theta = 0 collinear with the first axis):

* ``base_connection`` — adapter block between the drive carriage / platform (clamped bottom face) and
  the housing ("drive-/platform-side connection geometry").
* ``housing`` (with a bottom ``housing_cover``) with a bore along z holding two bearing rings of the first
  axis (in the 3-DOF joint: the "shaft of the third joint axis").
* ``shaft`` (first axis) carrying the ``yoke``: base plate and two arms at y = +-(inner_half_span ...)
  with bores along y holding the second-axis bearing rings.
* ``cross`` piece with trunnions along y (second axis = tilt axis) — and, for the 3-DOF joint, trunnions
  along x (third rotation) held by the arms of the ``strut_fork``.
* ``connection`` rod along the strut to the strut-side thread; its end face is rigidly coupled (RBE2) to
  the reference point on the strut axis where the load acts.

Every tapered roller bearing is a ring of substitute material (docs/theory/components.md) bonded (tied)
to its shaft/trunnion and bore. The strut-side group (cross, trunnions, strut fork, connection) is rotated
about y by the tilt angle; the base side stays fixed. Joint stiffness = force / deformation along the
strut at the reference point (rotations free, moments zero), docs/theory/components.md.

Assumption (documented in the parameter files): the real IWF geometry is not published; the layout
realises the axis-referenced tilt range 0-90 deg without collisions (see :func:`check_clearances`).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from pkmstiff.fe import mesh as fm
from pkmstiff.fe.assembly import NodeSet, Part, PartModel, ReferencePoint, Solution, Tie
from pkmstiff.fe.coupling import stiffness_along
from pkmstiff.fe.elasticity import ELEMENTS, element_type_label
from pkmstiff.fe.materials import CubicCylindrical, Material
from pkmstiff.fe.params import material, read_assumptions, read_materials, read_section, resolve_parameter_file
from pkmstiff.io import read_toml
from pkmstiff.errors import InputError

KINDS = ("2dof", "3dof")
DEFAULT_ANGLES_DEG = tuple(range(0, 91, 15))

_BEARING = {"inner_radius": "m", "outer_radius": "m", "width": "m", "material": "str"}
SCHEMA: dict[str, dict[str, str]] = {
    "joint": {"name": "str", "kind": "str", "description": "str"},
    "base_connection": {"width_x": "m", "width_y": "m", "height": "m", "material": "str"},
    "housing": {"width": "m", "height": "m", "cover_thickness": "m", "inset": "m", "material": "str"},
    "axis1_bearings": dict(_BEARING),
    "shaft": {"overhang": "m", "material": "str"},
    "yoke": {"inner_half_span": "m", "arm_thickness": "m", "arm_width": "m", "arm_half_height": "m",
             "extension": "m0", "base_thickness": "m", "material": "str"},
    "axis2_bearings": dict(_BEARING),
    "cross": {"half_width": "m", "clearance": "m", "material": "str"},
    "axis3_bearings": dict(_BEARING),
    "strut_fork": {"inner_half_span": "m", "arm_thickness": "m", "width_y": "m", "arm_half_height": "m",
                   "base_thickness": "m", "material": "str"},
    "connection": {"radius": "m", "length": "m", "material": "str"},
    "mesh": {"size": "m", "element": "str", "n_phi": "int"},
    "load": {"force": "N"},
}
_OPTIONAL = {"yoke": frozenset({"extension"})}
_ONLY_3DOF = ("axis3_bearings", "strut_fork")


@dataclass(frozen=True)
class JointParameters:
    """A joint parameter set in SI units (lengths m, moduli Pa, force N) plus its provenance."""

    name: str
    kind: str
    description: str
    sections: dict[str, dict[str, Any]]
    materials: dict[str, Material]
    assumptions: dict[str, str]
    raw: dict[str, Any]
    source: str

    def __getitem__(self, section: str) -> dict[str, Any]:
        return self.sections[section]

    @property
    def mesh_size(self) -> float:
        return float(self.sections["mesh"]["size"])

    @property
    def element(self) -> str:
        return str(self.sections["mesh"]["element"])

    def with_mesh(self, size: float | None = None, element: str | None = None,
                  n_phi: int | None = None) -> "JointParameters":
        """Copy with another mesh size [m], element type or circumferential division."""
        sec = {k: dict(v) for k, v in self.sections.items()}
        raw = json.loads(json.dumps(self.raw))
        if size is not None:
            sec["mesh"]["size"] = float(size)
            raw.setdefault("mesh", {})["size"] = f"{size * 1e3:g} mm"
        if element is not None:
            _check_element(element, self.source)
            sec["mesh"]["element"] = element
            raw.setdefault("mesh", {})["element"] = element
        if n_phi is not None:
            sec["mesh"]["n_phi"] = int(n_phi)
            raw.setdefault("mesh", {})["n_phi"] = int(n_phi)
        _check_geometry(sec, self.kind, self.source)
        return JointParameters(self.name, self.kind, self.description, sec, self.materials, self.assumptions,
                               raw, self.source)


def _check_element(element: str, source: str) -> None:
    if element not in ELEMENTS:
        raise InputError(source, "mesh.element", f"one of {', '.join(ELEMENTS)}", element)


def load_joint_parameters(path: str | Path) -> JointParameters:
    """Read a joint parameter TOML file (see ``pkmstiff/fe/params/*.toml``) into SI values."""
    path = resolve_parameter_file(path)
    source = str(path)
    raw = read_toml(path, "TOML parameter file")
    head = read_section(raw, "joint", SCHEMA["joint"], source)
    kind = head["kind"]
    if kind not in KINDS:
        raise InputError(source, "joint.kind", f"one of {', '.join(KINDS)}", kind)
    known = set(SCHEMA) | {"materials", "assumptions", "sweep"}
    unknown = sorted(set(raw) - known)
    if unknown:
        raise InputError(source, unknown[0], f"one of the sections {', '.join(sorted(known))}", unknown[0])
    sections: dict[str, dict[str, Any]] = {}
    for sec, spec in SCHEMA.items():
        if sec == "joint":
            continue
        if sec in _ONLY_3DOF and kind == "2dof":
            if sec in raw:
                raise InputError(source, sec, "no such section for a 2dof joint", "present")
            continue
        sections[sec] = read_section(raw, sec, spec, source, _OPTIONAL.get(sec, frozenset()))
    sections["yoke"].setdefault("extension", 0.0)
    _check_element(sections["mesh"]["element"], source)
    mats = read_materials(raw, source)
    for sec, vals in sections.items():
        if "material" in vals:
            mat = material(mats, vals["material"], source, f"{sec}.material")
            is_ring = sec.endswith("_bearings")
            if is_ring != isinstance(mat, CubicCylindrical):
                want = ("a bearing substitute material (law = 'cubic_cylindrical')" if is_ring
                        else "an isotropic material (the cylindrical law is for bearing rings only)")
                raise InputError(source, f"{sec}.material", want, vals["material"])
    _check_geometry(sections, kind, source)
    return JointParameters(head["name"], kind, head["description"], sections, mats, read_assumptions(raw, source),
                           raw, source)


def _check_geometry(s: dict[str, dict[str, Any]], kind: str, source: str) -> None:
    """Consistency of the dimensions (each violated rule names the key and the limit)."""

    def need(ok: bool, key: str, expected: str, found: float) -> None:
        if not ok:
            raise InputError(source, key, expected, f"{found * 1e3:.4g} mm")

    for sec in ("axis1_bearings", "axis2_bearings") + (("axis3_bearings",) if kind == "3dof" else ()):
        b = s[sec]
        need(b["outer_radius"] > b["inner_radius"], f"{sec}.outer_radius",
             f"> inner_radius ({b['inner_radius'] * 1e3:g} mm)", b["outer_radius"])
    h, a1, y, c, a2 = s["housing"], s["axis1_bearings"], s["yoke"], s["cross"], s["axis2_bearings"]
    need(a1["outer_radius"] < h["width"] / 2, "axis1_bearings.outer_radius",
         f"< housing.width/2 ({h['width'] * 500:g} mm)", a1["outer_radius"])
    need(2 * (h["inset"] + a1["width"]) < h["height"], "housing.height",
         "> 2 (inset + axis1_bearings.width) (two bearing rings)", h["height"])
    need(a2["outer_radius"] < min(y["arm_width"] / 2, y["arm_half_height"]), "axis2_bearings.outer_radius",
         "< min(yoke.arm_width/2, yoke.arm_half_height)", a2["outer_radius"])
    need(a2["width"] <= y["arm_thickness"], "axis2_bearings.width", "<= yoke.arm_thickness", a2["width"])
    need(c["clearance"] < y["inner_half_span"], "cross.clearance", "< yoke.inner_half_span", c["clearance"])
    need(a2["inner_radius"] < c["half_width"], "axis2_bearings.inner_radius", "< cross.half_width (trunnion root)",
         a2["inner_radius"])
    sweep_radius = math.sqrt(2.0) * c["half_width"]
    if kind == "3dof":
        f, a3 = s["strut_fork"], s["axis3_bearings"]
        need(f["inner_half_span"] > c["half_width"], "strut_fork.inner_half_span", "> cross.half_width",
             f["inner_half_span"])
        need(f["width_y"] / 2 < y["inner_half_span"], "strut_fork.width_y",
             "< 2 yoke.inner_half_span (fits between the yoke arms)", f["width_y"])
        need(a3["outer_radius"] < min(f["width_y"] / 2, f["arm_half_height"]), "axis3_bearings.outer_radius",
             "< min(strut_fork.width_y/2, strut_fork.arm_half_height)", a3["outer_radius"])
        need(a3["width"] <= f["arm_thickness"], "axis3_bearings.width", "<= strut_fork.arm_thickness", a3["width"])
        need(a3["inner_radius"] < c["half_width"], "axis3_bearings.inner_radius", "< cross.half_width",
             a3["inner_radius"])
        sweep_radius = max(sweep_radius, math.hypot(f["inner_half_span"] + f["arm_thickness"], f["arm_half_height"]))
    else:
        need(s["connection"]["radius"] < y["inner_half_span"] - c["clearance"], "connection.radius",
             "< yoke.inner_half_span - cross.clearance (passes between the yoke arms at 90 deg)",
             s["connection"]["radius"])
    need(sweep_radius < y["arm_half_height"] + y["extension"], "yoke.extension",
         f"yoke.arm_half_height + extension > {sweep_radius * 1e3:.4g} mm (strut-side parts clear the yoke base "
         "over 0-90 deg)", y["arm_half_height"] + y["extension"])


@dataclass
class JointModel:
    """Meshed joint: the multi-part FE model, the reference point and the load-direction function."""

    params: JointParameters
    model: PartModel
    reference: str = "strut"

    def strut_direction(self, tilt: float) -> np.ndarray:
        """Unit strut direction u(theta) in the joint frame (tilt in rad)."""
        return np.array([math.sin(tilt), 0.0, math.cos(tilt)])

    def placements(self, tilt: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        return {"strut": (fm.rotation((0.0, 1.0, 0.0), tilt), np.zeros(3))}

    def solve(self, tilt: float) -> tuple[float, Solution]:
        """Axial stiffness [N/m] along the strut at tilt angle ``tilt`` [rad] and the FE solution."""
        sol = self.model.condense(self.placements(tilt))
        return stiffness_along(sol.reference_matrix(self.reference), self.strut_direction(tilt)), sol

    def deformed(self, tilt: float, force: float | None = None) -> tuple[Solution, np.ndarray, float]:
        """FE solution, all DOFs (m, rad) under ``force`` [N] (default: the parameter file's load) along the
        strut at tilt ``tilt`` [rad], and the axial stiffness [N/m]."""
        k, sol = self.solve(tilt)
        F = float(self.params["load"]["force"]) if force is None else float(force)
        f = np.zeros(6)
        f[:3] = F * self.strut_direction(tilt)
        qa = np.linalg.solve(sol.reference_matrix(self.reference), f)
        return sol, sol.displacement(qa), k

    @property
    def n_dofs(self) -> int:
        return self.model.n_fe


def build_joint_model(p: JointParameters) -> JointModel:
    """Mesh the parts of a joint parameter set and assemble their stiffness matrices (joint frame)."""
    s = p.sections
    h, n_phi = p.mesh_size, int(s["mesh"]["n_phi"])
    n_phi = max(8, 4 * math.ceil(n_phi / 4))
    mats = p.materials
    parts: list[Part] = []
    ties: list[Tie] = []

    def add(name: str, mesh_: Any, sec: str, group: str = "base", axis: tuple | None = None) -> None:
        mat = mats[s[sec]["material"]]
        if isinstance(mat, CubicCylindrical):
            assert axis is not None
            mat = mat.with_axis(axis[0], axis[1])
        parts.append(Part(name, mesh_, mat, group))

    y, c, a1, a2 = s["yoke"], s["cross"], s["axis1_bearings"], s["axis2_bearings"]
    e_in, at, aw = y["inner_half_span"], y["arm_thickness"], y["arm_width"]
    Ha, ext = y["arm_half_height"], y["extension"]
    e_out = e_in + at
    z_yb = -Ha - ext  # yoke base top
    z_yb0 = z_yb - y["base_thickness"]
    z_h1 = z_yb0 - s["shaft"]["overhang"]  # housing top
    hs = s["housing"]
    z_h0 = z_h1 - hs["height"]
    z_hc = z_h0 - hs["cover_thickness"]
    bc = s["base_connection"]
    z_b0 = z_hc - bc["height"]

    # --- base side -------------------------------------------------------------------------------
    bx, by = bc["width_x"] / 2, bc["width_y"] / 2
    add("base_connection", fm.box((-bx, -by, z_b0), (bx, by, z_hc), h), "base_connection")
    hw = hs["width"] / 2
    add("housing_cover", fm.box((-hw, -hw, z_hc), (hw, hw, z_h0), h), "housing")
    add("housing", fm.block_with_bore((-hw, -hw, z_h0), (hw, hw, z_h1), "z", a1["outer_radius"], h, n_phi=n_phi),
        "housing")
    ties += [Tie("housing_cover", "base_connection", 0.0), Tie("housing", "housing_cover", 0.0)]
    z_s0 = z_h0 + hs["inset"]
    add("shaft", fm.cylinder((0, 0, z_s0), (0, 0, z_yb0), a1["inner_radius"], h, n_phi), "shaft")
    for tag, (z0, z1) in {"lower": (z_s0, z_s0 + a1["width"]),
                          "upper": (z_h1 - hs["inset"] - a1["width"], z_h1 - hs["inset"])}.items():
        name = f"bearing1_{tag}"
        add(name, fm.tube((0, 0, z0), (0, 0, z1), a1["inner_radius"], a1["outer_radius"], h, n_phi, n_rad=1),
            "axis1_bearings", axis=((0, 0, 0), (0, 0, 1)))
        ties += [Tie(name, "housing", 0.0), Tie(name, "shaft", 0.0)]
    add("yoke_base", fm.box((-aw / 2, -e_out, z_yb0), (aw / 2, e_out, z_yb), h), "yoke")
    ties.append(Tie("shaft", "yoke_base", 0.0))
    for sign, tag in ((1, "pos"), (-1, "neg")):
        ylo, yhi = sorted((sign * e_in, sign * e_out))
        arm = f"yoke_arm_{tag}"
        add(arm, fm.block_with_bore((-aw / 2, ylo, -Ha), (aw / 2, yhi, Ha), "y", a2["outer_radius"], h, n_phi=n_phi),
            "yoke")
        if ext > 0:
            add(f"yoke_ext_{tag}", fm.box((-aw / 2, ylo, z_yb), (aw / 2, yhi, -Ha), h), "yoke")
            ties += [Tie(f"yoke_ext_{tag}", "yoke_base", 0.0), Tie(arm, f"yoke_ext_{tag}", 0.0)]
        else:
            ties.append(Tie(arm, "yoke_base", 0.0))
        b0 = e_in + (at - a2["width"]) / 2
        r0, r1 = sorted((sign * b0, sign * (b0 + a2["width"])))
        ring = f"bearing2_{tag}"
        add(ring, fm.tube((0, r0, 0), (0, r1, 0), a2["inner_radius"], a2["outer_radius"], h, n_phi, n_rad=1),
            "axis2_bearings", axis=((0, 0, 0), (0, 1, 0)))
        # --- strut side: trunnions of the tilt axis ---
        t0, t1 = sorted((sign * (e_in - c["clearance"]), sign * e_out))
        trn = f"trunnion2_{tag}"
        add(trn, fm.cylinder((0, t0, 0), (0, t1, 0), a2["inner_radius"], h, n_phi), "cross", group="strut")
        ties += [Tie(ring, arm, 0.0), Tie(ring, trn, 0.0), Tie(trn, "cross", 0.0)]

    cw, cy = c["half_width"], e_in - c["clearance"]
    add("cross", fm.box((-cw, -cy, -cw), (cw, cy, cw), h), "cross", group="strut")
    con = s["connection"]
    if p.kind == "3dof":
        f, a3 = s["strut_fork"], s["axis3_bearings"]
        f_in, ft, fw, Hf = f["inner_half_span"], f["arm_thickness"], f["width_y"], f["arm_half_height"]
        z_f1 = Hf + f["base_thickness"]
        add("fork_base", fm.box((-(f_in + ft), -fw / 2, Hf), (f_in + ft, fw / 2, z_f1), h), "strut_fork", "strut")
        for sign, tag in ((1, "pos"), (-1, "neg")):
            xlo, xhi = sorted((sign * f_in, sign * (f_in + ft)))
            arm = f"fork_arm_{tag}"
            add(arm, fm.block_with_bore((xlo, -fw / 2, -Hf), (xhi, fw / 2, Hf), "x", a3["outer_radius"], h,
                                        n_phi=n_phi), "strut_fork", "strut")
            b0 = f_in + (ft - a3["width"]) / 2
            r0, r1 = sorted((sign * b0, sign * (b0 + a3["width"])))
            ring = f"bearing3_{tag}"
            add(ring, fm.tube((r0, 0, 0), (r1, 0, 0), a3["inner_radius"], a3["outer_radius"], h, n_phi, n_rad=1),
                "axis3_bearings", "strut", axis=((0, 0, 0), (1, 0, 0)))
            t0, t1 = sorted((sign * cw, sign * (f_in + ft)))
            trn = f"trunnion3_{tag}"
            add(trn, fm.cylinder((t0, 0, 0), (t1, 0, 0), a3["inner_radius"], h, n_phi), "cross", "strut")
            ties += [Tie(arm, "fork_base", 0.0), Tie(ring, arm, 0.0), Tie(ring, trn, 0.0), Tie(trn, "cross", 0.0)]
        z_c0, con_master = z_f1, "fork_base"
    else:
        z_c0, con_master = cw, "cross"
    z_c1 = z_c0 + con["length"]
    add("connection", fm.cylinder((0, 0, z_c0), (0, 0, z_c1), con["radius"], h, n_phi), "connection", "strut")
    ties.append(Tie("connection", con_master, 0.0))

    tol = tie_tolerance(p)
    ties = [Tie(t.slave, t.master, tol) for t in ties]
    eps = 1e-6
    clamps = [NodeSet("base_connection", lambda x: x[2] < z_b0 + eps)]
    refs = [ReferencePoint("strut", (0.0, 0.0, z_c1), NodeSet("connection", lambda x: x[2] > z_c1 - eps))]
    return JointModel(p, PartModel(parts, ties, clamps, refs, element=p.element))  # type: ignore[arg-type]


def tie_tolerance(p: JointParameters) -> float:
    """Tie search tolerance [m]: 1.5 x the largest chord sag of the polygonal cylinders (+0.05 mm)."""
    n_phi = max(8, 4 * math.ceil(int(p["mesh"]["n_phi"]) / 4))
    radii = [p[s]["outer_radius"] for s in p.sections if s.endswith("_bearings")]
    radii.append(p["connection"]["radius"])
    return 1.5 * max(radii) * (1.0 - math.cos(math.pi / n_phi)) + 5e-5


@dataclass
class SweepResult:
    """Stiffness along the strut over tilt angles, with provenance."""

    params: JointParameters
    tilt_deg: np.ndarray
    k: np.ndarray  # N/m
    seconds: float
    n_dofs: int
    date: str
    solutions: dict[float, Solution] = field(default_factory=dict, repr=False)

    @property
    def k_N_per_um(self) -> np.ndarray:
        return self.k / 1e6


def parse_angles(text: str) -> tuple[float, ...]:
    """Angles in degrees from ``"start:stop:step"`` (stop inclusive) or ``"a,b,c"``; checked to lie in [0, 90]."""
    try:
        if ":" in text:
            a, b, st = (float(v) for v in text.split(":"))
            if st <= 0 or b < a:
                raise ValueError
            vals = tuple(float(v) for v in np.arange(a, b + 1e-9 * max(1.0, abs(b)), st))
        else:
            vals = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise InputError("--angles", "angles", "'start:stop:step' (deg, step > 0) or a comma list 'a,b,c'",
                         text) from None
    check_angles(vals, "--angles")
    return vals


def check_angles(angles_deg: Sequence[float], source: str) -> None:
    a = np.asarray(angles_deg, float)
    if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)) or np.any(a < 0) or np.any(a > 90):
        raise InputError(source, "angles", "one or more tilt angles in [0, 90] deg (axis-referenced)", list(a))
    if np.any(np.diff(a) <= 0):
        raise InputError(source, "angles", "strictly increasing tilt angles", list(a))


def sweep(p: JointParameters, angles_deg: Sequence[float] = DEFAULT_ANGLES_DEG,
          progress: Callable[[float], None] | None = None, keep_solutions: bool = False) -> SweepResult:
    """Axial joint stiffness along the strut at each tilt angle (deg) -> :class:`SweepResult` (k in N/m)."""
    check_angles(angles_deg, p.source)
    t0 = time.perf_counter()
    jm = build_joint_model(p)
    ks, sols = [], {}
    for a in angles_deg:
        k, sol = jm.solve(math.radians(a))
        ks.append(k)
        if keep_solutions:
            sols[float(a)] = sol
        if progress is not None:
            progress(a)
    return SweepResult(p, np.asarray(angles_deg, float), np.asarray(ks), time.perf_counter() - t0, jm.n_dofs,
                       time.strftime("%Y-%m-%d"), sols)


def ring_stiffness(inner_radius: float, outer_radius: float, width: float, ring_material: CubicCylindrical,
                   h: float = 0.003, n_phi: int = 24, element: str = "hex20") -> np.ndarray:
    """6x6 stiffness [N/m, N m/rad] of one substitute bearing ring (axis z), outer surface clamped, inner surface
    rigidly coupled to its centre: radial = [0, 0], axial = [2, 2] — for comparison with the Dietl values
    k_r = 176.8 N/um, k_a = 118.8 N/um of docs/theory/components.md (rigid inner and outer rings)."""
    ring = fm.tube((0, 0, -width / 2), (0, 0, width / 2), inner_radius, outer_radius, h, n_phi)
    mat = ring_material.with_axis((0, 0, 0), (0, 0, 1))
    sag = 1.0 - math.cos(math.pi / n_phi)  # hex20 mid-side nodes lie on the chords
    model = PartModel([Part("ring", ring, mat)],
                      clamps=[NodeSet("ring", lambda x: np.hypot(x[0], x[1]) > outer_radius * (1 - sag) - 1e-9)],
                      references=[ReferencePoint("inner", (0.0, 0.0, 0.0), NodeSet(
                          "ring", lambda x: np.hypot(x[0], x[1]) < inner_radius * (1 + 1e-9)))],
                      element=element)  # type: ignore[arg-type]
    return model.condense().K


def part_masses(p: JointParameters) -> dict[str, float]:
    """Mass [kg] of each meshed part (volume x density of its material)."""
    jm = build_joint_model(p)
    return {name: fm.mesh_volume(part.mesh) * part.material.density for name, part in jm.model.parts.items()}


def element_label(p: JointParameters) -> str:
    return element_type_label(p.element)  # type: ignore[arg-type]
