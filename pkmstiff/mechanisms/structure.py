"""Elastic model of a mechanism at N configurations: the SDE model of :mod:`pkmstiff.multibody` (no second
solver) built from the element placement of :mod:`pkmstiff.mechanisms.elastic` (issue 27, item 1).

:func:`mechanism_structure` solves the inverse kinematics of the poses (or takes a :class:`Solution`) and builds,
vectorised over the configurations, rigid bodies for the rigid links, point masses for the nodes, axial elements
``k_V d̂ d̂ᵀ`` for the struts (eq. 4.48), ``F diag(k_drive, K_guide) Fᵀ`` for carriage nodes (eq. 3.6), 6×6 elements
for joints between rigid links and for link flexibilities (eq. 4.51–4.52) and exact rigid bindings for every
constrained direction without a stiffness.  Planar mechanisms are embedded in the plane z = 0 with their
out-of-plane motions bound rigidly.  Quantities and units as for the structure model of pod/glide machines
(docs/theory/structure.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

import pkmstiff.multibody as sde
from pkmstiff.errors import InputError
from pkmstiff.kinematics.joint_angles import joint_angles_along
from pkmstiff.mechanisms.constraints import link_rotations
from pkmstiff.mechanisms.elastic import ElasticData
from pkmstiff.mechanisms.model import JOINT_TYPES_2D, JOINT_TYPES_3D, Mechanism
from pkmstiff.mechanisms.solver import Solution, inverse, joint_values
from pkmstiff.structure.layout import PKSBody, combine_bodies
from pkmstiff.structure.stiffness import evaluate_component

Array = np.ndarray

#: component labels of the energy shares (share_* of point/section), in output order
LABELS = ("drive", "guide", "strut", "joint", "bearing", "link")


def _mass(c: Any) -> float:
    return 0.0 if c is None else float(getattr(c, "mass", 0.0) or 0.0)


def _perp(a: Array) -> Array:
    """A unit vector ⟂ a (deterministic)."""
    e = np.eye(3)[int(np.argmin(np.abs(a)))]
    v = np.cross(a, e)
    return v / np.linalg.norm(v)


@dataclass(frozen=True)
class StrutEnd:
    joint: int
    other: int  #: link across the joint
    node: str  #: node body name ("" = attached to the other link)
    telescopic: bool  #: a driven linear joint whose axis the strut carries: drive in series


@dataclass(frozen=True)
class Node:
    """A point mass at a joint where struts end: ``link`` carries the drive axis (-1: a free node where struts meet)."""

    name: str
    joint: int
    link: int
    mass: float


@dataclass(frozen=True)
class Plan:
    """Pose-independent placement of bodies and elements (see :mod:`pkmstiff.mechanisms.elastic`)."""

    mech: Mechanism
    elastic: ElasticData
    struts: tuple[tuple[int, tuple[StrutEnd, StrutEnd]], ...]
    nodes: dict[int, Node]
    bodies: dict[int, PKSBody]  #: rigid links (link coordinates = home world)
    tools: dict[int, PKSBody]  #: tool parts of flexible links
    joints: tuple[int, ...]  #: joints between rigid links / ground
    load: tuple[str, int, Array]  #: (kind "body"/"tool"/"node", link or joint, home point) of the output point
    #: drive-coordinate masses [kg] / inertias [kg m²] per driven joint (the machines' M_A, eq. 4.86): telescopic
    #: drives' masses and rotary drives' ``inertia``; in the kinetostatics only (see :func:`plan`)
    drive_inertias: dict[int, float] = field(default_factory=dict)

    def body_name(self, link: int) -> str:
        return sde.FRAME if link in self.mech.ground else self.mech.links[link]


def plan(mech: Mechanism, dynamics: bool = False) -> Plan:
    """Placement of the elastic model of ``mech`` (raises :class:`InputError` naming the file and key).

    A telescopic drive's mass (a ball screw's moved mass + apparent spindle mass, Cobet eq. 3.4) is the machines'
    drive mass M_A: the structure model (modes, ``dynamics=False``) places it at the drive's node, the strut's
    other end (the motor, fixed where that end is the ground); the rigid-body dynamics (``dynamics=True``: M_s of
    the kinetostatics, eq. 4.86) accelerate it with the drive coordinate, M_A s̈, so it is left out of the bodies
    and listed in :attr:`Plan.drive_inertias` — as is a rotary drive's ``inertia`` (rotor behind its gear, about
    the drive axis), which no body carries.
    """
    el = mech.elastic
    src = mech.path or mech.name
    if el is None:
        raise InputError(src, "elastic", "an [elastic] table (components on joints and links) for a stiffness model",
                         "none")
    for i, ln in enumerate(mech.links):
        if i not in mech.ground and ln == sde.FRAME:
            raise InputError(src, "mechanism.links", f"no moving link named {sde.FRAME!r} (the fixed frame's name)",
                             ln)
    for jt in mech.joints:
        if jt.type == "fixed":
            raise InputError(src, f"joints ({jt.name}).type", "joint types of links (the elastic model has no "
                             "'fixed' coordinates)", "fixed")
    is_strut = {i for i in range(len(mech.links)) if el.link(i).strut}
    ends: dict[int, list[StrutEnd]] = {}
    nodes: dict[int, Node] = {}
    point_masses: dict[int, list[PKSBody]] = {i: [] for i in range(len(mech.links))}
    node_mass: dict[int, float] = {}
    for li in sorted(is_strut):
        lst = []
        for ji, jt in enumerate(mech.joints):
            if li not in jt.links:
                continue
            other = jt.links[1] if jt.links[0] == li else jt.links[0]
            je = el.joint(ji)
            linear_drive = jt.drive is not None and jt.variable == "linear"
            if jt.drive is not None and not linear_drive:
                raise InputError(src, f"joints ({jt.name}).drive", "a linear drive at a strut end (a rotary drive "
                                 "needs rigid links on both sides)", f"a {jt.type} drive")
            telescopic = linear_drive and jt.links[0] == li
            if other in is_strut:
                nodes.setdefault(ji, Node(f"node {jt.name}", ji, -1, 0.0))
            elif linear_drive and not telescopic and (je.drive is not None or je.guide is not None):
                nodes[ji] = Node(f"node {jt.name}", ji, other, 0.0)
            elif je.guide is not None:
                raise InputError(src, f"elastic.joints.{jt.name}.guide", "guide carriages on a carriage (a driven "
                                 "linear joint whose axis is on the other link)", "another joint")
            lst.append(StrutEnd(ji, other, nodes[ji].name if ji in nodes else "", telescopic))
        ends[li] = lst
    for li, (e1, e2) in ends.items():
        le = el.link(li)
        tele = [e for e in (e1, e2) if e.telescopic]
        m_strut = _mass(le.component)
        for e, share in ((e1, le.mass_shares[0]), (e2, le.mass_shares[1])):
            extra = share * m_strut
            if tele and e is not tele[0] and not dynamics:  # the motor of a telescopic drive: the strut's other end
                extra += _mass(el.joint(tele[0].joint).drive)
            _put_mass(mech, el, e, extra, nodes, node_mass, point_masses)
    for ji, nd in list(nodes.items()):
        je = el.joint(ji)
        nodes[ji] = Node(nd.name, ji, nd.link, node_mass.get(ji, 0.0) + je.mass + _mass(je.drive) + _mass(je.guide))
    strut_joints = {e.joint for lst in ends.values() for e in lst}
    rigid_joints = []
    for ji, jt in enumerate(mech.joints):
        if ji in strut_joints:
            continue
        a, b = jt.links
        je = el.joint(ji)
        if je.joint is not None or je.guide is not None:
            raise InputError(src, f"elastic.joints.{jt.name}", "joint/guide components at strut ends only "
                             "(between rigid links: stiffness = a 6x6 component)", "joint or guide")
        carrier = b if b not in mech.ground else a
        if carrier not in mech.ground:
            point_masses[carrier].append(PKSBody(je.mass + _mass(je.drive), _home3(mech, jt.point), np.zeros((3, 3))))
        rigid_joints.append(ji)
    bodies, tools = {}, {}
    for li in range(len(mech.links)):
        if li in mech.ground or li in is_strut:
            continue
        le = el.link(li)
        bodies[li] = combine_bodies([le.body] + point_masses[li]) if point_masses[li] else le.body
        if le.flexibility is not None:
            tools[li] = le.tool
    inertias = {e.joint: _mass(el.joint(e.joint).drive) for lst in ends.values() for e in lst if e.telescopic}
    inertias.update({ji: float(getattr(el.joint(ji).drive, "inertia", 0.0)) for ji in rigid_joints
                     if mech.joints[ji].drive is not None and mech.joints[ji].variable == "angle"})
    return Plan(mech, el, tuple((li, (e[0], e[1])) for li, e in ends.items()), nodes, bodies, tools,
                tuple(rigid_joints), _load(mech, src, is_strut, ends, nodes, tools),
                {ji: v for ji, v in inertias.items() if v > 0})


def _home3(mech: Mechanism, p: Array) -> Array:
    return np.concatenate([np.asarray(p, float), np.zeros(3 - mech.dim)])


def _put_mass(mech: Mechanism, el: ElasticData, end: StrutEnd, mass: float, nodes: dict[int, Node],
              node_mass: dict[int, float], point_masses: dict[int, list[PKSBody]]) -> None:
    """Joint mass and strut share at a strut end: to its node, else to the other link at the joint point."""
    if end.joint in nodes:
        node_mass[end.joint] = node_mass.get(end.joint, 0.0) + mass
        return
    total = mass + el.joint(end.joint).mass
    if end.other not in mech.ground and total:
        point_masses[end.other].append(PKSBody(total, _home3(mech, mech.joints[end.joint].point), np.zeros((3, 3))))


def _load(mech: Mechanism, src: str, is_strut: set[int], ends: dict[int, list[StrutEnd]], nodes: dict[int, Node],
          tools: dict[int, PKSBody]) -> tuple[str, int, Array]:
    if mech.output is None:
        raise InputError(src, "output", "an [output] (the point where stiffness is evaluated)", "none")
    li, p = mech.output.link, _home3(mech, mech.output.point)
    if li not in is_strut:
        return ("tool" if li in tools else "body", li, p)
    for e in ends[li]:
        if np.allclose(_home3(mech, mech.joints[e.joint].point), p, atol=1e-12 * mech.length_scale):
            return ("node", e.joint, p) if e.node else ("body", e.other, p)
    raise InputError(src, "output.point", "on a strut link: the point of one of its end joints", p.tolist())


# ------------------------------------------------------------------------------------------------ per pose


def _link_frames(mech: Mechanism, q: Array) -> tuple[Array, Array]:
    """t (N, L, 3), R (N, L, 3, 3) of every link (planar: embedded in z = 0)."""
    n, n_l = q.shape[0], q.shape[1]
    if mech.dim == 3:
        R, _ = link_rotations(q[..., 3:], 3)
        return q[..., :3], R
    R2, _ = link_rotations(q[..., 2:], 2)
    R = np.zeros((n, n_l, 3, 3))
    R[..., :2, :2] = R2
    R[..., 2, 2] = 1.0
    t = np.zeros((n, n_l, 3))
    t[..., :2] = q[..., :2]
    return t, R


@dataclass
class _Geometry:
    t: Array
    R: Array
    mech: Mechanism

    def point(self, link: int, p: Array) -> Array:
        """World position (N, 3) of the home point p of link ``link``."""
        if link in self.mech.ground:
            return np.broadcast_to(p, (self.t.shape[0], 3))
        return self.t[:, link] + self.R[:, link] @ p

    def vector(self, link: int, v: Array) -> Array:
        if link in self.mech.ground:
            return np.broadcast_to(v, (self.t.shape[0], 3))
        return self.R[:, link] @ v

    def rot(self, link: int) -> Array | None:
        return None if link in self.mech.ground else self.R[:, link]


def _stiffness(comp: Any, n: int, **state: Array) -> tuple[Array, Array]:
    """Component stiffness (N, ...) at n states and an ok mask; ``None`` component: rigid (inf)."""
    if comp is None:
        return np.full(n, np.inf), np.ones(n, bool)
    kw = {k: np.ascontiguousarray(v, float) for k, v in state.items()}
    return evaluate_component(comp, kw, n)


@dataclass
class MechanismStructure:
    """Elastic model of a mechanism at N poses (the SDE model over the ``index`` poses whose configuration was found
    and whose components could be evaluated; NaN results elsewhere).

    ``solution`` the configurations; ``model`` the SDE model of the modelled poses; ``load_body``/``load_point``
    (M, 3) where the output point's stiffness is evaluated; ``energy_split`` per element name the factors (M, ...)
    that split its strain energy among the component labels (:data:`LABELS`).
    """

    plan: Plan
    poses: Array
    solution: Solution
    index: Array
    status: Array  #: (N,) 0 modelled, 1 no configuration, 2 component failed, 4 not positive definite
    model: sde.SDEModel | None
    load_body: str
    load_point: Array
    energy_split: dict[str, list[tuple[str, Any]]] = field(default_factory=dict)

    @property
    def output_body(self) -> str:
        """The body whose motion describes a mode: the output link's (its main body where the link is flexible)."""
        kind, ref, _ = self.plan.load
        return self.plan.body_name(ref) if kind == "tool" else self.load_body

    @property
    def mech(self) -> Mechanism:
        return self.plan.mech

    @property
    def n_poses(self) -> int:
        return int(self.poses.shape[0])

    @property
    def ok(self) -> Array:
        return self.status == 0

    def scatter(self, values: Array) -> Array:
        out = np.full((self.n_poses,) + values.shape[1:], np.nan)
        out[self.index] = values
        return out


