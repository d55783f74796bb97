"""Design files (TOML) for ``pkmstiff optimise``: read, validate (before any evaluation), build a :class:`Design`.

    machine = "hexaglide"                       # bundled name (":option" suffix) or path (relative to this file)
    [optimiser]
    algorithm = "auto"                          # auto | de | cmaes | nsga2
    budget = 200                                # evaluations
    time_budget = "5 min"                       # optional: a duration (pint) or seconds; checked between generations
    population = 20
    seed = 1
    coarse_step_mm = 25                         # optional coarse-to-fine: every section searched on this raster,
    refine = 10                                 # then the 10 best (several objectives: the front) re-evaluated on
                                                # the sections' own step_mm

    [[variables]]
    name = "tilt"                               # a continuous variable tied to two paths (a mirror-symmetric pair)
    paths = ["chains[1].x", "chains[2].x"]      # or path = "..."
    mirror = [1, -1]
    low = 0; high = 30; unit = "deg"
    # kind = "integer" (low/high), "categorical" (values = [...]), "direction" (polar = [lo, hi], azimuth = [lo, hi])
    # categorical from the component library: catalogue = "pod_ballscrews" (or a file), values = entry names
    # (default: every entry); path = the component reference to set, e.g. "chain_defaults.components.drive"

    [[objectives]]
    name = "kx_mean"; sense = "maximise"
    kind = "section"; quantity = "kx"; statistic = "mean"   # min | q05 | mean | max | area
    plane = "yz"; at_mm = 0; range = "y=-200:800,z=-1100:-500"; step_mm = 50
    # kind = "point" (pose = [x, y, z mm, a, b, c deg], quantity), "workspace" (resolution_mm, box_mm, ...),
    # "moving_mass" (kg, from the component data)

    [[constraints]]
    name = "area"; kind = "section"; quantity = "kx"; statistic = "area"; ...; min = 0.3   # and/or max
    # relative_to = "base": min/max are fractions of the base machine's value (on the same raster)
    # kind = "task_box": box_mm = [[x0, y0, z0], [x1, y1, z1]], step_mm, orientations_deg = [[0, 0, 0]]; min = 1

    [[reference]]                               # designs evaluated with the same measures, marked in the outputs
    name = "hand-optimised"; option = "optimised_drive_joints"    # an option of the base machine, or
    # machine = "other.toml"                                      # a bundled machine or machine file

Every error is a :class:`DesignFileError` naming ``file:line``, the key, what was expected and what was found; every
variable is tried on the base machine at its bounds and every categorical value (the machine file's own validation:
an unknown path, a unit of the wrong dimension, a component the catalogue does not have) before anything is evaluated.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.errors import ArgumentError, DesignFileError, InputError, OverrideError
from pkmstiff.io import read_toml
from pkmstiff.optimise.design import (
    SECTION_STATISTICS,
    VARIABLE_KINDS,
    Constraint,
    Design,
    FunctionMeasure,
    MovingMassMeasure,
    Objective,
    PointMeasure,
    Reference,
    SectionMeasure,
    TaskBoxMeasure,
    Variable,
    WorkspaceMeasure,
)

__all__ = ["check_design", "load_design", "parse_duration", "resolve_design"]

_TOP = {"machine", "optimiser", "variables", "objectives", "constraints", "reference"}
_OPT = {"algorithm", "budget", "time_budget", "population", "seed", "coarse_step_mm", "refine"}
_VAR = {"name", "path", "paths", "kind", "low", "high", "unit", "values", "mirror", "polar", "azimuth",
        "catalogue"}
_COMMON = {"name", "kind", "sense", "min", "max", "relative_to"}
_SECTION = {"quantity", "statistic", "plane", "at_mm", "range", "step_mm", "tool_length_mm", "orientation_deg",
            "frame", "neglect_spindle", "skip_checks"}
_POINT = {"quantity", "pose", "tool_length_mm", "frame", "neglect_spindle", "skip_checks"}
_WORKSPACE = {"resolution_mm", "box_mm", "requirements", "orientation_deg", "method", "frame", "neglect_spindle",
              "skip_checks"}
_TASK_BOX = {"box_mm", "step_mm", "orientations_deg"}
_KINDS = {"section": _SECTION, "point": _POINT, "workspace": _WORKSPACE, "task_box": _TASK_BOX,
          "moving_mass": set()}
_REFERENCE = {"name", "option", "machine"}
_ALGORITHMS = ("auto", "de", "cmaes", "nsga2")


class _Lines:
    """Line numbers of keys in the file's text: ``line(array, i, key)`` is the line of ``key`` in the i-th
    ``[[array]]`` table (the table's header line when the key is missing)."""

    def __init__(self, text: str):
        self.lines = text.splitlines()

    def line(self, array: str | None, index: int = 0, key: str | None = None) -> int:
        start, end = 0, len(self.lines)
        if array is not None:
            heads = [i for i, t in enumerate(self.lines) if re.match(rf"\s*\[\[\s*{re.escape(array)}\s*\]\]", t)]
            if index < len(heads):
                start = heads[index]
                end = next((i for i, t in enumerate(self.lines) if i > start and re.match(r"\s*\[", t)), end)
        if key is not None:
            for i in range(start, end):
                if re.match(rf"\s*{re.escape(key)}\s*=", self.lines[i]) or re.search(rf"[;{{]\s*{re.escape(key)}\s*=",
                                                                                    self.lines[i]):
                    return i + 1
        return start + 1


class _Reader:
    def __init__(self, path: Path):
        self.path = path
        self.src = str(path)
        self.lines = _Lines(path.read_text(encoding="utf-8")) if path.is_file() else _Lines("")

    def error(self, array: str | None, index: int, key: str | None, expected: str, found: Any) -> DesignFileError:
        where = f"{array}[{index + 1}]" if array else ""
        full = ".".join(k for k in (where, key) if k) or "(top level)"
        return DesignFileError(f"{self.src}:{self.lines.line(array, index, key)}", full, expected, found)

    def keys(self, tab: Any, allowed: set[str], array: str | None, index: int) -> dict[str, Any]:
        if not isinstance(tab, dict):
            raise self.error(array, index, None, "a table", tab)
        unknown = sorted(set(tab) - allowed)
        if unknown:
            raise self.error(array, index, unknown[0], f"one of the keys {sorted(allowed)}", unknown[0])
        return tab

    def number(self, tab: dict, key: str, array: str, index: int, default: Any = None) -> float:
        v = tab.get(key, default)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise self.error(array, index, key, "a finite number", "missing key" if v is None else v)
        return float(v)


def _variable(r: _Reader, tab: Any, i: int) -> Variable:
    tab = r.keys(tab, _VAR, "variables", i)
    name = tab.get("name")
    if not isinstance(name, str) or not name.strip():
        raise r.error("variables", i, "name", "a variable name (text)", name if name is not None else "missing key")
    if ("path" in tab) == ("paths" in tab):
        raise r.error("variables", i, "path", "exactly one of 'path' (text) or 'paths' (list of text)",
                      "both" if "path" in tab else "missing key")
    paths = [tab["path"]] if "path" in tab else tab["paths"]
    if not isinstance(paths, list) or not paths or not all(isinstance(p, str) and p for p in paths):
        raise r.error("variables", i, "paths", "a non-empty list of dotted machine-file paths", paths)
    kind = tab.get("kind", "continuous")
    if kind not in VARIABLE_KINDS:
        raise r.error("variables", i, "kind", f"one of {list(VARIABLE_KINDS)}", kind)
    mirror = tab.get("mirror", [1] * len(paths))
    if (not isinstance(mirror, list) or len(mirror) != len(paths)
            or not all(not isinstance(s, bool) and s in (1, -1) for s in mirror)):
        raise r.error("variables", i, "mirror", f"a list of {len(paths)} signs (1 or -1), one per path", mirror)
    unit = tab.get("unit")
    if unit is not None:
        if not isinstance(unit, str):
            raise r.error("variables", i, "unit", "a unit name (text)", unit)
        from pkmstiff.units import ureg

        try:
            ureg().Unit(unit)
        except Exception:  # noqa: BLE001 - pint raises several types for unknown units
            raise r.error("variables", i, "unit", "a unit name understood by pint (e.g. 'deg', 'mm', 'N/um')",
                          unit) from None
    low: tuple[float, ...] = ()
    high: tuple[float, ...] = ()
    values: tuple[Any, ...] = ()
    entries: tuple[tuple[str, Any], ...] = ()
    catalogue = tab.get("catalogue")
    if catalogue is not None and kind != "categorical":
        raise r.error("variables", i, "catalogue", "a catalogue only with kind = 'categorical'", kind)
    if kind == "categorical":
        values = tuple(tab.get("values", ()))
        if catalogue is not None:
            cat = _catalogue(r, catalogue, i)
            values = values or tuple(cat.entries)
            for v in values:
                if v not in cat.entries:
                    raise r.error("variables", i, "values", f"entries of the catalogue '{cat.name}' "
                                  f"({', '.join(cat.entries)})", v)
            entries = tuple((v, cat.entries[v]) for v in values)
            catalogue = cat.name
        if not values:
            raise r.error("variables", i, "values", "a non-empty list of values", tab.get("values", "missing key"))
    elif kind == "direction":
        pairs = []
        for key in ("polar", "azimuth"):
            pr = tab.get(key)
            if (not isinstance(pr, list) or len(pr) != 2
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in pr)):
                raise r.error("variables", i, key, "[low, high] in the variable's unit", pr or "missing key")
            if not pr[0] < pr[1]:
                raise r.error("variables", i, key, "low < high", pr)
            pairs.append(pr)
        if unit not in ("deg", "degree", "rad", None):
            raise r.error("variables", i, "unit", "an angle unit ('deg' or 'rad') for a direction", unit)
        low, high = (float(pairs[0][0]), float(pairs[1][0])), (float(pairs[0][1]), float(pairs[1][1]))
    else:
        lo, hi = r.number(tab, "low", "variables", i), r.number(tab, "high", "variables", i)
        if not lo < hi:
            raise r.error("variables", i, "high", f"high > low = {lo:g}", tab["high"])
        if kind == "integer" and (lo != int(lo) or hi != int(hi)):
            raise r.error("variables", i, "low", "whole numbers for an integer variable", [tab["low"], tab["high"]])
        low, high = (lo,), (hi,)
    return Variable(name.strip(), tuple(paths), kind, low, high, unit, values, tuple(float(s) for s in mirror),
                    entries, catalogue)


