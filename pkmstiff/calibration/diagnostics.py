"""Model-fit diagnostics of an identification (issue 26 item 5): does the model explain the readings?

Every test works on the weighted residual r (m,) of the identification, its weighted Jacobian J (m, n_b) and the
noise the instrument states (σ per reading: the device accuracy read as a 2σ bound, k = 2, as in the simulation;
:meth:`~pkmstiff.calibration.instruments.Instrument.reading_sigma`). Each has a false-alarm probability of
:data:`ALPHA` when the model and the stated noise are right:

* **χ²** (``chi2``): χ² = Σ (r_i/σ_i)² against the χ² distribution with m − n_b degrees of freedom;
* **added-variable tests** (``drift``, ``setup:TOKEN``, ``cw-ccw``): a candidate column block C (a linear trend in
  time per reading, a set-up parameter not identified, a CW/CCW offset) is projected off the identified columns,
  C⊥ = (I − J J⁺) C, and the residual reduction it buys, ΔRSS = rᵀ C⊥ (C⊥ᵀ C⊥)⁺ C⊥ᵀ r, is compared with
  s² χ²_q (q = rank C⊥, s² = ‖r‖²/(m − n_b)); the size of the effect β = (C⊥ᵀ C⊥)⁺ C⊥ᵀ r and the bias it puts
  into the identified parameters, J⁺ C β, in units of their σ, are reported;
* **runs** (``run``): the χ² of every run (a contiguous block of samples of one direction) against its share of the
  degrees of freedom; a run that fails is re-identified with its readings in reverse order — if that fits, the run
  is named as reversed or mislabelled (``reversed-run``);
* **outliers** (``outliers``): with u = r/σ, |u_i − median u| / s_robust (s_robust = 1.4826 · median |u − median u|,
  at least 1: not below the stated noise) above the Bonferroni bound z with P(|N(0, 1)| > z) = ALPHA / m.

The added-variable tests use s = max(‖r‖/√(m − n_b), stated σ): a fit better than the instrument's accuracy
(a noise-free simulation) does not make rounding noise significant; likewise a run stands out only if it also
misfits the stated noise.

The fit is *consistent* when no test fails.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

#: false-alarm probability of every test (per test; the outlier bound is Bonferroni-corrected over the readings)
ALPHA = 1e-3
#: a projected candidate column shorter than this fraction of its length lies in the span of the identified
#: columns (the readings cannot tell it from the parameters: a gauge freedom, nothing to test)
SPAN_TOL = 1e-6


@dataclass(frozen=True)
class Finding:
    """One diagnostic: ``key`` (``chi2``, ``drift``, ``setup:bar-offset``, ``cw-ccw``, ``run``, ``reversed-run``,
    ``outliers``), ``title`` (prose), the test ``statistic`` and the ``threshold`` it is compared with, whether it
    ``failed``, a one-line ``message`` naming the cause and what to do, and JSON-ready ``values`` (keys name their
    units)."""

    key: str
    title: str
    statistic: float
    threshold: float
    failed: bool
    message: str
    values: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"key": self.key, "title": self.title, "statistic": float(self.statistic),
                "threshold": float(self.threshold), "failed": bool(self.failed), "message": self.message,
                **self.values}


@dataclass(frozen=True)
class FitDiagnostics:
    """The findings of :func:`diagnose` and the outliers (pose, time, residual); ``sigma`` the stated σ of each
    reading kind (SI, :attr:`~pkmstiff.calibration.instruments.Instrument.reading_names` order)."""

    findings: tuple[Finding, ...]
    outliers: tuple[dict, ...]
    sigma: tuple[float, ...]
    reading_units: tuple[str, ...]

    @property
    def consistent(self) -> bool:
        return not any(bool(f.failed) for f in self.findings)

    @property
    def failed(self) -> tuple[Finding, ...]:
        """The failed findings, named causes first (a reversed run, a set-up parameter, outliers, drift), then the
        symptoms (CW/CCW offset, a run standing out, χ²)."""
        order = ("reversed-run", "setup", "outliers", "drift", "cw-ccw", "run", "chi2")
        return tuple(sorted((f for f in self.findings if f.failed), key=lambda f: order.index(f.key.split(":")[0])))

    def summary(self) -> str:
        """One line: consistent, or the failed tests with their causes."""
        if self.consistent:
            return "the model fits the readings within the instrument's stated accuracy (no diagnostic failed)"
        return "the model does not fit the measurement: " + "; ".join(f.message for f in self.failed)

    def to_dict(self) -> dict:
        return {"consistent": self.consistent, "summary": self.summary(), "alpha": ALPHA,
                "stated_sigma": [{"unit": "um" if u == "m" else "urad", "value": s * 1e6}
                                 for s, u in zip(self.sigma, self.reading_units)],
                "findings": [f.to_dict() for f in self.findings], "outliers": list(self.outliers)}


@dataclass(frozen=True)
class Candidate:
    """A column block (m, q) to test by :func:`added_variable`: ``key``, ``title``, the columns, the names of its
    effects (β) with their units, what to do when it is significant (``advice``)."""

    key: str
    title: str
    columns: np.ndarray
    names: tuple[str, ...]
    units: tuple[str, ...]
    advice: str


def added_variable(J: np.ndarray, r: np.ndarray, C: np.ndarray, s: float) -> tuple[float, int, np.ndarray,
                                                                                    np.ndarray]:
    """Added-variable test (module docstring): (ΔRSS / s², q, β (q,), bias J⁺ C β (n_b,)). β is the least-squares
    effect of the columns C (m, q) not explained by J (m, n_b); q = 0 when C lies in the span of J."""
    Q, _ = np.linalg.qr(J)
    Cp = C - Q @ (Q.T @ C)
    keep = np.linalg.norm(Cp, axis=0) > SPAN_TOL * np.maximum(np.linalg.norm(C, axis=0), 1e-300)
    beta = np.zeros(C.shape[1])
    if not keep.any():
        return 0.0, 0, beta, np.zeros(J.shape[1])
    b, _, q, _ = np.linalg.lstsq(Cp[:, keep], r, rcond=SPAN_TOL)
    beta[keep] = b
    fit = Cp[:, keep] @ b
    bias = np.linalg.lstsq(J, C @ beta, rcond=None)[0]
    return float(fit @ fit) / s ** 2, int(q), beta, bias


def runs_of(direction: np.ndarray) -> list[tuple[int, int, str]]:
    """Contiguous runs (start, stop, direction) of a per-sample direction label."""
    d = np.asarray(direction).astype(str)
    cuts = np.flatnonzero(d[1:] != d[:-1]) + 1
    starts = np.r_[0, cuts]
    stops = np.r_[cuts, d.size]
    return [(int(a), int(b), d[a]) for a, b in zip(starts, stops)]


def _fmt(v: float, unit: str) -> str:
    return f"{v * 1e6:+.3g} µm" if unit == "m" else f"{v * 1e6:+.3g} µrad"


def diagnose(J: np.ndarray, r: np.ndarray, sigma: np.ndarray, weights: np.ndarray, param_sigma: np.ndarray, *,
             reading_names: tuple[str, ...], reading_units: tuple[str, ...], t: np.ndarray,
             direction: np.ndarray | None = None, candidates: tuple[Candidate, ...] = (),
             refit_reversed: Callable[[int, int], np.ndarray | None] | None = None, max_reversed: int = 4,
             robust_weights: np.ndarray | None = None) -> FitDiagnostics:
    """Model-fit diagnostics (module docstring) of a fit with weighted residual ``r`` (m,) and Jacobian ``J``
    (m, n_b): k = len(``reading_names``) readings per sample with stated σ ``sigma`` (k,, SI) and row weights
    ``weights`` (k,); parameter σ ``param_sigma`` (n_b,), sample times ``t`` (N,) and directions (N,);
    ``candidates`` are extra column blocks in weighted rows (set-up parameters not identified);
    ``refit_reversed(start, stop)`` returns the residual of the identification with the readings of samples
    start..stop−1 reversed, or None if that cannot be identified (tried for up to ``max_reversed`` runs when χ²
    fails; ``None``: not tried). ``robust_weights`` (m,): the IRLS weights of a robust identification — the
    outliers it down-weighted (weight < 1/2) are listed with their weight and left out of every other test (their
    rows zeroed, the degrees of freedom reduced), and the outlier test fails only for an outlier not down-weighted."""
    raw = np.asarray(r, dtype=float)
    m, nb = J.shape
    k = len(reading_names)
    n = m // k
    w = np.asarray(weights, dtype=float)
    sigma_rows = np.tile(np.asarray(sigma, dtype=float) * w, n)
    u = raw / sigma_rows  # in units of the stated noise
    med = float(np.median(u))
    s_rob = max(1.4826 * float(np.median(np.abs(u - med))), 1.0)  # not below the stated noise
    z = float(stats.norm.isf(ALPHA / (2 * m)))
    flagged = np.abs(u - med) > z * s_rob
    dropped = flagged & (np.asarray(robust_weights) < 0.5) if robust_weights is not None else np.zeros(m, bool)
    if dropped.any():
        keep = (~dropped).astype(float)
        r, J = raw * keep, J * keep[:, None]
        candidates = tuple(dataclasses.replace(c, columns=c.columns * keep[:, None]) for c in candidates)
    dof = m - nb - int(dropped.sum())
    # residual scale of the added-variable tests: the fit's s, but not below the stated noise (a fit better than the
    # instrument's accuracy — e.g. noise-free simulations — must not turn rounding noise into "significant" effects)
    s = max(float(np.sqrt(r @ r / dof)), float(np.sqrt(np.mean(sigma_rows ** 2))))
    findings: list[Finding] = []

    chi2 = float(np.sum((r / sigma_rows) ** 2))
    lim = float(stats.chi2.isf(ALPHA, dof))
    rms = float(np.sqrt(np.mean(r[0::k] ** 2))) / w[0]
    findings.append(Finding(
        "chi2", "residual against the instrument's stated accuracy (chi-squared)", chi2 / dof, lim / dof, chi2 > lim,
        f"chi2: residual RMS {_fmt(rms, reading_units[0])[1:]} is {rms / sigma[0]:.3g}x the stated noise sigma "
        f"{_fmt(sigma[0], reading_units[0])[1:]} (chi2/dof {chi2 / dof:.3g} > {lim / dof:.3g})",
        {"chi2_per_dof": chi2 / dof, "dof": dof, "p_value": float(stats.chi2.sf(chi2, dof)),
         "rms_over_sigma": rms / float(sigma[0])}))

    tc = np.asarray(t, dtype=float) - float(np.mean(t))
    span = float(np.ptp(t)) if n > 1 else 0.0
    trend = np.zeros((m, k))
    for i in range(k):
        trend[i::k, i] = tc * w[i]  # β_i in reading units per second
    cands = [Candidate("drift", "trend of the readings over time (drift)", trend,
                       tuple(f"drift of {nm} over the measurement" for nm in reading_names), reading_units,
                       "measure after warm-up, shorten the run or model the drift")] + list(candidates)
    d = None if direction is None else np.asarray(direction).astype(str)
    if d is not None and {"cw", "ccw"} <= set(d.tolist()):
        col = np.zeros((m, 1))
        col[0::k, 0] = np.where(d == "cw", 0.5, -0.5) * w[0]
        cands.append(Candidate("cw-ccw", "CW/CCW consistency (offset between the two directions)", col,
                               ("CW - CCW offset",), (reading_units[0],),
                               "reversal error (backlash, servo mismatch) or a mislabelled run"))
    for c in cands:
        stat, q, beta, bias = added_variable(J, r, c.columns, s)
        if q == 0:
            continue
        clim = float(stats.chi2.isf(ALPHA, q))
        scale = span if c.key == "drift" else 1.0
        effects = ", ".join(f"{nm} {_fmt(b * scale, u)}" for nm, b, u in zip(c.names, beta, c.units) if b != 0)
        zb = float(np.max(np.abs(bias) / param_sigma)) if bias.size else 0.0
        findings.append(Finding(
            c.key, c.title, stat, clim, stat > clim,
            f"{c.key}: {effects} (chi2 {stat:.3g} > {clim:.3g} on {q} dof), biasing the parameters by up to "
            f"{zb:.3g} sigma: {c.advice}",
            {"effects": [{"name": nm, "value_um" if u == "m" else "value_urad": float(b * scale) * 1e6}
                         for nm, b, u in zip(c.names, beta, c.units)], "dof": q, "bias_max_sigma": zb}))

    runs = runs_of(d) if d is not None and n > 1 else []
    if len(runs) > 1:
        rss = r @ r
        for no, (a, b, dname) in enumerate(runs, 1):
            rr = r[a * k:b * k]
            nr, nrest = rr.size, m - rr.size
            f = float((rr @ rr / nr) / max((rss - rr @ rr) / nrest, 1e-300))
            flim = float(stats.f.isf(ALPHA / len(runs), nr, nrest))
            # standing out counts only where the run also misfits the stated noise (not among near-zero residuals)
            bad = f > flim and float(np.sum((rr / sigma_rows[a * k:b * k]) ** 2)) > stats.chi2.isf(ALPHA, nr)
            label = f"run {no} ({dname}, samples {a + 1}-{b}, t = {t[a]:.4g}-{t[b - 1]:.4g} s)"
            findings.append(Finding(
                "run", f"{label}: residual variance against the other runs (F test)", f, flim, bad,
                f"{label} stands out: its residual variance is {f:.3g}x that of the other runs",
                {"run": no, "direction": dname, "first_sample": a + 1, "last_sample": b,
                 "rms_um": float(np.sqrt(np.mean(rr ** 2))) * 1e6}))
            if chi2 > lim and refit_reversed is not None and no <= max_reversed:
                rrev = refit_reversed(a, b)
                if rrev is None:  # the reversed hypothesis could not even be identified
                    continue
                crev = float(np.sum((rrev / sigma_rows) ** 2))
                if crev < 0.25 * chi2:  # a reversed run explains at least 3/4 of the misfit
                    findings.append(Finding(
                        "reversed-run", f"{label}: readings in reverse order", crev / dof, 0.25 * chi2 / dof, True,
                        f"{label} is reversed or mislabelled: its readings fit the commanded poses in reverse order "
                        f"(residual RMS {np.sqrt(np.mean(r ** 2)) * 1e6:.3g} -> "
                        f"{np.sqrt(np.mean(rrev ** 2)) * 1e6:.3g} µm); check its direction label and sample order",
                        {"run": no, "rms_um": float(np.sqrt(np.mean(r ** 2))) * 1e6,
                         "rms_reversed_um": float(np.sqrt(np.mean(rrev ** 2))) * 1e6}))

    out = []
    for i in np.flatnonzero(flagged):
        out.append({"sample": int(i // k) + 1, "reading": reading_names[i % k], "t_s": float(t[i // k]),
                    "residual_um" if reading_units[i % k] == "m" else "residual_urad": float(raw[i] / w[i % k]) * 1e6,
                    "robust_z": float(abs(u[i] - med) / s_rob)})
        if robust_weights is not None:
            out[-1]["weight"] = float(robust_weights[i])
    big = max((o["robust_z"] for o in out), default=0.0)
    kept = [o for o in out if o.get("weight", 1.0) >= 0.5]  # outliers the fit still trusts
    first = "" if not out else (f", first sample {out[0]['sample']} (t = {out[0]['t_s']:.4g} s, "
                                f"{next(v for kk, v in out[0].items() if kk.startswith('residual')):+.3g} µm)")
    findings.append(Finding(
        "outliers", "single readings far off (robust z-score, Bonferroni)", big, z, bool(kept),
        f"{len(out)} outlier(s) beyond {z:.3g} robust sigma{first}"
        + (f", {len(out) - len(kept)} down-weighted by the robust fit" if robust_weights is not None else "")
        + ": remove them or identify with --robust huber|tukey",
        {"count": len(out), "robust_sigma_over_stated": s_rob}))
    return FitDiagnostics(tuple(findings), tuple(out), tuple(float(v) for v in sigma), tuple(reading_units))


__all__ = ["ALPHA", "Candidate", "Finding", "FitDiagnostics", "added_variable", "diagnose", "runs_of"]
