"""Parsing the compact range and angle texts of the command line and of sweep/report files (mm and degrees in,
SI out): ``"y=-600:800,z=-1200:-500"`` and ``"a,b,c"``."""

from __future__ import annotations

import math

import numpy as np

from pkmstiff.errors import ArgumentError


def parse_ranges(text: str, plane: str) -> dict[str, tuple[float, float]]:
    """``"y=-600:800,z=-1200:-500"`` (mm) -> {"y": (-0.6, 0.8), "z": (-1.2, -0.5)} in m, for the plane's axes."""
    out = {}
    for part in text.split(","):
        try:
            axis, rng = part.split("=")
            lo, hi = (float(v) for v in rng.split(":"))
        except ValueError:
            raise ArgumentError(option="--range", expected="AXIS=LO:HI pairs in mm separated by commas",
                                found=part) from None
        axis = axis.strip().lower()
        if axis not in plane:
            raise ArgumentError(f"axis {axis!r} is not in the {plane.upper()} plane", option="--range")
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise ArgumentError(f"expected LO < HI (mm), found {lo:g}:{hi:g}", option=f"--range {axis}")
        out[axis] = (lo * 1e-3, hi * 1e-3)
    missing = [a for a in plane if a not in out]
    if missing:
        raise ArgumentError(f"missing the range of {', '.join(missing)} for the {plane.upper()} plane",
                            option="--range")
    return out


def parse_numbers(text: str, count: int, option: str, what: str, count_text: str | None = None) -> list[float]:
    """``"1,-2,3.5"`` -> ``count`` finite floats; otherwise an :class:`ArgumentError` naming ``option``, the expected
    count and meaning ``what`` (e.g. ``"x,y,z,a,b,c (mm, deg)"``) and the text found."""
    n = count_text or str(count)
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise ArgumentError(option=option, expected=f"{n} numbers {what}", found=text) from None
    if len(vals) != count or not all(math.isfinite(v) for v in vals):
        raise ArgumentError(option=option, expected=f"{n} finite numbers {what}", found=text)
    return vals


def parse_triple_deg(text: str, what: str) -> np.ndarray:
    """``"a,b,c"`` in degrees -> (3,) array in rad; ``what`` names the option in the error."""
    return np.deg2rad(parse_numbers(text, 3, what, "a,b,c in degrees", count_text="three"))
