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


# ------------------------------------------------------------------------------------------------------ calibration


class CalibrationError(PkmstiffError):
    """A calibration task cannot be carried out as set up (singular set-up, unreachable plan, failed simulation)."""


class CalibrationInputError(CalibrationError, InputError):
    """Invalid calibration input: unknown parameter names, malformed plan files, inconsistent instrument set-ups."""
