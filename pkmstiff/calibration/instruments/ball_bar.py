"""The double ball bar (Szatmári §4.3, Tab. 4.3–4.5): r = |o + R (v + Δv) − s_7| + Δr, one reading per pose; the
QC10 device (the only place its figures are written) and the ball-bar measurement."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pkmstiff.calibration.instruments.base import Instrument, Setup, SetupState
from pkmstiff.calibration.instruments.file_format import check_version, fmt, names, numbers, scalars, vec
from pkmstiff.errors import InadmissibleError, InputError

Array = NDArray[np.float64]

#: Szatmári Tab. 4.5: uncertainty of the whole measuring procedure on Felix vs. path feed (mm/min -> µm)
TAB_4_5_FEED = np.array([0.0, 100.0, 500.0, 1000.0, 2000.0]) / 60e3  # m/s
TAB_4_5_UNCERTAINTY = np.array([15.0, 22.0, 22.0, 36.0, 54.0]) * 1e-6  # m
NOISE_MODELS = ("none", "instrument", "procedure")
#: (tilt, torsion) amplitudes in deg of the default hemisphere's orientation schedule, tried in this order
DEFAULT_SCHEDULES = tuple((t, min(t, 15.0)) for t in (20.0, 15.0, 10.0, 5.0))
#: file units of a pose (x, y, z mm; a, b, c deg) -> SI
_POSE_FILE_SCALE = np.array([1e-3] * 3 + [np.pi / 180] * 3)
UNITS_LINE = ("t_s s; x_mm y_mm z_mm mm; a_deg b_deg c_deg deg; q<i>_mm mm (linear drive); q<i>_deg deg (rotary "
              "drive); reading_mm mm (measured distance - bar_length); feed_mm_min mm/min; temperature_C degC")


@dataclass(frozen=True)
class BallbarDevice:
    """A ball-bar device (defaults: QC10, Szatmári Tab. 4.3): ``sample_rate`` [Hz], reading ``range`` (lo, hi)
    about the nominal bar length [m], ``resolution`` and ``accuracy`` [m]; the procedure uncertainty table U(feed)
    (Tab. 4.5) as ``procedure_feed`` [m/s] / ``procedure_uncertainty`` [m]."""

    name: str = "QC10"
    sample_rate: float = 250.0
    range: tuple[float, float] = (-1e-3, 1e-3)
    resolution: float = 0.1e-6
    accuracy: float = 0.5e-6
    procedure_feed: tuple[float, ...] = tuple(TAB_4_5_FEED)
    procedure_uncertainty: tuple[float, ...] = tuple(TAB_4_5_UNCERTAINTY)

    def __post_init__(self) -> None:
        for key in ("sample_rate", "resolution", "accuracy"):
            v = getattr(self, key)
            if not (np.isfinite(v) and v >= 0) or (key == "sample_rate" and v <= 0):
                raise InputError("instrument", key, "a positive number", v)
        if not self.range[0] < 0 < self.range[1]:
            raise InputError("instrument", "range", "lo < 0 < hi (m, about the bar length)", self.range)

    def uncertainty(self, feed: np.ndarray | float) -> np.ndarray:
        """Procedure uncertainty U(feed) [m] (Tab. 4.5, linear interpolation, constant beyond the table)."""
        return np.interp(np.abs(feed), self.procedure_feed, self.procedure_uncertainty)

    def sigma(self, noise: str | float, feed: np.ndarray | float) -> np.ndarray:
        """White-noise standard deviation [m]: ``none``, ``instrument`` (accuracy / 2), ``procedure`` (U / 2) or
        a number (σ in m)."""
        f = np.asarray(feed, dtype=float)
        if isinstance(noise, str):
            if noise == "none":
                return np.zeros_like(f)
            if noise == "instrument":
                return np.full_like(f, self.accuracy / 2.0)
            if noise == "procedure":
                return self.uncertainty(f) / 2.0
            raise InputError("--noise", "noise", f"one of {', '.join(NOISE_MODELS)} or a σ", noise)
        return np.full_like(f, float(noise))


QC10 = BallbarDevice()


@dataclass
class BallbarMeasurement:
    """One ball-bar measurement in SI units.

    Header: ``bar_length`` [m], ``fixed_ball`` (3,) [m] (centre-mount ball in machine coordinates),
    ``ball_offset`` (3,) [m] (moving ball in the pose frame), the ``device`` name (header key ``instrument``),
    its ``range`` (lo, hi) of the reading [m], ``resolution``, ``accuracy`` [m], ``sample_rate`` [Hz], ``plane``
    (name or "auto"), ``notes``.
    Samples (N,): ``t`` [s], ``poses`` (N, 6) [m, rad] or None, ``drives`` (N, n) [m or rad per ``drive_units``]
    or None, ``reading`` [m], ``feed`` [m/s] or None, ``direction`` ("ccw"/"cw") or None, ``temperature`` [°C]
    or None. ``lines`` (N,) holds the file line of each sample when read from a file.
    """

    bar_length: float
    fixed_ball: Array
    t: Array
    reading: Array
    poses: Array | None = None
    drives: Array | None = None
    drive_units: tuple[str, ...] = ()
    feed: Array | None = None
    direction: NDArray[np.str_] | None = None
    temperature: Array | None = None
    ball_offset: Array = field(default_factory=lambda: np.zeros(3))
    machine: str = ""
    device: str = QC10.name
    range: tuple[float, float] = QC10.range
    resolution: float = QC10.resolution
    accuracy: float = QC10.accuracy
    sample_rate: float = QC10.sample_rate
    plane: str = "auto"
    notes: list[str] = field(default_factory=list)
    lines: NDArray[np.int64] | None = None
    placing_pose: Array | None = None  # (6,) m, rad: the machine placed the fixed ball at this commanded pose

    @property
    def instrument(self) -> BallBar:
        return BALL_BAR

    @property
    def n_samples(self) -> int:
        return int(self.t.size)


class BallBar(Instrument):
    """Double ball bar: the distance of the moving ball (target v, PKS) from the fixed ball s_7 (MKS)."""

    kind = "ballbar"
    title = "ball bar"
    reading_names = ("r",)
    reading_units = ("m",)
    setup_tokens = {"ball-offset": "ball_offset", "fixed-ball": "fixed_ball", "bar-offset": "bar_offset"}
    target_name = "moving-ball centre"
    file_columns = ("reading_mm",)
    header_keys = ("bar_length_mm", "fixed_ball_mm", "ball_offset_mm", "range_mm", "plane", "fixed_ball_placed_at")
    path_plans = True
    saturates = True

    # ---------------------------------------------------------------------------------------------- set-up
    def check_setup(self, setup: Setup) -> None:
        if setup.fixed_ball is None or setup.bar_length is None or not setup.bar_length > 0:
            raise InputError("setup", "fixed_ball/bar_length", "a fixed-ball position and a positive "
                                        "bar length for a ball bar", (setup.fixed_ball, setup.bar_length))
        object.__setattr__(setup, "fixed_ball", np.asarray(setup.fixed_ball, dtype=float).reshape(3))
        if setup.measuring_range is None:
            object.__setattr__(setup, "measuring_range", QC10.range[1])

    def default_setup(self, machine: Any, centre: np.ndarray, bar_length: float) -> Setup:
        """Ball bar of ``bar_length`` with the fixed ball at ``centre`` (Szatmári §5.1: R = 300 mm about the
        origin of Felix)."""
        return Setup(self, target=machine.tool.tip(), fixed_ball=centre, bar_length=bar_length)

    def setup_from_toml(self, table: dict, quantity: Callable[..., Any], target: np.ndarray) -> Setup:
        return Setup(self, target=target, fixed_ball=quantity(table, "fixed_ball", "m", "setup.", shape=(3,)),
                     bar_length=quantity(table, "bar_length", "m", "setup.", positive=True),
                     measuring_range=quantity(table, "measuring_range", "m", "setup.", QC10.range[1], positive=True),
                     max_mount_angle=(quantity(table, "max_mount_angle", "rad", "setup.", positive=True)
                                      if "max_mount_angle" in table else None))

    def setup_toml(self, setup: Setup, quantity: Callable[[float, str, float], str]) -> list[str]:
        lines = ["fixed_ball = [" + ", ".join(quantity(v, "mm", 1e-3) for v in setup.fixed_ball) + "]",
                 f"bar_length = {quantity(setup.bar_length, 'mm', 1e-3)}",
                 f"measuring_range = {quantity(setup.measuring_range, 'mm', 1e-3)}"]
        if setup.max_mount_angle is not None:
            lines.append(f"max_mount_angle = {quantity(setup.max_mount_angle, 'deg', np.pi / 180)}")
        return lines

    # ---------------------------------------------------------------------------------------------- readings
    def readings(self, setup: Setup, state: SetupState, o: np.ndarray, R: np.ndarray,
                 R_cmd: np.ndarray) -> np.ndarray:
        m = o + np.einsum("nij,j->ni", R, state.target)
        return (np.linalg.norm(m - state.fixed_ball, axis=1) + state.bar_offset)[:, None]

    @staticmethod
    def _bar_direction(setup: Setup, m: np.ndarray, source: str = "") -> np.ndarray:
        rel = m - setup.fixed_ball
        dist = np.linalg.norm(rel, axis=1)
        if np.any(dist < 1e-9):
            raise InadmissibleError(f"{source}: the moving ball coincides with the fixed ball (singular ball-bar "
                                   "set-up)")
        return rel / dist[:, None]

    def reading_twist(self, setup: Setup, m: np.ndarray, Rv: np.ndarray, source: str) -> np.ndarray:
        u = self._bar_direction(setup, m, source)
        return np.concatenate([u, np.cross(Rv, u)], axis=1)[:, None, :]

    def setup_column(self, block: str, component: str, axis: np.ndarray, setup: Setup, R: np.ndarray,
                     m: np.ndarray) -> np.ndarray:
        u = self._bar_direction(setup, m)
        if block == "ball_offset":
            return np.einsum("ni,nij,j->n", u, R, axis)[:, None]
        if block == "fixed_ball":
            return (-u @ axis)[:, None]
        if block == "bar_offset":
            return np.ones((len(m), 1))
        return super().setup_column(block, component, axis, setup, R, m)

    def check_nominal(self, machine: Any, plan: Any, poses: np.ndarray) -> None:
        """The bar's tilt against the cup (``max_mount_angle``) and the nominal readings against the range."""
        from pkmstiff.calibration.plans import _fmt_pose
        from pkmstiff.kinematics.rotation import cardan_matrix

        setup = plan.setup
        R = cardan_matrix(poses[:, 3], poses[:, 4], poses[:, 5])
        if setup.max_mount_angle is not None:
            m = poses[:, :3] + np.einsum("nij,j->ni", R, setup.target)
            bar = setup.fixed_ball - m
            axis = np.einsum("nij,j->ni", R, machine.tool.axis)
            cos = np.einsum("ni,ni->n", bar, axis) / np.linalg.norm(bar, axis=1) / np.linalg.norm(axis, axis=1)
            ang = np.arccos(np.clip(cos, -1.0, 1.0))
            off = np.flatnonzero(ang > setup.max_mount_angle)
            if off.size:
                i = int(off[0])
                raise InadmissibleError(
                    f"plan '{plan.name}': {off.size} of {len(poses)} poses tilt the ball bar beyond the cup's "
                    f"{np.degrees(setup.max_mount_angle):g} deg to the tool axis, first pose {i + 1} "
                    f"{_fmt_pose(poses[i])} at {np.degrees(ang[i]):.1f} deg")
        r = self.readings(setup, setup.state(), poses[:, :3], R, R)[:, 0]
        off = np.flatnonzero(np.abs(r - setup.bar_length) > setup.measuring_range)
        if off.size:
            i = int(off[0])
            raise InadmissibleError(
                f"plan '{plan.name}': {off.size} of {len(poses)} poses put the ball bar outside its range "
                f"{setup.bar_length * 1e3:g} ± {setup.measuring_range * 1e3:g} mm, first pose {i + 1} "
                f"{_fmt_pose(poses[i])} at {r[i] * 1e3:.3f} mm")

    def project_path(self, setup: Setup, P: np.ndarray, Pq: np.ndarray, k: np.ndarray,
                     w: np.ndarray) -> np.ndarray:
        """Back on the sphere about the fixed ball (radius interpolated between the nodes)."""
        c = setup.fixed_ball
        rad = np.linalg.norm(P - c, axis=1)
        rq = rad[k] + w * (rad[k + 1] - rad[k])
        return c + (Pq - c) * (rq / np.linalg.norm(Pq - c, axis=1))[:, None]

    # ---------------------------------------------------------------------------------------------- plans
    def default_plans(self, machine: Any, centre: np.ndarray, setup: Setup) -> Iterator[Any]:
        """Szatmári's tilted hemisphere path of R = 300 mm about the workspace centre (§4.4, §5.1), the ball above
        the fixed ball when the tool points down (−z'), else below; then the fixed ball moved (±100 mm in y,
        ±150/300 mm in z), the tilt reduced (20, 15, 10, 5 deg) and the shorter QC10 bars (150, 100 mm)."""
        from pkmstiff.calibration.plans import hemisphere_plan

        side = 1.0 if machine.tool.axis[2] <= 0 else -1.0
        offsets = [np.array([0.0, dy, dz * side]) for dz in (0.0, -0.15, 0.15, -0.3) for dy in (0.0, -0.1, 0.1)]
        for bar in (0.3, 0.15, 0.1):  # QC10 bar lengths (Szatmári Tab. 4.3)
            for tilt, torsion in DEFAULT_SCHEDULES:
                for off in offsets:
                    st = Setup(self, target=setup.target, fixed_ball=centre + off, bar_length=bar)
                    yield hemisphere_plan(st, tilt=np.radians(tilt), torsion=np.radians(torsion), side=side,
                                          name=f"default hemisphere R={bar * 1e3:g} mm, tilt {tilt:g} deg")

    # ---------------------------------------------------------------------------------------------- devices
    def default_device(self) -> BallbarDevice:
        return QC10

    def device(self, setup: Setup, *, sample_rate: float | None = None, range: float | None = None,
               resolution: float | None = None, accuracy: float | None = None,
               angle_accuracy: float | None = None) -> BallbarDevice:
        """QC10 with the figures given; ``range`` ± about the bar length (default: the set-up's measuring range);
        ``angle_accuracy`` does not apply and is ignored."""
        rng = setup.measuring_range if range is None else range
        return BallbarDevice(sample_rate=QC10.sample_rate if sample_rate is None else sample_rate, range=(-rng, rng),
                             resolution=QC10.resolution if resolution is None else resolution,
                             accuracy=QC10.accuracy if accuracy is None else accuracy)

    # ---------------------------------------------------------------------------------------------- simulation
    def finish_readings(self, device: BallbarDevice, setup: Setup, options: Any, clean: np.ndarray,
                        noisy: np.ndarray, rng: np.random.Generator):
        dev = noisy[:, 0] - setup.bar_length
        out = noisy
        if options.quantise and device.resolution > 0:
            dev = np.round(dev / device.resolution) * device.resolution
            out = (setup.bar_length + dev)[:, None]
        return out, np.flatnonzero((dev < device.range[0]) | (dev > device.range[1])), dev

    def range_error(self, plan: Any, res: Any, device: BallbarDevice) -> str:
        v = res.violations
        i = int(v[0])
        dev = (res.readings[i, 0] - plan.setup.bar_length) * 1e3
        return (f"plan '{plan.name}': {v.size} of {len(res.readings)} simulated readings outside the {device.name} "
                f"range [{device.range[0] * 1e3:g}, {device.range[1] * 1e3:g}] mm, first at sample {i + 1} "
                f"(t = {res.samples.t[i]:.3f} s, reading {dev:+.4f} mm)")

    def simulation_summary(self, plan: Any, res: Any) -> dict:
        dev = res.readings[:, 0] - plan.setup.bar_length
        return {"reading_min_um": float(dev.min() * 1e6), "reading_max_um": float(dev.max() * 1e6)}

    def to_measurement(self, machine: Any, plan: Any, res: Any, device: BallbarDevice, saturate: bool,
                       notes: list[str]) -> BallbarMeasurement:
        """Reading = distance − bar length; ``saturate`` clips out-of-range readings at the range limits, as the
        transducer would."""
        dev = res.readings[:, 0] - plan.setup.bar_length if res.deviation is None else res.deviation
        if saturate:
            dev = np.clip(dev, *device.range)
        plane = plan.segments[0].label.split()[1] if plan.segments and plan.segments[0].label.startswith("circle ") \
            and len(plan.segments) == 1 else "auto"
        return BallbarMeasurement(bar_length=float(plan.setup.bar_length), fixed_ball=plan.setup.fixed_ball.copy(),
                                  t=res.samples.t, reading=dev, poses=res.samples.poses,
                                  feed=res.samples.feed, direction=res.samples.direction.astype(str),
                                  temperature=res.temperature, ball_offset=plan.setup.target.copy(),
                                  machine=machine.name, device=device.name, range=device.range,
                                  resolution=device.resolution, accuracy=device.accuracy,
                                  sample_rate=device.sample_rate,
                                  plane=plane if plane in ("XY", "XZ", "YZ") else "auto", notes=notes,
                                  placing_pose=plan.setup.placing_pose)

    # ---------------------------------------------------------------------------------------------- measurements
    def measured(self, meas: BallbarMeasurement) -> tuple[Setup, np.ndarray]:
        """The full ball distance: the file's reading + bar length, (N, 1) m."""
        setup = Setup(self, target=meas.ball_offset, fixed_ball=meas.fixed_ball, bar_length=meas.bar_length,
                      measuring_range=max(abs(meas.range[0]), abs(meas.range[1])), placing_pose=meas.placing_pose)
        return setup, (np.asarray(meas.reading, dtype=float) + meas.bar_length)[:, None]

    def reading_sigma(self, meas: BallbarMeasurement) -> np.ndarray:
        return np.array([meas.accuracy / 2.0])

    def range_violations(self, meas: BallbarMeasurement) -> np.ndarray:
        lo, hi = meas.range
        return np.flatnonzero((meas.reading < lo) | (meas.reading > hi))

    def range_message(self, meas: BallbarMeasurement, bad: np.ndarray) -> str:
        i = int(bad[0])
        return (f"{bad.size} reading(s) outside the instrument range [{meas.range[0] * 1e3:g}, "
                f"{meas.range[1] * 1e3:g}] mm, first at sample {i} (t = {meas.t[i]:g} s, reading "
                f"{meas.reading[i] * 1e3:g} mm)")

    def header_lines(self, meas: BallbarMeasurement) -> list[str]:
        return [f"# bar_length_mm: {fmt(meas.bar_length / 1e-3)}",
                f"# fixed_ball_mm: {vec(np.asarray(meas.fixed_ball), 1e-3)}",
                f"# ball_offset_mm: {vec(np.asarray(meas.ball_offset), 1e-3)}",
                f"# range_mm: {vec(np.asarray(meas.range), 1e-3)}",
                f"# resolution_um: {fmt(meas.resolution / 1e-6)}",
                f"# accuracy_um: {fmt(meas.accuracy / 1e-6)}",
                f"# sample_rate_hz: {fmt(meas.sample_rate)}",
                f"# plane: {meas.plane}"] + ([] if meas.placing_pose is None else [
                "# fixed_ball_placed_at: " + ", ".join(fmt(x) for x in np.asarray(meas.placing_pose) / _POSE_FILE_SCALE)]) + [
                f"# units: {UNITS_LINE}"]

    def reading_columns(self, meas: BallbarMeasurement) -> list[tuple[str, np.ndarray]]:
        return [("reading_mm", meas.reading / 1e-3)]

    def parse_header(self, src: str, header: dict[str, tuple[int, str]]) -> dict:
        check_version(src, header)
        meta: dict = {}
        if "bar_length_mm" not in header:
            raise InputError(src, reason="missing header key 'bar_length_mm' (e.g. '# bar_length_mm: 150')")
        no, v = header["bar_length_mm"]
        (L,) = numbers(src, no, "bar_length_mm", v, 1)
        if L <= 0:
            raise InputError(src, line=no, reason=f"header key 'bar_length_mm': expected a positive length, "
                                       f"found {v!r}")
        meta["bar_length"] = L * 1e-3
        if "fixed_ball_mm" not in header:
            raise InputError(src, reason="missing header key 'fixed_ball_mm' (e.g. '# fixed_ball_mm: 0, 0, "
                                       "0')")
        no, v = header["fixed_ball_mm"]
        meta["fixed_ball"] = np.array(numbers(src, no, "fixed_ball_mm", v, 3)) * 1e-3
        if (h := header.get("ball_offset_mm")) is not None:
            meta["ball_offset"] = np.array(numbers(src, h[0], "ball_offset_mm", h[1], 3)) * 1e-3
        if (h := header.get("range_mm")) is not None:
            lo, hi = numbers(src, h[0], "range_mm", h[1], 2)
            if not lo < hi:
                raise InputError(src, line=h[0], reason=f"header key 'range_mm': expected lower < upper, "
                                           f"found {h[1]!r}")
            meta["range"] = (lo * 1e-3, hi * 1e-3)
        scalars(src, header, (("resolution_um", "resolution", 1e-6, False), ("accuracy_um", "accuracy", 1e-6, False),
                              ("sample_rate_hz", "sample_rate", 1.0, False)), meta)
        names(header, meta)
        if (h := header.get("plane")) is not None:
            if h[1].upper() not in ("XY", "YZ", "ZX", "XZ", "AUTO"):
                raise InputError(src, line=h[0], reason=f"header key 'plane': expected XY, YZ, ZX, XZ or auto, "
                                           f"found {h[1]!r}")
            meta["plane"] = h[1].upper() if h[1].upper() != "AUTO" else "auto"
        if (h := header.get("fixed_ball_placed_at")) is not None:  # x, y, z mm, a, b, c deg of the placing pose
            meta["placing_pose"] = np.array(numbers(src, h[0], "fixed_ball_placed_at", h[1], 6)) * _POSE_FILE_SCALE
        return meta

    def from_columns(self, src: str, column: Callable[[str], np.ndarray], common: dict, check_range: bool,
                     locate: Callable[[int, str], tuple[int, int, str]]) -> BallbarMeasurement:
        reading = column("reading_mm") * 1e-3
        meas = BallbarMeasurement(reading=reading, **common)
        if check_range:
            bad = self.range_violations(meas)
            if bad.size:
                line, col, name = locate(int(bad[0]), "reading_mm")
                lo, hi = meas.range
                more = ""
                if bad.size > 1:
                    more = (f" ({bad.size} readings out of range, lines {locate(int(bad[0]), name)[0]}-"
                            f"{locate(int(bad[-1]), name)[0]})")
                raise InputError(src, key=name, line=line, reason=f"reading {reading[bad[0]] * 1e3:g} mm outside the "
                                           f"instrument range [{lo * 1e3:g}, {hi * 1e3:g}] mm{more}", column=col)
        return meas


BALL_BAR = BallBar()
