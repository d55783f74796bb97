"""The design question of ``pkmstiff optimise``: a base machine, variables, objectives and constraints.

A variable is one or more dotted machine-file paths (the paths of sweep files, :mod:`pkmstiff.machine.variants`)
set from one decision coordinate (a *group*; ``mirror`` gives each path a sign). Kinds:

* ``continuous``: ``low``/``high`` in ``unit`` (any unit pint knows; the override is written ``"<value> <unit>"``);
* ``integer``: ``low``/``high`` whole numbers;
* ``categorical``: ``values`` (e.g. component names, joint tables of the catalogue, model names); with ``entries``
  (a catalogue of the component library, :mod:`components.library`) each value names an entry: the entry's component
  table is added to the machine as ``components.<entry>`` and the paths are set to its name;
* ``direction``: a unit vector from spherical angles (``polar``/``azimuth`` bounds in ``unit``), a = (sin t cos p,
  sin t sin p, -cos t) — the tilt t from -z, as study e; a mirror sign -1 reflects x (the YZ plane).

Objectives and constraints are :class:`Measure` s — functions of the machine variant with a name and a unit: a
section statistic (min, q05, mean, max, area), the workspace volume, a point quantity at a pose, the admissible
fraction of a task-workspace box, the moving mass, or (from Python) any function of the machine. A design's
:class:`Reference` s (e.g. a hand-optimised option of the base machine) are evaluated with the same measures.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pkmstiff.errors import DesignFileError
from pkmstiff.machine.model import Machine

__all__ = [
    "SECTION_STATISTICS",
    "VARIABLE_KINDS",
    "Constraint",
    "Design",
    "FunctionMeasure",
    "Measure",
    "MovingMassMeasure",
    "Objective",
    "PointMeasure",
    "Reference",
    "SectionMeasure",
    "TaskBoxMeasure",
    "Variable",
    "WorkspaceMeasure",
]

VARIABLE_KINDS = ("continuous", "integer", "categorical", "direction")
#: statistics of a section quantity: name -> unit (None: the quantity's display unit)
SECTION_STATISTICS = {"min": None, "q05": None, "mean": None, "max": None, "area": "m^2"}


@dataclass(frozen=True)
class Variable:
    """One decision variable tied to ``paths`` (values in ``unit``; SI machine-file values when ``unit`` is None)."""

    name: str
    paths: tuple[str, ...]
    kind: str = "continuous"
    low: tuple[float, ...] = ()  # continuous/integer: (low,); direction: (polar low, azimuth low)
    high: tuple[float, ...] = ()
    unit: str | None = None
    values: tuple[Any, ...] = ()  # categorical
    mirror: tuple[float, ...] = ()  # one sign per path (default all +1)
    # categorical from a component catalogue: (entry name, component table as in a machine file) per value
    entries: tuple[tuple[str, Any], ...] = field(default=(), compare=False)
    catalogue: str | None = None  # the catalogue's name (outputs)

    @property
    def dims(self) -> int:
        """Decision coordinates this variable takes (2 for a direction)."""
        return 2 if self.kind == "direction" else 1

    def bounds(self) -> tuple[list[float], list[float]]:
        """Lower and upper bounds of its decision coordinates (integer and categorical: widened by 1/2, rounded)."""
        if self.kind == "categorical":
            return [-0.5], [len(self.values) - 0.5]
        if self.kind == "integer":
            return [self.low[0] - 0.5], [self.high[0] + 0.5]
        return list(self.low), list(self.high)

    def value(self, x: Sequence[float]) -> Any:
        """The variable's value (in ``unit``; categorical: the catalogue value) at decision coordinates ``x``."""
        if self.kind == "categorical":
            return self.values[int(np.clip(round(float(x[0])), 0, len(self.values) - 1))]
        if self.kind == "integer":
            return int(np.clip(round(float(x[0])), self.low[0], self.high[0]))
        if self.kind == "direction":
            return (float(x[0]), float(x[1]))
        return float(x[0])

    def overrides(self, value: Any) -> dict[str, Any]:
        """Machine-file overrides (dotted path -> value as written in a machine file) for ``value``."""
        signs = self.mirror or (1.0,) * len(self.paths)
        out: dict[str, Any] = {}
        for path, s in zip(self.paths, signs):
            if self.kind == "direction":
                t, p = (math.radians(v) if self.unit in ("deg", "degree") else v for v in value)
                a = [math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), -math.cos(t)]
                out[path] = [s * a[0], a[1], a[2]]
            elif self.kind == "categorical":
                if self.entries:  # the entry's table as a new component of that name, referenced by the paths
                    out.setdefault(f"components.{value}", dict(self.entries)[value])
                out[path] = value
            elif self.kind == "integer":
                out[path] = int(s * value)
            else:
                v = s * value
                out[path] = f"{v!r} {self.unit}" if self.unit else v
        return out

    def columns(self) -> list[str]:
        """Result labels of this variable (``"name [unit]"``; a direction gives polar and azimuth)."""
        u = f" [{self.unit}]" if self.unit else ""
        if self.kind == "direction":
            return [f"{self.name} polar{u}", f"{self.name} azimuth{u}"]
        return [f"{self.name}{u}"]


