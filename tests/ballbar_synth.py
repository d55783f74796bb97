"""Synthetic ball-bar circular tests for the tests (not a machine simulation; that is ``pkmstiff calibrate simulate``).

The actual moving-ball path is the commanded circle of radius R about the fixed ball s, in the plane (e1, e2),
distorted by: a centre offset e (in-plane, m), a radius error ΔR, an ellipse (x stretched by δ, y shrunk by δ), and
radial lobes Σ c_k cos(kθ − ψ_k). Readings = |actual − s| − bar_length + white noise, quantised to the resolution.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pkmstiff.calibration.measurement_file import BallbarMeasurement

QC10_NOISE = 0.5e-6  # QC10 accuracy ±0.5 µm (Szatmári Tab. 4.3) used as 1σ white noise: conservative
QC10_RESOLUTION = 0.1e-6


@dataclass
class SyntheticRun:
    theta: np.ndarray  # commanded angles (N,) in time order
    positions: np.ndarray  # commanded ball positions (N, 3)
    actual: np.ndarray  # actual ball positions (N, 3)
    reading: np.ndarray  # instrument readings (N,) relative to the bar length
    true_deviation: np.ndarray  # noise-free radial deviation (N,)


def circle_run(R: float = 0.15, n: int = 4096, *, offset=(0.0, 0.0), radius_error: float = 0.0,
               ellipse: float = 0.0, lobes: dict[int, tuple[float, float]] | None = None, noise: float = 0.0,
               resolution: float = 0.0, start: float = 0.0, direction: int = 1, fixed_ball=(0.0, 0.0, 0.0),
               e1=(1.0, 0.0, 0.0), e2=(0.0, 1.0, 0.0), jitter: float = 0.0, seed: int = 0,
               bar_length: float | None = None) -> SyntheticRun:
    rng = np.random.default_rng(seed)
    step = 2 * np.pi / n
    theta = start + direction * step * (np.arange(n) + (rng.uniform(-jitter, jitter, n) if jitter else 0.0))
    e1, e2, s = (np.asarray(v, dtype=float) for v in (e1, e2, fixed_ball))
    c, si = np.cos(theta), np.sin(theta)
    u = np.outer(c, e1) + np.outer(si, e2)
    P = s + R * u
    radial = np.full(n, radius_error) + sum(a * np.cos(k * theta - psi) for k, (a, psi) in (lobes or {}).items())
    A = s + (R + radial)[:, None] * u
    A = A + ellipse * (np.outer(c, e1) - np.outer(si, e2))
    A = A + offset[0] * e1 + offset[1] * e2
    L = R if bar_length is None else bar_length
    true_dev = np.linalg.norm(A - s, axis=1) - np.linalg.norm(P - s, axis=1)
    reading = np.linalg.norm(A - s, axis=1) - L
    if noise:
        reading = reading + rng.normal(0.0, noise, n)
    if resolution:
        reading = np.round(reading / resolution) * resolution
    return SyntheticRun(theta=theta, positions=P, actual=A, reading=reading, true_deviation=true_dev)


def measurement_from_runs(runs: dict[str, SyntheticRun], bar_length: float = 0.15, fixed_ball=(0.0, 0.0, 0.0),
                          feed: float = 500.0 / 60e3, sample_rate: float = 250.0, **header) -> BallbarMeasurement:
    """A measurement (poses with zero orientation, ball offset 0) from runs keyed 'ccw'/'cw', in that order."""
    pos = np.concatenate([r.positions for r in runs.values()])
    n = len(pos)
    poses = np.zeros((n, 6))
    poses[:, :3] = pos
    direction = np.concatenate([np.full(len(r.positions), k) for k, r in runs.items()])
    return BallbarMeasurement(bar_length=bar_length, fixed_ball=np.asarray(fixed_ball, dtype=float),
                              t=np.arange(n) / sample_rate, reading=np.concatenate([r.reading for r in runs.values()]),
                              poses=poses, feed=np.full(n, feed), direction=direction,
                              temperature=np.full(n, 20.0), sample_rate=sample_rate, **header)
