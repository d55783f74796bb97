"""The registry of component models and the builder of components from machine-file tables.

A ``[components.<name>]`` table selects its model with ``model = "..."``; :func:`build_component` reads the
table with the model's declared parameters (:class:`~components.params.ModelSpec`, declared next to each
model class) and calls its factory. Unknown model, missing or unknown parameter, wrong unit or sign raise
:class:`~pkmstiff.errors.InputError` naming the source file, the key (``components.<name>.<parameter>``), what
was expected and what was found.

Users add their own models with :func:`register_model` (or :func:`register` for a full
:class:`~components.params.ModelSpec`); a factory receives a :class:`~components.reader.Params` reader and
returns a :class:`~components.protocol.Component`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Iterable

from components import ballscrew, bearings, bodies, direct_drive, guides, joints, protocol, struts
from components.params import ModelInfo, ModelSpec, Param
from components.protocol import Component
from components.reader import COMMON_KEYS, Params
from pkmstiff.errors import ComponentModelError, InputError

__all__ = ["COMMON_KEYS", "ModelInfo", "ModelSpec", "Param", "Params", "available_models", "build_component",
           "build_components", "model_info", "models", "register", "register_model"]

#: The modules whose ``MODELS`` are registered on import, in catalogue order.
BUILTIN_MODULES = (protocol, ballscrew, direct_drive, guides, struts, joints, bearings, bodies)

_REGISTRY: dict[str, ModelSpec] = {}


def register(spec: ModelSpec, *, replace: bool = False) -> None:
    """Register a declared model under ``spec.name`` (the ``model`` value in machine files)."""
    if not spec.name or not spec.name.replace("_", "").isalnum():
        raise ComponentModelError(f"register_model: model names use letters, digits and '_', found {spec.name!r}")
    if spec.name in _REGISTRY and not replace:
        raise ComponentModelError(f"register_model: model '{spec.name}' is already registered "
                                  "(pass replace=True to override)")
    _REGISTRY[spec.name] = spec


def register_model(name: str, factory: Callable[[Params], Component], description: str, *, equation: str = "",
                   parameters: Iterable[Param | tuple[str, str, str, str]] = (), replace: bool = False) -> None:
    """Register a component model under ``name`` from its factory and parameter declarations.

    ``factory(p: Params) -> Component`` reads its parameters with ``p[key]`` (declared ones) or
    ``p.quantity(...)`` etc.; every parameter it does not read is reported as unknown. ``parameters`` are
    :class:`Param` declarations, or (key, SI unit, default text, meaning) tuples that only document.
    """
    decls = tuple(p if isinstance(p, Param) else Param(p[0], p[1], None, p[3], required=p[2] == "required",
                                                       default_text=p[2]) for p in parameters)
    register(ModelSpec(name, description, equation, decls, factory), replace=replace)


def models() -> list[ModelSpec]:
    """Every registered model, built-in ones in catalogue order, then user models."""
    return list(_REGISTRY.values())


def available_models() -> dict[str, str]:
    """Registered model names with their one-line descriptions (sorted by name)."""
    return {name: _REGISTRY[name].description for name in sorted(_REGISTRY)}


def model_info(name: str) -> ModelSpec:
    """The declaration of a model (description, equation, parameters, factory)."""
    if name not in _REGISTRY:
        raise KeyError(f"unknown component model {name!r}; available: {', '.join(sorted(_REGISTRY))}")
    return _REGISTRY[name]


def build_component(name: str, params: dict[str, Any], *, source: str = "",
                    base_dir: str | Path | None = None) -> Component:
    """Build the component ``name`` from its parameter table; ``params["model"]`` selects the model.

    ``base_dir`` resolves relative file names (joint tables) — normally the machine file's directory.
    Common optional keys for every model: ``assumptions`` (table parameter -> one-line reason, merged into
    the component's assumptions) and ``provenance`` (string).
    """
    if not isinstance(params, dict):
        raise InputError(source, f"components.{name}", "a table of parameters", params)
    model = params.get("model")
    if model is None:
        raise InputError(source, f"components.{name}.model", f"one of {', '.join(sorted(_REGISTRY))}", "missing")
    if model not in _REGISTRY:
        raise InputError(source, f"components.{name}.model", f"one of {', '.join(sorted(_REGISTRY))}", model)
    spec = _REGISTRY[model]
    p = Params(name, params, source=source, base_dir=base_dir, declared=spec.parameters)
    assumptions = p.string_table("assumptions")
    provenance = p.string("provenance", "")
    try:
        component = spec.factory(p)
    except (InputError, ComponentModelError):
        raise
    except (ValueError, TypeError) as exc:  # an ArgumentError of the component's constructor included
        raise InputError(source, f"components.{name}", f"valid parameters for model '{model}'", str(exc)) from exc
    extra = p.unused()
    if extra:
        known = ", ".join(d.key for d in spec.parameters) or "see available_models()"
        raise p.error(extra[0], f"a parameter of model '{model}' ({known})", f"unknown parameter '{extra[0]}'")
    if not isinstance(component, Component):
        raise TypeError(f"factory of model '{model}' returned {type(component).__name__}, not a Component")
    updates: dict[str, Any] = {"assumptions": {**component.assumptions, **assumptions}}
    if provenance:
        updates["provenance"] = provenance
    for key, value in updates.items():
        object.__setattr__(component, key, value)
    return component


def build_components(table: dict[str, dict[str, Any]], *, source: str = "",
                     base_dir: str | Path | None = None) -> dict[str, Component]:
    """Build all components of a ``[components]`` table: name -> component."""
    return {name: build_component(name, params, source=source, base_dir=base_dir) for name, params in table.items()}


for _module in BUILTIN_MODULES:
    for _spec in _module.MODELS:
        register(_spec)
