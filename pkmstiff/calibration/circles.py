"""Ball-bar circles in a measurement (the calibration report's polar plots): runs of consecutive samples with one
direction whose ball centres lie in one plane; the ccw and cw runs of one circle are evaluated together (Szatmári
§4.5, :func:`~pkmstiff.calibration.ballbar.evaluate_circular_test`) on residuals, e.g. before (nominal model) and
after (calibrated model) identification. Non-planar paths (a hemisphere) are no circles."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pkmstiff.calibration.ballbar import BallbarEvaluation, evaluate_circular_test, plane_frame
from pkmstiff.errors import BallbarError

#: a run of samples is a circle when its ball centres leave their best-fit plane by less than this fraction of the
#: run's extent (its diameter): 1e-3 of the radius, the ball-bar evaluation's own planarity limit. The simulator
#: interpolates between plan nodes on the bar's sphere, which bends a circle that is not centred on the fixed ball
#: out of its plane by ~1.4e-4 of its extent; a hemisphere leaves it by ~0.3.
PLANE_TOL = 5e-4


@dataclass(frozen=True)
class CircleRun:
    """One ball-bar circle of a measurement: sample indices (time order, both directions), its label, and the
    ball-bar evaluations of the residuals before and after identification."""

    label: str
    index: np.ndarray
    before: BallbarEvaluation
    after: BallbarEvaluation


def _pieces(P: np.ndarray, direction: np.ndarray | None) -> list[np.ndarray]:
    """Runs of consecutive samples: split where the direction label changes or the ball jumps (> 20 median steps)."""
    n = len(P)
    cut = np.zeros(n, dtype=bool)
    if direction is not None:
        d = np.asarray(direction).astype(str)
        cut[1:] |= d[1:] != d[:-1]
    step = np.linalg.norm(np.diff(P, axis=0), axis=1)
    if step.size:
        med = float(np.median(step[step > 0])) if np.any(step > 0) else 0.0
        cut[1:] |= step > 20 * med if med > 0 else False
    return np.split(np.arange(n), np.flatnonzero(cut))


def _plane(P: np.ndarray) -> tuple[np.ndarray, np.ndarray, float] | None:
    """(centroid, unit normal, largest distance from the plane) of points, or None for fewer than 8 points."""
    if len(P) < 8:
        return None
    c = P.mean(axis=0)
    _, _, Vt = np.linalg.svd(P - c, full_matrices=False)
    n = Vt[-1]
    return c, n, float(np.max(np.abs((P - c) @ n)))


def circle_runs(P: np.ndarray, direction: np.ndarray | None) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Circles of a ball-bar measurement: (sample indices, plane point, unit normal) per circle. Runs of consecutive
    samples (:func:`_pieces`) whose ball centres ``P`` (N, 3) lie in a plane (within :data:`PLANE_TOL` of their
    extent) are circles;
    consecutive planar runs in the same plane (e.g. ccw then cw) are one circle."""
    out: list[tuple[list[np.ndarray], np.ndarray, np.ndarray]] = []
    for idx in _pieces(P, direction):
        pl = _plane(P[idx])
        if pl is None:
            continue
        c, n, _ = pl
        size = float(np.max(np.ptp(P[idx], axis=0)))
        if pl[2] > PLANE_TOL * size:
            continue
        if out:
            idx0, c0, n0 = out[-1]
            if abs(abs(float(n @ n0)) - 1.0) < 1e-6 and abs(float((c - c0) @ n0)) < PLANE_TOL * size:
                out[-1] = (idx0 + [idx], c0, n0)
                continue
        out.append(([idx], c, n))
    return [(np.concatenate(parts), c, n) for parts, c, n in out]


def _ideal_circle(P: np.ndarray, fixed_ball: np.ndarray, bar_length: float, source: str) -> np.ndarray:
    """The samples' ball centres moved onto the exact circle of the bar (same in-plane angle): the sphere of radius
    ``bar_length`` about the fixed ball cut by the samples' plane. The polar plots then show the residuals alone,
    not the few µm by which a sampled path (chords between plan nodes) leaves the ideal circle."""
    frame = plane_frame(P, fixed_ball, "auto", source=source)
    h = float((frame.origin - np.asarray(fixed_ball, dtype=float)) @ frame.normal)
    R = math.sqrt(max(bar_length ** 2 - h * h, 0.0))
    uv = frame.coordinates(P)
    th = np.arctan2(uv[:, 1], uv[:, 0])
    return frame.origin + frame.to_space(R * np.c_[np.cos(th), np.sin(th)])


def circles(P: np.ndarray, direction: np.ndarray | None, fixed_ball: np.ndarray, bar_length: float,
            before: np.ndarray, after: np.ndarray, source: str) -> list[CircleRun]:
    """Ball-bar evaluations of the residuals before/after on every circle found in the samples."""
    runs = []
    for k, (idx, _c, _n) in enumerate(circle_runs(P, direction), 1):
        d = None if direction is None else np.asarray(direction)[idx]
        try:
            Q = _ideal_circle(P[idx], fixed_ball, bar_length, source)
            ev0 = evaluate_circular_test(Q, before[idx], fixed_ball, bar_length, direction=d, source=source)
            ev1 = evaluate_circular_test(Q, after[idx], fixed_ball, bar_length, direction=d, source=source)
        except BallbarError:  # an arc, not a full circle (gaps): no circular-test figures
            continue
        centre = P[idx].mean(axis=0) * 1e3
        label = (f"circle {k}: {ev0.plane.name} plane, centre ({', '.join(f'{v:.0f}' for v in centre)}) mm, "
                 f"{idx.size} samples")
        runs.append(CircleRun(label, idx, ev0, ev1))
    return runs


__all__ = ["PLANE_TOL", "CircleRun", "circle_runs", "circles"]
