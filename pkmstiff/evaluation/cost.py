"""One cost model for every command: CPU time and peak resident memory before the work (issue 22, item 3).

A command's cost is the process baseline (interpreter, numpy/scipy, compiled kernels) plus counts × measured
per-unit costs. The per-unit constants below were measured by ``benchmarks/bench_estimates.py`` (CPU seconds of one
process, so that the load of a shared machine does not enter; peak RSS from ``getrusage``) and rounded; the
benchmark prints estimate / actual for every command and must stay within 0.5..2. Counts come from the input:

* sections: raster points (every one runs the pose pipeline) and the *admissible* points (only they get
  quantities); the admissible fraction is measured on a sub-raster of at most :data:`PILOT_POINTS` points first
  (:func:`admissible_fraction`), because it ranges from 0 to 1 and the structure quantities cost ~10× a pose;
* workspace (modified octree): the evaluations grow like the workspace's boundary area over eps² (the octree's
  growth law: ×4 per halving of eps, measured on the bundled machines) — :data:`OCTREE_SURFACE_FACTOR` × the reach
  box's surface / eps², at most the full lattice;
* rotation maps: raster points × directions × the increments searched per point;
* FE: degrees of freedom (from the mesh size) with the fill-in law of a 3-D sparse direct solve;
* everything else: its row/step/harmonic count × a per-unit cost.

Time is the CPU time of the one process (wall time equals it on an idle machine); memory is the peak RSS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Iterable, Sequence

import numpy as np

MB = float(1 << 20)

# ----------------------------------------------------------------------------------------------- measured constants
#: resident memory of a process that has loaded the evaluation stack (numpy, scipy, numba kernels, a machine), bytes
BASE_BYTES = 220 * MB
#: CPU seconds of that start (imports, machine cache, the first compiled-kernel calls)
BASE_SECONDS = 1.0
#: pose pipeline (IK, Jacobians, all admissibility checks) per pose, s
POSE_SECONDS = 5e-6
#: structure model (stiffness, compliance; shared by every structure quantity) per admissible pose, s
STRUCTURE_SECONDS = 40e-6
#: lowest modes (generalised eigenproblem) per admissible pose on top of the structure model, s
MODAL_SECONDS = 15e-6
#: a kinematic quantity (κ, U, velocities) per admissible pose, s
KINEMATIC_SECONDS = 1e-6
#: held per raster point during a section (pose, mask, reasons, coordinates), bytes
RASTER_BYTES = 120
#: held per raster point and quantity (the value and its display copy), bytes
VALUE_BYTES = 24
#: working set of one evaluation chunk (4,096 poses through the pose pipeline and the structure model), bytes
CHUNK_BYTES = 40 * MB
#: writing a section: per raster point (its coordinates and flags) and per raster point and quantity (CSV cells,
#: VTU and NPZ arrays), s; bytes per raster point and quantity. Measured at 0.625 mm (2.3 million points, one after
#: another): 3.0–3.3 s with one quantity, 6.3–6.7 s with four (the columnar CSV writer and VTK's writers)
WRITE_POINT_SECONDS = 0.9e-6
WRITE_SECONDS = 0.5e-6
WRITE_BYTES = 400
#: one matplotlib map (s), and importing matplotlib once per process (s)
PNG_SECONDS = 0.3
PLOT_LIBRARY_SECONDS = 0.5
#: a 3-D figure (pyvista/VTK off-screen: one render; the library's resident memory), s and bytes, and importing
#: pyvista/VTK once per process (s)
FIGURE_3D_SECONDS = 0.7
FIGURE_3D_BYTES = 340 * MB
FIGURE_3D_LIBRARY_SECONDS = 1.0
#: modified octree: evaluations per (reach-box surface / eps²); measured 0.41 (Hexaglide) .. 0.92 (6X); the
#: geometric mean keeps every bundled machine within 1.6×
OCTREE_SURFACE_FACTOR = 0.65
#: per octree evaluation: pose pipeline, lattice bookkeeping, surface extraction (s) and the held lattice (bytes);
#: serial runs on the shared 2-core machine, 2026-11-26: 1.7 (Paralix, 6X, 4 mm) .. 1.9 (Felix 4 mm) .. 2.6 us
#: (Hexaglide 2-4 mm) of run time per evaluation, the command's start-up (BASE_SECONDS) aside (6 us before the
#: compiled kernels put Felix at 4 mm 2.9x over)
OCTREE_SECONDS = 3e-6
OCTREE_BYTES = 300
#: a pilot run (growth law, :func:`octree_pilot_halvings`) for runs expected above OCTREE_PILOT_MIN evaluations
OCTREE_PILOT_MIN = 50_000
OCTREE_PILOT_EVALUATIONS = 30_000
#: rotation maps (Hexaglide YZ raster, 1° and 0.1° increments): mean limit angle of a search, prediction error of
#: the predictor-corrector, its evaluations per point besides the error, increments per block of the plain search,
#: CPU seconds per evaluation of the plain search (large batches) and per batch of the predictor-corrector, per
#: base pose (the fused kernel in chunks of 4096: ~2.7 us), and per evaluation the predictor-corrector is estimated
#: to make (it makes ~0.55 of the estimate: 1.2 us; Hexaglide yz maps of 2-3.125 mm, 6 directions, on the shared
#: 2-core machine, 2026-11: estimated 5.6 s against 4.5 s CPU at 2 mm, 3.2 s against 2.0 s at 3.125 mm; the plain
#: search 0.9 s CPU for 316,072 evaluations at 12.5 mm, 2.85 us each)
ROTATION_TYPICAL_LIMIT = math.radians(20.0)
ROTATION_PREDICTION_ERROR = math.radians(2.5)
ROTATION_PC_EVALUATIONS = 1.5
ROTATION_BLOCK = 8
ROTATION_PLAIN_SECONDS = 2.8e-6
ROTATION_CALL_SECONDS = 0.3e-3
ROTATION_BASE_SECONDS = 2.7e-6
ROTATION_PC_SECONDS = 1.2e-6
#: FE: bytes and CPU seconds per solve per degree of freedom at 1e5 DOFs (sparse direct solve of a 3-D hex mesh),
#: scaled with the fill-in law n^(4/3) for memory and n^(5/3) for time (nested dissection of a 3-D mesh); measured
#: on the shipped joint (28,527 DOFs, 2.3 s per tilt angle, 0.77 GB) and platform (44,928 DOFs, 1.46 GB)
FE_BYTES_PER_DOF = 31e3
FE_SECONDS_PER_DOF = 1.8e-4
FE_REFERENCE_DOFS = 1e5
FE_BASE_BYTES = 260 * MB
FE_BASE_SECONDS = 1.8
#: a sweep task: building the modified machine (s), and one point evaluation (structure + modes of one pose, s)
TASK_SECONDS = 0.05
POINT_SECONDS = 0.02
#: held per result row of a sweep (a dict of floats), bytes
ROW_BYTES = 2000
#: ``pkmstiff point --poses``: per pose row (pose pipeline, structure model, modes, CSV row), bytes and s
POINT_ROW_BYTES = 4000
POINT_ROW_SECONDS = 70e-6
#: generic mechanisms: one continuation step of a path that converges (a damped Newton solve of the batch;
#: slider-crank, 1e3..1e5 steps: 0.65..1 ms), s. A target without solution retries with 2×, 4×, … 16× the steps
#: (max_refine = 4), up to ~30× this: the estimate is the lower bound, so feasible work is never refused
MECHANISM_STEP_SECONDS = 8e-4
#: calibration: per planned pose (identification Jacobian rows over ~200 parameters, readings, samples), bytes and s
PLAN_POSE_BYTES = 20e3
PLAN_POSE_SECONDS = 2e-4
#: ``pkmstiff ballbar analyse``: the process (no compiled kernels) and per sample row (parsing, the run's arrays,
#: the least-squares and minimum-zone circles, the filtered reconstruction in blocks), bytes and s
BALLBAR_BASE_BYTES = 100 * MB
BALLBAR_ROW_BYTES = 1100
BALLBAR_ROW_SECONDS = 8e-6
#: points of the pilot that measures a section's admissible fraction
PILOT_POINTS = 2000


#: quantity groups (:attr:`pkmstiff.evaluation.quantities.Quantity.group`) computed from the structure model; the
#: others (kinematics, pose) come with the pose pipeline
STRUCTURE_GROUPS = frozenset({"stiffness", "modal", "kinetostatics", "deflection"})


@dataclass(frozen=True)
class Cost:
    """The estimated cost of one piece of work: ``count`` ``unit`` (set by ``option``), peak resident memory
    ``bytes`` and CPU ``seconds``."""

    what: str
    count: float
    unit: str
    bytes: float
    seconds: float
    option: str = ""
    advice: str = "use a coarser step/resolution or a smaller region"

    def then(self, other: Cost, what: str | None = None) -> Cost:
        """This work followed by ``other`` in the same process: the peak is the larger one, the times add (the
        process start, :data:`BASE_SECONDS`, which every cost includes, once)."""
        return Cost(what or self.what, self.count + other.count, self.unit if self.unit == other.unit else "items",
                    max(self.bytes, other.bytes), self.seconds + other.seconds - BASE_SECONDS,
                    self.option or other.option)

    def plus(self, seconds: float = 0.0, bytes: float = 0.0) -> Cost:
        """The same work with ``seconds`` more and a peak ``bytes`` higher (figures, files)."""
        return replace(self, seconds=self.seconds + seconds, bytes=self.bytes + bytes)

    def named(self, what: str, option: str | None = None) -> Cost:
        return replace(self, what=what, option=self.option if option is None else option)


def total(costs: Iterable[Cost], what: str, option: str = "") -> Cost:
    """Work done one after another in one process (a report): max of the peaks, sum of the times."""
    out = Cost(what, 0, "items", BASE_BYTES, BASE_SECONDS, option)
    for c in costs:
        out = out.then(c, what)
    return replace(out, option=option or out.option)


# ---------------------------------------------------------------------------------------------------- sections


def section_cost(n_points: int, admissible: float, n_kinematic: int, n_structure: int, modal: bool = False,
                 n_png: int = 0, write: bool = False) -> Cost:
    """A section of ``n_points`` raster points of which the fraction ``admissible`` is admissible, with
    ``n_kinematic`` kinematic and ``n_structure`` structure quantities (``modal``: some need modes); ``write``: the
    VTU/CSV/NPZ files, ``n_png`` maps (the plotting library's import, once per process, is the caller's:
    :data:`PLOT_LIBRARY_SECONDS`)."""
    n = float(n_points)
    n_adm = n * min(max(admissible, 0.0), 1.0)
    nq = n_kinematic + n_structure
    per_adm = n_kinematic * KINEMATIC_SECONDS + (STRUCTURE_SECONDS + (MODAL_SECONDS if modal else 0.0)
                                                 if n_structure else 0.0)
    seconds = BASE_SECONDS + n * POSE_SECONDS + n_adm * per_adm + n_png * PNG_SECONDS
    held = n * (RASTER_BYTES + VALUE_BYTES * nq)
    peak = held + CHUNK_BYTES
    if write:
        seconds += n * (WRITE_POINT_SECONDS + max(nq, 1) * WRITE_SECONDS)
        peak = max(peak, held + n * WRITE_BYTES * max(nq, 1) ** 0.5)
    return Cost("section", n_points, "points", BASE_BYTES + peak, seconds, "--step")


def admissible_fraction(machine, points: np.ndarray, orientation: Iterable[float],
                        checks: Sequence[str] | None = None) -> float:
    """Fraction of the raster ``points`` (N, 3) (m, machine frame) that are admissible at ``orientation`` (rad) under
    ``checks`` (None: all), measured on an evenly strided subset of at most :data:`PILOT_POINTS` points (~20 ms)."""
    from pkmstiff.admissibility.checks import ALL_CHECKS
    from pkmstiff.admissibility.pipeline import evaluate_poses

    pts = np.asarray(points, float).reshape(-1, 3)
    if pts.shape[0] == 0:
        return 0.0
    stride = max(1, pts.shape[0] // PILOT_POINTS)
    sub = pts[::stride]
    poses = np.concatenate([sub, np.broadcast_to(np.asarray(tuple(orientation), float), (len(sub), 3))], axis=1)
    return float(np.mean(evaluate_poses(machine, poses, checks=ALL_CHECKS if checks is None else checks).ok))


def plane_points(u_range: tuple[float, float], v_range: tuple[float, float], step: float, origin: Iterable[float],
                 u_axis: Iterable[float], v_axis: Iterable[float], max_points: int = PILOT_POINTS) -> np.ndarray:
    """At most about ``max_points`` points (m) evenly spread over a raster window, for :func:`admissible_fraction`
    without building the (possibly huge) raster itself."""
    nu = max(2, int((u_range[1] - u_range[0]) / step) + 1)
    nv = max(2, int((v_range[1] - v_range[0]) / step) + 1)
    k = max(1.0, math.sqrt(nu * nv / max_points))
    u = np.linspace(u_range[0], u_range[1], max(2, int(nu / k)))
    v = np.linspace(v_range[0], v_range[1], max(2, int(nv / k)))
    uu, vv = np.meshgrid(u, v)
    return (np.asarray(tuple(origin), float) + uu.reshape(-1, 1) * np.asarray(tuple(u_axis), float)
            + vv.reshape(-1, 1) * np.asarray(tuple(v_axis), float))


# --------------------------------------------------------------------------------------------------- workspace


def octree_evaluations(extent: Iterable[float], eps: float) -> float:
    """Expected admissibility evaluations of the modified octree over a box of ``extent`` (m) at resolution
    ``eps`` (m): :data:`OCTREE_SURFACE_FACTOR` × box surface / eps², at most the full lattice."""
    e = np.maximum(np.asarray(tuple(extent), float), eps)
    surface = 2.0 * (e[0] * e[1] + e[1] * e[2] + e[0] * e[2])
    lattice = float(np.prod(e / eps + 1.0))
    return min(OCTREE_SURFACE_FACTOR * surface / eps ** 2, lattice)


def octree_pilot_halvings(extent: Iterable[float], eps: float, orientations: int = 1) -> int:
    """Halvings k ≥ 2 of a pilot run at eps·2^k of at most :data:`OCTREE_PILOT_EVALUATIONS` evaluations; 0 when the
    whole run is expected below :data:`OCTREE_PILOT_MIN` evaluations (no pilot: the box estimate is good enough)."""
    n = octree_evaluations(extent, eps) * max(int(orientations), 1)
    if n < OCTREE_PILOT_MIN:
        return 0
    return max(2, math.ceil(0.5 * math.log2(n / OCTREE_PILOT_EVALUATIONS)))


def workspace_cost(extent: Iterable[float], eps: float, orientations: int = 1, structure: bool = False,
                   pilot: tuple[float, int] | None = None) -> Cost:
    """The modified octree at resolution ``eps`` (m) over a box of ``extent`` (m), each point checked at
    ``orientations`` orientations (an orientation range), ``structure``: requirements need the structure model.
    ``pilot`` = (eps_p, evaluations) of a pilot run: the evaluations scale with (eps_p / eps)² (growth law)."""
    n = (pilot[1] * (pilot[0] / eps) ** 2 if pilot is not None else octree_evaluations(extent, eps)) \
        * max(int(orientations), 1)
    per = OCTREE_SECONDS + (STRUCTURE_SECONDS if structure else 0.0)
    return Cost("workspace", int(n), "evaluations", BASE_BYTES + n * OCTREE_BYTES + CHUNK_BYTES,
                BASE_SECONDS + n * per, "--resolution")


# ------------------------------------------------------------------------------------------------ rotation maps


def rotation_map_cost(n_points: int, admissible: float, n_diagonals: int, n_directions: int, increment: float,
                      max_angle: float, plain: bool, verify: bool = False) -> Cost:
    """Rotation angles (increment, max_angle in rad) on ``n_points`` raster points, the fraction ``admissible`` of them
    at the base orientation, in ``n_directions`` directions. The plain search walks up to the limit angle
    (:data:`ROTATION_TYPICAL_LIMIT` on average, at most max_angle) in blocks of :data:`ROTATION_BLOCK`; the
    predictor-corrector needs :data:`ROTATION_PC_EVALUATIONS` plus the prediction error
    (:data:`ROTATION_PREDICTION_ERROR`) in increments per point, one batch per step of each of the ``n_diagonals``
    anti-diagonals; ``verify`` re-checks every increment below the result (held at once per diagonal); the base
    orientation is checked once per raster point (:func:`rotation_base_seconds`)."""
    k_max = max(max_angle / increment, 1.0)
    walk = min(k_max, ROTATION_TYPICAL_LIMIT / increment)
    pd = n_points * min(max(admissible, 0.0), 1.0) * max(int(n_directions), 1)  # searches
    if plain:
        evals = pd * (walk + ROTATION_BLOCK)
        secs = evals * ROTATION_PLAIN_SECONDS
    else:
        steps = ROTATION_PC_EVALUATIONS + min(k_max, ROTATION_PREDICTION_ERROR / increment)
        evals = pd * steps
        secs = evals * ROTATION_PC_SECONDS + (n_diagonals * steps + walk) * ROTATION_CALL_SECONDS
    held = 0.0
    if verify:
        evals += pd * walk
        secs += pd * walk * ROTATION_PLAIN_SECONDS
        held = pd / max(n_diagonals, 1) * walk * 64.0  # (increment, pose) rows of one anti-diagonal
    return Cost("rotation map", int(evals), "evaluations", BASE_BYTES + CHUNK_BYTES + n_points * n_directions * 64.0
                + held, BASE_SECONDS + rotation_base_seconds(n_points) + secs, "--increment")


def rotation_base_seconds(n_points: int) -> float:
    """The check of a rotation map's base orientation on ``n_points`` raster points (s; part of
    :func:`rotation_map_cost`)."""
    return n_points * ROTATION_BASE_SECONDS


# ----------------------------------------------------------------------------------------------------------- FE


def fe_dofs(n_built: int, size_built: float, size: float, n_phi_built: int, n_phi: int) -> float:
    """Degrees of freedom of a mesh at element size ``size`` and ``n_phi`` circumferential segments from a mesh built
    at (``size_built``, ``n_phi_built``) with ``n_built`` DOFs: ×(h₀/h)³ (volume mesh), ×n_phi/n_phi₀ when the
    circumferential division grows (an upper bound: only the circular parts grow)."""
    return n_built * (size_built / size) ** 3 * max(1.0, n_phi / max(n_phi_built, 1))


def fe_cost(n_dofs: float, solves: float = 1, what: str = "FE model", option: str = "--mesh-size") -> Cost:
    """A sparse direct FE solve of ``n_dofs`` degrees of freedom, ``solves`` times (tilt angles): memory by the
    fill-in law n^(4/3), time n^(5/3) per solve, both anchored at :data:`FE_REFERENCE_DOFS`."""
    r = max(float(n_dofs), 1.0) / FE_REFERENCE_DOFS
    mem = FE_BASE_BYTES + FE_BYTES_PER_DOF * FE_REFERENCE_DOFS * r ** (4 / 3)
    secs = FE_BASE_SECONDS + FE_SECONDS_PER_DOF * FE_REFERENCE_DOFS * r ** (5 / 3) * max(float(solves), 1.0)
    return Cost(what, int(n_dofs), "degrees of freedom", mem, secs, option)


# ------------------------------------------------------------------------------------------------------ sweeps


def sweep_cost(n_tasks: int, task: Cost, jobs: int = 1) -> Cost:
    """``n_tasks`` tasks of cost ``task`` each (its process start counted once), in ``jobs`` processes (each holds
    one task's working set): the CPU time adds, the peak is the workers' working sets plus the result rows."""
    per = task.seconds - BASE_SECONDS + TASK_SECONDS
    workers = max(int(jobs), 1)
    return Cost(f"{n_tasks:,} sweep task(s) of {task.what}", n_tasks, "tasks",
                BASE_BYTES + workers * (task.bytes - BASE_BYTES) + float(n_tasks) * ROW_BYTES,
                BASE_SECONDS + float(n_tasks) * per, task.option)


# ------------------------------------------------------------------------------------------------- plain counts


def rows_cost(n: float, bytes_per: float, seconds_per: float, what: str, unit: str, option: str,
              advice: str = "use fewer", base_bytes: float = BASE_BYTES) -> Cost:
    """Work linear in a count (poses of a file, continuation steps, planned points, ball-bar samples) in a process
    of ``base_bytes`` resident memory."""
    return Cost(what, n, unit, base_bytes + float(n) * bytes_per, BASE_SECONDS + float(n) * seconds_per, option,
                f"{advice} {unit}" if advice == "use fewer" else advice)