STATUS_BITS = {"NO_CONFIGURATION": 1, "COMPONENT_FAILED": 2, "NOT_POSITIVE_DEFINITE": 4}


def mechanism_structure(mech: Mechanism, poses: ArrayLike | None = None, solution: Solution | None = None,
                        point: ArrayLike | None = None, **solve_kw: Any) -> MechanismStructure:
    """Elastic model of ``mech`` at the poses (inverse kinematics, continuation from home or ``solve_kw``) or at the
    configurations of ``solution``; loads and responses at the output point or at ``point`` (3,) [m], home
    coordinates of a point of the output link (a rigid link)."""
    pl = plan(mech)
    if point is not None:
        kind, ref, _ = pl.load
        if kind == "node":
            raise InputError(mech.path or mech.name, "point", "a point of a rigid output link (the output of this "
                             "file is a point mass where struts meet)", point)
        p = np.asarray(point, float).reshape(-1)
        if p.shape != (mech.dim,) or not np.all(np.isfinite(p)):
            raise InputError(mech.path or mech.name, "point", f"{mech.dim} finite coordinates in m", point)
        pl = replace(pl, load=(kind, ref, _home3(mech, p)))
    if solution is None:
        solution = inverse(mech, np.atleast_2d(np.asarray(poses, float)), **solve_kw)
    poses_arr = np.asarray(solution.poses if poses is None else np.atleast_2d(np.asarray(poses, float)), float)
    status = np.where(solution.ok, 0, STATUS_BITS["NO_CONFIGURATION"]).astype(np.uint8)
    idx = np.flatnonzero(status == 0)
    model, load_point, split = None, np.zeros((0, 3)), {}
    if idx.size:
        model, load_point, split, good = _build(pl, solution.q[idx])
        status[idx[~good]] |= STATUS_BITS["COMPONENT_FAILED"]
        if not good.all():
            idx = idx[good]
            model, load_point, split = (_build(pl, solution.q[idx])[:3] if idx.size else
                                        (None, np.zeros((0, 3)), {}))
    kind, ref, _ = pl.load
    body = (pl.nodes[ref].name if kind == "node" else
            f"{mech.links[ref]}.tool" if kind == "tool" else pl.body_name(ref))
    return MechanismStructure(pl, poses_arr, solution, idx, status, model, body, load_point, split)


