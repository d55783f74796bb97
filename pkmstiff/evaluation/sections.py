"""Workspace sections (docs/theory/workspace.md): quantities on a rastered plane, masked by admissibility.

A section is a plane through the workspace given by an origin and two orthonormal in-plane axes (YZ, XZ, XY or
any plane), a raster (u, v values) and a fixed tool orientation and tool length. The raster points are the
positions of O' (the pose's position); tool-dependent quantities (TCP stiffness) use the tool length. Every
raster point is checked for admissibility; quantities are evaluated only at admissible points and are NaN
elsewhere, where the reason code says why.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

import numpy as np

from pkmstiff.admissibility.checks import (
    ALL_CHECKS,
    NEAR_SINGULAR_FRACTION,
    Reason,
    checks_left_out,
    near_singular_limit,
)
from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.errors import ArgumentError
from pkmstiff.evaluation import parallel, result_files
from pkmstiff.evaluation.progress import callback as progress_callback
from pkmstiff.evaluation.quantities import EvalContext, get_quantity
from pkmstiff.machine.frames import frame_metadata, frame_origin
from pkmstiff.machine.model import Machine

#: quantiles of the section statistics (linear interpolation between order statistics, numpy's default)
QUANTILES = (0.01, 0.05, 0.95, 0.99)
QUANTILE_KEYS = ("p1", "p5", "p95", "p99")

AXES = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}




@dataclass(frozen=True)
class Plane:
    """A section plane: points origin + u * u_axis + v * v_axis (m), u and v on a regular raster."""

    origin: np.ndarray  # (3,) m
    u_axis: np.ndarray  # (3,) unit
    v_axis: np.ndarray  # (3,) unit, orthogonal to u_axis
    u_values: np.ndarray  # (nu,) m
    v_values: np.ndarray  # (nv,) m
    u_name: str = "u"
    v_name: str = "v"
    name: str = "plane"

    def __post_init__(self) -> None:
        for key in ("u_axis", "v_axis"):
            a = np.asarray(getattr(self, key), float)
            if a.shape != (3,) or not np.isclose(np.linalg.norm(a), 1.0, atol=1e-9):
                raise ArgumentError(f"plane {key}: expected a unit 3-vector, found {a}")
        if abs(float(np.dot(self.u_axis, self.v_axis))) > 1e-9:
            raise ArgumentError("plane axes must be orthogonal")
        for key in ("u_values", "v_values"):
            vals = np.asarray(getattr(self, key), float)
            if vals.ndim != 1 or vals.size < 2 or not np.all(np.diff(vals) > 0):
                raise ArgumentError(f"plane {key}: expected at least 2 increasing values, found {vals}")

    @property
    def shape(self) -> tuple[int, int]:
        """(nv, nu): rows along v, columns along u."""
        return (len(self.v_values), len(self.u_values))

    @property
    def normal(self) -> np.ndarray:
        return np.cross(self.u_axis, self.v_axis)

    @property
    def size(self) -> int:
        """Number of raster points nv * nu."""
        return len(self.v_values) * len(self.u_values)

    def points(self, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Raster points ``start`` … ``stop`` - 1 (default all, (nv * nu, 3)) in m, row-major: index = iv * nu + iu.
        A range is computed alone (a worker makes its own points) and gives the same bytes as those rows of all."""
        idx = np.arange(start, self.size if stop is None else stop)
        nu = len(self.u_values)
        uu, vv = self.u_values[idx % nu], self.v_values[idx // nu]
        return self.origin + uu.reshape(-1, 1) * self.u_axis + vv.reshape(-1, 1) * self.v_axis

    @property
    def cell_area(self) -> float:
        """Area represented by one raster point (m²) for a regular raster."""
        du = float(np.mean(np.diff(self.u_values)))
        dv = float(np.mean(np.diff(self.v_values)))
        return du * dv

    def metadata(self) -> dict[str, Any]:
        return {"plane": self.name, "origin_m": self.origin.tolist(), "u_axis": self.u_axis.tolist(),
                "v_axis": self.v_axis.tolist(), "u_name": self.u_name, "v_name": self.v_name,
                "u_range_m": [float(self.u_values[0]), float(self.u_values[-1])],
                "v_range_m": [float(self.v_values[0]), float(self.v_values[-1])],
                "shape_nv_nu": list(self.shape)}


def raster_count(lo: float, hi: float, step: float) -> int:
    """Number of raster values lo, lo + step, … ≤ hi (a step that lands on hi within 1e-9 steps counts)."""
    return int(np.floor((hi - lo) / step + 1e-9)) + 1


def raster(lo: float, hi: float, step: float) -> np.ndarray:
    """The raster values of :func:`raster_count` (the one raster of sections, mechanisms and rotation maps)."""
    if not (hi > lo and step > 0):
        raise ArgumentError(f"range {lo}:{hi} with step {step}: expected lo < hi and step > 0")
    return lo + step * np.arange(raster_count(lo, hi, step))


def axis_plane(kind: str, at: float, u_range: tuple[float, float], v_range: tuple[float, float],
               step: float | tuple[float, float]) -> Plane:
    """Plane 'yz' (x = at), 'xz' (y = at) or 'xy' (z = at); ranges and step in m.

    The in-plane axes are the two named axes in order, e.g. 'yz': u = y, v = z.
    """
    kind = kind.lower()
    if kind not in ("yz", "xz", "xy"):
        raise ArgumentError(option="plane", expected="'yz', 'xz' or 'xy'", found=kind)
    su, sv = (step, step) if np.isscalar(step) else step
    normal_axis = ({"x", "y", "z"} - set(kind)).pop()
    origin = AXES[normal_axis] * at
    return Plane(origin=origin, u_axis=AXES[kind[0]], v_axis=AXES[kind[1]], u_values=raster(*u_range, su),
                 v_values=raster(*v_range, sv), u_name=kind[0], v_name=kind[1],
                 name=f"{kind.upper()} plane at {normal_axis} = {at * 1e3:g} mm")


def general_plane(origin, u_axis, v_axis, u_range, v_range, step, name="plane") -> Plane:
    """Any plane by origin and two in-plane axes (normalised; v is orthogonalised against u)."""
    u = np.asarray(u_axis, float)
    u = u / np.linalg.norm(u)
    v = np.asarray(v_axis, float)
    v = v - np.dot(v, u) * u
    if np.linalg.norm(v) < 1e-9:
        raise ArgumentError("plane axes must not be parallel")
    v = v / np.linalg.norm(v)
    su, sv = (step, step) if np.isscalar(step) else step
    return Plane(np.asarray(origin, float), u, v, raster(*u_range, su), raster(*v_range, sv), name=name)


@dataclass
class SectionResult:
    """Values of quantities on a plane (SI, NaN where inadmissible) with admissibility and metadata."""

    machine: str
    plane: Plane
    orientation: np.ndarray  # (3,) rad
    tool_length: float | None  # m
    values: dict[str, np.ndarray]  # name -> (nv, nu) SI
    units: dict[str, str]  # name -> display unit
    si_units: dict[str, str]
    labels: dict[str, str]
    ok: np.ndarray  # (nv, nu) bool
    reasons: np.ndarray  # (nv, nu) uint32
    settings: dict[str, Any] = field(default_factory=dict)
    frame: dict[str, Any] = field(default_factory=lambda: {"frame": "machine", "frame_origin_mm": [0.0, 0.0, 0.0]})
    #: how the points were split over workers (:mod:`pkmstiff.evaluation.parallel`); not part of the written results
    plan: parallel.Plan | None = None
    kappa: np.ndarray | None = None  # (nv, nu) κ of the admissible points (NaN elsewhere); None: not computed

    @property
    def near_singular(self) -> np.ndarray:
        """(nv, nu) bool: admissible points with κ above ``settings["near_singular_kappa"]`` (the singularity margin,
        :data:`pkmstiff.admissibility.checks.NEAR_SINGULAR_FRACTION` of the machine's threshold)."""
        limit = self.settings.get("near_singular_kappa")
        if self.kappa is None or limit is None:
            return np.zeros(self.ok.shape, bool)
        with np.errstate(invalid="ignore"):
            return self.ok & (self.kappa > limit)

    def display(self, name: str) -> np.ndarray:
        """Values of ``name`` in its display unit."""
        return get_quantity(name).to_display(self.values[name])

    def statistics(self) -> dict[str, dict[str, float]]:
        """Per quantity over the admissible points: min, the 1 %, 5 %, 95 % and 99 % quantiles (p1, p5, p95, p99),
        mean, max (display unit), count, the near-singular points among them (:attr:`near_singular`), admissible
        points and area (m²). Min and max are often set by near-singular points; the quantiles are not (unless more
        than 1 % or 5 % of the points are near-singular)."""
        area = float(self.ok.sum()) * self.plane.cell_area
        near = self.near_singular
        out = {}
        for name in self.values:
            vals = self.display(name)
            finite = self.ok & np.isfinite(vals)
            d = vals[finite]
            q = np.quantile(d, QUANTILES) if d.size else np.full(len(QUANTILES), np.nan)
            out[name] = {"unit": self.units[name], "min": float(d.min()) if d.size else float("nan"),
                         **{key: float(v) for key, v in zip(QUANTILE_KEYS, q)},
                         "mean": float(d.mean()) if d.size else float("nan"),
                         "max": float(d.max()) if d.size else float("nan"), "count": int(d.size),
                         "near_singular_points": int(np.count_nonzero(near & finite)),
                         "admissible_points": int(self.ok.sum()), "admissible_area_m2": area}
        return out

    def touching_edges(self) -> list[str]:
        """Edges of the window that admissible points touch (e.g. ``['y max', 'z min']``): there the window clips the
        admissible region, and statistics over the section do not describe the whole region."""
        ok = np.asarray(self.ok, bool)
        u, v = self.plane.u_name, self.plane.v_name
        edges = [(f"{u} min", ok[:, 0]), (f"{u} max", ok[:, -1]), (f"{v} min", ok[0, :]), (f"{v} max", ok[-1, :])]
        return [name for name, line in edges if line.any()]

    def clipping_warning(self) -> str | None:
        """One line warning when the window clips the admissible region (None otherwise)."""
        edges = self.touching_edges()
        if not edges:
            return None
        return (f"the admissible region touches the window edge(s) {', '.join(edges)}: it is clipped there "
                f"(widen --range or omit it to fit the window to the workspace)")

    def reason_counts(self) -> dict[str, int]:
        return {r.name: int(np.count_nonzero(self.reasons & int(r))) for r in Reason}  # type: ignore[misc]

    def metadata(self) -> dict[str, Any]:
        return {"machine": self.machine, **self.plane.metadata(),
                "orientation_deg": np.rad2deg(self.orientation).tolist(),
                "tool_length_mm": None if self.tool_length is None else self.tool_length * 1e3,
                "units": self.units, "settings": self.settings, **self.frame,
                "note": f"raster points are positions of O' in the {self.frame['frame']} frame; values NaN where "
                        "inadmissible"}


def _evaluate_chunk(machine: Machine, poses: np.ndarray, names: Sequence[str], tool_length: float | None,
                    options: dict[str, Any], checks: Sequence[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ok, reasons, values (len(names) + 1, n) SI) of one chunk of poses; the last row is κ of the admissible
    poses (the near-singular margin, :attr:`SectionResult.near_singular`)."""
    ev = evaluate_poses(machine, poses, checks=checks)
    ok = ev.ok.copy()
    vals = np.full((len(names) + 1, len(poses)), np.nan)
    if ok.any():
        sub = ev if ok.all() else ev.subset(ok)
        vals[-1, ok] = sub.kappa
        ctx = EvalContext(machine, sub, tool_length, options)
        for i, n in enumerate(names):
            vals[i, ok] = np.asarray(get_quantity(n).compute(ctx), float)
    return ok, ev.admissibility.reasons, vals


def _evaluate_task(machine: parallel.Shared[Machine], raster: tuple[Plane, np.ndarray, np.ndarray], start: int,
                   stop: int, chunk_size: int, names: Sequence[str], tool_length: float | None,
                   options: dict[str, Any], checks: Sequence[str], target: result_files.OutputTarget | None = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """One task: raster points ``start`` … ``stop`` - 1 of ``raster`` = (plane, orientation, frame origin), made here
    and evaluated in consecutive chunks of ``chunk_size`` (the chunks the serial run evaluates): written into
    ``target`` at their columns (None returned), or returned as three compact arrays (without a target, or where
    writing it fails: a full ``/dev/shm``)."""
    m = machine.get()
    parts = [_evaluate_chunk(m, _raster_poses(raster, a, min(a + chunk_size, stop)), names, tool_length, options,
                             checks) for a in range(start, stop, chunk_size)]
    out = _concat(parts)
    if target is not None and _put(target, start, out):
        return None
    return out


_OUTPUT_NAMES = ("ok", "reasons", "vals")


def _put(target: result_files.OutputTarget, start: int, parts: tuple[np.ndarray, np.ndarray, np.ndarray]) -> bool:
    """``parts`` (ok, reasons, values) into ``target`` from column ``start`` on; False where the system refuses."""
    try:
        with target.writer() as w:
            for name, a in zip(_OUTPUT_NAMES, parts):
                w.put(name, start, a)
    except OSError:
        return False
    return True


def _written(out: result_files.SharedOutput, parts: list[tuple[int, Any]]
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The arrays of ``out`` once its tasks are done, with the parts ``(start column, arrays or None)`` that came back
    instead of being written (this process's own first chunk; a task whose writes the system refused) put in."""
    back = [(a, p) for a, p in parts if p is not None]
    if not all(_put(out.target, a, p) for a, p in back):  # no room left: ordinary arrays
        arrays = out.copies()
        for a, p in back:
            for name, x in zip(_OUTPUT_NAMES, p):
                arrays[name][..., a:a + x.shape[-1]] = x
        return arrays["ok"], arrays["reasons"], arrays["vals"]
    return out.arrays["ok"], out.arrays["reasons"], out.arrays["vals"]


def _concat(parts: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
            np.concatenate([p[2] for p in parts], axis=1))


def section_poses(plane: Plane, orientation: Iterable[float] = (0.0, 0.0, 0.0), start: int = 0,
                  stop: int | None = None) -> np.ndarray:
    """Poses (n, 6) of raster points ``start`` … ``stop`` - 1 (default all) of ``plane`` at ``orientation``."""
    pts = plane.points(start, stop)
    ori = np.broadcast_to(np.asarray(orientation, float), (len(pts), 3))
    return np.concatenate([pts, ori], axis=1)


def _raster_poses(raster: tuple[Plane, np.ndarray, np.ndarray], start: int, stop: int) -> np.ndarray:
    plane, orientation, offset = raster
    poses = section_poses(plane, orientation, start, stop)
    poses[:, :3] += offset
    return poses


def evaluate_section(
    machine: Machine,
    plane: Plane,
    quantities: Sequence[str] = (),
    orientation: Iterable[float] = (0.0, 0.0, 0.0),
    tool_length: float | None = None,
    chunk_size: int = 4096,
    n_jobs: int = 1,
    progress: bool | None = None,
    options: dict[str, Any] | None = None,
    checks: Sequence[str] = ALL_CHECKS,
    frame: str = "machine",
    scheduler: Any = None,
) -> SectionResult:
    """Evaluate ``quantities`` (names, see :mod:`pkmstiff.evaluation.quantities`) on a plane, masked by admissibility.

    ``orientation`` = (a, b, c) in rad, fixed over the plane; ``tool_length`` in m (None: the machine's).
    ``n_jobs`` > 1 (-1: all cores) evaluates the chunks in the run's worker pool, in tasks of whole chunks, about
    four per worker, while the first chunk runs here; ``scheduler`` (a Dask address or client) on a cluster
    (:mod:`pkmstiff.evaluation.parallel`): the first chunk runs here first and its measured time sizes the tasks (too
    little work stays serial). Every chunk is evaluated alone whatever the plan, so the result is the
    same bytes for any ``n_jobs``/``scheduler``; ``result.plan`` keeps the plan (not written to files).
    ``progress``: None = a progress bar only on a terminal when the section is large.
    ``checks``: the admissibility checks to apply (default all, see :data:`pkmstiff.admissibility.checks.ALL_CHECKS`).
    ``frame``: the plane's points are positions of O' in this frame (``"machine"`` or ``"report"``,
    :mod:`pkmstiff.machine.frames`); the result keeps them so and states the frame.
    """
    names = list(dict.fromkeys(quantities))
    qs = {n: get_quantity(n) for n in names}  # raises early for unknown names
    parallel.resolve_workers(n_jobs)
    raster = (plane, np.asarray(orientation, float), np.asarray(frame_origin(machine, frame), float))
    n = plane.size
    opts = dict(options or {})
    # K_U left out is the machine's field (pkmstiff.machine.frames.neglect_spindle): every quantity honours it; the
    # settings state it
    settings = {"chunk_size": chunk_size, "checks": list(checks), "checks_left_out": checks_left_out(checks), **opts}
    if machine.spindle_neglected:
        settings["neglect_spindle"] = True
    if progress is None:  # a bar on a terminal, periodic lines otherwise (pkmstiff.evaluation.progress)
        progress = n * (1 + len(names)) > 20_000
    n_first = min(chunk_size, n)
    rest = n - n_first
    first: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    seconds = [0.0]

    def run_first() -> None:
        t0 = time.perf_counter()
        first.append(_evaluate_chunk(machine, _raster_poses(raster, 0, n_first), names, tool_length, opts, checks))
        seconds[0] = (time.perf_counter() - t0) / n_first

    # local workers: tasks of whole chunks (a chunk outlasts a local task's overhead), sent before the first chunk is
    # evaluated here meanwhile; on Dask the first chunk's measured time decides whether the cluster pays
    ahead = scheduler is None and parallel.resolve_workers(n_jobs) > 1
    if not ahead:
        run_first()
    with parallel.connected(scheduler):
        plan = parallel.plan(rest, parallel.MIN_LOCAL_TASK_SECONDS / chunk_size if ahead else seconds[0], n_jobs,
                             scheduler, granule=chunk_size)
        bounds = parallel.split(rest, plan if plan.parallel else dataclasses.replace(plan, task_items=chunk_size))
        shared = parallel.Shared(machine)
        # local workers write their columns straight into the result's arrays (no result through the pipe, nothing
        # joined here, issue 25); elsewhere, or without a place for them, the parts come back and are joined
        out = result_files.SharedOutput.create(
            {"ok": ((n,), bool), "reasons": ((n,), np.uint32), "vals": ((len(names) + 1, n), float)}
        ) if plan.where == "local" else None
        target = None if out is None else out.target
        payloads = [(shared, raster, n_first + a, n_first + b, chunk_size, names, tool_length, opts, checks, target)
                    for a, b in bounds]
        step = progress_callback(len(payloads), progress, "section", "task" if plan.parallel else "chunk")
        try:
            parts = parallel.run_tasks(_evaluate_task, payloads, plan, scheduler, step,
                                       meanwhile=run_first if ahead else None)
            if out is not None:
                ok, reasons, vals = _written(out, [(0, first[0])] + [(n_first + a, part)
                                                                       for (a, _), part in zip(bounds, parts)])
        finally:
            if out is not None:
                out.close()
    plan = dataclasses.replace(plan, item_seconds=seconds[0])
    if out is None:
        ok, reasons, vals = _concat([*first, *parts])
    shape = plane.shape
    return SectionResult(
        machine=machine.name, plane=plane, orientation=np.asarray(orientation, float), tool_length=tool_length,
        values={n: vals[i].reshape(shape) for i, n in enumerate(names)}, units={n: q.unit for n, q in qs.items()},
        si_units={n: q.si_unit for n, q in qs.items()}, labels={n: q.label for n, q in qs.items()},
        ok=ok.reshape(shape), reasons=reasons.reshape(shape),
        settings={**settings, "near_singular_kappa": near_singular_limit(machine)},
        frame=frame_metadata(machine, frame), plan=dataclasses.replace(plan, items=n),
        kappa=vals[-1].reshape(shape),
    )


def three_planes(centre: Iterable[float], half_extent: Iterable[float], step: float) -> list[Plane]:
    """The three orthogonal planes YZ, XZ, XY through ``centre`` (m) with half extents (hx, hy, hz) (m)."""
    c = np.asarray(centre, float)
    h = np.asarray(half_extent, float)
    return [
        axis_plane("yz", c[0], (c[1] - h[1], c[1] + h[1]), (c[2] - h[2], c[2] + h[2]), step),
        axis_plane("xz", c[1], (c[0] - h[0], c[0] + h[0]), (c[2] - h[2], c[2] + h[2]), step),
        axis_plane("xy", c[2], (c[0] - h[0], c[0] + h[0]), (c[1] - h[1], c[1] + h[1]), step),
    ]


def evaluate_three_planes(machine: Machine, planes: list[Plane], quantities: Sequence[str], **kw) -> list[SectionResult]:
    """A three-plane set (Cobet chapter 2): the same quantities on each plane."""
    return [evaluate_section(machine, p, quantities, **kw) for p in planes]


def statistics_line(name: str, st: dict[str, Any]) -> str:
    """One text line of a quantity's statistics, led by the 5 % quantile, the mean and the 95 % quantile (not set by
    near-singular points), then min / 1 % / 99 % / max in parentheses."""
    return (f"  {name:<16} [{st['unit']}]  p5 {st['p5']:.4g}  mean {st['mean']:.4g}  p95 {st['p95']:.4g}  "
            f"(min {st['min']:.4g}, p1 {st['p1']:.4g}, p99 {st['p99']:.4g}, max {st['max']:.4g})")


def near_singular_line(summary: dict[str, Any]) -> str:
    """The count of near-singular points of a :func:`section_summary`, one text line."""
    ns = summary["near_singular"]
    return (f"  near-singular (kappa above {ns['kappa_above']:.3g} = {ns['fraction_of_threshold']:g} x the singularity "
            f"threshold): {ns['points']} of {summary['admissible_points']} admissible points")


def section_summary(res: SectionResult, seconds: float | None = None) -> dict:
    """Plane, admissible points and area, orientation, tool length, statistics and reasons (JSON-ready, units in keys)."""
    d = {"machine": res.machine, "plane": res.plane.name, "points": int(res.ok.size),
         "admissible_points": int(res.ok.sum()),
         "admissible_area_m2": float(res.ok.sum()) * res.plane.cell_area,
         "orientation_deg": np.rad2deg(res.orientation).tolist(),
         "tool_length_mm": None if res.tool_length is None else res.tool_length * 1e3,
         **res.frame, "neglect_spindle": bool(res.settings.get("neglect_spindle", False)),
         "checks_left_out": list(res.settings.get("checks_left_out", [])),
         "statistics": res.statistics(), "inadmissible_reasons": {k: v for k, v in res.reason_counts().items() if v},
         "window_mm": {res.plane.u_name: [float(res.plane.u_values[0]) * 1e3, float(res.plane.u_values[-1]) * 1e3],
                       res.plane.v_name: [float(res.plane.v_values[0]) * 1e3, float(res.plane.v_values[-1]) * 1e3]},
         "window_touches_admissible_region": res.touching_edges(), "warnings": [],
         "near_singular": {"points": int(res.near_singular.sum()),
                           "kappa_above": res.settings.get("near_singular_kappa"),
                           "fraction_of_threshold": NEAR_SINGULAR_FRACTION,
                           "note": "admissible points near the singularity threshold (docs/theory/kinematics.md); "
                                   "min/max are often set by them, the quantiles p1..p99 are not"}}
    w = res.clipping_warning()
    if w:
        d["warnings"].append(w)
    if seconds is not None:
        d["run_time_s"] = seconds
    return d
