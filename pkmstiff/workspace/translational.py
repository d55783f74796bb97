"""Translational workspace of a machine: constant orientation or one variable orientation range (docs/theory/workspace.md). Positions are those of O' (the pose's position) in the machine frame, in m; volumes in m^3."""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike

import pkmstiff.admissibility.checks as adm
from pkmstiff.errors import ArgumentError
from pkmstiff.evaluation import parallel
from pkmstiff.machine.model import Machine
from pkmstiff.workspace.octree import OctreeResult, Progress, octree_boundary
from pkmstiff.workspace.oracle import OracleSubtrees, PoseOracle, RangeMode
from pkmstiff.workspace.requirements import Requirement
from pkmstiff.workspace.surface import BoundarySurface
from pkmstiff.workspace.volume import DEFAULT_METHODS, HEADLINE_METHOD, workspace_volume

MAX_RETRY_LEVEL = 6  # finest start grid tried when a coarser one finds no admissible corner


def reach_box(machine: Machine) -> tuple[np.ndarray, np.ndarray]:
    """A box that certainly contains every position of O' the chains can reach.

    |w - q_i| <= l_i + |p'_i| for every chain (the strut spans l_i, the platform joint lies |p'_i| from O'), with
    q_i on its guide segment (glide) or fixed (pod, l_i = l_max): the intersection of the chains' boxes and of the
    machine's frame limits (``[limits] frame``).
    """
    ch = machine.chains
    reach = (ch.strut_length if ch.kind == "glide" else ch.length_max) + np.linalg.norm(ch.platform_joint, axis=1)
    if ch.kind == "glide":
        a = ch.guide_start + ch.drive_joint
        b = a + ch.guide_length[:, None] * ch.guide_direction
        lo_i, hi_i = np.minimum(a, b), np.maximum(a, b)
    else:
        lo_i = hi_i = ch.drive_joint
    lo = np.maximum((lo_i - reach[:, None]).max(axis=0), machine.limits.position_min)
    hi = np.minimum((hi_i + reach[:, None]).min(axis=0), machine.limits.position_max)
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()) or np.any(hi <= lo):
        raise ArgumentError(f"machine '{machine.name}': the chains' reach boxes do not overlap (no workspace); "
                         f"found lo={lo.tolist()} m, hi={hi.tolist()} m")
    return lo, hi


