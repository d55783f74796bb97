"""Declarations of component models: :class:`Param` (one machine-file parameter) and :class:`ModelSpec`.

A model module declares each model once, next to its class, as a :class:`ModelSpec` listing its parameters.
That one declaration drives the machine-file reader (:class:`components.reader.Params`: unit, default, range
and choices of every key), the ``pkmstiff components`` listing and the generated catalogue
(:func:`components.catalogue.markdown`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Literal

import numpy as np

if TYPE_CHECKING:
    from components.protocol import Component
    from components.reader import Params

ParamKind = Literal["quantity", "choice", "integer", "string", "raw"]


@dataclass(frozen=True)
class Param:
    """One parameter of a ``[components.<name>]`` table.

    ``unit`` is the SI unit the value is converted to (``"-"`` for numbers without unit, choices and text);
    ``default`` is returned as is when the key is absent (``required=True``: the key must be given; a string
    documents a condition under which the model's factory requires it). ``kind`` selects the reader:
    ``"quantity"`` (pint, :func:`pkmstiff.units.parse_quantity`, with ``positive``, ``min_value``, ``shape``
    and ``rigid_ok``), ``"choice"`` (one of ``choices``), ``"integer"``, ``"string"`` or ``"raw"`` (read by
    the factory itself). ``default_text`` replaces the default in the documentation where the value alone
    does not say it (e.g. ``"spindle_length"``).
    """

    key: str
    unit: str
    default: Any = None
    meaning: str = ""
    required: bool | str = False
    kind: ParamKind = "quantity"
    positive: bool = False
    min_value: float | None = None
    shape: tuple[int | None, ...] | None = None
    rigid_ok: bool = False
    choices: tuple[str, ...] = ()
    default_text: str | None = None

    def __post_init__(self) -> None:
        if self.choices and self.kind == "quantity":
            object.__setattr__(self, "kind", "choice")

    @property
    def default_doc(self) -> str:
        """The default as the documentation shows it: ``required``, a condition, or the value."""
        if self.default_text is not None:
            return self.default_text
        if self.required is True:
            return "required"
        if isinstance(self.required, str) and self.required:
            return f"required {self.required}"
        return _format_value(self.default)

    @property
    def accepts(self) -> str:
        """What the reader accepts besides the unit (range, shape, choices), as one short phrase."""
        parts = []
        if self.kind == "choice":
            parts.append("one of " + ", ".join(f"'{c}'" for c in self.choices))
        if self.kind == "integer":
            parts.append("integer" + (f" >= {self.min_value:g}" if self.min_value is not None else ""))
        elif self.positive:
            parts.append("> 0")
        elif self.min_value is not None:
            parts.append(f">= {self.min_value:g}")
        if self.shape is not None:
            parts.append("list" if self.shape == (None,) else "array of shape (" + ", ".join(
                "n" if s is None else str(s) for s in self.shape) + (",)" if len(self.shape) == 1 else ")"))
        if self.rigid_ok:
            parts.append("'rigid' allowed")
        return "; ".join(parts)


def _format_value(value: Any) -> str:
    if value is None:
        return "none"
    if isinstance(value, str):
        return f"'{value}'"
    if isinstance(value, float) and np.isposinf(value):
        return "rigid"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


@dataclass(frozen=True)
class ModelSpec:
    """A component model: ``name`` (the ``model`` value in machine files), one-line ``description``,
    ``equation`` (source reference), declared ``parameters`` and ``factory(p: Params) -> Component``.

    ``tables`` names the format of bundled joint tables the model reads (``"tilt"`` or ``"swivel_tilt"``;
    the catalogue lists their provenance), ``None`` for models without tables.
    """

    name: str
    description: str
    equation: str
    parameters: tuple[Param, ...]
    factory: Callable[["Params"], "Component"]
    tables: str | None = None

    def parameter(self, key: str) -> Param | None:
        """The declaration of ``key``, or ``None``."""
        return next((p for p in self.parameters if p.key == key), None)


#: Compatibility name of :class:`ModelSpec` (``model_info`` returned a ``ModelInfo`` before).
ModelInfo = ModelSpec
