"""The calibration workflow behind ``calibrate identify`` and ``calibrate report`` (issue 17; Szatmári §4.6, §5.4):
read a measurement, identify the machine's base parameters, estimate their uncertainty, build the calibrated machine
and check it on further measurements — returning typed results (SI) that the command line and the report only
render.

* :func:`identify_file` — one measurement file: its plan (commanded poses + nominal set-up) and readings, the error
  model, the identifiability of the measured poses (computed once and shared by every identification of that
  plan), the identification (:func:`~pkmstiff.calibration.identification.identify`) and its uncertainty
  (:func:`~pkmstiff.calibration.uncertainty.uncertainty`); with ``deflection="gravity"`` the predicted gravity
  deflection is subtracted first and its contribution analysed (:mod:`pkmstiff.calibration.deflection`); the
  model-fit diagnostics of the result (:func:`fit_diagnostics`, :mod:`pkmstiff.calibration.diagnostics`);
* :func:`run_calibration` — that, for a ball-bar file, plus the calibrated machine, the ball-bar circles of the
  measurement evaluated before and after (:mod:`pkmstiff.calibration.circles`) and the residuals of the nominal and
  the calibrated machine on every validation file (:func:`~pkmstiff.calibration.compensation.check`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.calibration.backlash import BLOCK as BACKLASH
from pkmstiff.calibration.backlash import has_backlash
from pkmstiff.calibration.ballbar import ball_positions
from pkmstiff.calibration.circles import CircleRun, circles
from pkmstiff.calibration.compensation import check, measurement_plan
from pkmstiff.calibration.deflection import (
    DeflectionAnalysis,
    DeflectionSummary,
    deflection_analysis,
    subtract_deflection,
)
from pkmstiff.calibration.diagnostics import Candidate, FitDiagnostics, diagnose
from pkmstiff.calibration.identifiability import Identifiability, check_identifiable, identifiability
from pkmstiff.calibration.identification import Identification, ResidualStats, identify, jacobian_at
from pkmstiff.calibration.instruments import BALL_BAR, BallbarMeasurement, instrument
from pkmstiff.calibration.jacobian import identification_jacobian, reading_weights
from pkmstiff.calibration.measurement_file import Measurement, read_measurement, read_measurement_setups
from pkmstiff.calibration.parameters import ParameterSet, error_model, parse_with
from pkmstiff.calibration.perturb import perturbed_machine
from pkmstiff.calibration.plans import Plan, read_plan
from pkmstiff.calibration.setups import PlanSet, parts, setups_error_model
from pkmstiff.calibration.uncertainty import Uncertainty, uncertainty
from pkmstiff.errors import InputError, NumericalError
from pkmstiff.machine import Machine

#: ``--deflection`` values of ``calibrate report`` ("none": the report says "not computed")
DEFLECTION_LOADS = ("none", "gravity")


@dataclass
class IdentificationRun:
    """One measurement identified (SI): the file ``measurements`` and its measurement ``meas``, the ``plan``
    (commanded poses + nominal set-up) with its readings ``measured`` (N, k), the error model ``params``, the
    identifiability ``ident`` of the measured poses, the identification ``res`` (with the deflection subtracted
    when ``deflection`` is not None) and its uncertainty ``unc``."""

    measurements: str
    meas: Measurement
    plan: Plan
    measured: np.ndarray
    params: ParameterSet
    ident: Identifiability
    res: Identification
    unc: Uncertainty
    deflection: DeflectionAnalysis | None = None
    diagnostics: FitDiagnostics | None = None

    @property
    def before(self) -> ResidualStats:
        """Residuals of the nominal machine (m)."""
        return ResidualStats.of(self.res.residual_before)

    @property
    def after(self) -> ResidualStats:
        """Residuals of the calibrated machine (m)."""
        return ResidualStats.of(self.res.residual_after)

    def calibrated_machine(self, machine: Machine) -> Machine:
        """``machine`` with the identified chain errors; set-up errors belong to the measurement, not to the
        machine (:mod:`pkmstiff.calibration.compensation`)."""
        delta = self.res.delta.copy()
        delta[self.params.chain < 0] = 0.0
        return perturbed_machine(machine, self.params, delta)


def identify_file(machine: Machine, measurements: str | Sequence[str], *, meas: Measurement | None = None,
                  method: str = "lm",
                  loss: str = "linear", frame: str = "cartesian", monte_carlo: int = 0, outlier_threshold: float = 3.0,
                  expected: str | None = None, deflection: str = "none", load: Any | None = None,
                  with_: str | None = None, robust: str | None = None) -> IdentificationRun:
    """Identify ``machine`` from the measurement file ``measurements`` (already read: ``meas``); ``expected``
    names the instrument the file must hold (``--instrument``); ``deflection="gravity"`` subtracts the predicted
    deflection (with the extra ``load`` at the target, N or N and N m) and analyses its bias; ``with_`` (``--with``
    tokens, e.g. ``"bar-offset"``) adds the set-up parameters of the measurement to the unknowns; ``robust``
    (``huber``, ``tukey``) down-weights outliers (IRLS, :func:`~pkmstiff.calibration.identification.identify`).

    Several files (``measurements`` a sequence; issue 26 item 3): one set-up each (fixed-ball position, bar length,
    ball offset or tracker station), identified together — the machine's parameters once, the ``--with`` set-up
    parameters per file (:mod:`pkmstiff.calibration.setups`); the diagnostics run on the stacked residuals with
    the files' sample times laid end to end."""
    files = [measurements] if isinstance(measurements, str) else list(measurements)
    paths, metas = [], []
    for k, p in enumerate(files):  # a file with a 'setup' column holds several set-ups
        got = [meas] if (meas is not None and not k) else read_measurement_setups(p)
        paths += [p] if len(got) == 1 else [f"{p} set-up {i + 1}" for i in range(len(got))]
        metas += got
    for p, mm in zip(paths, metas):
        if expected is not None and instrument(expected) != mm.instrument:
            raise InputError(p, "instrument", f"'{expected}' (--instrument), but the file holds "
                                        f"{mm.instrument} readings (header instrument_type)", mm.instrument.kind)
        if mm.instrument != metas[0].instrument:
            raise InputError(p, "instrument_type", f"{metas[0].instrument} readings as {paths[0]} (one instrument "
                                                   "per identification)", mm.instrument.kind)
    if len(paths) > 1 and deflection != "none":
        raise InputError("--deflection", "deflection", "'none' with several measurement files (the deflection "
                                                       "is subtracted from one file's readings)", deflection)
    meas = metas[0]
    blocks = parse_with(with_, meas.instrument)
    plans = [measurement_plan(mm, machine.name, p) for p, mm in zip(paths, metas)]
    if len(plans) == 1:
        plan, y = plans[0]
    else:
        plan = PlanSet(" + ".join(Path(p).name for p in paths), tuple(pl for pl, _ in plans))
        y = np.vstack([yy for _, yy in plans])
    measurements = ", ".join(files)
    params = setups_error_model(machine, plan, frame, blocks)
    ident = identifiability(machine, params, plan)
    check_identifiable(ident, measurements)  # an ill-posed measurement fails here, not after minutes of LM
    kw = dict(loss=loss, outlier_threshold=outlier_threshold, source=measurements, ident=ident, robust=robust)
    analysis = None
    if deflection == "gravity":
        analysis = deflection_analysis(machine, params, plan, y, method, load=load, **kw)
        res = analysis.corrected
    else:
        res = identify(machine, params, plan, y, method, **kw)
    unc = uncertainty(res, monte_carlo=monte_carlo)
    refit = None
    if analysis is None:
        def refit(a: int, b: int) -> np.ndarray | None:
            yr = y.copy()
            yr[a:b] = y[a:b][::-1]
            try:
                return identify(machine, params, plan, yr, method, **kw).residual_after
            except NumericalError:  # diverged or not evaluable: the hypothesis does not fit
                return None
    diag = fit_diagnostics(machine, meas if len(metas) == 1 else _stacked_times(metas), plan, params, res, unc,
                           refit)
    return IdentificationRun(measurements, meas, plan, y, params, ident, res, unc, analysis, diag)