def _catalogue(r: _Reader, name: Any, i: int) -> Any:
    """A catalogue of the component library (:mod:`components.library`; a path relative to the design file)."""
    from components.library import bundled_catalogues, load_catalogue

    if not isinstance(name, str) or not name:
        raise r.error("variables", i, "catalogue", "a catalogue name or file (text)", name)
    try:
        return load_catalogue(name, r.path.parent)
    except InputError as exc:
        found = name if exc.key == "catalogue" else str(exc)
        raise r.error("variables", i, "catalogue", f"a bundled catalogue ({', '.join(bundled_catalogues())}) or a "
                      "valid catalogue file", found) from None


def _measure(r: _Reader, array: str, tab: dict, i: int, sections: dict) -> Any:
    from pkmstiff.evaluation.quantities import get_quantity
    from pkmstiff.report.sweep_evaluations import PointValues, WorkspaceVolume

    name = str(tab.get("name", f"{array}_{i + 1}"))
    kind = tab.get("kind")
    if kind not in _KINDS:
        raise r.error(array, i, "kind", f"one of {sorted(_KINDS)}", kind if kind is not None else "missing key")
    r.keys(tab, _COMMON | _KINDS[kind], array, i)
    kw = {k: (tuple(v) if isinstance(v, list) else v) for k, v in tab.items() if k in _KINDS[kind]}
    try:
        if kind == "section":
            stat = kw.pop("statistic", "mean")
            if stat not in SECTION_STATISTICS:
                raise r.error(array, i, "statistic", f"one of {list(SECTION_STATISTICS)}", stat)
            q = kw.pop("quantity", None)
            if not isinstance(q, str):
                raise r.error(array, i, "quantity", "a quantity name (pkmstiff quantities lists them)", q)
            key = tuple(sorted(kw.items()))
            sections.setdefault(key, set()).add(q)
            return ("section", key, name, q, stat)  # built once every section's quantities are known
        if kind == "point":
            q = kw.pop("quantity", None)
            ev = PointValues(quantities=(q,), **kw)
            return PointMeasure(name, get_quantity(q).unit, ev)
        if kind == "workspace":
            return WorkspaceMeasure(name, "m^3", WorkspaceVolume(**kw))
        if kind == "moving_mass":
            return MovingMassMeasure(name)
        box = tab.get("box_mm")
        if (not isinstance(box, list) or len(box) != 2
                or not all(isinstance(c, list) and len(c) == 3 for c in box)):
            raise r.error(array, i, "box_mm", "[[x0, y0, z0], [x1, y1, z1]] in mm", box)
        lo, hi = np.asarray(box[0], float) * 1e-3, np.asarray(box[1], float) * 1e-3
        if np.any(hi < lo):
            raise r.error(array, i, "box_mm", "corners with x0 <= x1, y0 <= y1, z0 <= z1", box)
        step = r.number(tab, "step_mm", array, i, 50.0) * 1e-3
        oris = tab.get("orientations_deg", [[0.0, 0.0, 0.0]])
        return TaskBoxMeasure(name, "1", tuple(lo), tuple(hi), step,
                              tuple(tuple(float(v) for v in np.radians(o)) for o in oris))
    except DesignFileError:
        raise
    except (ArgumentError, TypeError, ValueError, KeyError) as exc:
        raise r.error(array, i, None, f"valid {kind} settings", str(exc)) from None


