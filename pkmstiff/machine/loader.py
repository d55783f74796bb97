"""Loading and validation of TOML machine files (format described in the README, "Machine files").

A machine is loaded by bundled name (``"hexaglide"``), by name with options (``"linapod:printed_values"``) or by
path. A file may ``extends`` another machine and override parts of it (tables are merged key by key, the
``chains`` array element by element); ``[options.NAME]`` tables are optional overrides selected at load time.
Every value is validated; errors are :class:`InputError` naming file, key, expectation and finding.
"""

from __future__ import annotations

import copy
import dataclasses
import importlib.resources
import math
import os
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from pkmstiff.errors import InputError, UnknownMachineError
from pkmstiff.io import check_format_version, check_keys, read_toml, require
from pkmstiff.io.inputs import input_file_problem
from pkmstiff.machine.model import Chains, Guide, Hull, JointType, Limits, Machine, Tool
from pkmstiff.units import parse_quantity

_TOP_KEYS = {"format_version", "machine", "limits", "tool", "joint_types", "guides", "chain_defaults", "chains",
             "hull", "components", "machine_components", "assumptions", "options", "calibration"}
_MACHINE_KEYS = {"name", "title", "type", "source", "extends", "gravity", "transmission_weight", "notes",
                 "report_origin", "report_origin_note", "transmission_form", "strut_mass_shares"}
TRANSMISSION_FORMS = ("inverse_sqrt_kappa", "inverse_kappa")
_LIMIT_KEYS = {"singularity_threshold", "strut_collision_mode", "platform_end_exclusion", "drive_load_include_coulomb",
               "drive_load_strut_mass", "frame"}
_FRAME_KEYS = {f"{a}_{m}" for a in "xyz" for m in ("min", "max")}
_TOOL_KEYS = {"offset", "axis", "length"}
_JOINT_KEYS = {"convention", "strut_direction", "swivel_min", "swivel_max", "tilt_min", "tilt_max", "ina_coupled",
               "stiffness", "mass", "description"}
_GUIDE_KEYS = {"chains", "min_distance", "max_distance", "safety_margin"}
_GLIDE_CHAIN_KEYS = {"guide_start", "guide_direction", "guide_length", "strut_length", "root"}
_POD_CHAIN_KEYS = {"length_min", "length_max"}
_COMMON_CHAIN_KEYS = {"drive_joint", "drive_axis", "drive_reference", "platform_joint", "platform_axis",
                      "platform_reference", "strut_radius", "drive_joint_type", "platform_joint_type", "components",
                      "label", "drive_offset"}
_HULL_KEYS = {"vertices", "triangles", "source"}


def bundled_machine_dir() -> Path:
    return Path(str(importlib.resources.files("pkmstiff") / "machine" / "bundled"))


def bundled_machines() -> list[str]:
    """Names of the machine files shipped with the package."""
    return sorted(p.stem for p in bundled_machine_dir().glob("*.toml"))


def resolve_machine_path(name_or_path: str | Path) -> Path:
    p = Path(name_or_path)
    if p.suffix == ".toml" or os.path.lexists(p):
        problem = input_file_problem(p)
        if problem == "no such file":
            raise UnknownMachineError(f"machine file '{p}' does not exist")
        if problem is not None:
            raise UnknownMachineError(f"machine file '{p}': expected a regular file, found {problem}")
        return p
    candidate = bundled_machine_dir() / f"{name_or_path}.toml"
    if candidate.is_file():
        return candidate
    raise UnknownMachineError(
        f"unknown machine '{name_or_path}': not a file and not a bundled machine (bundled: {', '.join(bundled_machines())})"
    )


def _merge(base: Any, over: Any) -> Any:
    """Deep merge: tables key by key, equally long arrays of tables element by element, everything else replaced."""
    if isinstance(base, dict) and isinstance(over, dict):
        out = copy.deepcopy(base)
        for k, v in over.items():
            out[k] = _merge(out[k], v) if k in out else copy.deepcopy(v)
        return out
    if (isinstance(base, list) and isinstance(over, list) and len(base) == len(over)
            and all(isinstance(x, dict) for x in base + over)):
        return [_merge(b, o) for b, o in zip(base, over)]
    return copy.deepcopy(over)


