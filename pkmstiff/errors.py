"""The toolkit's exceptions, with one root.

Every error pkmstiff raises on purpose derives from :class:`PkmstiffError`; the command line catches the root and prints
one line (exit status 2). Input errors additionally derive from :class:`ValueError` so that code written against the
standard library's conventions keeps working.
"""

from __future__ import annotations

from typing import Any


class PkmstiffError(Exception):
    """Root of every error the toolkit raises on purpose."""


class InputError(PkmstiffError, ValueError):
    """Invalid input data; the message names file, key, expectation and finding."""

    def __init__(self, source: str, key: str, expected: str, found: Any):
        self.source, self.key, self.expected, self.found = source, key, expected, found
        where = f"{source}: " if source else ""
        super().__init__(f"{where}key '{key}': expected {expected}, found {found!r}")


# ---- mechanisms (generic link-and-joint kinematics, pkmstiff.mechanisms) ----


class MechanismFileError(InputError):
    """A mechanism file is invalid: names file, key (the joint, where one is at fault), expectation and finding."""


class UnknownMechanismError(PkmstiffError, ValueError):
    """No bundled mechanism of that name and no file at that path."""


class MechanismInputError(PkmstiffError, ValueError):
    """Invalid argument of a mechanism function (poses, drive values, parameter names); the message says which."""
