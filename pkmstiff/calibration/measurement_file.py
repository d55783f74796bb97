"""Measurement files: a CSV and its header (issue 16 item 5; instrument data docs/theory/calibration.md).

pkmstiff writes the header as ``<name>.json`` beside the CSV (issue 22 item 6: the CSV is a plain table that
``pandas.read_csv(path)`` reads with no options); a CSV may instead carry the same keys as ``# key: value`` comment
lines before the column row (the earlier form, read unchanged; a byte-order mark is dropped, cells may be quoted).

This module reads and writes what every instrument's file shares (header lines, time, commanded poses or drive
values, feed, direction, temperature); the header keys and reading columns of each instrument come from its
:class:`~pkmstiff.calibration.instruments.Instrument` (``instrument_type`` names it, :mod:`.instruments.registry`).
The header key ``instrument`` names the device (e.g. QC10), the measurement's ``device`` attribute.

Layout (one sample per row, comma separated, ``#`` starts a comment line)::

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
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pkmstiff.calibration.instruments import BallbarMeasurement, Instrument, PointMeasurement
from pkmstiff.calibration.instruments.file_format import FORMAT_VERSION, fmt
from pkmstiff.calibration.instruments.registry import FILE_DEFAULT, find, instruments, kinds
from pkmstiff.errors import MeasurementFileError
from pkmstiff.io.atomic import atomic_write_text
from pkmstiff.io.columns import sidecar_path
from pkmstiff.io.inputs import input_file_problem

Array = NDArray[np.float64]
Measurement = BallbarMeasurement | PointMeasurement

SIGNATURE = "pkmstiff ball-bar measurement"
POSE_COLUMNS = ("x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg")
_POSE_SCALE = np.array([1e-3, 1e-3, 1e-3, math.pi / 180, math.pi / 180, math.pi / 180])
_DRIVE_RE = re.compile(r"^q(\d+)_(mm|deg)$")
_OPTIONAL = ("feed_mm_min", "direction", "temperature_C")
#: header keys of every measurement file (each instrument adds its own, :attr:`Instrument.header_keys`)
_COMMON_KEYS = ("format_version", "instrument_type", "machine", "instrument", "resolution_um", "accuracy_um",
                "sample_rate_hz", "units", "note")


def range_violations(meas: Measurement) -> NDArray[np.int64]:
    """Indices of samples whose reading lies outside the instrument range (ball bar: ``meas.range`` about the bar
    length; tracker / pose: farther than ``meas.volume_radius`` from the instrument-frame origin)."""
    return meas.instrument.range_violations(meas)


# ------------------------------------------------------------------------------------------------- writing


def write_measurement(path: str | Path, meas: Measurement, *, allow_out_of_range: bool = False) -> Path:
    """Write ``meas`` as a measurement CSV (format above); values are printed with the shortest round-trip repr of
    their value in the file unit, so reading back reproduces them to one unit in the last place.

    Readings outside the instrument range raise :class:`MeasurementFileError` naming the first sample and the
    count, unless ``allow_out_of_range`` (the file then fails to read, as a real instrument's would).
    """
    path = Path(path)
    src = str(path)
    inst = meas.instrument
    inst.check_measurement(src, meas)
    _check_lengths(meas, src)
    bad = inst.range_violations(meas)
    if bad.size and not allow_out_of_range:
        raise MeasurementFileError(src, None, inst.range_message(meas, bad))
    cols = _command_cols(meas) + inst.reading_columns(meas) + _optional_cols(meas)
    for name, values in cols:  # the readings of any instrument, whatever its fields are called
        if len(values) != meas.n_samples:
            raise MeasurementFileError(src, None, f"column '{name}' has {len(values)} samples, expected "
                                       f"{meas.n_samples} (as 't')")
    if inst == FILE_DEFAULT:  # files of the default instrument keep their original header (no instrument_type)
        head = [f"# {SIGNATURE}", f"# format_version: {FORMAT_VERSION}"]
    else:
        head = [f"# pkmstiff {inst} measurement", f"# format_version: {FORMAT_VERSION}", f"# instrument_type: {inst}"]
    head += [f"# machine: {meas.machine}", f"# instrument: {meas.device}"] + inst.header_lines(meas)
    head += [f"# note: {note}" for note in meas.notes]
    return _write_table(path, head, cols, meas.n_samples)


def _json_value(text: str):
    """A header value as JSON data: a number, a list of numbers (``"0, 0, 0"``) or the text."""
    parts = [p.strip() for p in text.split(",")]
    try:
        nums = [float(p) for p in parts]
    except ValueError:
        return text
    nums = [int(v) if v.is_integer() and abs(v) < 2**53 else v for v in nums]
    return nums[0] if len(nums) == 1 else nums


#: header keys whose values stay text in the JSON header even when they look like numbers
_TEXT_KEYS = ("machine", "instrument", "instrument_type", "plane", "units")


def _write_table(path: Path, head: list[str], cols: list, n: int) -> Path:
    """The CSV (the column row and the samples: ``pandas.read_csv(path)`` reads it with no options) and its header
    as ``<name>.json`` beside it (the ``# key: value`` lines of earlier files, which are still read)."""
    meta: dict = {"file": head[0].lstrip("# ").strip()}
    for line in head[1:]:
        key, value = (p.strip() for p in line.lstrip("# ").split(":", 1))
        if key == "note":
            meta.setdefault("note", []).append(value)
        else:
            meta[key] = value if key in _TEXT_KEYS else _json_value(value)
    atomic_write_text(sidecar_path(path), json.dumps(meta, indent=2, ensure_ascii=False) + "\n")
    text_cols = []
    for name, values in cols:
        if name == "direction":
            text_cols.append([str(v) for v in values])
        else:
            text_cols.append([fmt(v) for v in np.asarray(values, dtype=float)])
    rows = [",".join(c[i] for c in text_cols) for i in range(n)]
    atomic_write_text(path, "\n".join([",".join(name for name, _ in cols)] + rows) + "\n")
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


def _check_lengths(meas: BallbarMeasurement | PointMeasurement, src: str) -> None:
    n = meas.n_samples
    for name in ("reading", "position", "rotation", "poses", "drives", "feed", "direction", "temperature"):
        v = getattr(meas, name, None)
        if v is not None and len(v) != n:
            raise MeasurementFileError(src, None, f"'{name}' has {len(v)} samples, expected {n} (as 't')")
    if meas.poses is None and meas.drives is None:
        raise MeasurementFileError(src, None, "a measurement needs commanded poses or drive values")


# ------------------------------------------------------------------------------------------------- reading


def _header_keys() -> tuple[str, ...]:
    keys = list(_COMMON_KEYS)
    for inst in instruments():
        keys += [k for k in inst.header_keys if k not in keys]
    return tuple(keys)


def _foreign_key(src: str, inst: Instrument, key: str, line: int) -> MeasurementFileError:
    """The error for a header key of another instrument's files: named after that instrument when its files
    extend this one's (a pose key in a tracker file), else 'does not belong'."""
    owners = [o for o in instruments() if key in o.header_keys]
    if owners and all(set(inst.header_keys) <= set(o.header_keys) for o in owners):
        return MeasurementFileError(src, line, f"header key '{key}' belongs to a {owners[0]} file, not to a {inst} "
                                    f"file (instrument_type: {inst})")
    return MeasurementFileError(src, line, f"header key '{key}' does not belong to a {inst} file "
                                f"(instrument_type: {inst})")


def _read_sidecar(src: str, known: tuple[str, ...]) -> tuple[dict[str, tuple[int | None, str]], list[str]]:
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
        if key not in known:
            raise MeasurementFileError(src, None, f"unknown header key '{key}'; expected one of {', '.join(known)}")
        if key == "note":
            notes += [str(v) for v in (value if isinstance(value, list) else [value])]
            continue
        header[key] = (None, ", ".join(str(v) for v in value) if isinstance(value, list) else str(value))
    return header, notes


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
    known = _header_keys()
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
            if key not in known:
                raise MeasurementFileError(src, no, f"unknown header key '{key}'; expected one of "
                                           f"{', '.join(known)}")
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
        header, notes = _read_sidecar(hsrc, known)
    inst = FILE_DEFAULT
    if "instrument_type" in header:
        no, kind = header["instrument_type"]
        found = find(kind)
        if found is None:
            raise MeasurementFileError(hsrc, no, f"header key 'instrument_type': expected one of "
                                       f"{', '.join(kinds())}, found {kind!r}")
        inst = found
    for key, (no, _) in header.items():
        if key not in _COMMON_KEYS and key not in inst.header_keys:
            raise _foreign_key(hsrc, inst, key, no)
    meta = inst.parse_header(hsrc, header)
    layout = _parse_columns(src, col_line, columns, inst)
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
    return inst.from_columns(src, lambda name: numeric(layout[name]), common, check_range,
                             lambda i, name: (int(line_no[i]), layout[name] + 1, name))


def _parse_columns(src: str, line: int, columns: list[str], inst: Instrument) -> dict:
    layout: dict = {}
    drives: list[tuple[int, int, str]] = []
    reads = inst.file_columns
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
            other = [o for o in instruments() if name in o.file_columns and o != inst]
            hint = (f" ('{name}' is a reading of a {other[-1]} file; set the header key 'instrument_type')"
                    if other else "")
            raise MeasurementFileError(src, line, f"unknown column '{name}' in a {inst} file{hint}; expected one "
                                       f"of {', '.join(allowed)}", j + 1, name)
    for req in ("t_s",) + reads:
        if req not in layout:
            raise MeasurementFileError(src, line, f"missing column '{req}' (a {inst} file)")
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
