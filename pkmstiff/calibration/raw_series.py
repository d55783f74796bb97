"""Raw ball-bar series: what a ball bar records during one run, before it is tied to the machine's poses (issue 26
item 1; read by :mod:`pkmstiff.calibration.raw_import`).

One file per run (one capture): optional header lines ``# key: value``, an optional column row, then one sample
per line: the deviation (the measured distance minus the bar length), or the time and the deviation, separated by
commas, semicolons, tabs or blanks::

    # sample_rate_hz: 250
    # bar_length_mm: 150
    # feed_mm_min: 500
    # direction: ccw
    # segment: 1
    t_s, deviation_mm
    0.000, -0.50012
    0.004, -0.50013

Header keys (each may instead be given on the command line; both given and different is an error):
``sample_rate_hz`` (required without a time column; with one it must match the median time step to 1 %),
``bar_length_mm`` (checked against the plan), ``feed_mm_min`` (the programmed feed), ``direction`` (``ccw``/``cw``),
``segment`` (1-based path segment of the plan), ``run`` (1-based run of the NC program, instead of segment and
direction), ``start_offset_s`` (time of the start of the feed-in arc in this file: skips the synchronisation
search), ``unit`` (``mm`` default, or ``um``), ``instrument`` (device name, default QC10), ``accuracy_um``. Any
other ``# …`` line is a comment. A column row names the unit when it ends in ``_mm`` or ``_um``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pkmstiff.calibration.instruments.file_format import fmt
from pkmstiff.errors import InputError
from pkmstiff.io.atomic import atomic_write_text
from pkmstiff.io.inputs import read_text_file

#: header keys of a raw series and the attribute each sets
KEYS = {"sample_rate_hz": "sample_rate", "bar_length_mm": "bar_length", "feed_mm_min": "feed",
        "direction": "direction", "segment": "segment", "run": "run", "start_offset_s": "start_offset",
        "unit": "unit", "instrument": "device", "accuracy_um": "accuracy"}
_SPLIT = re.compile(r"[,;\t ]+")


@dataclass
class RawSeries:
    """One raw ball-bar run (SI): ``t`` [s] (from the time column or k / sample rate), ``deviation`` [m], and the
    header values (None where not given): ``sample_rate`` [Hz], ``bar_length`` [m], ``feed`` [m/s], ``direction``,
    ``segment`` and ``run`` (1-based), ``start_offset`` [s], ``device``, ``accuracy`` [m]; ``lines`` the file line
    of each sample; ``sources`` where each value came from (header line or option)."""

    path: str
    t: np.ndarray
    deviation: np.ndarray
    sample_rate: float | None = None
    bar_length: float | None = None
    feed: float | None = None
    direction: str | None = None
    segment: int | None = None
    run: int | None = None
    start_offset: float | None = None
    unit: str = "mm"
    device: str = "QC10"
    accuracy: float | None = None
    lines: np.ndarray | None = None
    sources: dict[str, str] = field(default_factory=dict)

    def where(self, attr: str) -> str:
        """'header line N' or the option that set ``attr``."""
        return self.sources.get(attr, "as given")


def _value(src: str, no: int, key: str, text: str):
    attr = KEYS[key]
    if attr in ("direction",):
        if text.lower() not in ("ccw", "cw"):
            raise InputError(src, key=key, line=no, reason=f"key '{key}': expected ccw or cw, found {text!r}")
        return text.lower()
    if attr in ("unit",):
        if text.lower() not in ("mm", "um", "µm"):
            raise InputError(src, key=key, line=no, reason=f"key '{key}': expected mm or um, found {text!r}")
        return "um" if text.lower() in ("um", "µm") else "mm"
    if attr == "device":
        return text
    try:
        v = float(text)
    except ValueError:
        raise InputError(src, key=key, line=no, reason=f"key '{key}': expected a number, found {text!r}") from None
    if attr in ("segment", "run"):
        if v != int(v) or v < 1:
            raise InputError(src, key=key, line=no, reason=f"key '{key}': expected a positive integer, found {text!r}")
        return int(v)
    if not np.isfinite(v) or (v <= 0 and attr != "start_offset") or v < 0:
        raise InputError(src, key=key, line=no, reason=f"key '{key}': expected a positive number, found {text!r}")
    return v * {"bar_length": 1e-3, "feed": 1e-3 / 60, "accuracy": 1e-6}.get(attr, 1.0)


def read_raw(path: str | Path, options: dict | None = None) -> RawSeries:
    """Read a raw series (module docstring) into SI; ``options`` {attribute: SI value} from the command line fill
    what the header does not give (a different value in both is an error). Every problem is a one-line
    :class:`InputError` naming the file, line and key."""
    src = str(path)
    text = read_text_file(src, "a raw ball-bar series")
    head: dict[str, tuple[int, object]] = {}
    rows: list[list[float]] = []
    lines: list[int] = []
    unit_col = None
    ncol = None
    for no, raw in enumerate(text.splitlines(), start=1):
        s = raw.strip()
        if not s:
            continue
        if s.startswith("#"):
            body = s.lstrip("#").strip()
            if ":" in body:
                key, val = (p.strip() for p in body.split(":", 1))
                if key in KEYS:
                    if key in head:
                        raise InputError(src, key=key, line=no, reason=f"key '{key}': repeated header key (first on line "
                                                                       f"{head[key][0]})")
                    head[key] = (no, _value(src, no, key, val))
            continue
        cells = [c for c in _SPLIT.split(s) if c]
        try:
            vals = [float(c) for c in cells]
        except ValueError:
            if rows or unit_col is not None:
                bad = next(c for c in cells if not _is_number(c))
                raise InputError(src, line=no, reason=f"expected a number, found {bad!r}") from None
            unit_col = cells  # the column row
            continue
        if ncol is None:
            ncol = len(vals)
            if ncol not in (1, 2):
                raise InputError(src, line=no, reason=f"expected 1 (deviation) or 2 (time, deviation) numbers per "
                                                      f"line, found {ncol}")
        elif len(vals) != ncol:
            raise InputError(src, line=no, reason=f"expected {ncol} numbers per line (as line {lines[0]}), found "
                                                  f"{len(vals)}")
        if not all(np.isfinite(vals)):
            raise InputError(src, line=no, reason=f"expected finite numbers, found {s!r}")
        rows.append(vals)
        lines.append(no)
    if len(rows) < 2:
        raise InputError(src, reason=f"expected a series of deviations, found {len(rows)} sample(s)")
    data = np.array(rows)
    series = RawSeries(src, np.zeros(0), np.zeros(0), lines=np.array(lines))
    for key, (no, v) in head.items():
        setattr(series, KEYS[key], v)
        series.sources[KEYS[key]] = f"header line {no}"
    for attr, v in (options or {}).items():
        if v is None:
            continue
        have = getattr(series, attr)
        if attr in series.sources and not _same(have, v):
            raise InputError(src, key=_key(attr), line=int(series.sources[attr].split()[-1]),
                             reason=f"key '{_key(attr)}': the header gives {_show(attr, have)}, the command line "
                                    f"{_show(attr, v)}")
        setattr(series, attr, v)
        series.sources.setdefault(attr, f"--{attr.replace('_', '-')}")
    if unit_col is not None and unit_col[-1].lower().endswith(("_um", "_µm")):
        series.unit = "um"
    scale = 1e-6 if series.unit == "um" else 1e-3
    series.deviation = data[:, -1] * scale
    if ncol == 2:
        t = data[:, 0]
        dt = np.diff(t)
        if np.any(dt <= 0):
            i = int(np.flatnonzero(dt <= 0)[0]) + 1
            raise InputError(src, line=lines[i], reason=f"time must increase, found {t[i]:g} s after {t[i - 1]:g} s")
        rate = 1.0 / float(np.median(dt))
        if series.sample_rate is not None and abs(rate / series.sample_rate - 1) > 0.01:
            raise InputError(src, key="sample_rate_hz", reason=f"key 'sample_rate_hz': expected the time column's rate "
                             f"{rate:.6g} Hz (within 1 %), found {series.sample_rate:g} Hz ({series.where('sample_rate')})")
        series.sample_rate = series.sample_rate or rate
        series.t = t
    else:
        if series.sample_rate is None:
            raise InputError(src, key="sample_rate_hz", reason="key 'sample_rate_hz': expected the sample rate (header '# sample_rate_hz: "
                                                               "250' or --sample-rate) for a series without times")
        series.t = np.arange(len(data)) / series.sample_rate
    return series


def _is_number(c: str) -> bool:
    try:
        float(c)
    except ValueError:
        return False
    return True


def _key(attr: str) -> str:
    return next(k for k, a in KEYS.items() if a == attr)


def _same(a, b) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        return bool(np.isclose(float(a), float(b), rtol=1e-9, atol=0.0))
    return a == b


def _show(attr: str, v) -> str:
    scale = {"bar_length": (1e-3, "mm"), "feed": (1e-3 / 60, "mm/min"), "accuracy": (1e-6, "um"),
             "sample_rate": (1.0, "Hz"), "start_offset": (1.0, "s")}
    if attr in scale:
        f, u = scale[attr]
        return f"{float(v) / f:g} {u}"
    return str(v)


def raw_text(series: RawSeries, note: str = "") -> str:
    """The file text of ``series`` (module docstring), the deviation in mm, times only implied by the rate."""
    head = ["# pkmstiff raw ball-bar series" + (f" ({note})" if note else "")]
    for key, attr in KEYS.items():
        v = getattr(series, attr)
        if v is None or attr in ("unit", "start_offset"):
            continue
        head.append(f"# {key}: {_show(attr, v).split()[0] if attr in ('bar_length', 'feed', 'accuracy', 'sample_rate') else v}")
    head.append("deviation_mm")
    return "\n".join(head + [fmt(v) for v in series.deviation / 1e-3]) + "\n"


def write_raw(path: str | Path, series: RawSeries, note: str = "") -> Path:
    """Write ``series`` atomically (the caller checks ``--force``)."""
    atomic_write_text(path, raw_text(series, note))
    return Path(path)


__all__ = ["KEYS", "RawSeries", "raw_text", "read_raw", "write_raw"]
