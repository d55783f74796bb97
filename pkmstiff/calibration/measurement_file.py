"""Ball-bar measurement files: a CSV and its header (issue 16 item 5; instrument data docs/theory/calibration.md).

pkmstiff writes the header as ``<name>.json`` beside the CSV (issue 22 item 6: the CSV is a plain table that
``pandas.read_csv(path)`` reads with no options); a CSV may instead carry the same keys as ``# key: value`` comment
lines before the column row (the earlier form, read unchanged; a byte-order mark is dropped, cells may be quoted).

Layout of the earlier form (one sample per row, comma separated, ``#`` starts a comment line)::

    # pkmstiff ball-bar measurement
    # format_version: 1
    # machine: felix
    # instrument: QC10
    # bar_length_mm: 150
    # fixed_ball_mm: 0, 0, 0
    # ball_offset_mm: 0, 0, 0
    # range_mm: -1, 1
    # resolution_um: 0.1
    # accuracy_um: 0.5
    # sample_rate_hz: 250
    # plane: XY
    # units: t_s s; x_mm y_mm z_mm mm; a_deg b_deg c_deg deg; q<i>_mm mm; q<i>_deg deg; reading_mm mm; ...
    # note: free text (repeatable)
    t_s,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,reading_mm,feed_mm_min,direction,temperature_C
    0,150,0,0,0,0,0,0.00123,500,ccw,20.1

Header keys carry their unit in the name (as do the columns); ``units`` is written for people and not read.
Columns: ``t_s`` (required, non-decreasing), the commanded pose ``x_mm … c_deg`` (all six) and/or drive
values ``q1_mm``/``q1_deg``, ``q2_…`` (consecutive), ``reading_mm`` (required: the transducer reading, i.e. the
measured ball distance minus ``bar_length``), optional ``feed_mm_min``, ``direction`` (``ccw``/``cw``) and
``temperature_C``. Instrument defaults are the QC10 class values of Szatmári Tab. 4.3 (docs/theory/calibration.md).

**Tracker and 6-D pose files** (same layout, header ``instrument_type: tracker`` or ``pose``; without that key a
file is a ball-bar file, so older files read unchanged)::

    # pkmstiff tracker measurement
    # format_version: 1
    # instrument_type: tracker
    # machine: felix
    # instrument: laser tracker (AT960 class, assumed)
    # target_mm: 0, 0, -100
    # volume_radius_mm: 20000
    # resolution_um: 0.1
    # accuracy_um: 15
    # accuracy_um_per_m: 6
    # standoff_mm: 2000
    # sample_rate_hz: 1000
    t_s,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,px_mm,py_mm,pz_mm
    1,-150,-150,-250,0,0,0,-150.0012,-149.9987,-350.0003

``px_mm,py_mm,pz_mm`` (required) are the measured target position in the instrument frame (nominally the
machine frame), ``target_mm`` the target in the platform frame; a pose file adds ``rx_urad,ry_urad,rz_urad``
(required), the measured orientation error as a rotation vector φ = log(Qᵀ R R_cᵀ) (R reached, R_c commanded
orientation; :mod:`~pkmstiff.calibration.instruments`) and may give ``angle_resolution_urad`` and
``angle_accuracy_urad``. Readings farther than ``volume_radius_mm`` from the instrument-frame origin are out of
range. Ball-bar header keys (``bar_length_mm`` ...) are errors in these files and vice versa.

Every error is a :class:`~pkmstiff.errors.MeasurementFileError` whose one-line message names the file, the line
and, for a cell, the column number and name. Readings outside the instrument range are an error on reading (the
first offending line is named, with the count); :func:`range_violations` lists them for a writer's report.
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pkmstiff.errors import MeasurementFileError
from pkmstiff.io.atomic import atomic_write_text
from pkmstiff.io.inputs import input_file_problem

Array = NDArray[np.float64]

SIGNATURE = "pkmstiff ball-bar measurement"
FORMAT_VERSION = 1
POSE_COLUMNS = ("x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg")
_POSE_SCALE = np.array([1e-3, 1e-3, 1e-3, math.pi / 180, math.pi / 180, math.pi / 180])
_DRIVE_RE = re.compile(r"^q(\d+)_(mm|deg)$")
_OPTIONAL = ("feed_mm_min", "direction", "temperature_C")
KINDS = ("ballbar", "tracker", "pose")
POSITION_COLUMNS = ("px_mm", "py_mm", "pz_mm")
ROTATION_COLUMNS = ("rx_urad", "ry_urad", "rz_urad")
#: reading columns per instrument type
READING_COLUMNS = {"ballbar": ("reading_mm",), "tracker": POSITION_COLUMNS, "pose": POSITION_COLUMNS + ROTATION_COLUMNS}
POINT_UNITS_LINE = ("t_s s; x_mm y_mm z_mm mm; a_deg b_deg c_deg deg (commanded pose); px_mm py_mm pz_mm mm "
                    "(measured target position, instrument frame); rx_urad ry_urad rz_urad urad (measured "
                    "orientation error, rotation vector); feed_mm_min mm/min; temperature_C degC")
UNITS_LINE = ("t_s s; x_mm y_mm z_mm mm; a_deg b_deg c_deg deg; q<i>_mm mm (linear drive); q<i>_deg deg (rotary "
              "drive); reading_mm mm (measured distance - bar_length); feed_mm_min mm/min; temperature_C degC")

# QC10-class defaults (Szatmári Tab. 4.3, docs/theory/calibration.md)
QC10_RANGE = (-1e-3, 1e-3)
QC10_RESOLUTION = 0.1e-6
QC10_ACCURACY = 0.5e-6
QC10_SAMPLE_RATE = 250.0


@dataclass
class BallbarMeasurement:
    """One ball-bar measurement in SI units.

    Header: ``bar_length`` [m], ``fixed_ball`` (3,) [m] (centre-mount ball in machine coordinates),
    ``ball_offset`` (3,) [m] (moving ball in the pose frame), instrument ``range`` (lo, hi) of the reading [m],
    ``resolution``, ``accuracy`` [m], ``sample_rate`` [Hz], ``plane`` (name or "auto"), ``notes``.
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
    instrument: str = "QC10"
    range: tuple[float, float] = QC10_RANGE
    resolution: float = QC10_RESOLUTION
    accuracy: float = QC10_ACCURACY
    sample_rate: float = QC10_SAMPLE_RATE
    plane: str = "auto"
    notes: list[str] = field(default_factory=list)
    lines: NDArray[np.int64] | None = None

    @property
    def n_samples(self) -> int:
        return int(self.t.size)


