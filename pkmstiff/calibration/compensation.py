"""Compensation: the calibrated machine file, residual checks of any machine file against a measurement, and the
TCP error of a controller model on a real machine (issue 17 item 3; Szatmári §5.4; Denkena §1.3, Table 1).

The calibrated machine is a machine file that ``extends`` the nominal one with the identified chain geometry
(:func:`~pkmstiff.calibration.perturb.machine_file_text`) and a ``[calibration]`` provenance table (validated by
the machine loader). The corrected inverse kinematics is then simply the calibrated machine's IK. Set-up
parameters (ball offset, fixed ball, ...) belong to the measurement, not to the machine, and are not written.

Check (validation on any data): the readings are predicted as the machine under test moving to the drive values
the *nominal* controller commanded for the measurement's poses (the controller that took the measurement), with
the nominal instrument set-up of the measurement file — or, with set-up blocks (``--with``), with the set-up
parameters of that measurement fitted first (Gauss–Newton on the set-up columns only, the machine held fixed),
since a set-up error belongs to each measurement and not to the machine.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import hashlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pkmstiff.calibration.backlash import run_starts_of_samples
from pkmstiff.calibration.identification import Identification, noise_estimate, residual_stats, setup_at
from pkmstiff.calibration.instruments import Setup, SetupState, readings, target_points
from pkmstiff.calibration.jacobian import reading_weights
from pkmstiff.calibration.measurement import commanded_drives
from pkmstiff.calibration.parameters import error_model
from pkmstiff.calibration.perturb import machine_file_text, perturbed_state
from pkmstiff.calibration.plans import Plan
from pkmstiff.calibration.uncertainty import Uncertainty
from pkmstiff.errors import InadmissibleError, InputError, NumericalError
from pkmstiff.io.atomic import atomic_write_text
from pkmstiff.kinematics import as_poses, forward_kinematics, inverse_kinematics
from pkmstiff.kinematics.rotation import cardan_matrix
from pkmstiff.machine import Machine


def file_sha256(path: str | Path) -> str:
    """SHA-256 hex digest of a file's bytes (the measurement file of the provenance block)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _q(value: float, unit: str) -> str:
    return f'"{value * 1e3:.9g} mm"' if unit == "m" else f'"{value * 1e3:.9g} mrad"'


def provenance(res: Identification, unc: Uncertainty | None = None,
               measurement: str | Path | Sequence[str | Path] | None = None, date: str | None = None,
               deflection: str = "none") -> dict:
    """The ``[calibration]`` table of a calibrated machine file (units in the key names or values); ``deflection``
    records what was subtracted from the readings before identification ("none", "gravity", "gravity + load …");
    several measurement files (one per set-up): the first as ``measurement_file``, the others in
    ``more_measurement_files`` / ``more_measurement_sha256``."""
    import pkmstiff

    r0, r1 = residual_stats(res.residual_before), residual_stats(res.residual_after)
    out = {"nominal_machine": res.machine.name, "method": res.method, "loss": res.loss, "rank": res.rank,
           "n_readings": res.n_readings, "condition_number": float(res.condition_number),
           "rms_before_um": r0["rms_um"], "rms_after_um": r1["rms_um"], "max_before_um": r0["max_abs_um"],
           "max_after_um": r1["max_abs_um"], "s_um": noise_estimate(res.residual_after, res.rank) * 1e6,
           "date": date or _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
           "toolkit_version": pkmstiff.__version__, "scaling": res.scaling,
           "gauge_freedoms": [g.label() for g in res.gauge_freedoms], "deflection": deflection}
    more = []
    if measurement is not None and not isinstance(measurement, (str, Path)):
        measurement, *more = list(measurement)
    if measurement is not None:
        out["measurement_file"] = str(Path(measurement).name)
        out["measurement_sha256"] = file_sha256(measurement)
        header = Path(measurement).with_suffix(".json")  # the header beside the CSV (files written since issue 22)
        if header.is_file():
            out["measurement_header_sha256"] = file_sha256(header)
    if more:
        out["more_measurement_files"] = [str(Path(p).name) for p in more]
        out["more_measurement_sha256"] = [file_sha256(p) for p in more]
    out["identified"] = {nm: float(res.delta[i]) for nm, i in zip(res.base_names, res.base)}
    if unc is not None:
        out["sigma"] = {nm: float(s) for nm, s in zip(unc.names, unc.sigma)}
    return out


def _toml_scalar(v: object) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v) if np.isfinite(v) else "1e308"
    if isinstance(v, list):
        return "[" + ", ".join(_toml_scalar(x) for x in v) + "]"
    raise TypeError(type(v))