def fit_diagnostics(machine: Machine, meas: Measurement, plan: Plan, params: ParameterSet, res: Identification,
                    unc: Uncertainty, refit_reversed: Callable[[int, int], np.ndarray | None] | None = None
                    ) -> FitDiagnostics:
    """:func:`~pkmstiff.calibration.diagnostics.diagnose` of an identification: the stated σ of the measurement's
    device, its sample times and directions, and every set-up parameter of the instrument not identified as an
    added-variable candidate (its Jacobian columns at the solution)."""
    inst = plan.instrument
    done = {params.blocks[i] for i in np.flatnonzero(params.chain < 0)} | ({BACKLASH} if has_backlash(params) else set())
    todo = {tok: blk for tok, blk in inst.setup_tokens.items() if blk not in done}
    cands = []
    if todo:
        full = setups_error_model(machine, plan, params.frame, tuple(sorted(done)) + tuple(todo.values()))
        d = np.zeros(full.n)
        d[full.indices(params.names)] = res.delta
        w = reading_weights(machine, inst, plan.n_poses)
        J = w[:, None] * jacobian_at(machine, full, plan, d)
        for tok, blk in todo.items():
            idx = np.flatnonzero(full.mask(blk))
            cands.append(Candidate(f"setup:{tok}", f"set-up parameter {tok} not identified", J[:, idx],
                                   tuple(full.names[i] for i in idx), tuple(full.units[i] for i in idx),
                                   f"identify with --with {tok}"))
    direction = getattr(meas, "direction", None)
    return diagnose(res.J, res.residual_after, inst.reading_sigma(meas),
                    reading_weights(machine, inst, 1), unc.sigma, reading_names=inst.reading_names,
                    reading_units=inst.reading_units, t=np.asarray(meas.t, dtype=float), direction=direction,
                    candidates=tuple(cands), refit_reversed=refit_reversed, robust_weights=res.robust_weights)