def fit_box(lo: ArrayLike, hi: ArrayLike, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """Grow [lo, hi] about its centre to extents eps * 2**L_k, so that repeated halving gives exactly eps.

    Boxes fitted for eps and eps / 2 coincide, so the lattices of successive resolutions are nested.
    """
    lo_a, hi_a = np.asarray(lo, float), np.asarray(hi, float)
    ext = np.array([eps * 2.0 ** max(0, math.ceil(math.log2(e / eps) - 1e-9)) for e in hi_a - lo_a])
    c = 0.5 * (lo_a + hi_a)
    return c - ext / 2, c + ext / 2


@dataclass
class WorkspaceResult:
    """Boundary, volumes and statistics of a translational workspace (SI units: m, m^3, s)."""

    machine: str
    orientation: np.ndarray  # (3,) rad
    resolution: float  # m, requested eps
    octree: OctreeResult
    volumes: dict[str, float]  # m^3 by method
    surface: BoundarySurface | None  # closed mesh with crossing vertices (m)
    stats: dict[str, Any]
    settings: dict[str, Any] = field(default_factory=dict)
    # frame of the positions in summary(): {"frame", "frame_origin_mm", "frame_note"} (pkmstiff.machine.frames)
    frame: dict[str, Any] = field(default_factory=lambda: {"frame": "machine", "frame_origin_mm": [0.0, 0.0, 0.0]})

    @property
    def volume(self) -> float:
        """Volume by the default method (surface nets), m^3."""
        return self.volumes.get(HEADLINE_METHOD, next(iter(self.volumes.values()), float("nan")))

    @property
    def boundary_points(self) -> np.ndarray:
        return self.octree.boundary_points

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self.octree.extent
        return lo.copy(), hi.copy()

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary; keys name their units."""
        off = np.asarray(self.frame.get("frame_origin_mm", [0.0, 0.0, 0.0]), float) * 1e-3
        lo, hi = (b - off for b in self.bounding_box())
        o = self.octree
        return {
            "machine": self.machine, **self.frame,
            "orientation_deg": np.rad2deg(self.orientation).tolist(),
            "resolution_mm": self.resolution * 1e3,
            "effective_resolution_mm": (o.spacing * 1e3).tolist(),
            "volume_m3": self.volume,
            "volume_method": HEADLINE_METHOD,  # volume_m3, the figure to quote; volumes_m3: every method (cross-checks)
            "volumes_m3": dict(self.volumes),
            "bounding_box_mm": None if not np.isfinite(lo).all() else {"min": (lo * 1e3).tolist(),
                                                                         "max": (hi * 1e3).tolist()},
            "initial_box_mm": {"min": ((o.lo - off) * 1e3).tolist(), "max": ((o.hi - off) * 1e3).tolist()},
            "boundary_points": int(o.leaf_index.shape[0]),
            "evaluations": int(self.stats["evaluations"]),
            "poses_evaluated": int(self.stats["poses_evaluated"]),
            "evaluations_per_level": [[int(a), int(b)] for a, b in o.evaluations_per_level],
            "closure_voxels": o.closure_voxels,
            "touches_initial_box": o.touches_box,
            "run_time_s": self.stats["run_time_s"],
            "evaluation_time_s": self.stats["evaluation_time_s"],
            "octree_overhead_s": self.stats["octree_overhead_s"],
            "surface_triangles": 0 if self.surface is None else int(self.surface.triangles.shape[0]),
            "settings": self.settings,
        }


def constant_orientation_workspace(
    machine: Machine,
    resolution: float,
    orientation: ArrayLike = (0.0, 0.0, 0.0),
    *,
    requirements: Iterable[str | Requirement] = (),
    checks: Sequence[str] = adm.ALL_CHECKS,
    box: tuple[ArrayLike, ArrayLike] | None = None,
    orientation_range: tuple[str, float, float] | None = None,
    range_step: float = math.radians(2.0),
    range_mode: RangeMode = "all",
    methods: Sequence[str] = DEFAULT_METHODS,
    refine_steps: int = 0,
    min_level: int = 3,
    progress: Progress | None = None,
    n_jobs: int = 1,
    scheduler: Any = None,
) -> WorkspaceResult:
    """Workspace at constant orientation (a, b, c [rad]) by the modified octree, with volumes and a closed surface.

    ``resolution`` = eps in m. ``box`` = (lo, hi) in m; default :func:`reach_box`, fitted so that the effective
    resolution equals eps (:func:`fit_box`). ``orientation_range`` = ("a"|"b"|"c", lo, hi) [rad] gives the workspace
    with one variable orientation range (see :class:`PoseOracle`). ``refine_steps``: bisection steps along the
    boundary edges for the surface-nets volume (extra evaluations, counted). ``n_jobs`` (-1: all cores) /
    ``scheduler`` (Dask): the octree levels' points are evaluated in the run's worker pool / on the cluster, sized by
    the measured time of the previous level (:class:`PoseOracle`); the result is the same whatever the plan.
    """
    t0 = time.perf_counter()
    ori = np.asarray(orientation, float)
    if ori.shape != (3,) or not np.isfinite(ori).all():
        raise ValueError(f"orientation: expected three finite angles a, b, c in rad, found {orientation!r}")
    if not (math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution: expected a positive length in m, found {resolution!r}")
    lo, hi = reach_box(machine) if box is None else (np.asarray(box[0], float), np.asarray(box[1], float))
    if box is None:
        lo, hi = fit_box(lo, hi, resolution)
    oracle = PoseOracle(machine, np.concatenate([np.zeros(3), ori]), (0, 1, 2), requirements=requirements,
                        checks=checks, orientation_range=orientation_range, range_step=range_step,
                        range_mode=range_mode, n_jobs=n_jobs, scheduler=scheduler)
    with parallel.connected(scheduler):
        res, level, rep = _octree(oracle, lo, hi, resolution, min_level, methods, refine_steps, progress)
    if res.leaf_index.shape[0] == 0 and res.inside_volume == 0.0:
        warnings.warn(f"{machine.name}: no admissible point found on the octree start grids up to level {level} "
                      f"(spacing {np.max((hi - lo) / 2 ** level) * 1e3:.0f} mm); the workspace is empty or thinner "
                      f"than that — give a tighter box", RuntimeWarning, stacklevel=2)
    run = time.perf_counter() - t0
    st = oracle.stats
    stats = {"evaluations": st.points, "octree_evaluations": res.evaluations,
             "refine_evaluations": rep.refine_evaluations, **st.as_dict(),
             "run_time_s": run, "evaluation_time_s": st.time, "octree_overhead_s": run - st.time}
    settings = {"checks": list(checks), "checks_left_out": adm.checks_left_out(checks),
                "requirements": [r.text for r in oracle.requirements],
                "orientation_range": None if orientation_range is None else
                [orientation_range[0], math.degrees(orientation_range[1]), math.degrees(orientation_range[2])],
                "orientation_range_unit": "deg", "range_step_deg": math.degrees(range_step),
                "range_mode": range_mode, "refine_steps": refine_steps, "min_level": min_level, "start_level": level}
    return WorkspaceResult(machine.name, ori, float(resolution), res, rep.volumes, rep.crossing_mesh, stats, settings)


def _octree(oracle: PoseOracle, lo: np.ndarray, hi: np.ndarray, resolution: float, min_level: int,
            methods: Sequence[str], refine_steps: int, progress: Progress | None) -> tuple[OctreeResult, int, Any]:
    """The octree from ``min_level`` (finer start levels while no start corner is admissible) and its volumes."""
    res = octree_boundary(oracle, lo, hi, resolution, min_level=min_level, progress=progress,
                          subtrees=OracleSubtrees(oracle), threads=oracle.threads)
    # A workspace thinner than the start grid's spacing is missed when no start corner is admissible (docs/theory/workspace.md,
    # known limitation): start finer before concluding that there is none, and say so if there still is none.
    level = min_level
    while res.leaf_index.shape[0] == 0 and res.inside_volume == 0.0 and level < max(min_level, MAX_RETRY_LEVEL):
        level += 1
        res = octree_boundary(oracle, lo, hi, resolution, min_level=level, progress=progress,
                              subtrees=OracleSubtrees(oracle), threads=oracle.threads)
    return res, level, workspace_volume(res, tuple(methods), refine_steps=refine_steps, admissible=oracle)


def volume_vs_orientation(
    machine: Machine,
    angles: ArrayLike,
    axes: Sequence[str] = ("a", "b", "c"),
    resolution: float = 0.025,
    *,
    base_orientation: ArrayLike = (0.0, 0.0, 0.0),
    method: str = "surface_nets",
    **kw: Any,
) -> dict[str, np.ndarray]:
    """Workspace volume (m^3) as a function of one tool angle at a time, the others at ``base_orientation``.

    Returns ``{axis: volumes (len(angles),)}`` for each axis in ``axes`` (angles in rad). The box is fixed over
    all angles (the reach box, independent of the orientation) so that every run uses the same lattice.
    """
    ang = np.asarray(angles, float)
    base = np.asarray(base_orientation, float)
    out: dict[str, np.ndarray] = {}
    box = kw.pop("box", None) or fit_box(*reach_box(machine), resolution)
    for ax in axes:
        if ax not in ("a", "b", "c"):
            raise ValueError(f"axes: expected names among 'a', 'b', 'c', found {ax!r}")
        vols = []
        for th in ang:
            ori = base.copy()
            ori["abc".index(ax)] = th
            r = constant_orientation_workspace(machine, resolution, ori, box=box, methods=(method,), **kw)
            vols.append(r.volumes[method])
        out[ax] = np.array(vols)
    return out
