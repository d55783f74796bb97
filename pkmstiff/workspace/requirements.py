"""User requirements on workspace points: ``"kx>=20 N/um"``, ``"f1>=50 Hz"``, ``"U>=0.2"``, ``"kappa<=100"``.

A requirement compares a named per-pose quantity with a limit (docs/theory/workspace.md: "any additional user
requirements (e.g. minimum stiffness, acceleration, orientability, maximum condition number, minimum transmission
quality)"). Quantities come from the shared registry :mod:`pkmstiff.evaluation.quantities` (name -> SI values for a chunk of
poses; ``pkmstiff quantities`` lists them: ``kx``, ``f1``, ``kappa``, ``U``, ``tilt_drive_max``, ...). New
quantities are added with :func:`pkmstiff.evaluation.quantities.register_quantity`.

A requirement is evaluated only on poses that passed every admissibility check (so expensive quantities are
never computed for unreachable poses); a NaN value fails the requirement.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np

from pkmstiff.errors import ArgumentError
from pkmstiff.evaluation.quantities import EvalContext, get_quantity
from pkmstiff.units import ureg

_OPS: dict[str, Callable[[np.ndarray, float], np.ndarray]] = {
    ">=": np.greater_equal, "<=": np.less_equal, ">": np.greater, "<": np.less,
}
_PATTERN = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*(>=|<=|=>|=<|>|<)\s*([^\s<>=].*?)\s*$")




@dataclass(frozen=True)
class Requirement:
    """``quantity op limit`` with the limit in SI units; callable on an :class:`EvalContext`."""

    quantity: str
    op: str
    limit_si: float
    text: str

    def evaluate(self, ctx: EvalContext) -> np.ndarray:
        """(N,) bool: requirement met (NaN values fail)."""
        vals = np.asarray(get_quantity(self.quantity).compute(ctx), float)
        with np.errstate(invalid="ignore"):
            return _OPS[self.op](vals, self.limit_si) & np.isfinite(vals)


def parse_requirement(text: str) -> Requirement:
    """Parse ``"NAME OP VALUE [UNIT]"``, OP in >=, <=, >, <; the value's unit must match the quantity's dimension.

    A dimensionless quantity (``U``, ``kappa``) takes a bare number; any other needs a unit
    (``"kx>=20 N/um"``, ``"f1>=50 Hz"``, ``"tilt_drive_max<=40 deg"``).
    """
    m = _PATTERN.match(text or "")
    if not m:
        raise ArgumentError(f"requirement {text!r}: expected 'NAME OP VALUE [UNIT]' with OP one of >=, <=, >, <, "
                               "e.g. 'kx>=20 N/um' or 'U>=0.2'")
    name, op, value = m.group(1), m.group(2), m.group(3)
    op = {"=>": ">=", "=<": "<="}.get(op, op)
    try:
        q = get_quantity(name)
    except ArgumentError as exc:
        raise ArgumentError(f"requirement {text!r}: {exc}") from None
    try:
        parsed = ureg()(value)
    except Exception:
        raise ArgumentError(f"requirement {text!r}: expected a number with a unit of {q.unit}, "
                               f"found {value!r}") from None
    dimensionless = not hasattr(parsed, "units") or parsed.dimensionless and str(parsed.units) == "dimensionless"
    if dimensionless:
        if q.si_unit not in ("1", "dimensionless"):
            raise ArgumentError(f"requirement {text!r}: quantity {name!r} needs a unit (e.g. "
                                   f"'{name}{op}{value} {q.unit}'), found a bare number")
        limit = float(getattr(parsed, "magnitude", parsed))
    else:
        target = ureg()("dimensionless" if q.si_unit == "1" else q.si_unit)
        target = target if hasattr(target, "units") else ureg().Quantity(target)
        if parsed.dimensionality != target.dimensionality:
            raise ArgumentError(f"requirement {text!r}: expected a value in {q.unit} (or another unit of the "
                                   f"same dimension), found {value!r}")
        limit = float(parsed.to(target.units).magnitude) / float(target.magnitude)
    if not np.isfinite(limit):
        raise ArgumentError(option=f"requirement {text!r}", expected="a finite limit", found=value)
    return Requirement(name, op, limit, text.strip())


def parse_requirements(texts: Iterable[str | Requirement]) -> list[Requirement]:
    """Parse several requirements (already parsed ones pass through)."""
    return [t if isinstance(t, Requirement) else parse_requirement(t) for t in texts]