def _raw_with_extends(path: Path, seen: tuple[Path, ...] = ()) -> dict[str, Any]:
    raw = read_toml(path, "machine file")
    parent = raw.get("machine", {}).get("extends") if isinstance(raw.get("machine"), dict) else None
    if parent is None:
        return raw
    try:
        parent_path = resolve_machine_path(parent if not str(parent).endswith(".toml") else path.parent / parent)
    except UnknownMachineError as exc:
        raise InputError(str(path), "machine.extends", "a bundled machine name or a path", parent) from exc
    if parent_path.resolve() in seen:
        raise InputError(str(path), "machine.extends", "no circular 'extends'", parent)
    base = _raw_with_extends(parent_path, seen + (path.resolve(),))
    # a component the child defines with its own 'model' replaces the parent's as a whole (a pasted
    # [components.NAME] table, e.g. from 'pkmstiff fe-platform', must not inherit parameters of the old definition:
    # a 'matrix' next to the parent's 'diagonal' would be contradictory); without 'model' its keys override
    own = raw.get("components") if isinstance(raw.get("components"), dict) else {}
    if own and isinstance(base.get("components"), dict):
        base = {**base, "components": {k: v for k, v in base["components"].items()
                                       if not (isinstance(own.get(k), dict) and "model" in own[k])}}
    # the child's own assumptions/options add to the parent's; 'extends' itself is not inherited
    merged = _merge(base, raw)
    merged["machine"].pop("extends", None)
    return merged


def split_machine_spec(name_or_path: str | Path, options: Iterable[str] = ()) -> tuple[str, list[str]]:
    """``"hexapod_6x:constant_drive_stiffness"`` -> (``"hexapod_6x"``, [``"constant_drive_stiffness"``])."""
    opts = list(options)
    spec = str(name_or_path)
    if ":" in spec and not Path(spec).exists() and not (len(spec) > 1 and spec[1] == ":"):
        spec, extra = spec.split(":", 1)
        opts += [o for o in extra.split(",") if o]
    return spec, opts


def raw_machine(name_or_path: str | Path, options: Iterable[str] = ()) -> tuple[dict[str, Any], str, list[str]]:
    """The raw TOML data of a machine with ``extends`` resolved and options applied: (raw dict, source, options)."""
    spec, opts = split_machine_spec(name_or_path, options)
    path = resolve_machine_path(spec)
    raw = _raw_with_extends(path)
    src = str(path)
    available = raw.get("options", {})
    for opt in opts:
        if opt not in available:
            raise InputError(src, "options", f"one of {sorted(available)}", opt)
        raw = _merge(raw, available[opt])
    return raw, src, opts


def machine_options(name_or_path: str | Path) -> dict[str, str]:
    """The ``[options.NAME]`` variants of a machine: name -> its description (the file's ``description``, else the
    tables it changes)."""
    raw, _, _ = raw_machine(name_or_path)
    out = {}
    for opt, tab in (raw.get("options") or {}).items():
        desc = tab.get("description") if isinstance(tab, dict) else None
        out[opt] = desc if isinstance(desc, str) else ", ".join(sorted(tab)) if isinstance(tab, dict) else ""
    return out


def load_machine(name_or_path: str | Path, options: Iterable[str] = ()) -> Machine:
    """Load and validate a machine by bundled name (``"hexaglide"``, ``"linapod:printed_values"``) or path.

    ``options`` (or the ``:opt1,opt2`` suffix of the name) selects ``[options.NAME]`` override tables of the file.
    Bundled machines are cached on disk after their first load (:mod:`pkmstiff.machine.cache`).
    """
    spec, opts = split_machine_spec(name_or_path, options)
    p = Path(spec)
    if p.suffix != ".toml" and not p.exists() and (bundled_machine_dir() / f"{spec}.toml").is_file():
        from pkmstiff.machine.cache import cached_load

        return cached_load(spec, opts, lambda: _load_uncached(spec, opts))
    return _load_uncached(name_or_path, options)


