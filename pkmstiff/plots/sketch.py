"""Geometric sketch of a machine at a pose: guides / fixed drive joints, struts, drive and platform joints, hull; and
of a mechanism at a configuration: links, joints, output point."""

from __future__ import annotations

import numpy as np

from pkmstiff.kinematics import inverse_kinematics
from pkmstiff.machine.model import Machine
from pkmstiff.plots import offscreen

MM = 1e3


def machine_sketch(machine: Machine, pose, scale: float = MM):
    """pyvista MultiBlock (coordinates in mm by default) of the machine at ``pose`` (x, y, z [m], a, b, c [rad]).

    Blocks: ``guides`` (glide: the usable guide segments), ``struts`` (tubes), ``drive_joints``,
    ``platform_joints`` (spheres), ``platform`` (the hull, or the polygon of platform joints when no hull is given).
    Unreachable chains are left out.
    """
    ik = inverse_kinematics(machine, np.asarray(pose, float)[None])
    R, w = ik.R[0], ik.poses[0, :3]
    hull = machine.hull.vertices @ R.T + w if not machine.hull.empty else None
    return sketch_from_points(machine, ik.q[0], ik.p[0], hull, scale)


def sketch_from_points(machine: Machine, q: np.ndarray, p: np.ndarray, hull_points: np.ndarray | None,
                       scale: float = MM):
    """Sketch from drive-side joint points q (n, 3), platform-side joint points p (n, 3) and hull vertices (m)."""
    pv = offscreen()
    ch = machine.chains
    blocks = pv.MultiBlock()
    if ch.kind == "glide":
        start = ch.guide_start
        end = ch.guide_start + ch.guide_length[:, None] * ch.guide_direction
        blocks["guides"] = _lines(np.stack([start, end], 1) * scale, pv)
    q, p = q * scale, p * scale
    ok = np.isfinite(q).all(axis=1) & np.isfinite(p).all(axis=1)
    radius = float(np.mean(ch.strut_radius)) * scale
    struts = pv.MultiBlock()
    for i in np.nonzero(ok)[0]:
        struts[f"strut {i + 1}"] = pv.Line(q[i], p[i]).tube(radius=radius)
    blocks["struts"] = struts.combine().extract_surface(algorithm="dataset_surface") if len(struts) else pv.PolyData()
    blocks["drive_joints"] = _spheres(q[ok], 1.6 * radius, pv)
    blocks["platform_joints"] = _spheres(p[ok], 1.6 * radius, pv)
    if hull_points is not None:
        faces = np.hstack([np.full((len(machine.hull.triangles), 1), 3), machine.hull.triangles]).ravel()
        blocks["platform"] = pv.PolyData(hull_points * scale, faces)
    elif ok.sum() >= 4:
        blocks["platform"] = pv.PolyData(p[ok]).delaunay_3d().extract_surface(algorithm="dataset_surface")
    return blocks


def add_sketch(plotter, machine: Machine | None, pose, opacity: float = 1.0, sketch=None, colour: str | None = None,
               name: str | None = None) -> None:
    """Draw the sketch (of ``machine`` at ``pose``, or a given ``sketch``, e.g. :func:`mechanism_sketch`) into a plotter with consistent colours; with ``name``
    the actors are named ``<name>_<block>`` and replace those of an earlier call with the same ``name``."""
    sk = machine_sketch(machine, pose) if sketch is None else sketch
    colours = {"guides": "dimgray", "struts": "steelblue", "drive_joints": "black", "platform_joints": "black",
               "platform": "lightgray", "links": "steelblue", "joints": "black", "output": "crimson"}
    for block in sk.keys():
        mesh = sk[block]
        if mesh is None or mesh.n_points == 0:
            if name is not None:
                plotter.remove_actor(f"{name}_{block}", render=False)
            continue
        kw: dict = {"line_width": 4} if block == "guides" else {}
        if name is not None:
            kw["name"] = f"{name}_{block}"
        plotter.add_mesh(mesh, color=colour or colours.get(block, "gray"), opacity=opacity, **kw)