@dataclass
class PointMeasurement:
    """One laser-tracker (``kind`` "tracker") or 6-D pose (``kind`` "pose") measurement in SI units.

    Header: ``target`` (3,) [m] (the target / reference point in the platform frame), ``volume_radius`` [m]
    (largest distance of a reading from the instrument-frame origin), ``resolution`` [m], the position MPE
    ``accuracy`` + ``accuracy_per_m`` · distance [m, m/m] at the ``standoff`` distance [m], ``angle_resolution``
    and ``angle_accuracy`` [rad] (pose), ``sample_rate`` [Hz], ``notes``. Samples (N,): ``t`` [s], ``position``
    (N, 3) [m] measured target positions in the instrument frame, ``rotation`` (N, 3) [rad] measured orientation
    errors (rotation vectors; pose only, else None), commanded ``poses`` (N, 6) / ``drives`` as for the ball bar,
    ``feed`` [m/s], ``direction``, ``temperature`` [°C], ``lines`` (file line per sample when read).
    """

    kind: str
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
    instrument: str = ""
    volume_radius: float = 20.0
    resolution: float = 0.1e-6
    accuracy: float = 15e-6
    accuracy_per_m: float = 6e-6
    standoff: float = 2.0
    angle_resolution: float = 1e-6
    angle_accuracy: float = 175e-6
    sample_rate: float = 1000.0
    notes: list[str] = field(default_factory=list)
    lines: NDArray[np.int64] | None = None

    @property
    def n_samples(self) -> int:
        return int(self.t.size)

    @property
    def readings(self) -> Array:
        """Readings (N, 3) or (N, 6) [m, rad] in the order of :data:`pkmstiff.calibration.instruments.READINGS`."""
        return self.position if self.rotation is None else np.hstack([self.position, self.rotation])


def range_violations(meas: BallbarMeasurement | PointMeasurement) -> NDArray[np.int64]:
    """Indices of samples whose reading lies outside the instrument range (ball bar: ``meas.range`` about the bar
    length; tracker / pose: farther than ``meas.volume_radius`` from the instrument-frame origin)."""
    if isinstance(meas, PointMeasurement):
        return np.flatnonzero(np.linalg.norm(meas.position, axis=1) > meas.volume_radius)
    lo, hi = meas.range
    return np.flatnonzero((meas.reading < lo) | (meas.reading > hi))