class Measure:
    """A number computed from a machine variant: ``name``, ``unit`` and ``__call__(machine, memo) -> float``."""

    name: str
    unit: str

    def __call__(self, machine: Machine, memo: dict) -> float:  # pragma: no cover - interface
        raise NotImplementedError

    @property
    def label(self) -> str:
        return f"{self.name} [{self.unit}]"


@dataclass(frozen=True)
class SectionMeasure(Measure):
    """``statistic`` of ``quantity`` over the admissible points of an axis-plane section (``request``: a
    :class:`pkmstiff.evaluation.requests.SectionRequest`, SI); sections of equal settings are evaluated once per
    variant (``memo``). q05 is the 5 % quantile (``numpy.quantile``, linear); area the admissible area [m²]."""

    name: str
    unit: str
    quantity: str
    statistic: str
    request: Any

    def __call__(self, machine: Machine, memo: dict) -> float:
        res = memo.get(self.request)
        if res is None:
            res = memo[self.request] = self.request.evaluate(machine)
        if self.statistic == "area":
            return float(np.count_nonzero(res.ok)) * res.plane.cell_area
        d = np.asarray(res.display(self.quantity))[np.asarray(res.ok, bool)]
        d = d[np.isfinite(d)]
        if not d.size:
            return float("nan")
        return float({"min": np.min, "mean": np.mean, "max": np.max,
                      "q05": lambda a: np.quantile(a, 0.05)}[self.statistic](d))


@dataclass(frozen=True)
class PointMeasure(Measure):
    """A point quantity at one pose (``evaluation``: :class:`pkmstiff.report.sweep_evaluations.PointValues`); an
    inadmissible pose makes the candidate fail (infeasible)."""

    name: str
    unit: str
    evaluation: Any

    def __call__(self, machine: Machine, memo: dict) -> float:
        return float(next(iter(self.evaluation(machine).values())))


@dataclass(frozen=True)
class WorkspaceMeasure(Measure):
    """The constant-orientation workspace volume [m³] (``evaluation``:
    :class:`pkmstiff.report.sweep_evaluations.WorkspaceVolume`)."""

    name: str
    unit: str
    evaluation: Any

    def __call__(self, machine: Machine, memo: dict) -> float:
        return float(self.evaluation(machine)["volume [m^3]"])


@dataclass(frozen=True)
class TaskBoxMeasure(Measure):
    """Admissible fraction [1] of a task workspace: the grid ``lo:step:hi`` [m] (machine frame) at each of
    ``orientations`` (a, b, c [rad]); a constraint ``>= 1`` keeps the whole box admissible."""

    name: str
    unit: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    step: float
    orientations: tuple[tuple[float, float, float], ...] = ((0.0, 0.0, 0.0),)

    def poses(self) -> np.ndarray:
        axes = [np.linspace(lo, hi, max(1, round((hi - lo) / self.step) + 1)) for lo, hi in zip(self.lo, self.hi)]
        pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        return np.concatenate([np.hstack([pts, np.tile(o, (len(pts), 1))]) for o in self.orientations])

    def __call__(self, machine: Machine, memo: dict) -> float:
        from pkmstiff.api import StudyMachine

        ok, _ = StudyMachine.of(machine).admissibility(self.poses())
        return float(np.mean(ok))


@dataclass(frozen=True)
class MovingMassMeasure(Measure):
    """Mass of the moving parts [kg] from the machine's component data: the total mass of the structure model
    (:func:`pkmstiff.structure.layout.structure_layout`, docs/theory/structure.md),

        m = m_P + m_U + Σ_i (m_A,i + m_W,i + m_S,i + m_GA,i + m_GP,i + m_strut,i (s_A + s_P)),

    platform m_P and spindle m_U, per chain the drive m_A (a ball screw's includes its apparent spindle mass,
    Cobet eq. 3.4), guide carriages m_W, drive suspension m_S, drive- and platform-joint masses m_GA, m_GP and the
    strut shares s_A, s_P that the machine file lumps at the joints (``strut_mass_shares``; 0 where the drive and
    platform masses already hold the struts, as the Hexaglide's)."""

    name: str
    unit: str = "kg"

    def __call__(self, machine: Machine, memo: dict) -> float:
        from pkmstiff.structure.layout import structure_layout

        lay = structure_layout(machine)
        return float(lay.platform.mass + lay.spindle.mass + np.sum(lay.drive_mass))


