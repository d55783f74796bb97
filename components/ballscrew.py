"""Ball-screw drives with indirect measuring system (spec models.md §3.1, Cobet eq. 3.1–3.4, 3.21–3.24).

Axial stiffness of the drive depends on the nut position through the spindle; bearings, nut and nut
connection are constant. Arrangements (Cobet Table 3.1):

* ``fixed_fixed`` (eq. 3.2): two fixed bearings, the nut splits the spindle into l_Sp1 (from the
  motor-side bearing) and l_Sp2 = l_Sp − l_Sp1; equivalent to two paths "fixed bearing (2 k_al) in series
  with a spindle segment" acting in parallel;
* ``fixed_floating`` / ``floating_fixed`` (eq. 3.3): l_eff is the distance from the fixed bearing to the
  nut; the fixed bearing is at the motor end resp. at the far end.

The nut position along the spindle is ``s = nut_offset + drive_position`` measured from the motor-side
bearing (``state.l_eff``, when given, is used directly as l_eff resp. l_Sp1).

:class:`TelescopicBallScrew` is the pod strut drive of the 6X Hexapod (machines.md §4.2): fixed–floating,
driven by the strut length through l_eff = l_eff_min + (l − l_at_l_eff_min) (Assumption) and evaluated either
with the quadratic fit of Cobet eq. 3.22 (default) or the exact eq. 3.3.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, ClassVar

import numpy as np

from pkmstiff.errors import ComponentDataError, ComponentRangeError
from pkmstiff.units import to_unit

from components.limits import DRIVE_LIMITS, drive_limits
from components.params import ModelSpec, Param
from components.protocol import Component, ComponentState, parallel, series

if TYPE_CHECKING:
    from components.reader import Params

ARRANGEMENTS: tuple[str, ...] = ("fixed_fixed", "fixed_floating", "floating_fixed")
RANGE_POLICIES: tuple[str, ...] = ("clamp", "error")
DRIVE_MODELS: tuple[str, ...] = ("fit_3_22", "exact_3_3")


def _check_drive_data(drive) -> None:
    """Range policy and positive stiffness data common to the ball-screw drives (eq. 3.2, 3.3)."""
    if drive.out_of_range not in RANGE_POLICIES:
        raise ComponentDataError(f"drive '{drive.name}': out_of_range must be one of {RANGE_POLICIES}, "
                                 f"found {drive.out_of_range!r}")
    for key in ("k_al", "spindle_ea", "k_m", "k_tm"):
        if not getattr(drive, key) > 0:
            raise ComponentDataError(f"drive '{drive.name}': {key} must be positive, found {getattr(drive, key)!r}")


# --------------------------------------------------------------------------------------------- formulas
def spindle_axial_rigidity(d_sp: float, E: float) -> float:
    """EA = π d_Sp² E / 4 [N] of the spindle (numerator of Cobet eq. 3.1); d_Sp = mean of core and nominal diameter."""
    return np.pi * d_sp**2 * E / 4.0


def spindle_stiffness(d_sp: float, E: float, l_eff: Any) -> np.ndarray:
    """Spindle stiffness k_Sp = π d_Sp² E / (4 l_eff) [N/m], Cobet eq. 3.1 (l_eff = 0 gives np.inf)."""
    with np.errstate(divide="ignore"):
        return spindle_axial_rigidity(d_sp, E) / np.asarray(l_eff, dtype=float)


def fixed_fixed_stiffness_eq_3_2(k_al: float, k_sp1: Any, k_sp2: Any, k_m: float, k_tm: float) -> np.ndarray:
    """Axial stiffness of the fixed–fixed arrangement, closed form of Cobet eq. 3.2 (finite k_Sp only)."""
    k1 = np.asarray(k_sp1, dtype=float)
    k2 = np.asarray(k_sp2, dtype=float)
    bearing_spindle = (2 * k_al + k1) * (2 * k_al + k2) / (4 * k_al * (k1 * k2 + k_al * (k1 + k2)))
    return 1.0 / (bearing_spindle + 1.0 / k_m + 1.0 / k_tm)


def fixed_fixed_bearing_spindle(k_al: float, k_sp1: Any, k_sp2: Any) -> np.ndarray:
    """Bearing + spindle part of eq. 3.2 as two parallel paths, each ``2 k_al`` in series with a segment."""
    return parallel(series(2 * k_al, k_sp1), series(2 * k_al, k_sp2))


def fixed_floating_stiffness(k_al: float, k_sp: Any, k_m: float, k_tm: float) -> np.ndarray:
    """Axial stiffness 1/k_A = 1/(2 k_aL) + 1/k_Sp + 1/k_M + 1/k_TM, Cobet eq. 3.3 (np.inf = rigid)."""
    return series(2 * k_al, k_sp, k_m, k_tm)


def apparent_mass_from_inertia(J: float, lead: float) -> float:
    """Apparent translational mass m = (2π/h_S)² J [kg], Cobet eq. 3.4 (J: spindle inertia [kg·m²], h_S [m])."""
    return (2.0 * np.pi / lead) ** 2 * J


def apparent_mass_from_geometry(d_sp: float, l_abs: float, rho: float, lead: float) -> float:
    """Apparent translational mass m = π³ d⁴ l_abs ρ / (8 h_S²) [kg], Cobet eq. 3.4 (solid spindle)."""
    return np.pi**3 * d_sp**4 * l_abs * rho / (8.0 * lead**2)


def max_axial_force(motor_torque: float, efficiency: float, lead: float) -> float:
    """Maximum axial drive force τ_q,max = 2π M_t η / h_S [N], Cobet eq. 3.24."""
    return 2.0 * np.pi * motor_torque * efficiency / lead


@dataclass(frozen=True)
class StrokeFit:
    """Least-squares polynomial k(l_eff) ≈ Σ c_j l_eff^(deg-j) (l_eff in m), as in Cobet eq. 3.22.

    ``coefficients`` highest power first, in N/m (per m^power); ``correlation`` = Pearson correlation of
    fitted and exact values at the samples (multiple R); ``max_rel_deviation`` = max |fit/exact − 1|.
    """

    coefficients: np.ndarray
    correlation: float
    r_squared: float
    max_rel_deviation: float
    samples: np.ndarray

    def coefficients_in(self, unit: str = "N/um") -> np.ndarray:
        """Coefficients with the stiffness in ``unit`` (l_eff still in m), e.g. N/µm as printed in eq. 3.22."""
        return np.asarray(to_unit(self.coefficients, unit))

    def __call__(self, l_eff: Any) -> np.ndarray:
        return np.polyval(self.coefficients, np.asarray(l_eff, dtype=float))


def fit_stroke_polynomial(
    stiffness_of_l_eff: Callable[[np.ndarray], np.ndarray],
    l_eff_range: tuple[float, float],
    degree: int = 2,
    *,
    n_samples: int = 200,
) -> StrokeFit:
    """Fit a polynomial in l_eff [m] to a length-dependent drive stiffness [N/m] (Cobet eq. 3.22).

    Sampling: ``n_samples`` equally spaced points including both ends. 200 samples reproduce the fit
    quoted in machines.md §4.2 (85.05, −246.0, 284.1 N/µm, r = 0.998) for the 6X data; the printed
    eq. 3.22 (85.3, −248.14, 285.53) is not reproduced exactly by any uniform sampling (its sampling is not
    stated); all samplings with ≥ 20 points are within 2 % of it.
    """
    lo, hi = (float(v) for v in l_eff_range)
    if not (0 < lo < hi) or degree < 0 or n_samples < degree + 2:
        raise ComponentDataError("fit_stroke_polynomial: need 0 < l_min < l_max, degree >= 0 and "
                                 f"n_samples >= degree + 2, "
                                 f"found range {l_eff_range}, degree {degree}, n_samples {n_samples}")
    x = np.linspace(lo, hi, n_samples)
    y = np.asarray(stiffness_of_l_eff(x), dtype=float)
    coeffs = np.polyfit(x, y, degree)
    fitted = np.polyval(coeffs, x)
    r = float(np.corrcoef(y, fitted)[0, 1])
    r2 = float(1.0 - np.sum((y - fitted) ** 2) / np.sum((y - y.mean()) ** 2))
    return StrokeFit(coefficients=coeffs, correlation=r, r_squared=r2,
                     max_rel_deviation=float(np.max(np.abs(fitted / y - 1.0))), samples=x)


def _range_policy(values: np.ndarray, lo: float, hi: float, policy: str, what: str, name: str) -> np.ndarray:
    if policy == "error":
        bad = (values < lo) | (values > hi)
        if np.any(bad):
            idx = int(np.flatnonzero(bad)[0])
            raise ComponentRangeError(f"drive '{name}': {what} = {values[idx]:.6g} m (pose {idx}) outside the "
                                      f"admissible range [{lo:.6g}, {hi:.6g}] m (out_of_range='error')")
        return values
    return np.clip(values, lo, hi)


# --------------------------------------------------------------------------------------------- components
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
            raise ComponentDataError(f"drive '{self.name}': arrangement must be one of {ARRANGEMENTS}, found "
                                     f"{self.arrangement!r}")
        _check_drive_data(self)
        if self.arrangement != "fixed_floating" and self.spindle_length is None:
            raise ComponentDataError(f"drive '{self.name}': spindle_length is required for the {self.arrangement} "
                                     f"arrangement")
        if self.spindle_length is not None and not self.spindle_length > 0:
            raise ComponentDataError(f"drive '{self.name}': spindle_length must be positive, found "
                                     f"{self.spindle_length!r}")
        hi = self.l_eff_max if self.l_eff_max is not None else (self.spindle_length or np.inf)
        if not 0 <= self.l_eff_min < hi:
            raise ComponentDataError(f"drive '{self.name}': need 0 <= l_eff_min < l_eff_max, found {self.l_eff_min}, "
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


@dataclass(frozen=True, kw_only=True, eq=False)
class TelescopicBallScrew(Component):
    """Telescopic strut drive of a pod machine (fixed–floating ball screw, machines.md §4.2).

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
            raise ComponentDataError(f"drive '{self.name}': drive_model must be one of {DRIVE_MODELS}, found "
                                     f"{self.drive_model!r}")
        _check_drive_data(self)
        if not 0 < self.l_eff_min < self.l_eff_max:
            raise ComponentDataError(f"drive '{self.name}': need 0 < l_eff_min < l_eff_max, found "
                                     f"{self.l_eff_min}, {self.l_eff_max}")
        if self.drive_model == "fit_3_22":
            c = np.asarray(self.fit_coefficients, dtype=float)
            if c.ndim != 1 or c.size == 0:
                raise ComponentDataError(f"drive '{self.name}': drive_model 'fit_3_22' needs fit_coefficients")
            x = np.linspace(self.l_eff_min, self.l_eff_max, 101)
            if np.any(np.polyval(c, x) <= 0):
                raise ComponentDataError(f"drive '{self.name}': the fit polynomial is not positive over "
                                         f"[{self.l_eff_min}, {self.l_eff_max}] m")
        object.__setattr__(self, "fit_coefficients", tuple(float(v) for v in self.fit_coefficients))
        object.__setattr__(self, "limits", {"l_eff_min": self.l_eff_min, "l_eff_max": self.l_eff_max, **self.limits})
        defaults = {
            "l_eff_mapping": "l_eff = l_eff_min + (l - length_at_l_eff_min): strut-length-to-spindle-length mapping "
                             "assumed by the toolkit (machines.md §4.2)",
        }
        if self.out_of_range == "clamp":
            defaults["out_of_range"] = "l_eff outside [l_eff_min, l_eff_max] is clamped to the range (toolkit choice)"
        object.__setattr__(self, "assumptions", {**defaults, **self.assumptions})

    def l_eff(self, state: ComponentState) -> np.ndarray:
        """Effective spindle length [m] per pose."""
        if state.l_eff is not None:
            value = state.l_eff
        else:
            length = state.strut_length if state.strut_length is not None else state.require("drive_position", self.name)
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
#: Stiffness data of a ball screw (Cobet eq. 3.1-3.3); the spindle is given by E*A or by d_Sp and E.
SCREW_DATA: tuple[Param, ...] = (
    Param("k_aL", "N/m", None, "axial stiffness of the bearings (fixed bearing = 2 k_aL)", required=True,
          positive=True),
    Param("k_M", "N/m", None, "nut stiffness", required=True, positive=True),
    Param("k_TM", "N/m", np.inf, "nut connection stiffness", positive=True, rigid_ok=True),
    Param("spindle_EA", "N", None, "spindle E*A (= k_Sp l_eff)", required="unless d_Sp + E", positive=True),
    Param("d_Sp", "m", None, "spindle diameter (mean of core and nominal), with E", required="unless spindle_EA",
          positive=True),
    Param("E", "Pa", None, "Young's modulus of the spindle, with d_Sp", required="unless spindle_EA", positive=True),
)
#: Moved mass, apparent spindle mass (eq. 3.4) and maximum force from the motor torque (eq. 3.24).
SCREW_DYNAMICS: tuple[Param, ...] = (
    Param("mass", "kg", 0.0, "moved mass (the apparent spindle mass is added)", min_value=0.0),
    Param("lead", "m", None, "spindle lead h_S", positive=True),
    Param("spindle_inertia", "kg*m^2", None, "spindle inertia J for the apparent mass (eq. 3.4)", positive=True),
    Param("spindle_inertia_per_length", "kg*m", None, "spindle inertia per length, with spindle_total_length "
          "(instead of spindle_inertia)", positive=True),
    Param("spindle_total_length", "m", None, "total spindle length, with spindle_inertia_per_length", positive=True),
    Param("motor_torque", "N*m", None, "max_force = 2 pi M_t eta / h_S (eq. 3.24; instead of max_force)",
          positive=True),
    Param("efficiency", "-", 1.0, "efficiency eta, with motor_torque (eq. 3.24)", positive=True),
)
RANGE_PARAM = Param("out_of_range", "-", "clamp", "policy for l_eff outside [l_eff_min, l_eff_max]",
                    choices=RANGE_POLICIES)


