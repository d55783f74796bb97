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


# -------------------- components


class ComponentDataError(PkmstiffError, ValueError):
    """Data a component cannot use: invalid constructor arguments or a state array it needs but was not given."""


class ComponentRangeError(PkmstiffError, ValueError):
    """A state value (angle, position) lies outside the range a component can evaluate."""


class ComponentModelError(PkmstiffError, ValueError):
    """A component model is registered or declared inconsistently (name taken, parameter read but not declared)."""


class JointTableNotFound(InputError):
    """The named joint table is neither a bundled table nor an existing file."""