def _stacked_times(metas: Sequence[Measurement]) -> Measurement:
    """The first measurement with the sample times and directions of all laid end to end (each file starts one
    sample interval after the previous one ends): what the diagnostics of a stacked identification read (only
    its times, directions and device figures)."""
    t, off = [], 0.0
    for mm in metas:
        tt = np.asarray(mm.t, dtype=float)
        t.append(tt - tt[0] + off)
        off = t[-1][-1] + (1.0 / mm.sample_rate if getattr(mm, "sample_rate", 0) else 1.0)
    dirs = [getattr(mm, "direction", None) for mm in metas]
    direction = None if any(d is None for d in dirs) else np.concatenate(dirs)
    extra = {"direction": direction} if hasattr(metas[0], "direction") else {}
    return dataclasses.replace(metas[0], t=np.concatenate(t), **extra)


@dataclass
class Validation:
    """Residuals (m) of the nominal (``before``) and the calibrated machine (``after``) on one further measurement
    file ``path``, and its ball-bar circles evaluated on both."""

    path: str
    before: np.ndarray
    after: np.ndarray
    circles: list[CircleRun] = field(default_factory=list)

    @property
    def before_stats(self) -> ResidualStats:
        return ResidualStats.of(self.before)

    @property
    def after_stats(self) -> ResidualStats:
        return ResidualStats.of(self.after)


