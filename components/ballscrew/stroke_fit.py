"""Polynomial fit of a length-dependent drive stiffness over l_eff (Cobet eq. 3.22)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from pkmstiff.errors import ArgumentError
from pkmstiff.units import to_unit


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
    quoted in docs/user-guide/machines.md (85.05, −246.0, 284.1 N/µm, r = 0.998) for the 6X data; the printed
    eq. 3.22 (85.3, −248.14, 285.53) is not reproduced exactly by any uniform sampling (its sampling is not
    stated); all samplings with ≥ 20 points are within 2 % of it.
    """
    lo, hi = (float(v) for v in l_eff_range)
    if not (0 < lo < hi) or degree < 0 or n_samples < degree + 2:
        raise ArgumentError("fit_stroke_polynomial: need 0 < l_min < l_max, degree >= 0 and "
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

