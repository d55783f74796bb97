"""Deflection-aware calibration (issue 17 item 4, beyond the sources): the elastic TCP deflection under gravity (and
an optional load) from the structure model (Cobet §4.2–4.7, eq. 4.70–4.72; :mod:`pkmstiff.analysis.gravity`),
its effect on the instrument readings, its subtraction before identification, and the bias it causes otherwise.

* **Deflection** δ = C(x)·w generalised to the weight of every mass of the structure model: ``K q = f_g + f_load``
  per pose (stacked solves), the tool body's motion read at the tool point.  Which masses are loaded and which are
  not is stated in :mod:`pkmstiff.analysis.gravity` (Assumption: the strut masses as the machine file's
  ``strut_mass_shares`` lump them; masses at rigidly suspended drives go straight into the frame).  A machine
  without stiffness data (e.g. Felix) has no structure model: a one-line error.
* **Readings** (:func:`reading_deflection`): the platform frame (o, R) the machine reaches is moved by the
  deflection twist of the tool body referred to O' (u_O' = u_v − θ × R v for the twist (u_v, θ) at the target v),
  o + u_O', exp(θ) R, and the reading is evaluated exactly there (:func:`~pkmstiff.calibration.instruments.
  readings`): ball bar the length change of the displaced moving ball, tracker the target's displacement, 6-D
  the position and orientation change.
* **Subtraction** (``--deflection gravity``, :func:`identify_with_deflection`): y − Δr(p̂) with Δr first at the
  nominal machine and commanded poses, then re-evaluated at the estimate p̂ (perturbed machine at the poses it
  reaches, perturbed set-up) and identified again.  The nominal Δr is right to first order only: the deflection
  of the real machine differs by O(|Δp|/L) (mm errors on m-sized chains): on the Hexaglide with 1.75 mm errors
  7 µm in the readings of a 270 µm deflection, and 0.8 mm in the parameters (the deflection falls into poorly
  conditioned directions).  Each re-evaluation multiplies the parameter error by a contraction factor (measured:
  ≈ 0.02 on the Hexaglide, ≈ 2e-4 on the Hexapod 6X), so a few re-evaluations reach the forward kinematics'
  tolerance (noise-free ≤ 1e-9 m); they stop when Δr changes by ≤ 1e-12 m.
* **Bias** (:func:`deflection_analysis`): identifying the raw readings biases the base parameters by, to first
  order, b = (JᵀJ)⁻¹Jᵀ Δr (weighted J of the corrected identification, the least-squares image of the
  reading deflection); it is reported next to the actual difference of the two identifications.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from pkmstiff.calibration.identification import Identification, identify
from pkmstiff.calibration.instruments import Setup, SetupState, readings
from pkmstiff.calibration.jacobian import reading_weights
from pkmstiff.calibration.measurement import reached_poses
from pkmstiff.calibration.parameters import ParameterSet
from pkmstiff.calibration.perturb import perturbed_machine, perturbed_state
from pkmstiff.calibration.plans import Plan
from pkmstiff.errors import CalibrationError, CalibrationInputError, StructureModelError
from pkmstiff.kinematics import as_poses
from pkmstiff.kinematics.rotation import cardan_matrix
from pkmstiff.machine import Machine
from pkmstiff.structure import strut_mass_text

DEFLECTION_MODELS = ("none", "gravity")


def check_deflection(model: str, source: str = "--deflection") -> str:
    """The deflection model name (``none`` or ``gravity``), else a one-line error."""
    if model not in DEFLECTION_MODELS:
        raise CalibrationInputError(source, "deflection", f"one of {', '.join(DEFLECTION_MODELS)}", model)
    return model


def split_load(load: Any | None, source: str = "load") -> tuple[np.ndarray, np.ndarray]:
    """A user load (None, a force (3,) [N] or force and moment (6,) [N, N m]) as (force, moment)."""
    if load is None:
        return np.zeros(3), np.zeros(3)
    w = np.asarray(load, dtype=float).reshape(-1)
    if w.size not in (3, 6) or not np.all(np.isfinite(w)):
        raise CalibrationInputError(source, "load", "a force Fx,Fy,Fz [N] or Fx,Fy,Fz,Mx,My,Mz [N, N m]", load)
    return w[:3].copy(), (w[3:] if w.size == 6 else np.zeros(3)).copy()


def _no_structure_model(machine: Machine, exc: StructureModelError) -> CalibrationInputError:
    return CalibrationInputError(machine.name, "components", "stiffness and mass data (a structure model) for the "
                                 "deflection; use --deflection none or a machine file with components",
                                 f"none usable ({exc.expected})")


def require_structure_model(machine: Machine) -> None:
    """One-line error before any work when ``machine`` has no structure model (e.g. Felix: kinematics only)."""
    from pkmstiff.structure.layout import structure_layout

    try:
        structure_layout(machine)
    except StructureModelError as exc:
        raise _no_structure_model(machine, exc) from None


def gravity_deflection(machine: Machine, poses: np.ndarray, load: Any | None = None,
                       tool_length: float | np.ndarray | None = None, gravity: np.ndarray | None = None,
                       weight: bool = True) -> np.ndarray:
    """TCP deflection (N, 6) [m, rad] under the structure's weight (``weight``) and an optional user ``load``
    (force (3,) [N] or force and moment (6,) [N, N m], acting at the TCP) at poses (N, 6); the TCP is the machine's
    tool tip, ``tool_length`` [m] or a tool vector (3,) [m, PKS] (the calibration set-up's target v).  Cobet's
    structure model (module docstring of :mod:`pkmstiff.analysis.gravity`: which masses are loaded); issue 17
    item 4.  A pose the structure model cannot take is a one-line :class:`CalibrationError`."""
    from pkmstiff.analysis.gravity import gravity_deflection as _solve

    force, moment = split_load(load)
    x = as_poses(poses)
    try:
        d = _solve(machine, x, tool_length=tool_length, gravity=gravity, force=force, moment=moment, weight=weight)
    except StructureModelError as exc:
        raise _no_structure_model(machine, exc) from None
    bad = np.flatnonzero(~np.isfinite(d).all(axis=1))
    if bad.size:
        raise CalibrationError(f"machine '{machine.name}': the structure model cannot take {bad.size} of {len(x)} "
                               f"poses (singular or a component out of range), first pose {int(bad[0]) + 1}; "
                               "the deflection is undefined there")
    return d


def frame_deflection(machine: Machine, poses: np.ndarray, target: np.ndarray, load: Any | None = None,
                     gravity: np.ndarray | None = None) -> np.ndarray:
    """Deflection twist (N, 6) of the tool body referred to the platform origin O': (u_O', θ) with
    u_O' = u_v − θ × R v from the twist (u_v, θ) at the target v (PKS), where the user load acts."""
    x = as_poses(poses)
    tv = np.asarray(target, dtype=float).reshape(3)
    d = gravity_deflection(machine, x, load, tool_length=tv, gravity=gravity)
    arm = cardan_matrix(x[:, 3], x[:, 4], x[:, 5]) @ tv
    return np.concatenate([d[:, :3] - np.cross(d[:, 3:], arm), d[:, 3:]], axis=1)