@dataclass(frozen=True)
class FunctionMeasure(Measure):
    """Any picklable function of the machine (Python API; e.g. a closed form for tests)."""

    name: str
    unit: str
    function: Callable[[Machine], float]

    def __repr__(self) -> str:  # stable across processes (part of the cache key): the function's qualified name
        f = self.function
        return f"FunctionMeasure({self.name!r}, {self.unit!r}, {f.__module__}.{getattr(f, '__qualname__', f)!r})"

    def __call__(self, machine: Machine, memo: dict) -> float:
        return float(self.function(machine))


@dataclass(frozen=True)
class Objective:
    measure: Measure
    sense: str = "minimise"  # or "maximise"


@dataclass(frozen=True)
class Constraint:
    """``lower <= measure <= upper`` (either bound may be None); ``relative``: the bounds are fractions of the base
    machine's value of the measure on the same raster (the engine resolves them with :meth:`absolute`)."""

    measure: Measure
    lower: float | None = None
    upper: float | None = None
    relative: bool = False

    def absolute(self, base_value: float) -> Constraint:
        """This constraint with its bounds in the measure's unit, given the base machine's value."""
        if not self.relative:
            return self
        return Constraint(self.measure, None if self.lower is None else self.lower * base_value,
                          None if self.upper is None else self.upper * base_value)

    def violation(self, value: float) -> float:
        """> 0 where violated, scaled by the bound's magnitude (pymoo's G <= 0 convention); NaN counts as 1."""
        if not math.isfinite(value):
            return 1.0
        g = 0.0
        if self.lower is not None:
            g = max(g, (self.lower - value) / max(abs(self.lower), 1e-12))
        if self.upper is not None:
            g = max(g, (value - self.upper) / max(abs(self.upper), 1e-12))
        return g


@dataclass(frozen=True)
class Reference:
    """A design to compare the optimised ones with, evaluated with the same measures: ``machine`` is a bundled
    name with options (``"hexaglide:optimised_drive_joints"``) or a machine file."""

    name: str
    machine: str
    key: str = "machine"  # the design-file key it came from ("option" or "machine"), for error messages


@dataclass(frozen=True)
class Design:
    """A design question. ``algorithm``: "auto" (DE for one objective, NSGA-II for more), "de", "cmaes", "nsga2";
    ``budget``: evaluations; ``time_budget``: seconds (None: none; checked between generations); ``population``: per
    generation. Coarse-to-fine: ``coarse_step`` [m] is the raster of every section during the search (None: the
    requested ones); afterwards the ``refine`` best feasible candidates (one objective) or the search front (several)
    are re-evaluated on the requested rasters."""

    machine: str
    variables: tuple[Variable, ...]
    objectives: tuple[Objective, ...]
    constraints: tuple[Constraint, ...] = ()
    algorithm: str = "auto"
    budget: int = 200
    population: int = 20
    seed: int = 1
    time_budget: float | None = None
    coarse_step: float | None = None
    refine: int = 10
    source: str = "(design)"
    options: Mapping[str, Any] = field(default_factory=dict)
    references: tuple[Reference, ...] = ()

    def __post_init__(self) -> None:
        names = [v.name for v in self.variables]
        if len(set(names)) != len(names):
            raise DesignFileError(self.source, "variables", "distinct variable names", names)
        if not self.objectives:
            raise DesignFileError(self.source, "objectives", "at least one [[objectives]] table", "none")

    @property
    def n_var(self) -> int:
        return sum(v.dims for v in self.variables)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo: list[float] = []
        hi: list[float] = []
        for v in self.variables:
            a, b = v.bounds()
            lo += a
            hi += b
        return np.array(lo, float), np.array(hi, float)

    def split(self, x: Sequence[float]) -> list[Any]:
        """Decision vector -> one value per variable."""
        out, i = [], 0
        for v in self.variables:
            out.append(v.value(x[i:i + v.dims]))
            i += v.dims
        return out

    def overrides(self, values: Sequence[Any]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for v, val in zip(self.variables, values):
            out.update(v.overrides(val))
        return out

    def measures(self) -> tuple[Measure, ...]:
        return tuple(o.measure for o in self.objectives) + tuple(c.measure for c in self.constraints)

    def resolved_algorithm(self) -> str:
        if self.algorithm != "auto":
            return self.algorithm
        return "nsga2" if len(self.objectives) > 1 else "de"