def _reference(r: _Reader, tab: Any, i: int, machine: str, path: Path) -> Reference:
    """A [[reference]]: an ``option`` of the base machine or another ``machine`` (bundled or a file)."""
    tab = r.keys(tab, _REFERENCE, "reference", i)
    if ("option" in tab) == ("machine" in tab):
        raise r.error("reference", i, "option", "exactly one of 'option' (of the base machine) or 'machine'",
                      "both" if "option" in tab else "neither")
    key = "option" if "option" in tab else "machine"
    value = tab[key]
    if not isinstance(value, str) or not value:
        raise r.error("reference", i, key, "a name (text)", value)
    if key == "option":
        spec = f"{machine},{value}" if ":" in machine else f"{machine}:{value}"
    else:
        base = value.split(":", 1)[0]
        spec = str(path.parent / value) if base.endswith(".toml") and not Path(base).is_absolute() else value
    name = tab.get("name", value)
    if not isinstance(name, str) or not name.strip():
        raise r.error("reference", i, "name", "a name (text)", name)
    return Reference(name.strip(), spec, key)


def _section_measures(r: _Reader, raw: list, sections: dict[tuple, set[str]]) -> list:
    """Replace the section placeholders by :class:`SectionMeasure` s sharing one request per settings."""
    from pkmstiff.evaluation.quantities import get_quantity
    from pkmstiff.report.sweep_evaluations import SectionStatistics

    requests = {key: SectionStatistics(quantities=tuple(sorted(qs)), **dict(key)).request()
                for key, qs in sections.items()}
    out = []
    for m in raw:
        if isinstance(m, tuple):
            _, key, name, q, stat = m
            unit = SECTION_STATISTICS[stat] or get_quantity(q).unit
            m = SectionMeasure(name, unit, q, stat, requests[key])
        out.append(m)
    return out