def _lines(segments: np.ndarray, pv):
    pts = segments.reshape(-1, 3)
    n = len(segments)
    lines = np.hstack([np.full((n, 1), 2), np.arange(2 * n).reshape(n, 2)]).ravel()
    return pv.PolyData(pts, lines=lines)


def _spheres(points: np.ndarray, radius: float, pv):
    if len(points) == 0:
        return pv.PolyData()
    return pv.PolyData(points).glyph(geom=pv.Sphere(radius=radius, theta_resolution=12, phi_resolution=12),
                                     scale=False, orient=False)


def mechanism_world(mech, q: np.ndarray) -> dict[int, np.ndarray]:
    """World positions {link: (P, 3)} [m] of the drawn points of every moving link (its joint points and the output
    point, in the order of :func:`pkmstiff.mechanisms.modeshape.link_points`) at the configuration q (L, d);
    planar mechanisms in z = 0."""
    from pkmstiff.mechanisms.constraints import Frames
    from pkmstiff.mechanisms.modeshape import link_points

    F = Frames(np.asarray(q, float)[None], mech.dim, derivatives=False)
    out = {}
    for li, plist in link_points(mech).items():
        if plist and li not in mech.ground:
            w = F.t[0, li] + np.array([p for p, _ in plist]) @ F.R[0, li].T
            out[li] = np.column_stack([w, np.zeros((len(w), 3 - mech.dim))])
    return out


def mechanism_sketch(mech, world: dict[int, np.ndarray], scale: float = MM):
    """pyvista MultiBlock of a mechanism (coordinates in mm by default) from the world points of its links
    (:func:`mechanism_world`, or those points displaced by a mode shape).

    Blocks: ``guides`` (axes of linear joints on the ground), ``links`` (tubes along each link's polygon of joint
    points), ``joints`` and ``drive_joints`` (spheres; driven joints larger), ``output`` (the output point).
    """
    from pkmstiff.mechanisms.modeshape import link_points

    pv = offscreen()
    radius = 0.008 * mech.length_scale * scale
    blocks = pv.MultiBlock()
    guides = [(np.asarray(jt.point, float) - s * 0.3 * mech.length_scale * np.asarray(jt.axis, float))
              for jt in mech.joints for s in (1.0, -1.0)
              if jt.axis is not None and jt.variable == "linear" and jt.links[0] in mech.ground]
    ends = np.array([np.concatenate([p, np.zeros(3 - mech.dim)]) for p in guides]).reshape(-1, 2, 3)
    blocks["guides"] = _lines(ends * scale, pv) if guides else pv.PolyData()
    tubes = pv.MultiBlock()
    position: dict[int, np.ndarray] = {}
    for li, plist in link_points(mech).items():
        if li not in world:
            continue
        w = world[li] * scale
        for (_, ji), x in zip(plist, w):
            position.setdefault(ji, x)
        ring = np.vstack([w, w[:1]]) if len(w) > 2 else w
        for k in range(len(ring) - 1):
            if np.linalg.norm(ring[k + 1] - ring[k]) > 1e-9 * scale:
                tubes[f"{mech.links[li]} {k}"] = pv.Line(ring[k], ring[k + 1]).tube(radius=radius)
    blocks["links"] = (tubes.combine().extract_surface(algorithm="dataset_surface") if len(tubes)
                       else pv.PolyData())
    driven = [ji for ji in position if ji >= 0 and mech.joints[ji].drive is not None]
    plain = [ji for ji in position if ji >= 0 and mech.joints[ji].drive is None]
    blocks["joints"] = _spheres(np.array([position[j] for j in plain]).reshape(-1, 3), 1.6 * radius, pv)
    blocks["drive_joints"] = _spheres(np.array([position[j] for j in driven]).reshape(-1, 3), 2.2 * radius, pv)
    blocks["output"] = _spheres(position[-1][None] if -1 in position else np.zeros((0, 3)), 2.2 * radius, pv)
    return blocks
