"""Ready-made sweep evaluations: functions of a machine returning named numbers (names carry their units).

Each is a thin front-end (mm and degrees, as in sweep files) to an SI request of
:mod:`pkmstiff.evaluation.requests` / :mod:`pkmstiff.workspace.requests`.

All are frozen dataclasses (picklable, so they run in local processes and on Dask workers). Lengths in mm and angles
in degrees in their settings, as on the command line:

* :class:`SectionStatistics` — statistics of quantities on a section plane, e.g. ``"kx mean [N/um]"``;
* :class:`PointValues` — quantities at one pose, e.g. ``"f1 [Hz]"`` (an inadmissible pose is an error naming why);
* :class:`WorkspaceVolume` — constant-orientation workspace volume, ``"volume [m^3]"``;
* :class:`Combined` — several of these merged into one row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from pkmstiff.errors import InadmissiblePoseError, SectionArgumentError
from pkmstiff.evaluation.cost import POINT_SECONDS, Cost, rows_cost, total
from pkmstiff.evaluation.quantities import get_quantity
from pkmstiff.evaluation.requests import STATISTICS, PointRequest, SectionRequest, statistic
from pkmstiff.evaluation.sweep import SweepError
from pkmstiff.io.ranges import parse_ranges
from pkmstiff.machine.model import Machine
from pkmstiff.workspace.requests import WorkspaceRequest

__all__ = ["SectionStatistics", "PointValues", "WorkspaceVolume", "Combined", "InadmissiblePoseError"]

SECTION_STATISTICS = tuple(STATISTICS)




def _check_quantities(names: Sequence[str], where: str) -> tuple[str, ...]:
    from pkmstiff.evaluation.quantities import UnknownQuantityError, get_quantity

    names = tuple(names)
    if not names or not all(isinstance(n, str) for n in names):
        raise SweepError(f"{where}: expected a non-empty list of quantity names, found {names!r}")
    for n in names:
        try:
            get_quantity(n)
        except UnknownQuantityError as exc:
            raise SweepError(f"{where}: {exc}") from None
    return names


def _orientation(values: Sequence[float], where: str) -> tuple[float, float, float]:
    v = tuple(float(x) for x in values)
    if len(v) != 3 or not all(math.isfinite(x) for x in v):
        raise SweepError(f"{where}: expected three angles a, b, c in deg, found {values!r}")
    return v  # type: ignore[return-value]


def _check_skip(names: Sequence[str], where: str) -> tuple[str, ...]:
    """Admissibility check names to leave out, validated against ``ALL_CHECKS``."""
    from pkmstiff.admissibility.checks import ALL_CHECKS

    names = tuple(names)
    bad = [n for n in names if n not in ALL_CHECKS]
    if bad:
        raise SweepError(f"{where}: expected admissibility check names from {', '.join(ALL_CHECKS)}, found {bad[0]!r}")
    return names


def _check_frame(frame: str, where: str) -> None:
    if frame not in ("machine", "report"):
        raise SweepError(f"{where}: expected 'machine' or 'report', found {frame!r}")


@dataclass(frozen=True)
class SectionStatistics:
    """Statistics of ``quantities`` over the admissible points of a section plane (as ``pkmstiff section``).

    Outputs ``"<q> <stat> [<unit>]"`` for stat in min, mean, max (display unit), area (admissible area, m^2),
    count (admissible points). A statistic without any admissible point is NaN and ``"<q> count [1]"`` says so.
    """

    quantities: tuple[str, ...]
    plane: str = "yz"
    at_mm: float = 0.0
    range: str = "y=-600:800,z=-1200:-500"
    step_mm: float = 20.0
    statistics: tuple[str, ...] = ("mean", "max")
    tool_length_mm: float | None = None
    orientation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    frame: str = "machine"  # frame of at_mm / range ("machine" or "report", pkmstiff.machine.frames)
    neglect_spindle: bool = False  # leave K_U out (docs/user-guide/validation-hexaglide.md, reading: tool length 0)
    skip_checks: tuple[str, ...] = ()  # admissibility checks left out (names of ALL_CHECKS)

    def __post_init__(self) -> None:
        _check_frame(self.frame, "SectionStatistics.frame")
        object.__setattr__(self, "skip_checks", _check_skip(self.skip_checks, "SectionStatistics.skip_checks"))
        object.__setattr__(self, "quantities", _check_quantities(self.quantities, "SectionStatistics.quantities"))
        object.__setattr__(self, "plane", str(self.plane).lower())
        if self.plane not in ("yz", "xz", "xy"):
            raise SweepError(f"SectionStatistics.plane: expected 'yz', 'xz' or 'xy', found {self.plane!r}")
        try:
            parse_ranges(self.range, self.plane)
        except SectionArgumentError as exc:
            raise SweepError(f"SectionStatistics.range: {exc}") from None
        if not (isinstance(self.step_mm, (int, float)) and self.step_mm > 0):
            raise SweepError(f"SectionStatistics.step_mm: expected a positive step in mm, found {self.step_mm!r}")
        stats = tuple(self.statistics)
        bad = [s for s in stats if s not in SECTION_STATISTICS]
        if bad or not stats:
            raise SweepError(f"SectionStatistics.statistics: expected a list of {list(SECTION_STATISTICS)}, "
                             f"found {list(stats)!r}")
        object.__setattr__(self, "statistics", stats)
        object.__setattr__(self, "orientation_deg", _orientation(self.orientation_deg,
                                                                 "SectionStatistics.orientation_deg"))

    def request(self) -> SectionRequest:
        """The SI evaluation request this sweep evaluation stands for."""
        r = parse_ranges(self.range, self.plane)
        return SectionRequest(self.plane, self.at_mm * 1e-3, r[self.plane[0]], r[self.plane[1]], self.step_mm * 1e-3,
                              self.quantities, tuple(np.radians(self.orientation_deg)),
                              None if self.tool_length_mm is None else self.tool_length_mm * 1e-3,
                              frame=self.frame, neglect_spindle=self.neglect_spindle, skip_checks=self.skip_checks)

    def __call__(self, machine: Machine) -> dict[str, float]:
        res = self.request().evaluate(machine)
        out: dict[str, float] = {}
        for q, st in res.statistics().items():
            for s in self.statistics:
                unit = STATISTICS[s][1] or st["unit"]
                out[f"{q} {s} [{unit}]"] = statistic(st, s)
        return out


@dataclass(frozen=True)
class PointValues:
    """Quantities at one pose ``(x, y, z [mm], a, b, c [deg])``: outputs ``"<q> [<unit>]"``.

    An inadmissible pose raises :class:`InadmissiblePoseError` with the failing checks (recorded as the task's
    error); ``suffix`` is appended to the output names (e.g. ``" @z-1000"``) to combine several points.
    """

    pose: tuple[float, float, float, float, float, float]
    quantities: tuple[str, ...]
    tool_length_mm: float | None = None
    suffix: str = ""
    frame: str = "machine"  # frame of the pose's position
    neglect_spindle: bool = False  # leave K_U out
    skip_checks: tuple[str, ...] = ()  # admissibility checks left out (names of ALL_CHECKS)

    def __post_init__(self) -> None:
        _check_frame(self.frame, "PointValues.frame")
        object.__setattr__(self, "skip_checks", _check_skip(self.skip_checks, "PointValues.skip_checks"))
        p = tuple(float(x) for x in self.pose)
        if len(p) != 6 or not all(math.isfinite(x) for x in p):
            raise SweepError(f"PointValues.pose: expected x, y, z [mm], a, b, c [deg], found {self.pose!r}")
        object.__setattr__(self, "pose", p)
        object.__setattr__(self, "quantities", _check_quantities(self.quantities, "PointValues.quantities"))

    def request(self) -> PointRequest:
        """The SI evaluation request this sweep evaluation stands for."""
        pose = (*(v * 1e-3 for v in self.pose[:3]), *np.radians(self.pose[3:]))
        return PointRequest(pose, self.quantities, None if self.tool_length_mm is None else self.tool_length_mm * 1e-3,
                            frame=self.frame, neglect_spindle=self.neglect_spindle, skip_checks=self.skip_checks)

    def __call__(self, machine: Machine) -> dict[str, float]:
        res = self.request().evaluate(machine)
        if not res.admissible:
            raise InadmissiblePoseError(f"pose {list(self.pose)} (mm, deg, {self.frame} frame) is inadmissible for {machine.name}: "
                                        + "; ".join(res.failing))
        return {f"{q} [{get_quantity(q).unit}]{self.suffix}": v for q, v in res.values.items()}


@dataclass(frozen=True)
class WorkspaceVolume:
    """Constant-orientation workspace volume (octree, docs/theory/workspace.md): output ``"volume [m^3]"`` (+ ``"touches box"``).

    ``box_mm`` = (xmin, xmax, ymin, ymax, zmin, zmax) or None (the chains' reach box); ``requirements`` as in
    ``pkmstiff workspace --require``; ``method`` one of :data:`pkmstiff.workspace.volume.METHODS`.
    """

    resolution_mm: float
    box_mm: tuple[float, ...] | None = None
    requirements: tuple[str, ...] = ()
    orientation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    method: str = "surface_nets"
    frame: str = "machine"  # frame of box_mm
    neglect_spindle: bool = False  # leave K_U out (stiffness requirements)
    skip_checks: tuple[str, ...] = ()  # admissibility checks left out (names of ALL_CHECKS)

    def __post_init__(self) -> None:
        _check_frame(self.frame, "WorkspaceVolume.frame")
        object.__setattr__(self, "skip_checks", _check_skip(self.skip_checks, "WorkspaceVolume.skip_checks"))
        from pkmstiff.workspace.requirements import RequirementError, parse_requirements
        from pkmstiff.workspace.volume import METHODS

        if not (isinstance(self.resolution_mm, (int, float)) and self.resolution_mm > 0):
            raise SweepError(f"WorkspaceVolume.resolution_mm: expected a positive length in mm, "
                             f"found {self.resolution_mm!r}")
        if self.box_mm is not None:
            b = tuple(float(v) for v in self.box_mm)
            if len(b) != 6 or not all(hi > lo for lo, hi in zip(b[0::2], b[1::2])):
                raise SweepError(f"WorkspaceVolume.box_mm: expected xmin, xmax, ymin, ymax, zmin, zmax (mm) with "
                                 f"min < max, found {self.box_mm!r}")
            object.__setattr__(self, "box_mm", b)
        if self.method not in METHODS:
            raise SweepError(f"WorkspaceVolume.method: expected one of {list(METHODS)}, found {self.method!r}")
        object.__setattr__(self, "requirements", tuple(self.requirements))
        try:
            parse_requirements(self.requirements)
        except RequirementError as exc:
            raise SweepError(f"WorkspaceVolume.requirements: {exc}") from None
        object.__setattr__(self, "orientation_deg", _orientation(self.orientation_deg,
                                                                 "WorkspaceVolume.orientation_deg"))

    def request(self) -> WorkspaceRequest:
        """The SI evaluation request this sweep evaluation stands for."""
        box = None
        if self.box_mm is not None:
            b = np.array(self.box_mm) * 1e-3
            box = (b[0::2], b[1::2])
        return WorkspaceRequest(self.resolution_mm * 1e-3, box, self.requirements,
                                tuple(np.radians(self.orientation_deg)), (self.method,), frame=self.frame,
                                neglect_spindle=self.neglect_spindle, skip_checks=self.skip_checks)

    def __call__(self, machine: Machine) -> dict[str, float]:
        res = self.request().evaluate(machine)
        return {"volume [m^3]": float(res.volumes[self.method]), "touches box [1]": float(res.octree.touches_box)}


@dataclass(frozen=True)
class Combined:
    """Several evaluations of the same machine merged into one output dict (later names must not repeat)."""

    parts: tuple[Callable[[Machine], Mapping[str, Any]], ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "parts", tuple(self.parts))
        if not self.parts or not all(callable(p) for p in self.parts):
            raise SweepError(f"Combined.parts: expected at least one evaluation, found {self.parts!r}")

    def __call__(self, machine: Machine) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for p in self.parts:
            d = p(machine)
            clash = sorted(set(d) & set(out))
            if clash:
                raise SweepError(f"Combined: output {clash[0]!r} is produced twice; give PointValues a suffix")
            out.update(d)
        return out


def evaluation_cost(ev: Callable[[Machine], Mapping[str, Any]], machine: Machine) -> Cost:
    """The :class:`~pkmstiff.evaluation.cost.Cost` of one sweep evaluation on ``machine``: a section or workspace by
    its request's estimate, a point (or an evaluation of another kind) by the cost of one structure evaluation."""
    if isinstance(ev, Combined):
        return total((evaluation_cost(p, machine) for p in ev.parts), "combined evaluations")
    if isinstance(ev, (SectionStatistics, WorkspaceVolume)):
        return ev.request().cost(machine)
    return rows_cost(1, 0.0, POINT_SECONDS, "a point", "points", "")