def _load_uncached(name_or_path: str | Path, options: Iterable[str] = ()) -> Machine:
    raw, src, options = raw_machine(name_or_path, options)
    try:
        return _build(raw, src, options)
    except InputError as exc:  # raised by the unit parser or a component model: name the machine file
        raise exc.in_file(src) from None


# ----------------------------------------------------------------------------------------------------------------
# building and validation


def _vec(value: Any, src: str, key: str, unit: str = "m") -> np.ndarray:
    return np.asarray(parse_quantity(value, unit, source=src, key=key, shape=(3,)), dtype=float)


def _direction(value: Any, src: str, key: str) -> np.ndarray:
    v = _vec(value, src, key, "dimensionless")
    norm = float(np.linalg.norm(v))
    if norm < 1e-9:
        raise InputError(src, key, "a non-zero direction vector", list(v))
    return v / norm


def _angle(value: Any, src: str, key: str) -> float:
    return float(parse_quantity(value, "rad", source=src, key=key))


def _length(value: Any, src: str, key: str, *, positive: bool = True) -> float:
    return float(parse_quantity(value, "m", source=src, key=key, positive=positive, min_value=None if positive else 0.0))


def _strut_mass_shares(tab: Any, src: str) -> tuple[float, float]:
    """``[machine] strut_mass_shares = { drive = D, platform = P }``: fractions of each strut's mass lumped at its
    drive and platform joint in the structure model, each in [0, 1], D + P <= 1."""
    key = "machine.strut_mass_shares"
    if not isinstance(tab, dict):
        raise InputError(src, key, "a table { drive = fraction, platform = fraction }", tab)
    check_keys(tab, {"drive", "platform"}, src, key + ".")
    shares = tuple(float(parse_quantity(require(tab, side, src, key + ".", "a fraction in [0, 1]"),
                                        "dimensionless", source=src,
                                        key=f"{key}.{side}", min_value=0.0)) for side in ("drive", "platform"))
    if max(shares) > 1.0 or sum(shares) > 1.0 + 1e-12:
        raise InputError(src, key, "fractions in [0, 1] with drive + platform <= 1", tab)
    return shares  # type: ignore[return-value]


