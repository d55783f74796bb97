"""The measuring program of a ball-bar plan: runs with feed-in and feed-out arcs, their timing, and the G-code
(NC program) that puts them on the machine (issue 26 item 2). :mod:`pkmstiff.calibration.raw_import` maps raw
ball-bar samples onto the same runs.

**A run** (one path segment of the plan in one direction; ``cw`` is the path reversed, starting where ``ccw``
started, as :func:`pkmstiff.calibration.simulation.sample_plan`) is a polyline of TCP points (the moving-ball centre,
MKS) with the platform's Cardan angles A B C:

1. feed-in arc: the great circle about the fixed ball that runs into the path's first point along its tangent,
   first ``approach`` long at radius r − ``depth`` (the bar shortened by ``depth``; the machine accelerates here),
   then a ``ramp`` long, over which the radius grows linearly to r (the synchronisation signature);
2. the path: the plan's poses (nodes, kept exactly) and between them points on the sphere (radius interpolated)
   with slerped orientations, so close that a chord leaves the sphere by at most ``chord`` (sagitta
   step²/(8 r));
3. overshoot: the great circle continued from the path's last point along its tangent at radius r, ``overshoot``
   long; then the feed-out arc, the mirror of the feed-in: a ``ramp`` down to r − ``depth`` and ``approach`` at
   r − ``depth`` (deceleration). The orientation is held at the first / last pose on these arcs.

**Timing (Assumption: constant feed).** The controller moves the TCP along the polyline at the programmed path
feed F from the start of the feed-in ramp to the end of the feed-out ramp (look-ahead without stops at the program
points, X Y Z and A B C interpolated linearly between them); acceleration and deceleration take place on the
``approach`` parts at r − ``depth`` (choose ``approach`` ≥ F²/(2 a_max)), which the synchronisation does not use.
A sample at time τ after the start of the feed-in arc is at arc length s = F τ.

**Dialect (Assumption: generic ISO 6983 / DIN 66025).** ``G90 G21 G94``; ``G01 X Y Z A B C F`` with X Y Z the
TCP in mm in the machine frame (set the controller's tool offset to the ball offset, printed in the header), A B C
the platform orientation in degrees in the machine file's convention R = R_x(A) R_y(B) R_z(C) (pkmstiff's Cardan
angles, unwrapped along a run so that the controller never turns the long way), F in mm/min; ``G04 P`` dwell in s;
comments in parentheses. Values are written with 6 decimals (1e-6 mm, 1e-6 deg), and the runs are rounded to them
when built, so that the program, the runs the import uses and the runs the raw simulation drives are one and the
same. Lines ``(run …)``, ``(path start)``, ``(path end)`` and ``(node k)`` mark what :func:`parse_program` reads
back.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from pkmstiff.calibration.instruments import BALL_BAR
from pkmstiff.calibration.plans import Plan, Segment, poses_for_target
from pkmstiff.errors import InputError
from pkmstiff.kinematics.rotation import cardan_angles, cardan_matrix

#: decimals of mm and deg in the program (1e-6 mm, 1e-6 deg)
DECIMALS = 6


@dataclass(frozen=True)
class NCOptions:
    """How the measuring runs are programmed (SI): path ``feed`` [m/s] of the TCP, ``directions``, feed-in/out
    ``depth`` δ [m] (bar shortening at their ends), ``approach`` [m] (part at r − δ), ``ramp`` [m] (radius ramp),
    ``overshoot`` [m], ``dwell`` [s] (G04 before and after each run) and ``chord`` [m] (largest sagitta of a
    program chord on the path); module docstring."""

    feed: float = 500.0 / 60e3
    directions: tuple[str, ...] = ("ccw", "cw")
    depth: float = 0.5e-3
    approach: float = 5e-3
    ramp: float = 2e-3
    overshoot: float = 2e-3
    dwell: float = 1.0
    chord: float = 1e-6

    def __post_init__(self) -> None:
        for key in ("feed", "depth", "approach", "ramp", "chord"):
            if not getattr(self, key) > 0:
                raise InputError("NC program", key, "a positive number", getattr(self, key))
        for key in ("overshoot", "dwell"):
            if not getattr(self, key) >= 0:
                raise InputError("NC program", key, "a non-negative number", getattr(self, key))
        if not self.directions or any(d not in ("ccw", "cw") for d in self.directions):
            raise InputError("NC program", "directions", "ccw and/or cw", ",".join(self.directions))

    def describe(self) -> str:
        return (f"feed {self.feed * 60e3:g} mm/min; feed-in {self.approach * 1e3:g} mm at -{self.depth * 1e3:g} mm, "
                f"then a {self.ramp * 1e3:g} mm ramp; overshoot {self.overshoot * 1e3:g} mm; feed-out the mirror; "
                f"dwell {self.dwell:g} s; chord {self.chord * 1e6:g} um")


@dataclass(frozen=True)
class Run:
    """One programmed run (SI): TCP points ``tcp`` (M, 3) [m] and Cardan angles ``angles`` (M, 3) [rad]
    (unwrapped), the point indices ``path`` = (first, last) of the measured path, ``nodes`` the point indices of
    the plan's poses and ``node_ids`` their pose indices in the plan, ``feed`` [m/s]."""

    number: int
    segment: int
    label: str
    direction: str
    tcp: np.ndarray
    angles: np.ndarray
    path: tuple[int, int]
    nodes: np.ndarray
    node_ids: np.ndarray
    feed: float
    s: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "s", np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(self.tcp, axis=0), axis=1))])

    @property
    def length(self) -> float:
        """Arc length of the whole run (m)."""
        return float(self.s[-1])

    @property
    def path_times(self) -> tuple[float, float]:
        """Times (s) after the start of the feed-in arc at which the TCP passes the path's first and last point."""
        return float(self.s[self.path[0]] / self.feed), float(self.s[self.path[1]] / self.feed)

    @property
    def duration(self) -> float:
        """Time (s) from the start of the feed-in arc to the end of the feed-out arc."""
        return self.length / self.feed

    def at(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """TCP (N, 3) [m] and angles (N, 3) [rad] at times ``tau`` (s) after the start of the feed-in arc (constant
        feed; held at the ends before and after the motion)."""
        s = np.clip(np.asarray(tau, dtype=float) * self.feed, 0.0, self.length)
        k = np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.s) - 2)
        ds = self.s[k + 1] - self.s[k]
        w = np.divide(s - self.s[k], ds, out=np.zeros_like(s), where=ds > 0)[:, None]
        return (self.tcp[k] + w * (self.tcp[k + 1] - self.tcp[k]),
                self.angles[k] + w * (self.angles[k + 1] - self.angles[k]))

    def poses(self, tau: np.ndarray, target: np.ndarray) -> np.ndarray:
        """Commanded platform poses (N, 6) at times ``tau``: o = TCP − R v (v the ball offset in the PKS)."""
        P, A = self.at(tau)
        R = cardan_matrix(A[:, 0], A[:, 1], A[:, 2])
        return np.concatenate([P - np.einsum("nij,j->ni", R, target), A], axis=1)

    def nominal_reading(self, tau: np.ndarray, fixed_ball: np.ndarray, bar_length: float) -> np.ndarray:
        """Deviation (m) the nominal machine shows at times ``tau``: |TCP − fixed ball| − bar length."""
        P, _ = self.at(tau)
        return np.linalg.norm(P - fixed_ball, axis=1) - bar_length


