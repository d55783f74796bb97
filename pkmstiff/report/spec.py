"""Report specs: a TOML file describing a comparison of machine variants -> a :class:`Report` (``pkmstiff report``).

A spec names the variants (bundled machine or machine file, options, parameter overrides, tool length,
orientation), the section planes and their quantities and statistics, the workspace, single poses and machine
values to compare. :func:`pkmstiff.report.build.build_report` evaluates everything and returns one comparison
table (rows = metric and statistic, columns = variants, "% of baseline"), section maps (one figure per variant and
quantity, a shared colour scale per quantity), workspace figures, an optional weighted evaluation
(``[[evaluation]]``), the machine files' assumptions (shared ones once, differences per variant) and the settings.
Every key is validated; errors are :class:`SpecError` naming the file, the key, what was expected and what was found.
Lengths are in mm and angles in degrees in the spec (keys ``*_mm``, ``*_deg``); SI inside.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

from pkmstiff.errors import (
    SectionArgumentError,
    SpecError,  # noqa: F401 (re-exported)
)
from pkmstiff.evaluation.requests import STATISTICS
from pkmstiff.io import check_keys, read_toml, require
from pkmstiff.io.ranges import parse_ranges
from pkmstiff.machine.model import Machine
from pkmstiff.report.weighted import Criterion

__all__ = ["SpecError", "Variant", "SectionSpec", "WorkspaceSpec", "PointSpec", "ReportSpec", "load_spec",
           "fast_spec", "STATISTICS", "MACHINE_ROWS"]

# machine value -> (row label, unit, function of (machine, variant) in that unit)
MACHINE_ROWS: dict[str, tuple[str, str, Callable[[Machine, "Variant"], float]]] = {
    "transmission_weight": ("transmission quality weight w (eq. 4.77)", "m/rad",
                            lambda m, v: float(m.transmission_weight)),
    "tool_length": ("tool length", "mm",
                    lambda m, v: 1e3 * float(m.tool.length if v.tool_length is None else v.tool_length)),
}

_REPORT_KEYS = {"title", "summary", "baseline", "digits", "machine_rows", "assumptions", "frame"}
_VARIANT_KEYS = {"name", "machine", "options", "overrides", "tool_length_mm", "orientation_deg", "description",
                 "neglect_spindle", "skip_checks"}
_SECTION_KEYS = {"plane", "at_mm", "range", "step_mm", "quantities", "statistics", "maps", "tool_length_mm",
                 "orientation_deg", "title"}
_WORKSPACE_KEYS = {"resolution_mm", "box_mm", "requirements", "methods", "figures", "orientation_deg"}
_POINT_KEYS = {"pose", "quantities", "tool_length_mm", "label"}
_OPTION_KEYS = {"fast_step_mm", "fast_resolution_mm", "jobs"}
_EVALUATION_KEYS = {"metric", "weight", "better"}
_TOP_KEYS = {"report", "variants", "sections", "workspace", "points", "options", "evaluation"}




@dataclass(frozen=True)
class Variant:
    name: str
    machine: str  # bundled name or path (resolved against the spec's folder), without ':options'
    options: tuple[str, ...] = ()
    overrides: Mapping[str, Any] = field(default_factory=dict)  # dotted path -> value (pkmstiff.machine.variants)
    tool_length: float | None = None  # m; None = the machine file's
    orientation: tuple[float, float, float] = (0.0, 0.0, 0.0)  # rad
    description: str = ""
    neglect_spindle: bool = False  # leave K_U out (docs/user-guide/validation-hexaglide.md, reading: tool length 0)
    skip_checks: tuple[str, ...] = ()  # admissibility checks left out (names of ALL_CHECKS)


@dataclass(frozen=True)
class SectionSpec:
    plane: str  # "yz" | "xz" | "xy"
    at: float  # m
    u_range: tuple[float, float]  # m
    v_range: tuple[float, float]  # m
    step: float  # m
    quantities: tuple[str, ...]
    statistics: tuple[str, ...] = ("min", "mean", "max")
    maps: bool = True
    tool_length: float | None = None  # m; None = the variant's
    orientation: tuple[float, float, float] | None = None  # rad; None = the variant's
    title: str = ""
    range_text: str = ""

    @property
    def name(self) -> str:
        normal = ({"x", "y", "z"} - set(self.plane)).pop()
        return self.title or f"{self.plane.upper()} plane at {normal} = {self.at * 1e3:g} mm"


@dataclass(frozen=True)
class WorkspaceSpec:
    resolution: float  # m
    box: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None  # (lo, hi) m
    requirements: tuple[str, ...] = ()
    methods: tuple[str, ...] = ("surface_nets",)
    figures: bool = True
    orientation: tuple[float, float, float] | None = None  # rad; None = the variant's


@dataclass(frozen=True)
class PointSpec:
    pose: tuple[float, ...]  # (x, y, z [m], a, b, c [rad])
    quantities: tuple[str, ...]
    tool_length: float | None = None  # m; None = the variant's
    label: str = ""

    @property
    def name(self) -> str:
        if self.label:
            return self.label
        p = self.pose
        return (f"x, y, z = {p[0] * 1e3:g}, {p[1] * 1e3:g}, {p[2] * 1e3:g} mm, "
                f"a, b, c = {math.degrees(p[3]):g}, {math.degrees(p[4]):g}, {math.degrees(p[5]):g} deg")


@dataclass(frozen=True)
class ReportSpec:
    title: str
    variants: tuple[Variant, ...]
    sections: tuple[SectionSpec, ...] = ()
    workspace: WorkspaceSpec | None = None
    points: tuple[PointSpec, ...] = ()
    baseline: str | None = None
    summary: str = ""
    digits: int = 4
    machine_rows: tuple[str, ...] = ()
    assumptions: Mapping[str, str] = field(default_factory=dict)
    fast_step: float | None = None  # m
    fast_resolution: float | None = None  # m
    jobs: int = 1
    source: str = ""
    frame: str = "machine"  # frame of every position in the spec (sections, points, workspace box)
    evaluation: tuple[Criterion, ...] = ()  # weighted evaluation (pkmstiff.report.weighted)


# ---------------------------------------------------------------------------------------------------------- parsing
class _Reader:
    """Typed access to a spec table with key checks; every error names file and key."""

    def __init__(self, src: str):
        self.src = src

    def error(self, key: str, expected: str, found: Any) -> SpecError:
        return SpecError(self.src, key, expected, found)

    def table(self, value: Any, key: str, allowed: set[str]) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.error(key or "(top level)", "a table", value)
        return check_keys(value, allowed, self.src, f"{key}." if key else "", SpecError)

    def req(self, tab: dict, key: str, prefix: str, what: str) -> Any:
        return require(tab, key, self.src, prefix, what, SpecError)

    def number(self, value: Any, key: str, *, positive: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(key, "a finite number", value)
        if positive and not value > 0:
            raise self.error(key, "a positive number", value)
        return float(value)

    def numbers(self, value: Any, key: str, n: int, what: str) -> list[float]:
        if not isinstance(value, list) or len(value) != n:
            raise self.error(key, f"a list of {n} numbers ({what})", value)
        return [self.number(v, f"{key}[{i + 1}]") for i, v in enumerate(value)]

    def string(self, value: Any, key: str) -> str:
        if not isinstance(value, str):
            raise self.error(key, "a string", value)
        return value

    def strings(self, value: Any, key: str, *, nonempty: bool = True) -> tuple[str, ...]:
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value) or (nonempty and not value):
            raise self.error(key, "a list of strings" + (" (at least one)" if nonempty else ""), value)
        return tuple(value)

    def boolean(self, value: Any, key: str) -> bool:
        if not isinstance(value, bool):
            raise self.error(key, "true or false", value)
        return value

    def check_names(self, value: Any, key: str) -> tuple[str, ...]:
        """Admissibility check names to leave out (:data:`pkmstiff.admissibility.checks.ALL_CHECKS`)."""
        from pkmstiff.admissibility.checks import checks_without

        names = self.strings(value, key, nonempty=False)
        checks_without(names, self.src, key)  # raises, naming the known checks
        return names

    def orientation(self, value: Any, key: str) -> tuple[float, float, float]:
        a, b, c = self.numbers(value, key, 3, "a, b, c in deg")
        return (math.radians(a), math.radians(b), math.radians(c))

    def quantities(self, value: Any, key: str) -> tuple[str, ...]:
        from pkmstiff.evaluation.quantities import UnknownQuantityError, get_quantity

        names = self.strings(value, key)
        for n in names:
            try:
                get_quantity(n)
            except UnknownQuantityError as exc:
                raise self.error(key, "quantity names (see 'pkmstiff quantities')", f"{n!r}: {exc}") from None
        return names


def _flatten(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested TOML tables (unquoted dotted keys) -> {"a.b.c": value}; quoted dotted keys pass through."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        path = f"{prefix}.{k}" if prefix else k
        if isinstance(v, dict):
            out.update(_flatten(v, path))
        else:
            out[path] = v
    return out


def _variant(r: _Reader, tab: Any, i: int, spec_dir: Path) -> Variant:
    p = f"variants[{i + 1}]"
    tab = r.table(tab, p, _VARIANT_KEYS)
    name = r.string(r.req(tab, "name", p + ".", "a short variant name"), p + ".name").strip()
    if not name:
        raise r.error(p + ".name", "a non-empty name", name)
    from pkmstiff.machine.variants import split_machine_spec

    mspec, opts = split_machine_spec(r.string(r.req(tab, "machine", p + ".", "a bundled machine name or a machine "
                                                                        "file path"), p + ".machine"))
    if mspec.endswith(".toml") or "/" in mspec or "\\" in mspec:
        mp = Path(mspec)
        mspec = str(mp if mp.is_absolute() else spec_dir / mp)
    opts += list(r.strings(tab["options"], p + ".options", nonempty=False)) if "options" in tab else []
    overrides = tab.get("overrides", {})
    if not isinstance(overrides, dict):
        raise r.error(p + ".overrides", "a table of dotted machine-file paths = values", overrides)
    return Variant(name=name, machine=mspec, options=tuple(opts), overrides=_flatten(overrides),
                   tool_length=None if "tool_length_mm" not in tab else
                   1e-3 * r.number(tab["tool_length_mm"], p + ".tool_length_mm"),
                   orientation=r.orientation(tab.get("orientation_deg", [0, 0, 0]), p + ".orientation_deg"),
                   description=r.string(tab.get("description", ""), p + ".description"),
                   neglect_spindle=r.boolean(tab.get("neglect_spindle", False), p + ".neglect_spindle"),
                   skip_checks=r.check_names(tab.get("skip_checks", []), p + ".skip_checks"))


def _section(r: _Reader, tab: Any, i: int) -> SectionSpec:
    p = f"sections[{i + 1}]"
    tab = r.table(tab, p, _SECTION_KEYS)
    plane = r.string(tab.get("plane", "yz"), p + ".plane").lower()
    if plane not in ("yz", "xz", "xy"):
        raise r.error(p + ".plane", "'yz', 'xz' or 'xy'", plane)
    rng = r.string(r.req(tab, "range", p + ".", "in-plane ranges in mm, e.g. 'y=-600:800,z=-1200:-500'"),
                   p + ".range")
    try:
        ranges = parse_ranges(rng, plane)
    except SectionArgumentError as exc:
        raise r.error(p + ".range", f"AXIS=LO:HI pairs in mm for both axes of the {plane.upper()} plane",
                      f"{rng!r} ({str(exc).removeprefix('--range: ')})") from None
    stats = r.strings(tab.get("statistics", ["min", "mean", "max"]), p + ".statistics")
    bad = [s for s in stats if s not in STATISTICS]
    if bad:
        raise r.error(p + ".statistics", f"a list of {sorted(STATISTICS)}", bad[0])
    return SectionSpec(
        plane=plane, at=1e-3 * r.number(tab.get("at_mm", 0.0), p + ".at_mm"), u_range=ranges[plane[0]],
        v_range=ranges[plane[1]], step=1e-3 * r.number(tab.get("step_mm", 10.0), p + ".step_mm", positive=True),
        quantities=r.quantities(r.req(tab, "quantities", p + ".", "quantity names, e.g. ['kx', 'U']"),
                                p + ".quantities"),
        statistics=stats, maps=r.boolean(tab.get("maps", True), p + ".maps"),
        tool_length=None if "tool_length_mm" not in tab else 1e-3 * r.number(tab["tool_length_mm"],
                                                                              p + ".tool_length_mm"),
        orientation=None if "orientation_deg" not in tab else r.orientation(tab["orientation_deg"],
                                                                             p + ".orientation_deg"),
        title=r.string(tab.get("title", ""), p + ".title"), range_text=rng)


def _workspace(r: _Reader, tab: Any) -> WorkspaceSpec:
    from pkmstiff.workspace.requirements import RequirementError, parse_requirements
    from pkmstiff.workspace.volume import METHODS

    tab = r.table(tab, "workspace", _WORKSPACE_KEYS)
    box = None
    if "box_mm" in tab:
        b = r.numbers(tab["box_mm"], "workspace.box_mm", 6, "xmin, xmax, ymin, ymax, zmin, zmax in mm")
        lo, hi = tuple(1e-3 * v for v in b[0::2]), tuple(1e-3 * v for v in b[1::2])
        if not all(h > l for l, h in zip(lo, hi)):
            raise r.error("workspace.box_mm", "min < max on every axis", b)
        box = (lo, hi)
    reqs = r.strings(tab.get("requirements", []), "workspace.requirements", nonempty=False)
    try:
        parse_requirements(reqs)
    except RequirementError as exc:
        raise r.error("workspace.requirements", "requirements such as 'U>=0.2' or 'kx>=20 N/um'", str(exc)) from None
    methods = r.strings(tab.get("methods", ["surface_nets"]), "workspace.methods")
    bad = [m for m in methods if m not in METHODS]
    if bad:
        raise r.error("workspace.methods", f"a list of {list(METHODS)}", bad[0])
    return WorkspaceSpec(
        resolution=1e-3 * r.number(r.req(tab, "resolution_mm", "workspace.", "the octree resolution in mm"),
                                   "workspace.resolution_mm", positive=True),
        box=box, requirements=reqs, methods=methods, figures=r.boolean(tab.get("figures", True), "workspace.figures"),
        orientation=None if "orientation_deg" not in tab else r.orientation(tab["orientation_deg"],
                                                                             "workspace.orientation_deg"))


def _point(r: _Reader, tab: Any, i: int) -> PointSpec:
    p = f"points[{i + 1}]"
    tab = r.table(tab, p, _POINT_KEYS)
    v = r.numbers(r.req(tab, "pose", p + ".", "x, y, z [mm], a, b, c [deg]"), p + ".pose", 6,
                  "x, y, z in mm and a, b, c in deg")
    pose = tuple(1e-3 * x for x in v[:3]) + tuple(math.radians(a) for a in v[3:])
    return PointSpec(pose=pose, quantities=r.quantities(r.req(tab, "quantities", p + ".", "quantity names"),
                                                        p + ".quantities"),
                     tool_length=None if "tool_length_mm" not in tab else
                     1e-3 * r.number(tab["tool_length_mm"], p + ".tool_length_mm"),
                     label=r.string(tab.get("label", ""), p + ".label"))


def _criterion(r: _Reader, tab: Any, i: int) -> Criterion:
    p = f"evaluation[{i + 1}]"
    tab = r.table(tab, p, _EVALUATION_KEYS)
    metric = r.string(r.req(tab, "metric", f"{p}.", "a row label of the comparison table, e.g. 'k_x mean'"),
                      f"{p}.metric")
    weight = r.number(tab.get("weight", 1.0), f"{p}.weight")
    if weight < 0:
        raise r.error(f"{p}.weight", "a weight >= 0", weight)
    better = tab.get("better", "higher")
    if better not in ("higher", "lower"):
        raise r.error(f"{p}.better", "'higher' or 'lower' (which values are better)", better)
    return Criterion(metric, weight, better == "higher")


def load_spec(path: str | Path) -> ReportSpec:
    """Read and validate a report spec (see the README, "Report specs", for every key)."""
    path = Path(path)
    src = str(path)
    raw = read_toml(path, SpecError, "report spec file")
    r = _Reader(src)
    r.table(raw, "", _TOP_KEYS)
    rep = r.table(r.req(raw, "report", "", "a [report] table with at least 'title'"), "report", _REPORT_KEYS)
    vt = r.req(raw, "variants", "", "an array of [[variants]] tables")
    if not isinstance(vt, list) or not vt:
        raise r.error("variants", "an array of at least one [[variants]] table", vt)
    variants = tuple(_variant(r, t, i, path.parent) for i, t in enumerate(vt))
    names = [v.name for v in variants]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise r.error("variants", "unique variant names", f"{dup[0]!r} used more than once")
    baseline = rep.get("baseline")
    if baseline is not None and baseline not in names:
        raise r.error("report.baseline", f"one of the variant names {names}", baseline)
    sections = raw.get("sections", [])
    if not isinstance(sections, list):
        raise r.error("sections", "an array of [[sections]] tables", sections)
    points = raw.get("points", [])
    if not isinstance(points, list):
        raise r.error("points", "an array of [[points]] tables", points)
    mrows = r.strings(rep.get("machine_rows", []), "report.machine_rows", nonempty=False)
    bad = [m for m in mrows if m not in MACHINE_ROWS]
    if bad:
        raise r.error("report.machine_rows", f"a list of {sorted(MACHINE_ROWS)}", bad[0])
    assumptions = rep.get("assumptions", {})
    if not isinstance(assumptions, dict) or not all(isinstance(v, str) for v in assumptions.values()):
        raise r.error("report.assumptions", "a table key = one-line reason (strings)", assumptions)
    opts = r.table(raw.get("options", {}), "options", _OPTION_KEYS)
    digits = rep.get("digits", 4)
    if isinstance(digits, bool) or not isinstance(digits, int) or not 1 <= digits <= 12:
        raise r.error("report.digits", "an integer 1..12 (significant digits)", digits)
    frame = rep.get("frame", "machine")
    if frame not in ("machine", "report"):
        raise r.error("report.frame", "'machine' or 'report' (frame of every position in the spec)", frame)
    crit = raw.get("evaluation", [])
    if not isinstance(crit, list):
        raise r.error("evaluation", "an array of [[evaluation]] tables (metric, weight, better)", crit)
    evaluation = tuple(_criterion(r, t, i) for i, t in enumerate(crit))
    if evaluation and sum(c.weight for c in evaluation) <= 0:
        raise r.error("evaluation", "at least one weight > 0", [c.weight for c in evaluation])
    jobs = opts.get("jobs", 1)
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs == 0:
        raise r.error("options.jobs", "a non-zero integer (-1: all cores)", jobs)
    spec = ReportSpec(
        title=r.string(r.req(rep, "title", "report.", "the report title"), "report.title"),
        variants=variants, sections=tuple(_section(r, t, i) for i, t in enumerate(sections)),
        workspace=_workspace(r, raw["workspace"]) if "workspace" in raw else None,
        points=tuple(_point(r, t, i) for i, t in enumerate(points)), baseline=baseline,
        summary=r.string(rep.get("summary", ""), "report.summary"), digits=digits, machine_rows=mrows,
        assumptions=dict(assumptions),
        fast_step=None if "fast_step_mm" not in opts else 1e-3 * r.number(opts["fast_step_mm"],
                                                                          "options.fast_step_mm", positive=True),
        fast_resolution=None if "fast_resolution_mm" not in opts else
        1e-3 * r.number(opts["fast_resolution_mm"], "options.fast_resolution_mm", positive=True),
        jobs=jobs, source=src, frame=frame, evaluation=evaluation)
    if not (spec.sections or spec.workspace or spec.points or spec.machine_rows):
        raise r.error("(file)", "at least one of [[sections]], [workspace], [[points]], report.machine_rows",
                      "nothing to compare")
    return spec


def fast_spec(spec: ReportSpec) -> ReportSpec:
    """The spec with the coarse raster step / workspace resolution of ``[options]`` (``--fast``).

    Without ``fast_step_mm`` every section step is multiplied by 4; without ``fast_resolution_mm`` the workspace
    resolution by 4 (a coarse but recognisable result).
    """
    sections = tuple(dataclasses.replace(s, step=spec.fast_step or 4.0 * s.step) for s in spec.sections)
    ws = spec.workspace
    if ws is not None:
        ws = dataclasses.replace(ws, resolution=spec.fast_resolution or 4.0 * ws.resolution)
    return dataclasses.replace(spec, sections=sections, workspace=ws)
