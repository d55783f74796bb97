"""Diagnosis of a ball-bar circular test into the error sources commercial ball-bar software names (issue 26 item 8).

The classic circle error model (Kakino, Ihara & Shinohara, *Accuracy Inspection of NC Machine Tools by Double Ball
Bar Method*, Hanser 1993, ch. 3; Ziegert & Mize, *The laser ball bar*, Prec. Eng. 16 (1994); the set of sources as
in Renishaw's QC10/QC20 diagnostics): each axis error of the two axes e1, e2 of the test plane ("X", "Y" below; any
plane, θ measured from e1, ``dir`` = +1 for CCW and −1 for CW runs) moves the ball by a small vector whose radial
component adds to the reading. To first order in the errors (second-order terms are error²/R: below 1 nm for
errors of 20 µm on a 100 mm bar) the radial deviation is linear in the source values:

==========================  ==========================================  ==============================================
source (value, unit)        axis model                                  radial deviation ΔR(θ)
==========================  ==========================================  ==============================================
centre offset (e1, e2) [m]  set-up, per run                             e1 cos θ + e2 sin θ
radius deviation [m]        bar length / set-up, per run                ΔR0
scale mismatch [m/m]        x' = (1 + s_x) x, y' = (1 + s_y) y          R (s_x − s_y)/2 · cos 2θ   (value s_x − s_y)
squareness [rad]            x' = x + α y (axes closer than 90° by α)    R α/2 · sin 2θ
servo mismatch [s]          x lags by τ_x, y by τ_y (τ = τ_x − τ_y)     dir · R ω τ/2 · sin 2θ     (ω = feed/R)
backlash X, Y [m]           x' = x − b_x/2 · sign(ẋ)                    b_x/2 · dir · sign(sin θ) cos θ
                            y' = y − b_y/2 · sign(ẏ)                    −b_y/2 · dir · sign(cos θ) sin θ
lateral play X, Y [m]       y' = y + p_x/2 · sign(ẋ)                    −p_x/2 · dir · |sin θ|
                            x' = x + p_y/2 · sign(ẏ)                    p_y/2 · dir · |cos θ|
reversal spikes X, Y [m]    outward spike h e^(−φ/w) after a reversal   h · e^(−φ/w), φ = angle travelled since the
                            of the axis (w = ``spike_width``)           axis reversed (θ = 0°, 180° for X; 90°, 270° Y)
cyclic error X, Y [m]       x' = x + c_x sin(2π x/P + ψ) (lead P)       c_x sin(2π R cos θ/P + ψ) cos θ  (Y: sin θ)
==========================  ==========================================  ==============================================

The values come from one linear least-squares fit of all runs together (centre offset and radius per run: they are
the set-up, not the machine); σ from the residual scatter. Servo mismatch and lateral play change sign with the
direction: they are only separable from squareness and the radius with both directions (one direction: not fitted,
said in the note). Cyclic error needs the screw lead P (not fitted without it).

Each source's **share of G** is the peak-to-valley of its fitted ΔR on the run where it is largest, divided by that
run's circular deviation G: the part of the circle's out-of-roundness it alone would cause. Peak-to-valley values do
not add, so the shares do not sum to 100 %; the residual (what no source explains) is listed with its own share.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from pkmstiff.calibration.ballbar import BallbarEvaluation

__all__ = ["SPIKE_WIDTH", "BallbarDiagnosis", "DiagnosedSource", "axis_names", "diagnose"]

SPIKE_WIDTH = math.radians(3.0)  # decay angle w of a reversal spike (a few degrees of travel, as stick-slip shows)

Basis = Callable[[np.ndarray, float, float, float], np.ndarray]  # (θ, dir, R, lead) -> ΔR per unit value


def _spike(theta: np.ndarray, d: float, reversals: tuple[float, float], w: float) -> np.ndarray:
    phi = np.minimum(*(np.mod(d * (theta - r), 2 * np.pi) for r in reversals))
    return np.exp(-phi / w)


def _cyclic(theta: np.ndarray, R: float, lead: float, axis: int, phase: int) -> np.ndarray:
    c = np.cos(theta) if axis == 0 else np.sin(theta)
    arg = 2 * np.pi * R * c / lead
    return (np.cos(arg) if phase == 0 else np.sin(arg)) * c


# name, label, unit of the reported value, basis, needs both directions, needs the lead
_SOURCES: tuple[tuple[str, str, str, Basis, bool, bool], ...] = (
    ("scale_mismatch", "scale mismatch", "µm/m", lambda t, d, R, P: R / 2 * np.cos(2 * t), False, False),
    ("squareness", "squareness", "µm/m", lambda t, d, R, P: R / 2 * np.sin(2 * t), False, False),
    ("servo_mismatch", "servo mismatch", "ms", lambda t, d, R, P: d * R / 2 * np.sin(2 * t), True, False),
    ("backlash_1", "backlash {e1}", "µm", lambda t, d, R, P: 0.5 * d * np.sign(np.sin(t)) * np.cos(t), False, False),
    ("backlash_2", "backlash {e2}", "µm", lambda t, d, R, P: -0.5 * d * np.sign(np.cos(t)) * np.sin(t), False, False),
    ("lateral_play_1", "lateral play {e1}", "µm", lambda t, d, R, P: -0.5 * d * np.abs(np.sin(t)), True, False),
    ("lateral_play_2", "lateral play {e2}", "µm", lambda t, d, R, P: 0.5 * d * np.abs(np.cos(t)), True, False),
    ("reversal_spike_1", "reversal spikes {e1}", "µm",
     lambda t, d, R, P: _spike(t, d, (0.0, np.pi), SPIKE_WIDTH), False, False),
    ("reversal_spike_2", "reversal spikes {e2}", "µm",
     lambda t, d, R, P: _spike(t, d, (np.pi / 2, 3 * np.pi / 2), SPIKE_WIDTH), False, False),
    ("cyclic_1", "cyclic error {e1}", "µm", lambda t, d, R, P: _cyclic(t, R, P, 0, 0), False, True),
    ("cyclic_2", "cyclic error {e2}", "µm", lambda t, d, R, P: _cyclic(t, R, P, 1, 0), False, True),
)
_CYCLIC_SIN = {"cyclic_1": lambda t, d, R, P: _cyclic(t, R, P, 0, 1), "cyclic_2": lambda t, d, R, P: _cyclic(t, R, P, 1, 1)}


@dataclass(frozen=True)
class DiagnosedSource:
    """One diagnosed error source: ``value`` and ``sigma`` in ``unit`` (report units: µm, µm/m, ms), ``pv`` the
    peak-to-valley [m] of its radial deviation on the run where it is largest, ``share`` = pv / G of that run."""

    name: str
    label: str
    unit: str
    value: float
    sigma: float
    pv: float
    share: float


@dataclass(frozen=True)
class BallbarDiagnosis:
    """The diagnosed sources, largest share first; ``residual_pv`` [m] and ``residual_share`` of what no source
    explains; ``residual_rms`` [m]; ``tolerance`` [m] (or None) with ``passed`` per run (G ≤ tolerance);
    ``not_fitted`` the sources left out (label -> reason)."""

    sources: list[DiagnosedSource]
    residual_rms: float
    residual_pv: float
    residual_share: float
    G: dict[str, float]
    tolerance: float | None
    passed: dict[str, bool]
    not_fitted: dict[str, str]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready; keys name their units."""
        return {
            "sources": [{"name": s.name, "label": s.label, "unit": s.unit, "value": s.value, "sigma": s.sigma,
                         "pv_um": s.pv * 1e6, "share_of_G_percent": s.share * 100} for s in self.sources],
            "residual_rms_um": self.residual_rms * 1e6,
            "residual_pv_um": self.residual_pv * 1e6,
            "residual_share_of_G_percent": self.residual_share * 100,
            "tolerance_um": None if self.tolerance is None else self.tolerance * 1e6,
            "passed": dict(self.passed),
            "not_fitted": dict(self.not_fitted),
        }


