"""Section windows that fit the workspace (issue 12, item 2): a coarse admissibility pass over the chains' reach box
gives the in-plane extent of the admissible region, so that a default section never clips the workspace.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable, Sequence

import numpy as np

from pkmstiff.admissibility.checks import ALL_CHECKS
from pkmstiff.errors import ArgumentError
from pkmstiff.evaluation.sections import axis_plane, evaluate_section
from pkmstiff.machine.model import Machine
from pkmstiff.workspace.translational import reach_box

#: coarse raster points along the longer in-plane side of the reach box
COARSE_POINTS = 120
#: raster points per chunk of the coarse pass (its ~10,000 points then make tasks for several workers)
COARSE_CHUNK = 512
#: windows are rounded outward to multiples of this length (m), so that titles and ticks show round numbers
ROUND_TO = 0.01


@dataclass(frozen=True)
class Window:
    """In-plane ranges (m) of a fitted section window and the admissible fraction of the coarse points inside them
    (what a section of the window costs scales with it, :meth:`~pkmstiff.evaluation.requests.SectionRequest.cost`)."""

    u_range: tuple[float, float]
    v_range: tuple[float, float]
    admissible_fraction: float


def fit_window(machine: Machine, kind: str, at: float, orientation: Iterable[float] = (0.0, 0.0, 0.0),
               margin_steps: float = 1.5, checks: Sequence[str] = ALL_CHECKS, n_jobs: int = 1,
               scheduler: Any = None) -> Window:
    """In-plane ranges (m) of plane ``kind`` ('yz', 'xz', 'xy') at ``at`` (m) that contain the admissible region.

    A raster of :data:`COARSE_POINTS` points along the longer side of the chains' reach box
    (:func:`~pkmstiff.workspace.translational.reach_box`, which contains every reachable position) is checked for
    admissibility; the bounding box of its admissible points grows by ``margin_steps`` coarse steps (the boundary lies
    within one coarse step of the outermost admissible point, plus a visible margin) and is rounded outward to
    :data:`ROUND_TO`. It is not clipped to the reach box: where the region ends at a frame limit, the margin shows
    inadmissible points, so the window's edge never cuts the region. Raises :class:`ArgumentError` when no coarse
    point is admissible.
    ``checks``: the admissibility checks that define the region (those the section will apply). ``n_jobs`` /
    ``scheduler``: the coarse pass runs in the run's worker pool / on a Dask cluster like a section
    (:func:`~pkmstiff.evaluation.sections.evaluate_section`); the window is the same whatever the plan.
    """
    kind = kind.lower()
    lo, hi = reach_box(machine)
    iu, iv = "xyz".index(kind[0]), "xyz".index(kind[1])
    step = max(hi[iu] - lo[iu], hi[iv] - lo[iv]) / COARSE_POINTS
    plane = axis_plane(kind, at, (lo[iu], hi[iu]), (lo[iv], hi[iv]), step)
    ok = evaluate_section(machine, plane, (), orientation, chunk_size=COARSE_CHUNK, n_jobs=n_jobs, progress=False,
                          checks=checks, scheduler=scheduler).ok
    if not ok.any():
        raise ArgumentError(f"{machine.name}: no admissible point on the {kind.upper()} plane at "
                           f"{'xyz'[3 - iu - iv]} = {at * 1e3:g} mm in the chains' reach box (coarse step "
                           f"{step * 1e3:.0f} mm); check the orientation and the plane position")
    rows, cols = np.nonzero(ok)
    u, v = plane.u_values, plane.v_values
    pad = margin_steps * step

    def rng(vals: np.ndarray, idx: np.ndarray) -> tuple[float, float]:
        lo_, hi_ = vals[idx.min()] - pad, vals[idx.max()] + pad
        return (round(math.floor(lo_ / ROUND_TO + 1e-9) * ROUND_TO, 9),
                round(math.ceil(hi_ / ROUND_TO - 1e-9) * ROUND_TO, 9))

    ur, vr = rng(u, cols), rng(v, rows)
    inside = np.count_nonzero((u >= ur[0]) & (u <= ur[1])) * np.count_nonzero((v >= vr[0]) & (v <= vr[1]))
    return Window(ur, vr, rows.size / max(int(inside), 1))


def window_ranges(machine: Machine, kind: str, at: float, step: float, orientation: Iterable[float] = (0.0, 0.0, 0.0),
                  frame: str = "machine", checks: Sequence[str] = ALL_CHECKS, n_jobs: int = 1,
                  scheduler: Any = None) -> Window:
    """The :class:`Window` of :func:`fit_window`, upper ends extended to whole raster steps (:func:`snap_to_step`)
    so that the raster's last row and column lie outside the admissible region too. ``at`` and the ranges are in
    ``frame`` (:mod:`pkmstiff.machine.frames`); the fit itself runs in the machine frame (``n_jobs`` / ``scheduler``:
    see :func:`fit_window`)."""
    from pkmstiff.machine.frames import frame_origin

    kind = kind.lower()
    o = frame_origin(machine, frame)
    normal = "xyz".index(({"x", "y", "z"} - set(kind)).pop())
    w = fit_window(machine, kind, at + o[normal], orientation, checks=checks, n_jobs=n_jobs, scheduler=scheduler)
    iu, iv = "xyz".index(kind[0]), "xyz".index(kind[1])
    (u0, u1), (v0, v1) = w.u_range, w.v_range
    return Window(snap_to_step((u0 - o[iu], u1 - o[iu]), step), snap_to_step((v0 - o[iv], v1 - o[iv]), step),
                  w.admissible_fraction)


def window_for(machine: Machine, kind: str, at: float, step: float,
               orientation: Iterable[float] = (0.0, 0.0, 0.0), frame: str = "machine"):
    """The fitted :class:`~pkmstiff.evaluation.sections.Plane` (raster ``step`` in m) of :func:`window_ranges`."""
    w = window_ranges(machine, kind, at, step, orientation, frame)
    return axis_plane(kind, at, w.u_range, w.v_range, step)


def snap_to_step(rng: tuple[float, float], step: float) -> tuple[float, float]:
    """(lo, hi) -> (lo, lo + k·step) with the smallest k for which lo + k·step >= hi: a raster from lo with ``step``
    then ends at or beyond hi instead of up to one step short of it."""
    lo, hi = rng
    k = math.ceil((hi - lo) / step - 1e-9)
    return lo, lo + k * step