@dataclass
class CalibrationRun:
    """Everything the calibration report shows (SI): the machine, the identification of the ball-bar file
    (:class:`IdentificationRun`), the calibrated machine, the circles of the measurement, the validations, the
    optional plan file (only described and drawn), the parameter frame and the deflection contribution
    (``--deflection gravity``, else None)."""

    machine: Machine
    run: IdentificationRun
    calibrated: Machine
    circles: list[CircleRun]
    validations: list[Validation]
    plan_file: Plan | None = None
    plan_path: str | None = None
    frame: str = "cartesian"
    with_: str | None = None
    #: several set-ups (issue 26 item 3): their measurements, residual row slices and their identifiability
    #: alone (the stacked one is ``ident``); empty for one set-up
    setups: list[SetupPart] = field(default_factory=list)
    files: list[str] = field(default_factory=list)

    # the parts of the identification the report shows
    @property
    def measurements(self) -> str:
        return self.run.measurements

    @property
    def file_names(self) -> str:
        """The measurement files' names (without folders), comma separated."""
        return ", ".join(Path(f).name for f in (self.files or [self.measurements]))

    @property
    def meas(self) -> BallbarMeasurement:
        return self.run.meas

    @property
    def plan(self) -> Plan:
        return self.run.plan

    @property
    def params(self) -> ParameterSet:
        return self.run.params

    @property
    def ident(self) -> Identifiability:
        return self.run.ident

    @property
    def res(self) -> Identification:
        return self.run.res

    @property
    def unc(self) -> Uncertainty:
        return self.run.unc

    @property
    def deflection(self) -> DeflectionSummary | None:
        return None if self.run.deflection is None else self.run.deflection.summary()

    def ball_points(self) -> np.ndarray:
        """Moving-ball centres of the identification measurement's commanded poses (N, 3), m."""
        if not self.setups:
            return ball_positions(self.plan.poses, self.meas.ball_offset)
        return np.vstack([ball_positions(self.plan.poses[s.rows], s.meas.ball_offset) for s in self.setups])


@dataclass
class SetupPart:
    """One set-up of a several-set-up calibration run: its measurement, label, rows of the stacked readings and
    what it identifies alone (the machine's parameters and its own set-up parameters)."""

    label: str
    meas: BallbarMeasurement
    rows: slice
    ident: Identifiability


def _ballbar_files(path: str) -> list[BallbarMeasurement]:
    """The set-ups of a ball-bar measurement file; another instrument's file is a one-line error (the report's
    plan, circle and polar-plot parts are ball-bar specific)."""
    metas = read_measurement_setups(path)
    for meas in metas:
        if not isinstance(meas, BallbarMeasurement):
            raise InputError(path, "instrument", "a ball-bar measurement file (calibrate report evaluates "
                                        "ball-bar circles; use calibrate identify / check for this file)",
                                        meas.instrument.kind)
    return metas


def _ballbar_file(path: str) -> BallbarMeasurement:
    metas = _ballbar_files(path)
    if len(metas) > 1:
        raise InputError(path, "setup", "a measurement of one set-up (a validation file)",
                         f"{len(metas)} set-ups")
    return metas[0]


def _circles(meas: BallbarMeasurement, plan: Plan, before: np.ndarray, after: np.ndarray,
             source: str) -> list[CircleRun]:
    return circles(ball_positions(plan.poses, meas.ball_offset), meas.direction, meas.fixed_ball, meas.bar_length,
                   before, after, source)


