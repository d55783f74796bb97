"""Parsing the compact range and angle texts of the command line and of sweep/report files (mm and degrees in,
SI out): ``"y=-600:800,z=-1200:-500"`` and ``"a,b,c"``."""

from __future__ import annotations

import math

import numpy as np

from pkmstiff.errors import SectionArgumentError


#: the one ``--range`` syntax of section, workspace and rotation-map: AXIS=LO:HI pairs separated by commas
RANGE_SYNTAX = "AXIS=LO:HI pairs separated by commas"


def parse_axis_ranges(text: str, axes: str, unit: str, option: str = "--range", required: bool = True,
                      error: type[Exception] = SectionArgumentError) -> dict[str, tuple[float, float]]:
    """``"y=-600:800,z=-1200:-500"`` -> {"y": (-600.0, 800.0), "z": (-1200.0, -500.0)} in ``unit`` (not converted):
    each axis one of ``axes`` at most once, LO < HI and finite; every axis of ``axes`` given unless not ``required``."""
    out: dict[str, tuple[float, float]] = {}
    for part in text.split(","):
        try:
            axis, rng = part.split("=")
            lo, hi = (float(v) for v in rng.split(":"))
        except ValueError:
            raise error(f"{option}: expected {RANGE_SYNTAX} (AXIS one of {', '.join(axes)}, LO and HI in {unit}), "
                        f"found {part!r}") from None
        axis = axis.strip().lower()
        if axis not in axes or len(axis) != 1:
            raise error(f"{option}: expected an axis among {', '.join(axes)}, found {axis!r}")
        if axis in out:
            raise error(f"{option}: expected each axis once, found {axis!r} twice")
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise error(f"{option} {axis}: expected LO < HI ({unit}), found {lo:g}:{hi:g}")
        out[axis] = (lo, hi)
    missing = [a for a in axes if a not in out]
    if required and missing:
        raise error(f"{option}: missing the range of {', '.join(missing)} ({RANGE_SYNTAX})")
    return out


def parse_ranges(text: str, plane: str) -> dict[str, tuple[float, float]]:
    """``"y=-600:800,z=-1200:-500"`` (mm) -> {"y": (-0.6, 0.8), "z": (-1.2, -0.5)} in m, for the plane's axes."""
    return {a: (lo * 1e-3, hi * 1e-3) for a, (lo, hi) in parse_axis_ranges(text, plane, "mm").items()}


def parse_numbers(text: str, count: int, option: str, what: str,
                  error: type[Exception] = SectionArgumentError, count_text: str | None = None) -> list[float]:
    """``"1,-2,3.5"`` -> ``count`` finite floats; otherwise ``error`` with one line naming ``option``, the expected
    count and meaning ``what`` (e.g. ``"x,y,z,a,b,c (mm, deg)"``) and the text found."""
    n = count_text or str(count)
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise error(f"{option}: expected {n} numbers {what}, found {text!r}") from None
    if len(vals) != count or not all(math.isfinite(v) for v in vals):
        raise error(f"{option}: expected {n} finite numbers {what}, found {text!r}")
    return vals


def parse_names(text: str, option: str, choices: tuple[str, ...] | None = None,
                error: type[Exception] = SectionArgumentError) -> list[str]:
    """``"kx, ky"`` -> ``["kx", "ky"]``: at least one name, each from ``choices`` when given; otherwise ``error``."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    want = f"a comma-separated subset of {','.join(choices)}" if choices else "one or more comma-separated names"
    if not names:
        raise error(f"{option}: expected {want}, found {text!r}")
    bad = [n for n in names if choices and n not in choices]
    if bad:
        raise error(f"{option}: expected {want}, found {', '.join(bad)}")
    return names


def parse_triple_deg(text: str, what: str) -> np.ndarray:
    """``"a,b,c"`` in degrees -> (3,) array in rad; ``what`` names the option in the error."""
    return np.deg2rad(parse_numbers(text, 3, what, "a,b,c in degrees", count_text="three"))
