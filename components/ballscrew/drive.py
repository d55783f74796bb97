"""Ball-screw drive with nut-position dependent stiffness (Cobet eq. 3.1-3.3) and its machine-file models."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, ClassVar

import numpy as np

from components.ballscrew.formulas import ARRANGEMENTS, _check_drive_data, _range_policy, fixed_fixed_bearing_spindle
from components.ballscrew.screw_params import RANGE_PARAM, SCREW_DATA, SCREW_DYNAMICS, _spindle_ea, screw_dynamics
from components.ballscrew.stroke_fit import StrokeFit, fit_stroke_polynomial
from components.limits import DRIVE_LIMITS
from components.params import ModelSpec, Param
from components.protocol import Component, ComponentState, series
from pkmstiff.errors import ArgumentError

if TYPE_CHECKING:
    from components.reader import Params


@dataclass(frozen=True, kw_only=True, eq=False)
class BallScrewDrive(Component):
    """Ball-screw drive, Cobet eq. 3.1–3.3 (all SI; ``np.inf`` = rigid ``k_tm``).

    ``spindle_ea`` = E·A of the spindle [N] (``spindle_axial_rigidity(d_Sp, E)``); ``spindle_length`` l_Sp =
    distance between the force-introduction points of the two bearings [m] (required for fixed_fixed and
    floating_fixed); ``nut_offset`` = nut distance from the motor-side bearing at drive position 0 [m].
    ``l_eff_min``/``l_eff_max`` bound l_eff (fixed_fixed: l_Sp1); outside, ``out_of_range`` clamps (default,
    Assumption) or raises.
    """

    kind: ClassVar[str] = "axial"
    arrangement: str
    k_al: float
    spindle_ea: float
    k_m: float
    k_tm: float = np.inf
    spindle_length: float | None = None
    nut_offset: float = 0.0
    l_eff_min: float = 0.0
    l_eff_max: float | None = None
    out_of_range: str = "clamp"

    def __post_init__(self) -> None:
        if self.arrangement not in ARRANGEMENTS:
            raise ArgumentError(f"drive '{self.name}': arrangement must be one of {ARRANGEMENTS}, found "
                                     f"{self.arrangement!r}")
        _check_drive_data(self)
        if self.arrangement != "fixed_floating" and self.spindle_length is None:
            raise ArgumentError(f"drive '{self.name}': spindle_length is required for the {self.arrangement} "
                                     f"arrangement")
        if self.spindle_length is not None and not self.spindle_length > 0:
            raise ArgumentError(f"drive '{self.name}': spindle_length must be positive, found "
                                     f"{self.spindle_length!r}")
        hi = self.l_eff_max if self.l_eff_max is not None else (self.spindle_length or np.inf)
        if not 0 <= self.l_eff_min < hi:
            raise ArgumentError(f"drive '{self.name}': need 0 <= l_eff_min < l_eff_max, found {self.l_eff_min}, "
                                     f"{hi}")
        object.__setattr__(self, "l_eff_max", hi)
        limits = {"l_eff_min": self.l_eff_min, "l_eff_max": hi, **self.limits}
        object.__setattr__(self, "limits", limits)
        if self.out_of_range == "clamp" and "out_of_range" not in self.assumptions:
            object.__setattr__(self, "assumptions", {**self.assumptions, "out_of_range":
                               "l_eff outside [l_eff_min, l_eff_max] is clamped to the range (toolkit choice)"})

    def l_eff(self, state: ComponentState) -> np.ndarray:
        """Effective spindle length [m] per pose (fixed_fixed: l_Sp1, the segment next to the motor-side bearing)."""
        if state.l_eff is not None:
            value = state.l_eff
        else:
            s = self.nut_offset + state.require("drive_position", self.name)
            value = self.spindle_length - s if self.arrangement == "floating_fixed" else s
        return _range_policy(value, self.l_eff_min, self.l_eff_max, self.out_of_range, "l_eff", self.name)

    def bearing_spindle_stiffness(self, state: ComponentState) -> np.ndarray:
        """Bearing + spindle part [N/m] (eq. 3.2 resp. 3.3 without nut and nut connection)."""
        l1 = self.l_eff(state)
        with np.errstate(divide="ignore"):
            if self.arrangement == "fixed_fixed":
                return fixed_fixed_bearing_spindle(self.k_al, self.spindle_ea / l1,
                                                   self.spindle_ea / (self.spindle_length - l1))
            return series(2 * self.k_al, self.spindle_ea / l1)

    def stiffness(self, state: ComponentState) -> np.ndarray:
        return series(self.bearing_spindle_stiffness(state), self.k_m, self.k_tm)

    def stiffness_at_l_eff(self, l_eff: Any) -> np.ndarray:
        """Stiffness [N/m] for given l_eff values [m] (fixed_fixed: l_Sp1)."""
        return self.stiffness(ComponentState(l_eff=np.atleast_1d(np.asarray(l_eff, dtype=float))))

    def fit_stroke_polynomial(self, l_eff_range: tuple[float, float] | None = None, degree: int = 2,
                              n_samples: int = 200) -> StrokeFit:
        """Polynomial fit of the stiffness over l_eff (Cobet eq. 3.22); default range = [l_eff_min, l_eff_max]."""
        rng = l_eff_range if l_eff_range is not None else (self.l_eff_min, self.l_eff_max)
        return fit_stroke_polynomial(self.stiffness_at_l_eff, rng, degree, n_samples=n_samples)


# --------------------------------------------------------------------------------------------- machine files
def _ballscrew_params(arrangement: str) -> tuple[Param, ...]:
    length_doc = "none" if arrangement == "fixed_floating" else "required"
    return SCREW_DATA + (
        Param("spindle_length", "m", None, "l_Sp between the bearing force points", positive=True,
              default_text=length_doc),
        Param("nut_offset", "m", 0.0, "nut distance from the motor-side bearing at drive position 0"),
        Param("l_eff_min", "m", 0.0, "smallest admissible l_eff (fixed_fixed: l_Sp1)", min_value=0.0),
        Param("l_eff_max", "m", None, "largest admissible l_eff (fixed_fixed: l_Sp1)", positive=True,
              default_text="spindle_length"),
        RANGE_PARAM,
    ) + SCREW_DYNAMICS + DRIVE_LIMITS


def _ballscrew_factory(arrangement: str) -> Callable[["Params"], Component]:
    def factory(p: "Params") -> Component:
        mass, limits, notes = screw_dynamics(p)
        drive = BallScrewDrive(
            name=p.name, arrangement=arrangement, k_al=p["k_aL"], k_m=p["k_M"], k_tm=p["k_TM"],
            spindle_ea=_spindle_ea(p), spindle_length=p["spindle_length"], nut_offset=p["nut_offset"],
            l_eff_min=p["l_eff_min"], l_eff_max=p["l_eff_max"], out_of_range=p["out_of_range"],
            mass=mass, limits=limits)
        object.__setattr__(drive, "provenance", "; ".join(notes.values()))
        return drive
    return factory


BALLSCREW_MODELS: tuple[ModelSpec, ...] = tuple(
    ModelSpec(f"ballscrew_{arrangement}",
              f"ball-screw drive, {arrangement.replace('_', '-')} bearing arrangement, nut-position dependent",
              equation, _ballscrew_params(arrangement), _ballscrew_factory(arrangement))
    for arrangement, equation in (("fixed_fixed", "Cobet eq. 3.1, 3.2"), ("fixed_floating", "Cobet eq. 3.1, 3.3"),
                                  ("floating_fixed", "Cobet eq. 3.1, 3.3")))
MODELS = BALLSCREW_MODELS