# ------------------------------------------------------------------------------------------------- writing

def _fmt(x: float) -> str:
    return "%.15g" % float(x)  # 15 significant digits: exact to 1e-15 relative, no binary noise like 0.0193000001


def _vec(v: Array, scale: float) -> str:
    return ", ".join(_fmt(x / scale) for x in v)


def write_measurement(path: str | Path, meas: BallbarMeasurement, *, allow_out_of_range: bool = False) -> Path:
    """Write ``meas`` as a measurement CSV (format above); values are printed with the shortest round-trip repr of
    their value in the file unit, so reading back reproduces them to one unit in the last place.

    Readings outside the instrument range raise :class:`MeasurementFileError` naming the first sample and the
    count, unless ``allow_out_of_range`` (the file then fails to read, as a real instrument's would).
    """
    path = Path(path)
    src = str(path)
    if isinstance(meas, PointMeasurement):
        return _write_points(path, meas, allow_out_of_range)
    n = meas.n_samples
    _check_lengths(meas, src)
    bad = range_violations(meas)
    if bad.size and not allow_out_of_range:
        i = int(bad[0])
        raise MeasurementFileError(src, None, f"{bad.size} reading(s) outside the instrument range "
                                   f"[{meas.range[0] * 1e3:g}, {meas.range[1] * 1e3:g}] mm, first at sample {i} "
                                   f"(t = {meas.t[i]:g} s, reading {meas.reading[i] * 1e3:g} mm)")
    cols = _command_cols(meas) + [("reading_mm", meas.reading / 1e-3)] + _optional_cols(meas)
    head = [
        f"# {SIGNATURE}",
        f"# format_version: {FORMAT_VERSION}",
        f"# machine: {meas.machine}",
        f"# instrument: {meas.instrument}",
        f"# bar_length_mm: {_fmt(meas.bar_length / 1e-3)}",
        f"# fixed_ball_mm: {_vec(np.asarray(meas.fixed_ball), 1e-3)}",
        f"# ball_offset_mm: {_vec(np.asarray(meas.ball_offset), 1e-3)}",
        f"# range_mm: {_vec(np.asarray(meas.range), 1e-3)}",
        f"# resolution_um: {_fmt(meas.resolution / 1e-6)}",
        f"# accuracy_um: {_fmt(meas.accuracy / 1e-6)}",
        f"# sample_rate_hz: {_fmt(meas.sample_rate)}",
        f"# plane: {meas.plane}",
        f"# units: {UNITS_LINE}",
    ] + [f"# note: {note}" for note in meas.notes]
    return _write_table(path, head, cols, n)


def sidecar_path(path: str | Path) -> Path:
    """The JSON file beside a measurement CSV that holds its header (``<name>.json``)."""
    return Path(path).with_suffix(".json")


def _json_value(text: str):
    """A header value as JSON data: a number, a list of numbers (``"0, 0, 0"``) or the text."""
    parts = [p.strip() for p in text.split(",")]
    try:
        nums = [float(p) for p in parts]
    except ValueError:
        return text
    nums = [int(v) if v.is_integer() and abs(v) < 2**53 else v for v in nums]
    return nums[0] if len(nums) == 1 else nums


def _write_table(path: Path, head: list[str], cols: list, n: int) -> Path:
    """The CSV (the column row and the samples: ``pandas.read_csv(path)`` reads it with no options) and its header
    as ``<name>.json`` beside it (the ``# key: value`` lines of earlier files, which are still read)."""
    meta: dict = {"file": head[0].lstrip("# ").strip()}
    for line in head[1:]:
        key, value = (p.strip() for p in line.lstrip("# ").split(":", 1))
        if key == "note":
            meta.setdefault("note", []).append(value)
        else:
            meta[key] = _json_value(value) if key not in ("machine", "instrument", "plane", "units") else value
    atomic_write_text(sidecar_path(path), json.dumps(meta, indent=2, ensure_ascii=False) + "\n")
    head = []
    text_cols = []
    for name, values in cols:
        if name == "direction":
            text_cols.append([str(v) for v in values])
        else:
            text_cols.append([_fmt(v) for v in np.asarray(values, dtype=float)])
    rows = [",".join(c[i] for c in text_cols) for i in range(n)]
    atomic_write_text(path, "\n".join(head + [",".join(name for name, _ in cols)] + rows) + "\n")
    return path