def parse_duration(value: Any, source: str, key: str) -> float:
    """A time budget [s]: seconds as a number, or a duration pint understands (``"300 s"``, ``"300s"``, ``"5 min"``,
    ``"1.5 h"``); positive."""
    from pkmstiff.units import parse_quantity

    return float(parse_quantity(value, "s", source=source, key=key, positive=True, plausible=False))


def resolve_design(path: str | Path) -> Path:
    """A design file path, or the name of a bundled example (``"hexaglide_joint_orientation"``)."""
    from pkmstiff.optimise import EXAMPLES

    p = Path(path)
    bundled = EXAMPLES / f"{path}.toml"
    return bundled if not p.exists() and p.suffix != ".toml" and bundled.is_file() else p


def load_design(path: str | Path) -> Design:
    """Read and validate a design file or bundled example (syntax, keys, values; :func:`check_design` tries it on
    the machine)."""
    path = resolve_design(path)
    r = _Reader(path)
    raw = read_toml(path, "design file")
    r.keys(raw, _TOP, None, 0)
    machine = raw.get("machine")
    if not isinstance(machine, str) or not machine:
        raise r.error(None, 0, "machine", "a bundled machine name or path (text)", machine or "missing key")
    base = machine.split(":", 1)[0]
    if base.endswith(".toml") and not Path(base).is_absolute():
        machine = str(path.parent / machine)
    opt = r.keys(raw.get("optimiser", {}), _OPT, None, 0)
    algorithm = opt.get("algorithm", "auto")
    if algorithm not in _ALGORITHMS:
        raise r.error(None, 0, "algorithm", f"one of {list(_ALGORITHMS)}", algorithm)
    ints: dict[str, Any] = {}
    for key, default, lo in (("budget", 200, 1), ("population", 20, 2), ("seed", 1, 0), ("refine", 10, 1)):
        v = opt.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise r.error(None, 0, key, f"a whole number >= {lo}", v)
        ints[key] = v
    if "time_budget" in opt:
        ints["time_budget"] = parse_duration(opt["time_budget"], f"{path}:{r.lines.line(None, 0, 'time_budget')}",
                                             "optimiser.time_budget")
    if "coarse_step_mm" in opt:
        ints["coarse_step"] = r.number(opt, "coarse_step_mm", None, 0) * 1e-3
        if ints["coarse_step"] <= 0:
            raise r.error(None, 0, "coarse_step_mm", "a positive raster step in mm", opt["coarse_step_mm"])
    for array in ("variables", "objectives"):
        if not isinstance(raw.get(array), list) or not raw[array]:
            raise r.error(None, 0, array, f"an array of at least one [[{array}]] table", raw.get(array, "missing"))
    variables = tuple(_variable(r, t, i) for i, t in enumerate(raw["variables"]))
    sections: dict[tuple, set[str]] = {}
    objs, cons = [], []
    for i, t in enumerate(raw["objectives"]):
        sense = t.get("sense", "minimise") if isinstance(t, dict) else None
        if sense not in ("minimise", "maximise"):
            raise r.error("objectives", i, "sense", "'minimise' or 'maximise'", sense)
        if "relative_to" in t:
            raise r.error("objectives", i, "relative_to", "no 'relative_to' in an objective (constraints only)",
                          t["relative_to"])
        objs.append((_measure(r, "objectives", t, i, sections), sense))
    for i, t in enumerate(raw.get("constraints", [])):
        m = _measure(r, "constraints", t, i, sections)
        lo, hi = t.get("min"), t.get("max")
        if lo is None and hi is None:
            raise r.error("constraints", i, "min", "a bound 'min' and/or 'max'", "missing key")
        lo = None if lo is None else r.number(t, "min", "constraints", i)
        hi = None if hi is None else r.number(t, "max", "constraints", i)
        if lo is not None and hi is not None and not lo <= hi:
            raise r.error("constraints", i, "max", f"max >= min = {lo:g}", hi)
        rel = t.get("relative_to")
        if rel not in (None, "base"):
            raise r.error("constraints", i, "relative_to", "'base' (min/max are fractions of the base machine's "
                          "value)", rel)
        cons.append((m, lo, hi, rel == "base"))
    built = _section_measures(r, [m for m, _ in objs] + [m for m, *_ in cons], sections)
    refs = raw.get("reference", [])
    if not isinstance(refs, list):
        raise r.error(None, 0, "reference", "an array of [[reference]] tables", refs)
    references = tuple(_reference(r, t, i, machine, path) for i, t in enumerate(refs))
    taken = {"base"}  # the names are the columns of the comparison: base, the references, design_NNN
    for i, ref in enumerate(references):
        if ref.name in taken or re.fullmatch(r"design_\d+", ref.name):
            raise r.error("reference", i, "name", "a name other than 'base', 'design_NNN' and the other references'",
                          ref.name)
        taken.add(ref.name)
    design = Design(machine, variables, tuple(Objective(m, s) for m, (_, s) in zip(built, objs)),
                    tuple(Constraint(m, lo, hi, rel) for m, (_, lo, hi, rel) in zip(built[len(objs):], cons)),
                    algorithm=algorithm, source=str(path), **ints, references=references)
    check_design(design, r)
    return design