def _build(pl: Plan, q: Array) -> tuple[sde.SDEModel, Array, dict, Array]:
    """SDE model of the configurations q (M, L, d), the load point (M, 3), the energy split and an ok mask (M,)."""
    mech, el = pl.mech, pl.elastic
    m = q.shape[0]
    t, R = _link_frames(mech, q)
    g = _Geometry(t, R, mech)
    model = sde.SDEModel()
    beta = el.damping_beta
    ok = np.ones(m, bool)
    split: dict[str, list[tuple[str, Any]]] = {}
    drive_vals = joint_values(mech, q, [i for i, j in enumerate(mech.joints) if j.drive is not None]) if m else \
        np.zeros((0, len(mech.drives)))
    drive_col = {i: c for c, i in enumerate(i for i, j in enumerate(mech.joints) if j.drive is not None)}

    def drive_value(ji: int) -> Array:  # drive value = joint variable + offset (eq. 8), the components' position
        return drive_vals[:, drive_col[ji]]

    for li, body in pl.bodies.items():
        rot = R[:, li]
        model.add_rigid_body(mech.links[li], body.mass, t[:, li] + rot @ body.cog, body.inertia, rotation=rot)
    for li, tool in pl.tools.items():
        rot = R[:, li]
        model.add_rigid_body(f"{mech.links[li]}.tool", tool.mass, t[:, li] + rot @ tool.cog, tool.inertia,
                             rotation=rot)
    for ji, nd in pl.nodes.items():
        jt = mech.joints[ji]
        model.add_point_mass(nd.name, nd.mass, g.point(jt.links[1], _home3(mech, jt.point)))
    # carriage nodes: K_W = F diag(k_drive, K_guide) Fᵀ, rigid directions bound (eq. 3.6, docs/theory/structure.md)
    from components.guides import drive_frame

    for ji, nd in pl.nodes.items():
        if nd.link < 0:
            continue
        jt, je = mech.joints[ji], el.joint(ji)
        axis = _home3(mech, jt.axis)
        f_home = drive_frame(axis, vertical=el.vertical)
        F = f_home if nd.link in mech.ground else R[:, nd.link] @ f_home
        k_loc = np.zeros((m, 3, 3))
        if je.guide is None:
            k_loc[:, 1, 1] = k_loc[:, 2, 2] = np.inf
        else:
            kg, okg = evaluate_component(je.guide, {"drive_position": drive_value(ji)}, m)
            k_loc[:] = kg
            ok &= okg
        kd, okd = _stiffness(je.drive, m, drive_position=drive_value(ji))
        ok &= okd
        k_loc[:, 0, 0] = kd
        rigid = np.all(np.isposinf(np.diagonal(k_loc, axis1=1, axis2=2)), axis=0)
        kl = np.where(np.isposinf(k_loc), 0.0, k_loc)
        kw = F @ kl @ np.swapaxes(F, -1, -2)
        point = g.point(jt.links[1], _home3(mech, jt.point))
        name = f"W {jt.name}"
        model.add_sde(name, pl.body_name(nd.link), nd.name, point, stiffness=kw,
                      damping=beta * kw if beta else None, group="W", check_psd=False)
        split[name] = [("drive", ("axial3", F[..., 0] if F.ndim == 3 else np.broadcast_to(F[:, 0], (m, 3)),
                                  kl[:, 0, 0])), ("guide", None)]
        for j in np.flatnonzero(rigid):
            axis_j = F[..., j] if F.ndim == 3 else F[:, j]
            model.add_rigid_binding(f"{name} rigid {'xyz'[j]}", pl.body_name(nd.link), nd.name, point, kind="axial",
                                    axis=axis_j)
    # struts: k_V d̂ d̂ᵀ, 1/k_V = 1/k_strut + Σ 1/k_joint + Σ 1/k_telescopic (eq. 4.48)
    for li, (e1, e2) in pl.struts:
        p1 = g.point(mech.joints[e1.joint].links[1], _home3(mech, mech.joints[e1.joint].point))
        p2 = g.point(mech.joints[e2.joint].links[1], _home3(mech, mech.joints[e2.joint].point))
        d = p2 - p1
        length = np.linalg.norm(d, axis=1)
        u = d / length[:, None]
        terms = []
        k_s, oks = _stiffness(el.link(li).component, m, strut_length=length)
        ok &= oks
        terms.append(("strut", k_s))
        for e, direction in ((e1, u), (e2, -u)):
            je = el.joint(e.joint)
            if je.joint is not None:
                rot = g.rot(e.other)
                tilt, swivel = joint_angles_along(direction, rot, je.axis,
                                                  je.reference if je.reference is not None else _perp(je.axis),
                                                  je.normal)
                kj, okj = evaluate_component(je.joint, {"tilt": tilt, "swivel": swivel}, m)
                ok &= okj
                terms.append(("joint", kj))
            if e.telescopic:
                kd, okd = _stiffness(je.drive, m, drive_position=drive_value(e.joint), strut_length=length)
                ok &= okd
                terms.append(("drive", kd))
        with np.errstate(divide="ignore", invalid="ignore"):
            kv = 1.0 / sum(1.0 / k for _, k in terms)
        a = pl.nodes[e1.joint].name if e1.node else pl.body_name(e1.other)
        b = pl.nodes[e2.joint].name if e2.node else pl.body_name(e2.other)
        name = f"V {mech.links[li]}"
        if np.all(np.isposinf(kv)):
            model.add_rigid_binding(name + " rigid", a, b, p2, kind="axial", axis=u)
            continue
        kv_f = np.where(np.isfinite(kv), kv, 0.0)
        model.add_sde(name, a, b, p2, k=kv_f, axis=u, c=beta * kv_f if beta else None, group="V")
        with np.errstate(divide="ignore", invalid="ignore"):
            split[name] = [(lab, ("share", np.where(np.isposinf(k), 0.0, kv_f / k))) for lab, k in terms]
    for ji in pl.joints:
        _joint_elements(pl, ji, g, model, split, drive_value, ok)
    for li, tool in pl.tools.items():  # link flexibility at `origin`, link axes (H K Hᵀ, eq. 4.51–4.52)
        le = el.link(li)
        ku = np.asarray(le.flexibility.stiffness(_state(1)), float).reshape(6, 6)
        h = np.zeros((m, 6, 6))
        h[:, :3, :3] = h[:, 3:, 3:] = R[:, li]
        k6 = h @ ku @ np.swapaxes(h, 1, 2)
        name = f"U {mech.links[li]}"
        model.add_sde(name, mech.links[li], f"{mech.links[li]}.tool", g.point(li, le.origin), stiffness=k6,
                      damping=beta * k6 if beta else None, group="U", check_psd=False)
        split[name] = [("link", None)]
    if mech.dim == 2:  # planar: out-of-plane motions bound
        for name in model.body_names:
            b = model.body(name)
            pos = np.broadcast_to(b.position, (m, 3))
            model.add_rigid_binding(f"{name} plane z", name, sde.FRAME, pos, kind="axial", axis=np.eye(3)[2])
            if isinstance(b, sde.RigidBody):
                for j in (0, 1):
                    model.add_rigid_binding(f"{name} plane r{'xy'[j]}", name, sde.FRAME, pos, kind="angular",
                                            axis=np.eye(3)[j])
    kind, ref, p = pl.load
    load_point = g.point(mech.joints[ref].links[1], p) if kind == "node" else g.point(ref, p)
    return model, load_point, split, ok


