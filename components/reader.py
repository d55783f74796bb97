"""Reader of one ``[components.<name>]`` table: parses every parameter with units and records what was read.

Quantities go through :func:`pkmstiff.units.parse_quantity` (bare numbers are SI, strings carry units such as
``"25 N/um"``, ``"150 mm"``, ``"30 deg"``). ``p[key]`` reads a parameter as its :class:`~components.params.Param`
declaration says; the explicit readers (:meth:`Params.quantity`, :meth:`Params.choice`, ...) serve models
registered without declarations. Every error is an :class:`~pkmstiff.errors.InputError` with the key
``components.<name>.<param>``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from components.params import Param
from pkmstiff.errors import ComponentModelError, InputError
from pkmstiff.units import parse_quantity, si

_MISSING = object()
COMMON_KEYS: tuple[str, ...] = ("model", "assumptions", "provenance")


class Params:
    """Reader for the parameters of one component table; records which keys were used.

    ``declared`` maps keys to their :class:`Param` declarations (used by ``p[key]`` / :meth:`get`).
    Every getter raises :class:`InputError` with key ``components.<name>.<param>``.
    """

    def __init__(self, name: str, params: dict[str, Any], *, source: str, base_dir: str | Path | None,
                 declared: Iterable[Param] = ()):
        self.name = name
        self.source = source
        self.base_dir = Path(base_dir) if base_dir is not None else None
        self.model = str(params.get("model", ""))
        self._params = dict(params)
        self._used: set[str] = set(COMMON_KEYS)
        self._declared = {p.key: p for p in declared}

    def key(self, key: str) -> str:
        """Full key ``components.<name>.<key>`` for error messages."""
        return f"components.{self.name}.{key}"

    def error(self, key: str, expected: str, found: Any) -> InputError:
        return InputError(self.source, self.key(key), expected, found)

    def has(self, key: str) -> bool:
        return key in self._params

    def set_default(self, key: str, value: Any) -> None:
        """Use ``value`` (unparsed, as if written in the table) when the table does not give ``key``."""
        self._params.setdefault(key, value)

    def __getitem__(self, key: str) -> Any:
        return self.get(key)

    def get(self, key: str, **overrides: Any) -> Any:
        """Read ``key`` as declared; ``overrides`` replace fields of the declaration (e.g. a ``shape``
        that depends on another parameter)."""
        decl = self._declared.get(key)
        if decl is None:
            raise ComponentModelError(f"component model '{self.model}' reads parameter '{key}' without declaring it")
        if overrides:
            decl = dataclasses.replace(decl, **overrides)
        default = _MISSING if decl.required is True else decl.default
        if decl.kind == "choice":
            return self.choice(key, decl.choices, default)
        if decl.kind == "integer":
            return self.integer(key, default, min_value=None if decl.min_value is None else int(decl.min_value))
        if decl.kind == "string":
            return self.string(key, default)
        if decl.kind == "raw":
            return self.raw(key, default)
        unit = "dimensionless" if decl.unit == "-" else decl.unit
        return self.quantity(key, unit, default, positive=decl.positive, min_value=decl.min_value,
                             shape=decl.shape, rigid_ok=decl.rigid_ok)

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        """The unparsed value of ``key``; ``default`` (returned as is) when absent, error when required."""
        self._used.add(key)
        if key in self._params:
            return self._params[key]
        if default is _MISSING:
            raise self.error(key, f"a value (required by model '{self.model}')", "nothing (parameter missing)")
        return default

    def quantity(self, key: str, unit: str, default: Any = _MISSING, *, positive: bool = False,
                 min_value: float | None = None, shape: tuple[int | None, ...] | None = None,
                 rigid_ok: bool = False) -> Any:
        """A quantity in SI ``unit`` (``default`` is returned unparsed when the key is absent).

        ``rigid_ok`` also accepts ``"rigid"`` or ``inf`` and returns ``np.inf``.
        """
        if not self.has(key):
            return self.raw(key, default)
        value = self.raw(key)
        if rigid_ok and (value == "rigid" or (isinstance(value, float) and np.isposinf(value))):
            return np.inf
        return parse_quantity(value, unit, source=self.source, key=self.key(key), shape=shape,
                              positive=positive, min_value=min_value)

    def quantity_in(self, key: str, si_unit: str, number_unit: str, default: Any = _MISSING,
                    shape: tuple[int | None, ...] | None = None) -> Any:
        """Like :meth:`quantity`, but bare numbers are read in ``number_unit`` instead of SI."""
        if not self.has(key):
            return self.raw(key, default)
        value = self.raw(key)

        def one(v: Any, k: str) -> float:
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                return float(si(float(v), number_unit))
            return float(parse_quantity(v, si_unit, source=self.source, key=self.key(k)))

        if isinstance(value, dict):
            out = parse_quantity(value, si_unit, source=self.source, key=self.key(key), shape=shape)
        elif isinstance(value, (list, tuple)):
            out = np.array([[one(v, f"{key}[{i}][{j}]") for j, v in enumerate(row)] if isinstance(row, (list, tuple))
                            else one(row, f"{key}[{i}]") for i, row in enumerate(value)], dtype=float)
        else:
            out = one(value, key)
        arr = np.asarray(out)
        if shape is not None and (arr.ndim != len(shape) or any(s is not None and s != a
                                                                for s, a in zip(shape, arr.shape))):
            raise self.error(key, f"an array of shape {shape}", f"shape {arr.shape}")
        return out

    def choice(self, key: str, choices: Iterable[str], default: Any = _MISSING) -> str:
        value = self.raw(key, default)
        choices = tuple(choices)
        if value not in choices:
            raise self.error(key, f"one of {', '.join(repr(c) for c in choices)}", value)
        return value

    def string(self, key: str, default: Any = _MISSING) -> Any:
        value = self.raw(key, default)
        if value is not None and not isinstance(value, str):
            raise self.error(key, "a string", value)
        return value

    def integer(self, key: str, default: Any = _MISSING, *, min_value: int | None = None) -> int:
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or int(value) != value:
            raise self.error(key, "an integer", value)
        if min_value is not None and value < min_value:
            raise self.error(key, f"an integer >= {min_value}", value)
        return int(value)

    def string_table(self, key: str) -> dict[str, str]:
        value = self.raw(key, {})
        if not isinstance(value, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in value.items()):
            raise self.error(key, "a table of strings (parameter = one-line reason)", value)
        return dict(value)

    def exactly_one(self, *groups: tuple[str, ...]) -> int:
        """Index of the single parameter group that is present (e.g. ``("k",), ("E", "area")``)."""
        present = [i for i, g in enumerate(groups) if any(self.has(k) for k in g)]
        if len(present) != 1:
            alts = " or ".join("+".join(g) for g in groups)
            found = "none" if not present else " and ".join("+".join(groups[i]) for i in present)
            raise self.error(groups[0][0] if not present else groups[present[-1]][0], f"exactly one of {alts}", found)
        return present[0]

    def unused(self) -> list[str]:
        return [k for k in self._params if k not in self._used]