def _largest_possible(m: Any) -> float | None:
    """The largest value a measure can take whatever the design (None where unbounded): the admissible area of a
    section is at most its whole raster, the admissible fraction of a task box 1."""
    if isinstance(m, TaskBoxMeasure):
        return 1.0
    if isinstance(m, SectionMeasure) and m.statistic == "area":
        from pkmstiff.evaluation.sections import axis_plane

        q = m.request
        plane = axis_plane(q.plane, q.at, q.u_range, q.v_range, q.step)
        return float(plane.u_values.size * plane.v_values.size) * plane.cell_area
    return None


def check_design(design: Design, reader: _Reader | None = None) -> None:
    """Try every variable on the base machine (bounds, every categorical value) and every quantity name, before
    any evaluation; raise :class:`DesignFileError` naming the variable's line."""
    from pkmstiff.errors import ArgumentError
    from pkmstiff.evaluation.quantities import check_quantity
    from pkmstiff.machine.variants import machine_with

    r = reader or _Reader(Path(design.source))
    try:
        base = machine_with(design.machine)
    except InputError as exc:
        raise r.error(None, 0, "machine", "a machine that loads", str(exc)) from None
    except Exception as exc:  # noqa: BLE001 - an unknown bundled name
        raise r.error(None, 0, "machine", "a bundled machine name or a machine file", str(exc)) from None
    for i, v in enumerate(design.variables):
        if v.kind == "categorical":
            trials = list(v.values)
        elif v.kind == "direction":
            trials = [tuple(v.low), tuple(v.high)]
        else:
            trials = [v.low[0], v.high[0]] if v.kind == "continuous" else [int(v.low[0]), int(v.high[0])]
        for value in trials:
            try:
                machine_with(design.machine, v.overrides(value))
            except InputError as exc:
                key = ("path" if isinstance(exc, OverrideError) else "values" if v.kind == "categorical"
                       else "unit" if v.unit else "low")
                raise r.error("variables", i, key, f"a value the machine accepts at {value!r} "
                              f"({exc.key}: {exc.expected})", exc.found) from None
    for i, ref in enumerate(design.references):
        try:
            machine_with(ref.machine)
        except Exception as exc:  # noqa: BLE001 - an unknown option or bundled name, or an invalid machine file
            raise r.error("reference", i, ref.key, "a machine that loads", str(exc)) from None
    for i, c in enumerate(design.constraints):
        most = _largest_possible(c.measure)
        if most is not None and not c.relative and c.lower is not None and c.lower > most * (1 + 1e-9):
            raise r.error("constraints", i, "min", f"a bound some design can meet (infeasible everywhere: "
                          f"{c.measure.name} is at most {most:.6g} {c.measure.unit})", c.lower)
    for array, items in (("objectives", design.objectives), ("constraints", design.constraints)):
        for i, it in enumerate(items):
            q = getattr(it.measure, "quantity", None) or next(iter(getattr(getattr(it.measure, "evaluation", None),
                                                                           "quantities", ()) or ()), None)
            if q is None or isinstance(it.measure, FunctionMeasure):
                continue
            try:
                check_quantity(q, base.n_chains)
            except ArgumentError as exc:
                raise r.error(array, i, "quantity", "a quantity of this machine (pkmstiff quantities lists them)",
                              str(exc)) from None
