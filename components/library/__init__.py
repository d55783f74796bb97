"""The component library: catalogues of named component entries (products such as ball-screw sizes and leads, guide
carriages, joints) for the categorical variables of ``pkmstiff optimise`` (docs/user-guide/optimise.md).

A catalogue is a TOML file: an optional ``[catalogue]`` table (``title``, ``provenance``) and one table per entry,
each a component table exactly as a machine file's ``[components.<name>]`` (``model = "..."`` and the model's
parameters with units). Every entry is built with its model on loading (:func:`components.registry.build_component`),
so a bad entry is an :class:`~pkmstiff.errors.InputError` naming the catalogue file and ``<entry>.<parameter>``.
Catalogues shipped with the package live beside this module (:func:`bundled_catalogues`); any other is a file path.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pkmstiff.errors import InputError

__all__ = ["Catalogue", "bundled_catalogues", "load_catalogue"]

_DIR = Path(__file__).resolve().parent
_META = "catalogue"


@dataclass(frozen=True)
class Catalogue:
    """Named component tables (raw, as written in the file) with the catalogue's title and provenance."""

    name: str
    path: str
    entries: dict[str, dict[str, Any]] = field(default_factory=dict)
    title: str = ""
    provenance: str = ""


def bundled_catalogues() -> list[str]:
    """Names (file stems) of the catalogues shipped in ``components/library/``."""
    return sorted(p.stem for p in _DIR.glob("*.toml"))


def load_catalogue(name_or_path: str | Path, base_dir: str | Path | None = None) -> Catalogue:
    """A bundled catalogue by name, or a catalogue file (absolute or relative to ``base_dir``); every entry is
    built once with its component model (errors name the file and ``<entry>.<parameter>``)."""
    from components.registry import build_component

    text = str(name_or_path)
    path = _DIR / f"{text}.toml"
    if not (text in bundled_catalogues() and path.is_file()):
        path = Path(text)
        if not path.is_absolute() and base_dir is not None:
            path = Path(base_dir) / path
    if not path.is_file():
        raise InputError("", "catalogue", f"a bundled catalogue ({', '.join(bundled_catalogues())}) or a catalogue "
                                          f"file (TOML)", text)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(str(path), "(syntax)", "valid TOML", str(exc)) from None
    meta = raw.pop(_META, {})
    if not isinstance(meta, dict) or set(meta) - {"title", "provenance"}:
        raise InputError(str(path), _META, "a table with 'title' and 'provenance'", meta)
    if not raw:
        raise InputError(str(path), "(entries)", "at least one entry table", "none")
    for name, table in raw.items():
        if not isinstance(table, dict):
            raise InputError(str(path), name, "an entry table (a component table with 'model')", table)
        try:
            build_component(name, table, source=str(path), base_dir=path.parent)
        except InputError as exc:  # the registry names machine-file keys 'components.<entry>.<parameter>'
            raise InputError(str(path), exc.key.removeprefix("components."), exc.expected, exc.found) from None
    return Catalogue(path.stem, str(path), raw, str(meta.get("title", "")), str(meta.get("provenance", "")))
