"""Elastic data of a mechanism file: components on joints, drives and links (issue 27, items 1–2).

The ``[components.NAME]`` tables are those of machine files (same models, units and catalogue,
docs/theory/components.md); the ``[elastic]`` table places them on the mechanism::

    [elastic]
    vertical = [0, 0, 1]                 # upward direction: guide carriage frames (z' = vertical, Cobet eq. 3.6)
    damping_beta = "0 s"                 # stiffness-proportional damping C = β K of every element
    transmission_weight = "1.43 m/rad"  # w of the transmission quality (eq. 4.77; default: the length scale)
    drive_load_strut_mass = 1.0          # static drive loads only (eq. 4.90): this fraction of every strut's mass
                                         # added at the output link's CoG (the machines' limits key; default 0)

    [elastic.links.platform]             # a rigid link: one rigid body (6 DOF)
    body = "platform"                    # rigid_body component; its CoG and inertia in link axes about `origin`
    origin = [0.0, 0.3, -0.9]            # home world coordinates of the component's reference point (default 0)
    flexibility = "platform_stiffness"   # optional 6×6 link flexibility (body_stiffness, link axes) at `origin`:
    tool_body = "spindle"                # the link is two bodies joined by it, the tool side carries the output

    [elastic.links.strut1]
    model = "strut"                      # a two-force member between its two joints: one axial element
    component = "strut_1000"             # strut stiffness (absent: rigid); its mass is lumped at the joints
    mass_shares = [0.5, 0.5]             # fractions of the strut mass at its [first, second] joint (file order)

    [elastic.joints.carriage1]
    drive = "linear_motor_1"             # along (linear drive) or about (rotary drive) the drive axis
    guide = "schneeberger_35x4"          # guide carriages: transverse stiffness of a carriage node
    joint = "iwf_3dof_improved"          # joint stiffness along the strut, at the joint's tilt/swivel angles
    axis = [0, 0, -1]                    # joint axis and swivel reference (home, on the joint's non-strut link)
    reference = [-1, 0, 0]
    convention = "axis"                  # tilt convention of the joint (docs/theory/kinematics.md): axis | normal
    stiffness = "bearing"                # 6×6 joint stiffness between two rigid links, in the axes of the
                                         # joint's first link (world axes at home); 0 in the joint's free directions
    mass = "2.3 kg"                      # joint mass (at the node, else on the joint's non-strut link)

Element placement (the structure model of docs/theory/structure.md, generalised): a strut's end is a point-mass
*node* where a driven linear joint carries the drive axis on the other link (a carriage) or where two struts meet;
the node is joined to that link by ``K_W = F diag(k_drive, K_guide) Fᵀ`` (F: x' = drive axis, z' = vertical).
Otherwise the strut attaches to the body of the other link at the joint.  The strut element is ``k_V d̂ d̂ᵀ`` with
``1/k_V = 1/k_strut + Σ 1/k_joint + Σ 1/k_telescopic drive`` (eq. 4.48).  Joints between rigid links are one 6×6
element (the joint stiffness in joint axes plus the drive along/about its axis); directions the joint constrains
and no stiffness is given for are exact rigid bindings, as are drives without a drive component.  Components not
given are rigid; links without ``[elastic.links.*]`` are massless rigid bodies.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.errors import InputError
from pkmstiff.io import check_keys
from pkmstiff.mechanisms.model import Mechanism
from pkmstiff.structure.layout import PKSBody, component_body
from pkmstiff.units import parse_quantity

_ELASTIC = {"vertical", "damping_beta", "transmission_weight", "drive_load_strut_mass", "links", "joints", "notes"}
_LINK = {"model", "body", "origin", "flexibility", "tool_body", "component", "mass_shares", "notes"}
_JOINT = {"drive", "guide", "joint", "axis", "reference", "convention", "stiffness", "mass", "notes"}
#: component kinds each role accepts (``kind`` of :mod:`components.protocol`)
_ROLE_KINDS = {"drive": ("axial", "torsional"), "guide": ("matrix3",), "joint": ("axial",), "stiffness": ("matrix6",),
               "component": ("axial",), "flexibility": ("matrix6",)}


@dataclass(frozen=True)
class JointElastic:
    """Components of one joint (None = rigid) and its mass [kg]; axis/reference (3,) home world, on the link
    ``links[0]`` of the joint unless the strut logic says otherwise."""

    drive: Any = None
    guide: Any = None
    joint: Any = None
    stiffness: Any = None
    axis: np.ndarray | None = None
    reference: np.ndarray | None = None
    normal: bool = False
    mass: float = 0.0


@dataclass(frozen=True)
class LinkElastic:
    """A link's elastic description: ``strut`` (two-force member) or a rigid body; ``body`` in link (= home world)
    coordinates; ``flexibility`` a 6×6 component splitting the link at ``origin`` into body and ``tool``."""

    strut: bool = False
    body: PKSBody = field(default_factory=PKSBody.empty)
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    flexibility: Any = None
    tool: PKSBody = field(default_factory=PKSBody.empty)
    component: Any = None  #: strut stiffness component
    mass_shares: tuple[float, float] = (0.5, 0.5)


@dataclass(frozen=True)
class ElasticData:
    """The ``[components]`` and ``[elastic]`` tables of a mechanism file, resolved (SI)."""

    components: dict[str, Any]
    links: dict[int, LinkElastic]
    joints: dict[int, JointElastic]
    vertical: np.ndarray
    damping_beta: float = 0.0
    transmission_weight: float | None = None  #: m/rad (None: the mechanism's length scale)
    #: fraction of every strut's mass added to the output link's moved mass for the static drive loads only (eq. 4.90;
    #: the machines' ``limits.drive_load_strut_mass``)
    drive_load_strut_mass: float = 0.0

    def link(self, i: int) -> LinkElastic:
        return self.links.get(i, LinkElastic())

    def joint(self, i: int) -> JointElastic:
        return self.joints.get(i, JointElastic())


def _vec3(v: Any, unit: str, mech: Mechanism, src: str, key: str, unitvec: bool = False) -> np.ndarray:
    arr = np.asarray(parse_quantity(v, unit, source=src, key=key, shape=(mech.dim,)), float)
    if unitvec:
        n = float(np.linalg.norm(arr))
        if not n > 0:
            raise InputError(src, key, "a non-zero direction", v)
        arr = arr / n
    return np.concatenate([arr, np.zeros(3 - mech.dim)])


def parse_elastic(raw: dict[str, Any], mech: Mechanism, src: str) -> ElasticData | None:
    """The elastic data of a mechanism file's parsed TOML (None without an ``[elastic]`` table)."""
    comps_raw = raw.get("components", {})
    if "elastic" not in raw:
        if comps_raw:
            raise InputError(src, "elastic", "an [elastic] table placing the [components] on joints and links",
                             "[components] without [elastic]")
        return None
    from components.registry import build_component

    if not isinstance(comps_raw, dict) or not all(isinstance(v, dict) for v in comps_raw.values()):
        raise InputError(src, "components", "tables [components.NAME] with a model", comps_raw)
    base = str(Path(src).parent) if src else "."
    comps = {n: build_component(n, t, source=src, base_dir=base) for n, t in comps_raw.items()}
    el = check_keys(raw["elastic"], _ELASTIC, src, "elastic.")

    def comp(name: Any, role: str, key: str) -> Any:
        if name is None:
            return None
        if name not in comps:
            raise InputError(src, key, f"a component of [components] ({', '.join(sorted(comps)) or 'none'})", name)
        c = comps[name]
        kind = getattr(c, "kind", "body")
        if role in _ROLE_KINDS and kind not in _ROLE_KINDS[role]:
            raise InputError(src, key, f"a component of kind {' or '.join(_ROLE_KINDS[role])}", f"{name!r} ({kind})")
        if role == "drive" and getattr(c, "axial_stiffness", None) == "pole_placement":
            raise InputError(src, key, "a drive of given stiffness (mechanisms have no pole-placement model)",
                             f"{name!r} (pole_placement)")
        return c

    links: dict[int, LinkElastic] = {}
    for ln, t in (el.get("links") or {}).items():
        key = f"elastic.links.{ln}"
        if ln not in mech.links:
            raise InputError(src, key, f"one of the links {list(mech.links)}", ln)
        li = mech.link_index(ln)
        if li in mech.ground:
            raise InputError(src, key, "a moving link (the ground is rigid and fixed)", ln)
        check_keys(t, _LINK, src, key + ".")
        model = t.get("model", "rigid")
        if model not in ("rigid", "strut"):
            raise InputError(src, key + ".model", "'rigid' or 'strut'", model)
        if model == "strut":
            if any(k in t for k in ("body", "origin", "flexibility", "tool_body")):
                raise InputError(src, key, "component and mass_shares only for a strut", sorted(t))
            ends = [j for j in mech.joints if li in j.links]
            if len(ends) != 2:
                raise InputError(src, key + ".model", "a strut joined by exactly two joints",
                                 f"{len(ends)} joints ({', '.join(j.name for j in ends)})")
            shares = t.get("mass_shares", [0.5, 0.5])
            if not (isinstance(shares, list) and len(shares) == 2 and all(0 <= float(s) <= 1 for s in shares)):
                raise InputError(src, key + ".mass_shares", "two fractions in [0, 1]", shares)
            links[li] = LinkElastic(strut=True, component=comp(t.get("component"), "component", key + ".component"),
                                    mass_shares=(float(shares[0]), float(shares[1])))
        else:
            if "component" in t or "mass_shares" in t:
                raise InputError(src, key, "body, origin, flexibility, tool_body for a rigid link", sorted(t))
            origin = _vec3(t["origin"], "m", mech, src, key + ".origin") if "origin" in t else np.zeros(3)
            body = component_body(comp(t.get("body"), "body", key + ".body"))
            flex = comp(t.get("flexibility"), "flexibility", key + ".flexibility")
            if "tool_body" in t and flex is None:
                raise InputError(src, key + ".tool_body", "a tool body only with a flexibility", t["tool_body"])
            tool = component_body(comp(t.get("tool_body"), "body", key + ".tool_body"))
            links[li] = LinkElastic(body=PKSBody(body.mass, body.cog + origin, body.inertia), origin=origin,
                                    flexibility=flex, tool=PKSBody(tool.mass, tool.cog + origin, tool.inertia))
    joints: dict[int, JointElastic] = {}
    names = [j.name for j in mech.joints]
    for jn, t in (el.get("joints") or {}).items():
        key = f"elastic.joints.{jn}"
        if jn not in names:
            raise InputError(src, key, "a joint of [[joints]]", jn)
        check_keys(t, _JOINT, src, key + ".")
        ji = names.index(jn)
        jt = mech.joints[ji]
        conv = t.get("convention", "axis")
        if conv not in ("axis", "normal"):
            raise InputError(src, key + ".convention", "'axis' or 'normal'", conv)
        if "drive" in t and jt.drive is None:
            raise InputError(src, key + ".drive", "a drive component on a driven joint", f"{jn} is not driven")
        if "joint" in t and "axis" not in t:
            raise InputError(src, key + ".axis", "the joint axis for the angle-dependent joint stiffness",
                             "missing key")
        joints[ji] = JointElastic(
            drive=comp(t.get("drive"), "drive", key + ".drive"), guide=comp(t.get("guide"), "guide", key + ".guide"),
            joint=comp(t.get("joint"), "joint", key + ".joint"),
            stiffness=comp(t.get("stiffness"), "stiffness", key + ".stiffness"),
            axis=_vec3(t["axis"], "dimensionless", mech, src, key + ".axis", True) if "axis" in t else None,
            reference=(_vec3(t["reference"], "dimensionless", mech, src, key + ".reference", True)
                       if "reference" in t else None),
            normal=conv == "normal",
            mass=float(parse_quantity(t.get("mass", 0.0), "kg", source=src, key=key + ".mass")))
    vertical = np.asarray(parse_quantity(el.get("vertical", [0.0, 0.0, 1.0]), "dimensionless", source=src,
                                         key="elastic.vertical", shape=(3,)), float)
    if not np.linalg.norm(vertical) > 0:
        raise InputError(src, "elastic.vertical", "a non-zero direction", el.get("vertical"))
    beta = float(parse_quantity(el.get("damping_beta", 0.0), "s", source=src, key="elastic.damping_beta"))
    if not (np.isfinite(beta) and beta >= 0):
        raise InputError(src, "elastic.damping_beta", "a time >= 0 s", beta)
    weight = None
    if "transmission_weight" in el:
        weight = float(parse_quantity(el["transmission_weight"], "m/rad", source=src, key="elastic.transmission_weight"))
        if not (np.isfinite(weight) and weight > 0):
            raise InputError(src, "elastic.transmission_weight", "a length per angle > 0 m/rad", weight)
    frac = float(parse_quantity(el.get("drive_load_strut_mass", 0.0), "dimensionless", source=src,
                                key="elastic.drive_load_strut_mass"))
    if not 0.0 <= frac <= 1.0:
        raise InputError(src, "elastic.drive_load_strut_mass", "a fraction in [0, 1]", frac)
    return ElasticData(comps, links, joints, vertical / np.linalg.norm(vertical), beta, weight, frac)

