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

Every error is a :class:`~pkmstiff.errors.InputError` whose one-line message names the file, the line
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
from pkmstiff.errors import InputError
from pkmstiff.io.atomic import atomic_write_text
from pkmstiff.io.columns import sidecar_path
from pkmstiff.io.inputs import input_file_problem, read_text_file

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
#: column and header key of a file holding several set-ups (:func:`read_measurement_setups`)
SETUP_COLUMN = "setup"
SETUPS_KEY = "setups"


def range_violations(meas: Measurement) -> NDArray[np.int64]:
    """Indices of samples whose reading lies outside the instrument range (ball bar: ``meas.range`` about the bar
    length; tracker / pose: farther than ``meas.volume_radius`` from the instrument-frame origin)."""
    return meas.instrument.range_violations(meas)


# ------------------------------------------------------------------------------------------------- writing


def write_measurement(path: str | Path, meas: Measurement, *, allow_out_of_range: bool = False) -> Path:
    """Write ``meas`` as a measurement CSV (format above); values are printed with the shortest round-trip repr of
    their value in the file unit, so reading back reproduces them to one unit in the last place.

    Readings outside the instrument range raise :class:`InputError` naming the first sample and the
    count, unless ``allow_out_of_range`` (the file then fails to read, as a real instrument's would).
    """
    path = Path(path)
    src = str(path)
    inst = meas.instrument
    inst.check_measurement(src, meas)
    _check_lengths(meas, src)
    bad = inst.range_violations(meas)
    if bad.size and not allow_out_of_range:
        raise InputError(src, reason=inst.range_message(meas, bad))
    cols = _command_cols(meas) + inst.reading_columns(meas) + _optional_cols(meas)
    for name, values in cols:  # the readings of any instrument, whatever its fields are called
        if len(values) != meas.n_samples:
            raise InputError(src, reason=f"column '{name}' has {len(values)} samples, expected "
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


def _write_table(path: Path, head: list[str], cols: list, n: int, extra: dict | None = None) -> Path:
    """The CSV (the column row and the samples: ``pandas.read_csv(path)`` reads it with no options) and its header
    as ``<name>.json`` beside it (the ``# key: value`` lines of earlier files, which are still read)."""
    meta: dict = {"file": head[0].lstrip("# ").strip()}
    for line in head[1:]:
        key, value = (p.strip() for p in line.lstrip("# ").split(":", 1))
        if key == "note":
            meta.setdefault("note", []).append(value)
        else:
            meta[key] = value if key in _TEXT_KEYS else _json_value(value)
    meta.update(extra or {})
    atomic_write_text(sidecar_path(path), json.dumps(meta, indent=2, ensure_ascii=False) + "\n")
    text_cols = []
    for name, values in cols:
        if name == "direction":
            text_cols.append([str(v) for v in values])
        elif name == SETUP_COLUMN:
            text_cols.append([str(int(v)) for v in values])
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
            raise InputError(src, reason=f"'{name}' has {len(v)} samples, expected {n} (as 't')")
    if meas.poses is None and meas.drives is None:
        raise InputError(src, reason="a measurement needs commanded poses or drive values")


# ------------------------------------------------------------------------------------------------- reading


def _header_keys() -> tuple[str, ...]:
    keys = list(_COMMON_KEYS) + [SETUPS_KEY]
    for inst in instruments():
        keys += [k for k in inst.header_keys if k not in keys]
    return tuple(keys)


def _foreign_key(src: str, inst: Instrument, key: str, line: int) -> InputError:
    """The error for a header key of another instrument's files: named after that instrument when its files
    extend this one's (a pose key in a tracker file), else 'does not belong'."""
    owners = [o for o in instruments() if key in o.header_keys]
    if owners and all(set(inst.header_keys) <= set(o.header_keys) for o in owners):
        return InputError(src, line=line, reason=f"header key '{key}' belongs to a {owners[0]} file, not to a {inst} "
                                    f"file (instrument_type: {inst})")
    return InputError(src, line=line, reason=f"header key '{key}' does not belong to a {inst} file "
                                f"(instrument_type: {inst})")


def _read_sidecar(src: str, known: tuple[str, ...]) -> tuple[dict[str, tuple[int | None, str]], list[str]]:
    """The header of a measurement CSV from the JSON file beside it: {key: (None, value text)} and the notes."""
    problem = input_file_problem(src)
    if problem is not None:
        raise InputError(src, reason=f"expected the header file of the measurement, found {problem}")
    try:
        raw = json.loads(Path(src).read_text(encoding="utf-8-sig"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(src, reason=f"expected a JSON object with the header keys, found invalid JSON "
                                   f"({str(exc).splitlines()[0]})") from None
    if not isinstance(raw, dict):
        raise InputError(src, reason=f"expected a JSON object with the header keys, found "
                                   f"{type(raw).__name__}")
    header: dict[str, tuple[int | None, str]] = {}
    notes: list[str] = []
    for key, value in raw.items():
        if key == "file":
            continue
        if key not in known:
            raise InputError(src, reason=f"unknown header key '{key}'; expected one of {', '.join(known)}")
        if key == "note":
            notes += [str(v) for v in (value if isinstance(value, list) else [value])]
            continue
        if key == SETUPS_KEY:
            header[key] = (None, value)  # the set-up tables of a several-set-up file, split by the reader
            continue
        header[key] = (None, ", ".join(str(v) for v in value) if isinstance(value, list) else str(value))
    return header, notes


def read_measurement(path: str | Path, *, check_range: bool = True) -> BallbarMeasurement | PointMeasurement:
    """Read a measurement CSV (format in the module docstring) into SI units: a :class:`BallbarMeasurement`, or
    a :class:`PointMeasurement` for a file with ``instrument_type: tracker`` / ``pose``.

    Raises :class:`InputError` (one line: file, line, column) for: a missing file, unknown or repeated
    header keys, bad header values, a missing column row, unknown/duplicate/missing columns, rows with the wrong
    number of cells, cells that are not finite numbers (or not ccw/cw), time running backwards, and — with
    ``check_range`` — readings outside the instrument range.
    """
    parsed = _parse_file(path)
    src, columns, col_line = parsed[0], parsed[4], parsed[5]
    if SETUP_COLUMN in columns:
        raise InputError(src, line=col_line, reason=f"column '{SETUP_COLUMN}': this file holds several set-ups; "
                                                    "expected one set-up here (calibrate identify and report read "
                                                    "several: read_measurement_setups)")
    return _measurement(*parsed, check_range)


def _parse_file(path: str | Path) -> tuple:
    """(src, header source, header, notes, columns, column-row line, data lines, data rows) of a measurement file."""
    path = Path(path)
    src = str(path)
    text = read_text_file(path, "a regular measurement file")
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
                raise InputError(src, line=no, reason=f"unknown header key '{key}'; expected one of "
                                           f"{', '.join(known)}")
            if key == "note":
                notes.append(value)
                continue
            if key in header:
                raise InputError(src, line=no, reason=f"header key '{key}' repeated (first on line {header[key][0]})")
            header[key] = (no, value)
            continue
        cells = [c.strip() for c in next(csv.reader([s]))]  # quoted cells may hold commas
        if columns is None:
            columns, col_line = cells, no
        else:
            data_lines.append(no)
            data_rows.append(cells)
    if columns is None:
        raise InputError(src, line=len(lines) or None, reason="no column row found (expected a line such as "
                                   "'t_s,x_mm,...,reading_mm')")
    hsrc = src  # where the header came from: the CSV's '# key: value' lines or the JSON file beside it
    if not header and not notes:
        if not os.path.lexists(sidecar_path(path)):
            raise InputError(src, reason=f"no header: neither '# key: value' lines nor "
                                       f"{sidecar_path(path).name} beside the file (a ball-bar file needs at least "
                                       f"bar_length_mm and fixed_ball_mm)")
        hsrc = str(sidecar_path(path))
        header, notes = _read_sidecar(hsrc, known)
    return src, hsrc, header, notes, columns, col_line, data_lines, data_rows


def _measurement(src: str, hsrc: str, header: dict, notes: list[str], columns: list[str], col_line: int,
                 data_lines: list[int], data_rows: list[list[str]], check_range: bool) -> Measurement:
    """The measurement of a parsed header and table (:func:`read_measurement`, one set-up of
    :func:`read_measurement_setups`)."""
    inst = FILE_DEFAULT
    if "instrument_type" in header:
        no, kind = header["instrument_type"]
        found = find(kind)
        if found is None:
            raise InputError(hsrc, line=no, reason=f"header key 'instrument_type': expected one of "
                                       f"{', '.join(kinds())}, found {kind!r}")
        inst = found
    for key, (no, _) in header.items():
        if key not in _COMMON_KEYS and key not in inst.header_keys:
            raise _foreign_key(hsrc, inst, key, no)
    meta = inst.parse_header(hsrc, header)
    layout = _parse_columns(src, col_line, columns, inst)
    if not data_rows:
        raise InputError(src, line=col_line, reason="no data rows after the column row")
    ncol = len(columns)
    for no, cells in zip(data_lines, data_rows):
        if len(cells) != ncol:
            raise InputError(src, line=no, reason=f"expected {ncol} values (as in the column row, line {col_line}), "
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
                    raise InputError(src, key=columns[j], line=int(line_no[i]),
                                     reason=f"expected a number, found {c!r}",
                                               column=j + 1) from None
        bad = ~np.isfinite(vals)
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(src, key=columns[j], line=int(line_no[i]),
                             reason=f"expected a finite number, found {col[i]!r}",
                                       column=j + 1)
        return vals

    t = numeric(layout["t_s"])
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        i = int(back[0]) + 1
        raise InputError(src, key="t_s", line=int(line_no[i]),
                         reason=f"time must not decrease: {t[i]:g} s after {t[i - 1]:g} s",
                                   column=layout["t_s"] + 1)
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
            raise InputError(src, key="direction", line=int(line_no[i]),
                             reason=f"expected 'ccw' or 'cw', found {table[i, j]!r}",
                                       column=j + 1)
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
            raise InputError(src, key=name, line=line, reason=f"duplicate column '{name}'", column=j + 1)
        if m:
            drives.append((int(m.group(1)), j, m.group(2)))
        elif name in ("t_s",) + reads + POSE_COLUMNS + _OPTIONAL:
            layout[name] = j
        else:
            other = [o for o in instruments() if name in o.file_columns and o != inst]
            hint = (f" ('{name}' is a reading of a {other[-1]} file; set the header key 'instrument_type')"
                    if other else "")
            raise InputError(src, key=name, line=line,
                             reason=f"unknown column '{name}' in a {inst} file{hint}; expected one "
                                       f"of {', '.join(allowed)}", column=j + 1)
    for req in ("t_s",) + reads:
        if req not in layout:
            raise InputError(src, line=line, reason=f"missing column '{req}' (a {inst} file)")
    have = [c for c in POSE_COLUMNS if c in layout]
    if have and len(have) != 6:
        missing = [c for c in POSE_COLUMNS if c not in layout]
        raise InputError(src, line=line, reason=f"pose columns incomplete: missing {', '.join(missing)}")
    if drives:
        drives.sort()
        idx = [d[0] for d in drives]
        if idx != list(range(1, len(idx) + 1)):
            raise InputError(src, line=line, reason=f"drive columns must be q1..q{len(idx)}, found "
                                       f"{', '.join(f'q{i}' for i in idx)}")
        layout["drives"] = [(j, u) for _, j, u in drives]
    if not have and not drives:
        raise InputError(src, line=line, reason="expected the commanded pose (x_mm,y_mm,z_mm,a_deg,b_deg,c_deg) or "
                                   "drive values (q1_mm, ...) among the columns")
    return layout


# ------------------------------------------------------------------------------------ several set-ups in one file


def write_measurement_setups(path: str | Path, metas: list[Measurement], *, allow_out_of_range: bool = False) -> Path:
    """Write the measurements of several set-ups of one instrument (issue 26 item 3) as one file: the CSV of
    :func:`write_measurement` with a first column ``setup`` (1, 2, … in the order of ``metas``), and in the JSON
    header the keys the set-ups share plus ``setups``, a list with each set-up's own instrument keys
    (``fixed_ball_mm``, ``bar_length_mm``, ``target_mm`` …)."""
    path = Path(path)
    src = str(path)
    inst = metas[0].instrument
    for k, mm in enumerate(metas):
        if mm.instrument != inst:
            raise InputError(src, SETUPS_KEY, f"set-ups of one instrument ({inst}); set-up {k + 1}",
                             str(mm.instrument))
        inst.check_measurement(src, mm)
        _check_lengths(mm, src)
        bad = inst.range_violations(mm)
        if bad.size and not allow_out_of_range:
            raise InputError(src, reason=f"set-up {k + 1}: " + inst.range_message(mm, bad))
    tables = [_command_cols(mm) + inst.reading_columns(mm) + _optional_cols(mm) for mm in metas]
    names = [n for n, _ in tables[0]]
    for k, cols in enumerate(tables):
        if [n for n, _ in cols] != names:
            raise InputError(src, SETUP_COLUMN, f"the columns {', '.join(names)} in every set-up; set-up {k + 1}",
                             ", ".join(n for n, _ in cols))
    cols = [(SETUP_COLUMN, np.concatenate([np.full(mm.n_samples, k + 1.0) for k, mm in enumerate(metas)]))]
    for j, name in enumerate(names):
        vals = [c[j][1] for c in tables]
        cols.append((name, np.concatenate([np.asarray(v, dtype=object if name == "direction" else float)
                                           for v in vals])))
    first = [f"# pkmstiff {inst} measurement", f"# format_version: {FORMAT_VERSION}", f"# instrument_type: {inst}",
             f"# machine: {metas[0].machine}", f"# instrument: {metas[0].device}"]
    own = [dict(_header_pair(line) for line in inst.header_lines(mm)) for mm in metas]
    shared = {key: v for key, v in own[0].items() if all(o.get(key) == v for o in own[1:])}
    head = first + [f"# {key}: {v}" for key, v in shared.items()] + [f"# note: {n}" for n in dict.fromkeys(n for mm in metas for n in mm.notes)]
    sets = [{key: (v if key in _TEXT_KEYS else _json_value(v)) for key, v in o.items() if key not in shared}
            for o in own]
    return _write_table(path, head, cols, len(cols[0][1]), extra={SETUPS_KEY: sets})


def _header_pair(line: str) -> tuple[str, str]:
    key, value = (p.strip() for p in line.lstrip("# ").split(":", 1))
    return key, value


def read_measurement_setups(path: str | Path, *, check_range: bool = True) -> list[Measurement]:
    """The measurements of a file: one for a one-set-up file (:func:`read_measurement`), one per set-up for a file
    with a ``setup`` column (:func:`write_measurement_setups`), in the order of the ``setups`` header list; line
    numbers in errors are the file's."""
    src, hsrc, header, notes, columns, col_line, data_lines, data_rows = _parse_file(path)
    if SETUP_COLUMN not in columns:
        if SETUPS_KEY in header:
            raise InputError(hsrc, SETUPS_KEY, f"a '{SETUP_COLUMN}' column in {src} (the header lists set-ups)",
                             "none")
        return [_measurement(src, hsrc, header, notes, columns, col_line, data_lines, data_rows, check_range)]
    sets = header.pop(SETUPS_KEY, (None, None))[1]
    if not isinstance(sets, list) or not sets or not all(isinstance(t, dict) for t in sets):
        raise InputError(hsrc, SETUPS_KEY, "a list of set-up tables (one per value of the 'setup' column)",
                         repr(sets))
    j = columns.index(SETUP_COLUMN)
    rest = columns[:j] + columns[j + 1:]
    known = {str(k) for k in range(1, len(sets) + 1)}
    for no, r in zip(data_lines, data_rows):
        if len(r) > j and r[j] not in known:
            raise InputError(src, SETUP_COLUMN, f"a set-up number 1 … {len(sets)} (the header's set-ups)", r[j],
                             line=no, column=j + 1)
    out = []
    for k, table in enumerate(sets, start=1):
        rows = [(no, r[:j] + r[j + 1:]) for no, r in zip(data_lines, data_rows) if len(r) > j and r[j] == str(k)]
        if not rows:
            raise InputError(src, SETUP_COLUMN, f"rows of set-up {k} (the header lists {len(sets)})", "none")
        head = dict(header)
        for key, value in table.items():
            if key in head:
                raise InputError(hsrc, f"{SETUPS_KEY}[{k}].{key}", "a key not also given for all set-ups", key)
            head[key] = (None, ", ".join(str(v) for v in value) if isinstance(value, list) else str(value))
        out.append(_measurement(src, hsrc, head, notes, rest, col_line, [no for no, _ in rows],
                                [r for _, r in rows], check_range))
    return out
