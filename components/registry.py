"""Build component instances from machine-file tables (``[components.<name>]`` with ``model = "..."``).

Every parameter is parsed with units (:func:`pkmstiff.units.parse_quantity`: bare numbers are SI, strings
carry units such as ``"25 N/um"``, ``"150 mm"``, ``"30 deg"``). Unknown model, missing or unknown
parameter, wrong unit or sign raise :class:`~pkmstiff.units.InputError` naming the source file, the key
(``components.<name>.<parameter>``), what was expected and what was found.

Users add their own models with :func:`register_model`; a factory receives a :class:`Params` reader and
returns a :class:`~components.protocol.Component`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np

from components import ballscrew as bs
from components.bearings import TaperedRollerBearing
from components.bodies import BodyStiffness, RigidBody
from components.direct_drive import AXIAL_MODES, LinearDirectDrive
from components.guides import GuideCarriages
from components.joint_tables import JointTableNotFound, load_joint_table
from components.joints import (
    AnalyticJoint330,
    ConstantJoint,
    ProductJoint,
    SwivelTiltTableJoint,
    TiltTableJoint,
    joint_from_table,
)
from components.protocol import Component, ConstantAxial
from components.spline import EXTRAPOLATION_POLICIES
from components.struts import Strut, StrutSections
from pkmstiff.units import InputError, parse_quantity, si

_MISSING = object()
COMMON_KEYS: tuple[str, ...] = ("model", "assumptions", "provenance")


@dataclass(frozen=True)
class ParamDoc:
    """Documentation of one model parameter: key, SI unit (or kind), default (text) and meaning."""

    key: str
    unit: str
    default: str
    meaning: str


@dataclass(frozen=True)
class ModelInfo:
    """A registered model: name, one-line description, equation reference, parameter docs, factory."""

    name: str
    description: str
    equation: str
    parameters: tuple[ParamDoc, ...]
    factory: Callable[["Params"], Component]


_REGISTRY: dict[str, ModelInfo] = {}


class Params:
    """Reader for the parameters of one component table; records which keys were used.

    Every getter raises :class:`InputError` with key ``components.<name>.<param>``.
    """

    def __init__(self, name: str, params: dict[str, Any], *, source: str, base_dir: str | Path | None):
        self.name = name
        self.source = source
        self.base_dir = Path(base_dir) if base_dir is not None else None
        self.model = str(params.get("model", ""))
        self._params = dict(params)
        self._used: set[str] = set(COMMON_KEYS)

    def key(self, key: str) -> str:
        """Full key ``components.<name>.<key>`` for error messages."""
        return f"components.{self.name}.{key}"

    def error(self, key: str, expected: str, found: Any) -> InputError:
        return InputError(self.source, self.key(key), expected, found)

    def has(self, key: str) -> bool:
        return key in self._params

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        """The unparsed value of ``key``; ``default`` (returned as is) when absent, error when required."""
        self._used.add(key)
        if key in self._params:
            return self._params[key]
        if default is _MISSING:
            raise self.error(key, f"a value (required by model '{self.model}')", "nothing (parameter missing)")
        return default

    def quantity(self, key: str, unit: str, default: Any = _MISSING, *, positive: bool = False,
                 min_value: float | None = None, shape: tuple[int | None, ...] | None = None,
                 rigid_ok: bool = False) -> Any:
        """A quantity in SI ``unit`` (``default`` is returned unparsed when the key is absent).

        ``rigid_ok`` also accepts ``"rigid"`` or ``inf`` and returns ``np.inf``.
        """
        if not self.has(key):
            return self.raw(key, default)
        value = self.raw(key)
        if rigid_ok and (value == "rigid" or (isinstance(value, float) and np.isposinf(value))):
            return np.inf
        return parse_quantity(value, unit, source=self.source, key=self.key(key), shape=shape,
                              positive=positive, min_value=min_value)

    def quantity_in(self, key: str, si_unit: str, number_unit: str, default: Any = _MISSING,
                    shape: tuple[int | None, ...] | None = None) -> Any:
        """Like :meth:`quantity`, but bare numbers are read in ``number_unit`` instead of SI."""
        if not self.has(key):
            return self.raw(key, default)
        value = self.raw(key)

        def one(v: Any, k: str) -> float:
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                return float(si(float(v), number_unit))
            return float(parse_quantity(v, si_unit, source=self.source, key=self.key(k)))

        if isinstance(value, dict):
            out = parse_quantity(value, si_unit, source=self.source, key=self.key(key), shape=shape)
        elif isinstance(value, (list, tuple)):
            out = np.array([[one(v, f"{key}[{i}][{j}]") for j, v in enumerate(row)] if isinstance(row, (list, tuple))
                            else one(row, f"{key}[{i}]") for i, row in enumerate(value)], dtype=float)
        else:
            out = one(value, key)
        arr = np.asarray(out)
        if shape is not None and (arr.ndim != len(shape) or any(s is not None and s != a
                                                                for s, a in zip(shape, arr.shape))):
            raise self.error(key, f"an array of shape {shape}", f"shape {arr.shape}")
        return out

    def choice(self, key: str, choices: Iterable[str], default: Any = _MISSING) -> str:
        value = self.raw(key, default)
        choices = tuple(choices)
        if value not in choices:
            raise self.error(key, f"one of {', '.join(repr(c) for c in choices)}", value)
        return value

    def string(self, key: str, default: Any = _MISSING) -> Any:
        value = self.raw(key, default)
        if value is not None and not isinstance(value, str):
            raise self.error(key, "a string", value)
        return value

    def integer(self, key: str, default: Any = _MISSING, *, min_value: int | None = None) -> int:
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or int(value) != value:
            raise self.error(key, "an integer", value)
        if min_value is not None and value < min_value:
            raise self.error(key, f"an integer >= {min_value}", value)
        return int(value)

    def string_table(self, key: str) -> dict[str, str]:
        value = self.raw(key, {})
        if not isinstance(value, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in value.items()):
            raise self.error(key, "a table of strings (parameter = one-line reason)", value)
        return dict(value)

    def exactly_one(self, *groups: tuple[str, ...]) -> int:
        """Index of the single parameter group that is present (e.g. ``("k",), ("E", "area")``)."""
        present = [i for i, g in enumerate(groups) if any(self.has(k) for k in g)]
        if len(present) != 1:
            alts = " or ".join("+".join(g) for g in groups)
            found = "none" if not present else " and ".join("+".join(groups[i]) for i in present)
            raise self.error(groups[0][0] if not present else groups[present[-1]][0], f"exactly one of {alts}", found)
        return present[0]

    def unused(self) -> list[str]:
        return [k for k in self._params if k not in self._used]


# --------------------------------------------------------------------------------------------- public API
def register_model(name: str, factory: Callable[[Params], Component], description: str, *, equation: str = "",
                   parameters: Iterable[ParamDoc | tuple[str, str, str, str]] = (), replace: bool = False) -> None:
    """Register a component model under ``name`` (the ``model`` value in machine files).

    ``factory(p: Params) -> Component`` reads its parameters with ``p.quantity(...)`` etc.; every parameter
    it does not read is reported as unknown. ``parameters`` documents (key, SI unit, default, meaning).
    """
    if not name or not name.replace("_", "").isalnum():
        raise ValueError(f"register_model: model names use letters, digits and '_', found {name!r}")
    if name in _REGISTRY and not replace:
        raise ValueError(f"register_model: model '{name}' is already registered (pass replace=True to override)")
    docs = tuple(p if isinstance(p, ParamDoc) else ParamDoc(*p) for p in parameters)
    _REGISTRY[name] = ModelInfo(name, description, equation, docs, factory)


def available_models() -> dict[str, str]:
    """Registered model names with their one-line descriptions (sorted by name)."""
    return {name: _REGISTRY[name].description for name in sorted(_REGISTRY)}


def model_info(name: str) -> ModelInfo:
    """Full registration record of a model (equation, parameter docs)."""
    if name not in _REGISTRY:
        raise KeyError(f"unknown component model {name!r}; available: {', '.join(sorted(_REGISTRY))}")
    return _REGISTRY[name]


def build_component(name: str, params: dict[str, Any], *, source: str = "",
                    base_dir: str | Path | None = None) -> Component:
    """Build the component ``name`` from its parameter table; ``params["model"]`` selects the model.

    ``base_dir`` resolves relative file names (joint tables) — normally the machine file's directory.
    Common optional keys for every model: ``assumptions`` (table parameter -> one-line reason, merged into
    the component's assumptions) and ``provenance`` (string).
    """
    if not isinstance(params, dict):
        raise InputError(source, f"components.{name}", "a table of parameters", params)
    model = params.get("model")
    if model is None:
        raise InputError(source, f"components.{name}.model", f"one of {', '.join(sorted(_REGISTRY))}", "missing")
    if model not in _REGISTRY:
        raise InputError(source, f"components.{name}.model", f"one of {', '.join(sorted(_REGISTRY))}", model)
    p = Params(name, params, source=source, base_dir=base_dir)
    assumptions = p.string_table("assumptions")
    provenance = p.string("provenance", "")
    try:
        component = _REGISTRY[model].factory(p)
    except InputError:
        raise
    except (ValueError, TypeError) as exc:
        raise InputError(source, f"components.{name}", f"valid parameters for model '{model}'", str(exc)) from exc
    extra = p.unused()
    if extra:
        known = ", ".join(d.key for d in _REGISTRY[model].parameters) or "see available_models()"
        raise p.error(extra[0], f"a parameter of model '{model}' ({known})", f"unknown parameter '{extra[0]}'")
    if not isinstance(component, Component):
        raise TypeError(f"factory of model '{model}' returned {type(component).__name__}, not a Component")
    updates: dict[str, Any] = {"assumptions": {**component.assumptions, **assumptions}}
    if provenance:
        updates["provenance"] = provenance
    for key, value in updates.items():
        object.__setattr__(component, key, value)
    return component


def build_components(table: dict[str, dict[str, Any]], *, source: str = "",
                     base_dir: str | Path | None = None) -> dict[str, Component]:
    """Build all components of a ``[components]`` table: name -> component."""
    return {name: build_component(name, params, source=source, base_dir=base_dir) for name, params in table.items()}


# --------------------------------------------------------------------------------------------- shared readers
_LIMIT_PARAMS = {
    "max_force": ("N", "maximum drive force"),
    "force_reserve": ("N", "force reserve (static friction + safety)"),
    "max_speed": ("m/s", "maximum drive speed"),
    "coulomb_friction": ("N", "Coulomb friction coefficient C (eq. 4.89)"),
    "viscous_friction": ("N*s/m", "viscous friction coefficient V (eq. 4.89)"),
}
_JOINT_LIMITS = ("tilt_min", "tilt_max", "swivel_min", "swivel_max")


def _drive_limits(p: Params, keys: Iterable[str] = tuple(_LIMIT_PARAMS)) -> dict[str, float]:
    out = {}
    for key in keys:
        value = p.quantity(key, _LIMIT_PARAMS[key][0], None, min_value=0.0)
        if value is not None:
            out[key] = value
    return out


def _joint_common(p: Params) -> dict[str, Any]:
    limits = {}
    for key in _JOINT_LIMITS:
        value = p.quantity(key, "rad", None)
        if value is not None:
            limits[key] = value
    for lo, hi in (("tilt_min", "tilt_max"), ("swivel_min", "swivel_max")):
        if lo in limits and hi in limits and limits[lo] > limits[hi]:
            raise p.error(hi, f"a value >= {lo} ({np.rad2deg(limits[lo]):g} deg)", f"{np.rad2deg(limits[hi]):g} deg")
    conv = p.raw("angle_convention", None)
    if conv is not None and conv not in ("axis", "normal"):
        raise p.error("angle_convention", "'axis' or 'normal'", conv)
    return {"name": p.name, "limits": limits, "angle_convention": conv,
            "mass": p.quantity("mass", "kg", 0.0, min_value=0.0)}


def _undefined_swivel(p: Params) -> str | float:
    value = p.raw("undefined_swivel", "nan")
    if value == "nan":
        return "nan"
    return p.quantity("undefined_swivel", "rad")


_JOINT_DOCS = (
    ParamDoc("angle_convention", "-", "none (any)", "'axis' or 'normal' tilt convention the data refer to"),
    ParamDoc("tilt_min, tilt_max, swivel_min, swivel_max", "rad", "none", "angle limits (Cobet eq. B.5)"),
    ParamDoc("mass", "kg", "0", "joint mass"),
)
_DRIVE_LIMIT_DOCS = tuple(ParamDoc(k, u, "none", m) for k, (u, m) in _LIMIT_PARAMS.items())


# --------------------------------------------------------------------------------------------- factories
def _constant_axial(p: Params) -> Component:
    return ConstantAxial(name=p.name, k=p.quantity("k", "N/m", positive=True, rigid_ok=True),
                         mass=p.quantity("mass", "kg", 0.0, min_value=0.0), limits=_drive_limits(p))


def _spindle_ea(p: Params) -> float:
    if p.exactly_one(("spindle_EA",), ("d_Sp", "E")) == 0:
        return p.quantity("spindle_EA", "N", positive=True)
    return bs.spindle_axial_rigidity(p.quantity("d_Sp", "m", positive=True), p.quantity("E", "Pa", positive=True))


def _ballscrew_dynamics(p: Params) -> tuple[float, dict[str, float], dict[str, str]]:
    """(mass, limits, notes) from the optional dynamic parameters of a ball-screw drive."""
    notes: dict[str, str] = {}
    moved = p.quantity("mass", "kg", 0.0, min_value=0.0)
    lead = p.quantity("lead", "m", None, positive=True)
    inertia = p.quantity("spindle_inertia", "kg*m^2", None, positive=True)
    per_length = p.quantity("spindle_inertia_per_length", "kg*m", None, positive=True)
    total_length = p.quantity("spindle_total_length", "m", None, positive=True)
    if per_length is not None:
        if inertia is not None or total_length is None:
            raise p.error("spindle_inertia_per_length", "together with spindle_total_length and without "
                          "spindle_inertia", "an incomplete or conflicting spindle inertia")
        inertia = per_length * total_length
    apparent = 0.0
    if inertia is not None:
        if lead is None:
            raise p.error("lead", "the spindle lead (needed with a spindle inertia, eq. 3.4)", "missing")
        apparent = bs.apparent_mass_from_inertia(inertia, lead)
        notes["mass"] = f"moved mass {moved:g} kg + apparent spindle mass {apparent:.4g} kg (Cobet eq. 3.4)"
    limits = _drive_limits(p)
    torque = p.quantity("motor_torque", "N*m", None, positive=True)
    if torque is not None:
        if "max_force" in limits:
            raise p.error("motor_torque", "either max_force or motor_torque (+ efficiency, lead)", "both")
        if lead is None:
            raise p.error("lead", "the spindle lead (needed with motor_torque, eq. 3.24)", "missing")
        eta = p.quantity("efficiency", "dimensionless", 1.0, positive=True)
        if eta > 1:
            raise p.error("efficiency", "a value in (0, 1]", eta)
        limits["max_force"] = bs.max_axial_force(torque, eta, lead)
        notes["max_force"] = f"2 pi M_t eta / h_S = {limits['max_force']:.5g} N (Cobet eq. 3.24)"
    elif p.has("efficiency"):
        raise p.error("efficiency", "only together with motor_torque", p.raw("efficiency"))
    return moved + apparent, limits, notes


def _ballscrew(arrangement: str) -> Callable[[Params], Component]:
    def factory(p: Params) -> Component:
        mass, limits, notes = _ballscrew_dynamics(p)
        drive = bs.BallScrewDrive(
            name=p.name, arrangement=arrangement,
            k_al=p.quantity("k_aL", "N/m", positive=True),
            k_m=p.quantity("k_M", "N/m", positive=True),
            k_tm=p.quantity("k_TM", "N/m", np.inf, positive=True, rigid_ok=True),
            spindle_ea=_spindle_ea(p),
            spindle_length=p.quantity("spindle_length", "m", None, positive=True),
            nut_offset=p.quantity("nut_offset", "m", 0.0),
            l_eff_min=p.quantity("l_eff_min", "m", 0.0, min_value=0.0),
            l_eff_max=p.quantity("l_eff_max", "m", None, positive=True),
            out_of_range=p.choice("out_of_range", bs.RANGE_POLICIES, "clamp"),
            mass=mass, limits=limits)
        object.__setattr__(drive, "provenance", "; ".join(notes.values()))
        return drive
    return factory


_6X_DEFAULTS: dict[str, Any] = {
    "k_aL": "650 N/um", "k_M": "410 N/um", "k_TM": "rigid", "spindle_EA": "211 N*m/um",
    "fit_coefficients": {"value": [85.3, -248.14, 285.53], "unit": "N/um"},
    "l_eff_min": "0.12 m", "l_eff_max": "1.41 m", "length_at_l_eff_min": "1.28 m",
    "lead": "40 mm", "spindle_inertia_per_length": "12.57 kg*cm^2/m", "spindle_total_length": "1586 mm",
    "motor_torque": "33.3 N*m", "efficiency": 0.95, "max_speed": "0.5 m/s",
}


# a default is not applied when the user gives one of these alternative parameters
_6X_CONFLICTS: dict[str, tuple[str, ...]] = {
    "spindle_EA": ("d_Sp", "E"), "spindle_inertia_per_length": ("spindle_inertia",),
    "spindle_total_length": ("spindle_inertia",), "motor_torque": ("max_force",), "efficiency": ("max_force",),
}


def _telescopic(defaults: dict[str, Any]) -> Callable[[Params], Component]:
    def factory(p: Params) -> Component:
        for key, value in defaults.items():
            if not any(p.has(k) for k in _6X_CONFLICTS.get(key, ())):
                p._params.setdefault(key, value)
        drive_model = p.choice("drive_model", bs.DRIVE_MODELS, "fit_3_22")
        fit = p.quantity("fit_coefficients", "N/m", None, shape=(None,))
        if drive_model == "fit_3_22" and fit is None:
            raise p.error("fit_coefficients", "the polynomial coefficients of eq. 3.22 (l_eff in m, highest power "
                          "first) for drive_model = 'fit_3_22'", "missing")
        mass, limits, notes = _ballscrew_dynamics(p)
        drive = bs.TelescopicBallScrew(
            name=p.name, drive_model=drive_model, fit_coefficients=() if fit is None else tuple(fit),
            k_al=p.quantity("k_aL", "N/m", positive=True),
            k_m=p.quantity("k_M", "N/m", positive=True),
            k_tm=p.quantity("k_TM", "N/m", np.inf, positive=True, rigid_ok=True),
            spindle_ea=_spindle_ea(p),
            l_eff_min=p.quantity("l_eff_min", "m", positive=True),
            l_eff_max=p.quantity("l_eff_max", "m", positive=True),
            length_at_l_eff_min=p.quantity("length_at_l_eff_min", "m", positive=True),
            out_of_range=p.choice("out_of_range", bs.RANGE_POLICIES, "clamp"),
            mass=mass, limits=limits)
        prov = "6X Hexapod telescopic strut, docs/user-guide/machines.md / docs/theory/components.md" if defaults else ""
        object.__setattr__(drive, "provenance", "; ".join(v for v in (prov, *notes.values()) if v))
        return drive
    return factory


def _linear_direct_drive(p: Params) -> Component:
    mode = p.choice("axial_stiffness", AXIAL_MODES, "constant")
    k = p.quantity("k_axial", "N/m", None, positive=True)
    omega = p.quantity("pole_distance", "rad/s", None, positive=True)
    if mode == "constant" and omega is not None:
        raise p.error("pole_distance", "no pole_distance with axial_stiffness = 'constant'", omega)
    if mode == "pole_placement" and k is not None:
        raise p.error("k_axial", "no k_axial with axial_stiffness = 'pole_placement' (k = m_eff Omega^2)", k)
    if mode == "constant" and k is None:
        raise p.error("k_axial", "the axial stiffness (axial_stiffness = 'constant')", "missing")
    if mode == "pole_placement" and omega is None:
        raise p.error("pole_distance", "the pole distance Omega in rad/s (axial_stiffness = 'pole_placement')",
                      "missing")
    return LinearDirectDrive(name=p.name, axial_stiffness=mode, k_axial=k, pole_distance=omega,
                             mass=p.quantity("mass", "kg", 0.0, min_value=0.0), limits=_drive_limits(p))


def _guide_carriages(p: Params) -> Component:
    return GuideCarriages(name=p.name, k_horizontal=p.quantity("k_horizontal", "N/m", positive=True),
                          k_vertical=p.quantity("k_vertical", "N/m", positive=True),
                          count=p.integer("count", 1, min_value=1), mass=p.quantity("mass", "kg", 0.0, min_value=0.0))


def _strut(p: Params) -> Component:
    which = p.exactly_one(("k",), ("EA",), ("E", "area"))
    length = p.quantity("length", "m", None, positive=True)
    area = None
    if which == 0:
        k, ea = p.quantity("k", "N/m", positive=True), None
    elif which == 1:
        k, ea = None, p.quantity("EA", "N", positive=True)
    else:
        area = p.quantity("area", "m^2", positive=True)
        k, ea = None, p.quantity("E", "Pa", positive=True) * area
    mass_kind = [key for key in ("mass", "density", "mass_per_length") if p.has(key)]
    if len(mass_kind) > 1:
        raise p.error(mass_kind[1], "only one of mass, density, mass_per_length", mass_kind)
    mass = 0.0
    if mass_kind == ["mass"]:
        mass = p.quantity("mass", "kg", min_value=0.0)
    elif mass_kind == ["density"]:
        rho = p.quantity("density", "kg/m^3", positive=True)
        if area is None or length is None:
            raise p.error("density", "density only together with area and length (mass = rho A l)", rho)
        mass = rho * area * length
    elif mass_kind == ["mass_per_length"]:
        mu = p.quantity("mass_per_length", "kg/m", positive=True)
        if length is None:
            raise p.error("mass_per_length", "mass_per_length only together with length (mass = mu l)", mu)
        mass = mu * length
    return Strut(name=p.name, k=k, axial_rigidity=ea, length=length, mass=mass)


def _strut_sections(p: Params) -> Component:
    E = p.quantity("E", "Pa", shape=(None,), positive=True)
    area = p.quantity("area", "m^2", shape=(None,), positive=True)
    length = p.quantity("length", "m", shape=(None,), positive=True)
    if not (E.shape == area.shape == length.shape):
        raise p.error("area", f"as many entries as E ({E.size})", f"E {E.size}, area {area.size}, length {length.size}")
    if p.has("density") and p.has("mass"):
        raise p.error("density", "either mass or density", "both")
    mass = p.quantity("mass", "kg", 0.0, min_value=0.0)
    if p.has("density"):
        per_section = isinstance(p.raw("density"), (list, tuple, dict))
        rho = p.quantity("density", "kg/m^3", positive=True, shape=(E.size,) if per_section else None)
        mass = float(np.sum(np.broadcast_to(rho, E.shape) * area * length))
    return StrutSections(name=p.name, E=tuple(E), area=tuple(area), length=tuple(length), mass=mass)


def _joint_constant(p: Params) -> Component:
    return ConstantJoint(k=p.quantity("k", "N/m", positive=True, rigid_ok=True), **_joint_common(p))


def _joint_analytic(p: Params) -> Component:
    keys = ("k_AaL", "k_BrL", "k_CrL", "k_CaL")
    return AnalyticJoint330(**{k: p.quantity(k, "N/m", positive=True) for k in keys}, **_joint_common(p))


def _load_table(p: Params, swivel: bool) -> Component:
    common = _joint_common(p)
    policy = p.choice("extrapolation", EXTRAPOLATION_POLICIES, "clamp")
    extra = {"undefined_swivel": _undefined_swivel(p)} if swivel else {}
    if p.exactly_one(("table",), ("tilt", "stiffness")) == 0:
        ref = p.string("table")
        try:
            table = load_joint_table(ref, base_dir=p.base_dir)
        except JointTableNotFound as exc:
            raise p.error("table", exc.expected, f"{ref!r} ({exc.found})") from exc
        except InputError as exc:  # content error: keep file/line/column, add who referenced the table
            where = f"{exc.source} (table of {p.key('table')} in {p.source or 'input'})"
            raise InputError(where, exc.key, exc.expected, exc.found) from exc
        if (table.swivel is not None) != swivel:
            want = "a swivel-tilt table (swivel_deg,tilt_deg,k_N_per_um)" if swivel else "a tilt table (tilt_deg,k_N_per_um)"
            raise p.error("table", want, f"{table.path} has the other format")
        if common["angle_convention"] is None:
            common["angle_convention"] = table.angle_convention
        elif common["angle_convention"] != table.angle_convention:
            raise p.error("angle_convention", f"the table's convention '{table.angle_convention}' ({table.path})",
                          common["angle_convention"])
        return joint_from_table(table, extrapolation=policy, **common, **extra)
    tilt = p.quantity("tilt", "rad", shape=(None,))
    if swivel:
        sw = p.quantity("swivel", "rad", shape=(None,))
        k = p.quantity("stiffness", "N/m", shape=(sw.size, tilt.size), positive=True)
        return SwivelTiltTableJoint(swivel_nodes=sw, tilt_nodes=tilt, k_grid=k, extrapolation=policy,
                                    table_name="inline", **common, **extra)
    k = p.quantity("stiffness", "N/m", shape=(tilt.size,), positive=True)
    return TiltTableJoint(tilt_nodes=tilt, k_nodes=k, extrapolation=policy, table_name="inline", **common)


def _joint_product(p: Params) -> Component:
    common = _joint_common(p)
    sw = p.quantity("swivel", "rad", shape=(None,))
    ti = p.quantity("tilt", "rad", shape=(None,))
    return ProductJoint(k_ref=p.quantity("k_ref", "N/m", positive=True), swivel_nodes=sw,
                        g_swivel=p.quantity("g_swivel", "dimensionless", shape=(sw.size,), positive=True),
                        tilt_nodes=ti, g_tilt=p.quantity("g_tilt", "dimensionless", shape=(ti.size,), positive=True),
                        extrapolation=p.choice("extrapolation", EXTRAPOLATION_POLICIES, "clamp"),
                        undefined_swivel=_undefined_swivel(p), **common)


def _tapered_roller_bearing(p: Params) -> Component:
    n = p.integer("n_rollers", min_value=3)
    notes = {}
    if not p.has("pitch_radius"):
        notes["pitch_radius"] = "not given by the source (docs/theory/components.md); 0 m: tilt row/column is zero"
    angles = p.quantity("roller_angles", "rad", None, shape=(n,))
    return TaperedRollerBearing(name=p.name, n_rollers=n, k_roller=p.quantity("k_roller", "N/m", positive=True),
                                contact_angle=p.quantity("contact_angle", "rad", positive=True),
                                pitch_radius=p.quantity("pitch_radius", "m", 0.0, min_value=0.0),
                                roller_angles=None if angles is None else tuple(angles),
                                mass=p.quantity("mass", "kg", 0.0, min_value=0.0), assumptions=notes)


def _rigid_body(p: Params) -> Component:
    inertia_raw = p.raw("inertia", None)
    inertia = None
    if inertia_raw is not None:
        is_matrix = isinstance(inertia_raw, (list, tuple)) and inertia_raw and isinstance(inertia_raw[0], (list, tuple))
        if isinstance(inertia_raw, dict):
            is_matrix = np.ndim(inertia_raw.get("value")) == 2
        inertia = p.quantity("inertia", "kg*m^2", shape=(3, 3) if is_matrix else (3,), min_value=None)
    return RigidBody(name=p.name, mass=p.quantity("mass", "kg", min_value=0.0), inertia=inertia,
                     cog=p.quantity("cog", "m", None, shape=(3,)))


def _body_stiffness(p: Params) -> Component:
    t_unit = p.string("translational_unit", "N/um")
    r_unit = p.string("rotational_unit", "N*m/urad")
    c_unit = p.string("coupling_unit", "N/urad")
    for key, unit, dim in (("translational_unit", t_unit, "N/m"), ("rotational_unit", r_unit, "N*m/rad"),
                           ("coupling_unit", c_unit, "N/rad")):
        try:
            parse_quantity(f"1 {unit}", dim, source=p.source, key=p.key(key))
        except InputError as exc:
            raise p.error(key, f"a unit of {dim}", unit) from exc
    notes = {}
    if not p.has("rotational_unit"):
        notes["rotational_unit"] = ("bare rotational entries read as N*m/urad (interpretation of the unprinted "
                                    "Hexaglide K_P units, docs/user-guide/machines.md note 3)")
    if p.exactly_one(("diagonal",), ("matrix",)) == 0:
        trans = p.quantity_in("diagonal", "N/m", t_unit, shape=(6,))
        rot = p.quantity_in("diagonal", "N*m/rad", r_unit, shape=(6,))
        K = np.diag(np.concatenate([trans[:3], rot[3:]]))
    else:
        K = np.empty((6, 6))
        blocks = p.quantity_in("matrix", "N/m", t_unit, shape=(6, 6))
        K[:3, :3] = blocks[:3, :3]
        K[3:, 3:] = p.quantity_in("matrix", "N*m/rad", r_unit, shape=(6, 6))[3:, 3:]
        coupling = p.quantity_in("matrix", "N/rad", c_unit, shape=(6, 6))
        K[:3, 3:], K[3:, :3] = coupling[:3, 3:], coupling[3:, :3]
    return BodyStiffness(name=p.name, matrix=K, assumptions=notes)


# --------------------------------------------------------------------------------------------- registrations
_BALLSCREW_DOCS = (
    ParamDoc("k_aL", "N/m", "required", "axial stiffness of the bearings (fixed bearing = 2 k_aL)"),
    ParamDoc("k_M", "N/m", "required", "nut stiffness"),
    ParamDoc("k_TM", "N/m", "rigid", "nut connection stiffness ('rigid' allowed)"),
    ParamDoc("spindle_EA | d_Sp + E", "N | m + Pa", "required", "spindle E*A (= k_Sp l_eff), or diameter and modulus"),
    ParamDoc("spindle_length", "m", "required except fixed_floating", "l_Sp between the bearing force points"),
    ParamDoc("nut_offset", "m", "0", "nut distance from the motor-side bearing at drive position 0"),
    ParamDoc("l_eff_min, l_eff_max", "m", "0, spindle_length", "admissible l_eff (fixed_fixed: l_Sp1)"),
    ParamDoc("out_of_range", "-", "'clamp'", "'clamp' | 'error' for l_eff outside the range"),
    ParamDoc("mass", "kg", "0", "moved mass (the apparent spindle mass is added)"),
    ParamDoc("lead", "m", "none", "spindle lead h_S"),
    ParamDoc("spindle_inertia | spindle_inertia_per_length + spindle_total_length", "kg*m^2 | kg*m + m", "none",
             "spindle inertia J for the apparent mass (eq. 3.4)"),
    ParamDoc("motor_torque, efficiency", "N*m, -", "none, 1", "max_force = 2 pi M_t eta / h_S (eq. 3.24)"),
) + _DRIVE_LIMIT_DOCS

register_model("constant_axial", _constant_axial, "constant axial stiffness (drive, strut or any axial element)",
               equation="k = const", parameters=(ParamDoc("k", "N/m", "required", "axial stiffness ('rigid' allowed)"),
                                                 ParamDoc("mass", "kg", "0", "moved mass")) + _DRIVE_LIMIT_DOCS)
for _arr, _eq in (("fixed_fixed", "Cobet eq. 3.1, 3.2"), ("fixed_floating", "Cobet eq. 3.1, 3.3"),
                  ("floating_fixed", "Cobet eq. 3.1, 3.3")):
    register_model(f"ballscrew_{_arr}", _ballscrew(_arr),
                   f"ball-screw drive, {_arr.replace('_', '-')} bearing arrangement, nut-position dependent",
                   equation=_eq, parameters=_BALLSCREW_DOCS)
_TELESCOPIC_DOCS = (
    ParamDoc("drive_model", "-", "'fit_3_22'", "'fit_3_22' (polynomial) | 'exact_3_3'"),
    ParamDoc("fit_coefficients", "N/m (l_eff in m)", "required for fit_3_22", "polynomial, highest power first"),
    ParamDoc("k_aL, k_M, k_TM, spindle_EA | d_Sp + E", "N/m, N", "required (k_TM rigid)", "eq. 3.3 data"),
    ParamDoc("l_eff_min, l_eff_max", "m", "required", "range of the effective spindle length"),
    ParamDoc("length_at_l_eff_min", "m", "required", "strut length at l_eff_min (l_eff = l_eff_min + l - this)"),
    ParamDoc("out_of_range", "-", "'clamp'", "'clamp' | 'error'"),
    ParamDoc("mass, lead, spindle_inertia..., motor_torque, efficiency", "as ballscrew_*", "none",
             "apparent mass (eq. 3.4) and max force (eq. 3.24)"),
) + _DRIVE_LIMIT_DOCS
register_model("telescopic_ballscrew", _telescopic({}),
               "telescopic pod strut drive (fixed-floating ball screw) driven by the strut length",
               equation="Cobet eq. 3.3 / 3.22", parameters=_TELESCOPIC_DOCS)
register_model("telescopic_ballscrew_6x", _telescopic(_6X_DEFAULTS),
               "6X Hexapod telescopic strut drive; defaults = docs/user-guide/machines.md data (each overridable)",
               equation="Cobet eq. 3.3 / 3.22, 3.4, 3.24",
               parameters=tuple(ParamDoc(d.key, d.unit, "6X data", d.meaning) for d in _TELESCOPIC_DOCS))
register_model("linear_direct_drive", _linear_direct_drive,
               "linear direct drive: constant or pole-placement axial stiffness, force/speed/friction limits",
               equation="Cobet eq. 3.5, 3.9-3.13",
               parameters=(ParamDoc("axial_stiffness", "-", "'constant'", "'constant' | 'pole_placement'"),
                           ParamDoc("k_axial", "N/m", "required if constant", "axial stiffness"),
                           ParamDoc("pole_distance", "rad/s", "required if pole_placement", "Omega (k = m_eff Omega^2)"),
                           ParamDoc("mass", "kg", "0", "drive mass m_A")) + _DRIVE_LIMIT_DOCS)
register_model("guide_carriages", _guide_carriages, "guide carriages in parallel: transverse drive stiffness",
               equation="Cobet eq. 3.6, 3.14",
               parameters=(ParamDoc("k_horizontal", "N/m", "required", "per carriage, horizontal (y')"),
                           ParamDoc("k_vertical", "N/m", "required", "per carriage, vertical (z')"),
                           ParamDoc("count", "-", "1", "number of carriages per drive"),
                           ParamDoc("mass", "kg", "0", "carriage mass")))
register_model("strut", _strut, "strut of constant cross-section (k given or EA/l)", equation="Cobet eq. 3.7",
               parameters=(ParamDoc("k | EA | E + area", "N/m | N | Pa + m^2", "one required", "stiffness data"),
                           ParamDoc("length", "m", "state.strut_length", "strut length"),
                           ParamDoc("mass | density | mass_per_length", "kg | kg/m^3 | kg/m", "0", "strut mass")))
register_model("strut_sections", _strut_sections, "strut of sections in series", equation="Cobet eq. 3.8",
               parameters=(ParamDoc("E", "Pa", "required", "modulus per section"),
                           ParamDoc("area", "m^2", "required", "cross-section per section"),
                           ParamDoc("length", "m", "required", "length per section"),
                           ParamDoc("mass | density", "kg | kg/m^3", "0", "mass or density (scalar or per section)")))
register_model("joint_constant", _joint_constant, "angle-independent joint stiffness", equation="k = const",
               parameters=(ParamDoc("k", "N/m", "required", "joint stiffness ('rigid' allowed)"),) + _JOINT_DOCS)
register_model("joint_analytic_3_30", _joint_analytic, "analytic substitute Cardan-joint model over tilt",
               equation="Cobet eq. 3.30",
               parameters=tuple(ParamDoc(k, "N/m", "required", m) for k, m in (
                   ("k_AaL", "bearing A axial"), ("k_BrL", "bearing B radial"), ("k_CrL", "bearing C radial"),
                   ("k_CaL", "bearing C axial"))) + _JOINT_DOCS)
_TABLE_DOCS = (ParamDoc("extrapolation", "-", "'clamp'", "'clamp' (end value) | 'error' outside the table"),)
register_model("joint_table", lambda p: _load_table(p, swivel=False),
               "tabulated joint stiffness over tilt, clamped end-slope cubic spline", equation="Cobet 3.2.5",
               parameters=(ParamDoc("table | tilt + stiffness", "name/path | rad + N/m", "one required",
                                    "bundled table name, CSV path (relative to the machine file) or inline data"),)
               + _TABLE_DOCS + _JOINT_DOCS)
register_model("joint_table_swivel_tilt", lambda p: _load_table(p, swivel=True),
               "tabulated joint stiffness on a (swivel, tilt) grid, bicubic end-slope spline",
               equation="docs/theory/components.md Assumption",
               parameters=(ParamDoc("table | swivel + tilt + stiffness", "name/path | rad + rad + N/m", "one required",
                                    "2-D table or inline grid (stiffness[swivel][tilt])"),
                           ParamDoc("undefined_swivel", "rad | 'nan'", "'nan'", "swivel used where it is undefined"))
               + _TABLE_DOCS + _JOINT_DOCS)
register_model("joint_product_swivel_tilt", _joint_product,
               "k_ref g_swivel(swivel) g_tilt(tilt) from two normalised 1-D curves",
               equation="docs/theory/components.md Assumption",
               parameters=(ParamDoc("k_ref", "N/m", "required", "stiffness at the maxima of both curves"),
                           ParamDoc("swivel, g_swivel", "rad, -", "required", "swivel curve (normalised to its max)"),
                           ParamDoc("tilt, g_tilt", "rad, -", "required", "tilt curve (normalised to its max)"),
                           ParamDoc("undefined_swivel", "rad | 'nan'", "'nan'", "swivel used where it is undefined"))
               + _TABLE_DOCS + _JOINT_DOCS)
register_model("tapered_roller_bearing", _tapered_roller_bearing, "tapered roller bearing, Dietl spring model",
               equation="Cobet eq. 3.31, 3.32",
               parameters=(ParamDoc("n_rollers", "-", "required", "number of rollers"),
                           ParamDoc("k_roller", "N/m", "required", "local roller stiffness"),
                           ParamDoc("contact_angle", "rad", "required", "contact angle alpha"),
                           ParamDoc("pitch_radius", "m", "0 (not given)", "pitch radius r (tilt DOF)"),
                           ParamDoc("roller_angles", "rad", "equally spaced", "roller positions phi_i"),
                           ParamDoc("mass", "kg", "0", "bearing mass")))
register_model("rigid_body", _rigid_body, "rigid body: mass, inertia about the CoG (body axes), CoG",
               equation="docs/theory/structure.md",
               parameters=(ParamDoc("mass", "kg", "required", "mass"),
                           ParamDoc("inertia", "kg*m^2", "0", "3 principal values or a 3x3 tensor about the CoG"),
                           ParamDoc("cog", "m", "(0, 0, 0)", "CoG relative to the body reference point, body axes")))
register_model("body_stiffness", _body_stiffness, "constant 6x6 body stiffness (e.g. platform K_P / K_U)",
               equation="docs/theory/components.md",
               parameters=(ParamDoc("diagonal | matrix", "see units", "one required", "6 values or 6x6 matrix"),
                           ParamDoc("translational_unit", "-", "'N/um'", "unit of bare translational entries"),
                           ParamDoc("rotational_unit", "-", "'N*m/urad'", "unit of bare rotational entries (Assumption)"),
                           ParamDoc("coupling_unit", "-", "'N/urad'", "unit of bare coupling entries")))