def _state(n: int):
    from components.protocol import ComponentState

    return ComponentState(n_poses=n)


def _constrained(mech: Mechanism, ji: int, g: _Geometry) -> tuple[Array, Array]:
    """Orthonormal bases (N, 3, r) of the translations and rotations joint ``ji`` constrains (its elementary
    constraints, calibration.md §3; planar: in-plane translations, rotation about z)."""
    jt = mech.joints[ji]
    a, b = jt.links
    n = g.t.shape[0]
    trans, rots = [], []
    ax = None if jt.axis is None else g.vector(a, _home3(mech, jt.axis))
    types = JOINT_TYPES_3D if mech.dim == 3 else JOINT_TYPES_2D
    eye = np.broadcast_to(np.eye(3), (n, 3, 3))
    for e in types[jt.type]:
        if mech.dim == 2:
            if e == "1A":
                trans += [eye[..., 0], eye[..., 1]]
            elif e == "1B":
                rots.append(eye[..., 2])
            elif e == "1E":
                trans.append(np.cross(eye[..., 2], ax))
            continue
        if e == "1A":
            trans += [eye[..., 0], eye[..., 1], eye[..., 2]]
        elif e == "1B":
            rots += [eye[..., 0], eye[..., 1], eye[..., 2]]
        elif e in ("1C", "1E"):
            p1 = np.cross(ax, np.broadcast_to(_perp(_home3(mech, jt.axis)), (n, 3)))
            p1 = p1 / np.linalg.norm(p1, axis=1)[:, None]
            p2 = np.cross(ax, p1)
            trans += [p1, p2]
            if e == "1C":
                rots += [p1, p2]
        elif e == "1D":
            ax2 = g.vector(b, _home3(mech, jt.axis2))
            c = np.cross(ax, ax2)
            rots.append(c / np.linalg.norm(c, axis=1)[:, None])
        elif e == "1F":
            trans.append(ax)

    def basis(vs: list[Array]) -> Array:
        if not vs:
            return np.zeros((n, 3, 0))
        u, s, _ = np.linalg.svd(np.stack(vs, axis=2))
        r = int(np.sum(s[0] > 1e-9 * s[0, 0]))
        return u[..., :r]

    return basis(trans), basis(rots)


