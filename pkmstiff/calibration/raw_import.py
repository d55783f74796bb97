"""Raw ball-bar series -> a pkmstiff measurement (issue 26 item 1), and the raw series a ball bar would record on a
machine with errors (the simulation that tests it).

**Synchronisation.** Each raw series is one run of the NC program (:mod:`pkmstiff.calibration.nc_program`). The
ball bar sees the run's feed-in ramp (the radius grows by ``depth`` over ``ramp``) as two kinks in the deviation:
at τ₁ (ramp start) and τ₂ (path start) after the start t₀ of the feed-in arc. Over the window
[τ₁ − T_r/2, τ₂ + T_r] (T_r = τ₂ − τ₁) the deviation is modelled as

    y(t) = g(t − t₀) + a + b τ + c τ² + Σ_j (κ_j (τ − τ_j)₋ + λ_j (τ − τ_j)₋²),    τ = t − t₀ − τ₂, x₋ = min(x, 0)

with g the deviation of the nominal machine along the programmed polyline at constant feed and the smooth and kink
terms for what the machine's errors add (a smooth function of the pose whose slope and curvature change where the
path's direction does). t₀ minimises the residual (variable projection: a grid over ±T_r about the midpoint
crossing of the ramp, then a bounded Brent search); the residual's RMS is the **synchronisation residual**. The
same fit at the feed-out ramp gives a second t₀; a wrong feed, sample rate or path moves it by the relative error
times the run's duration, so a difference above one sample period (or a residual above ``limit``) is a one-line
error, never a silent shift. A given start offset skips the search but not the checks.

**Mapping (Assumption: constant feed, see :mod:`.nc_program`).** A sample at t lies at arc length
s = F (t − t₀) along the run's polyline; samples on the feed-in, overshoot and feed-out arcs are dropped, the
others get the commanded pose there (TCP and A B C interpolated linearly, o = TCP − R v); leading path samples
are left out until the drives' directions of motion the measurement will give them (the step to the next sample)
are those the machine ran them with (the step from the sample before, :func:`_lead_in`). A refined
synchronisation against the identified machine: :mod:`.sync_refine`. Times in the measurement
run on across runs (each run's duration plus two dwells).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from pkmstiff.calibration.backlash import held_signs
from pkmstiff.calibration.instruments import QC10, BallbarMeasurement, readings
from pkmstiff.calibration.measurement import commanded_drives, reached_poses
from pkmstiff.calibration.nc_program import NCOptions, Run
from pkmstiff.calibration.parameters import ParameterSet
from pkmstiff.calibration.perturb import perturbed_state
from pkmstiff.calibration.plans import Plan
from pkmstiff.calibration.raw_series import RawSeries
from pkmstiff.errors import InadmissibleError, InputError
from pkmstiff.kinematics.rotation import cardan_matrix
from pkmstiff.machine import Machine

#: fewest samples in a synchronisation window
MIN_WINDOW = 12
#: largest slope change at a ramp kink that the machine's errors may add, relative to the ramp's slope
MAX_KINK = 0.25


@dataclass(frozen=True)
class Sync:
    """The synchronisation of one raw series with its run: ``start`` t₀ [s] in the file's time, ``residual`` RMS
    of the signature fit [m], ``end_shift`` [s] (t₀ from the feed-out ramp − t₀ from the feed-in ramp),
    ``n_window`` samples in the feed-in window, ``given`` whether t₀ was given, ``kept`` samples mapped, ``sigma``
    the standard deviation of t₀ [s] from the fit (a timing error δt moves every sample by F δt along the path)."""

    file: str
    run: int
    start: float
    residual: float
    end_shift: float
    n_window: int
    given: bool
    kept: int
    sigma: float = math.nan

    def to_dict(self) -> dict:
        return {"file": self.file, "run": self.run, "start_s": self.start, "residual_um": self.residual * 1e6,
                "start_sigma_ms": self.sigma * 1e3, "end_shift_ms": self.end_shift * 1e3,
                "window_samples": self.n_window, "given": self.given, "samples": self.kept}


def kink_times(run: Run, fixed_ball: np.ndarray, bar_length: float) -> tuple[float, float, float, float]:
    """τ₁..τ₄ [s after the feed-in start]: ramp start, path start, feed-out ramp start and end (the program
    points where the TCP's distance to the fixed ball starts or stops changing)."""
    rad = np.linalg.norm(run.tcp - fixed_ball, axis=1)
    i0, i1 = run.path
    low = rad.min()
    tol = 1e-3 * (bar_length - low)
    fin = np.flatnonzero(rad[:i0] <= low + tol)
    after = np.arange(i1, len(rad))
    down0 = after[rad[after] >= bar_length - tol]
    down1 = after[rad[after] <= low + tol]
    if not fin.size or not down0.size or not down1.size:
        raise InputError(f"run {run.number}", "feed-in/out", "feed-in and feed-out ramps (a program written by "
                         "calibrate plan --nc)", "none")
    return tuple(float(run.s[i] / run.feed) for i in (fin[-1], i0, down0[-1], down1[0]))  # type: ignore[return-value]


def _reversals(machine: Machine | None, run: Run, target: np.ndarray, tau: np.ndarray) -> list[np.ndarray]:
    """Columns s_j, s_j τ of the drives j whose direction of motion (commanded, per sample) changes within the
    samples ``tau``: a reversal steps the deviation by the drive's backlash (module docstring)."""
    if machine is None:
        return []
    before = tau[0] - (tau[1] - tau[0])  # the sample before the window gives its first sample's direction
    s = held_signs(commanded_drives(machine, run.poses(np.r_[before, tau], target)), [0])[1:]
    flip = np.flatnonzero(np.any(s[1:] != s[:-1], axis=0))
    u = tau - tau.mean()
    return [c for j in flip for c in (s[:, j], s[:, j] * u)]


def _fit(t: np.ndarray, y: np.ndarray, run: Run, fixed_ball: np.ndarray, bar_length: float, t0: float,
         knots: tuple[float, float], window: tuple[float, float], machine: Machine | None = None,
         target: np.ndarray | None = None, vector: bool = False, w: np.ndarray | None = None):
    """RMS residual (m), sample count and the larger of the fitted slope changes at the two kinks relative to the
    nominal ramp slope, for start ``t0`` (module docstring); ``vector``: the residual vector on the samples ``w``."""
    tau = t - t0
    if w is None:
        w = (tau >= window[0]) & (tau <= window[1])
    if w.sum() < MIN_WINDOW:
        return math.inf, int(w.sum()), 0.0
    u = tau[w] - knots[1]
    kinks = [np.minimum(u - k, 0.0) for k in (knots[0] - knots[1], 0.0)]
    cols = [*kinks, np.ones_like(u), u, u ** 2, *(k ** 2 for k in kinks)]
    cols += _reversals(machine, run, target, tau[w])
    A = np.column_stack(cols)
    r = y[w] - run.nominal_reading(tau[w], fixed_ball, bar_length)
    coef, *_ = np.linalg.lstsq(A, r, rcond=None)
    res = r - A @ coef
    if vector:
        return res, A.shape[1] + 1
    slope = abs(run.nominal_reading(np.array([knots[0] + 0.5 * (knots[1] - knots[0])]), fixed_ball, bar_length)[0]
                - run.nominal_reading(np.array([knots[0]]), fixed_ball, bar_length)[0]) / (0.5 * (knots[1] - knots[0]))
    return float(np.sqrt(np.mean(res ** 2))), int(w.sum()), float(np.max(np.abs(coef[:2])) / slope)


def _search(t, y, run, fb, L, guess, knots, window, span, machine, target) -> float:
    """t₀ within ``guess`` ± ``span`` of least residual among the fits whose kink slopes are plausible (a window
    beside the true ramp fits it with kinks as steep as the ramp's)."""
    def f(t0):
        res, _, kink = _fit(t, y, run, fb, L, t0, knots, window, machine, target)
        if not np.isfinite(res):
            return 1e3
        return res if kink <= MAX_KINK else 1.0 + kink  # above every plausible fit (m), finite for Brent

    step = min(span / 60, 0.25 * float(np.median(np.diff(t))))  # finer than the valley (a fraction of a sample)
    grid = guess + np.linspace(-span, span, 2 * math.ceil(span / step) + 1)
    vals = np.array([f(g) for g in grid])
    k = int(np.argmin(vals))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    res = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": 1e-10})
    return float(res.x) if res.fun <= vals[k] else float(grid[k])


def _crossing(t: np.ndarray, y: np.ndarray, level: float, first: bool) -> float | None:
    """Time of the first sample above ``level`` (``first``), or of the sample after the last one above it."""
    idx = np.flatnonzero(y > level)
    if not idx.size:
        return None
    return float(t[int(idx[0])]) if first else float(t[min(int(idx[-1]) + 1, len(t) - 1)])


def _ramp_mid(run: Run, fixed_ball: np.ndarray, bar_length: float, a: float, b: float, level: float) -> float:
    """Time in [a, b] at which the nominal deviation crosses ``level``."""
    tt = np.linspace(a, b, 401)
    g = run.nominal_reading(tt, fixed_ball, bar_length)
    return float(tt[np.argmin(np.abs(g - level))])


def _timing_sigma(t, y, run, fb, L, t0, knots, window, machine, target) -> float:
    """σ of t₀ (s): s / ‖∂r/∂t₀‖ with r the projected residual on the fixed window samples, s² = ‖r‖²/(n − p)
    (central difference, h = 1 µs)."""
    w = ((t - t0) >= window[0]) & ((t - t0) <= window[1])
    r, p = _fit(t, y, run, fb, L, t0, knots, window, machine, target, True, w)
    h = 1e-6
    d = (_fit(t, y, run, fb, L, t0 + h, knots, window, machine, target, True, w)[0]
         - _fit(t, y, run, fb, L, t0 - h, knots, window, machine, target, True, w)[0]) / (2 * h)
    dof = max(len(r) - p, 1)
    nd = float(np.linalg.norm(d))
    return float(np.linalg.norm(r) / math.sqrt(dof) / nd) if nd > 0 else math.inf


def synchronise(series: RawSeries, run: Run, fixed_ball: np.ndarray, bar_length: float, *,
                limit: float | None = None, machine: Machine | None = None,
                target: np.ndarray | None = None) -> Sync:
    """Start t₀ of ``run`` in ``series`` (module docstring); one-line :class:`InputError` when the signature is
    not found, the window holds too few samples, the residual exceeds ``limit`` (default max(4 σ, 1 µm), σ the
    device's accuracy / 2) or the feed-out ramp is not where the feed and path put it. With ``machine`` (and the
    ball offset ``target``) a step per drive that reverses in a window is part of the model (backlash)."""
    t, y, src = series.t, series.deviation, series.path
    rate = series.sample_rate
    t1, t2, t3, t4 = kink_times(run, fixed_ball, bar_length)
    Tr = t2 - t1
    depth = bar_length - float(np.linalg.norm(run.tcp[0] - fixed_ball))
    what = (f"feed {run.feed * 60e3:g} mm/min, sample rate {rate:g} Hz, run {run.number} "
            f"({run.label}, {run.direction}, {run.length * 1e3:.1f} mm)")
    if 2 * Tr * rate < MIN_WINDOW:
        raise InputError(src, key="sample_rate_hz", reason=f"key 'sample_rate_hz': the feed-in ramp lasts {Tr * 1e3:.3g} ms = "
                         f"{Tr * rate:.2f} samples at {what}: expected at least {MIN_WINDOW / 2:.0f} samples on "
                         f"it (a longer --ramp, a lower feed or a higher sample rate)")
    acc = series.accuracy if series.accuracy is not None else QC10.accuracy
    limit = max(4 * acc / 2, 1e-6) if limit is None else limit
    win_in, win_out = (t1 - Tr / 2, t2 + Tr / 2), (t3 - Tr / 2, t4 + Tr / 2)
    span = Tr
    given = series.start_offset is not None
    level = y[0] + depth / 2  # the standstill before the feed-in + half the depth
    tc = _crossing(t, y, level, True)
    if tc is None:
        raise InputError(src, reason=f"no feed-in signature: the deviation never rises by half the feed-in depth "
                         f"({depth * 1e3:g} mm) above its first value {y[0] * 1e3:.4f} mm; expected a capture of "
                         f"{what} that starts before the feed-in arc")
    guess = tc - _ramp_mid(run, fixed_ball, bar_length, t1, t2, -depth / 2)
    t0 = float(series.start_offset) if given else _search(t, y, run, fixed_ball, bar_length, guess, (t1, t2),
                                                          win_in, span, machine, target)
    if t0 + win_in[0] < t[0] or t0 + win_out[1] > t[-1]:
        raise InputError(src, line=None if series.lines is None else int(series.lines[-1]), reason=f"the series covers t = {t[0]:g} .. {t[-1]:g} s "
                         f"but the run, starting at t = {t0:.4f} s, needs t = {t0 + win_in[0]:.4f} .. "
                         f"{t0 + win_out[1]:.4f} s ({what}): wrong feed, sample rate or path?")
    res, n, kink = _fit(t, y, run, fixed_ball, bar_length, t0, (t1, t2), win_in, machine, target)
    if not (res <= limit and kink <= MAX_KINK):
        raise InputError(src, reason=f"the feed-in signature does not fit: synchronisation residual "
                         f"{res * 1e6:.3g} um (at most {limit * 1e6:.3g} um), slope change {kink:.3g} x the ramp's "
                         f"(at most {MAX_KINK:g}) at start t = {t0:.4f} s{' (given)' if given else ''}, {what}: wrong feed, sample "
                         "rate, path or start offset?")
    te = _crossing(t, y, y[-1] + depth / 2, False)
    shift = math.inf if te is None else te - _ramp_mid(run, fixed_ball, bar_length, t3, t4, -depth / 2) - t0
    if abs(shift) <= 2 * span:
        t0_out = _search(t, y, run, fixed_ball, bar_length, t0 + shift, (t3, t4), win_out, span, machine, target)
        r_out, _, k_out = _fit(t, y, run, fixed_ball, bar_length, t0_out, (t3, t4), win_out, machine, target)
        shift = t0_out - t0 if (r_out <= limit and k_out <= MAX_KINK) else math.inf
    if not abs(shift) <= 1.0 / rate:
        found = "not found" if not np.isfinite(shift) else f"{shift:+.4f} s from where it belongs"
        ratio = f"; the machine moved at {(t3 - t2) / (t3 - t2 + shift):.5g} x the feed" if np.isfinite(shift) \
            else ""
        raise InputError(src, reason=f"the feed-out ramp is {found} (expected within one sample, "
                         f"{1e3 / rate:.3g} ms{ratio}; {what}): wrong feed, sample rate or path")
    return Sync(src, run.number, t0, res, shift, n, given, 0,
                _timing_sigma(t, y, run, fixed_ball, bar_length, t0, (t1, t2), win_in, machine, target))


def _lead_in(machine: Machine, run: Run, target: np.ndarray, tau: np.ndarray, first: int) -> int:
    """Index of the first sample to keep from ``first`` (the first on the path) on: a measurement gives its first
    sample the drives' directions of motion of the step to the second (:func:`~.backlash.held_signs`), whereas
    the machine ran into it from the sample before (on the feed-in ramp, or across a drive reversal); samples are
    left out until the two agree for every drive (at most 5)."""
    n = min(first + 7, len(tau))
    if first < 1 or n - first < 3:
        return first
    q = commanded_drives(machine, run.poses(tau[first - 1:n], target))
    step = np.sign(np.diff(q, axis=0))  # step[i]: into sample first + i
    for i in range(min(5, len(step) - 1)):
        if np.array_equal(step[i], step[i + 1]):
            return first + i
    return first + 5


def match_runs(series: list[RawSeries], runs: list[Run]) -> list[Run]:
    """The run of each raw series: header/option ``run``, else ``segment`` (1 if the program has one) and
    ``direction``, else the series' position."""
    by_num = {r.number: r for r in runs}
    segs = sorted({r.segment for r in runs})
    out = []
    for k, s in enumerate(series):
        if s.run is not None:
            if s.run not in by_num:
                raise InputError(s.path, key="run", reason=f"key 'run': expected a run 1..{len(runs)} of the program, found "
                                 f"{s.run} ({s.where('run')})")
            out.append(by_num[s.run])
            continue
        if s.direction is not None:
            seg = (s.segment - 1) if s.segment is not None else (segs[0] if len(segs) == 1 else None)
            if seg is None:
                raise InputError(s.path, key="segment", reason=f"key 'segment': expected the path segment (1..{len(segs)}) of "
                                 "this run (header '# segment: 1' or --segment), found none")
            hit = [r for r in runs if r.segment == seg and r.direction == s.direction]
            if not hit:
                raise InputError(s.path, key="direction", reason=f"key 'direction': expected a run of the program, found segment "
                                 f"{seg + 1} {s.direction} ({s.where('direction')})")
            out.append(hit[0])
            continue
        if k >= len(runs):
            raise InputError(s.path, key="run", reason=f"key 'run': expected at most {len(runs)} series (the program's runs), "
                             f"found series {k + 1}")
        out.append(runs[k])
    nums = [r.number for r in out]
    dup = next((n for n in nums if nums.count(n) > 1), None)
    if dup is not None:
        files = [s.path for s, r in zip(series, out) if r.number == dup]
        raise InputError(files[1], key="run", reason=f"key 'run': expected one series per run, found run {dup} also in "
                         f"{files[0]}")
    return out


def import_raw(machine: Machine, plan: Plan, runs: list[Run], series: list[RawSeries], *,
               limit: float | None = None, syncs: list[Sync] | None = None) -> tuple[BallbarMeasurement, list[Sync]]:
    """The measurement of raw ``series`` taken on ``machine`` along ``runs`` of ``plan`` (module docstring) and
    the synchronisation of each; ``syncs`` (one per series, e.g. refined by :mod:`.sync_refine`) replace the
    feed-in synchronisation."""
    st = plan.setup
    fb, L = st.fixed_ball, float(st.bar_length)
    matched = match_runs(series, runs)
    given, syncs = syncs, []
    parts = []
    for k, (s, run) in enumerate(zip(series, matched)):
        if s.bar_length is not None and not math.isclose(s.bar_length, L, rel_tol=1e-9):
            raise InputError(s.path, key="bar_length_mm", reason=f"key 'bar_length_mm': expected the plan's bar length {L * 1e3:g} mm, "
                             f"found {s.bar_length * 1e3:g} mm ({s.where('bar_length')})")
        if s.feed is not None and not math.isclose(s.feed, run.feed, rel_tol=1e-9):
            raise InputError(s.path, key="feed_mm_min", reason=f"key 'feed_mm_min': expected the program's feed {run.feed * 60e3:g} "
                             f"mm/min, found {s.feed * 60e3:g} mm/min ({s.where('feed')})")
        if s.direction is not None and s.direction != run.direction:
            raise InputError(s.path, key="direction", reason=f"key 'direction': expected {run.direction} (run {run.number}), found "
                             f"{s.direction} ({s.where('direction')})")
        sync = synchronise(s, run, fb, L, limit=limit, machine=machine, target=st.target) if given is None \
            else given[k]
        a, b = run.path_times
        tau = s.t - sync.start
        keep = (tau >= a - 1e-12) & (tau <= b + 1e-12)
        keep[:_lead_in(machine, run, st.target, tau, int(np.argmax(keep)))] = False
        parts.append((tau[keep], s.deviation[keep], run, s))
        syncs.append(Sync(**{**sync.__dict__, "kept": int(keep.sum())}))
    t_all, dev, poses, direction, feed = [], [], [], [], []
    offset = 0.0
    for tau, y, run, s in parts:
        t_all.append(offset + tau)
        dev.append(y)
        poses.append(run.poses(tau, st.target))
        direction += [run.direction] * len(tau)
        feed.append(np.full(len(tau), run.feed))
        offset += run.duration + 1.0  # runs 1 s apart (the dwells between them are not recorded)
    s0 = series[0]
    rng = st.measuring_range or QC10.range[1]
    notes = [(f"imported by pkmstiff from raw ball-bar series along plan '{plan.name}' (Assumption: constant feed "
             "from the feed-in ramp to the feed-out ramp)")]
    notes += [f"{sy.file}: run {sy.run}, feed-in start t = {sy.start:.6f} s ({'given' if sy.given else 'found'}), "
              f"synchronisation residual {sy.residual * 1e6:.3g} um, sigma {sy.sigma * 1e3:.2g} ms, feed-out shift "
              f"{sy.end_shift * 1e3:+.3g} ms"
              for sy in syncs]
    meas = BallbarMeasurement(bar_length=L, fixed_ball=fb.copy(), t=np.concatenate(t_all),
                              reading=np.concatenate(dev), poses=np.concatenate(poses), feed=np.concatenate(feed),
                              direction=np.array(direction), ball_offset=st.target.copy(), machine=machine.name,
                              device=s0.device, range=(-rng, rng),
                              accuracy=s0.accuracy if s0.accuracy is not None else QC10.accuracy,
                              sample_rate=float(s0.sample_rate), notes=notes)
    return meas, syncs


# ------------------------------------------------------------------------------------------------- simulation


def simulate_raw(machine: Machine, params: ParameterSet, delta: np.ndarray, plan: Plan, runs: list[Run], *,
                 sample_rate: float = QC10.sample_rate, sigma: float = 0.0, resolution: float = 0.0,
                 delays: np.ndarray | None = None, dwell: float = NCOptions.dwell, seed: int | None = None,
                 ) -> list[RawSeries]:
    """The raw series a ball bar records on ``machine`` with errors ``delta`` (backlash parameters included)
    running ``runs``: samples at ``sample_rate`` from the capture start, the motion starting ``delays`` [s] later
    (default: uniform 0.2..1.2 s per run from ``seed``) and the capture ending ``dwell`` after the run; white
    noise ``sigma`` [m], rounded to ``resolution`` [m] when positive."""
    rng = np.random.default_rng(seed)
    delays = rng.uniform(0.2, 1.2, len(runs)) if delays is None else np.asarray(delays, dtype=float)
    st = plan.setup
    taus, starts, x = [], [0], []
    for run, d in zip(runs, delays):
        t = np.arange(0.0, d + run.duration + dwell, 1.0 / sample_rate)
        taus.append(t)
        x.append(run.poses(t - d, st.target))
        starts.append(starts[-1] + len(t))
    X = np.concatenate(x)
    reached = reached_poses(machine, params, delta, X, starts=starts[:-1])
    R = cardan_matrix(reached[:, 3], reached[:, 4], reached[:, 5])
    Rc = cardan_matrix(X[:, 3], X[:, 4], X[:, 5])
    dev = readings(st, perturbed_state(st, params, delta), reached[:, :3], R, Rc)[:, 0] - st.bar_length
    dev = dev + (rng.standard_normal(len(dev)) * sigma if sigma > 0 else 0.0)
    if resolution > 0:
        dev = np.round(dev / resolution) * resolution
    rng_m = st.measuring_range or QC10.range[1]
    bad = np.flatnonzero(np.abs(dev) > rng_m)
    if bad.size:
        raise InadmissibleError(f"plan '{plan.name}': {bad.size} simulated raw readings outside the range "
                                f"±{rng_m * 1e3:g} mm, first {dev[bad[0]] * 1e3:+.4f} mm")
    out = []
    for k, (run, t) in enumerate(zip(runs, taus)):
        out.append(RawSeries(f"run{run.number}", t, dev[starts[k]:starts[k + 1]], sample_rate=sample_rate,
                             bar_length=float(st.bar_length), feed=run.feed, direction=run.direction,
                             segment=run.segment + 1, run=run.number))
    return out


__all__ = ["Sync", "import_raw", "kink_times", "match_runs", "simulate_raw", "synchronise"]
