"""Parsing of quantities with units from input files (pint), returning SI magnitudes.

Accepted forms for a quantity expected in the dimension of ``unit`` (an SI unit string such as
``"N/m"``, ``"m"``, ``"rad"``, ``"kg*m^2"``):

* a bare number -> taken as SI (``2.7`` for a length means 2.7 m);
* a string with a unit -> ``"150 mm"``, ``"25 N/um"``, ``"30 deg"``, ``"4348 N*m/urad"``;
* a list of those (vectors / tables), e.g. ``[1.35, "800 mm", 0]``;
* a table ``{value = [1350, 800, 0], unit = "mm"}``.

Every error is an :class:`InputError` naming the source file, the key, what was expected and what was found.
"""

from __future__ import annotations

import math
import re
import threading
from functools import lru_cache
from typing import Any

import numpy as np

from pkmstiff.errors import InputError

#: Plausible magnitudes per quantity kind (SI), checked by :func:`parse_quantity` so that typos such as a length of
#: 1e300 m or a stiffness in N/µm written as N/m × 1e12 are rejected with one line. Keys are pint dimensionalities,
#: values (kind, largest plausible absolute SI magnitude). The bounds are generous (a factor of ~100 beyond the largest
#: machine tools, spindles and FE models in the spec) and documented in docs/user-guide/cli-output.md.
PLAUSIBLE_RANGES: dict[str, tuple[str, float]] = {
    "[length]": ("length", 1.0e3),                                  # 1 km: machine frames are a few metres
    "[mass]": ("mass", 1.0e6),                                      # 1000 t
    "[length] ** 2 * [mass]": ("moment of inertia", 1.0e6),         # kg·m²
    "[length] * [mass] / [time] ** 2": ("force", 1.0e9),            # N
    "[mass] / [time] ** 2": ("translational stiffness", 1.0e15),    # N/m (1e9 N/µm)
    "[length] ** 2 * [mass] / [time] ** 2": ("torque or rotational stiffness", 1.0e15),  # N·m, N·m/rad
    "[mass] / [length] / [time] ** 2": ("pressure or elastic modulus", 1.0e13),  # Pa (diamond: 1.2e12)
    "[mass] / [length] ** 3": ("density", 1.0e5),                   # kg/m³ (osmium: 2.3e4)
    "[length] / [time]": ("velocity", 1.0e3),                       # m/s
    "[length] / [time] ** 2": ("acceleration", 1.0e5),              # m/s²
    "[time]": ("time", 1.0e9),                                      # s
    "1 / [time]": ("frequency", 1.0e9),                             # Hz
    "[mass] / [time]": ("damping", 1.0e12),                         # N·s/m
}
#: any other dimensional quantity: |value| <= this (SI)
PLAUSIBLE_DEFAULT = 1.0e20


_UREG: list[Any] = []
_UREG_LOCK = threading.Lock()


def ureg() -> "pint.UnitRegistry":  # noqa: F821 (pint is imported here, on first use: ~0.3 s of start-up)
    """The one unit registry of the process, made at the first call. Under a lock: two threads asking first (a Dask
    worker's warm-up beside a task) made two registries, and a quantity of one converted by the other failed
    ("Cannot convert from 'newton / micrometer' to 'dimensionless'")."""
    if not _UREG:
        with _UREG_LOCK:
            if not _UREG:
                _UREG.append(_new_registry())
    return _UREG[0]


def _new_registry() -> "pint.UnitRegistry":  # noqa: F821
    import pint

    # pint's on-disk cache of its parsed definitions (the user cache directory) cuts the registry's start-up from
    # ~0.35 s to ~0.07 s CPU (benchmarks/bench_startup.py); the definitions, hence every conversion, are the same
    try:
        reg = pint.UnitRegistry(cache_folder=":auto:")
    except Exception:  # noqa: BLE001 (no writable cache directory: parse the definitions every time)
        reg = pint.UnitRegistry()
    # the field writes micrometres as "um" (pint knows "um" and "µm"); nothing else to add
    return reg


