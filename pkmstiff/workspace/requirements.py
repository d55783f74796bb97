"""User requirements on workspace points: ``"kx>=20 N/um"``, ``"f1>=50 Hz"``, ``"U>=0.2"``, ``"kappa<=100"``.

A requirement compares a named per-pose quantity with a limit (spec models.md §7.3: "any additional user
requirements (e.g. minimum stiffness, acceleration, orientability, maximum condition number, minimum transmission
quality)"). Quantities come from the shared registry :mod:`pkmstiff.quantities` (name -> SI values for a chunk of
poses); the kinematic ones are available now (``kappa``, ``U``, per-joint ``tilt_drive_3`` / ``swivel_platform_1``,
``drive_load_2``, and the maxima over all chains registered here: ``tilt_drive_max``, ``tilt_platform_max``,
``swivel_drive_max``, ``swivel_platform_max``, ``drive_load_max``). Structure-model quantities (``kx``, ``f1``, ...)
are added by the structure-model code through the same registry; :func:`register_quantity` is the short hook:

    register_quantity("kx", "N/um", lambda ctx: stiffness_x(ctx.machine, ctx.ev))  # SI values (N/m)

A requirement is evaluated only on poses that passed every admissibility check (so expensive quantities are
never computed for unreachable poses); a NaN value fails the requirement.
"""

from __future__ import annotations

import importlib
import re
from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np

from ..quantities import EvalContext, Quantity, UnknownQuantityError, get_quantity
from ..quantities import register_quantity as _register
from ..units import ureg

_OPS: dict[str, Callable[[np.ndarray, float], np.ndarray]] = {
    ">=": np.greater_equal, "<=": np.less_equal, ">": np.greater, "<": np.less,
}
_PATTERN = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*(>=|<=|=>|=<|>|<)\s*(\S.*?)\s*$")
# modules that register further quantities when imported (structure model); tried once on an unknown name
_PROVIDERS = ("pkmstiff.analysis",)


class RequirementError(ValueError):
    """A requirement string that cannot be parsed; the message names the text, the expectation and the finding."""


_SI_CANDIDATES = ("N/m", "N*m/rad", "Hz", "rad", "m", "N", "m/s", "m/s^2", "kg", "s")


def _si_unit_of(unit: str) -> str:
    """The SI unit with the dimension of ``unit`` ("N/um" -> "N/m", "deg" -> "rad"); base units otherwise."""
    if unit in ("1", "", "dimensionless"):
        return "1"
    q = ureg()(unit)
    for cand in _SI_CANDIDATES:
        if ureg()(cand).dimensionality == q.dimensionality:
            return cand
    return str(q.to_base_units().units)


def register_quantity(name: str, unit: str, fn: Callable[[EvalContext], np.ndarray], label: str | None = None,
                      needs_structure: bool = False) -> Quantity:
    """Register a per-pose quantity usable in requirements and section maps.

    ``unit`` is the display unit (``"N/um"``, ``"Hz"``, ``"deg"``, ``"1"``); ``fn(ctx)`` returns SI values
    of shape (N,) for the poses of ``ctx.ev`` (:class:`pkmstiff.quantities.EvalContext`).
    """
    q = Quantity(name, label or name, unit or "1", _si_unit_of(unit), fn,
                 group="structure" if needs_structure else "kinematics", needs_structure=needs_structure)
    return _register(q)


def _max_abs(key: str) -> Callable[[EvalContext], np.ndarray]:
    def f(ctx: EvalContext) -> np.ndarray:
        arr = np.abs(ctx.ev.angles[key])
        with np.errstate(invalid="ignore"):
            return np.where(np.isnan(arr).all(axis=1), np.nan, np.nanmax(np.where(np.isnan(arr), -np.inf, arr), axis=1))
    return f


def _drive_load_max(ctx: EvalContext) -> np.ndarray:
    if ctx.ev.drive_loads is None:
        return np.full(len(ctx.ev.poses), np.nan)
    return np.abs(ctx.ev.drive_loads).max(axis=1)


