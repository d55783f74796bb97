"""Primitives of the measurement CSV shared by every instrument (the file layout is in
:mod:`pkmstiff.calibration.measurement_file`): number formatting and header values with their line."""

from __future__ import annotations

import math

import numpy as np

from pkmstiff.errors import MeasurementFileError

FORMAT_VERSION = 1


def fmt(x: float) -> str:
    return "%.15g" % float(x)  # 15 significant digits: exact to 1e-15 relative, no binary noise like 0.0193000001


def vec(v: np.ndarray, scale: float) -> str:
    return ", ".join(fmt(x / scale) for x in v)


def numbers(src: str, line: int, key: str, text: str, count: int) -> list[float]:
    """``count`` comma-separated finite numbers of header key ``key`` (one-line error otherwise)."""
    parts = [p.strip() for p in text.split(",")]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        vals = []
    if len(vals) != count or not all(math.isfinite(v) for v in vals):
        what = "a number" if count == 1 else f"{count} comma-separated numbers"
        raise MeasurementFileError(src, line, f"header key '{key}': expected {what}, found {text!r}")
    return vals


def check_version(src: str, header: dict[str, tuple[int, str]]) -> None:
    if "format_version" in header:
        no, v = header["format_version"]
        if v != str(FORMAT_VERSION):
            raise MeasurementFileError(src, no, f"header key 'format_version': expected {FORMAT_VERSION}, found {v!r}")


def scalars(src: str, header: dict[str, tuple[int, str]], specs: tuple[tuple[str, str, float, bool], ...],
            meta: dict) -> None:
    """Positive (or, with ``zero_ok``, non-negative) scalar header keys -> ``meta[attr]`` = value · scale (SI);
    ``specs`` = (key, attr, scale, zero_ok), in order."""
    for key, attr, scale, zero_ok in specs:
        if (h := header.get(key)) is not None:
            (x,) = numbers(src, h[0], key, h[1], 1)
            if x < 0 or (x == 0 and not zero_ok):
                what = "a non-negative" if zero_ok else "a positive"
                raise MeasurementFileError(src, h[0], f"header key '{key}': expected {what} number, found {h[1]!r}")
            meta[attr] = x * scale


def names(header: dict[str, tuple[int, str]], meta: dict) -> None:
    """The free-text header keys ``machine`` and ``instrument`` (the device's name) -> ``meta``."""
    for key, attr in (("machine", "machine"), ("instrument", "device")):
        if (h := header.get(key)) is not None:
            meta[attr] = h[1]
