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


# -------------------- components


class ComponentDataError(PkmstiffError, ValueError):
    """Data a component cannot use: invalid constructor arguments or a state array it needs but was not given."""


class ComponentRangeError(PkmstiffError, ValueError):
    """A state value (angle, position) lies outside the range a component can evaluate."""


class ComponentModelError(PkmstiffError, ValueError):
    """A component model is registered or declared inconsistently (name taken, parameter read but not declared)."""


class JointTableNotFound(InputError):
    """The named joint table is neither a bundled table nor an existing file."""


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


class ParallelError(PkmstiffError, ValueError):
    """A worker pool or Dask cluster could not run the tasks (bad ``n_jobs``, unreachable scheduler, dead worker)."""


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
    """A range or angle text (``"y=-600:800,z=-1200:-500"``, ``"a,b,c"``) that cannot be read."""


class CliError(PkmstiffError):
    """A user error on the command line; printed without traceback, exit code 2."""


class PoseArgumentError(PkmstiffError, ValueError):
    """A ``--pose`` value that is not six finite numbers x,y,z [mm], a,b,c [deg]."""


class PointArgumentError(PkmstiffError, ValueError):
    """An invalid option of ``pkmstiff point``."""


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


# -------------------- calibration (ball-bar evaluation and measurement files)


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


# -------------------- calibration (error models, plans, identifiability)


class CalibrationError(PkmstiffError):
    """A calibration task cannot be carried out as set up (singular set-up, unreachable plan, failed simulation)."""


class CalibrationInputError(CalibrationError, InputError):
    """Invalid calibration input: unknown parameter names, malformed plan files, inconsistent instrument set-ups."""


# -------------------- mechanisms (generic link-and-joint kinematics)


class MechanismFileError(InputError):
    """A mechanism file is invalid: names file, key (the joint, where one is at fault), expectation and finding."""


class UnknownMechanismError(PkmstiffError, ValueError):
    """No bundled mechanism of that name and no file at that path."""


class MechanismInputError(PkmstiffError, ValueError):
    """Invalid argument of a mechanism function (poses, drive values, parameter names); the message says which."""


# -------------------- optimise


class DesignFileError(InputError):
    """An invalid design file of ``pkmstiff optimise`` (names file:line, key, what was expected and what was found)."""


class NothingFeasibleError(PkmstiffError):
    """An optimisation found no candidate that satisfies every constraint (exit status 3); no "best" is reported."""

    exit_status = 3