def deflect_frames(o: np.ndarray, R: np.ndarray, twist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Platform frames moved by deflection twists (N, 6) at O': o + u, exp(θ) R."""
    return o + twist[:, :3], np.einsum("nij,njk->nik", Rotation.from_rotvec(twist[:, 3:]).as_matrix(), R)


def _plan_of(plan_or_measurement: Any, machine: Machine) -> Plan:
    if isinstance(plan_or_measurement, Plan):
        return plan_or_measurement
    from pkmstiff.calibration.compensation import measurement_plan

    return measurement_plan(plan_or_measurement, machine.name, "measurement")[0]


def readings_change(machine: Machine, setup: Setup, state: SetupState, reached: np.ndarray, commanded: np.ndarray,
                    load: Any | None = None, gravity: np.ndarray | None = None) -> np.ndarray:
    """Change (N, k) of the readings when ``machine`` (the real one) at its ``reached`` poses deflects (module
    docstring); ``commanded`` poses give the orientation reference of the pose instrument."""
    o, R = reached[:, :3], cardan_matrix(reached[:, 3], reached[:, 4], reached[:, 5])
    Rc = cardan_matrix(commanded[:, 3], commanded[:, 4], commanded[:, 5])
    tw = frame_deflection(machine, reached, state.target, load, gravity)
    od, Rd = deflect_frames(o, R, tw)
    return readings(setup, state, od, Rd, Rc) - readings(setup, state, o, R, Rc)


def reading_deflection(machine: Machine, plan_or_measurement: Any, params: ParameterSet | None = None,
                       delta: np.ndarray | None = None, load: Any | None = None,
                       gravity: np.ndarray | None = None) -> np.ndarray:
    """Change of every instrument reading (m,) = (N·k,) [m, rad] caused by the deflection at the measured poses
    (ball bar: length change from the displaced tool ball; tracker: target displacement; pose: position and
    orientation change; :attr:`~pkmstiff.calibration.instruments.Instrument.reading_names` order).  With ``params``/``delta`` the
    machine and set-up carry those errors and deflect at the poses they reach (else: nominal machine at the
    commanded poses).  ``plan_or_measurement``: a :class:`Plan` or a ball-bar measurement."""
    plan = _plan_of(plan_or_measurement, machine)
    x = as_poses(plan.poses)
    if params is None or delta is None or not np.any(delta):
        return readings_change(machine, plan.setup, plan.setup.state(), x, x, load, gravity).reshape(-1)
    delta = params.check_vector(delta)
    real = perturbed_machine(machine, params, delta)
    reached = x if not np.any(delta[params.chain >= 0]) else reached_poses(machine, params, delta, x)
    return readings_change(real, plan.setup, perturbed_state(plan.setup, params, delta), reached, x, load,
                           gravity).reshape(-1)


def identify_with_deflection(machine: Machine, params: ParameterSet, plan: Plan, measured: np.ndarray,
                             method: str = "lm", *, load: Any | None = None, gravity: np.ndarray | None = None,
                             refine: int = 8, tol: float = 1e-12, **kwargs: Any) -> tuple[Identification, np.ndarray]:
    """Identification of the readings with the predicted deflection subtracted: Δr at the nominal machine, then
    ``refine`` re-evaluations at the estimate (module docstring: why), each followed by an identification started
    at the previous estimate; stops early when Δr changes by ≤ ``tol`` m.  Returns the identification (its
    ``residual_before`` is that of the corrected readings at the nominal machine) and the Δr used (N·k,)."""
    y = np.asarray(measured, dtype=float).reshape(plan.n_poses, -1)
    dr = reading_deflection(machine, plan, load=load, gravity=gravity)
    res = identify(machine, params, plan, y - dr.reshape(y.shape), method, **kwargs)
    before = res.residual_before
    for _ in range(max(int(refine), 0)):
        new = reading_deflection(machine, plan, params, res.delta, load=load, gravity=gravity)
        change = float(np.max(np.abs(new - dr)))
        dr = new
        if change <= tol:
            break
        res = identify(machine, params, plan, y - dr.reshape(y.shape), method, delta0=res.delta, base=res.base,
                       **kwargs)
    res.residual_before = before
    return res, dr


@dataclass(frozen=True)
class ParameterBias:
    """Deflection-induced bias of one identified parameter (``unit`` "m" or "rad"): first-order ``predicted`` and
    ``actual`` (difference of the two identifications), SI."""

    name: str
    unit: str
    predicted: float
    actual: float


@dataclass(frozen=True)
class DeflectionSummary:
    """The deflection's contribution to a calibration, SI: ``gravity`` (3,) m/s², the user load at the target
    ``force`` (3,) N and ``moment`` (3,) N m; ``n_readings``; RMS and largest reading change of the length
    readings ``rms_reading`` / ``max_reading`` (m) and of the orientation readings ``rms_reading_angle`` /
    ``max_reading_angle`` (rad, None without such readings); the target point's largest translation ``tcp_max``
    (m), mean translation ``tcp_mean`` (3,) m and largest rotation ``tcp_rotation_max`` (rad) over the plan
    (nominal machine, commanded poses); the ``bias`` of every identified base parameter and
    ``bias_relative_deviation`` ‖actual − predicted‖/‖predicted‖ (scaled unknowns); the residual RMS of the
    identifications with and without the subtraction (m); ``notes``."""

    gravity: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    n_readings: int
    rms_reading: float
    max_reading: float
    rms_reading_angle: float | None
    max_reading_angle: float | None
    tcp_max: float
    tcp_mean: np.ndarray
    tcp_rotation_max: float
    bias: tuple[ParameterBias, ...]
    bias_relative_deviation: float
    rms_after_corrected: float
    rms_after_uncorrected: float
    notes: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        """JSON-ready record; keys name their unit (µm, µrad), biases in SI with their ``unit``."""
        out: dict[str, Any] = {
            "model": "gravity", "gravity_m_s2": [float(v) for v in self.gravity],
            "load_N": [float(v) for v in self.force], "load_N_m": [float(v) for v in self.moment],
            "n_readings": self.n_readings, "rms_reading_um": self.rms_reading * 1e6,
            "max_reading_um": self.max_reading * 1e6, "tcp_max_um": self.tcp_max * 1e6,
            "tcp_mean_um": [float(v) * 1e6 for v in self.tcp_mean],
            "tcp_rotation_max_urad": self.tcp_rotation_max * 1e6,
            "bias": [{"name": b.name, "unit": b.unit, "predicted": b.predicted, "actual": b.actual}
                     for b in self.bias],
            "bias_relative_deviation": self.bias_relative_deviation,
            "rms_after_corrected_um": self.rms_after_corrected * 1e6,
            "rms_after_uncorrected_um": self.rms_after_uncorrected * 1e6,
            "notes": list(self.notes),
        }
        if self.rms_reading_angle is not None:
            out["rms_reading_urad"] = self.rms_reading_angle * 1e6
            out["max_reading_urad"] = self.max_reading_angle * 1e6
        return out


@dataclass
class DeflectionAnalysis:
    """Identification with and without the deflection subtracted and the bias of the base parameters (SI).

    ``reading`` (m,) the reading deflection Δr subtracted (at the corrected estimate); ``tcp`` (N, 6) the TCP
    deflection at the target point (nominal machine, commanded poses); ``predicted`` and ``actual`` (n_base,)
    biases Δp_uncorrected − Δp_corrected of the base parameters, first-order and from the two identifications.
    """

    corrected: Identification
    uncorrected: Identification
    reading: np.ndarray
    tcp: np.ndarray
    predicted: np.ndarray
    actual: np.ndarray
    load: tuple[np.ndarray, np.ndarray]
    gravity: np.ndarray
    notes: list[str] = field(default_factory=list)

    @property
    def relative_deviation(self) -> float:
        """‖actual − predicted‖ / ‖predicted‖ in the scaled unknowns (Δp / scale: 1 mm, 1 mrad)."""
        s = self.corrected.params.scale[self.corrected.base]
        den = float(np.linalg.norm(self.predicted / s))
        return float(np.linalg.norm((self.actual - self.predicted) / s)) / den if den > 0 else 0.0

    def _length_rows(self) -> np.ndarray:
        units = self.corrected.plan.instrument.reading_units
        return np.tile(np.array([u == "m" for u in units]), self.corrected.plan.n_poses)

    def summary(self) -> DeflectionSummary:
        """The contribution in figures (SI, :class:`DeflectionSummary`)."""
        rows = self._length_rows()
        dl, da = self.reading[rows], self.reading[~rows]
        p = self.corrected.params
        return DeflectionSummary(
            gravity=np.asarray(self.gravity, dtype=float), force=np.asarray(self.load[0], dtype=float),
            moment=np.asarray(self.load[1], dtype=float), n_readings=int(self.reading.size),
            rms_reading=float(np.sqrt(np.mean(dl ** 2))) if dl.size else 0.0,
            max_reading=float(np.max(np.abs(dl))) if dl.size else 0.0,
            rms_reading_angle=float(np.sqrt(np.mean(da ** 2))) if da.size else None,
            max_reading_angle=float(np.max(np.abs(da))) if da.size else None,
            tcp_max=float(np.max(np.linalg.norm(self.tcp[:, :3], axis=1))),
            tcp_mean=self.tcp[:, :3].mean(axis=0),
            tcp_rotation_max=float(np.max(np.linalg.norm(self.tcp[:, 3:], axis=1))),
            bias=tuple(ParameterBias(p.names[i], p.units[i], float(b), float(a))
                       for i, b, a in zip(self.corrected.base, self.predicted, self.actual)),
            bias_relative_deviation=self.relative_deviation,
            rms_after_corrected=float(np.sqrt(np.mean(self.corrected.residual_after ** 2))),
            rms_after_uncorrected=float(np.sqrt(np.mean(self.uncorrected.residual_after ** 2))),
            notes=tuple(self.notes))

    def to_dict(self) -> dict:
        """SI record (see :func:`deflection_contribution` for the keys)."""
        return self.summary().to_dict()

    def report(self) -> dict:
        """JSON-ready record for the command line: as :meth:`to_dict`, biases in mm (lengths) / µrad (angles)."""
        out = self.to_dict()
        rows = []
        for b in out.pop("bias"):
            f, unit = (1e3, "mm") if b["unit"] == "m" else (1e6, "urad")
            rows.append({"name": b["name"], f"predicted_{unit}": b["predicted"] * f,
                         f"actual_{unit}": b["actual"] * f})
        out["bias"] = rows
        return out


def deflection_analysis(machine: Machine, params: ParameterSet, plan: Plan, measured: np.ndarray,
                        method: str = "lm", *, load: Any | None = None, gravity: np.ndarray | None = None,
                        refine: int = 8, corrected: Identification | None = None,
                        uncorrected: Identification | None = None, **kwargs: Any) -> DeflectionAnalysis:
    """Identify with the deflection subtracted (:func:`identify_with_deflection`) and without, and the bias of
    every identified base parameter: predicted b = (JᵀWᵀWJ)⁻¹JᵀWᵀW Δr (weighted Jacobian J of the corrected
    identification, W the row weights) next to the actual difference (module docstring).  Identifications
    already computed can be passed in (``corrected`` then needs its Δr recomputed at its estimate)."""
    g = np.asarray(machine.gravity if gravity is None else gravity, dtype=float)
    if corrected is None:
        corrected, dr = identify_with_deflection(machine, params, plan, measured, method, load=load, gravity=g,
                                                 refine=refine, **kwargs)
    else:
        dr = reading_deflection(machine, plan, params, corrected.delta, load=load, gravity=g)
    if uncorrected is None:
        uncorrected = identify(machine, params, plan, measured, method, base=corrected.base, **kwargs)
    w = reading_weights(machine, plan.instrument, plan.n_poses)
    predicted = np.linalg.lstsq(corrected.J, w * dr, rcond=None)[0]
    actual = uncorrected.delta[corrected.base] - corrected.delta[corrected.base]
    tv = plan.setup.target
    tcp = gravity_deflection(machine, plan.poses, load, tool_length=tv, gravity=g)
    how = f"first at nominal, then re-evaluated at the estimate, up to {refine} times"
    notes = [f"deflection subtracted at the identified machine ({how})",
             f"Assumption: {strut_mass_text(machine)}; masses at rigidly suspended drives carried by the frame"]
    return DeflectionAnalysis(corrected, uncorrected, dr, tcp, predicted, actual, split_load(load), g, notes)


def subtract_deflection(machine: Machine, controller: Machine, plan: Plan, measured: np.ndarray,
                        load: Any | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Readings of ``machine`` (the machine under test, e.g. a calibrated file) with its predicted deflection
    removed: the drive values ``controller`` commanded for ``plan``'s poses move ``machine`` to the poses it
    reaches, where its deflection changes the readings by Δr.  Returns (measured − Δr, Δr) [m, rad]."""
    from pkmstiff.calibration.compensation import moved_poses
    from pkmstiff.calibration.measurement import commanded_drives

    reached = moved_poses(machine, commanded_drives(controller, plan.poses), plan.poses)
    dr = readings_change(machine, plan.setup, plan.setup.state(), reached, plan.poses, load)
    return measured - dr.reshape(measured.shape), dr


def deflection_contribution(machine: Machine, params: ParameterSet, plan: Plan, measured: np.ndarray,
                            method: str = "lm", *, load: Any | None = None, gravity: np.ndarray | None = None,
                            refine: int = 8, **kwargs: Any) -> dict:
    """The deflection's contribution to a calibration (for the calibration report), SI unless the key names a unit:

    * ``model`` ("gravity"), ``gravity_m_s2`` (3,), ``load_N`` / ``load_N_m`` (3,) the user load at the target;
    * ``n_readings``; ``rms_reading_um`` / ``max_reading_um``: RMS and largest |Δr| of the length readings caused
      by the deflection; ``rms_reading_urad`` / ``max_reading_urad`` for orientation readings (pose instrument);
    * ``tcp_max_um`` largest translation of the target point over the plan, ``tcp_mean_um`` (3,) its mean vector,
      ``tcp_rotation_max_urad`` the largest rotation (nominal machine, commanded poses);
    * ``bias``: one entry per identified base parameter ``{"name", "unit" ("m"|"rad"), "predicted", "actual"}``,
      the deflection-induced bias Δp_without − Δp_with in SI, first-order (JᵀJ)⁻¹JᵀΔr and from the two
      identifications; ``bias_relative_deviation`` ‖actual − predicted‖/‖predicted‖ (scaled unknowns);
    * ``rms_after_corrected_um`` / ``rms_after_uncorrected_um``: residual RMS of the two identifications;
    * ``notes``: how the deflection was subtracted, assumptions.

    ``measured`` (N, k) readings of ``plan`` [m, rad]; further keywords go to
    :func:`~pkmstiff.calibration.identification.identify`.
    """
    return deflection_analysis(machine, params, plan, measured, method, load=load, gravity=gravity, refine=refine,
                               **kwargs).to_dict()


__all__ = (
    "DEFLECTION_MODELS",
    "DeflectionAnalysis",
    "DeflectionSummary",
    "ParameterBias",
    "check_deflection",
    "deflect_frames",
    "deflection_analysis",
    "deflection_contribution",
    "require_structure_model",
    "subtract_deflection",
    "frame_deflection",
    "gravity_deflection",
    "identify_with_deflection",
    "reading_deflection",
    "readings_change",
    "split_load",
)