def _spindle_ea(p: "Params") -> float:
    if p.exactly_one(("spindle_EA",), ("d_Sp", "E")) == 0:  # the chosen alternative is required
        return p.get("spindle_EA", required=True)
    return spindle_axial_rigidity(p.get("d_Sp", required=True), p.get("E", required=True))


def screw_dynamics(p: "Params") -> tuple[float, dict[str, float], dict[str, str]]:
    """(mass, limits, notes) from the optional dynamic parameters of a ball-screw drive (:data:`SCREW_DYNAMICS`)."""
    notes: dict[str, str] = {}
    moved = p["mass"]
    lead = p["lead"]
    inertia = p["spindle_inertia"]
    per_length = p["spindle_inertia_per_length"]
    total_length = p["spindle_total_length"]
    if per_length is not None:
        if inertia is not None or total_length is None:
            raise p.error("spindle_inertia_per_length", "together with spindle_total_length and without "
                          "spindle_inertia", "an incomplete or conflicting spindle inertia")
        inertia = per_length * total_length
    apparent = 0.0
    if inertia is not None:
        if lead is None:
            raise p.error("lead", "the spindle lead (needed with a spindle inertia, eq. 3.4)", "missing")
        apparent = apparent_mass_from_inertia(inertia, lead)
        notes["mass"] = f"moved mass {moved:g} kg + apparent spindle mass {apparent:.4g} kg (Cobet eq. 3.4)"
    limits = drive_limits(p)
    torque = p["motor_torque"]
    if torque is not None:
        if "max_force" in limits:
            raise p.error("motor_torque", "either max_force or motor_torque (+ efficiency, lead)", "both")
        if lead is None:
            raise p.error("lead", "the spindle lead (needed with motor_torque, eq. 3.24)", "missing")
        eta = p["efficiency"]
        if eta > 1:
            raise p.error("efficiency", "a value in (0, 1]", eta)
        limits["max_force"] = max_axial_force(torque, eta, lead)
        notes["max_force"] = f"2 pi M_t eta / h_S = {limits['max_force']:.5g} N (Cobet eq. 3.24)"
    elif p.has("efficiency"):
        raise p.error("efficiency", "only together with motor_torque", p.raw("efficiency"))
    return moved + apparent, limits, notes


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

#: Data of the 6X Hexapod telescopic strut drive (machines.md §4.2, component-data.md §8), unparsed.
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
        prov = "6X Hexapod telescopic strut, machines.md §4.2 / component-data.md §8" if defaults else ""
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
              "6X Hexapod telescopic strut drive; defaults = machines.md §4.2 data (each overridable)",
              "Cobet eq. 3.3 / 3.22, 3.4, 3.24", tuple(_with_6x_defaults(d) for d in TELESCOPIC_PARAMS),
              _telescopic_factory(HEXAPOD_6X_DATA)),
)
MODELS: tuple[ModelSpec, ...] = BALLSCREW_MODELS + TELESCOPIC_MODELS