def _round(v: np.ndarray, unit: float) -> np.ndarray:
    return np.round(v / unit, DECIMALS) * unit


def _great_circle(c: np.ndarray, p: np.ndarray, tangent: np.ndarray, theta: np.ndarray,
                  radius: np.ndarray) -> np.ndarray:
    """Points c + ρ (cos θ u + sin θ t) of the great circle through ``p`` (about ``c``) along ``tangent``."""
    u = (p - c) / np.linalg.norm(p - c)
    t = tangent - (tangent @ u) * u
    t /= np.linalg.norm(t)
    return c + radius[:, None] * (np.cos(theta)[:, None] * u + np.sin(theta)[:, None] * t)


def _arc(r: float, lengths: list[tuple[float, float, float]], step: float) -> tuple[np.ndarray, ...]:
    """θ (rad) and radius ρ (m) along consecutive pieces (length m, radius at start, radius at end) of a great
    circle of radius ≈ r, points at most ``step`` apart, from 0."""
    th, rho, t0 = [np.zeros(1)], [np.array([lengths[0][1]])], 0.0
    for length, r0, r1 in lengths:
        if length <= 0:
            continue
        n = max(1, math.ceil(length / step))
        w = np.arange(1, n + 1) / n
        th.append(t0 + w * length / r)
        rho.append(r0 + w * (r1 - r0))
        t0 += length / r
    return np.concatenate(th), np.concatenate(rho)