def run_calibration(machine: Machine, measurements: str | Sequence[str], *, plan_path: str | None = None,
                    validate: Sequence[str] = (), method: str = "lm", loss: str = "linear",
                    frame: str = "cartesian", monte_carlo: int = 0, deflection: str = "none",
                    with_: str | None = None, robust: str | None = None) -> CalibrationRun:
    """Identify ``machine``'s base parameters from the ball-bar file ``measurements`` and check the result on every
    ``validate`` file (module docstring). ``plan_path`` (a plan file) is only described and drawn; the
    identification uses the commanded poses of the measurement. ``deflection="gravity"`` does what
    ``calibrate identify/check --deflection gravity`` do: the predicted gravity deflection is subtracted from the
    readings before identification and validation, and the bias without it is recorded. ``with_`` (``--with``)
    identifies the set-up parameters with the machine and fits them anew on every validation file (a set-up
    error belongs to its measurement).

    Several set-ups (several files, or a file with a ``setup`` column; issue 26 item 3) are identified together
    (:func:`identify_file`); the run then records each set-up's residual rows, circles and what it would
    identify alone (:class:`SetupPart`)."""
    files = [measurements] if isinstance(measurements, str) else list(measurements)
    plan_file = read_plan(plan_path) if plan_path else None
    if plan_file is not None and plan_file.instrument != BALL_BAR:
        raise InputError(plan_path, "plan.instrument", "a ball-bar plan (the measurement is a ball-bar "
                                    "file)", plan_file.instrument.kind)
    metas, labels = [], []
    for f in files:
        got = _ballbar_files(f)
        metas += got
        labels += [f] if len(got) == 1 else [f"{f} set-up {i + 1}" for i in range(len(got))]
    meas = metas[0]
    vals = []
    for v in validate:  # read every file before the (slower) identification: bad input fails fast
        vm = _ballbar_file(v)
        vals.append((v, vm, *measurement_plan(vm, machine.name, v)))
    run = identify_file(machine, files[0] if len(files) == 1 else files, meas=meas if len(metas) == 1 else None,
                        method=method, loss=loss, frame=frame, monte_carlo=monte_carlo, deflection=deflection,
                        with_=with_, robust=robust)
    blocks = parse_with(with_, meas.instrument)
    calibrated = run.calibrated_machine(machine)
    setups, found = [], []
    if len(metas) == 1:
        found = _circles(meas, run.plan, run.res.residual_before, run.res.residual_after, files[0])
    else:
        for (part, sub, _, rows), mm, lab in zip(parts(run.plan, run.params), metas, labels):
            setups.append(SetupPart(lab, mm, rows, identifiability(machine, sub, part)))
            for c in _circles(mm, part, run.res.residual_before[rows], run.res.residual_after[rows], lab):
                found.append(dataclasses.replace(c, label=f"{Path(lab).name}: {c.label}",
                                                 index=c.index + rows.start))
    validations = []
    for v, vm, vplan, vy in vals:
        y0 = y1 = vy
        if deflection == "gravity":  # each machine's own deflection at the poses it reaches
            y0, _ = subtract_deflection(machine, machine, vplan, vy)
            y1, _ = subtract_deflection(calibrated, machine, vplan, vy)
        r0 = check(machine, machine, vplan, y0, blocks).residual
        r1 = check(calibrated, machine, vplan, y1, blocks).residual
        validations.append(Validation(v, r0, r1, _circles(vm, vplan, r0, r1, v)))
    return CalibrationRun(machine=machine, run=run, calibrated=calibrated, circles=found, validations=validations,
                          plan_file=plan_file, plan_path=plan_path, frame=frame, with_=with_, setups=setups,
                          files=files)




def check_diagnostics(machine: Machine, controller: Machine, meas: Measurement, plan: Plan, residual: np.ndarray,
                      blocks: tuple[str, ...] = ()) -> FitDiagnostics:
    """The model-fit diagnostics of ``calibrate check`` (:mod:`pkmstiff.calibration.diagnostics`): the residual of
    a machine file against a measurement, with nothing fitted but the set-up ``blocks`` (``--with``; their columns
    at the nominal set-up); the set-up parameters not fitted are tested as candidates, as in ``identify``."""
    inst = plan.instrument
    full = error_model(machine, setup=plan.setup, setup_blocks=tuple(inst.setup_tokens.values()))
    w = reading_weights(machine, inst, plan.n_poses)
    Jall = w[:, None] * identification_jacobian(controller, dataclasses.replace(full, machine=controller.name),
                                                plan).J
    fitted = np.flatnonzero(np.isin(full.blocks, blocks) & (full.chain < 0))
    J = Jall[:, fitted]
    psig = np.ones(fitted.size)
    if fitted.size:
        from pkmstiff.calibration.uncertainty import covariance

        psig = np.sqrt(np.diag(covariance(J, residual, fitted.size)[0]))
    cands = []
    for tok, blk in inst.setup_tokens.items():
        if blk in blocks:
            continue
        idx = np.flatnonzero(full.mask(blk))
        cands.append(Candidate(f"setup:{tok}", f"set-up parameter {tok} not fitted", Jall[:, idx],
                               tuple(full.names[i] for i in idx), tuple(full.units[i] for i in idx),
                               f"check with --with {tok}"))
    return diagnose(J, residual, inst.reading_sigma(meas), reading_weights(machine, inst, 1), psig,
                    reading_names=inst.reading_names, reading_units=inst.reading_units,
                    t=np.asarray(meas.t, dtype=float), direction=getattr(meas, "direction", None),
                    candidates=tuple(cands))


__all__ = ["DEFLECTION_LOADS", "CalibrationRun", "IdentificationRun", "Validation", "check_diagnostics",
           "fit_diagnostics", "identify_file", "run_calibration"]
