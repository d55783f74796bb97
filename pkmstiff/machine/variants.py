"""Machines with modified parameters: a bundled machine or machine file plus overrides of its raw TOML values.

An override is a dotted path into the machine file's tables and a value written as in the file (a bare number is
SI, a string carries its unit, e.g. ``"300 N/um"``, ``"7 deg"``; lists and tables as in TOML):

    machine_with("hexaglide", {"components.strut_950.k": "300 N/um",
                               "joint_types.iwf_3dof.tilt_min": "7 deg",
                               "chains[3].platform_joint": [0.31, -0.13, 0.15],
                               "chains[*].strut_radius": "30 mm"})

``chains[i]`` is 1-based (chain i, as in the machine file's error messages and the guides' chain lists);
``chains[*]`` sets the key in every chain. Every table on the path must exist in the file (after ``extends`` and
options); the last key may be new (e.g. a limit the file does not set). The modified raw data go through the same
validation as :func:`pkmstiff.machine.loader.load_machine`, so an invalid value or an unknown key gives the usual
:class:`InputError` naming the key; a path that does not lead into the file gives an
:class:`OverrideError` naming the override and the keys available there.
"""

from __future__ import annotations

import copy
import re
from pathlib import Path
from typing import Any, Mapping

from pkmstiff.errors import InputError, OverrideError
from pkmstiff.machine.loader import _build, load_machine, raw_machine, split_machine_spec
from pkmstiff.machine.model import Machine

__all__ = ["machine_with", "parse_override_path", "raw_machine", "apply_overrides",
           "split_machine_spec"]

_SEGMENT = re.compile(r"^(?P<key>[^\[\]]+)(?:\[(?P<index>\*|\d+)\])?$")




def parse_override_path(path: str) -> list[tuple[str, int | str | None]]:
    """``"chains[3].platform_joint"`` -> [("chains", 3), ("platform_joint", None)]; ``[*]`` gives "*"."""
    if not isinstance(path, str) or not path.strip():
        raise OverrideError("(override)", str(path), "a dotted path such as 'components.strut_950.k'", path)
    out: list[tuple[str, int | str | None]] = []
    for seg in path.strip().split("."):
        m = _SEGMENT.match(seg.strip())
        if not m:
            raise OverrideError("(override)", path, "dotted keys, each optionally with a 1-based index [i] or [*], "
                                "e.g. 'chains[3].platform_joint'", seg)
        idx = m.group("index")
        out.append((m.group("key").strip(), None if idx is None else ("*" if idx == "*" else int(idx))))
    return out


def _set(node: Any, segments: list[tuple[str, int | str | None]], value: Any, path: str, src: str, done: str) -> None:
    key, idx = segments[0]
    here = f"{done}.{key}" if done else key
    last = len(segments) == 1
    if not isinstance(node, dict):
        raise OverrideError(src, path, f"a table at '{done}'", type(node).__name__)
    if idx is None:
        if last:
            node[key] = copy.deepcopy(value)
            return
        if key not in node:
            raise OverrideError(src, path, f"an existing table '{here}' (keys at '{done or '(top level)'}': "
                                f"{sorted(node)})", "no such key")
        _set(node[key], segments[1:], value, path, src, here)
        return
    seq = node.get(key)
    if not isinstance(seq, list):
        raise OverrideError(src, path, f"an array of tables at '{here}'",
                            "no such key" if key not in node else type(seq).__name__)
    if idx == "*":
        targets = list(range(len(seq)))
    else:
        if not 1 <= idx <= len(seq):
            raise OverrideError(src, path, f"a 1-based index 1..{len(seq)} into '{here}'", idx)
        targets = [idx - 1]
    for t in targets:
        if last:
            seq[t] = copy.deepcopy(value)
        else:
            _set(seq[t], segments[1:], value, path, src, f"{here}[{t + 1}]")


def _copy_path(node: Any, segments: list[tuple[str, int | str | None]]) -> None:
    """Replace the tables and arrays below ``node`` (a copy already) on the path ``segments`` by shallow copies, so
    that :func:`_set` changes copies only; a path that does not lead into the data is left to :func:`_set`'s
    error."""
    key, idx = segments[0]
    if not isinstance(node, dict) or not isinstance(node.get(key), (dict, list)):
        return
    node[key] = child = copy.copy(node[key])
    if idx is None:
        if len(segments) > 1:
            _copy_path(child, segments[1:])
        return
    if not isinstance(child, list) or len(segments) == 1:
        return
    for t in range(len(child)) if idx == "*" else [idx - 1] if 1 <= idx <= len(child) else []:
        if isinstance(child[t], (dict, list)):
            child[t] = copy.copy(child[t])
            _copy_path(child[t], segments[1:])


#: keys resolved before overrides apply (the parent file, the format, the option tables): an override of them would
#: be accepted and ignored
_RESOLVED_FIRST = (("machine", "extends"), ("format_version",), ("options",))


def apply_overrides(raw: dict[str, Any], overrides: Mapping[str, Any], src: str = "(override)", *,
                    share: bool = False) -> dict[str, Any]:
    """A deep copy of ``raw`` with every override set (in the mapping's order). ``share``: copy only the tables and
    arrays on the overrides' paths and share the rest with ``raw`` (equal data, for reading only, e.g. to hash it;
    a deep copy of a machine file takes about as long as hashing it)."""
    out = dict(raw) if share else copy.deepcopy(raw)
    if share:
        for path in overrides:
            _copy_path(out, parse_override_path(path))
    for path, value in overrides.items():
        keys = tuple(k for k, _ in parse_override_path(path))
        if any(keys[:len(r)] == r for r in _RESOLVED_FIRST):
            raise OverrideError(src, path, "a machine value (machine.extends, format_version and [options] are "
                                "resolved before overrides apply; use another machine file or ':option')", path)
        _set(out, parse_override_path(path), value, path, src, "")
    return out


def machine_with(name_or_path: str | Path, overrides: Mapping[str, Any] | None = None,
                 options: tuple[str, ...] | list[str] = ()) -> Machine:
    """Load a machine (bundled name with ``:options`` or path) with ``overrides`` applied to its raw TOML values.

    The result is validated exactly like :func:`pkmstiff.machine.loader.load_machine` (same builder); with no
    overrides it is ``load_machine(name_or_path, options)`` (a bundled machine then comes from the on-disk cache,
    :mod:`pkmstiff.machine.cache`). Errors name the machine file and, for invalid values, the key and the overrides
    applied.
    """
    overrides = dict(overrides or {})
    if not overrides:
        return load_machine(name_or_path, options)
    raw, src, opts = raw_machine(name_or_path, options)
    raw = apply_overrides(raw, overrides, src)
    where = f"{src} with overrides {sorted(overrides)}"
    try:
        return _build(raw, src, opts)
    except InputError as exc:  # add which overrides were applied
        raise InputError(where if exc.file in (src, "", None) else exc.file, exc.key, exc.expected,
                               exc.found) from None
