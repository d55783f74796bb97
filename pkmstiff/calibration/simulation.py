"""Simulated ball-bar (and tracker / pose) measurements with a device model (Szatmári §4.3, Tab. 4.3–4.5).

Chain of effects per sample (all SI):

1. the plan's paths are sampled at the instrument's rate at a constant feed (continuous measurement, Szatmári
   §4.3.3.2); static point sets give one sample per pose after a dwell time;
2. commanded pose → nominal IK → forward kinematics of the machine with errors Δp (:mod:`.measurement`);
3. drive-space disturbances, moving the reached platform frame to first order through the inverse Jacobian
   (twist = J_C⁻¹⁺ Δq; the reading is then evaluated exactly):
   reversal backlash Δq_i = −b/2 · sign(q̇_i) (the drive lags by half the backlash in its direction of motion;
   Szatmári §4.3.3.1, Fig. 4.12, Tab. 4.6) and slow thermal strut growth
   Δl_i(t) = α · l_i · ΔT (1 − exp(−t/τ)) — **Assumption** (no source gives a thermal model): a first-order
   warm-up of every strut by ΔT with time constant τ, steel α = 11.5e-6 /K; a pod's strut growth acts as a drive
   offset, a glide's as Δq_i = Δl_i · |d_i| / (d_i · r_i);
4. white noise (σ from the instrument accuracy or the feed-dependent procedure uncertainty of Tab. 4.5) and
   quantisation to the resolution; range violations are reported.

**Assumption:** the ±0.5 µm accuracy and the Tab. 4.5 procedure uncertainties are read as 2σ bounds (k = 2), i.e.
σ = accuracy / 2 resp. U(feed) / 2, with U interpolated linearly in the feed.

Laser tracker and 6-D pose instrument (:class:`~pkmstiff.calibration.instruments.TrackerDevice`): the readings of
:func:`~pkmstiff.calibration.instruments.readings` with white noise per coordinate (σ = MPE / 2, the same k = 2
reading) and quantisation to the resolution; the instrument figures are **assumptions** for a typical
AT960-class tracker with a 6-D probe (no source of the project gives them; see :class:`~pkmstiff.calibration.instruments.TrackerDevice`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from pkmstiff.calibration.backlash import held_signs
from pkmstiff.calibration.instruments import BallbarDevice, Setup, TrackerDevice, readings, target_points
from pkmstiff.calibration.measurement import reached_poses
from pkmstiff.calibration.parameters import ParameterSet
from pkmstiff.calibration.plans import Plan, poses_for_target
from pkmstiff.errors import InadmissibleError, InputError
from pkmstiff.kinematics import as_poses, inverse_jacobian, inverse_kinematics
from pkmstiff.kinematics.rotation import cardan_matrix
from pkmstiff.machine import Machine

STEEL_ALPHA = 11.5e-6  # 1/K, Assumption: steel struts


#: a device (noise model) of an instrument: :class:`~pkmstiff.calibration.instruments.BallbarDevice` or
#: :class:`~pkmstiff.calibration.instruments.TrackerDevice`
Device = BallbarDevice | TrackerDevice


def default_device(plan: Plan) -> Device:
    """The default device of a plan's instrument: QC10 ball bar, or the assumed tracker / 6-D device."""
    return plan.instrument.default_device()


@dataclass(frozen=True)
class SimulationOptions:
    """How the measurement is run: path ``feed`` [m/s] (default 500 mm/min, Szatmári's quasi-static limit for
    Felix, §4.3.3.2), ``directions`` ("ccw", "cw" or both, "cw" being the plan's paths reversed), ``noise`` (see
    :meth:`~pkmstiff.calibration.instruments.BallbarDevice.sigma`), ``quantise`` to the resolution, ``backlash`` b [m] per drive, thermal drift
    ``drift_dT`` [K] with time constant ``drift_tau`` [s] and expansion coefficient ``alpha`` [1/K] (Assumption,
    see the module docstring), start temperature ``T0`` [°C], ``dwell`` [s] per static pose; ``deflection``
    ``"gravity"`` adds the elastic deflection of the perturbed machine under its weight (and ``deflection_load`` at
    the target) at the reached poses (:mod:`.deflection`, issue 17 item 4)."""

    feed: float = 500.0 / 60e3
    directions: tuple[str, ...] = ("ccw", "cw")
    noise: str | float = "instrument"
    quantise: bool = True
    backlash: float = 0.0
    drift_dT: float = 0.0
    drift_tau: float = 1800.0
    alpha: float = STEEL_ALPHA
    T0: float = 20.0
    dwell: float = 1.0
    seed: int | None = None
    deflection: str = "none"  #: "gravity": add the structure model's deflection (issue 17 item 4, :mod:`.deflection`)
    deflection_load: tuple[float, ...] | None = None  #: user load at the target, (3,) N or (6,) N, N m

    def __post_init__(self) -> None:
        if not self.feed > 0:
            raise InputError("simulation", "feed", "a positive feed", self.feed)
        for d in self.directions:
            if d not in ("ccw", "cw"):
                raise InputError("simulation", "directions", "ccw and/or cw", d)
        for key in ("backlash", "drift_tau", "dwell"):
            v = getattr(self, key)
            if not v >= 0:
                raise InputError("simulation", key, "a non-negative number", v)
        if self.deflection not in ("none", "gravity"):
            raise InputError("simulation", "deflection", "none or gravity", self.deflection)