for _side in ("drive", "platform"):
    for _qty in ("tilt", "swivel"):
        register_quantity(f"{_qty}_{_side}_max", "deg", _max_abs(f"{_side}_{_qty}"),
                          label=f"largest {_qty} angle of the {_side}-side joints")
register_quantity("drive_load_max", "N", _drive_load_max, label="largest static drive load |tau_g| (eq. 4.90)")


def lookup_quantity(name: str) -> Quantity:
    """The registered quantity ``name``; imports the structure-model providers once if it is unknown."""
    try:
        return get_quantity(name)
    except UnknownQuantityError:
        for mod in _PROVIDERS:
            try:
                importlib.import_module(mod)
            except ModuleNotFoundError:
                continue
        return get_quantity(name)


@dataclass(frozen=True)
class Requirement:
    """``quantity op limit`` with the limit in SI units; callable on an :class:`EvalContext`."""

    quantity: str
    op: str
    limit_si: float
    text: str

    def evaluate(self, ctx: EvalContext) -> np.ndarray:
        """(N,) bool: requirement met (NaN values fail)."""
        vals = np.asarray(lookup_quantity(self.quantity).compute(ctx), float)
        with np.errstate(invalid="ignore"):
            return _OPS[self.op](vals, self.limit_si) & np.isfinite(vals)


def parse_requirement(text: str) -> Requirement:
    """Parse ``"NAME OP VALUE [UNIT]"``, OP in >=, <=, >, <; the value's unit must match the quantity's dimension.

    A dimensionless quantity (``U``, ``kappa``) takes a bare number; any other needs a unit
    (``"kx>=20 N/um"``, ``"f1>=50 Hz"``, ``"tilt_drive_max<=40 deg"``).
    """
    m = _PATTERN.match(text or "")
    if not m:
        raise RequirementError(f"requirement {text!r}: expected 'NAME OP VALUE [UNIT]' with OP one of >=, <=, >, <, "
                               "e.g. 'kx>=20 N/um' or 'U>=0.2'")
    name, op, value = m.group(1), m.group(2), m.group(3)
    op = {"=>": ">=", "=<": "<="}.get(op, op)
    try:
        q = lookup_quantity(name)
    except UnknownQuantityError as exc:
        raise RequirementError(f"requirement {text!r}: {exc}") from None
    try:
        parsed = ureg()(value)
    except Exception:
        raise RequirementError(f"requirement {text!r}: expected a number with a unit of {q.unit}, "
                               f"found {value!r}") from None
    dimensionless = not hasattr(parsed, "units") or parsed.dimensionless and str(parsed.units) == "dimensionless"
    if dimensionless:
        if q.si_unit not in ("1", "dimensionless"):
            raise RequirementError(f"requirement {text!r}: quantity {name!r} needs a unit (e.g. "
                                   f"'{name}{op}{value} {q.unit}'), found a bare number")
        limit = float(getattr(parsed, "magnitude", parsed))
    else:
        target = ureg()("dimensionless" if q.si_unit == "1" else q.si_unit)
        target = target if hasattr(target, "units") else ureg().Quantity(target)
        if parsed.dimensionality != target.dimensionality:
            raise RequirementError(f"requirement {text!r}: expected a value in {q.unit} (or another unit of the "
                                   f"same dimension), found {value!r}")
        limit = float(parsed.to(target.units).magnitude) / float(target.magnitude)
    if not np.isfinite(limit):
        raise RequirementError(f"requirement {text!r}: expected a finite limit, found {value!r}")
    return Requirement(name, op, limit, text.strip())


def parse_requirements(texts: Iterable[str | Requirement]) -> list[Requirement]:
    """Parse several requirements (already parsed ones pass through)."""
    return [t if isinstance(t, Requirement) else parse_requirement(t) for t in texts]