def _build(raw: dict[str, Any], src: str, options: list[str]) -> Machine:
    check_keys(raw, _TOP_KEYS, src, "")
    check_format_version(raw, src)
    mtab = check_keys(require(raw, "machine", src, "", "a [machine] table"), _MACHINE_KEYS, src,
                      "machine.")
    name = str(require(mtab, "name", src, "machine.", "the machine's short name"))
    kind = require(mtab, "type", src, "machine.", "'pod' or 'glide'")
    if kind not in ("pod", "glide"):
        raise InputError(src, "machine.type", "'pod' or 'glide'", kind)
    gravity = _vec(mtab.get("gravity", [0.0, 0.0, -9.81]), src, "machine.gravity", "m/s^2")
    w = float(parse_quantity(mtab.get("transmission_weight", 1.0), "m/rad", source=src,
                             key="machine.transmission_weight", positive=True))

    report_origin = _vec(mtab.get("report_origin", [0.0, 0.0, 0.0]), src, "machine.report_origin")
    tform = mtab.get("transmission_form", "inverse_sqrt_kappa")
    if tform not in TRANSMISSION_FORMS:
        raise InputError(src, "machine.transmission_form", f"one of {list(TRANSMISSION_FORMS)}", tform)
    shares = _strut_mass_shares(mtab.get("strut_mass_shares", {"drive": 0.5, "platform": 0.5}), src)
    limits = _limits(raw.get("limits", {}), src)
    tool = _tool(raw.get("tool", {}), src)
    components = _components(raw.get("components", {}), src)
    joint_types = _joint_types(raw.get("joint_types", {}), src, components)
    chain_tables = require(raw, "chains", src, "", "an array of [[chains]] tables")
    if not isinstance(chain_tables, list) or len(chain_tables) != 6:  # a square Jacobian: one chain per platform DOF
        raise InputError(src, "chains", "an array of 6 [[chains]] tables (one per degree of freedom of the "
                               "platform)", f"{len(chain_tables)} tables" if isinstance(chain_tables, list)
                               else chain_tables)
    defaults = raw.get("chain_defaults", {})
    chains, chain_components = _chains(kind, chain_tables, defaults, src, joint_types, components)
    guides = _guides(raw.get("guides", {}), src, chains.n, kind)
    on_guide = {c: g.name for g in guides.values() for c in g.chains}
    chains = dataclasses.replace(chains, guide=tuple(on_guide.get(i) for i in range(chains.n)))
    hull = _hull(raw.get("hull", {}), src)
    mcomp = raw.get("machine_components", {})
    if not isinstance(mcomp, dict):
        raise InputError(src, "machine_components", "a table role = component name", mcomp)
    for role, ref in mcomp.items():
        _check_ref(ref, components, src, f"machine_components.{role}")
    assumptions = raw.get("assumptions", {})
    if not isinstance(assumptions, dict) or not all(isinstance(v, str) for v in assumptions.values()):
        raise InputError(src, "assumptions", "a table key = one-line reason (strings)", assumptions)
    built = _build_components(components, src)
    _check_joint_conventions(joint_types, built, src)
    title = str(mtab.get("title", name)) + (f" [{', '.join(options)}]" if options else "")
    return Machine(
        name=name + (":" + ",".join(options) if options else ""), title=title, chains=chains,
        joint_types=joint_types, guides=guides, hull=hull, tool=tool, gravity=gravity, limits=limits,
        transmission_weight=w, components=components, chain_components=chain_components,
        machine_components={k: str(v) for k, v in mcomp.items()}, assumptions=dict(assumptions),
        source=str(mtab.get("source", "")), path=src, built_components=built,
        report_origin=report_origin, report_origin_note=str(mtab.get("report_origin_note", "")),
        transmission_form=tform, strut_mass_shares=shares, calibration=_calibration(raw.get("calibration"), src),
    )


#: [calibration] provenance block of a calibrated machine file (written by ``pkmstiff calibrate identify``):
#: key -> kind of value
_CALIBRATION_KEYS = {"nominal_machine": "str", "measurement_file": "str", "measurement_sha256": "sha256",
                     "measurement_header_sha256": "sha256",  # the measurement's header file <name>.json
                     "more_measurement_files": "strings", "more_measurement_sha256": "strings",  # set-ups 2, 3, …
                     "method": "str", "loss": "str", "rank": "count", "n_readings": "count",
                     "condition_number": "number", "rms_before_um": "number", "rms_after_um": "number",
                     "max_before_um": "number", "max_after_um": "number", "s_um": "number", "date": "str",
                     "toolkit_version": "str", "scaling": "str", "gauge_freedoms": "strings", "deflection": "str", "identified": "table",
                     "sigma": "table"}


def _calibration(tab: Any, src: str) -> dict[str, Any]:
    """Validate the ``[calibration]`` provenance table (keys above; ``identified``/``sigma``: parameter name ->
    quantity such as "0.012 mm"; σ must be non-negative). Returns it as a plain dict ({} when absent)."""
    if tab is None:
        return {}
    check_keys(tab, _CALIBRATION_KEYS, src, "calibration.")
    for key, value in tab.items():
        kind, k = _CALIBRATION_KEYS[key], f"calibration.{key}"
        if kind == "str" and not isinstance(value, str):
            raise InputError(src, k, "a string", value)
        if kind == "sha256" and not (isinstance(value, str) and len(value) == 64
                                     and all(c in "0123456789abcdef" for c in value)):
            raise InputError(src, k, "a SHA-256 hex digest (64 lower-case hex digits)", value)
        if kind == "count" and not (isinstance(value, int) and not isinstance(value, bool) and value >= 0):
            raise InputError(src, k, "a non-negative integer", value)
        if kind == "number" and not (isinstance(value, (int, float)) and not isinstance(value, bool)
                                     and value >= 0 and np.isfinite(value)):
            raise InputError(src, k, "a non-negative finite number", value)
        if kind == "strings" and not (isinstance(value, list) and all(isinstance(v, str) for v in value)):
            raise InputError(src, k, "a list of strings", value)
        if kind == "table":
            if not isinstance(value, dict):
                raise InputError(src, k, "a table parameter name = quantity", value)
            for name, q in value.items():
                if not isinstance(q, str):
                    raise InputError(src, f"{k}.{name}", "a quantity with its unit, e.g. \"0.012 mm\"", q)
                try:
                    unit = "rad" if any(u in q for u in ("rad", "deg")) else "m"
                    v = parse_quantity(q, unit, source=src, key=f"{k}.{name}")
                except InputError:
                    raise InputError(src, f"{k}.{name}", "a length or angle with its unit", q) from None
                if key == "sigma" and v < 0:
                    raise InputError(src, f"{k}.{name}", "a non-negative standard deviation", q)
    return dict(tab)


