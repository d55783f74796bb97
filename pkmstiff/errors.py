"""The toolkit's exceptions: one root and a handful of kinds, sorted by what went wrong, not by the module that
noticed it (the pint style).

Every error pkmstiff raises on purpose is one of the kinds below, or a subclass of one kept only where a caller must
tell it apart. Each kind keeps the facts as fields and builds its one-line message from them; the command line prints
that line and maps the kind to its exit status in one place (:data:`pkmstiff.cli.EXIT_STATUS`).

===========================  ===========================================================================  ====
kind                         what went wrong (fields)                                                     exit
===========================  ===========================================================================  ====
:class:`InputError`          a value in an input file or data set (file, line, column, key, expected,     2
                             found)
:class:`ArgumentError`       an argument or option (option, expected, found)                              2
:class:`ResourceError`       an estimate beyond a budget; a missing optional dependency (reason)          2
:class:`NumericalError`      an iteration that did not converge, a singular system (reason)               2
:class:`InadmissibleError`   a pose, path or plan the machine cannot reach or admit (reason)              3
===========================  ===========================================================================  ====

Where a finding is not one value, the ``reason`` field says it in words. Input, argument, numerical and
admissibility errors also derive from :class:`ValueError`, so code written against the standard library's
conventions keeps working.
"""

from __future__ import annotations

from typing import Any


class _Unset:
    def __repr__(self) -> str:
        return "<unset>"


#: "no value given" for a ``found`` field (``None`` is a legitimate finding)
UNSET: Any = _Unset()


def _rebuild(cls: type[PkmstiffError], state: dict[str, Any]) -> PkmstiffError:
    exc = cls.__new__(cls)
    exc.__dict__.update(state)
    exc.args = (str(exc),)
    return exc


class PkmstiffError(Exception):
    """Root of every error the toolkit raises on purpose; ``reason`` is the message in words."""

    def __init__(self, reason: str = ""):
        self.reason = reason
        super().__init__(str(self))

    def __str__(self) -> str:
        return self.reason

    def __reduce__(self):  # the fields travel (a worker process rebuilds the same error and message)
        return _rebuild, (type(self), self.__dict__)


class InputError(PkmstiffError, ValueError):
    """A value in an input file or data set: ``file``, ``line`` and ``column`` (where known), the ``key`` (or column
    name), what was ``expected`` and what was ``found``; or, where the finding is not one value, the ``reason``.

    ``raise InputError("m.toml", "chains.kind", "'pod' or 'glide'", "hexapod")`` prints
    ``m.toml: key 'chains.kind': expected 'pod' or 'glide', found 'hexapod'``;
    ``raise InputError("m.csv", "reading_mm", line=9, column=8, reason="expected a number, found 'x'")`` prints
    ``m.csv: line 9, column 8 (reading_mm): expected a number, found 'x'``.
    """

    def __init__(self, file: str = "", key: str = "", expected: str = "", found: Any = None, *,
                 line: int | None = None, column: int | None = None, reason: str = ""):
        self.file, self.key, self.expected, self.found = file, key, expected, found
        self.line, self.column = line, column
        super().__init__(reason)

    def __str__(self) -> str:
        where = [f"line {self.line}"] if self.line is not None else []
        if self.column is not None:
            where.append(f"column {self.column}" + (f" ({self.key})" if self.key and self.reason else ""))
        body = self.reason or f"key '{self.key}': expected {self.expected}, found {self.found!r}"
        return ": ".join(p for p in (self.file, ", ".join(where), body) if p)

    def in_file(self, file: str) -> InputError:
        """This error, naming ``file`` where it names none yet (a unit parser or a component model does not know
        the file it reads from)."""
        if not self.file:
            self.file = file
            self.args = (str(self),)
        return self


class ArgumentError(PkmstiffError, ValueError):
    """An argument or command-line option: ``option``, what was ``expected`` and what was ``found``; or the
    ``reason`` in words (after ``option``, where one is given).

    ``raise ArgumentError(option="--alpha", expected="a probability in (0, 1)", found=1.5)`` prints
    ``--alpha: expected a probability in (0, 1), found 1.5``.
    """

    def __init__(self, reason: str = "", *, option: str = "", expected: str = "", found: Any = UNSET):
        self.option, self.expected, self.found = option, expected, found
        super().__init__(reason)

    @property
    def detail(self) -> str:
        """The message without its ``option``: where a file key stands for the option, the key names it instead."""
        return self.reason if self.found is UNSET else f"expected {self.expected}, found {self.found!r}"

    def __str__(self) -> str:
        return f"{self.option}: {self.detail}" if self.option else self.detail


class ResourceError(PkmstiffError):
    """A computation refused before it starts: its estimate exceeds a budget (memory, time), or an optional
    dependency it needs is not installed; the ``reason`` names the estimate, the budget and the way out."""


class NumericalError(PkmstiffError, ValueError):
    """A computation that failed on its numbers: an iteration that did not converge, a singular (under-restrained,
    rank-deficient) system, a solver that gave up; the ``reason`` names the computation and what to try."""


class InadmissibleError(PkmstiffError, ValueError):
    """A pose, path or plan the machine cannot reach or admit (exit status 3 on the command line); the ``reason``
    names the failing poses and checks."""


# -------------------- the few subclasses that a caller must tell apart from their kind


class ComponentRangeError(ArgumentError):
    """A state value (angle, position) outside the range a component can evaluate: the structure model marks the
    pose instead of failing (:mod:`pkmstiff.structure.stiffness`)."""


class ComponentModelError(ArgumentError):
    """A component model registered or declared inconsistently (a name taken, a parameter read but not declared): a
    fault of the model's code, which the registry passes on instead of blaming the machine file."""


class JointTableNotFound(InputError):
    """The named joint table is neither a bundled table nor an existing file (the tabulated joint then names the
    machine key that referred to it)."""


class OverrideError(InputError):
    """An override path that does not lead into the machine file (names the override and what is there): a design
    file then blames the variable's ``path``, not its value (:mod:`pkmstiff.optimise.design_file`)."""


class UnknownMachineError(ArgumentError):
    """No bundled machine of that name and no file at that path (``extends`` reports it as a machine-file error)."""


class PlotDependencyError(ResourceError, ImportError):
    """matplotlib (2-D maps and curves) is not installed: the command writes its data files and skips the plots."""


class DesignFileError(InputError):
    """An invalid design file of ``pkmstiff optimise`` (names ``file:line``, key, expected and found): the design
    reader passes it on and names the line of any other error it meets (:mod:`pkmstiff.optimise.design_file`)."""
