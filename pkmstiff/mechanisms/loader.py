"""Loading and validation of mechanism files (TOML; links, joints by type, drives, limits, output).

Format (lengths with units as in machine files; bare numbers are SI)::

    format_version = 1
    [mechanism]
    name = "slider_crank"; title = "..."; source = "..."; dimension = 2   # 2 planar, 3 spatial
    links = ["0", "1", "2", "3"]; ground = "0"
    [[joints]]
    name = "A"; type = "revolute"; links = ["0", "1"]; point = [{value = [40, 20], unit = "mm"}]
    axis = [0, 0, 1]                       # spatial revolute / prismatic / cylindrical / 1E / planar normal
    axes = [[1, 0, 0], [0, 1, 0]]          # cardan: axis on the first link, axis on the second
    drive = { name = "s", offset = "0 mm" }  # active joint: drive value = joint variable + offset
    limits = { min = "-30 deg", max = "30 deg" }
    [output]
    link = "3"; point = [...]; orientation = "full" | "axis" | "none"; axis = [0, 0, -1]; coordinates = ["x", "y"]
    [assumptions]
    "joints.A.point" = "one-line reason"

Points and axes are world coordinates at home (DE 10 2004 026 707 A1 [0027], calibration.md §3).  Validation names
the file, the key and, where a joint is at fault, the joint: unknown links, links not connected to the ground,
cardan axes not perpendicular, and over-constrained rigid structures (rank by singular-value gap at home).
"""

from __future__ import annotations

import importlib.resources
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.errors import ArgumentError, InputError
from pkmstiff.io import check_keys, read_toml, require
from pkmstiff.mechanisms.elastic import parse_elastic
from pkmstiff.mechanisms.model import (COORDINATES, JOINT_TYPES_2D, JOINT_TYPES_3D, NOMINAL_RANK, Drive, Joint,
                                       Mechanism, Output)
from pkmstiff.units import parse_quantity

_TOP = {"format_version", "mechanism", "joints", "output", "assumptions", "components", "elastic"}
_MECH = {"name", "title", "source", "dimension", "links", "ground", "notes"}
_JOINT = {"name", "type", "links", "point", "axis", "axes", "drive", "limits", "coordinates", "values", "notes"}
_OUTPUT = {"link", "point", "orientation", "axis", "coordinates"}
_NEEDS_AXIS = {"revolute", "prismatic", "cylindrical", "planar", "common_axis", "point_on_axis", "point_in_plane",
               "slot"}


def bundled_mechanism_dir() -> Path:
    return Path(str(importlib.resources.files("pkmstiff") / "mechanisms" / "bundled"))


def bundled_mechanisms() -> list[str]:
    """Names of the mechanism files shipped with the package."""
    return sorted(p.stem for p in bundled_mechanism_dir().glob("*.toml"))


