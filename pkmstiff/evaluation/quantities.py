"""Registry of named quantities that can be evaluated on arrays of poses (section maps, requirements, reports).

A quantity has a name (``"kx"``, ``"f1"``, ``"tilt_drive_1"``, ``"U"``), a display unit (the field's habit:
N/µm, Hz, deg, m/min) and a function computing SI values for a chunk of admissible poses from an
:class:`EvalContext`. Families with an index (``f<n>``, ``tilt_drive_<i>``) are resolved by pattern.
Expensive intermediate results (structure model, modal analysis) are shared through ``EvalContext.cached``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from pkmstiff.admissibility.pipeline import PoseEvaluation
from pkmstiff.errors import UnknownQuantityError  # noqa: F401 (re-exported)
from pkmstiff.machine.model import Machine
from pkmstiff.units import to_unit


@dataclass
class EvalContext:
    """What a quantity function sees: the machine, a chunk of poses and their kinematic evaluation."""

    machine: Machine
    ev: PoseEvaluation
    tool_length: float | None = None  # m; None = the machine file's tool length
    options: dict[str, Any] = field(default_factory=dict)
    _cache: dict[str, Any] = field(default_factory=dict)

    @property
    def poses(self) -> np.ndarray:
        return self.ev.poses

    def cached(self, key: str, build: Callable[[], Any]) -> Any:
        if key not in self._cache:
            self._cache[key] = build()
        return self._cache[key]


@dataclass(frozen=True)
class Quantity:
    """A named per-pose quantity; ``compute`` returns SI values of shape (N,)."""

    name: str
    label: str
    unit: str  # display unit
    si_unit: str
    compute: Callable[[EvalContext], np.ndarray]
    group: str = "kinematics"

    def to_display(self, values_si: np.ndarray) -> np.ndarray:
        return np.asarray(to_unit(values_si, self.unit)) if self.unit != self.si_unit else np.asarray(values_si)


_REGISTRY: dict[str, Quantity] = {}
_FAMILIES: list[tuple[re.Pattern, Callable[[re.Match], Quantity], str]] = []


def register_quantity(q: Quantity) -> Quantity:
    """Add (or replace) a quantity under its name."""
    _REGISTRY[q.name] = q
    return q


def register_family(pattern: str, factory: Callable[[re.Match], Quantity], example: str) -> None:
    """Register a family of indexed quantities, e.g. ``r"f(\\d+)"`` -> the n-th eigenfrequency."""
    _FAMILIES.append((re.compile(pattern + r"\Z"), factory, example))




def get_quantity(name: str) -> Quantity:
    """Look a quantity up by name (exact names first, then indexed families)."""
    if name in _REGISTRY:
        return _REGISTRY[name]
    for pat, factory, _ in _FAMILIES:
        m = pat.match(name)
        if m:
            return factory(m)
    raise UnknownQuantityError(
        f"unknown quantity {name!r}; known: {', '.join(sorted(_REGISTRY))} and the families "
        f"{', '.join(ex for _, _, ex in _FAMILIES)}")


#: families indexed by a 1-based chain number (the last group of the name)
_CHAIN_FAMILIES = re.compile(r"((swivel|tilt|tilt_axis|tilt_normal)_(drive|platform)|drive|drive_load)_(\d+)\Z")


def check_quantity(name: str, n_chains: int | None = None) -> Quantity:
    """:func:`get_quantity` plus, for chain-indexed families (``tilt_drive_7``, ``drive_3``), the check that the
    chain exists on a machine with ``n_chains`` chains, so that a bad name fails before any computation."""
    q = get_quantity(name)
    m = _CHAIN_FAMILIES.match(name)
    if m and n_chains is not None and not (1 <= int(m.group(4)) <= n_chains):
        raise UnknownQuantityError(f"unknown quantity {name!r}: chain {int(m.group(4))} does not exist (the machine "
                                   f"has chains 1..{n_chains})")
    if re.fullmatch(r"f(\d+)", name) and int(name[1:]) < 1:
        raise UnknownQuantityError(f"unknown quantity {name!r}: natural frequencies are numbered from f1")
    return q


def available_quantities() -> dict[str, str]:
    """Name (or family example) -> 'label [unit]'."""
    out = {n: f"{q.label} [{q.unit}]" for n, q in sorted(_REGISTRY.items())}
    for _, factory, example in _FAMILIES:
        q = get_quantity(example)
        out[example] = f"{q.label} [{q.unit}]"
    return out


def evaluate_quantities(ctx: EvalContext, names: list[str]) -> dict[str, np.ndarray]:
    """SI values (N,) of several quantities for one chunk (sharing cached intermediates)."""
    return {n: np.asarray(get_quantity(n).compute(ctx), dtype=float) for n in names}


# ----------------------------------------------------------------------------------------------- kinematic ones


def _chain_column(arr: np.ndarray, i: int, name: str) -> np.ndarray:
    if i >= arr.shape[1]:
        raise UnknownQuantityError(f"{name}: the machine has only {arr.shape[1]} chains")
    return arr[:, i]


register_quantity(Quantity("kappa", "condition number of J^-1", "1", "1", lambda c: c.ev.kappa))


def _transmission(c: EvalContext) -> np.ndarray:
    from pkmstiff.kinematics import transmission_quality

    return transmission_quality(c.machine, c.ev.jinv)


register_quantity(Quantity("U", "transmission quality (eq. 4.75)", "1", "1", _transmission))


def _angle_family(m: re.Match) -> Quantity:
    qty, side = m.group(1), m.group(2)
    i = int(m.group(3)) - 1
    key = f"{side}_{qty}"
    return Quantity(m.group(0), f"{qty.replace('_', ' ')} of {side} joint {i + 1}", "deg", "rad",
                    lambda c: _chain_column(c.ev.angles[key], i, m.group(0)))


register_family(r"(swivel|tilt|tilt_axis|tilt_normal)_(drive|platform)_(\d+)", _angle_family, "tilt_drive_1")


def _drive_family(m: re.Match) -> Quantity:
    i = int(m.group(1)) - 1
    return Quantity(m.group(0), f"drive coordinate {i + 1}", "mm", "m",
                    lambda c: _chain_column(c.ev.drive, i, m.group(0)))


register_family(r"drive_(\d+)", _drive_family, "drive_1")


def _load_family(m: re.Match) -> Quantity:
    i = int(m.group(1)) - 1

    def f(c: EvalContext) -> np.ndarray:
        if c.ev.drive_loads is None:
            return np.full(len(c.ev.poses), np.nan)
        return _chain_column(c.ev.drive_loads, i, m.group(0))

    return Quantity(m.group(0), f"static drive load {i + 1} (eq. 4.90)", "N", "N", f)


register_family(r"drive_load_(\d+)", _load_family, "drive_load_1")


def _max_abs(key: str) -> Callable[[EvalContext], np.ndarray]:
    def f(c: EvalContext) -> np.ndarray:
        arr = np.abs(c.ev.angles[key])
        with np.errstate(invalid="ignore"):
            return np.where(np.isnan(arr).all(axis=1), np.nan, np.nanmax(np.where(np.isnan(arr), -np.inf, arr), axis=1))
    return f


for _side in ("drive", "platform"):
    for _qty in ("tilt", "swivel"):
        register_quantity(Quantity(f"{_qty}_{_side}_max", f"largest {_qty} angle of the {_side}-side joints", "deg",
                                   "rad", _max_abs(f"{_side}_{_qty}")))


def _drive_load_max(c: EvalContext) -> np.ndarray:
    if c.ev.drive_loads is None:
        return np.full(len(c.ev.poses), np.nan)
    return np.abs(c.ev.drive_loads).max(axis=1)


register_quantity(Quantity("drive_load_max", "largest static drive load |tau_g| (eq. 4.90)", "N", "N", _drive_load_max))


for _k, _axis in enumerate("xyz"):
    register_quantity(Quantity(_axis, f"position {_axis} of O' (machine frame)", "mm", "m",
                               (lambda k: lambda c: c.poses[:, k])(_k), group="pose"))


# ------------------------------------------------------------------------------------ structure-model quantities
# They share one structure model per chunk (structure_model, built from the chunk's pose evaluation) and one
# structure evaluation (TCP compliance + lowest modes, pkmstiff.analysis), cached in the context; the tool length of
# the context applies (None: the machine file's). Leaving K_U out is a property of the machine
# (pkmstiff.machine.frames.neglect_spindle), so every quantity honours it.


def structure_model(c: EvalContext):
    """The chunk's one structure model (:func:`pkmstiff.structure.build_structure` on the chunk's pose evaluation,
    which it reuses): stiffness, frequencies, shares and the deflection under gravity all take it."""
    from pkmstiff.structure import build_structure

    return c.cached("structure_model", lambda: build_structure(c.machine, c.ev))


def _structure(c: EvalContext, n_modes: int = 6):
    from pkmstiff.analysis import evaluate_structure

    n_modes = max(n_modes, int(c.options.get("n_modes", 6)))
    key = f"structure:{n_modes}"
    if key not in c._cache:
        # a batch with more modes serves requests for fewer
        have = [k for k in c._cache if k.startswith("structure:") and int(k.split(":")[1]) >= n_modes]
        c._cache[key] = c._cache[have[0]] if have else evaluate_structure(
            c.machine, structure_model(c), tool_length=c.tool_length, n_modes=n_modes)
    return c._cache[key]


_STIFFNESS = {"kx": (0, "x"), "ky": (1, "y"), "kz": (2, "z")}
for _name, (_i, _ax) in _STIFFNESS.items():
    register_quantity(Quantity(_name, f"TCP stiffness in {_ax} (force / displacement in {_ax})", "N/um", "N/m",
                               (lambda i: lambda c: _structure(c).stiffness[:, i])(_i), "stiffness"))
for _i, _ax in enumerate("xyz"):
    register_quantity(Quantity(f"kr{_ax}", f"rotational TCP stiffness about {_ax}", "N*m/urad", "N*m/rad",
                               (lambda i: lambda c: _structure(c).stiffness[:, 3 + i])(_i), "stiffness"))


def _kmin(c: EvalContext) -> np.ndarray:
    comp = _structure(c).compliance[:, :3, :3]
    out = np.full(len(comp), np.nan)
    good = np.isfinite(comp).all(axis=(1, 2))
    if good.any():
        out[good] = 1.0 / np.linalg.eigvalsh(comp[good])[:, -1]  # weakest direction: largest compliance
    return out


register_quantity(Quantity("kmin", "minimum translational TCP stiffness (weakest direction)", "N/um", "N/m", _kmin,
                           "stiffness"))


def _freq_family(m: re.Match) -> Quantity:
    n = int(m.group(1))
    if n < 1:
        raise UnknownQuantityError(f"eigenfrequencies are numbered from 1, found {m.group(0)!r}")
    return Quantity(m.group(0), f"eigenfrequency {n}", "Hz", "Hz",
                    lambda c: _structure(c, n).frequencies_hz[:, n - 1], "modal")


register_family(r"f(\d+)", _freq_family, "f1")


def _kinetostatics(c: EvalContext):
    from pkmstiff.analysis.kinetostatics import kinetostatics

    return c.cached("kinetostatics", lambda: kinetostatics(c.machine, c.ev))


def _vmax_family(m: re.Match) -> Quantity:
    ax = m.group(1)
    return Quantity(m.group(0), f"maximum TCP velocity along {ax} (eq. 4.79)", "m/min", "m/s",
                    lambda c: _kinetostatics(c).v_max[:, "xyz".index(ax)], "kinetostatics")


register_family(r"vmax_([xyz])", _vmax_family, "vmax_y")


def _amax_family(m: re.Match) -> Quantity:
    label = m.group(1)  # "+x", "-z", ...
    key = label.lstrip("+")

    def f(c: EvalContext) -> np.ndarray:
        k = _kinetostatics(c)
        return k.a_max[:, k.acceleration_labels.index(key)]

    return Quantity(m.group(0), f"maximum TCP acceleration towards {label} (eq. 4.87-4.93)", "m/s^2", "m/s^2", f,
                    "kinetostatics")


register_family(r"amax_([+-][xyz])", _amax_family, "amax_+z")


def _share_family(m: re.Match) -> Quantity:
    comp, direction = m.group(1), m.group(2)

    def f(c: EvalContext) -> np.ndarray:
        from pkmstiff.analysis.static import weak_points

        wp = c.cached(f"weak:{direction}", lambda: weak_points(structure_model(c), direction,
                                                               tool_length=c.tool_length))
        if comp not in wp.component_labels:
            return np.zeros(len(c.poses))  # component absent (rigid): no share
        return wp.component_shares[:, wp.component_labels.index(comp)]

    return Quantity(m.group(0), f"share of the {comp.replace('_', ' ')} in the TCP compliance along {direction}",
                    "%", "1", f, "stiffness")


register_family(r"share_(drive|guide|drive_suspension|drive_joint|strut|platform_joint|platform_spindle)_([xyz])",
                _share_family, "share_drive_joint_x")


# ------------------------------------------------------------------------------- deflection under gravity
# The TCP's static deflection under the weight of the structure model (pkmstiff.analysis.gravity: which masses are
# loaded), the error source next to the stiffness maps (issue 17 item 4); one stacked solve per chunk, cached.


def _gravity(c: EvalContext) -> np.ndarray:
    from pkmstiff.analysis.gravity import gravity_deflection

    return c.cached("gravity", lambda: gravity_deflection(c.machine, structure_model(c), tool_length=c.tool_length))


register_quantity(Quantity("deflection_gravity", "TCP deflection under gravity (magnitude of the translation)", "um",
                           "m", lambda c: np.linalg.norm(_gravity(c)[:, :3], axis=1), "deflection"))
register_quantity(Quantity("deflection_gravity_rot", "TCP rotation under gravity (magnitude)", "urad", "rad",
                           lambda c: np.linalg.norm(_gravity(c)[:, 3:], axis=1), "deflection"))


def _deflection_family(m: re.Match) -> Quantity:
    k = ("x", "y", "z", "rx", "ry", "rz").index(m.group(1))
    what = f"translation along {m.group(1)}" if k < 3 else f"rotation about {m.group(1)[1]}"
    return Quantity(m.group(0), f"TCP deflection under gravity, {what}", "um" if k < 3 else "urad",
                    "m" if k < 3 else "rad", lambda c: _gravity(c)[:, k], "deflection")


register_family(r"deflection_gravity_(x|y|z|rx|ry|rz)", _deflection_family, "deflection_gravity_z")