@lru_cache(maxsize=256)
def _si_factor(unit: str) -> tuple[float, Any]:
    q = ureg()(unit)
    q = q if isinstance(q, ureg().Quantity) else ureg().Quantity(q)
    return float(q.to_base_units().magnitude), q.dimensionality


@lru_cache(maxsize=4096)
def _si_quantity(text: str) -> tuple[float, Any]:
    """(magnitude in SI base units, dimensionality) of a quantity string; (the number, None) for a plain number.
    Kept per string: the machine files of a study's variants repeat their component data (pint parses slowly)."""
    q = ureg()(text)
    if not isinstance(q, ureg().Quantity):
        return float(q), None
    return float(q.to_base_units().magnitude), q.dimensionality


#: longest quantity string accepted (a quantity is a number and a unit; longer text is not a quantity)
MAX_QUANTITY_CHARS = 200
#: an exponent: ``**`` or ``^`` after a name or digit, then a plain number of at most two digits
_POWER = re.compile(r"(\*\*|\^)")
_PLAIN_EXPONENT = re.compile(r"\s*[+-]?\d{1,2}(\.\d+)?(?![\d.])(?!\s*(\*\*|\^))")


def _check_expression(text: str, what: str, source: str, key: str) -> None:
    """Refuse unit expressions that pint would evaluate at length before any conversion (``"9**9**9 mm"`` spins for
    minutes): at most :data:`MAX_QUANTITY_CHARS` characters, and every power a name or number raised to a plain number
    of at most two digits (``m**2``, ``kg*m^2``, ``s^-1``) — no power of a power or of a bracket."""
    if len(text) > MAX_QUANTITY_CHARS:
        raise InputError(source, key, f"{what} of at most {MAX_QUANTITY_CHARS} characters", text[:40] + "...")
    for m in _POWER.finditer(text):
        before = text[:m.start()].rstrip()
        if not before or not (before[-1].isalnum() or before[-1] == "_") or not _PLAIN_EXPONENT.match(text, m.end()):
            raise InputError(source, key, f"{what} whose powers are plain numbers (e.g. 'kg*m^2')", text)


def _scalar(value: Any, unit: str, source: str, key: str) -> float:
    if isinstance(value, bool):
        raise InputError(source, key, f"a number or a quantity in {unit}", value)
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, str):
        _check_expression(value, f"a quantity in {unit}", source, key)
        try:
            si, qdim = _si_quantity(value)
        except Exception as exc:  # pint raises several kinds
            raise InputError(source, key, f"a quantity in {unit} (e.g. '1.5 {unit}')", value) from exc
        if qdim is None:
            return si  # dimensionless string like "2.5"
        factor, dim = _si_factor(unit)
        if qdim != dim:
            raise InputError(source, key, f"a quantity with the dimension of {unit}", f"{value} ({qdim})")
        return si / factor
    raise InputError(source, key, f"a number or a quantity in {unit}", value)