def _command_cols(meas: BallbarMeasurement | PointMeasurement) -> list:
    """Columns before the readings: time and the commanded poses and/or drive values (file units)."""
    cols: list = [("t_s", meas.t)]
    if meas.poses is not None:
        for j, name in enumerate(POSE_COLUMNS):
            cols.append((name, meas.poses[:, j] / _POSE_SCALE[j]))
    if meas.drives is not None:
        units = meas.drive_units or ("mm",) * meas.drives.shape[1]
        for j, u in enumerate(units):
            cols.append((f"q{j + 1}_{u}", meas.drives[:, j] / (1e-3 if u == "mm" else math.pi / 180)))
    return cols


def _optional_cols(meas: BallbarMeasurement | PointMeasurement) -> list:
    """Columns after the readings, where given: feed, direction, temperature (file units)."""
    cols: list = []
    if meas.feed is not None:
        cols.append(("feed_mm_min", meas.feed * 60e3))
    if meas.direction is not None:
        cols.append(("direction", np.asarray(meas.direction)))
    if meas.temperature is not None:
        cols.append(("temperature_C", meas.temperature))
    return cols


def _write_points(path: Path, meas: PointMeasurement, allow_out_of_range: bool) -> Path:
    src = str(path)
    if meas.kind not in ("tracker", "pose"):
        raise MeasurementFileError(src, None, f"instrument type must be 'tracker' or 'pose', found {meas.kind!r}")
    if (meas.rotation is None) != (meas.kind == "tracker"):
        raise MeasurementFileError(src, None, "a pose measurement needs orientation readings, a tracker "
                                   "measurement none")
    n = meas.n_samples
    _check_lengths(meas, src)
    bad = range_violations(meas)
    if bad.size and not allow_out_of_range:
        i = int(bad[0])
        raise MeasurementFileError(src, None, f"{bad.size} reading(s) farther than the instrument's "
                                   f"{meas.volume_radius * 1e3:g} mm from its origin, first at sample {i} "
                                   f"(t = {meas.t[i]:g} s)")
    cols = _command_cols(meas)
    for j, name in enumerate(POSITION_COLUMNS):
        cols.append((name, meas.position[:, j] / 1e-3))
    if meas.rotation is not None:
        for j, name in enumerate(ROTATION_COLUMNS):
            cols.append((name, meas.rotation[:, j] / 1e-6))
    cols += _optional_cols(meas)
    head = [
        f"# pkmstiff {meas.kind} measurement",
        f"# format_version: {FORMAT_VERSION}",
        f"# instrument_type: {meas.kind}",
        f"# machine: {meas.machine}",
        f"# instrument: {meas.instrument}",
        f"# target_mm: {_vec(np.asarray(meas.target), 1e-3)}",
        f"# volume_radius_mm: {_fmt(meas.volume_radius / 1e-3)}",
        f"# resolution_um: {_fmt(meas.resolution / 1e-6)}",
        f"# accuracy_um: {_fmt(meas.accuracy / 1e-6)}",
        f"# accuracy_um_per_m: {_fmt(meas.accuracy_per_m / 1e-6)}",
        f"# standoff_mm: {_fmt(meas.standoff / 1e-3)}",
    ]
    if meas.kind == "pose":
        head += [f"# angle_resolution_urad: {_fmt(meas.angle_resolution / 1e-6)}",
                 f"# angle_accuracy_urad: {_fmt(meas.angle_accuracy / 1e-6)}"]
    head += [f"# sample_rate_hz: {_fmt(meas.sample_rate)}", f"# units: {POINT_UNITS_LINE}"]
    head += [f"# note: {note}" for note in meas.notes]
    return _write_table(path, head, cols, n)


def _check_lengths(meas: BallbarMeasurement | PointMeasurement, src: str) -> None:
    n = meas.n_samples
    for name in ("reading", "position", "rotation", "poses", "drives", "feed", "direction", "temperature"):
        v = getattr(meas, name, None)
        if v is not None and len(v) != n:
            raise MeasurementFileError(src, None, f"'{name}' has {len(v)} samples, expected {n} (as 't')")
    if meas.poses is None and meas.drives is None:
        raise MeasurementFileError(src, None, "a measurement needs commanded poses or drive values")


# ------------------------------------------------------------------------------------------------- reading