def _limits(tab: Any, src: str) -> Limits:
    check_keys(tab, _LIMIT_KEYS, src, "limits.")
    kw: dict[str, Any] = {}
    if "singularity_threshold" in tab:
        kw["singularity_threshold"] = float(parse_quantity(tab["singularity_threshold"], "dimensionless", source=src,
                                                           key="limits.singularity_threshold", min_value=1.0))
    if "strut_collision_mode" in tab:
        if tab["strut_collision_mode"] not in ("exact", "table_B2"):
            raise InputError(src, "limits.strut_collision_mode", "'exact' or 'table_B2'", tab["strut_collision_mode"])
        kw["strut_collision_mode"] = tab["strut_collision_mode"]
    if "platform_end_exclusion" in tab:
        kw["platform_end_exclusion"] = _length(tab["platform_end_exclusion"], src, "limits.platform_end_exclusion",
                                               positive=False)
    if "drive_load_include_coulomb" in tab:
        if not isinstance(tab["drive_load_include_coulomb"], bool):
            raise InputError(src, "limits.drive_load_include_coulomb", "true or false",
                                   tab["drive_load_include_coulomb"])
        kw["drive_load_include_coulomb"] = tab["drive_load_include_coulomb"]
    if "drive_load_strut_mass" in tab:
        frac = float(parse_quantity(tab["drive_load_strut_mass"], "dimensionless", source=src,
                                    key="limits.drive_load_strut_mass", min_value=0.0))
        if frac > 1.0:
            raise InputError(src, "limits.drive_load_strut_mass", "a fraction in [0, 1]", frac)
        kw["drive_load_strut_mass"] = frac
    if "frame" in tab:
        fr = check_keys(tab["frame"], _FRAME_KEYS, src, "limits.frame.")
        lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
        for k, v in fr.items():
            (lo if k.endswith("min") else hi)["xyz".index(k[0])] = float(
                parse_quantity(v, "m", source=src, key=f"limits.frame.{k}"))
        bad = np.nonzero(lo >= hi)[0]
        if bad.size:
            a = "xyz"[bad[0]]
            raise InputError(src, f"limits.frame.{a}_min", f"a value below {a}_max = {hi[bad[0]]} m",
                                   fr.get(f"{a}_min"))
        kw["position_min"], kw["position_max"] = lo, hi
    return Limits(**kw)


def _tool(tab: Any, src: str) -> Tool:
    check_keys(tab, _TOOL_KEYS, src, "tool.")
    return Tool(
        offset=_vec(tab.get("offset", [0, 0, 0]), src, "tool.offset"),
        axis=_direction(tab.get("axis", [0, 0, -1]), src, "tool.axis"),
        length=_length(tab.get("length", 0.0), src, "tool.length", positive=False),
    )


def _components(tab: Any, src: str) -> dict[str, dict[str, Any]]:
    if not isinstance(tab, dict):
        raise InputError(src, "components", "a table of named component tables", tab)
    out = {}
    try:
        from components.registry import available_models  # the component library validates the parameters
        models = set(available_models())
    except ImportError:  # component library not installed: only the structure is checked
        models = None
    for cname, params in tab.items():
        key = f"components.{cname}"
        if not isinstance(params, dict):
            raise InputError(src, key, "a table with at least the key 'model'", params)
        model = require(params, "model", src, key + ".", "the name of a component model")
        if models is not None and model not in models:
            raise InputError(src, key + ".model", f"one of the component models {sorted(models)}", model)
        out[cname] = dict(params)
    return out


