"""Weighted evaluation of variants (Cobet 6.2's outlook: a weighting that eases comparing kinematics).

Scoring rule, per criterion j (a row of the comparison table, with a user weight w_j >= 0 and a direction):

    u_ij = (x_ij - min_i x_ij) / (max_i x_ij - min_i x_ij)      "higher is better"
    u_ij = (max_i x_ij - x_ij) / (max_i x_ij - min_i x_ij)      "lower is better"

so the best variant on a criterion gets 1, the worst 0 (all variants 1 when they are equal; a missing value scores
0). The score of variant i is S_i = 100 · Σ_j w_j u_ij / Σ_j w_j points (0…100); the ranking sorts by S_i, ties
keep the spec's order. Sensitivity: the ranking is recomputed with each weight in turn set to 0 and doubled; a
ranking that changes there depends on that weight.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Criterion:
    """One criterion of the weighted evaluation: a comparison-table row label, its weight and direction."""

    metric: str
    weight: float
    higher_is_better: bool = True


def utilities(values: np.ndarray, higher_is_better: np.ndarray) -> np.ndarray:
    """u (n_variants, n_criteria) in [0, 1] from the values (NaN = missing) by the rule in the module docstring."""
    x = np.asarray(values, dtype=float)
    lo, hi = np.nanmin(np.where(np.isfinite(x), x, np.nan), axis=0), np.nanmax(np.where(np.isfinite(x), x, np.nan),
                                                                                axis=0)
    span = hi - lo
    with np.errstate(invalid="ignore", divide="ignore"):
        up = np.where(span > 0, (x - lo) / span, 1.0)
    u = np.where(np.asarray(higher_is_better, bool)[None, :], up, np.where(span > 0, 1.0 - up, 1.0))
    return np.where(np.isfinite(x), u, 0.0)


def scores(values: np.ndarray, weights: np.ndarray, higher_is_better: np.ndarray) -> np.ndarray:
    """S_i = 100 Σ_j w_j u_ij / Σ_j w_j (points, 0…100)."""
    w = np.asarray(weights, dtype=float)
    total = w.sum()
    if total <= 0:
        return np.zeros(np.shape(values)[0])
    return 100.0 * utilities(values, higher_is_better) @ w / total


def ranking(score: np.ndarray) -> list[int]:
    """Variant indices from the best score down (a stable sort: ties keep the given order)."""
    return [int(i) for i in np.argsort(-np.asarray(score), kind="stable")]


def sensitivity(values: np.ndarray, weights: np.ndarray, higher_is_better: np.ndarray,
                factors: tuple[float, ...] = (0.0, 2.0)) -> list[tuple[int, float, list[int]]]:
    """(criterion, factor, ranking) for each criterion's weight multiplied by each factor, the others unchanged."""
    out = []
    for j in range(len(weights)):
        for f in factors:
            w = np.asarray(weights, dtype=float).copy()
            w[j] *= f
            out.append((j, f, ranking(scores(values, w, higher_is_better))))
    return out
