"""What a command's ``machine`` argument names: one resolver and one dispatch for every machine kind.

Three kinds of model reach the commands ``pose``, ``point`` and ``section``: spatial machines (machine files,
:mod:`pkmstiff.machine`), the planar examples (:mod:`pkmstiff.analysis.planar`) and generic mechanisms (mechanism
files, :mod:`pkmstiff.mechanisms`). :func:`resolve` asks each kind, in the fixed order of :data:`KINDS`, whether it
recognises the name or file (bundled names first, so that a spatial machine is settled without importing the
mechanism solver); a command keeps a table ``{Kind: evaluator}`` and calls :func:`dispatch`, which falls back to the
spatial evaluator for a kind the command does not evaluate (its loader then says what is wrong with the name).
Adding a kind = one :class:`Kind` member, one recogniser in :data:`KINDS`, and an evaluator in the tables of the
commands that support it.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar


class Kind(enum.Enum):
    """The kind of model a machine argument names."""

    SPATIAL = "spatial machine"
    PLANAR = "planar machine"
    MECHANISM = "mechanism"


@dataclass(frozen=True)
class Target:
    """A machine argument with its kind (the model itself is loaded by the kind's evaluator)."""

    spec: str
    kind: Kind


def _bundled_spatial(spec: str) -> bool:
    from pkmstiff.machine import bundled_machines

    return spec in bundled_machines()


def _mechanism_file(spec: str) -> bool | None:
    """For an existing ``.toml`` file: True if it is a mechanism file (a ``[mechanism]`` table), False for any other
    (a machine file; the machine loader reports what is wrong with it); None for anything else."""
    from pkmstiff.errors import InputError
    from pkmstiff.io import read_toml

    p = Path(spec)
    if not (p.suffix == ".toml" and p.is_file()):
        return None
    try:
        return "mechanism" in read_toml(p, "machine or mechanism file")
    except InputError:
        return False


def _bundled_planar(spec: str) -> bool:
    from pkmstiff.analysis.planar import bundled_planar

    return spec in bundled_planar()


def _mechanism(spec: str) -> bool:
    from pkmstiff.mechanisms.loader import is_mechanism

    return is_mechanism(spec)


#: (kind, recogniser) in the order asked; a recogniser answers True (this kind), False (the next entry's kind is
#: not asked either: a file that is not a mechanism file is a machine file) or None (not recognised, ask on)
KINDS: tuple[tuple[Kind, Callable[[str], bool | None]], ...] = (
    (Kind.SPATIAL, lambda s: True if _bundled_spatial(s) else None),
    (Kind.MECHANISM, _mechanism_file),
    (Kind.PLANAR, lambda s: True if _bundled_planar(s) else None),
    (Kind.MECHANISM, lambda s: True if _mechanism(s) else None),
)


def resolve(spec: str) -> Target:
    """The :class:`Target` of a machine argument: the first kind of :data:`KINDS` that recognises it; a spatial
    machine when none does (or when a recogniser rules its kind out)."""
    for kind, recognises in KINDS:
        answer = recognises(spec)
        if answer:
            return Target(spec, kind)
        if answer is False:
            break
    return Target(spec, Kind.SPATIAL)


R = TypeVar("R")


def dispatch(spec: str, evaluators: Mapping[Kind, Callable[[Target], R]]) -> R:
    """Call the evaluator of ``spec``'s kind; a kind without one goes to the spatial evaluator (whose loader names
    the machines there are)."""
    target = resolve(spec)
    return evaluators.get(target.kind, evaluators[Kind.SPATIAL])(target)


def check_start_pose(spec: str, start_pose: str | None) -> None:
    """``--start-pose`` chooses a mechanism's working mode: refused (one line) for any other kind of model."""
    if start_pose is not None and resolve(spec).kind is not Kind.MECHANISM:
        from pkmstiff.errors import ArgumentError

        raise ArgumentError(f"--start-pose: only for a mechanism (its working mode), found '{spec}' (a machine has "
                            "one closed-form configuration per pose)")


__all__ = ["KINDS", "Kind", "Target", "check_start_pose", "dispatch", "resolve"]