def _dense_path(plan: Plan, x: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (M, 3), rotations (M, 3, 3) and node indices of the path through the poses ``x`` with at most
    ``step`` between points (positions back on the sphere, orientations slerped)."""
    st = plan.setup
    R = cardan_matrix(x[:, 3], x[:, 4], x[:, 5])
    P = x[:, :3] + np.einsum("nij,j->ni", R, st.target)
    ds = np.linalg.norm(np.diff(P, axis=0), axis=1)
    n = np.maximum(1, np.ceil(ds / step).astype(int))
    k = np.repeat(np.arange(len(ds)), n)
    w = np.concatenate([np.arange(m) / m for m in n])
    k, w = np.r_[k, len(P) - 2], np.r_[w, 1.0]
    Pq = st.instrument.project_path(st, P, P[k] + w[:, None] * (P[k + 1] - P[k]), k, w)
    rot = Rotation.from_matrix(R)
    rel = (rot[k].inv() * rot[k + 1]).as_rotvec()
    Rq = (rot[k] * Rotation.from_rotvec(rel * w[:, None])).as_matrix()
    nodes = np.r_[0, np.cumsum(n)]
    Pq[nodes], Rq[nodes] = P, R  # the nodes exactly
    return Pq, Rq, nodes


def _closed(P: np.ndarray) -> bool:
    from pkmstiff.calibration.simulation import _is_closed

    return _is_closed(P)


def run_order(plan: Plan, seg: Segment, direction: str) -> np.ndarray:
    """Plan pose indices of ``seg`` in the order a run in ``direction`` visits them: ``cw`` reversed, a closed
    path (first and last TCP 1 µm apart or less) closed by its first point (module docstring)."""
    ids = np.arange(seg.start, seg.stop)
    x = plan.poses[ids]
    Rn = cardan_matrix(x[:, 3], x[:, 4], x[:, 5])
    closed = _closed(x[:, :3] + np.einsum("nij,j->ni", Rn, plan.setup.target))
    order = ids if direction == "ccw" else ids[::-1]
    if closed and direction == "cw":
        order = np.roll(order, 1)
    return np.r_[order, order[0]] if closed else order


def programmed_plan(plan: Plan, directions: tuple[str, ...] = NCOptions.directions) -> Plan:
    """The plan as its NC program runs it: every path segment once per direction, in the order of
    :func:`run_order`, each run a segment of its own (so the drives' directions of motion, and with them the
    backlash columns, are those of the runs); point segments unchanged."""
    segs, idx = [], []
    for seg in plan.segments or (Segment(plan.name, 0, plan.n_poses),):
        dirs = directions if seg.kind == "path" else ("ccw",)
        for d in dirs:
            order = run_order(plan, seg, d) if seg.kind == "path" else np.arange(seg.start, seg.stop)
            label = f"{seg.label} {d}" if seg.kind == "path" else seg.label
            segs.append(Segment(label, len(idx), len(idx) + len(order), seg.kind))
            idx.extend(order.tolist())
    return Plan(plan.name, plan.setup, plan.poses[np.array(idx, dtype=int)], tuple(segs))


def program_runs(plan: Plan, options: NCOptions | None = None) -> list[Run]:
    """The runs of a ball-bar plan's path segments, each in every direction of ``options`` (module docstring),
    rounded to the program's decimals."""
    opts = options or NCOptions()
    if plan.instrument != BALL_BAR:
        raise InputError(plan.name, "plan.instrument", "a ball-bar plan (the NC program's feed-in arcs are the "
                                    "ball bar's synchronisation signature)", plan.instrument.kind)
    st = plan.setup
    c, r = st.fixed_ball, float(st.bar_length)
    rng = st.measuring_range or 1e-3
    if opts.depth >= rng:
        raise InputError("NC program", "depth", f"less than the measuring range {rng * 1e3:g} mm",
                         f"{opts.depth * 1e3:g} mm")
    step = math.sqrt(8.0 * r * opts.chord)
    runs: list[Run] = []
    for j, seg in enumerate(plan.segments or ()):
        if seg.kind != "path":
            raise InputError(plan.name, f"segment '{seg.label}'", "measuring paths (a ball-bar plan)", seg.kind)
        for d in opts.directions:
            order = run_order(plan, seg, d)
            xs = plan.poses[order]
            P, R, nodes = _dense_path(plan, xs, step)
            tin = P[1] - P[0]
            tout = P[-1] - P[-2]
            low = r - opts.depth
            th, rho = _arc(r, [(opts.ramp, r, low), (opts.approach, low, low)], step)
            fin = _great_circle(c, P[0], -tin, th[::-1], rho[::-1])[:-1]  # backwards from the path start
            th, rho = _arc(r, [(opts.overshoot, r, r), (opts.ramp, r, low), (opts.approach, low, low)], step)
            fout = _great_circle(c, P[-1], tout, th, rho)[1:]
            ang = np.unwrap(np.concatenate([np.repeat(cardan_angles(R[:1]), len(fin), 0), cardan_angles(R),
                                            np.repeat(cardan_angles(R[-1:]), len(fout), 0)]), axis=0)
            tcp = np.concatenate([fin, P, fout])
            first = len(fin)
            runs.append(Run(len(runs) + 1, j, seg.label, d, _round(tcp, 1e-3), _round(ang, math.pi / 180),
                            (first, first + len(P) - 1), first + nodes, order, opts.feed))
    if not runs:
        raise InputError(plan.name, "segments", "at least one measuring path", 0)
    return runs


# --------------------------------------------------------------------------------------------------- G-code


def _word(letter: str, v: np.ndarray) -> np.ndarray:
    return np.char.add(letter, np.char.mod(f"%.{DECIMALS}f", np.round(v, DECIMALS) + 0.0))  # no "-0.000000"


def program_text(plan: Plan, runs: list[Run], options: NCOptions, machine: str) -> str:
    """The G-code of ``runs`` (module docstring: dialect and markers)."""
    st = plan.setup
    mm = ", ".join(f"{v * 1e3:g}" for v in st.target)
    fb = ", ".join(f"{v * 1e3:g}" for v in st.fixed_ball)
    out = ["%", f"(pkmstiff ball-bar measuring program: plan '{plan.name}', machine {machine})",
           ("(dialect: ISO 6983 / DIN 66025 - G90 absolute, G21 mm, G94 mm/min; G01 interpolates X Y Z A B C "
           "linearly; G04 P dwell in s)"),
           (f"(X Y Z: TCP = moving-ball centre, mm, machine frame; controller tool offset = ball offset {mm} mm in "
           "the platform frame)"),
           "(A B C: platform orientation, deg, R = Rx(A) Ry(B) Rz(C) as in the machine file)",
           f"(fixed ball {fb} mm; bar length {st.bar_length * 1e3:g} mm)",
           f"({options.describe()})",
           "G90 G21 G94"]
    F = f"F{options.feed * 60e3:.{DECIMALS}f}"
    for run in runs:
        P = run.tcp / 1e-3
        A = np.degrees(run.angles)
        words = _word("X", P[:, 0])
        for letter, v in (("Y", P[:, 1]), ("Z", P[:, 2]), ("A", A[:, 0]), ("B", A[:, 1]), ("C", A[:, 2])):
            words = np.char.add(np.char.add(words, " "), _word(letter, v))
        lines = np.char.add("G01 ", words).astype(object)
        lines[0] = lines[0] + " " + F
        lines[run.nodes] = [f"{ln} (node {int(i) + 1})" for ln, i in zip(lines[run.nodes], run.node_ids)]
        out.append(f"(run {run.number}: segment {run.segment + 1} '{run.label}' {run.direction})")
        out.append(str(lines[0]))
        out.append(f"G04 P{options.dwell:g}")
        out += [str(v) for v in lines[1:run.path[0]]]
        out.append("(path start)")
        out += [str(v) for v in lines[run.path[0]:run.path[1] + 1]]
        out.append("(path end)")
        out += [str(v) for v in lines[run.path[1] + 1:]]
        out.append(f"G04 P{options.dwell:g}")
        out.append(f"(end of run {run.number})")
    out += ["M30", "%"]
    return "\n".join(out) + "\n"


_RUN = re.compile(r"^\(run (\d+): segment (\d+) '(.*)' (ccw|cw)\)$")
_NODE = re.compile(r"\(node (\d+)\)")
_WORD = re.compile(r"([XYZABCF])(-?\d+(?:\.\d*)?)")


def parse_program(text: str, source: str = "NC program") -> list[Run]:
    """The runs of a program written by :func:`program_text` (SI); anything else is a one-line error naming the
    line."""
    runs: list[Run] = []
    cur: dict | None = None
    feed = None
    for no, raw in enumerate(text.splitlines(), start=1):
        ln = raw.strip()
        m = _RUN.match(ln)
        if m:
            cur = {"number": int(m[1]), "segment": int(m[2]) - 1, "label": m[3], "direction": m[4], "pts": [],
                   "nodes": [], "ids": [], "path": [None, None]}
            continue
        if cur is None or not ln:
            continue
        if ln == "(path start)":
            cur["path"][0] = len(cur["pts"])
        elif ln == "(path end)":
            cur["path"][1] = len(cur["pts"]) - 1
        elif ln.startswith("(end of run"):
            if None in cur["path"]:
                raise InputError(source, line=no, reason="run without '(path start)' / '(path end)' markers")
            pts = np.array(cur["pts"])
            runs.append(Run(cur["number"], cur["segment"], cur["label"], cur["direction"], pts[:, :3] * 1e-3,
                            np.radians(pts[:, 3:]), tuple(cur["path"]), np.array(cur["nodes"], dtype=int),
                            np.array(cur["ids"], dtype=int), feed))
            cur = None
        elif ln.startswith("G01"):
            words = dict(_WORD.findall(ln.split("(")[0]))
            if any(k not in words for k in "XYZABC"):
                raise InputError(source, line=no, reason=f"expected G01 with X Y Z A B C, found {ln[:60]!r}")
            if "F" in words:
                feed = float(words["F"]) / 60e3
            if feed is None:
                raise InputError(source, line=no, reason="expected a feed F before the first move")
            n = _NODE.search(ln)
            if n:
                cur["nodes"].append(len(cur["pts"]))
                cur["ids"].append(int(n[1]) - 1)
            cur["pts"].append([float(words[k]) for k in "XYZABC"])
    if not runs:
        raise InputError(source, reason="expected runs '(run k: segment j 'label' ccw|cw)', found none")
    return runs


def node_poses(run: Run, target: np.ndarray) -> np.ndarray:
    """The platform poses (k, 6) of the plan's nodes of a run (o = TCP − R v)."""
    A = run.angles[run.nodes]
    R = cardan_matrix(A[:, 0], A[:, 1], A[:, 2])
    return poses_for_target(run.tcp[run.nodes], R, target)


__all__ = ["NCOptions", "Run", "node_poses", "parse_program", "program_runs", "program_text"]