def diagnose(ev: "BallbarEvaluation", *, tolerance: float | None = None, lead: float | None = None,
             feed: float | None = None) -> BallbarDiagnosis:
    """Fit the classic circle error model (module docstring) to the runs of ``ev``.

    ``tolerance`` [m] on G; ``lead`` [m] of the axis screws (cyclic error; None: not fitted); ``feed`` [m/s] of the
    test (servo mismatch as a time in ms; None: reported as the amplitude R ω τ/2 in µm instead).
    """
    from pkmstiff.errors import InputError

    runs = ev.runs
    both = len(runs) == 2
    not_fitted: dict[str, str] = {}
    e1, e2 = axis_names(ev)
    cols: list[tuple[str, str, str, Basis]] = []
    for name, label, unit, f, need_both, need_lead in _SOURCES:
        label = label.format(e1=e1, e2=e2)
        if need_both and not both:
            not_fitted[label] = "needs runs in both directions"
        elif need_lead and lead is None:
            not_fitted[label] = "needs the screw lead"
        else:
            cols.append((name, label, unit, f))
            if name in _CYCLIC_SIN:
                cols.append((name + "_sin", "", unit, _CYCLIC_SIN[name]))
    if lead is not None and not lead > 0:
        raise InputError(reason=f"the screw lead must be positive, found {lead} m")
    labels = list(runs)
    n_run = 3 * len(labels)  # radius and centre offset per run
    blocks, ys = [], []
    for i, lab in enumerate(labels):
        r = runs[lab]
        t, d, R = r.theta, 1.0 if lab == "ccw" else -1.0, r.radius_nominal
        A = np.zeros((t.size, n_run + len(cols)))
        A[:, 3 * i:3 * i + 3] = np.column_stack([np.ones_like(t), np.cos(t), np.sin(t)])
        for j, (_, _, _, f) in enumerate(cols):
            A[:, n_run + j] = f(t, d, R, lead if lead is not None else 1.0)
        blocks.append(A)
        ys.append(r.deviation)
    A, y = np.vstack(blocks), np.concatenate(ys)
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    coef, *_ = np.linalg.lstsq(A / scale, y, rcond=None)
    coef = coef / scale
    res = y - A @ coef
    dof = max(y.size - A.shape[1], 1)
    s2 = float(res @ res) / dof
    cov = s2 * np.linalg.pinv((A / scale).T @ (A / scale)) / np.outer(scale, scale)
    sig = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    G = {lab: runs[lab].circular_deviation for lab in labels}
    splits = np.cumsum([b.shape[0] for b in blocks])[:-1]

    def pv_share(contrib: np.ndarray) -> tuple[float, float]:
        best = (0.0, 0.0)
        for lab, part in zip(labels, np.split(contrib, splits)):
            pv = float(part.max() - part.min()) if part.size else 0.0
            if pv > best[0]:
                best = (pv, pv / G[lab] if G[lab] > 0 else math.inf)
        return best

    sources = []
    j = 0
    while j < len(cols):
        name, label, unit, _ = cols[j]
        idx = [n_run + j]
        if j + 1 < len(cols) and cols[j + 1][0] == name + "_sin":
            idx.append(n_run + j + 1)
            j += 1
        j += 1
        contrib = A[:, idx] @ coef[idx]
        pv, share = pv_share(contrib)
        value, sigma = _report_value(name, coef[idx], sig[idx], cov[np.ix_(idx, idx)], ev, feed)
        if name == "servo_mismatch" and feed is None:
            unit = "µm"
        sources.append(DiagnosedSource(name, label, unit, value, sigma, pv, share))
    sources.sort(key=lambda s: -s.pv)
    rpv, rshare = pv_share(res)
    passed = {lab: bool(g <= tolerance) for lab, g in G.items()} if tolerance is not None else {}
    return BallbarDiagnosis(sources, float(np.sqrt(np.mean(res**2))), rpv, rshare, G, tolerance, passed, not_fitted)


