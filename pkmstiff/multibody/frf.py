"""Frequency response functions of the SDE model: receptance, accelerance, peaks.

Receptance ``H(ω) = bₒᵀ (K − ω² M + iω C)⁻¹ bᵢ`` between an excitation (unit force or moment along a direction at
a point of a body, generalized load ``bᵢ = N(Δ)ᵀ (e, 0)``) and a response (displacement or rotation of a point
along a direction, ``bₒᵀ q``); units m/N, rad/N, m/(N m), rad/(N m).  Accelerance ``A = −ω² H`` ((m/s²)/N, ...).

Damping: SDE damping matrices (assembled C, ``sde_damping=True``) and/or a modal damping ratio ``zeta`` (scalar or
per mode).  ``method="modal"`` superposes all modes with modal damping ``ζ_r = zeta_r + φ_rᵀ C φ_r / (2 ω_r)`` (exact
for proportional damping, the usual approximation otherwise) plus the static residual of condensed massless DOFs
(undamped: SDE damping acting between massless DOFs is neglected there, use the direct method for it);
``method="direct"`` solves the complex system per frequency with ``C + M Φ diag(2 ζ_r ω_r) Φᵀ M`` (exact).
Note: the spec (§4.1) neglects damping in its evaluations; this module is an extension.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from pkmstiff.errors import InputError
from pkmstiff.multibody.assembly import damping_matrix, has_damping, mass_matrix, stiffness_matrix
from pkmstiff.multibody.constraints import null_space_basis
from pkmstiff.multibody.modal import dynamic_system
from pkmstiff.multibody.solver import StaticSystem
from pkmstiff.multibody.static import DEFAULT_CHUNK, _n_total, chunk_point, point_load
from pkmstiff.multibody.system import SDEModel


@dataclass(frozen=True)
class PointDirection:
    """A direction at a point of a body: excitation by a unit force (``rotation=False``) or moment, response =
    displacement or rotation along it.  ``point`` (3,)/(N, 3) in m (None = body reference point)."""

    body: str
    direction: Any
    point: Any = None
    rotation: bool = False


def load_vector(model: SDEModel, pd: PointDirection) -> np.ndarray:
    """Generalized vector b (N, n) of a unit force/moment along ``pd.direction`` at ``pd.point`` (unit vector)."""
    e = np.asarray(pd.direction, dtype=float)
    if e.shape != (3,) or not np.linalg.norm(e) > 0:
        raise InputError("PointDirection", "direction", "a non-zero vector (3,)", pd.direction)
    e = e / np.linalg.norm(e)
    if pd.rotation:
        return point_load(model, pd.body, pd.point, moment=e)
    return point_load(model, pd.body, pd.point, force=e)


def _zeta(zeta: Any, r: int) -> np.ndarray:
    if zeta is None:
        return np.zeros(r)
    z = np.broadcast_to(np.asarray(zeta, dtype=float), (r,)) if np.ndim(zeta) == 0 else np.asarray(zeta, float)
    if z.shape != (r,) or np.any(z < 0):
        raise InputError("receptance", "zeta", f"a ratio >= 0, scalar or one per mode ({r})", np.shape(zeta))
    return z


def _receptance_chunk(model: SDEModel, omega: np.ndarray, bo: np.ndarray, bi: np.ndarray, zeta: Any,
                      sde_damping: bool, method: str) -> np.ndarray:
    k = stiffness_matrix(model)
    n_p = max(k.shape[0], bo.shape[0], bi.shape[0])
    if n_p > k.shape[0]:  # pose-independent model with per-pose points: evaluate per pose
        k = np.ascontiguousarray(np.broadcast_to(k, (n_p,) + k.shape[1:]))
    dyn = dynamic_system(model, k)
    lam, y = np.linalg.eigh(dyn.a)
    phi = dyn.to_full(y)  # (N, r, n) all modes, mass-normalised
    r = lam.shape[1]
    wr = np.sqrt(np.clip(lam, 0.0, None))
    z = _zeta(zeta, r)
    c = damping_matrix(model) if (sde_damping and has_damping(model)) else None
    if method == "modal":
        po = (phi @ bo[:, :, None])[..., 0]  # modal participation of the response direction (N, r)
        pi = (phi @ bi[:, :, None])[..., 0]
        zr = np.broadcast_to(z, lam.shape)
        if c is not None:
            cr = np.einsum("nri,nij,nrj->nr", phi, np.broadcast_to(c, (phi.shape[0],) + c.shape[1:]), phi)
            zr = zr + cr / (2.0 * np.where(wr > 0, wr, np.inf))
        den = lam[:, :, None] - omega[None, None, :] ** 2 + 2j * (zr * wr)[:, :, None] * omega[None, None, :]
        h = ((po * pi)[:, None, :] @ (1.0 / den))[:, 0, :]
        if dyn.n_massless:  # static residual of the condensed DOFs: bₒᵀ K⁻¹ bᵢ − Σ φₒφᵢ/λ
            static = (bo * StaticSystem(model, k).solve(np.broadcast_to(bi, (n_p, bi.shape[1])))).sum(axis=-1)
            h = h + (static - (po * pi / lam).sum(axis=-1))[:, None]
        return h
    # direct: (K - ω² M + iω C) x = b for every frequency, on the reduced system with rigid bindings
    m = np.broadcast_to(mass_matrix(model), k.shape)
    ctot = np.zeros_like(k) if c is None else np.broadcast_to(c, k.shape).copy()
    if np.any(z > 0):
        mphi = m @ np.swapaxes(phi, 1, 2)
        ctot = ctot + mphi @ ((2.0 * z * wr)[:, :, None] * np.swapaxes(mphi, 1, 2))
    zb = null_space_basis(model)
    bo_, bi_ = np.broadcast_to(bo, (n_p, bo.shape[1])), np.broadcast_to(bi, (n_p, bi.shape[1]))
    if zb is not None:
        zt = np.swapaxes(zb, 1, 2)
        k, m, ctot = zt @ k @ zb, zt @ m @ zb, zt @ ctot @ zb
        bo_, bi_ = np.einsum("nji,nj->ni", zb, bo_), np.einsum("nji,nj->ni", zb, bi_)
    dyn_mat = (k[:, None] - omega[None, :, None, None] ** 2 * m[:, None]
               + 1j * omega[None, :, None, None] * ctot[:, None])
    x = np.linalg.solve(dyn_mat, np.broadcast_to(bi_[:, None, :, None], (n_p, omega.size, bi_.shape[1], 1)))[..., 0]
    return np.einsum("nj,nfj->nf", bo_, x)


def receptance(model: SDEModel, freq_hz: Any, response: PointDirection, excitation: PointDirection, *,
               zeta: Any = None, sde_damping: bool = True, method: Literal["modal", "direct"] = "modal",
               chunk_size: int = DEFAULT_CHUNK) -> np.ndarray:
    """Complex receptance (N, n_freq) at frequencies ``freq_hz`` (Hz) (see module docstring for units/damping)."""
    f = np.asarray(freq_hz, dtype=float).ravel()
    if f.size == 0 or np.any(f < 0) or not np.all(np.isfinite(f)):
        raise InputError("receptance", "freq_hz", "finite frequencies >= 0 Hz", freq_hz)
    if method not in ("modal", "direct"):
        raise InputError("receptance", "method", "'modal' or 'direct'", method)
    omega = 2.0 * np.pi * f
    n_p = max(_n_total(model, response.point, response.body), _n_total(model, excitation.point, excitation.body))
    out = np.zeros((n_p, f.size), dtype=complex)
    step = chunk_size if method == "modal" else max(1, chunk_size // max(1, f.size))
    for sl, sub in model.chunks(step, n_p):
        resp = replace(response, point=chunk_point(response.point, sl))
        exc = replace(excitation, point=chunk_point(excitation.point, sl))
        out[sl] = _receptance_chunk(sub, omega, load_vector(sub, resp), load_vector(sub, exc), zeta, sde_damping,
                                    method)
    return out


def accelerance(model: SDEModel, freq_hz: Any, response: PointDirection, excitation: PointDirection,
                **kwargs: Any) -> np.ndarray:
    """Accelerance ``−ω² H`` (N, n_freq) in (m/s²)/N (or (rad/s²)/N, ...); arguments as :func:`receptance`."""
    omega = 2.0 * np.pi * np.asarray(freq_hz, dtype=float).ravel()
    return -(omega ** 2) * receptance(model, freq_hz, response, excitation, **kwargs)


def find_peaks(freq_hz: Any, h: np.ndarray, max_peaks: int = 6, min_rel_height: float = 0.0
               ) -> tuple[np.ndarray, np.ndarray]:
    """Resonance peaks of |h| (N, n_freq): frequencies (Hz) and magnitudes, each (N, max_peaks), ascending in
    frequency and NaN-padded.  Local maxima (refined by a parabola through log|h| at the three samples around
    each); only the ``max_peaks`` highest, and only those ≥ ``min_rel_height`` × the pose's maximum, are kept."""
    f = np.asarray(freq_hz, dtype=float).ravel()
    mag = np.abs(np.atleast_2d(h))
    if mag.shape[-1] != f.size or f.size < 3:
        raise InputError("find_peaks", "h", f"(N, {f.size}) values with >= 3 frequencies", mag.shape)
    inner = (mag[:, 1:-1] > mag[:, :-2]) & (mag[:, 1:-1] >= mag[:, 2:])
    inner &= mag[:, 1:-1] >= min_rel_height * mag.max(axis=1, keepdims=True)
    score = np.where(inner, mag[:, 1:-1], -np.inf)
    top = np.argsort(-score, axis=1, kind="stable")[:, :max_peaks]
    valid = np.take_along_axis(score, top, axis=1) > -np.inf
    k = top + 1
    y0, y1, y2 = (np.log(np.take_along_axis(mag, k + d, axis=1) + 1e-300) for d in (-1, 0, 1))
    x0, x1, x2 = (f[k + d] for d in (-1, 0, 1))
    # vertex of the parabola through (x0, y0), (x1, y1), (x2, y2)
    num = (x1 - x0) ** 2 * (y1 - y2) - (x1 - x2) ** 2 * (y1 - y0)
    den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0)
    xv = x1 - 0.5 * num / np.where(den != 0, den, np.inf)
    a = ((y2 - y1) / (x2 - x1) - (y1 - y0) / (x1 - x0)) / (x2 - x0)
    b = (y1 - y0) / (x1 - x0) - a * (x0 + x1)
    yv = a * xv ** 2 + b * xv + (y0 - a * x0 ** 2 - b * x0)
    freq = np.where(valid, xv, np.nan)
    peak = np.where(valid, np.exp(yv), np.nan)
    order = np.argsort(np.where(valid, freq, np.inf), axis=1)
    return np.take_along_axis(freq, order, axis=1), np.take_along_axis(peak, order, axis=1)
