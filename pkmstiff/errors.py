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


# --- calibration: ball-bar evaluation and measurement files (pkmstiff.calibration.ballbar / .measurement_file) ---

class BallbarError(InputError):
    """Ball-bar data that cannot be evaluated (too few samples, an incomplete revolution, a non-planar run, ...)."""

    def __init__(self, message: str, source: str = ""):
        self.source, self.key, self.expected, self.found = source, "", "", None
        Exception.__init__(self, f"{source}: {message}" if source else message)


class MeasurementFileError(BallbarError):
    """A malformed measurement CSV; the one-line message names file, line (1-based) and column (1-based, name)."""

    def __init__(self, source: str, line: int | None, message: str, column: int | None = None,
                 column_name: str | None = None):
        self.line, self.column, self.column_name = line, column, column_name
        where = []
        if line is not None:
            where.append(f"line {line}")
        if column is not None:
            where.append(f"column {column}" + (f" ({column_name})" if column_name else ""))
        prefix = ", ".join(where)
        super().__init__(f"{prefix}: {message}" if prefix else message, source)
