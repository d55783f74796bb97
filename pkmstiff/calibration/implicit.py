"""Sensitivities of implicitly defined states by the implicit function theorem (Denkena §1.3–1.4, Gl. 61–68).

For a model 0 = F(s, p) (s the state: pose, orientation, passive joints; p the parameters) with F_s of full column
rank, ds/dp = −F_s⁺ F_p. F may have more rows than s (the extended-DH loop equations are row-redundant, Denkena
Gl. 44; the rows of a rotation-matrix equation), so the pseudo-inverse is taken by least squares. Vectorised over
a leading batch axis.
"""

from __future__ import annotations

import numpy as np

from pkmstiff.errors import InadmissibleError


def implicit_sensitivity(F_s: np.ndarray, F_p: np.ndarray) -> np.ndarray:
    """ds/dp (B, n_s, n_p) = −F_s⁺ F_p for F_s (B, n_F, n_s) and F_p (B, n_F, n_p); full column rank of F_s is
    required (checked: a rank-deficient F_s means the state is not defined by the model, a singular set-up)."""
    F_s = np.asarray(F_s, dtype=float)
    F_p = np.asarray(F_p, dtype=float)
    if F_s.ndim == 2:
        return implicit_sensitivity(F_s[None], F_p[None])[0]
    Q, R = np.linalg.qr(F_s)  # (B, n_F, n_s), (B, n_s, n_s)
    d = np.abs(np.diagonal(R, axis1=1, axis2=2))
    if np.any(d.min(axis=1) <= 1e-12 * d.max(axis=1)):
        raise InadmissibleError("implicit model: F_s is rank deficient (the state is not determined by the model "
                               "equations: singular configuration)")
    return -np.linalg.solve(R, np.swapaxes(Q, 1, 2) @ F_p)