def parse_quantity(
    value: Any,
    unit: str,
    *,
    source: str = "",
    key: str = "",
    shape: tuple[int | None, ...] | None = None,
    min_value: float | None = None,
    positive: bool = False,
    allow_nan: bool = False,
    plausible: bool = True,
) -> float | np.ndarray:
    """Parse ``value`` as a quantity of the dimension of ``unit`` and return its magnitude in ``unit``.

    ``unit`` should be the SI unit (then the result is SI). ``shape`` (``None`` entries are free) is
    checked for array values; a scalar is expected when ``shape`` is ``None``. ``min_value`` and
    ``positive`` check the range; NaN/inf are rejected unless ``allow_nan``. Unless ``plausible=False`` the magnitude
    must lie in the plausible range of its quantity kind (:data:`PLAUSIBLE_RANGES`, :class:`InputError`).
    """
    if isinstance(value, dict):
        if set(value) != {"value", "unit"}:
            raise InputError(source, key, "a table with exactly the keys 'value' and 'unit'", value)
        vunit = value["unit"]
        _check_expression(str(vunit), "a unit name", source, key + ".unit")
        try:
            factor, dim = _si_factor(str(vunit))
            tfactor, tdim = _si_factor(unit)
        except Exception as exc:
            raise InputError(source, key + ".unit", "a unit name understood by pint", vunit) from exc
        if dim != tdim:
            raise InputError(source, key + ".unit", f"a unit with the dimension of {unit}", vunit)
        raw = parse_quantity(value["value"], "dimensionless", source=source, key=key + ".value",
                             shape=shape, allow_nan=allow_nan)
        result = np.asarray(raw, dtype=float) * (factor / tfactor)
        result = float(result) if np.ndim(result) == 0 else result
    elif isinstance(value, (list, tuple)):
        try:
            result = np.array(_nested(value, unit, source, key), dtype=float)
        except ValueError as exc:
            if isinstance(exc, InputError):
                raise
            raise InputError(source, key, "a rectangular array", value) from exc
    else:
        if unit == "dimensionless" and isinstance(value, str):
            try:
                result = float(value)
            except ValueError:
                raise InputError(source, key, "a number", value) from None
        else:
            result = _scalar(value, unit, source, key)

    arr = np.asarray(result)
    if shape is None and arr.ndim != 0:
        raise InputError(source, key, f"a single quantity in {unit}", value)
    if shape is not None:
        if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"
            raise InputError(source, key, f"an array of shape {want} in {unit}", f"shape {arr.shape}: {value}")
    if not allow_nan and not np.all(np.isfinite(arr)):
        raise InputError(source, key, f"finite numbers in {unit}", value)
    if positive and np.any(arr <= 0):
        raise InputError(source, key, f"positive values in {unit}", value)
    if min_value is not None and np.any(arr < min_value):
        raise InputError(source, key, f"values >= {min_value:g} {unit}", value)
    if plausible and unit != "dimensionless" and arr.size:
        check_plausible(arr, unit, source, key, value)
    return float(arr) if arr.ndim == 0 else arr


def plausible_range(unit: str) -> tuple[str, float]:
    """(kind, largest plausible absolute magnitude in ``unit``) of the quantity kind of ``unit``."""
    factor, dim = _si_factor(unit)
    kind, limit = PLAUSIBLE_RANGES.get(str(dim), (f"quantity in {unit}", PLAUSIBLE_DEFAULT))
    return kind, limit / factor if factor else limit


def check_plausible(arr: np.ndarray, unit: str, source: str, key: str, found: Any) -> None:
    """Reject magnitudes beyond the documented plausible range of their kind (:data:`PLAUSIBLE_RANGES`)."""
    if str(_si_factor(unit)[1]) == "dimensionless":
        return
    kind, limit = plausible_range(unit)
    finite = np.asarray(arr, dtype=float)
    finite = finite[np.isfinite(finite)]
    if finite.size and np.max(np.abs(finite)) > limit:
        raise InputError(source, key, f"a plausible {kind} (|value| <= {limit:.3g} {unit})", found)


def _nested(value: Any, unit: str, source: str, key: str) -> Any:
    if isinstance(value, (list, tuple)):
        return [_nested(v, unit, source, f"{key}[{i}]") for i, v in enumerate(value)]
    if unit == "dimensionless":
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        raise InputError(source, key, "a number", value)
    return _scalar(value, unit, source, key)


def to_unit(value_si: float | np.ndarray, unit: str) -> float | np.ndarray:
    """Convert an SI magnitude to ``unit`` (for output at the edges: mm, deg, N/um, ...)."""
    factor, _ = _si_factor(unit)
    return np.asarray(value_si) / factor if np.ndim(value_si) else float(value_si) / factor


def si(value: float | np.ndarray, unit: str) -> float | np.ndarray:
    """Convert a magnitude given in ``unit`` to SI."""
    factor, _ = _si_factor(unit)
    return np.asarray(value) * factor if np.ndim(value) else float(value) * factor


def isfinite_or_raise(x: float, source: str, key: str, expected: str) -> float:
    if not math.isfinite(x):
        raise InputError(source, key, expected, x)
    return x
