"""Measurement plans: commanded platform poses plus the instrument set-up (Szatmári §4.3–4.4, Denkena §1.4).

A :class:`Plan` is the minimal object the identification Jacobian needs: an instrument :class:`Setup`, commanded
platform poses (N, 6) (x, y, z [m], a, b, c [rad]) and labelled segments. Builders make ball-bar circles, the
hemisphere path of Szatmári §4.4 (Fig. 4.23) and point/pose sets; :func:`default_plan` chooses the plan a user
would start with per instrument; :func:`read_plan` reads a small TOML plan format (documented in the docs page);
:func:`check_plan` rejects plans with inadmissible poses (listing them with their failing checks) or readings
outside the instrument range.

Orientation convention (docs/theory/calibration.md, Assumption): tilt B (angle of the platform normal z' from the MKS z
axis), azimuth L of the tilt and torsion D about the platform normal: R = R_z(L) R_y(B) R_z(D − L) (a
tilt-and-torsion form without a singularity at B = 0).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pkmstiff.admissibility import evaluate_poses
from pkmstiff.calibration.instruments import Instrument, Setup, instrument, kinds
from pkmstiff.errors import InadmissibleError, InputError
from pkmstiff.io import check_keys, read_toml, require
from pkmstiff.kinematics import as_poses
from pkmstiff.kinematics.rotation import cardan_angles
from pkmstiff.machine import Machine
from pkmstiff.units import parse_quantity

if TYPE_CHECKING:
    from pkmstiff.calibration.setups import PlanSet


@dataclass(frozen=True)
class Segment:
    """A labelled run of consecutive poses of a plan (e.g. one circle); ``kind`` "path" (a continuous path,
    sampled at the instrument's rate when simulated) or "points" (static poses, one reading each)."""

    label: str
    start: int
    stop: int
    kind: str = "path"


@dataclass(frozen=True)
class Plan:
    """Commanded platform poses (N, 6) in SI with an instrument set-up (Szatmári §4.4); ``runs``: further indices
    where a measuring run starts besides the segment starts (the drives' direction of motion is taken per run,
    :mod:`pkmstiff.calibration.backlash`)."""

    name: str
    setup: Setup
    poses: np.ndarray
    segments: tuple[Segment, ...] = field(default=())
    runs: tuple[int, ...] = field(default=())

    @property
    def instrument(self) -> Instrument:
        return self.setup.instrument

    @property
    def n_poses(self) -> int:
        return int(self.poses.shape[0])

    @property
    def n_readings(self) -> int:
        return self.n_poses * self.setup.n_readings

    def concat(self, other: Plan, name: str | None = None) -> Plan:
        """Two plans with the same set-up as one."""
        if not _same_setup(self.setup, other.setup):
            raise InputError(self.name, "setup", "plans with the same instrument set-up", other.name)
        off = self.n_poses
        segs = self.segments + tuple(Segment(s.label, s.start + off, s.stop + off, s.kind) for s in other.segments)
        runs = self.runs + (off,) + tuple(r + off for r in other.runs)
        return Plan(name or f"{self.name} + {other.name}", self.setup, np.vstack([self.poses, other.poses]), segs,
                    runs)


def _same_setup(a: Setup, b: Setup) -> bool:
    return (a.instrument == b.instrument and np.array_equal(a.target, b.target)
            and (a.fixed_ball is None) == (b.fixed_ball is None)
            and (a.fixed_ball is None or np.array_equal(a.fixed_ball, b.fixed_ball)) and a.bar_length == b.bar_length)


# ------------------------------------------------------------------------------------------------- orientations


def tilt_torsion_matrix(B: np.ndarray, L: np.ndarray, D: np.ndarray) -> np.ndarray:
    """R = R_z(L) R_y(B) R_z(D − L) (N, 3, 3): platform normal at polar angle B, azimuth L; torsion D (rad)."""
    B, L, D = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (B, L, D)))

    def rz(t):
        c, s = np.cos(t), np.sin(t)
        R = np.zeros(t.shape + (3, 3))
        R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1], R[..., 2, 2] = c, -s, s, c, 1.0
        return R

    cb, sb = np.cos(B), np.sin(B)
    Ry = np.zeros(B.shape + (3, 3))
    Ry[..., 0, 0], Ry[..., 0, 2], Ry[..., 1, 1], Ry[..., 2, 0], Ry[..., 2, 2] = cb, sb, 1.0, -sb, cb
    return rz(L) @ Ry @ rz(D - L)


