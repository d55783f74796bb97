"""Telescopic strut drive of a pod machine (6X Hexapod, docs/user-guide/machines.md; Cobet eq. 3.3, 3.22) and its models."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, ClassVar

import numpy as np

from components.ballscrew.formulas import DRIVE_MODELS, _check_drive_data, _range_policy, fixed_floating_stiffness
from components.ballscrew.screw_params import RANGE_PARAM, SCREW_DATA, SCREW_DYNAMICS, _spindle_ea, screw_dynamics
from components.ballscrew.stroke_fit import StrokeFit, fit_stroke_polynomial
from components.limits import DRIVE_LIMITS
from components.params import ModelSpec, Param
from components.protocol import Component, ComponentState
from pkmstiff.errors import ArgumentError

if TYPE_CHECKING:
    from components.reader import Params


@dataclass(frozen=True, kw_only=True, eq=False)
class TelescopicBallScrew(Component):
    """Telescopic strut drive of a pod machine (fixed–floating ball screw, docs/user-guide/machines.md).

    l_eff = l_eff_min + (l − length_at_l_eff_min) from ``state.strut_length`` (or ``state.drive_position``;
    ``state.l_eff`` overrides). ``drive_model``: ``"fit_3_22"`` (default) evaluates the polynomial
    ``fit_coefficients`` [N/m, l_eff in m, highest power first]; ``"exact_3_3"`` evaluates eq. 3.3 with
    ``k_al``, ``spindle_ea``, ``k_m``, ``k_tm``.
    """

    kind: ClassVar[str] = "axial"
    k_al: float
    spindle_ea: float
    k_m: float
    k_tm: float = np.inf
    drive_model: str = "fit_3_22"
    fit_coefficients: tuple[float, ...] = ()
    l_eff_min: float
    l_eff_max: float
    length_at_l_eff_min: float
    out_of_range: str = "clamp"

    def __post_init__(self) -> None:
        if self.drive_model not in DRIVE_MODELS:
            raise ArgumentError(f"drive '{self.name}': drive_model must be one of {DRIVE_MODELS}, found "
                                     f"{self.drive_model!r}")
        _check_drive_data(self)
        if not 0 < self.l_eff_min < self.l_eff_max:
            raise ArgumentError(f"drive '{self.name}': need 0 < l_eff_min < l_eff_max, found "
                                     f"{self.l_eff_min}, {self.l_eff_max}")
        if self.drive_model == "fit_3_22":
            c = np.asarray(self.fit_coefficients, dtype=float)
            if c.ndim != 1 or c.size == 0:
                raise ArgumentError(f"drive '{self.name}': drive_model 'fit_3_22' needs fit_coefficients")
            x = np.linspace(self.l_eff_min, self.l_eff_max, 101)
            if np.any(np.polyval(c, x) <= 0):
                raise ArgumentError(f"drive '{self.name}': the fit polynomial is not positive over "
                                         f"[{self.l_eff_min}, {self.l_eff_max}] m")
        object.__setattr__(self, "fit_coefficients", tuple(float(v) for v in self.fit_coefficients))
        object.__setattr__(self, "limits", {"l_eff_min": self.l_eff_min, "l_eff_max": self.l_eff_max, **self.limits})
        defaults = {
            "l_eff_mapping": "l_eff = l_eff_min + (l - length_at_l_eff_min): strut-length-to-spindle-length mapping "
                             "assumed by the toolkit (docs/user-guide/machines.md)",
        }
        if self.out_of_range == "clamp":
            defaults["out_of_range"] = "l_eff outside [l_eff_min, l_eff_max] is clamped to the range (toolkit choice)"
        object.__setattr__(self, "assumptions", {**defaults, **self.assumptions})

    def l_eff(self, state: ComponentState) -> np.ndarray:
        """Effective spindle length [m] per pose."""
        if state.l_eff is not None:
            value = state.l_eff
        else:
            length = (state.strut_length if state.strut_length is not None
                      else state.require("drive_position", self.name))
            value = self.l_eff_min + (length - self.length_at_l_eff_min)
        return _range_policy(value, self.l_eff_min, self.l_eff_max, self.out_of_range, "l_eff", self.name)

    def exact(self, l_eff: Any) -> np.ndarray:
        """Exact eq. 3.3 stiffness [N/m] at l_eff [m]."""
        with np.errstate(divide="ignore"):
            return fixed_floating_stiffness(self.k_al, self.spindle_ea / np.asarray(l_eff, dtype=float),
                                            self.k_m, self.k_tm)

    def fit(self, l_eff: Any) -> np.ndarray:
        """Polynomial (eq. 3.22) stiffness [N/m] at l_eff [m]."""
        return np.polyval(np.asarray(self.fit_coefficients), np.asarray(l_eff, dtype=float))

    def stiffness(self, state: ComponentState) -> np.ndarray:
        l_eff = self.l_eff(state)
        return self.fit(l_eff) if self.drive_model == "fit_3_22" else self.exact(l_eff)

    def fit_stroke_polynomial(self, degree: int = 2, n_samples: int = 200) -> StrokeFit:
        """Refit eq. 3.22 from the exact eq. 3.3 over [l_eff_min, l_eff_max]."""
        return fit_stroke_polynomial(self.exact, (self.l_eff_min, self.l_eff_max), degree, n_samples=n_samples)


# --------------------------------------------------------------------------------------------- machine files
#: Data of the 6X Hexapod telescopic strut drive (docs/user-guide/machines.md, docs/theory/components.md), unparsed.
HEXAPOD_6X_DATA: dict[str, Any] = {
    "k_aL": "650 N/um", "k_M": "410 N/um", "k_TM": "rigid", "spindle_EA": "211 N*m/um",
    "fit_coefficients": {"value": [85.3, -248.14, 285.53], "unit": "N/um"},
    "l_eff_min": "0.12 m", "l_eff_max": "1.41 m", "length_at_l_eff_min": "1.28 m",
    "lead": "40 mm", "spindle_inertia_per_length": "12.57 kg*cm^2/m", "spindle_total_length": "1586 mm",
    "motor_torque": "33.3 N*m", "efficiency": 0.95, "max_speed": "0.5 m/s",
}
# a 6X default is not applied when the user gives one of these alternative parameters
_6X_CONFLICTS: dict[str, tuple[str, ...]] = {
    "spindle_EA": ("d_Sp", "E"), "spindle_inertia_per_length": ("spindle_inertia",),
    "spindle_total_length": ("spindle_inertia",), "motor_torque": ("max_force",), "efficiency": ("max_force",),
}
TELESCOPIC_PARAMS: tuple[Param, ...] = (
    Param("drive_model", "-", "fit_3_22", "'fit_3_22' (polynomial, eq. 3.22) or 'exact_3_3' (eq. 3.3)",
          choices=DRIVE_MODELS),
    Param("fit_coefficients", "N/m", None, "eq. 3.22 polynomial in l_eff [m], highest power first",
          required="for drive_model = 'fit_3_22'", shape=(None,)),
) + SCREW_DATA + (
    Param("l_eff_min", "m", None, "smallest effective spindle length", required=True, positive=True),
    Param("l_eff_max", "m", None, "largest effective spindle length", required=True, positive=True),
    Param("length_at_l_eff_min", "m", None, "strut length at l_eff_min (l_eff = l_eff_min + l - this)",
          required=True, positive=True),
    RANGE_PARAM,
) + SCREW_DYNAMICS + DRIVE_LIMITS


def _telescopic_factory(defaults: dict[str, Any]) -> Callable[["Params"], Component]:
    def factory(p: "Params") -> Component:
        for key, value in defaults.items():
            if not any(p.has(k) for k in _6X_CONFLICTS.get(key, ())):
                p.set_default(key, value)
        drive_model = p["drive_model"]
        fit = p["fit_coefficients"]
        if drive_model == "fit_3_22" and fit is None:
            raise p.error("fit_coefficients", "the polynomial coefficients of eq. 3.22 (l_eff in m, highest power "
                          "first) for drive_model = 'fit_3_22'", "missing")
        mass, limits, notes = screw_dynamics(p)
        drive = TelescopicBallScrew(
            name=p.name, drive_model=drive_model, fit_coefficients=() if fit is None else tuple(fit),
            k_al=p["k_aL"], k_m=p["k_M"], k_tm=p["k_TM"], spindle_ea=_spindle_ea(p),
            l_eff_min=p["l_eff_min"], l_eff_max=p["l_eff_max"], length_at_l_eff_min=p["length_at_l_eff_min"],
            out_of_range=p["out_of_range"], mass=mass, limits=limits)
        prov = "6X Hexapod telescopic strut, docs/user-guide/machines.md / docs/theory/components.md" if defaults else ""
        object.__setattr__(drive, "provenance", "; ".join(v for v in (prov, *notes.values()) if v))
        return drive
    return factory


def _with_6x_defaults(decl: Param) -> Param:
    if decl.key not in HEXAPOD_6X_DATA:
        return decl
    value = HEXAPOD_6X_DATA[decl.key]
    text = f"{value['value']} {value['unit']}" if isinstance(value, dict) else str(value)
    return dataclasses.replace(decl, default_text=f"6X: {text}")


TELESCOPIC_MODELS: tuple[ModelSpec, ...] = (
    ModelSpec("telescopic_ballscrew",
              "telescopic pod strut drive (fixed-floating ball screw) driven by the strut length",
              "Cobet eq. 3.3 / 3.22", TELESCOPIC_PARAMS, _telescopic_factory({})),
    ModelSpec("telescopic_ballscrew_6x",
              "6X Hexapod telescopic strut drive; defaults = docs/user-guide/machines.md data (each overridable)",
              "Cobet eq. 3.3 / 3.22, 3.4, 3.24", tuple(_with_6x_defaults(d) for d in TELESCOPIC_PARAMS),
              _telescopic_factory(HEXAPOD_6X_DATA)),
)
MODELS = TELESCOPIC_MODELS