def load_mechanism(name_or_path: str | Path) -> Mechanism:
    """Load a bundled mechanism by name (``"slider_crank"``) or a mechanism file by path; validated."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        return mechanism_from_dict(read_toml(p, "mechanism file"), str(p))
    cand = bundled_mechanism_dir() / f"{name_or_path}.toml"
    if cand.exists():
        return mechanism_from_dict(read_toml(cand, "mechanism file"), str(cand))
    raise ArgumentError(f"no bundled mechanism {str(name_or_path)!r} and no such file; bundled: "
                                f"{', '.join(bundled_mechanisms())}")


def _err(src, key, expected, found):
    return InputError(src, key, expected, found)


def _vec(v: Any, unit: str, dim: int, src: str, key: str, unitvec: bool = False) -> np.ndarray:
    arr = np.asarray(parse_quantity(v, unit, source=src, key=key, shape=(dim,)), dtype=float)
    if unitvec:
        n = np.linalg.norm(arr)
        if not n > 0:
            raise _err(src, key, "a non-zero axis vector", v)
        arr = arr / n
    return arr


def mechanism_from_dict(raw: dict[str, Any], src: str = "") -> Mechanism:
    """Build and validate a :class:`Mechanism` from the parsed TOML table of a mechanism file."""
    return _from_dict(raw, src)


def _from_dict(raw: dict[str, Any], src: str) -> Mechanism:
    check_keys(raw, _TOP, src)
    fv = raw.get("format_version", 1)
    if fv != 1:
        raise _err(src, "format_version", "1", fv)
    mt = check_keys(require(raw, "mechanism", src, what="a [mechanism] table"), _MECH, src,
                    "mechanism.")
    name = str(require(mt, "name", src, "mechanism.", "a name"))
    dim = mt.get("dimension", 3)
    if dim not in (2, 3):
        raise _err(src, "mechanism.dimension", "2 (planar) or 3 (spatial)", dim)
    links = require(mt, "links", src, "mechanism.", "a list of link names")
    if not isinstance(links, list) or not links or not all(isinstance(x, str) and x for x in links):
        raise _err(src, "mechanism.links", "a non-empty list of link names (strings)", links)
    if len(set(links)) != len(links):
        dup = next(x for x in links if links.count(x) > 1)
        raise _err(src, "mechanism.links", "unique link names", f"{dup!r} twice")
    ground = mt.get("ground", links[0])
    ground = [ground] if isinstance(ground, str) else ground
    for g in ground:
        if g not in links:
            raise _err(src, "mechanism.ground", f"one of the links {links}", g)
    types = JOINT_TYPES_3D if dim == 3 else JOINT_TYPES_2D
    rawj = require(raw, "joints", src, what="an array of [[joints]] tables")
    if not isinstance(rawj, list) or not rawj:
        raise _err(src, "joints", "a non-empty array of [[joints]] tables", rawj)
    joints: list[Joint] = []
    names: set[str] = set()
    drive_names: set[str] = set()
    for i, jr in enumerate(rawj):
        pre = f"joints[{i}]."
        check_keys(jr, _JOINT, src, pre)
        jname = str(jr.get("name", f"J{i}"))
        pre = f"joints[{i}] ({jname})."
        if jname in names:
            raise _err(src, pre + "name", "a unique joint name", jname)
        names.add(jname)
        jtype = require(jr, "type", src, pre, f"a joint type: one of {sorted(types)}")
        if jtype not in types:
            raise _err(src, pre + "type", f"a {'spatial' if dim == 3 else 'planar'} joint type, one of "
                       f"{sorted(types)}", jtype)
        jl = require(jr, "links", src, pre, "the two links the joint joins")
        nl = 1 if jtype == "fixed" else 2
        if not isinstance(jl, list) or len(jl) != nl:
            raise _err(src, pre + "links", f"a list of {nl} link name(s)", jl)
        for ln in jl:
            if ln not in links:
                raise _err(src, pre + "links", f"links declared in mechanism.links {links}", f"unknown link {ln!r}")
        if nl == 2 and jl[0] == jl[1]:
            raise _err(src, pre + "links", "two different links", jl)
        li = tuple(links.index(x) for x in jl)
        point = _vec(jr["point"], "m", dim, src, pre + "point") if "point" in jr else np.zeros(dim)
        if "point" not in jr and jtype not in ("equal_orientation", "common_axis", "perpendicular_axes", "fixed"):
            raise _err(src, pre + "point", f"the joint point in world coordinates at home ({dim} lengths)",
                       "missing key")
        axis = axis2 = None
        if jtype == "cardan" or jtype == "perpendicular_axes":
            ax = require(jr, "axes", src, pre, "two axes [[on the first link], [on the second link]]")
            if not isinstance(ax, list) or len(ax) != 2:
                raise _err(src, pre + "axes", "two axis vectors", ax)
            axis = _vec(ax[0], "dimensionless", 3, src, pre + "axes[0]", True)
            axis2 = _vec(ax[1], "dimensionless", 3, src, pre + "axes[1]", True)
            if abs(axis @ axis2) > 1e-9:
                raise _err(src, pre + "axes", "perpendicular axes (Cardan joint, 1D)",
                           f"angle {np.degrees(np.arccos(np.clip(axis @ axis2, -1, 1))):.6g} deg")
        elif "axis" in jr:
            axis = _vec(jr["axis"], "dimensionless", dim, src, pre + "axis", True)
        elif dim == 3 and jtype in _NEEDS_AXIS or dim == 2 and jtype in ("prismatic", "point_on_axis", "slot"):
            raise _err(src, pre + "axis", f"an axis vector ({dim} numbers) for a {jtype} joint", "missing key")
        coords, values = (), ()
        if jtype == "fixed":
            cn = jr.get("coordinates", list(COORDINATES[dim]))
            if not isinstance(cn, list) or not all(c in COORDINATES[dim] for c in cn):
                raise _err(src, pre + "coordinates", f"a list of {COORDINATES[dim]}", cn)
            coords = tuple(COORDINATES[dim].index(c) for c in cn)
            vals = jr.get("values", [0.0] * len(cn))
            if not isinstance(vals, list) or len(vals) != len(cn):
                raise _err(src, pre + "values", f"{len(cn)} values (m or rad)", vals)
            values = tuple(float(parse_quantity(v, "m" if c < dim else "rad", source=src, key=pre + "values"))
                           for v, c in zip(vals, coords))
            li = (li[0], li[0])
        from pkmstiff.mechanisms.model import JOINT_VARIABLE

        var = JOINT_VARIABLE.get(jtype)
        unit = "m" if var == "linear" else "rad"
        drive = None
        if "drive" in jr:
            dr = jr["drive"]
            if isinstance(dr, str):
                dr = {"name": dr}
            check_keys(dr, {"name", "offset"}, src, pre + "drive.")
            if var not in ("linear", "angle"):
                raise _err(src, pre + "drive", "a drive on a revolute, prismatic, cylindrical or point-on-axis joint",
                           f"a {jtype} joint")
            if dim == 3 and var == "angle" and axis is None:
                raise _err(src, pre + "axis", "the axis of the driven revolute joint", "missing key")
            dn = str(dr.get("name", jname))
            if dn in drive_names:
                raise _err(src, pre + "drive.name", "a unique drive name", dn)
            drive_names.add(dn)
            drive = Drive(dn, float(parse_quantity(dr.get("offset", 0.0), unit, source=src, key=pre + "drive.offset")))
        limits = (-np.inf, np.inf)
        if "limits" in jr:
            lt = check_keys(jr["limits"], {"min", "max"}, src, pre + "limits.")
            if var is None:
                raise _err(src, pre + "limits", "limits only on joints with a joint variable "
                           "(revolute, prismatic, cylindrical, point_on_axis, spherical, cardan)", jtype)
            if var == "tilt" and axis is None:
                raise _err(src, pre + "axis", "a reference axis for the tilt limit of a spherical/cardan joint",
                           "missing key")
            lo = parse_quantity(lt.get("min", -np.inf), unit, source=src, key=pre + "limits.min", allow_nan=True)
            hi = parse_quantity(lt.get("max", np.inf), unit, source=src, key=pre + "limits.max", allow_nan=True)
            if not lo < hi:
                raise _err(src, pre + "limits", "min < max", f"min {lo}, max {hi}")
            limits = (float(lo), float(hi))
        joints.append(Joint(jname, jtype, li, point, axis, axis2, drive, limits, coords, values))
    output = None
    if "output" in raw:
        ot = check_keys(raw["output"], _OUTPUT, src, "output.")
        ol = require(ot, "link", src, "output.", "the output link")
        if ol not in links:
            raise _err(src, "output.link", f"one of the links {links}", ol)
        opoint = _vec(require(ot, "point", src, "output.", "the output point at home"), "m", dim,
                      src, "output.point")
        orient = ot.get("orientation", "full")
        if orient not in ("full", "axis", "none") or (dim == 2 and orient == "axis"):
            raise _err(src, "output.orientation", "'full', 'axis' (spatial) or 'none'", orient)
        oaxis = None
        if orient == "axis":
            oaxis = _vec(require(ot, "axis", src, "output.", "the tool axis at home"),
                         "dimensionless", 3, src, "output.axis", True)
        elif "axis" in ot:  # "full": the tool axis of `point --tool-length` (not a controlled output)
            if orient != "full" or dim != 3:
                raise _err(src, "output.axis", "a tool axis only with orientation 'full' or 'axis' (spatial)", orient)
            oaxis = _vec(ot["axis"], "dimensionless", 3, src, "output.axis", True)
        cn = ot.get("coordinates", list("xyz"[:dim]))
        if not isinstance(cn, list) or not cn or not all(c in "xyz"[:dim] for c in cn) or len(set(cn)) != len(cn):
            raise _err(src, "output.coordinates", f"a list of distinct names from {list('xyz'[:dim])}", cn)
        output = Output(links.index(ol), opoint, orient, oaxis, tuple("xyz".index(c) for c in cn))
    assumptions = raw.get("assumptions", {})
    if not isinstance(assumptions, dict) or not all(isinstance(v, str) for v in assumptions.values()):
        raise _err(src, "assumptions", "a table of one-line reasons (strings)", assumptions)
    mech = Mechanism(name=name, title=str(mt.get("title", name)), dim=dim, links=tuple(links),
                     ground=tuple(links.index(g) for g in ground), joints=tuple(joints), output=output,
                     assumptions=dict(assumptions), source=str(mt.get("source", "")), path=src)
    check_connected(mech, src)
    check_home(mech, src)
    check_redundancy(mech, src)
    check_mobility(mech, src)
    elastic = parse_elastic(raw, mech, src)
    return mech if elastic is None else replace(mech, elastic=elastic)


def check_connected(mech: Mechanism, src: str = "") -> None:
    """Every link must be joined to the ground through a chain of joints; the error names a joint of the island."""
    adj: dict[int, set[int]] = {i: set() for i in range(len(mech.links))}
    for jt in mech.joints:
        a, b = jt.links
        adj[a].add(b)
        adj[b].add(a)
    seen = set(mech.ground)
    stack = list(mech.ground)
    while stack:
        for nb in adj[stack.pop()]:
            if nb not in seen:
                seen.add(nb)
                stack.append(nb)
    for li, ln in enumerate(mech.links):
        if li not in seen:
            culprit = next((f"joint '{jt.name}' (links {mech.links[jt.links[0]]!r}, {mech.links[jt.links[1]]!r})"
                            for jt in mech.joints if li in jt.links), "no joint")
            raise _err(src, f"mechanism.links ({ln})", "every link connected to the ground by joints",
                       f"link {ln!r} not connected to ground {mech.links[mech.ground[0]]!r}; its joints: {culprit}")


def check_home(mech: Mechanism, src: str = "") -> None:
    """The home configuration (every link frame = world) must satisfy every joint (e.g. Cardan axes ⊥)."""
    from pkmstiff.mechanisms.constraints import System, model_blocks

    for ji, jt in enumerate(mech.joints):
        sysj = System(mech, model_blocks(mech, [ji], ground=False))
        r, _ = sysj.evaluate(np.zeros((1, len(mech.links), mech.dof_per_link)), jac=False)
        if np.abs(r).max(initial=0.0) > 1e-9 * mech.length_scale:
            raise _err(src, f"joint '{jt.name}'", "a joint satisfied at home (all link frames = world frame)",
                       f"residual {np.abs(r).max():.3g}")


def check_redundancy(mech: Mechanism, src: str = "") -> None:
    """Reject over-constrained rigid structures: a joint whose constraints are (partly) redundant at home
    (rank gain < nominal rank, singular-value gap) while its two links end up rigidly connected."""
    from pkmstiff.mechanisms.constraints import System, model_blocks
    from pkmstiff.mechanisms.linalg import numerical_rank

    q0 = np.zeros((1, len(mech.links), mech.dof_per_link))
    d = mech.dof_per_link
    nominal = NOMINAL_RANK[mech.dim]
    types = JOINT_TYPES_3D if mech.dim == 3 else JOINT_TYPES_2D
    order: list[int] = []
    prev = System(mech, model_blocks(mech, [], ground=True))
    rank_prev = numerical_rank(prev.evaluate(q0)[1][0])
    redundant = []
    for ji, jt in enumerate(mech.joints):
        order.append(ji)
        cur = System(mech, model_blocks(mech, order, ground=True))
        rank = numerical_rank(cur.evaluate(q0)[1][0])
        nom = sum(nominal[e] * (len(jt.coordinates) if e == "fixed" else 1) for e in types[jt.type])
        if rank - rank_prev < nom:
            redundant.append((ji, rank - rank_prev, nom))
        rank_prev = rank
    if not redundant:
        return
    J = System(mech, model_blocks(mech)).evaluate(q0)[1][0]
    _, s, vt = np.linalg.svd(J)
    rank = numerical_rank(J)
    Z = vt[rank:].T  # null space (n, mobility)
    for ji, gain, nom in redundant:
        jt = mech.joints[ji]
        a, b = jt.links
        rel = Z[b * d:(b + 1) * d] - Z[a * d:(a + 1) * d]
        if Z.shape[1] == 0 or np.abs(rel).max() < 1e-9:
            raise _err(src, f"joint '{jt.name}'", "constraints that are not redundant (over-constrained rigid "
                       "structure)", f"rank gain {gain} of {nom}: links {mech.links[a]!r} and {mech.links[b]!r} are "
                       "already rigidly connected")


def is_mechanism(name_or_path: str | Path) -> bool:
    """True for a bundled mechanism name or a TOML file with a ``[mechanism]`` table (the dispatch hook for
    commands that take a machine or a mechanism, e.g. ``pkmstiff section``)."""
    p = Path(name_or_path)
    if p.suffix == ".toml" and p.exists():
        try:
            return "mechanism" in read_toml(p, "mechanism file")
        except InputError:
            return False
    return (bundled_mechanism_dir() / f"{name_or_path}.toml").exists()


def check_mobility(mech: Mechanism, src: str = "") -> None:
    """The drives must lock every motion of the mechanism, each a different one: the rank of the model Jacobian
    at home plus the number of drives equals the unknowns, and the drive rows raise the rank one by one.

    Mobility by rank at home rather than by Grübler/Kutzbach (which miscounts overconstrained linkages).  A
    mechanism without drives (described for its structure only) is not checked.  The error names the free motion
    (the largest link coordinates of a null-space vector of model + drive equations) or the drive that locks
    nothing new."""
    from pkmstiff.mechanisms.constraints import System, drive_blocks, model_blocks
    from pkmstiff.mechanisms.linalg import numerical_rank

    nd = len(mech.drives)
    if nd == 0:
        return
    q0 = np.zeros((1, len(mech.links), mech.dof_per_link))
    target = np.array([[j.drive.offset for j in mech.drives]])
    model = model_blocks(mech)
    Jm = System(mech, model).evaluate(q0)[1][0]
    rank = numerical_rank(Jm)
    mobility = Jm.shape[1] - rank
    key = "joints (drives)"
    expected = f"as many drives as the mobility at home ({mobility} = {Jm.shape[1]} unknowns − rank {rank})"
    drives = System(mech, model + drive_blocks(mech))
    Jd = drives.evaluate(q0, target)[1][0]
    row_of = {}  # drive index → its row in the full system
    for b in drives.blocks:
        if b.kind.startswith("drive"):
            for i, c in enumerate(b.coord):
                row_of[int(c)] = b.row0 + i * b.nrows
    rows = list(range(Jm.shape[0]))
    for c in range(nd):
        r_new = numerical_rank(Jd[rows + [row_of[c]]])
        if r_new == numerical_rank(Jd[rows]):
            raise _err(src, key, expected, f"{nd} drives; drive {mech.drive_names[c]!r} locks no motion that "
                       "the model equations and the drives before it leave free")
        rows.append(row_of[c])
    if rank + nd < Jm.shape[1]:
        z = np.linalg.svd(Jd)[2][numerical_rank(Jd)]  # a free motion: null-space vector at home
        d = mech.dof_per_link
        names = [f"link {mech.links[i // d]!r} {COORDINATES[mech.dim][i % d]}" for i in np.argsort(-np.abs(z))[:3]
                 if abs(z[i]) > 1e-3 * np.abs(z).max()]
        raise _err(src, key, expected, f"{nd} drives; {Jm.shape[1] - rank - nd} motion(s) left free, e.g. "
                   f"{', '.join(names)}")