@dataclass
class Samples:
    """The sampled measurement: commanded poses (N, 6), time [s], feed [m/s] (0 for static), direction labels,
    segment index per sample."""

    poses: np.ndarray
    t: np.ndarray
    feed: np.ndarray
    direction: np.ndarray
    segment: np.ndarray


@dataclass
class SimulationResult:
    """Simulated readings (N, k) [m, rad] with the samples; ``violations`` are sample indices whose reading
    leaves the instrument range (ball bar: the range about the bar length; tracker / pose: the measuring
    volume); ``sigma`` the (position) noise σ per sample [m]; ``temperature`` [°C]."""

    samples: Samples
    readings: np.ndarray
    clean: np.ndarray
    sigma: np.ndarray
    temperature: np.ndarray
    violations: np.ndarray
    notes: list[str] = field(default_factory=list)
    deviation: np.ndarray | None = None  #: ball bar: reading − bar length [m], quantised like the readings


# --------------------------------------------------------------------------------------------------- sampling


def _slerp_pairs(R: np.ndarray, k: np.ndarray, w: np.ndarray) -> np.ndarray:
    rot = Rotation.from_matrix(R)
    rel = (rot[k].inv() * rot[k + 1]).as_rotvec()
    return (rot[k] * Rotation.from_rotvec(rel * w[:, None])).as_matrix()


