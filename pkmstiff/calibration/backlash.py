"""Reversal errors as identification parameters (issue 26 item 6): per-drive backlash ``chain<i>.backlash``.

Model (the one :func:`pkmstiff.calibration.simulation.backlash_offsets` simulates): a drive with backlash b lags
behind its command by half the clearance against its direction of motion,

    Δq_i(k) = −b_i / 2 · s_i(k),      s_i(k) = sign(q̇_i) at sample k,

s_i the sign of the commanded drive velocity (differences of the nominal inverse kinematics of consecutive
samples of one run), held through standstill; the samples of a run before a drive's first motion take the sign of
that first motion (the feed-in arc of a measuring run moves every drive the way the run starts). A run starts at
every segment of a plan and at every index in :attr:`~pkmstiff.calibration.plans.Plan.runs` (a measurement file:
where the direction label changes, the time jumps or the commanded pose jumps, :func:`run_starts_of_samples`).

The backlash acts like a strut offset whose sign follows the motion, so its Jacobian column is the strut-offset
(pod) / drive-zero (glide) column times −s_i(k)/2 (:mod:`pkmstiff.calibration.jacobian`). It is a machine
parameter (``chain`` ≥ 0) but not a geometric one: the calibrated machine file does not hold it (a controller's
reversal compensation does); ``identify`` reports it.
"""

from __future__ import annotations

import itertools

import numpy as np

#: the parameter block (one scalar per chain, m) and its ``--with`` token
BLOCK = "backlash"
TOKEN = "backlash"


def has_backlash(params) -> bool:
    """Whether the error model ``params`` holds backlash parameters."""
    return bool(params.mask(BLOCK).any())


def held_signs(drives: np.ndarray, starts: np.ndarray | list[int]) -> np.ndarray:
    """s (N, n): sign of the drive velocity per sample from the step q_k − q_{k−1} of the drive values (N, n) of
    each run (runs start at ``starts``, 0 included), held through standstill, leading samples at the sign of the
    first motion (loop over runs only)."""
    drives = np.asarray(drives, dtype=float)
    N = len(drives)
    out = np.zeros_like(drives)
    edges = np.unique(np.r_[0, np.asarray(starts, dtype=int), N])
    edges = edges[(edges >= 0) & (edges <= N)]
    for a, e in itertools.pairwise(edges):
        sgn = np.sign(np.diff(drives[a:e], axis=0, prepend=drives[a:a + 1]))
        m = len(sgn)
        idx = np.maximum.accumulate(np.where(sgn != 0, np.arange(m)[:, None], 0), axis=0)
        held = np.take_along_axis(sgn, idx, axis=0)
        first = np.argmax(sgn != 0, axis=0)
        lead = np.arange(m)[:, None] < first[None, :]
        out[a:e] = np.where(lead, sgn[first, np.arange(sgn.shape[1])][None, :], held)
    return out


def run_starts_of_samples(t: np.ndarray, direction: np.ndarray | None, poses: np.ndarray | None = None,
                          feed: np.ndarray | None = None, jump: float = 5.0) -> tuple[int, ...]:
    """Indices where a new run starts in a measurement's samples: the direction label changes, the time step
    between two path samples (``feed`` > 0; all when no feed is given) is more than 10 × the median step, or the
    commanded position jumps more than ``jump`` × the median step. Static poses (feed 0) stay in one run: each
    is approached from the one before."""
    t = np.asarray(t, dtype=float)
    cut = np.zeros(max(len(t) - 1, 0), dtype=bool)
    if len(t) > 2:
        dt = np.diff(t)
        moving = np.ones(len(t), dtype=bool) if feed is None else np.asarray(feed, dtype=float) > 0
        both = moving[1:] & moving[:-1]
        if both.any():
            cut |= both & (dt > 10 * np.median(dt[both]))
        if poses is not None:
            ds = np.linalg.norm(np.diff(np.asarray(poses)[:, :3], axis=0), axis=1)
            med = np.median(ds)
            if med > 0:
                cut |= ds > jump * med
    if direction is not None and len(direction) > 1:
        d = np.asarray(direction).astype(str)
        cut |= d[1:] != d[:-1]
    return tuple(int(i) for i in np.flatnonzero(cut) + 1)


def plan_run_starts(plan) -> np.ndarray:
    """Run starts of a plan: 0, every segment start and :attr:`Plan.runs`."""
    return np.unique(np.r_[0, [s.start for s in plan.segments], list(plan.runs)]).astype(int)


def drive_offsets(params, delta: np.ndarray, signs: np.ndarray) -> np.ndarray:
    """Δq (N, n) = −b/2 · s of the backlash parameters in ``delta`` (module docstring)."""
    b = params.block_scalars(delta, BLOCK, signs.shape[1])
    return -0.5 * b[None, :] * signs


__all__ = ["BLOCK", "TOKEN", "drive_offsets", "has_backlash", "held_signs", "plan_run_starts",
           "run_starts_of_samples"]