def calibrated_machine_text(res: Identification, unc: Uncertainty | None = None,
                            measurement: str | Path | Sequence[str | Path] | None = None, name: str | None = None,
                            date: str | None = None, deflection: str = "none") -> str:
    """TOML of the calibrated machine: ``extends`` the nominal machine, the identified chain geometry and the
    ``[calibration]`` provenance block (identified values and σ as quantities in mm / mrad)."""
    machine, params = res.machine, res.params
    delta = res.delta.copy()
    delta[params.chain < 0] = 0.0  # set-up errors belong to the measurement, not to the machine
    text = machine_file_text(machine, params, delta, name=name or machine.name + "_calibrated",
                             title=machine.title + " (calibrated)")
    prov = provenance(res, unc, measurement, date, deflection)
    lines = [text.rstrip("\n"), "", "[calibration]"]
    for k, v in prov.items():
        if k not in ("identified", "sigma"):
            lines.append(f"{k} = {_toml_scalar(v)}")
    for table in ("identified", "sigma"):
        if table in prov:
            lines += ["", f"[calibration.{table}]"]
            for nm, v in prov[table].items():
                lines.append(f'"{nm}" = {_q(v, params.units[params.index(nm)])}')
    return "\n".join(lines) + "\n"


def write_calibrated_machine(path: str | Path, res: Identification, unc: Uncertainty | None = None,
                             measurement: str | Path | Sequence[str | Path] | None = None, name: str | None = None,
                             deflection: str = "none") -> Path:
    p = Path(path)
    atomic_write_text(p, calibrated_machine_text(res, unc, measurement, name, deflection=deflection))
    return p


def moved_poses(real: Machine, drives: np.ndarray, start: np.ndarray, tol: float = 1e-13) -> np.ndarray:
    """Poses (N, 6) ``real`` reaches for drive values (N, n), forward kinematics started at ``start`` (N, 6)."""
    fk = forward_kinematics(real, drives, start, tol_q=tol, tol_x=tol)
    if not fk.converged.all():
        raise NumericalError(f"machine '{real.name}': the forward kinematics did not converge for "
                               f"{int((~fk.converged).sum())} poses; is the machine file the one measured?")
    return fk.poses


def _reached_frames(machine: Machine, controller: Machine, plan: Plan):
    x = as_poses(plan.poses)
    reached = moved_poses(machine, commanded_drives(controller, x), x)
    return reached[:, :3], cardan_matrix(reached[:, 3], reached[:, 4], reached[:, 5]), \
        cardan_matrix(x[:, 3], x[:, 4], x[:, 5])


def predicted_readings(machine: Machine, controller: Machine, plan: Plan) -> np.ndarray:
    """Readings (N, k) predicted by ``machine`` for the drive values ``controller`` commands for the plan's poses
    (nominal set-up of the plan)."""
    o, R, Rc = _reached_frames(machine, controller, plan)
    return readings(plan.setup, placed_state(machine, controller, plan.setup), o, R, Rc)


def placed_state(machine: Machine, controller: Machine, setup: Setup) -> SetupState:
    """The nominal set-up state, with a fixed ball placed by the machine (:mod:`.setups`) where ``machine`` puts it
    for the drive values ``controller`` commands at the placing pose."""
    st = setup.state()
    if setup.placing_pose is None:
        return st
    probe = Plan("placing pose", setup, setup.placing_pose[None, :])
    (o,), (R,), _ = _reached_frames(machine, controller, probe)
    (oc,), (Rc,), _ = _reached_frames(controller, controller, probe)
    return dataclasses.replace(st, fixed_ball=st.fixed_ball + (o + R @ setup.target) - (oc + Rc @ setup.target))


#: Gauss–Newton iterations of :func:`fit_setup` (the set-up model is smooth; 3–5 suffice from the nominal set-up)
SETUP_FIT_ITERATIONS = 20


def fit_setup(machine: Machine, controller: Machine, plan: Plan, measured: np.ndarray,
              blocks: tuple[str, ...]) -> tuple[np.ndarray, tuple[tuple[str, float, str], ...]]:
    """Residuals (m, weighted rows as in the identification) of ``machine`` against ``measured`` with the set-up
    ``blocks`` of the measurement fitted (the machine held fixed): Gauss–Newton min ‖W (y − y(s))‖ over the
    set-up parameters s (minimum-norm steps, so set-up directions the readings do not see stay at zero).
    Returns (residual, ((parameter name, value, unit), ...)) in SI."""
    inst = plan.instrument
    if "backlash" in blocks:  # a machine parameter: fitting it needs the perturbed forward kinematics
        raise InputError("--with", "backlash", "set-up parameters only (the machine is held fixed; identify the "
                         "backlash with calibrate identify --with backlash)", "backlash")
    params = error_model(machine, setup=plan.setup, setup_blocks=blocks)
    idx = np.flatnonzero(params.chain < 0)
    o, R, Rc = _reached_frames(machine, controller, plan)
    y = np.asarray(measured, dtype=float).reshape(-1)
    N, k = plan.n_poses, inst.n_readings
    w = reading_weights(machine, inst, N)
    d = np.zeros(params.n)
    scale = params.scale[idx]
    placed = placed_state(machine, controller, plan.setup)

    def state(d: np.ndarray) -> SetupState:  # the set-up errors on top of where the machine placed the fixed ball
        st = perturbed_state(plan.setup, params, d)
        if plan.setup.placing_pose is None:
            return st
        return dataclasses.replace(st, fixed_ball=st.fixed_ball + placed.fixed_ball - plan.setup.fixed_ball)

    for _ in range(SETUP_FIT_ITERATIONS):
        st = state(d)
        r = w * (y - readings(plan.setup, st, o, R, Rc).reshape(-1))
        J = np.zeros((N, k, params.n))
        inst.setup_jacobian(J, params, setup_at(plan.setup, params, d), R, target_points(st, o, R))
        A = w[:, None] * J.reshape(N * k, params.n)[:, idx] * scale[None, :]
        step = np.linalg.lstsq(A, r, rcond=1e-10)[0]
        d[idx] += scale * step
        if np.max(np.abs(step)) < 1e-12:  # scaled unknowns (1 mm, 1 mrad): below 1 fm
            break
    r = w * (y - readings(plan.setup, state(d), o, R, Rc).reshape(-1))
    return r, tuple((params.names[i], float(d[i]), params.units[i]) for i in idx)


