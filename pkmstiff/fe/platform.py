"""Parametric FE model of a PKM platform: 6x6 stiffness at the spindle reference point (docs/theory/components.md).

Geometry (platform frame PKS, origin O', z' along the spindle): an annular ``plate`` around a
``spindle_housing`` tube. The spindle is taken as rigid and clamped in the housing bore: all bore-surface
nodes are coupled (RBE2) to the spindle reference point (default O'). Each joint interface is a circular
pad on the plate's top face coupled (RBE2) to the joint point p'_i; the joint points are supported in
translation and free in rotation ("pinned", the joints transmit no moments, Cobet 3.3) or fully
("clamped"). Guyan condensation onto the spindle reference point gives the 6x6 K_U between platform
joints and spindle: blocks N/m, N/rad, N m/rad with rotations about the PKS axes.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.fe import mesh as fm
from pkmstiff.fe.assembly import NodeSet, Part, PartModel, ReferencePoint, Solution, Tie
from pkmstiff.fe.elasticity import ELEMENTS, element_type_label
from pkmstiff.fe.materials import Isotropic, Material
from pkmstiff.fe.params import material, read_assumptions, read_materials, read_section, resolve_parameter_file
from pkmstiff.io import read_toml
from pkmstiff.units import parse_quantity
from pkmstiff.errors import InputError

SUPPORTS = ("pinned", "clamped")
SCHEMA: dict[str, dict[str, str]] = {
    "platform": {"name": "str", "description": "str"},
    "plate": {"outer_radius": "m", "thickness": "m", "z_top": "m~", "material": "str"},
    "spindle_housing": {"bore_radius": "m", "outer_radius": "m", "z_bottom": "m~", "z_top": "m~", "material": "str"},
    "joints": {"pad_radius": "m", "support": "str"},
    "mesh": {"size": "m", "element": "str", "n_phi": "int"},
}


@dataclass(frozen=True)
class PlatformParameters:
    """Platform parameter set in SI (m, Pa) with provenance."""

    name: str
    description: str
    sections: dict[str, dict[str, Any]]
    joint_points: np.ndarray  # (n, 3) m, PKS
    reference_point: np.ndarray  # (3,) m, PKS
    materials: dict[str, Material]
    assumptions: dict[str, str]
    raw: dict[str, Any]
    source: str

    def __getitem__(self, section: str) -> dict[str, Any]:
        return self.sections[section]

    @property
    def mesh_size(self) -> float:
        return float(self.sections["mesh"]["size"])

    def with_mesh(self, size: float | None = None, n_phi: int | None = None) -> "PlatformParameters":
        sec = {k: dict(v) for k, v in self.sections.items()}
        raw = json.loads(json.dumps(self.raw))
        if size is not None:
            sec["mesh"]["size"] = float(size)
            raw["mesh"]["size"] = f"{size * 1e3:g} mm"
        if n_phi is not None:
            sec["mesh"]["n_phi"] = int(n_phi)
            raw["mesh"]["n_phi"] = int(n_phi)
        return PlatformParameters(self.name, self.description, sec, self.joint_points, self.reference_point,
                                  self.materials, self.assumptions, raw, self.source)


def load_platform_parameters(path: str | Path) -> PlatformParameters:
    """Read a platform parameter TOML file (see ``pkmstiff/fe/params/hexaglide_platform.toml``)."""
    path = resolve_parameter_file(path)
    source = str(path)
    raw = read_toml(path, "TOML parameter file")
    known = set(SCHEMA) | {"materials", "assumptions", "spindle"}
    unknown = sorted(set(raw) - known)
    if unknown:
        raise InputError(source, unknown[0], f"one of the sections {', '.join(sorted(known))}", unknown[0])
    head = read_section(raw, "platform", SCHEMA["platform"], source)
    sec: dict[str, dict[str, Any]] = {}
    for name in ("plate", "spindle_housing", "mesh"):
        sec[name] = read_section(raw, name, SCHEMA[name], source)
    jt = raw.get("joints")
    if not isinstance(jt, dict):
        raise InputError(source, "joints", "a [joints] table with points, pad_radius, support", jt)
    sec["joints"] = read_section({"j": {k: v for k, v in jt.items() if k != "points"}}, "j", SCHEMA["joints"], source)
    points = parse_quantity(jt.get("points"), "m", source=source, key="joints.points", shape=(None, 3))
    if points.shape[0] < 3:
        raise InputError(source, "joints.points", "at least 3 joint points [x, y, z]", points.tolist())
    if sec["joints"]["support"] not in SUPPORTS:
        raise InputError(source, "joints.support", f"one of {', '.join(SUPPORTS)}", sec["joints"]["support"])
    sp_ = raw.get("spindle", {})
    if not isinstance(sp_, dict) or set(sp_) - {"reference_point"}:
        raise InputError(source, "spindle", "a [spindle] table with the key reference_point", sp_)
    ref = parse_quantity(sp_.get("reference_point", [0.0, 0.0, 0.0]), "m", source=source,
                         key="spindle.reference_point", shape=(3,))
    if sec["mesh"]["element"] not in ELEMENTS:
        raise InputError(source, "mesh.element", f"one of {', '.join(ELEMENTS)}", sec["mesh"]["element"])
    mats = read_materials(raw, source)
    for name in ("plate", "spindle_housing"):
        m = material(mats, sec[name]["material"], source, f"{name}.material")
        if not isinstance(m, Isotropic):
            raise InputError(source, f"{name}.material", "an isotropic material", sec[name]["material"])
    pl, sh = sec["plate"], sec["spindle_housing"]
    if not sh["bore_radius"] < sh["outer_radius"] < pl["outer_radius"]:
        raise InputError(source, "spindle_housing.outer_radius",
                         "bore_radius < outer_radius < plate.outer_radius", f"{sh['outer_radius'] * 1e3:g} mm")
    if not (sh["z_bottom"] < pl["z_top"] - pl["thickness"] and pl["z_top"] <= sh["z_top"]):
        raise InputError(source, "spindle_housing.z_top",
                         "a housing spanning the plate (z_bottom < plate bottom, z_top >= plate.z_top)",
                         f"{sh['z_bottom'] * 1e3:g}..{sh['z_top'] * 1e3:g} mm")
    r_xy = np.hypot(points[:, 0], points[:, 1])
    bad = np.flatnonzero((r_xy - sec["joints"]["pad_radius"] < sh["outer_radius"])
                         | (r_xy + sec["joints"]["pad_radius"] > pl["outer_radius"]))
    if bad.size:
        raise InputError(source, f"joints.points[{bad[0]}]",
                         "a joint pad lying on the plate (between housing and plate outer radius)",
                         points[bad[0]].tolist())
    return PlatformParameters(head["name"], head["description"], sec, points, ref, mats,
                              read_assumptions(raw, source), raw, source)


def build_platform_model(p: PlatformParameters) -> PartModel:
    """Mesh plate and spindle housing and set up the joint supports and the spindle reference point."""
    h = p.mesh_size
    pl, sh = p["plate"], p["spindle_housing"]
    z0, z1 = pl["z_top"] - pl["thickness"], pl["z_top"]
    n_plate = fm.n_phi_for(pl["outer_radius"], h, minimum=int(p["mesh"]["n_phi"]))
    n_sh = max(int(p["mesh"]["n_phi"]), 8)
    parts = [
        Part("plate", fm.tube((0, 0, z0), (0, 0, z1), sh["outer_radius"], pl["outer_radius"], h, n_plate),
             p.materials[pl["material"]]),
        Part("spindle_housing", fm.tube((0, 0, sh["z_bottom"]), (0, 0, sh["z_top"]), sh["bore_radius"],
                                        sh["outer_radius"], h, n_sh), p.materials[sh["material"]]),
    ]
    sag = sh["outer_radius"] * (1 - np.cos(np.pi / min(n_plate, n_sh)))
    ties = [Tie("plate", "spindle_housing", 1.5 * sag + 5e-5)]
    eps = 1e-6
    fixed = (0, 1, 2) if p["joints"]["support"] == "pinned" else (0, 1, 2, 3, 4, 5)
    refs = []
    for i, q in enumerate(p.joint_points):
        def pad(x: np.ndarray, q: np.ndarray = q) -> np.ndarray:
            return (np.abs(x[2] - z1) < eps) & (np.hypot(x[0] - q[0], x[1] - q[1]) <= p["joints"]["pad_radius"])
        refs.append(ReferencePoint(f"joint_{i + 1}", tuple(q), NodeSet("plate", pad), fixed=fixed, retain=False))
    rb = sh["bore_radius"]
    refs.append(ReferencePoint("spindle", tuple(p.reference_point),
                               NodeSet("spindle_housing", lambda x: np.hypot(x[0], x[1]) < rb * (1 + 1e-6))))
    return PartModel(parts, ties, clamps=(), references=refs, element=p["mesh"]["element"])


@dataclass
class PlatformResult:
    """6x6 stiffness at the spindle reference point (SI) with provenance."""

    params: PlatformParameters
    K: np.ndarray
    solution: Solution
    model: PartModel
    seconds: float
    date: str


def platform_stiffness(p: PlatformParameters) -> PlatformResult:
    """Guyan-condensed 6x6 platform stiffness K_U at the spindle reference point [N/m, N/rad, N m/rad]."""
    t0 = time.perf_counter()
    model = build_platform_model(p)
    sol = model.condense()
    return PlatformResult(p, sol.reference_matrix("spindle"), sol, model, time.perf_counter() - t0,
                          time.strftime("%Y-%m-%d"))


def to_dissertation_units(K: np.ndarray) -> np.ndarray:
    """6x6 in N/µm (translational), N/µrad (coupling), N m/µrad (rotational)."""
    return np.asarray(K, float) / 1e6


def component_toml(result: PlatformResult, component_name: str = "platform_stiffness") -> str:
    """A ``[components.NAME]`` table (model ``body_stiffness``) for a machine file, with provenance comments."""
    from pkmstiff.fe.export import versions

    p = result.params
    Kd = to_dissertation_units(result.K)
    rows = ",\n".join("  [" + ", ".join(f"{v:.6g}" for v in row) + "]" for row in Kd)
    lines = [
        f"# 6x6 platform stiffness K_U at the spindle reference point "
        f"{np.round(p.reference_point * 1e3, 3).tolist()} mm (PKS)",
        f"# source: pkmstiff FE (scikit-fem), parameters {Path(p.source).name}; platform '{p.name}': {p.description}",
        f"# supports: {len(p.joint_points)} joint pads, {p['joints']['support']}; mesh {p.mesh_size * 1e3:g} mm, "
        f"{element_type_label(p['mesh']['element'])}; {result.model.n_fe} DOFs",
        f"# date: {result.date}; version: {versions()}",
        f"[components.{component_name}]",
        'model = "body_stiffness"',
        'translational_unit = "N/um"',
        'rotational_unit = "N*m/urad"',
        'coupling_unit = "N/urad"',
        f"matrix = [\n{rows}\n]",
    ]
    return "\n".join(lines) + "\n"