def _build_components(components: dict[str, dict[str, Any]], src: str) -> dict[str, tuple[dict, Any]]:
    """Build every component instance (validating its parameters); empty without the component library."""
    try:
        from components.registry import build_component
    except ImportError:
        return {}
    return {name: (params, build_component(name, params, source=src, base_dir=str(Path(src).parent)))
            for name, params in components.items()}


def _check_joint_conventions(joint_types: dict[str, JointType], built: dict, src: str) -> None:
    """A joint's stiffness data must refer to the tilt convention of its joint type (docs/theory/kinematics.md)."""
    for jt in joint_types.values():
        if jt.stiffness is None or jt.stiffness not in built:
            continue
        conv = getattr(built[jt.stiffness][1], "angle_convention", None)
        if conv is not None and conv != jt.convention:
            raise InputError(src, f"joint_types.{jt.name}.stiffness",
                                   f"stiffness data in the joint type's '{jt.convention}' tilt convention",
                                   f"component '{jt.stiffness}' with angle_convention '{conv}'")


def _check_ref(ref: Any, components: dict, src: str, key: str) -> None:
    if not isinstance(ref, str) or ref not in components:
        raise InputError(src, key, f"the name of a component defined under [components] ({sorted(components)})",
                               ref)


def _joint_types(tab: Any, src: str, components: dict) -> dict[str, JointType]:
    if not isinstance(tab, dict) or not tab:
        raise InputError(src, "joint_types", "at least one [joint_types.NAME] table", tab)
    out = {}
    for jname, jt in tab.items():
        p = f"joint_types.{jname}."
        check_keys(jt, _JOINT_KEYS, src, p)
        conv = jt.get("convention", "axis")
        if conv not in ("axis", "normal"):
            raise InputError(src, p + "convention", "'axis' or 'normal'", conv)
        sdir = jt.get("strut_direction", "outward")
        if sdir not in ("outward", "drive_to_platform"):
            raise InputError(src, p + "strut_direction", "'outward' or 'drive_to_platform'", sdir)
        kw = {k: _angle(jt[k], src, p + k) for k in ("swivel_min", "swivel_max", "tilt_min", "tilt_max") if k in jt}
        for lo, hi in (("swivel_min", "swivel_max"), ("tilt_min", "tilt_max")):
            if lo in kw and hi in kw and kw[lo] > kw[hi]:
                raise InputError(src, p + lo, f"a value <= {hi}", jt[lo])
        ina = jt.get("ina_coupled", False)
        if not isinstance(ina, bool):
            raise InputError(src, p + "ina_coupled", "true or false", ina)
        stiff = jt.get("stiffness")
        if stiff is not None:
            _check_ref(stiff, components, src, p + "stiffness")
        mass = float(parse_quantity(jt.get("mass", 0.0), "kg", source=src, key=p + "mass", min_value=0.0))
        out[jname] = JointType(name=jname, convention=conv, strut_direction=sdir, ina_coupled=ina,
                               stiffness=stiff, mass=mass, **kw)
    return out


