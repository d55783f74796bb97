"""The laser tracker: the target position in the instrument frame, Qᵀ (o + R (v + Δv) − τ), three readings per
pose; the assumed AT960-class device and the point measurement (shared with the 6-D pose instrument,
:mod:`.pose`)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pkmstiff.calibration.instruments.base import Instrument, Setup, SetupState, target_points
from pkmstiff.calibration.instruments.file_format import check_version, fmt, names, numbers, scalars, vec
from pkmstiff.errors import InputError

Array = NDArray[np.float64]

POSITION_COLUMNS = ("px_mm", "py_mm", "pz_mm")
POINT_UNITS_LINE = ("t_s s; x_mm y_mm z_mm mm; a_deg b_deg c_deg deg (commanded pose); px_mm py_mm pz_mm mm "
                    "(measured target position, instrument frame); rx_urad ry_urad rz_urad urad (measured "
                    "orientation error, rotation vector); feed_mm_min mm/min; temperature_C degC")


@dataclass(frozen=True)
class TrackerDevice:
    """A laser tracker, with a 6-DoF probe for the pose instrument. Every figure is an **Assumption** (typical
    data-sheet values of an AT960-class tracker; the project's sources give none), one reason each:

    * ``sample_rate`` 1000 Hz: the output rate such trackers offer for dynamic measurement;
    * ``resolution`` 0.1 µm: the distance (ADM/IFM) display resolution;
    * position MPE = ``mpe_constant`` 15 µm + ``mpe_per_m`` 6 µm/m × distance: the usual form and size of a
      tracker's ISO 10360-10 maximum permissible error;
    * ``standoff`` 2 m: the tracker stands beside the machine, about 2 m from the workspace, so the MPE is
      evaluated at 2 m (27 µm);
    * ``volume_radius`` 20 m: the 6-DoF probe range of such trackers (readings beyond are out of range);
    * ``angle_accuracy`` 175 µrad (0.01°) MPE and ``angle_resolution`` 1 µrad: 6-DoF probe (T-Mac class) data.

    σ = MPE / 2 per coordinate (k = 2, as for the ball bar)."""

    name: str = "laser tracker (AT960 class, assumed)"
    sample_rate: float = 1000.0
    resolution: float = 0.1e-6
    mpe_constant: float = 15e-6
    mpe_per_m: float = 6e-6
    standoff: float = 2.0
    volume_radius: float = 20.0
    angle_resolution: float = 1e-6
    angle_accuracy: float = 175e-6

    def __post_init__(self) -> None:
        for key in ("sample_rate", "resolution", "mpe_constant", "mpe_per_m", "standoff", "volume_radius",
                    "angle_resolution", "angle_accuracy"):
            v = getattr(self, key)
            if not (np.isfinite(v) and v >= 0) or (key in ("sample_rate", "volume_radius") and v <= 0):
                raise InputError("instrument", key, "a positive number", v)

    @property
    def accuracy(self) -> float:
        """Position MPE at the standoff distance [m]."""
        return self.mpe_constant + self.mpe_per_m * self.standoff

    def sigma(self, noise: str | float, feed: np.ndarray | float) -> np.ndarray:
        """Position σ per sample [m]: ``none``, ``instrument`` (MPE / 2) or a number (σ in m); the ball-bar
        ``procedure`` model (Szatmári Tab. 4.5) does not apply to a tracker."""
        f = np.asarray(feed, dtype=float)
        if isinstance(noise, str):
            if noise == "none":
                return np.zeros_like(f)
            if noise == "instrument":
                return np.full_like(f, self.accuracy / 2.0)
            raise InputError("--noise", "noise", "none, instrument or a sigma for a tracker / pose "
                                        "instrument (procedure is the ball-bar model of Szatmari Tab. 4.5)", noise)
        return np.full_like(f, float(noise))

    def angle_sigma(self, noise: str | float) -> float:
        """Orientation σ [rad]: 0 for ``none``, angle MPE / 2 otherwise (a numeric σ sets the position only)."""
        return 0.0 if noise == "none" else self.angle_accuracy / 2.0


AT960 = TrackerDevice()


@dataclass
class PointMeasurement:
    """One laser-tracker or 6-D pose measurement (``instrument``) in SI units.

    Header: ``target`` (3,) [m] (the target / reference point in the platform frame), the ``device`` name (header
    key ``instrument``), ``volume_radius`` [m] (largest distance of a reading from the instrument-frame origin),
    ``resolution`` [m], the position MPE ``accuracy`` + ``accuracy_per_m`` · distance [m, m/m] at the ``standoff``
    distance [m], ``angle_resolution`` and ``angle_accuracy`` [rad] (pose), ``sample_rate`` [Hz], ``notes``.
    Samples (N,): ``t`` [s], ``position`` (N, 3) [m] measured target positions in the instrument frame,
    ``rotation`` (N, 3) [rad] measured orientation errors (rotation vectors; pose only, else None), commanded
    ``poses`` (N, 6) / ``drives`` as for the ball bar, ``feed`` [m/s], ``direction``, ``temperature`` [°C],
    ``lines`` (file line per sample when read).
    """

    instrument: Tracker
    t: Array
    position: Array
    rotation: Array | None = None
    poses: Array | None = None
    drives: Array | None = None
    drive_units: tuple[str, ...] = ()
    feed: Array | None = None
    direction: NDArray[np.str_] | None = None
    temperature: Array | None = None
    target: Array = field(default_factory=lambda: np.zeros(3))
    machine: str = ""
    device: str = ""
    volume_radius: float = AT960.volume_radius
    resolution: float = AT960.resolution
    accuracy: float = AT960.mpe_constant
    accuracy_per_m: float = AT960.mpe_per_m
    standoff: float = AT960.standoff
    angle_resolution: float = AT960.angle_resolution
    angle_accuracy: float = AT960.angle_accuracy
    sample_rate: float = AT960.sample_rate
    notes: list[str] = field(default_factory=list)
    lines: NDArray[np.int64] | None = None

    def __post_init__(self) -> None:
        from pkmstiff.calibration.instruments.registry import instrument

        self.instrument = instrument(self.instrument, "measurement")

    @property
    def n_samples(self) -> int:
        return int(self.t.size)

    @property
    def readings(self) -> Array:
        """Readings (N, 3) or (N, 6) [m, rad] in the order of the instrument's ``reading_names``."""
        return self.position if self.rotation is None else np.hstack([self.position, self.rotation])


class Tracker(Instrument):
    """Laser tracker: the target point's position in the instrument frame."""

    kind = "tracker"
    title = "laser tracker"
    reading_names = ("x", "y", "z")
    reading_units = ("m",) * 3
    setup_tokens = {"target-offset": "target_offset", "instrument-frame": "instrument_frame"}
    file_columns = POSITION_COLUMNS
    header_keys = ("target_mm", "volume_radius_mm", "accuracy_um_per_m", "standoff_mm")

    # ---------------------------------------------------------------------------------------------- readings
    def readings(self, setup: Setup, state: SetupState, o: np.ndarray, R: np.ndarray,
                 R_cmd: np.ndarray) -> np.ndarray:
        return (target_points(state, o, R) - state.frame_translation) @ state.frame_rotation

    def reading_twist(self, setup: Setup, m: np.ndarray, Rv: np.ndarray, source: str) -> np.ndarray:
        H = np.zeros((len(m), self.n_readings, 6))
        H[:, 0:3, 0:3] = np.eye(3)
        H[:, 0:3, 3:6] = -_skew(Rv)
        return H

    def setup_column(self, block: str, component: str, axis: np.ndarray, setup: Setup, R: np.ndarray,
                     m: np.ndarray) -> np.ndarray:
        col = np.zeros((len(m), self.n_readings))
        if block == "target_offset":
            col[:, 0:3] = R @ axis
        elif block == "instrument_frame":
            col[:, 0:3] = np.cross(m, axis) if component.startswith("r") else -axis
        else:
            return super().setup_column(block, component, axis, setup, R, m)
        return col

    # ---------------------------------------------------------------------------------------------- plans
    def default_plans(self, machine: Any, centre: np.ndarray, setup: Setup) -> Iterator[Any]:
        """A 3×3×3 grid of ±150 mm about the workspace centre, three orientations per point (then ±100, ±50 mm;
        tilt 10, then 5 deg)."""
        from pkmstiff.calibration.plans import grid_plan

        for hw in (0.15, 0.1, 0.05):
            for tilt in (10.0, 5.0):
                yield grid_plan(setup, centre, hw, tilt=np.radians(tilt), torsion=np.radians(tilt),
                                name=f"default grid 3^3 ±{hw * 1e3:g} mm, tilt {tilt:g} deg")

    # ---------------------------------------------------------------------------------------------- devices
    def default_device(self) -> TrackerDevice:
        return AT960

    def device(self, setup: Setup, *, sample_rate: float | None = None, range: float | None = None,
               resolution: float | None = None, accuracy: float | None = None,
               angle_accuracy: float | None = None) -> TrackerDevice:
        """The AT960-class device with the figures given: ``range`` the radius of the measuring volume,
        ``accuracy`` the constant part of the MPE."""
        if angle_accuracy is not None and self.n_readings < 6:
            raise InputError("--angle-accuracy", "angle_accuracy", "a pose (6-D) plan", self.kind)
        d = AT960
        return TrackerDevice(sample_rate=d.sample_rate if sample_rate is None else sample_rate,
                             volume_radius=d.volume_radius if range is None else range,
                             resolution=d.resolution if resolution is None else resolution,
                             mpe_constant=d.mpe_constant if accuracy is None else accuracy,
                             angle_accuracy=d.angle_accuracy if angle_accuracy is None else angle_accuracy)

    # ---------------------------------------------------------------------------------------------- simulation
    def finish_readings(self, device: TrackerDevice, setup: Setup, options: Any, clean: np.ndarray,
                        noisy: np.ndarray, rng: np.random.Generator):
        """Quantisation to the position resolution; the samples beyond the measuring volume."""
        out = noisy.copy()
        if options.quantise and device.resolution > 0:
            out[:, :3] = np.round(out[:, :3] / device.resolution) * device.resolution
        return out, np.flatnonzero(np.linalg.norm(out[:, :3], axis=1) > device.volume_radius), None

    def range_error(self, plan: Any, res: Any, device: TrackerDevice) -> str:
        v = res.violations
        i = int(v[0])
        return (f"plan '{plan.name}': {v.size} of {len(res.readings)} simulated readings beyond the {device.name}'s "
                f"measuring volume of radius {device.volume_radius * 1e3:g} mm, first at sample {i + 1} "
                f"(t = {res.samples.t[i]:.3f} s, {np.linalg.norm(res.readings[i, :3]) * 1e3:.1f} mm)")

    def simulation_summary(self, plan: Any, res: Any) -> dict:
        """Largest deviation of the reading from the commanded target position."""
        from pkmstiff.kinematics.rotation import cardan_matrix

        x = res.samples.poses
        cmd = target_points(plan.setup.state(), x[:, :3], cardan_matrix(x[:, 3], x[:, 4], x[:, 5]))
        return {"position_error_max_um": float(np.linalg.norm(res.readings[:, :3] - cmd, axis=1).max() * 1e6)}

    def to_measurement(self, machine: Any, plan: Any, res: Any, device: TrackerDevice, saturate: bool,
                       notes: list[str]) -> PointMeasurement:
        return PointMeasurement(instrument=self, t=res.samples.t, position=res.readings[:, :3],
                                rotation=res.readings[:, 3:6] if self.n_readings == 6 else None,
                                poses=res.samples.poses, feed=res.samples.feed,
                                direction=res.samples.direction.astype(str), temperature=res.temperature,
                                target=plan.setup.target.copy(), machine=machine.name, device=device.name,
                                volume_radius=device.volume_radius, resolution=device.resolution,
                                accuracy=device.mpe_constant, accuracy_per_m=device.mpe_per_m,
                                standoff=device.standoff, angle_resolution=device.angle_resolution,
                                angle_accuracy=device.angle_accuracy, sample_rate=device.sample_rate, notes=notes)

    # ---------------------------------------------------------------------------------------------- measurements
    def measured(self, meas: PointMeasurement) -> tuple[Setup, np.ndarray]:
        return Setup(self, target=np.asarray(meas.target, dtype=float)), np.asarray(meas.readings, dtype=float)

    def reading_sigma(self, meas: PointMeasurement) -> np.ndarray:
        """Position: MPE at the standoff / 2; orientation (pose): angle MPE / 2 (as :class:`TrackerDevice`)."""
        pos = (meas.accuracy + meas.accuracy_per_m * meas.standoff) / 2.0
        return np.array([pos if u == "m" else meas.angle_accuracy / 2.0 for u in self.reading_units])

    def range_violations(self, meas: PointMeasurement) -> np.ndarray:
        return np.flatnonzero(np.linalg.norm(meas.position, axis=1) > meas.volume_radius)

    def range_message(self, meas: PointMeasurement, bad: np.ndarray) -> str:
        i = int(bad[0])
        return (f"{bad.size} reading(s) farther than the instrument's {meas.volume_radius * 1e3:g} mm from its "
                f"origin, first at sample {i} (t = {meas.t[i]:g} s)")

    def check_measurement(self, src: str, meas: PointMeasurement) -> None:
        """Orientation readings present exactly for an instrument with six readings."""
        if (meas.rotation is None) != (self.n_readings == 3):
            raise InputError(src, reason="a pose measurement needs orientation readings, a tracker "
                                       "measurement none")

    def header_lines(self, meas: PointMeasurement) -> list[str]:
        return [f"# target_mm: {vec(np.asarray(meas.target), 1e-3)}",
                f"# volume_radius_mm: {fmt(meas.volume_radius / 1e-3)}",
                f"# resolution_um: {fmt(meas.resolution / 1e-6)}",
                f"# accuracy_um: {fmt(meas.accuracy / 1e-6)}",
                f"# accuracy_um_per_m: {fmt(meas.accuracy_per_m / 1e-6)}",
                f"# standoff_mm: {fmt(meas.standoff / 1e-3)}"] + self._angle_header(meas) + [
                f"# sample_rate_hz: {fmt(meas.sample_rate)}", f"# units: {POINT_UNITS_LINE}"]

    def _angle_header(self, meas: PointMeasurement) -> list[str]:
        return []

    def reading_columns(self, meas: PointMeasurement) -> list[tuple[str, np.ndarray]]:
        return [(name, meas.position[:, j] / 1e-3) for j, name in enumerate(POSITION_COLUMNS)]

    #: scalar header keys (key, attribute, scale to SI, zero allowed), in file order
    SCALAR_KEYS: tuple[tuple[str, str, float, bool], ...] = (
        ("volume_radius_mm", "volume_radius", 1e-3, False), ("resolution_um", "resolution", 1e-6, True),
        ("accuracy_um", "accuracy", 1e-6, True), ("accuracy_um_per_m", "accuracy_per_m", 1e-6, True),
        ("standoff_mm", "standoff", 1e-3, True), ("angle_resolution_urad", "angle_resolution", 1e-6, True),
        ("angle_accuracy_urad", "angle_accuracy", 1e-6, True), ("sample_rate_hz", "sample_rate", 1.0, False))

    def parse_header(self, src: str, header: dict[str, tuple[int, str]]) -> dict:
        """Every key optional (defaults: the assumed AT960-class figures of :class:`TrackerDevice`)."""
        check_version(src, header)
        meta: dict = {}
        if (h := header.get("target_mm")) is not None:
            meta["target"] = np.array(numbers(src, h[0], "target_mm", h[1], 3)) * 1e-3
        scalars(src, header, self.SCALAR_KEYS, meta)
        names(header, meta)
        return meta

    def from_columns(self, src: str, column: Callable[[str], np.ndarray], common: dict, check_range: bool,
                     locate: Callable[[int, str], tuple[int, int, str]]) -> PointMeasurement:
        position = np.column_stack([column(c) for c in POSITION_COLUMNS]) * 1e-3
        pm = PointMeasurement(instrument=self, position=position, rotation=self._rotation(column), **common)
        if check_range:
            bad = self.range_violations(pm)
            if bad.size:
                i = int(bad[0])
                line, col, name = locate(i, "px_mm")
                raise InputError(src, key=name, line=line,
                                 reason=f"reading at {np.linalg.norm(position[i]) * 1e3:g} mm from the "
                                           f"instrument origin, beyond its measuring volume of radius "
                                           f"{pm.volume_radius * 1e3:g} mm ({bad.size} such readings)", column=col)
        return pm

    def _rotation(self, column: Callable[[str], np.ndarray]) -> np.ndarray | None:
        return None


def _skew(v: np.ndarray) -> np.ndarray:
    """[v]× for v (N, 3) -> (N, 3, 3)."""
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


TRACKER = Tracker()