def resample_path(setup: Setup, poses: np.ndarray, step: float, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """Poses along a path at a constant arc-length ``step`` of the target point (m) and their arc length (m):
    positions interpolated linearly and, for a ball bar, put back on the sphere about the fixed ball (radius
    interpolated between the nodes), orientations by slerp. Returns (poses (M, 6), s (M,))."""
    x = as_poses(poses)
    if closed:
        x = np.vstack([x, x[:1]])
    R = cardan_matrix(x[:, 3], x[:, 4], x[:, 5])
    P = target_points(setup.state(), x[:, :3], R)
    ds = np.linalg.norm(np.diff(P, axis=0), axis=1)
    s = np.r_[0.0, np.cumsum(ds)]
    if len(x) < 2 or s[-1] <= 0:
        return x[:1].copy(), np.zeros(1)
    sq = np.arange(0.0, s[-1] * (1 - 1e-12), step) if not closed else np.arange(0.0, s[-1] - 0.5 * step, step)
    if not closed and s[-1] - sq[-1] > 1e-12:
        sq = np.r_[sq, s[-1]]
    k = np.clip(np.searchsorted(s, sq, side="right") - 1, 0, len(s) - 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(ds[k] > 0, (sq - s[k]) / ds[k], 0.0)
    Pq = P[k] + w[:, None] * (P[k + 1] - P[k])
    Pq = setup.instrument.project_path(setup, P, Pq, k, w)
    Rq = _slerp_pairs(R, k, w)
    return poses_for_target(Pq, Rq, setup.target), sq


def _is_closed(P: np.ndarray) -> bool:
    if len(P) < 3:
        return False
    step = np.median(np.linalg.norm(np.diff(P, axis=0), axis=1))
    return bool(np.linalg.norm(P[-1] - P[0]) < 1.5 * step)


def sample_plan(plan: Plan, device: Device, options: SimulationOptions) -> Samples:
    """The samples of a measurement along ``plan``: path segments at ``options.feed`` and the device's sample
    rate (one run per direction, ``cw`` reversed), point segments one sample per pose after ``options.dwell``."""
    step = options.feed / device.sample_rate
    parts, t0 = [], 0.0
    segs = plan.segments or ()
    for j, seg in enumerate(segs):
        x = plan.poses[seg.start:seg.stop]
        if getattr(seg, "kind", "path") == "points":
            t = t0 + options.dwell * np.arange(1, len(x) + 1)
            parts.append((x, t, np.zeros(len(x)), np.full(len(x), "ccw"), np.full(len(x), j)))
            t0 = t[-1]
            continue
        R = cardan_matrix(x[:, 3], x[:, 4], x[:, 5])
        closed = _is_closed(target_points(plan.setup.state(), x[:, :3], R))
        for d in options.directions:
            xx = x if d == "ccw" else x[::-1]
            if closed and d == "cw":
                xx = np.roll(xx, 1, axis=0)  # the cw run starts where the ccw run started
            q, s = resample_path(plan.setup, xx, step, closed)
            t = t0 + s / options.feed
            parts.append((q, t, np.full(len(q), options.feed), np.full(len(q), d), np.full(len(q), j)))
            t0 = t[-1] + 1.0 / device.sample_rate
    if not parts:
        raise InputError(plan.name, "segments", "at least one path or point set", 0)
    cols = list(zip(*parts))
    return Samples(*(np.concatenate(c) for c in cols))


# ------------------------------------------------------------------------------------------------- disturbances


def _run_cuts(segment: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Indices where a new run starts: the segment or the direction changes."""
    return np.flatnonzero((segment[1:] != segment[:-1]) | (direction[1:] != direction[:-1])) + 1


def backlash_offsets(drives: np.ndarray, segment: np.ndarray, direction: np.ndarray, b: float) -> np.ndarray:
    """Δq (N, n) = −b/2 · sign(q̇): the direction of motion of each drive from the commanded drive values of
    consecutive samples of one run, held through standstill; samples before a drive's first motion in a run take
    the sign of that first motion (:func:`pkmstiff.calibration.backlash.held_signs`)."""
    if b == 0 or len(drives) == 0:
        return np.zeros_like(drives)
    return -0.5 * b * held_signs(drives, _run_cuts(segment, direction))


def thermal_growth(t: np.ndarray, dT: float, tau: float) -> np.ndarray:
    """Temperature rise ΔT (1 − exp(−t/τ)) [K] (Assumption: first-order warm-up, module docstring)."""
    if dT == 0:
        return np.zeros_like(t)
    return dT * (1.0 - np.exp(-t / tau)) if tau > 0 else np.full_like(t, dT)


def drift_offsets(machine: Machine, ik, rise: np.ndarray, alpha: float) -> np.ndarray:
    """Drive-equivalent offsets (N, n) of a strut growth Δl_i = α l_i ΔT(t): pod Δq = Δl; glide
    Δq = Δl |d| / (d · r) (first order: the slider that keeps the grown strut's platform joint in place)."""
    dl = alpha * ik.length * rise[:, None]
    if ik.kind == "glide":
        r = machine.chains.guide_direction
        dr = np.einsum("nij,ij->ni", ik.d, r)
        return dl * ik.length / dr
    return dl


def displaced_frames(o: np.ndarray, R: np.ndarray, Jinv: np.ndarray, dq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Platform frames moved by drive offsets dq (N, n) to first order: twist (v, ω) = J_C⁻¹⁺ dq (at O'), then
    o + v and exp(ω) R. The reading itself is then evaluated exactly (a ball bar sees a motion normal to the bar in
    second order, which a linearised reading would lose)."""
    tw = np.einsum("nij,nj->ni", np.linalg.pinv(Jinv), dq)
    return o + tw[:, :3], np.einsum("nij,njk->nik", Rotation.from_rotvec(tw[:, 3:]).as_matrix(), R)


# --------------------------------------------------------------------------------------------------- simulate


def simulate(machine: Machine, params: ParameterSet, delta: np.ndarray, plan: Plan,
             device: Device | None = None, options: SimulationOptions | None = None,
             samples: Samples | None = None) -> SimulationResult:
    """Simulate a measurement along ``plan`` on ``machine`` with errors ``delta`` (module docstring); ``device``
    is the instrument's device (default: the plan's instrument's)."""
    device = device or default_device(plan)
    _check_match(plan, device)
    options = options or SimulationOptions()
    delta = params.check_vector(delta)
    smp = samples or sample_plan(plan, device, options)
    x = smp.poses
    ik = inverse_kinematics(machine, x)
    bad = np.flatnonzero(~ik.all_reachable)
    if bad.size:
        raise InadmissibleError(f"plan '{plan.name}': {bad.size} sampled poses unreachable by the nominal inverse "
                               f"kinematics, first sample {int(bad[0]) + 1}")
    reached = x if not np.any(delta[params.chain >= 0]) else reached_poses(
        machine, params, delta, x, starts=_run_cuts(smp.segment, smp.direction))
    o, R = reached[:, :3], cardan_matrix(reached[:, 3], reached[:, 4], reached[:, 5])
    Rc = cardan_matrix(x[:, 3], x[:, 4], x[:, 5])
    rise = thermal_growth(smp.t, options.drift_dT, options.drift_tau)
    notes = []
    if options.backlash > 0 or options.drift_dT != 0:
        dq = backlash_offsets(ik.drive, smp.segment, smp.direction, options.backlash)
        if options.drift_dT != 0:
            dq = dq + drift_offsets(machine, ik, rise, options.alpha)
            notes.append(f"Assumption: thermal strut growth alpha = {options.alpha:g} /K, dT = {options.drift_dT:g} K, "
                         f"tau = {options.drift_tau:g} s")
        if options.backlash > 0:
            notes.append(f"reversal backlash {options.backlash * 1e6:g} µm per drive")
        o, R = displaced_frames(o, R, inverse_jacobian(machine, ik), dq)
    from pkmstiff.calibration.setups import actual_state

    state = actual_state(machine, params, delta, plan.setup)
    if options.deflection == "gravity":  # the real (perturbed) machine deflects under its weight at reached poses
        from pkmstiff.calibration.deflection import deflect_frames, frame_deflection
        from pkmstiff.calibration.perturb import perturbed_machine

        tw = frame_deflection(perturbed_machine(machine, params, delta), reached, state.target,
                              options.deflection_load)
        o, R = deflect_frames(o, R, tw)
        from pkmstiff.structure import strut_mass_text

        notes.append(f"gravity deflection of the structure model added (Assumption: {strut_mass_text(machine)})")
    clean = readings(plan.setup, state, o, R, Rc)
    sigma = device.sigma(options.noise, smp.feed)
    rng = np.random.default_rng(options.seed)
    out = clean + (rng.standard_normal(clean.shape) * sigma[:, None] if np.any(sigma > 0) else 0.0)
    out, violations, dev = plan.instrument.finish_readings(device, plan.setup, options, clean, out, rng)
    return SimulationResult(smp, out, clean, sigma, options.T0 + rise, violations, notes, dev)


def check_samples(machine: Machine, plan: Plan, samples: Samples, max_list: int = 3) -> None:
    """Refuse a plan whose *sampled* poses (the spline / slerp interpolated poses between its nodes at constant
    feed, :func:`sample_plan`) leave the admissible region: a one-line :class:`InadmissibleError` listing the
    first ``max_list`` offending samples with their time, pose and failing App. B checks (as
    :func:`~pkmstiff.calibration.plans.check_plan` does for the nodes)."""
    from pkmstiff.admissibility import evaluate_poses
    from pkmstiff.calibration.plans import _fmt_pose

    ev = evaluate_poses(machine, samples.poses)
    bad = np.flatnonzero(~ev.ok)
    if not bad.size:
        return
    items = [f"sample {i + 1} (t = {samples.t[i]:.3f} s) {_fmt_pose(samples.poses[i])}: "
             f"{', '.join(ev.admissibility.failing(int(i)))}" for i in bad[:max_list]]
    more = f"; ... ({bad.size - max_list} more)" if bad.size > max_list else ""
    raise InadmissibleError(f"plan '{plan.name}': {bad.size} of {len(samples.poses)} sampled poses not admissible "
                           f"on {machine.name}: " + "; ".join(items) + more)


def _check_match(plan: Plan, device: Device) -> None:
    if not plan.instrument.accepts(device):
        raise InputError(plan.name, "instrument", f"a {plan.instrument} device for a "
                                    f"{plan.instrument} plan", type(device).__name__)


def range_error(plan: Plan, res: SimulationResult, device: Device) -> str:
    """The one-line report of range violations (empty when there are none)."""
    return plan.instrument.range_error(plan, res, device) if res.violations.size else ""


def to_measurement(machine: Machine, plan: Plan, res: SimulationResult, device: Device, saturate: bool = False):
    """The simulated run as a measurement of the plan's instrument
    (:class:`~pkmstiff.calibration.instruments.BallbarMeasurement`: reading = distance − bar length, ``saturate``
    clips out-of-range readings at the range limits, as the transducer would;
    :class:`~pkmstiff.calibration.instruments.PointMeasurement` for a tracker / pose plan)."""
    _check_match(plan, device)
    return plan.instrument.to_measurement(machine, plan, res, device, saturate,
                                          [f"simulated by pkmstiff from plan '{plan.name}'"] + res.notes)


__all__ = (
    "Device",
    "Samples",
    "SimulationOptions",
    "SimulationResult",
    "backlash_offsets",
    "check_samples",
    "default_device",
    "displaced_frames",
    "drift_offsets",
    "range_error",
    "resample_path",
    "sample_plan",
    "simulate",
    "thermal_growth",
    "to_measurement",
)