def _chains(kind: str, tables: list, defaults: Any, src: str, joint_types: dict,
            components: dict) -> tuple[Chains, tuple[dict[str, str], ...]]:
    allowed = _COMMON_CHAIN_KEYS | (_GLIDE_CHAIN_KEYS if kind == "glide" else _POD_CHAIN_KEYS)
    check_keys(defaults, allowed, src, "chain_defaults.")
    n = len(tables)
    cols: dict[str, list] = {k: [] for k in allowed}
    comps: list[dict[str, str]] = []
    for i, tab in enumerate(tables):
        p = f"chains[{i + 1}]."
        check_keys(tab, allowed, src, p)
        t = _merge(defaults, tab)

        def need(key: str, what: str) -> Any:
            if key not in t:
                raise InputError(src, p + key, f"{what} (required for a {kind} chain)", "missing key")
            return t[key]

        cols["drive_joint"].append(_vec(t.get("drive_joint", [0, 0, 0]) if kind == "glide"
                                        else need("drive_joint", "the drive-side joint point [x, y, z] in m"),
                                        src, p + "drive_joint"))
        cols["drive_axis"].append(_direction(need("drive_axis", "the drive joint's first axis a_i"), src,
                                             p + "drive_axis"))
        cols["drive_reference"].append(_direction(need("drive_reference", "the drive joint's swivel reference b_i"),
                                                  src, p + "drive_reference"))
        cols["platform_joint"].append(_vec(need("platform_joint", "the platform joint point p'_i [x, y, z] in m"),
                                           src, p + "platform_joint"))
        cols["platform_axis"].append(_direction(need("platform_axis", "the platform joint's first axis m'_i"), src,
                                                p + "platform_axis"))
        cols["platform_reference"].append(_direction(need("platform_reference",
                                                          "the platform joint's swivel reference n'_i"),
                                                     src, p + "platform_reference"))
        cols["strut_radius"].append(_length(need("strut_radius", "the strut radius for collision checks"), src,
                                            p + "strut_radius", positive=False))
        for side in ("drive_joint_type", "platform_joint_type"):
            jt = need(side, "the name of a [joint_types.NAME] table")
            if jt not in joint_types:
                raise InputError(src, p + side, f"one of the joint types {sorted(joint_types)}", jt)
            cols[side].append(jt)
        if kind == "glide":
            cols["guide_start"].append(_vec(need("guide_start", "the guide start point s_i"), src, p + "guide_start"))
            cols["guide_direction"].append(_direction(need("guide_direction", "the guide direction r_i"), src,
                                                      p + "guide_direction"))
            cols["guide_length"].append(_length(need("guide_length", "the usable guide length t_i"), src,
                                                p + "guide_length"))
            cols["strut_length"].append(_length(need("strut_length", "the strut length l_i"), src, p + "strut_length"))
            root = t.get("root", "smaller")
            if root not in ("smaller", "larger"):
                raise InputError(src, p + "root", "'smaller' or 'larger'", root)
            cols["root"].append(root == "larger")
        else:
            lmin = _length(need("length_min", "the minimum strut length"), src, p + "length_min")
            lmax = _length(need("length_max", "the maximum strut length"), src, p + "length_max")
            if lmax <= lmin:
                raise InputError(src, p + "length_max", f"a length > length_min = {lmin} m", t["length_max"])
            cols["length_min"].append(lmin)
            cols["length_max"].append(lmax)
        # drive zero offset (calibrated machines): controller drive coordinate = geometric one - drive_offset
        cols["drive_offset"].append(float(parse_quantity(t.get("drive_offset", 0.0), "m", source=src,
                                                         key=p + "drive_offset")))
        cc = t.get("components", {})
        if not isinstance(cc, dict):
            raise InputError(src, p + "components", "a table role = component name", cc)
        for role, ref in cc.items():
            _check_ref(ref, components, src, f"{p}components.{role}")
        comps.append({k: str(v) for k, v in cc.items()})

    nan = np.full(n, np.nan)
    glide = kind == "glide"
    chains = Chains(
        kind=kind,  # type: ignore[arg-type]
        guide_start=np.array(cols["guide_start"]) if glide else np.zeros((n, 3)),
        guide_direction=np.array(cols["guide_direction"]) if glide else np.zeros((n, 3)),
        guide_length=np.array(cols["guide_length"]) if glide else nan.copy(),
        strut_length=np.array(cols["strut_length"]) if glide else nan.copy(),
        larger_root=np.array(cols["root"], dtype=bool) if glide else np.zeros(n, dtype=bool),
        length_min=nan.copy() if glide else np.array(cols["length_min"]),
        length_max=nan.copy() if glide else np.array(cols["length_max"]),
        drive_joint=np.array(cols["drive_joint"]), drive_axis=np.array(cols["drive_axis"]),
        drive_reference=np.array(cols["drive_reference"]), platform_joint=np.array(cols["platform_joint"]),
        platform_axis=np.array(cols["platform_axis"]), platform_reference=np.array(cols["platform_reference"]),
        strut_radius=np.array(cols["strut_radius"]),
        drive_joint_type=tuple(cols["drive_joint_type"]), platform_joint_type=tuple(cols["platform_joint_type"]),
        guide=tuple([None] * n), drive_offset=np.array(cols["drive_offset"]),
    )
    return chains, tuple(comps)


