"""Uncertainty of identified base parameters (Szatmári §5.4, §5.4.2; Denkena §1.3).

Linearised at the solution, with weighted Jacobian J (m × n_b, SI) of the base parameters and residuals r (m):

    Σ = s² (JᵀJ)⁻¹,   s² = ‖r‖² / (m − rank),   σ_j = sqrt(Σ_jj),   ρ_jk = Σ_jk / (σ_j σ_k).

(JᵀJ)⁻¹ is formed from the SVD of J (no normal equations). The Monte-Carlo check (Szatmári §5.4.2) adds
normal noise of standard deviation s to the readings predicted at the solution, re-identifies with the linearised
model (one least-squares solve per run, all runs at once) and compares the spread of the estimates with σ.
A robust (IRLS) identification uses Huber's covariance of the M-estimate instead
(:func:`~pkmstiff.calibration.identification.robust_covariance`; s is then its effective scale).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from pkmstiff.calibration.identification import Identification, noise_estimate, residual_stats
from pkmstiff.errors import ArgumentError, NumericalError


@dataclass(frozen=True)
class Uncertainty:
    """Covariance (n_b × n_b, SI²) of the base parameters ``names``, σ (SI), correlation, residual s (m) with
    ``dof`` = m − rank degrees of freedom; ``mc_sigma`` the Monte-Carlo spread (SI) when asked for."""

    names: tuple[str, ...]
    units: tuple[str, ...]
    covariance: np.ndarray
    sigma: np.ndarray
    correlation: np.ndarray
    s: float
    dof: int
    before: dict
    after: dict
    mc_sigma: np.ndarray | None = None
    mc_runs: int = 0

    def interval(self, level: float = 0.95) -> np.ndarray:
        """Half-widths (SI) of the two-sided confidence intervals (Student t with ``dof`` degrees of freedom)."""
        return stats.t.ppf(0.5 + level / 2, self.dof) * self.sigma

    def max_correlation(self) -> tuple[float, str, str]:
        n = len(self.names)
        if n < 2:
            return 0.0, "", ""
        C = np.abs(self.correlation - np.eye(n))
        i, j = np.unravel_index(int(np.argmax(C)), C.shape)
        return float(C[i, j]), self.names[i], self.names[j]

    def to_dict(self) -> dict:
        def u(unit: str) -> tuple[str, float]:
            return ("sigma_um", 1e6) if unit == "m" else ("sigma_urad", 1e6)
        out = {"s_um": self.s * 1e6, "dof": self.dof, "residual_before": self.before, "residual_after": self.after,
               "parameters": []}
        for k, (nm, unit) in enumerate(zip(self.names, self.units)):
            key, f = u(unit)
            row = {"name": nm, key: float(self.sigma[k]) * f}
            if self.mc_sigma is not None:
                row["monte_carlo_" + key] = float(self.mc_sigma[k]) * f
            out["parameters"].append(row)
        c, a, b = self.max_correlation()
        out["max_correlation"] = {"value": c, "pair": [a, b]}
        if self.mc_sigma is not None:
            out["monte_carlo_runs"] = self.mc_runs
        return out


def covariance(J: np.ndarray, r: np.ndarray, rank: int | None = None) -> tuple[np.ndarray, float, int]:
    """Σ = s²(JᵀJ)⁻¹ with s² = ‖r‖²/(m − rank) (``rank`` default: columns of J); returns (Σ, s, m − rank).
    A rank-deficient J (a parameter the readings do not see) is an error, not an infinite σ."""
    m, n = J.shape
    rank = n if rank is None else int(rank)
    if m <= rank:
        raise ArgumentError(f"{m} readings for {rank} identified parameters: no degrees of freedom are left to "
                               "estimate the noise; measure more poses")
    _, sv, Vt = np.linalg.svd(J, full_matrices=False)
    if sv[-1] <= sv[0] * 1e-13 * max(m, n):
        raise NumericalError("the Jacobian of the identified parameters is rank deficient; identify the base "
                               "parameters only (their gauge freedoms fixed)")
    s = noise_estimate(np.asarray(r, dtype=float), rank)
    Vs = Vt.T / sv[None, :]
    return s * s * (Vs @ Vs.T), s, m - rank


def uncertainty(res: Identification, monte_carlo: int = 0, seed: int | None = 0) -> Uncertainty:
    """Covariance, σ and correlations of the identified base parameters; ``monte_carlo`` > 0 runs that many
    linearised Monte-Carlo re-identifications (Szatmári §5.4.2) and reports their spread."""
    Sigma, s, dof = covariance(res.J, res.residual_after, res.rank)
    if res.robust is not None:  # M-estimate: Huber's sandwich covariance, not s²(JᵀJ)⁻¹ of the weighted fit
        from pkmstiff.calibration.identification import robust_covariance

        Sigma, s = robust_covariance(res.J, res.residual_after, res.robust_scale, res.robust)
    sigma = np.sqrt(np.diag(Sigma))
    corr = Sigma / np.outer(sigma, sigma)
    names = res.base_names
    units = tuple(res.params.units[i] for i in res.base)
    mc = None
    if monte_carlo > 0:
        rng = np.random.default_rng(seed)
        E = rng.normal(0.0, s, size=(res.J.shape[0], int(monte_carlo)))
        X = np.linalg.lstsq(res.J, E, rcond=None)[0]  # (n_b, runs): estimate errors of the linearised problem
        mc = X.std(axis=1, ddof=1)
    return Uncertainty(names=names, units=units, covariance=Sigma, sigma=sigma, correlation=corr, s=s, dof=dof,
                       before=residual_stats(res.residual_before), after=residual_stats(res.residual_after),
                       mc_sigma=mc, mc_runs=int(monte_carlo))