def poses_for_target(positions: np.ndarray, R: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Platform poses (N, 6) that put the PKS point ``target`` at ``positions`` (N, 3) with orientations R."""
    o = positions - np.einsum("nij,j->ni", R, target)
    return np.concatenate([o, cardan_angles(R)], axis=1)


# ------------------------------------------------------------------------------------------------------ builders

_PLANES = {"XY": (0, 1), "XZ": (0, 2), "YZ": (1, 2)}


def plane_axes(plane: str | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """In-plane unit vectors (e1, e2) of a circle plane: "XY", "XZ", "YZ" (e1, e2 along the named axes) or a
    normal vector n (e1 = the projection of x, or of y when n ∥ x, onto the plane; e2 = n × e1, so the circle runs
    counter-clockwise about n)."""
    E = np.eye(3)
    if isinstance(plane, str):
        if plane not in _PLANES:
            raise InputError("plan", "plane", "XY, XZ, YZ or a normal vector", plane)
        i, j = _PLANES[plane]
        return E[i], E[j]
    n = np.asarray(plane, dtype=float).reshape(3)
    if not np.linalg.norm(n) > 0:
        raise InputError("plan", "normal", "a non-zero normal vector", n.tolist())
    n = n / np.linalg.norm(n)
    ref = E[0] if abs(n[0]) < 0.9 else E[1]
    e1 = ref - (ref @ n) * n
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1)


def circle_positions(centre: np.ndarray, radius: float, plane: str | np.ndarray, n: int) -> np.ndarray:
    """``n`` points on a circle (counter-clockwise from e1, see :func:`plane_axes`)."""
    e1, e2 = plane_axes(plane)
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    return np.asarray(centre, dtype=float) + radius * (np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2)


def spline_orientations(nodes: np.ndarray, s: np.ndarray, periodic: bool) -> np.ndarray:
    """Orientation schedule (len(s), 3) of B, L, D [rad] from ``nodes`` (k, 3) at equally spaced parameters in
    [0, 1] (periodic: [0, 1) and closed) interpolated by cubic splines (Szatmári §4.4.3: a continuous, smooth
    measuring motion between the optimised orientation nodes). One node: constant; two or three: a spline of
    the highest order they allow. L and D are unwrapped (consecutive nodes, and for a closed path the last and
    the first, differ by at most 180°), so a schedule may turn the tilt azimuth once around a circle."""
    from scipy.interpolate import CubicSpline, make_interp_spline

    nodes = np.atleast_2d(np.asarray(nodes, dtype=float))
    if nodes.ndim != 2 or nodes.shape[1] != 3 or not np.all(np.isfinite(nodes)):
        raise InputError("plan", "nodes", "orientation nodes (k, 3): B, L, D", nodes.shape)
    k = len(nodes)
    if k == 1:
        return np.repeat(nodes, len(s), axis=0)
    if periodic:
        u = np.linspace(0.0, 1.0, k + 1)
        ext = np.vstack([nodes, nodes[:1]])
        ext[:, 1:] = np.unwrap(ext[:, 1:], axis=0)
        wind = ext[-1] - ext[0]  # 2π w for L and D (whole turns), 0 for B
        base = CubicSpline(u, ext - np.outer(u, wind), bc_type="periodic")
        sm = np.mod(s, 1.0)
        return base(sm) + np.outer(sm, wind)
    nodes = nodes.copy()
    nodes[:, 1:] = np.unwrap(nodes[:, 1:], axis=0)
    u = np.linspace(0.0, 1.0, k)
    return make_interp_spline(u, nodes, k=min(3, k - 1))(s)


def circle_plan(setup: Setup, plane: str | np.ndarray = "XY", n: int = 72, centre: np.ndarray | None = None,
                radius: float | None = None, tilt: float = 0.0, tilt_azimuth: float = 0.0, torsion: float = 0.0,
                name: str | None = None, nodes: np.ndarray | None = None) -> Plan:
    """A circle of the target point (ball bar: centred on the fixed ball with the bar length as radius) in a
    named plane or the plane of a normal vector, at a constant orientation (tilt B, azimuth L, torsion D in rad;
    untilted by default, Szatmári Fig. 4.15/4.16) or with a tilt schedule: orientation ``nodes`` (k, 3) of B, L, D
    at k equally spaced circle angles from e1, interpolated by periodic cubic splines."""
    if centre is None:
        if setup.fixed_ball is None:
            raise InputError("plan", "centre", "a circle centre (no fixed ball in the set-up)", None)
        centre = setup.fixed_ball
    radius = setup.bar_length if radius is None else radius
    if radius is None or not radius > 0:
        raise InputError("plan", "radius", "a positive circle radius", radius)
    P = circle_positions(np.asarray(centre, float), float(radius), plane, int(n))
    if nodes is None:
        R = tilt_torsion_matrix(np.full(n, tilt), np.full(n, tilt_azimuth), np.full(n, torsion))
    else:
        BLD = spline_orientations(nodes, np.arange(n) / n, periodic=True)
        R = tilt_torsion_matrix(BLD[:, 0], BLD[:, 1], BLD[:, 2])
    pname = plane if isinstance(plane, str) else "n=(" + ", ".join(f"{v:g}" for v in np.ravel(plane)) + ")"
    label = name or f"circle {pname} r={radius * 1e3:g} mm"
    return Plan(label, setup, poses_for_target(P, R, setup.target), (Segment(label, 0, n),))


def hemisphere_plan(setup: Setup, n: int = 360, turns: float = 4.0, polar: tuple[float, float] = (np.radians(10),
                    np.radians(80)), tilt: float = np.radians(20), torsion: float = np.radians(15),
                    side: float = 1.0, name: str | None = None, nodes: np.ndarray | None = None) -> Plan:
    """Szatmári's hemisphere path (§4.4, Fig. 4.23): the moving ball on a sphere of the bar length about the fixed
    ball, along a spiral from polar angle ``polar[0]`` to ``polar[1]`` (from the pole of the side ``side`` = +1
    above, −1 below the fixed ball) over ``turns`` turns; the platform tilted towards the direction of travel
    (L = azimuth + 90°) by B = ``tilt`` · |sin(2.5 · azimuth)| with a torsion D = ``torsion`` · sin(3 · azimuth)
    (Assumption: this smooth orientation schedule as the default start path; the thesis optimises the orientation
    nodes, issue "Calibration 2"). A constant tilt towards the direction of travel is a poor choice: it leaves the
    combination "platform joints along z' + cos B · base joints along z" unseen (the ball then moves normal to the
    bar), which :func:`pkmstiff.calibration.identifiability.identifiability` reports.

    ``nodes`` (k, 3): orientation nodes B, L, D [rad] (absolute, calibration.md §1 reading) at k equally spaced
    values of the path parameter, interpolated by cubic splines (Szatmári §4.4.3); they replace the default
    schedule. The simulation runs the path at constant feed (:mod:`pkmstiff.calibration.simulation`)."""
    if setup.fixed_ball is None:
        raise InputError("plan", "instrument", "a ball-bar set-up for a hemisphere path",
                                    setup.instrument.kind)
    s = np.linspace(0.0, 1.0, int(n))
    pol = polar[1] + (polar[0] - polar[1]) * s  # from near the equator up to near the pole
    az = 2 * np.pi * turns * s
    dirs = np.c_[np.sin(pol) * np.cos(az), np.sin(pol) * np.sin(az), side * np.cos(pol)]
    P = setup.fixed_ball + setup.bar_length * dirs
    if nodes is None:
        R = tilt_torsion_matrix(tilt * np.abs(np.sin(2.5 * az)), az + np.pi / 2, torsion * np.sin(3 * az))
    else:
        BLD = spline_orientations(nodes, s, periodic=False)
        R = tilt_torsion_matrix(BLD[:, 0], BLD[:, 1], BLD[:, 2])
    label = name or f"hemisphere r={setup.bar_length * 1e3:g} mm"
    return Plan(label, setup, poses_for_target(P, R, setup.target), (Segment(label, 0, int(n)),))


def grid_plan(setup: Setup, centre: np.ndarray, half_width: float, points: int = 3, tilt: float = np.radians(10),
              torsion: float = np.radians(10), name: str | None = None) -> Plan:
    """A tracker or 6-D pose set: a points³ grid of target positions about ``centre`` (± ``half_width``), each at
    three orientations (tilted by ``tilt`` towards 0/120/240° with torsions −D, 0, +D)."""
    g = np.linspace(-half_width, half_width, points)
    X = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3) + np.asarray(centre, float)
    k = np.arange(3)
    P = np.repeat(X, 3, axis=0)
    L = np.tile(np.radians(120.0) * k, len(X))
    D = np.tile(torsion * (k - 1.0), len(X))
    R = tilt_torsion_matrix(np.full(len(P), tilt), L, D)
    label = name or f"grid {points}^3 ±{half_width * 1e3:g} mm"
    return Plan(label, setup, poses_for_target(P, R, setup.target), (Segment(label, 0, len(P), "points"),))


# --------------------------------------------------------------------------------------------------- checking


def _fmt_pose(p: np.ndarray) -> str:
    return ("(" + ", ".join(f"{v * 1e3:.1f}" for v in p[:3]) + " mm, "
            + ", ".join(f"{np.degrees(v):.1f}" for v in p[3:]) + " deg)")


def check_plan(machine: Machine, plan: Plan, max_list: int = 3) -> None:
    """Raise a one-line :class:`InadmissibleError` if a pose of the plan is not admissible on ``machine`` (every
    App. B check; the poses are listed with their failing checks) or a nominal reading lies outside the
    instrument's range."""
    poses = as_poses(plan.poses, f"plan '{plan.name}'")
    ev = evaluate_poses(machine, poses)
    bad = np.flatnonzero(~ev.ok)
    if bad.size:
        items = [f"pose {i + 1} {_fmt_pose(poses[i])}: {', '.join(ev.admissibility.failing(int(i)))}"
                 for i in bad[:max_list]]
        more = f"; ... ({bad.size - max_list} more)" if bad.size > max_list else ""
        raise InadmissibleError(f"plan '{plan.name}': {bad.size} of {len(poses)} poses not admissible on "
                               f"{machine.name}: " + "; ".join(items) + more)
    plan.instrument.check_nominal(machine, plan, poses)


# ------------------------------------------------------------------------------------------- default plans


def workspace_centre(machine: Machine, points: int = 17) -> np.ndarray:
    """The middle of the constant-orientation workspace (m): the admissible point of a grid over the reach box
    farthest from any inadmissible one (the origin if it is admissible and at least 80 % as deep)."""
    from scipy.ndimage import distance_transform_edt

    from pkmstiff.workspace import reach_box

    lo, hi = reach_box(machine)
    axes = [np.linspace(a, b, points) for a, b in zip(lo, hi)]
    X = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    ok = evaluate_poses(machine, np.c_[X, np.zeros((len(X), 3))]).ok.reshape((points,) * 3)
    if not ok.any():
        raise InadmissibleError(f"machine '{machine.name}': no admissible pose at zero orientation on a "
                               f"{points}^3 grid of the reach box: cannot choose a default plan")
    step = (hi - lo) / (points - 1)
    depth = distance_transform_edt(np.pad(ok, 1), sampling=step)[1:-1, 1:-1, 1:-1]
    best = np.unravel_index(np.argmax(depth), depth.shape)
    centre = np.array([axes[k][best[k]] for k in range(3)])
    origin_ok = evaluate_poses(machine, np.zeros((1, 6))).ok[0]
    if origin_ok and np.all((lo < 0) & (hi > 0)):
        idx = tuple(int(np.argmin(np.abs(a))) for a in axes)
        if depth[idx] >= 0.8 * depth.max():
            return np.zeros(3)
    return centre


def default_setup(machine: Machine, kind: Instrument | str, centre: np.ndarray | None = None,
                  bar_length: float = 0.3) -> Setup:
    """The set-up a user starts with: target at the TCP (machine ``[tool]``); ball bar of 300 mm with the fixed
    ball at the workspace centre (Szatmári §5.1: hemisphere of R = 300 mm about the origin of Felix)."""
    c = workspace_centre(machine) if centre is None else np.asarray(centre, float)
    return instrument(kind).default_setup(machine, c, bar_length)


def _admissible(machine: Machine, plan: Plan) -> bool:
    return bool(evaluate_poses(machine, plan.poses).ok.all())


def default_plan(machine: Machine, kind: Instrument | str) -> Plan:
    """The default plan of an instrument (:meth:`~pkmstiff.calibration.instruments.Instrument.default_plans`): the
    first admissible candidate (the candidates reduce tilt and size), e.g.

    * ball bar: Szatmári's tilted hemisphere path of R = 300 mm about the workspace centre (§4.4, §5.1);
    * tracker / pose: a 3×3×3 grid of ±150 mm about the workspace centre, three orientations per point.
    """
    inst = instrument(kind)
    centre = workspace_centre(machine)
    setup = default_setup(machine, inst, centre)
    last = None
    for p in inst.default_plans(machine, centre, setup):
        last = p
        if _admissible(machine, p):
            return p
    check_plan(machine, last)  # raises with the failing poses of the most modest candidate
    return last


# ---------------------------------------------------------------------------------------------- TOML plans

_PLAN_KEYS = {"plan", "setup", "setups", "paths"}
_PLAN_TABLE = {"name", "instrument", "description"}
_SETUP_KEYS = {"target", "fixed_ball", "bar_length", "measuring_range", "max_mount_angle",
               "placed_by_machine"}
_PATH_KEYS = {"circle": {"kind", "label", "plane", "normal", "points", "centre", "radius", "tilt", "tilt_azimuth",
                         "torsion", "nodes"},
              "hemisphere": {"kind", "label", "points", "turns", "polar_min", "polar_max", "tilt", "torsion", "side",
                             "nodes"},
              "grid": {"kind", "label", "centre", "half_width", "points", "tilt", "torsion"},
              "poses": {"kind", "label", "positions", "angles"}}
_KINDS = "circle, hemisphere, grid or poses"


def read_plan(path: str | Path, check: Callable[[int, str], None] | None = None) -> Plan | PlanSet:
    """Read a TOML plan (format in docs/user-guide/calibration-identifiability.md); SI for bare numbers. A plan
    with ``[[setups]]`` tables is a :class:`~pkmstiff.calibration.setups.PlanSet` (its paths built per set-up).
    ``example:NAME`` reads a bundled example plan (:mod:`pkmstiff.calibration.examples`). ``check(poses, key)``
    is called with the running pose count before each path is built (a cost check may refuse it by raising)."""
    from pkmstiff.calibration.examples import resolve

    path = resolve(path)
    src = str(path)
    raw = check_keys(read_toml(path, "plan file"), _PLAN_KEYS, src, "")
    pt = check_keys(require(raw, "plan", src, "", "a [plan] table"), _PLAN_TABLE, src,
                    "plan.")
    inst = instrument(require(pt, "instrument", src, "plan.", f"one of {', '.join(kinds())}"),
                      src, "plan.instrument")
    st = check_keys(raw.get("setup", {}), _SETUP_KEYS, src, "setup.")

    def q(table, key, unit, prefix, default=None, shape=None, positive=False):
        if key not in table:
            if default is None:
                raise InputError(src, prefix + key, f"a value in {unit}", "missing key")
            return default
        try:
            return parse_quantity(table[key], unit, source=src, key=prefix + key, shape=shape, positive=positive)
        except InputError:
            raise
        except ValueError as exc:  # another ValueError (e.g. of numpy): name the key
            raise InputError(getattr(exc, "file", src), getattr(exc, "key", prefix + key),
                                        getattr(exc, "expected", f"a value in {unit}"),
                                        getattr(exc, "found", table[key])) from None

    def count(table: dict, key: str, prefix: str, default: float) -> int:
        """A whole positive number of points (2.5 points is a typo, not a plan)."""
        v = q(table, key, "dimensionless", prefix, default, positive=True)
        if v != int(v):
            raise InputError(src, prefix + key, "a whole number of points", table[key])
        return int(v)

    setups = _setups(raw, st, inst, q, src)
    plans = [_paths(raw, setup, q, count, check, src, str(pt.get("name", Path(src).stem))) for setup in setups]
    if len(plans) == 1:
        return plans[0]
    from pkmstiff.calibration.setups import PlanSet

    return PlanSet(plans[0].name, tuple(Plan(f"{p.name}, set-up {k + 1}", p.setup, p.poses, p.segments)
                                        for k, p in enumerate(plans)))


def _setups(raw: dict, st: dict, inst: Instrument, q: Callable, src: str) -> list[Setup]:
    """The ``[setup]`` table, or one set-up per ``[[setups]]`` table (its keys override ``[setup]``'s; issue 26:
    several fixed-ball positions, bar lengths, ball offsets or tracker stations in one plan)."""
    tables = raw.get("setups")
    if tables is None:
        items = [(st, "setup.")]
    elif not isinstance(tables, list) or not tables or not all(isinstance(t, dict) for t in tables):
        raise InputError(src, "setups", "[[setups]] tables (keys of [setup] that change per set-up)", tables)
    else:
        items = [({**st, **check_keys(t, _SETUP_KEYS, src, f"setups[{i + 1}].")}, f"setups[{i + 1}].")
                 for i, t in enumerate(tables)]
    out = []
    for table, pre in items:
        def qk(tab, key, unit, prefix, *a, _pre=pre, **kw):
            return q(tab, key, unit, _pre, *a, **kw)

        setup = inst.setup_from_toml(table, qk, qk(table, "target", "m", pre, np.zeros(3), (3,)))
        placed = table.get("placed_by_machine", False)
        if not isinstance(placed, bool):
            raise InputError(src, pre + "placed_by_machine", "true or false", placed)
        if placed:
            if setup.fixed_ball is None:
                raise InputError(src, pre + "placed_by_machine", "a ball-bar set-up (a fixed ball)", inst.kind)
            place = poses_for_target(setup.fixed_ball[None, :], np.eye(3)[None], setup.target)[0]
            setup = dataclasses.replace(setup, placing_pose=place)
        out.append(setup)
    return out


def _paths(raw: dict, setup: Setup, q: Callable, count: Callable, check: Callable | None, src: str,
           name: str) -> Plan:
    """The ``[[paths]]`` of a plan file built for one set-up."""
    paths = raw.get("paths")
    if not isinstance(paths, list) or not paths:
        raise InputError(src, "paths", "at least one [[paths]] table", paths)
    plan: Plan | None = None
    total = 0
    for i, p in enumerate(paths):
        pre = f"paths[{i + 1}]."
        kind = require(p, "kind", src, pre, _KINDS) if isinstance(p, dict) else None
        if kind not in _PATH_KEYS:
            raise InputError(src, pre + "kind", _KINDS, kind)
        check_keys(p, _PATH_KEYS[kind], src, pre)
        label = p.get("label")
        nodes = q(p, "nodes", "rad", pre, shape=(None, 3)) if "nodes" in p else None
        if nodes is not None and len(nodes) < 1:
            raise InputError(src, pre + "nodes", "at least one [B, L, D] node", "an empty list")
        if check is not None:
            check(total + _path_poses(kind, p, q, pre), f"{src}: {pre}points")
        if kind == "circle":
            n = count(p, "points", pre, 72.0)
            if "normal" in p and "plane" in p:
                raise InputError(src, pre + "normal", "either plane or normal", "both")
            plane = q(p, "normal", "dimensionless", pre, shape=(3,)) if "normal" in p else str(p.get("plane", "XY"))
            if not isinstance(plane, str) and not np.linalg.norm(plane) > 0:
                raise InputError(src, pre + "normal", "a non-zero normal vector", plane.tolist())
            if isinstance(plane, str) and plane not in _PLANES:
                raise InputError(src, pre + "plane", "XY, XZ or YZ (or a normal vector)", plane)
            part = circle_plan(setup, plane=plane, n=n, nodes=nodes,
                               centre=q(p, "centre", "m", pre, setup.fixed_ball, (3,)),
                               radius=q(p, "radius", "m", pre, setup.bar_length, positive=True),
                               tilt=q(p, "tilt", "rad", pre, 0.0), tilt_azimuth=q(p, "tilt_azimuth", "rad", pre, 0.0),
                               torsion=q(p, "torsion", "rad", pre, 0.0), name=label)
        elif kind == "hemisphere":
            part = hemisphere_plan(setup, n=count(p, "points", pre, 360.0),
                                   turns=q(p, "turns", "dimensionless", pre, 4.0, positive=True),
                                   polar=(q(p, "polar_min", "rad", pre, np.radians(10)),
                                          q(p, "polar_max", "rad", pre, np.radians(80))),
                                   tilt=q(p, "tilt", "rad", pre, np.radians(20)),
                                   torsion=q(p, "torsion", "rad", pre, np.radians(15)),
                                   side=q(p, "side", "dimensionless", pre, 1.0), name=label, nodes=nodes)
        elif kind == "grid":
            part = grid_plan(setup, q(p, "centre", "m", pre, setup.fixed_ball if setup.fixed_ball is not None
                                      else np.zeros(3), (3,)),
                             q(p, "half_width", "m", pre, positive=True),
                             points=count(p, "points", pre, 3.0),
                             tilt=q(p, "tilt", "rad", pre, np.radians(10)),
                             torsion=q(p, "torsion", "rad", pre, np.radians(10)), name=label)
        else:
            pos = q(p, "positions", "m", pre, shape=(None, 3))
            ang = q(p, "angles", "rad", pre, np.zeros_like(pos), shape=(None, 3))
            if ang.shape != pos.shape:
                raise InputError(src, pre + "angles", f"{len(pos)} rows like positions",
                                            f"{len(ang)} rows")
            lab = label or f"poses ({len(pos)})"
            part = Plan(lab, setup, np.c_[pos, ang], (Segment(lab, 0, len(pos), "points"),))
        plan = part if plan is None else plan.concat(part)
        total = plan.n_poses
    assert plan is not None
    return Plan(name, setup, plan.poses, plan.segments)


def _path_poses(kind: str, p: dict, q: Callable, pre: str) -> int:
    """Poses a plan path will hold, from its keys alone (before building it)."""
    if kind == "grid":
        return int(q(p, "points", "dimensionless", pre, 3.0, positive=True)) ** 3
    if kind in ("circle", "hemisphere"):
        return int(q(p, "points", "dimensionless", pre, 72.0 if kind == "circle" else 360.0, positive=True))
    return len(p.get("positions", ()))


__all__: Sequence[str] = (
    "Plan",
    "Segment",
    "check_plan",
    "circle_plan",
    "default_plan",
    "default_setup",
    "grid_plan",
    "hemisphere_plan",
    "plane_axes",
    "poses_for_target",
    "read_plan",
    "spline_orientations",
    "tilt_torsion_matrix",
    "workspace_centre",
)