_BALLBAR_KEYS = ("bar_length_mm", "fixed_ball_mm", "ball_offset_mm", "range_mm", "plane")
_POINT_KEYS = ("target_mm", "volume_radius_mm", "accuracy_um_per_m", "standoff_mm", "angle_resolution_urad",
               "angle_accuracy_urad")
_HEADER_KEYS = ("format_version", "instrument_type", "machine", "instrument", "resolution_um", "accuracy_um",
                "sample_rate_hz", "units", "note") + _BALLBAR_KEYS + _POINT_KEYS


def _numbers(src: str, line: int, key: str, text: str, count: int) -> list[float]:
    parts = [p.strip() for p in text.split(",")]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        vals = []
    if len(vals) != count or not all(math.isfinite(v) for v in vals):
        what = "a number" if count == 1 else f"{count} comma-separated numbers"
        raise MeasurementFileError(src, line, f"header key '{key}': expected {what}, found {text!r}")
    return vals


def read_measurement(path: str | Path, *, check_range: bool = True) -> BallbarMeasurement | PointMeasurement:
    """Read a measurement CSV (format in the module docstring) into SI units: a :class:`BallbarMeasurement`, or
    a :class:`PointMeasurement` for a file with ``instrument_type: tracker`` / ``pose``.

    Raises :class:`MeasurementFileError` (one line: file, line, column) for: a missing file, unknown or repeated
    header keys, bad header values, a missing column row, unknown/duplicate/missing columns, rows with the wrong
    number of cells, cells that are not finite numbers (or not ccw/cw), time running backwards, and — with
    ``check_range`` — readings outside the instrument range.
    """
    path = Path(path)
    src = str(path)
    problem = input_file_problem(path)
    if problem is not None:
        raise MeasurementFileError(src, None, "file not found" if problem == "no such file" else
                                   f"expected a regular measurement file, found {problem}")
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark (as spreadsheet programs write) is dropped
    except FileNotFoundError:
        raise MeasurementFileError(src, None, "file not found") from None
    except UnicodeDecodeError as exc:
        raise MeasurementFileError(src, None, f"expected a UTF-8 text file, found the non-UTF-8 byte "
                                              f"0x{exc.object[exc.start]:02x} at offset {exc.start}") from None
    except OSError as exc:
        raise MeasurementFileError(src, None, f"cannot read the file ({exc.__class__.__name__})") from None
    lines = text.splitlines()
    header: dict[str, tuple[int, str]] = {}
    notes: list[str] = []
    columns: list[str] | None = None
    col_line = 0
    data_lines: list[int] = []
    data_rows: list[list[str]] = []
    for no, raw in enumerate(lines, start=1):
        s = raw.strip()
        if not s:
            continue
        if s.startswith("#"):
            if columns is not None:
                continue  # comments between data rows are allowed and ignored
            body = s[1:].strip()
            if ":" not in body:
                continue  # free comment (e.g. the signature line)
            key, value = (p.strip() for p in body.split(":", 1))
            if key not in _HEADER_KEYS:
                raise MeasurementFileError(src, no, f"unknown header key '{key}'; expected one of "
                                           f"{', '.join(_HEADER_KEYS)}")
            if key == "note":
                notes.append(value)
                continue
            if key in header:
                raise MeasurementFileError(src, no, f"header key '{key}' repeated (first on line {header[key][0]})")
            header[key] = (no, value)
            continue
        cells = [c.strip() for c in next(csv.reader([s]))]  # quoted cells may hold commas
        if columns is None:
            columns, col_line = cells, no
        else:
            data_lines.append(no)
            data_rows.append(cells)
    if columns is None:
        raise MeasurementFileError(src, len(lines) or None, "no column row found (expected a line such as "
                                   "'t_s,x_mm,...,reading_mm')")
    hsrc = src  # where the header came from: the CSV's '# key: value' lines or the JSON file beside it
    if not header and not notes:
        if not os.path.lexists(sidecar_path(path)):
            raise MeasurementFileError(src, None, f"no header: neither '# key: value' lines nor "
                                       f"{sidecar_path(path).name} beside the file (a ball-bar file needs at least "
                                       f"bar_length_mm and fixed_ball_mm)")
        hsrc = str(sidecar_path(path))
        header, notes = _read_sidecar(hsrc)
    kind = "ballbar"
    if "instrument_type" in header:
        no, kind = header["instrument_type"]
        if kind not in KINDS:
            raise MeasurementFileError(src, no, f"header key 'instrument_type': expected one of {', '.join(KINDS)}, "
                                       f"found {kind!r}")
    foreign = _POINT_KEYS if kind == "ballbar" else _BALLBAR_KEYS
    for key in foreign:
        if key in header:
            raise MeasurementFileError(hsrc, header[key][0], f"header key '{key}' does not belong to a {kind} file "
                                       f"(instrument_type: {kind})")
    meta = _parse_header(hsrc, header) if kind == "ballbar" else _parse_point_header(hsrc, header, kind)
    layout = _parse_columns(src, col_line, columns, kind)
    if not data_rows:
        raise MeasurementFileError(src, col_line, "no data rows after the column row")
    ncol = len(columns)
    for no, cells in zip(data_lines, data_rows):
        if len(cells) != ncol:
            raise MeasurementFileError(src, no, f"expected {ncol} values (as in the column row, line {col_line}), "
                                       f"found {len(cells)}")
    table = np.array(data_rows, dtype=object)
    line_no = np.array(data_lines, dtype=np.int64)

    def numeric(j: int) -> Array:
        col = table[:, j]
        try:
            vals = np.array(col, dtype=float)
        except ValueError:
            vals = None
        if vals is None:
            for i, c in enumerate(col):
                try:
                    float(c)
                except ValueError:
                    raise MeasurementFileError(src, int(line_no[i]), f"expected a number, found {c!r}",
                                               j + 1, columns[j]) from None
        bad = ~np.isfinite(vals)
        if bad.any():
            i = int(np.argmax(bad))
            raise MeasurementFileError(src, int(line_no[i]), f"expected a finite number, found {col[i]!r}",
                                       j + 1, columns[j])
        return vals

    t = numeric(layout["t_s"])
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        i = int(back[0]) + 1
        raise MeasurementFileError(src, int(line_no[i]), f"time must not decrease: {t[i]:g} s after {t[i - 1]:g} s",
                                   layout["t_s"] + 1, "t_s")
    reading = numeric(layout["reading_mm"]) * 1e-3 if kind == "ballbar" else None
    poses = None
    if "x_mm" in layout:
        poses = np.column_stack([numeric(layout[c]) for c in POSE_COLUMNS]) * _POSE_SCALE
    drives, drive_units = None, ()
    dcols = layout.get("drives", [])
    if dcols:
        drive_units = tuple(u for _, u in dcols)
        drives = np.column_stack([numeric(j) * (1e-3 if u == "mm" else math.pi / 180) for j, u in dcols])
    feed = numeric(layout["feed_mm_min"]) / 60e3 if "feed_mm_min" in layout else None
    temperature = numeric(layout["temperature_C"]) if "temperature_C" in layout else None
    direction = None
    if "direction" in layout:
        j = layout["direction"]
        direction = np.char.lower(table[:, j].astype(str))
        bad = ~np.isin(direction, ("ccw", "cw"))
        if bad.any():
            i = int(np.argmax(bad))
            raise MeasurementFileError(src, int(line_no[i]), f"expected 'ccw' or 'cw', found {table[i, j]!r}",
                                       j + 1, "direction")
    common = dict(t=t, poses=poses, drives=drives, drive_units=drive_units, feed=feed, direction=direction,
                  temperature=temperature, notes=notes, lines=line_no, **meta)
    if kind != "ballbar":
        position = np.column_stack([numeric(layout[c]) for c in POSITION_COLUMNS]) * 1e-3
        rotation = (np.column_stack([numeric(layout[c]) for c in ROTATION_COLUMNS]) * 1e-6 if kind == "pose"
                    else None)
        pm = PointMeasurement(kind=kind, position=position, rotation=rotation, **common)
        if check_range:
            bad = range_violations(pm)
            if bad.size:
                i = int(bad[0])
                raise MeasurementFileError(src, int(line_no[i]), f"reading at {np.linalg.norm(position[i]) * 1e3:g} "
                                           f"mm from the instrument origin, beyond its measuring volume of radius "
                                           f"{pm.volume_radius * 1e3:g} mm ({bad.size} such readings)",
                                           layout["px_mm"] + 1, "px_mm")
        return pm
    meas = BallbarMeasurement(reading=reading, **common)
    if check_range:
        bad = range_violations(meas)
        if bad.size:
            i = int(bad[0])
            lo, hi = meas.range
            more = f" ({bad.size} readings out of range, lines {line_no[bad[0]]}-{line_no[bad[-1]]})" \
                if bad.size > 1 else ""
            raise MeasurementFileError(src, int(line_no[i]), f"reading {reading[i] * 1e3:g} mm outside the "
                                       f"instrument range [{lo * 1e3:g}, {hi * 1e3:g}] mm{more}",
                                       layout["reading_mm"] + 1, "reading_mm")
    return meas