def _report_value(name: str, c: np.ndarray, s: np.ndarray, cov: np.ndarray, ev: "BallbarEvaluation",
                  feed: float | None) -> tuple[float, float]:
    """Coefficient → reported value and σ in the report unit."""
    if name in ("scale_mismatch", "squareness"):
        return float(c[0]) * 1e6, float(s[0]) * 1e6  # m/m -> µm/m
    if name == "servo_mismatch":
        if feed is None:  # amplitude R ω τ/2 of the sin 2θ term [µm] (the coefficient is ω τ)
            R = np.mean([r.radius_nominal for r in ev.runs.values()])
            return float(c[0]) * R / 2 * 1e6, float(s[0]) * R / 2 * 1e6
        R = np.mean([r.radius_nominal for r in ev.runs.values()])
        omega = feed / R
        return float(c[0]) / omega * 1e3, float(s[0]) / omega * 1e3  # s -> ms
    if len(c) == 2:  # cyclic: amplitude sqrt(a² + b²), σ by first-order propagation
        amp = float(np.hypot(*c))
        g = c / amp if amp > 0 else np.array([1.0, 0.0])
        return amp * 1e6, float(np.sqrt(max(g @ cov @ g, 0.0))) * 1e6
    return float(c[0]) * 1e6, float(s[0]) * 1e6


def axis_names(ev: "BallbarEvaluation") -> tuple[str, str]:
    """The names of the plane's axes e1, e2 ("X", "Y" for an XY test; "e1", "e2" for an oblique plane)."""
    names = {"XY": ("X", "Y"), "YZ": ("Y", "Z"), "ZX": ("Z", "X"), "XZ": ("X", "Z")}
    return names.get(ev.plane.name, ("e1", "e2"))
