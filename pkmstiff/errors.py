"""The toolkit's exceptions, with one root.

Every error pkmstiff raises on purpose derives from :class:`PkmstiffError`; the command line catches the root and prints
one line (exit status 2). Input errors additionally derive from :class:`ValueError` so that code written against the
standard library's conventions keeps working.
"""

from __future__ import annotations

from typing import Any


class PkmstiffError(Exception):
    """Root of every error the toolkit raises on purpose.

    ``exit_status`` is the command line's exit status for this error (2: bad input; 3: a refused inadmissible pose).
    """

    exit_status = 2


class InputError(PkmstiffError, ValueError):
    """Invalid input data; the message names file, key, expectation and finding."""

    def __init__(self, source: str, key: str, expected: str, found: Any):
        self.source, self.key, self.expected, self.found = source, key, expected, found
        where = f"{source}: " if source else ""
        super().__init__(f"{where}key '{key}': expected {expected}, found {found!r}")


# -------------------- machine


class MachineFileError(InputError):
    """A machine file is invalid (names file, key, what was expected and what was found)."""


class UnknownMachineError(PkmstiffError, ValueError):
    """No bundled machine of that name and no file at that path."""


class OverrideError(MachineFileError):
    """An override path that does not lead into the machine file (names the override and what is there)."""


# -------------------- kinematics


class KinematicsInputError(PkmstiffError, ValueError):
    """Invalid argument of a kinematics function; the message names the argument, expectation and finding."""


# -------------------- multibody


class SDEInputError(InputError):
    """Invalid input to the SDE model; the message names the object, the key, the expectation and the finding."""


class SingularModelError(PkmstiffError, ValueError):
    """The stiffness matrix (or a pivot block of it) is not positive definite: the model is under-restrained."""


# -------------------- structure


class StructureModelError(InputError):
    """The machine's data do not define a structure model (names machine, key, expectation and finding)."""


# -------------------- analysis


class PlanarFileError(InputError):
    """A planar machine file is invalid (names file, key, expectation and finding)."""


# -------------------- evaluation


class SectionError(PkmstiffError, ValueError):
    pass


class SweepError(PkmstiffError, ValueError):
    """An invalid sweep definition (names the parameter or setting, what was expected and what was found)."""


class UnknownQuantityError(PkmstiffError, ValueError):
    pass


# -------------------- workspace


class PlotDependencyError(PkmstiffError, ImportError):
    """matplotlib (2-D maps and curves) is not installed."""


class RequirementError(PkmstiffError, ValueError):
    """A requirement string that cannot be parsed; the message names the text, the expectation and the finding."""


class OracleInputError(PkmstiffError, ValueError):
    """Invalid oracle settings; the message names the argument, the expectation and the finding."""


class VolumeError(PkmstiffError, ValueError):
    """Unknown volume method or unusable input."""


class RotationMapError(PkmstiffError, ValueError):
    """Invalid rotation-map argument; the message names the argument, the expectation and the finding."""


class OctreeInputError(PkmstiffError, ValueError):
    """Invalid octree argument; the message names the argument, the expectation and the finding."""


class SurfaceError(PkmstiffError, ValueError):
    """The octree result cannot be meshed (e.g. it was computed without the closure step)."""


# -------------------- fe


class MeshGeometryError(PkmstiffError, ValueError):
    """A primitive was asked for an impossible geometry (names the primitive, expectation and finding)."""


class MaterialError(PkmstiffError, ValueError):
    """Invalid material constants (names the material, the constant, the expectation and the value)."""


class ConstraintError(PkmstiffError, ValueError):
    """Inconsistent constraints (cyclic ties, singular reduced system); the message names the cause."""


# -------------------- report


class ReportError(PkmstiffError, ValueError):
    """A report cannot be rendered (bad baseline, missing or non-PNG figure); names the table/figure."""


class SpecError(InputError):
    """An invalid report spec (names file, key, what was expected and what was found)."""


class SweepFileError(InputError):
    """An invalid sweep file (names file, key, what was expected and what was found)."""


class InadmissiblePoseError(PkmstiffError, ValueError):
    """The pose of a :class:`PointValues` evaluation is not admissible for this machine variant."""


# -------------------- cli


class SectionArgumentError(PkmstiffError, ValueError):
    pass


class CliError(PkmstiffError):
    """A user error on the command line; printed without traceback, exit code 2."""


class PoseArgumentError(PkmstiffError, ValueError):
    pass


class PointArgumentError(PkmstiffError, ValueError):
    pass


# -------------------- cli (edges: refused poses, outputs, cost)


class InadmissiblePoseRefused(PkmstiffError):
    """``pkmstiff point`` refuses to analyse an inadmissible pose (exit status 3); the message names every failing
    check and the ``--allow-inadmissible`` switch."""

    exit_status = 3


class OutputPathError(CliError):
    """An output path that cannot be written (a file where a directory is needed, an unwritable parent, an existing
    output without ``--force``); raised before any computation."""


class CostLimitError(CliError):
    """The estimated memory of a command exceeds the memory budget (``--memory-budget``); raised before the work."""


class PlausibilityError(InputError):
    """A magnitude outside the documented plausible range of its quantity kind (e.g. a length of 1e300 m)."""


class FormatVersionError(InputError):
    """An input file whose ``format_version`` this version of pkmstiff does not know."""