def _read_sidecar(src: str) -> tuple[dict[str, tuple[int | None, str]], list[str]]:
    """The header of a measurement CSV from the JSON file beside it: {key: (None, value text)} and the notes."""
    problem = input_file_problem(src)
    if problem is not None:
        raise MeasurementFileError(src, None, f"expected the header file of the measurement, found {problem}")
    try:
        raw = json.loads(Path(src).read_text(encoding="utf-8-sig"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise MeasurementFileError(src, None, f"expected a JSON object with the header keys, found invalid JSON "
                                   f"({str(exc).splitlines()[0]})") from None
    if not isinstance(raw, dict):
        raise MeasurementFileError(src, None, f"expected a JSON object with the header keys, found "
                                   f"{type(raw).__name__}")
    header: dict[str, tuple[int | None, str]] = {}
    notes: list[str] = []
    for key, value in raw.items():
        if key == "file":
            continue
        if key not in _HEADER_KEYS:
            raise MeasurementFileError(src, None, f"unknown header key '{key}'; expected one of "
                                       f"{', '.join(_HEADER_KEYS)}")
        if key == "note":
            notes += [str(v) for v in (value if isinstance(value, list) else [value])]
            continue
        text = ", ".join(str(v) for v in value) if isinstance(value, list) else str(value)
        header[key] = (None, text)
    return header, notes


def _parse_header(src: str, header: dict[str, tuple[int, str]]) -> dict:
    def get(key: str) -> tuple[int, str] | None:
        return header.get(key)

    if "format_version" in header:
        no, v = header["format_version"]
        if v != str(FORMAT_VERSION):
            raise MeasurementFileError(src, no, f"header key 'format_version': expected {FORMAT_VERSION}, found {v!r}")
    meta: dict = {}
    if "bar_length_mm" not in header:
        raise MeasurementFileError(src, None, "missing header key 'bar_length_mm' (e.g. '# bar_length_mm: 150')")
    no, v = header["bar_length_mm"]
    (L,) = _numbers(src, no, "bar_length_mm", v, 1)
    if L <= 0:
        raise MeasurementFileError(src, no, f"header key 'bar_length_mm': expected a positive length, found {v!r}")
    meta["bar_length"] = L * 1e-3
    if "fixed_ball_mm" not in header:
        raise MeasurementFileError(src, None, "missing header key 'fixed_ball_mm' (e.g. '# fixed_ball_mm: 0, 0, 0')")
    no, v = header["fixed_ball_mm"]
    meta["fixed_ball"] = np.array(_numbers(src, no, "fixed_ball_mm", v, 3)) * 1e-3
    if (h := get("ball_offset_mm")) is not None:
        meta["ball_offset"] = np.array(_numbers(src, h[0], "ball_offset_mm", h[1], 3)) * 1e-3
    if (h := get("range_mm")) is not None:
        lo, hi = _numbers(src, h[0], "range_mm", h[1], 2)
        if not lo < hi:
            raise MeasurementFileError(src, h[0], f"header key 'range_mm': expected lower < upper, found {h[1]!r}")
        meta["range"] = (lo * 1e-3, hi * 1e-3)
    for key, attr, scale in (("resolution_um", "resolution", 1e-6), ("accuracy_um", "accuracy", 1e-6),
                             ("sample_rate_hz", "sample_rate", 1.0)):
        if (h := get(key)) is not None:
            (x,) = _numbers(src, h[0], key, h[1], 1)
            if x <= 0:
                raise MeasurementFileError(src, h[0], f"header key '{key}': expected a positive number, "
                                           f"found {h[1]!r}")
            meta[attr] = x * scale
    for key in ("machine", "instrument"):
        if (h := get(key)) is not None:
            meta[key] = h[1]
    if (h := get("plane")) is not None:
        if h[1].upper() not in ("XY", "YZ", "ZX", "XZ", "AUTO"):
            raise MeasurementFileError(src, h[0], f"header key 'plane': expected XY, YZ, ZX, XZ or auto, "
                                       f"found {h[1]!r}")
        meta["plane"] = h[1].upper() if h[1].upper() != "AUTO" else "auto"
    return meta


def _parse_point_header(src: str, header: dict[str, tuple[int, str]], kind: str) -> dict:
    """Header of a tracker / pose file (module docstring); every key optional (defaults: the assumed AT960-class
    figures of :class:`PointMeasurement`)."""
    if "format_version" in header:
        no, v = header["format_version"]
        if v != str(FORMAT_VERSION):
            raise MeasurementFileError(src, no, f"header key 'format_version': expected {FORMAT_VERSION}, found {v!r}")
    meta: dict = {}
    if (h := header.get("target_mm")) is not None:
        meta["target"] = np.array(_numbers(src, h[0], "target_mm", h[1], 3)) * 1e-3
    if kind == "tracker":
        for key in ("angle_resolution_urad", "angle_accuracy_urad"):
            if key in header:
                raise MeasurementFileError(src, header[key][0], f"header key '{key}' belongs to a pose file, not to "
                                           "a tracker file (instrument_type: tracker)")
    for key, attr, scale, zero_ok in (("volume_radius_mm", "volume_radius", 1e-3, False),
                                      ("resolution_um", "resolution", 1e-6, True),
                                      ("accuracy_um", "accuracy", 1e-6, True),
                                      ("accuracy_um_per_m", "accuracy_per_m", 1e-6, True),
                                      ("standoff_mm", "standoff", 1e-3, True),
                                      ("angle_resolution_urad", "angle_resolution", 1e-6, True),
                                      ("angle_accuracy_urad", "angle_accuracy", 1e-6, True),
                                      ("sample_rate_hz", "sample_rate", 1.0, False)):
        if (h := header.get(key)) is not None:
            (x,) = _numbers(src, h[0], key, h[1], 1)
            if x < 0 or (x == 0 and not zero_ok):
                what = "a non-negative" if zero_ok else "a positive"
                raise MeasurementFileError(src, h[0], f"header key '{key}': expected {what} number, found {h[1]!r}")
            meta[attr] = x * scale
    for key in ("machine", "instrument"):
        if (h := header.get(key)) is not None:
            meta[key] = h[1]
    return meta


def _parse_columns(src: str, line: int, columns: list[str], kind: str = "ballbar") -> dict:
    layout: dict = {}
    drives: list[tuple[int, int, str]] = []
    reads = READING_COLUMNS[kind]
    allowed = ("t_s",) + POSE_COLUMNS + ("q<i>_mm", "q<i>_deg") + reads + _OPTIONAL
    for j, name in enumerate(columns):
        m = _DRIVE_RE.match(name)
        if name in layout or (m and any(d[0] == int(m.group(1)) for d in drives)):
            raise MeasurementFileError(src, line, f"duplicate column '{name}'", j + 1, name)
        if m:
            drives.append((int(m.group(1)), j, m.group(2)))
        elif name in ("t_s",) + reads + POSE_COLUMNS + _OPTIONAL:
            layout[name] = j
        else:
            other = [k for k, cols in READING_COLUMNS.items() if name in cols and k != kind]
            hint = (f" ('{name}' is a reading of a {other[-1]} file; set the header key 'instrument_type')"
                    if other else "")
            raise MeasurementFileError(src, line, f"unknown column '{name}' in a {kind} file{hint}; expected one "
                                       f"of {', '.join(allowed)}", j + 1, name)
    for req in ("t_s",) + reads:
        if req not in layout:
            raise MeasurementFileError(src, line, f"missing column '{req}' (a {kind} file)")
    have = [c for c in POSE_COLUMNS if c in layout]
    if have and len(have) != 6:
        missing = [c for c in POSE_COLUMNS if c not in layout]
        raise MeasurementFileError(src, line, f"pose columns incomplete: missing {', '.join(missing)}")
    if drives:
        drives.sort()
        idx = [d[0] for d in drives]
        if idx != list(range(1, len(idx) + 1)):
            raise MeasurementFileError(src, line, f"drive columns must be q1..q{len(idx)}, found "
                                       f"{', '.join('q%d' % i for i in idx)}")
        layout["drives"] = [(j, u) for _, j, u in drives]
    if not have and not drives:
        raise MeasurementFileError(src, line, "expected the commanded pose (x_mm,y_mm,z_mm,a_deg,b_deg,c_deg) or "
                                   "drive values (q1_mm, ...) among the columns")
    return layout