def _joint_elements(pl: Plan, ji: int, g: _Geometry, model: sde.SDEModel, split: dict, drive_value, ok: Array
                    ) -> None:
    """One 6×6 element (joint stiffness in joint axes + drive) and rigid bindings for joint ``ji`` between rigid
    links / the ground."""
    mech, el = pl.mech, pl.elastic
    jt, je = mech.joints[ji], el.joint(ji)
    a, b = jt.links
    na, nb = pl.body_name(a), pl.body_name(b)
    m = g.t.shape[0]
    point = g.point(b, _home3(mech, jt.point))
    k6 = np.zeros((m, 6, 6))
    parts = []
    trans, rots = _constrained(mech, ji, g)
    if je.stiffness is not None:  # given in the axes of the joint's first link (world axes at home)
        kl = np.asarray(je.stiffness.stiffness(_state(1)), float).reshape(6, 6)
        if a in mech.ground:
            k6 += kl
        else:
            h = np.zeros((m, 6, 6))
            h[:, :3, :3] = h[:, 3:, 3:] = g.R[:, a]
            k6 += h @ kl @ np.swapaxes(h, 1, 2)
        parts.append(("bearing", None))
    drive_dir = None
    if jt.drive is not None:
        drive_dir = g.vector(a, _home3(mech, jt.axis) if jt.axis is not None else np.eye(3)[2])
        kd, okd = _stiffness(je.drive, m, drive_position=drive_value(ji))
        ok &= okd
        rotary = jt.variable == "angle"
        if np.all(np.isposinf(kd)):
            model.add_rigid_binding(f"J {jt.name} drive rigid", na, nb, point,
                                    kind="angular" if rotary else "axial", axis=drive_dir)
        else:
            blk = slice(3, 6) if rotary else slice(0, 3)
            k6[:, blk, blk] += kd[:, None, None] * drive_dir[:, :, None] * drive_dir[:, None, :]
            parts.insert(0, ("drive", ("rot" if rotary else "axial", drive_dir, kd)))
    if je.stiffness is None:
        for j in range(trans.shape[2]):
            model.add_rigid_binding(f"J {jt.name} rigid t{j}", na, nb, point, kind="axial", axis=trans[..., j])
        for j in range(rots.shape[2]):
            model.add_rigid_binding(f"J {jt.name} rigid r{j}", na, nb, point, kind="angular", axis=rots[..., j])
    if parts:
        name = f"J {jt.name}"
        beta = el.damping_beta
        model.add_sde(name, na, nb, point, stiffness=k6, damping=beta * k6 if beta else None, group="J",
                      check_psd=False)
        # the rest of the element's energy: the bearing's; without a bearing stiffness all of it is the drive's
        split[name] = parts if je.stiffness is not None else [("drive", None)]
