"""One allowed-key check for every TOML input (machine, planar, sweep, report, FE parameters, calibration, mechanism).

Tables are checked key by key so that the error names the file, the dotted key, what was expected and what was found.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from pkmstiff.errors import InputError


def check_keys(table: Any, allowed: Iterable[str], source: str, prefix: str = "") -> dict[str, Any]:
    """Return ``table`` if it is a table whose keys all lie in ``allowed``; else raise :class:`InputError` naming the
    first offending key as ``prefix + key`` (``prefix`` ends with a dot, e.g. ``"chains[2]."``)."""
    allowed = set(allowed)
    if not isinstance(table, dict):
        raise InputError(source, prefix.rstrip(".") or "(top level)", "a table", table)
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise InputError(source, f"{prefix}{unknown[0]}", f"one of the keys {sorted(allowed)}", "unknown key")
    return table


def require(table: dict[str, Any], key: str, source: str, prefix: str = "", what: str = "a value") -> Any:
    """Return ``table[key]``; a missing key raises :class:`InputError` naming ``prefix + key`` and ``what`` was
    expected."""
    if key not in table:
        raise InputError(source, f"{prefix}{key}", f"{what} (the key is required)", "missing key")
    return table[key]


def check_format_version(raw: dict[str, Any], source: str, supported: Iterable[int] = (1,)) -> int:
    """Return the file's ``format_version`` (default 1 when absent); an unknown version raises :class:`InputError`
    naming the file, the versions this pkmstiff reads and the finding."""
    supported = tuple(supported)
    v = raw.get("format_version", 1)
    if isinstance(v, bool) or not isinstance(v, int) or v not in supported:
        raise InputError(source, "format_version", "one of " + ", ".join(map(str, supported))
                         + " (a newer file needs a newer pkmstiff)", v)
    return v
