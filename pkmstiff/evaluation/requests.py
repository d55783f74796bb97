"""One evaluation-request model: what to evaluate on a machine, in SI units, and one statistics function.

A request is a frozen (picklable) dataclass with ``evaluate(machine)``. The command line, report specs, sweeps and
studies are thin front-ends that build requests from their own units (mm, degrees) and format the results:

* :class:`SectionRequest` — quantities on a section plane, masked by admissibility (:class:`SectionResult`);
* :class:`PointRequest` — quantities at one pose (:class:`PointResult`, with the failing checks if inadmissible);
* :class:`pkmstiff.workspace.requests.WorkspaceRequest` and ``RotationMapRequest`` — the workspace layer's.

Every request takes ``frame`` ("machine" or "report", :mod:`pkmstiff.machine.frames`): its positions are given in
that frame and its results state it; and ``neglect_spindle`` (leave the platform-spindle stiffness K_U out, as the
dissertation's tool-length-0 stiffness maps do; docs/user-guide/validation-hexaglide.md (reading 4)); and
``skip_checks`` (names of :data:`pkmstiff.admissibility.checks.ALL_CHECKS` left out of the admissibility; the
results state them).

:func:`statistic` is the one place that turns a section's per-quantity statistics into a named number.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from pkmstiff.admissibility.checks import checks_left_out, checks_without
from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.evaluation.cost import Cost
from pkmstiff.evaluation.quantities import EvalContext, evaluate_quantities, get_quantity
from pkmstiff.evaluation.sections import SectionResult, axis_plane, evaluate_section
from pkmstiff.machine.frames import check_frame, neglect_spindle, to_machine_frame
from pkmstiff.machine.model import Machine

#: statistics of a section quantity -> (label, unit override or None = the quantity's display unit)
STATISTICS = {"min": ("min", None), "mean": ("mean", None), "max": ("max", None),
              "p1": ("1 % quantile", None), "p5": ("5 % quantile", None), "p95": ("95 % quantile", None),
              "p99": ("99 % quantile", None),
              "area": ("admissible area", "m^2"), "count": ("admissible points", "1"),
              "near_singular": ("near-singular points", "1")}


def statistic(stats: dict[str, float], name: str) -> float:
    """The statistic ``name`` (one of :data:`STATISTICS`) from one entry of :meth:`SectionResult.statistics`.

    ``area`` is the admissible area [m²], ``count`` the number of admissible points with a finite value,
    ``near_singular`` those of them near the singularity threshold; min, the quantiles p1..p99, mean and max are in
    the quantity's display unit and NaN when there is no admissible point.
    """
    if name == "area":
        return stats["admissible_area_m2"]
    if name in ("count", "near_singular"):
        return float(stats["count" if name == "count" else "near_singular_points"])
    return stats[name]


@dataclass(frozen=True)
class SectionRequest:
    """Quantities on an axis-parallel section plane (``plane`` "yz", "xz" or "xy" at ``at`` along its normal)."""

    plane: str
    at: float  # m
    u_range: tuple[float, float]  # m, first in-plane axis
    v_range: tuple[float, float]  # m, second in-plane axis
    step: float  # m
    quantities: tuple[str, ...]
    orientation: tuple[float, float, float] = (0.0, 0.0, 0.0)  # rad
    tool_length: float | None = None  # m; None = the machine file's
    frame: str = "machine"  # frame of at / u_range / v_range and of the result's raster
    neglect_spindle: bool = False  # leave K_U out
    skip_checks: tuple[str, ...] = ()  # admissibility checks left out (names of ALL_CHECKS)

    def evaluate(self, machine: Machine, *, n_jobs: int = 1, progress: bool | None = False,
                 scheduler: Any = None) -> SectionResult:
        check_frame(self.frame)
        checks = checks_without(self.skip_checks, "SectionRequest")
        plane = axis_plane(self.plane, self.at, self.u_range, self.v_range, self.step)
        return evaluate_section(neglect_spindle(machine, self.neglect_spindle), plane, self.quantities,
                                orientation=self.orientation, tool_length=self.tool_length, n_jobs=n_jobs,
                                progress=progress, frame=self.frame, checks=checks, scheduler=scheduler)

    def cost(self, machine: Machine, n_png: int = 0, write: bool = False, admissible_fraction: float | None = None
             ) -> Cost:
        """The :class:`~pkmstiff.evaluation.cost.Cost` of :meth:`evaluate` (plus ``n_png`` maps and, ``write``, the
        VTU/CSV/NPZ files): raster points, the admissible fraction (only admissible points get quantities; measured
        on a sub-raster unless given, e.g. by the window fit's coarse pass,
        :class:`~pkmstiff.workspace.windows.Window`), kinematic and structure quantities. The raster itself is not
        built."""
        from pkmstiff.evaluation.cost import STRUCTURE_GROUPS, plane_points, section_cost
        from pkmstiff.evaluation.cost import admissible_fraction as admissible_fraction_of
        from pkmstiff.evaluation.sections import AXES, raster_count
        from pkmstiff.machine.frames import frame_origin

        kind = self.plane.lower()
        n_points = raster_count(*self.u_range, self.step) * raster_count(*self.v_range, self.step)
        normal = ({"x", "y", "z"} - set(kind)).pop()
        origin = AXES[normal] * self.at + frame_origin(machine, self.frame)
        frac = admissible_fraction
        if frac is None:
            pts = plane_points(self.u_range, self.v_range, self.step, origin, AXES[kind[0]], AXES[kind[1]])
            frac = admissible_fraction_of(machine, pts, self.orientation,
                                          checks_without(self.skip_checks, "SectionRequest"))
        qs = [get_quantity(n) for n in dict.fromkeys(self.quantities)]
        structure = sum(q.group in STRUCTURE_GROUPS for q in qs)
        return section_cost(n_points, frac, len(qs) - structure, structure, any(q.group == "modal" for q in qs),
                            n_png, write)


@dataclass(frozen=True)
class PointResult:
    """Quantities at one pose in display units (empty if inadmissible) and the failing checks."""

    values: dict[str, float]
    failing: list[str]
    pose_machine: tuple[float, ...] = ()  # the pose in the machine frame (m, rad)
    frame: str = "machine"  # frame in which the request's pose was given
    checks_left_out: tuple[str, ...] = ()  # admissibility checks not applied

    @property
    def admissible(self) -> bool:
        return not self.failing


@dataclass(frozen=True)
class PointRequest:
    """Quantities at one pose (x, y, z [m], a, b, c [rad])."""

    pose: tuple[float, ...]
    quantities: tuple[str, ...]
    tool_length: float | None = None  # m; None = the machine file's
    frame: str = "machine"  # frame of the pose's position
    neglect_spindle: bool = False  # leave K_U out
    skip_checks: tuple[str, ...] = ()  # admissibility checks left out (names of ALL_CHECKS)

    def evaluate(self, machine: Machine) -> PointResult:
        check_frame(self.frame)
        checks = checks_without(self.skip_checks, "PointRequest")
        left_out = tuple(checks_left_out(checks))
        machine = neglect_spindle(machine, self.neglect_spindle)
        x = to_machine_frame(machine, np.asarray(self.pose, float)[None, :], self.frame)
        ev = evaluate_poses(machine, x, checks=checks)
        pm = tuple(float(v) for v in x[0])
        if not ev.ok[0]:
            return PointResult({}, ev.admissibility.failing(0), pm, self.frame, left_out)
        vals = evaluate_quantities(EvalContext(machine, ev, self.tool_length, {}), list(self.quantities))
        return PointResult({n: float(get_quantity(n).to_display(vals[n])[0]) for n in self.quantities}, [], pm,
                           self.frame, left_out)


def check_quantity_names(names: Sequence[str]) -> tuple[str, ...]:
    """The names as a tuple if every one is a registered quantity; else the registry's error."""
    for n in names:
        get_quantity(n)
    return tuple(names)
