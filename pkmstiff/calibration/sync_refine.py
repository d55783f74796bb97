"""Synchronisation refined against the identified machine (issue 26 items 1 and 6): synchronisation and
identification iterated.

The feed-in ramp alone fixes a run's start t₀ to σ ≈ 0.2–1 ms at 25 Hz (:mod:`.raw_import`): the machine's
unknown errors must be absorbed there by nuisance terms. Once a machine is identified its readings are predicted
along the *whole* run — feed-in arc, ramps, path, overshoot, feed-out — so each run's t₀ is re-fitted by
Gauss-Newton on

    r_k(t₀) = y_k − ŷ(t_k − t₀),        ŷ(τ) = the identified machine's deviation at the commanded pose of τ,

(ŷ′ by a central difference, h = 10 µs), over every sample on the run's motion except those within one sample
interval of a drive reversal (where the backlash state of a sample depends on t₀ discontinuously), with
σ(t₀) = s / ‖∂r/∂t₀‖, s² = ‖r‖²/(n − 1). The measurement is then re-mapped at the new t₀ and identified again,
until no start moves by more than ``tol`` × its σ (a fixed point of the alternating minimisation of the joint
least-squares problem in t₀ and the parameters).

With t₀ known to σ ≈ 0.05 ms instead of ≈ 0.5 ms, a timing error δt moving every sample by F δt along the path
no longer biases the readings, and the drive-direction sign of the sample next to a reversal (a step of the
drive's backlash) is assigned as the machine ran it except with probability ≈ 2 σ(t₀) / sample interval per
reversal.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from pkmstiff.calibration.backlash import held_signs
from pkmstiff.calibration.instruments import readings
from pkmstiff.calibration.measurement import commanded_drives, reached_poses
from pkmstiff.calibration.nc_program import Run
from pkmstiff.calibration.parameters import ParameterSet
from pkmstiff.calibration.perturb import perturbed_state
from pkmstiff.calibration.plans import Plan
from pkmstiff.calibration.raw_import import import_raw
from pkmstiff.calibration.raw_series import RawSeries
from pkmstiff.kinematics.rotation import cardan_matrix
from pkmstiff.machine import Machine

#: central-difference step of ŷ′ (s): 0.33 µm along the path at 2000 mm/min, far inside one program segment
H = 1e-5


def predicted_deviation(machine: Machine, params: ParameterSet, delta: np.ndarray, plan: Plan, run: Run,
                        tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ŷ (N,) [m]: the deviation the machine with errors ``delta`` shows at times ``tau`` [s after the start of
    the feed-in arc] of ``run`` (standstill before and after), and the drives' signs of motion (N, n) used."""
    st = plan.setup
    x = run.poses(tau, st.target)
    reached = reached_poses(machine, params, delta, x)
    R = cardan_matrix(reached[:, 3], reached[:, 4], reached[:, 5])
    Rc = cardan_matrix(x[:, 3], x[:, 4], x[:, 5])
    y = readings(st, perturbed_state(st, params, delta), reached[:, :3], R, Rc)[:, 0] - st.bar_length
    return y, held_signs(commanded_drives(machine, x), [0])


def resynchronise(machine: Machine, params: ParameterSet, delta: np.ndarray, plan: Plan, run: Run,
                  series: RawSeries, start: float, iterations: int = 4) -> tuple[float, float, float]:
    """t₀ [s], its σ [s] and the RMS residual [m] of ``series`` against the machine with errors ``delta`` along
    ``run`` (module docstring), Gauss-Newton from ``start``."""
    t, y = series.t, series.deviation
    t0 = float(start)
    sigma, rms = np.inf, np.inf
    for _ in range(iterations):
        tau = t - t0
        on = (tau >= 0.0) & (tau <= run.duration)
        yh, s = predicted_deviation(machine, params, delta, plan, run, tau[on])
        # a sample whose drive sign differs from a neighbour's lies within one sample interval of a reversal
        flip = np.any(s[1:] != s[:-1], axis=1)
        near = np.r_[flip, False] | np.r_[False, flip]
        keep = ~near
        up, s_up = predicted_deviation(machine, params, delta, plan, run, tau[on][keep] + H)
        dn, s_dn = predicted_deviation(machine, params, delta, plan, run, tau[on][keep] - H)
        same = np.all((s_up == s[keep]) & (s_dn == s[keep]), axis=1)  # no sign change within ±H
        d = ((up - dn) / (2 * H))[same]  # ∂r/∂t₀ = ŷ′(t − t₀) for r = y − ŷ(t − t₀)
        r = (y[on][keep] - yh[keep])[same]
        dd = float(d @ d)
        if dd <= 0:
            break
        step = -float(d @ r) / dd
        t0 += step
        n = r.size
        rms = float(np.sqrt(np.mean(r ** 2)))
        sigma = float(np.linalg.norm(r) / np.sqrt(max(n - 1, 1)) / np.sqrt(dd))
        if abs(step) <= 1e-3 * sigma:
            break
    return t0, sigma, rms


def import_refined(machine: Machine, plan: Plan, runs: list[Run], series: list[RawSeries],
                   identify_delta: Callable[[object], np.ndarray], params: ParameterSet, *, tol: float = 0.1,
                   max_rounds: int = 5, limit: float | None = None):
    """Import ``series`` (:func:`~.raw_import.import_raw`), then alternate: identify (``identify_delta``:
    measurement -> error vector of ``params``), re-synchronise every run against the identified machine, re-import
    at the new starts; until no start moves by more than ``tol`` × its σ or after ``max_rounds``. Returns the
    measurement, the syncs (``sigma`` and ``residual`` of the refined fit) and the rounds taken."""
    meas, syncs = import_raw(machine, plan, runs, series, limit=limit)
    by_num = {r.number: r for r in runs}
    rounds = 0
    for rounds in range(1, max_rounds + 1):
        delta = identify_delta(meas)
        new = []
        for s, sy in zip(series, syncs):
            t0, sig, rms = resynchronise(machine, params, delta, plan, by_num[sy.run], s, sy.start)
            new.append(dataclasses.replace(sy, start=t0, sigma=sig, residual=rms))
        moved = max(abs(a.start - b.start) / b.sigma for a, b in zip(syncs, new))
        meas, syncs = import_raw(machine, plan, runs, series, syncs=new)
        if moved <= tol:
            break
    return meas, syncs, rounds


__all__ = ["import_refined", "predicted_deviation", "resynchronise"]