@dataclass(frozen=True)
class Check:
    """Residuals y_meas − y_predicted (m, flattened) of a machine file against a measurement."""

    machine: str
    controller: str
    residual: np.ndarray
    setup: tuple[tuple[str, float, str], ...] | None = None  # fitted set-up (name, value, unit), SI; None: nominal

    def to_dict(self) -> dict:
        out = {"machine": self.machine, "controller": self.controller, "n_readings": int(self.residual.size),
               **residual_stats(self.residual)}
        if self.setup is not None:
            out["setup_fitted"] = [{"name": nm, "value_mm" if u == "m" else "value_mrad": v * 1e3}
                                   for nm, v, u in self.setup]
        return out


def check(machine: Machine, controller: Machine, plan: Plan, measured: np.ndarray,
          setup_blocks: tuple[str, ...] = ()) -> Check:
    """Residuals of ``machine`` against readings ``measured`` (N, k) taken with ``controller`` commanding
    ``plan`` (validation of a calibrated machine on data not used for identification); ``setup_blocks``
    (``--with``) are fitted to the measurement first (:func:`fit_setup`)."""
    y = np.asarray(measured, dtype=float).reshape(plan.n_poses, -1)
    if y.shape[1] != plan.setup.n_readings:
        raise InputError(plan.name, "readings", f"{plan.setup.n_readings} readings per pose",
                                    y.shape[1])
    if setup_blocks:
        r, fitted = fit_setup(machine, controller, plan, y, tuple(setup_blocks))
        return Check(machine.name, controller.name, r, fitted)
    return Check(machine.name, controller.name, (y - predicted_readings(machine, controller, plan)).reshape(-1))


def tcp_errors(real: Machine, controller: Machine, poses: np.ndarray, point: np.ndarray | None = None) -> np.ndarray:
    """Position errors (N,) in m of a platform point (default: the pose origin, PKS) when ``controller``'s inverse
    kinematics commands ``poses`` and the ``real`` machine moves (compensation = controller is the calibrated
    machine; Denkena Table 1)."""
    x = as_poses(poses)
    ik = inverse_kinematics(controller, x)
    if not ik.all_reachable.all():
        raise InadmissibleError(f"machine '{controller.name}' cannot reach every pose of the plan")
    reached = moved_poses(real, ik.drive, x)
    v = np.zeros(3) if point is None else np.asarray(point, dtype=float)
    R = cardan_matrix(reached[:, 3], reached[:, 4], reached[:, 5])
    Rc = cardan_matrix(x[:, 3], x[:, 4], x[:, 5])
    return np.linalg.norm(reached[:, :3] + R @ v - x[:, :3] - Rc @ v, axis=1)


def measurement_plan(meas: object, machine_name: str, source: str) -> tuple[Plan, np.ndarray]:
    """Plan (commanded poses + nominal set-up) and readings of a measurement taken on the machine
    ``machine_name``: ball bar (N, 1) in m (the full ball distance: the file's reading + bar length); tracker
    (N, 3) target positions in m; pose (N, 6) positions in m and orientation errors in rad (the order of
    :attr:`~pkmstiff.calibration.instruments.Instrument.reading_names`). A file of another machine or without commanded poses is
    a one-line error saying what to do."""
    if meas.machine and meas.machine != machine_name.split(":")[0]:
        raise InputError(source, "machine", f"a measurement taken on '{machine_name}' (give the machine "
                                    f"the file was measured on, '{meas.machine}', or the right file)", meas.machine)
    if meas.poses is None:
        raise InputError(source, "x_mm ... c_deg", "the commanded pose columns (identification needs the "
                                    "commanded poses; export them with the readings)", "drive columns only")
    setup, y = meas.instrument.measured(meas)
    poses = np.asarray(meas.poses, dtype=float)
    runs = run_starts_of_samples(meas.t, getattr(meas, "direction", None), poses, getattr(meas, "feed", None))
    return Plan(f"measurement {Path(source).name}", setup, poses, runs=runs), y