def _guides(tab: Any, src: str, n: int, kind: str) -> dict[str, Guide]:
    if not isinstance(tab, dict):
        raise InputError(src, "guides", "a table of [guides.NAME] tables", tab)
    out = {}
    used: set[int] = set()
    for gname, g in tab.items():
        p = f"guides.{gname}."
        check_keys(g, _GUIDE_KEYS, src, p)
        if kind != "glide":
            raise InputError(src, f"guides.{gname}", "shared guides only for glide machines", "a guide table")
        members = require(g, "chains", src, p, "the 1-based chain numbers on this guide")
        if (not isinstance(members, list) or len(members) < 2
                or not all(isinstance(c, int) and not isinstance(c, bool) and 1 <= c <= n for c in members)):
            raise InputError(src, p + "chains", f"a list of at least two chain numbers 1..{n}", members)
        if used & set(members):
            raise InputError(src, p + "chains", "each chain on at most one guide", members)
        used |= set(members)
        out[gname] = Guide(
            name=gname, chains=tuple(c - 1 for c in members),
            min_distance=_length(g.get("min_distance", 0.0), src, p + "min_distance", positive=False),
            max_distance=(math.inf if "max_distance" not in g
                          else _length(g["max_distance"], src, p + "max_distance")),
            safety_margin=_length(g.get("safety_margin", 0.0), src, p + "safety_margin", positive=False),
        )
    return out


def _hull(tab: Any, src: str) -> Hull:
    check_keys(tab, _HULL_KEYS, src, "hull.")
    if "vertices" not in tab:
        return Hull(vertices=np.zeros((0, 3)), triangles=np.zeros((0, 3), dtype=int))
    verts = np.asarray(parse_quantity(tab["vertices"], "m", source=src, key="hull.vertices", shape=(None, 3)))
    if "triangles" in tab:
        tri = np.asarray(parse_quantity(tab["triangles"], "dimensionless", source=src, key="hull.triangles",
                                        shape=(None, 3)))
        if np.any(tri != np.round(tri)) or tri.min() < 0 or tri.max() >= len(verts):
            raise InputError(src, "hull.triangles", f"integer vertex indices 0..{len(verts) - 1}",
                                   tab["triangles"])
        hull = Hull(vertices=verts, triangles=tri.astype(int))
        try:
            hull.face_planes()  # computed at load, kept in the machine cache
        except Exception:  # noqa: BLE001 (a flat vertex set: the platform check reports it when it needs the hull)
            pass
        return hull
    if len(verts) < 4:
        raise InputError(src, "hull.vertices", "at least 4 vertices spanning a volume (or give 'triangles')",
                               f"{len(verts)} vertices")
    from scipy.spatial import ConvexHull, QhullError

    try:
        ch = ConvexHull(verts)
    except QhullError as exc:
        raise InputError(src, "hull.vertices", "vertices spanning a volume (convex hull)", "degenerate set") \
            from exc
    hull = Hull(vertices=verts, triangles=_oriented(verts, ch.simplices), convex=True)
    object.__setattr__(hull, "_equations", ch.equations)  # = hull.convex_hull_equations()
    hull.face_planes()  # computed at load, kept in the machine cache
    return hull


def _oriented(verts: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Orient convex-hull triangles outward (normal away from the centroid)."""
    c = verts.mean(axis=0)
    a, b, d = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    flip = np.einsum("ij,ij->i", np.cross(b - a, d - a), a - c) < 0
    tris = tris.copy()
    tris[flip] = tris[flip][:, [0, 2, 1]]
    return tris
