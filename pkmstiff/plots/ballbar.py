"""Ball-bar figures: the polar deviation plot and the harmonic spectrum (matplotlib ``Figure``, no backend switch).

The polar plot follows the usual ball-bar presentation: the nominal circle is a ring, the radial deviation is drawn
magnified about it (the radial axis is labelled in µm of deviation, not in radius), one trace per direction, the
filtered reconstruction (Szatmári §4.5.3) dashed over the raw readings.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pkmstiff.calibration.ballbar_diagnosis import axis_names
from pkmstiff.io.atomic import atomic_path, output_path

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from pkmstiff.calibration.ballbar import BallbarEvaluation
    from pkmstiff.calibration.ballbar_diagnosis import BallbarDiagnosis

_COLOURS = {"ccw": "tab:blue", "cw": "tab:red"}


def _nice_step(span: float) -> float:
    raw = span / 4.0
    mag = 10 ** math.floor(math.log10(raw)) if raw > 0 else 1.0
    for m in (1, 2, 2.5, 5, 10):
        if m * mag >= raw:
            return m * mag
    return 10 * mag


def polar_deviation_figure(ev: "BallbarEvaluation", *, title: str | None = None, show_filtered: bool = True,
                           max_points: int = 4000) -> "Figure":
    """Polar plot of the radial deviation [µm] of each run about the nominal circle (bold ring = 0 µm).

    The radial axis is offset so that the most negative deviation stays inside the plot: radius on paper =
    deviation − (lower limit). ``max_points`` thins long runs for drawing only.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10.0, 7.0))
    ax = fig.add_axes((0.08, 0.06, 0.52, 0.84), projection="polar")  # room for the 180° label
    devs = np.concatenate([r.deviation for r in ev.runs.values()]) * 1e6
    lo, hi, step = _radial_scale(devs)
    for lab, run in ev.runs.items():
        colour = _COLOURS.get(lab, "k")
        _trace(ax, run.theta, run.deviation, lo, max_points, color=colour, lw=0.8,
               alpha=0.55 if show_filtered else 1.0,
               label=f"{lab.upper()} readings (G = {run.circular_deviation * 1e6:.2f} µm)")
        if show_filtered:
            grid = np.linspace(0, 2 * np.pi, 721)
            f = run.harmonics.evaluate(grid, run.choice.n) * 1e6
            ax.plot(grid, f - lo, color=colour, lw=1.6, ls="--",
                    label=f"{lab.upper()} filtered, {run.choice.n} harmonic{'s' if run.choice.n != 1 else ''}")
    ring = np.linspace(0, 2 * np.pi, 361)
    ax.plot(ring, np.full_like(ring, -lo), color="k", lw=1.4, label="nominal circle (0 µm)")
    _polar_axes(ax, ev, lo, hi, step)
    lines = [f"bar {ev.bar_length * 1e3:g} mm, plane {ev.plane.name}", f"scale {step:g} µm/div", ""]
    for lab, run in ev.runs.items():
        tag = lab.upper() + ":"
        lines += [f"{tag:<5}G      {run.circular_deviation * 1e6:8.2f} µm",
                  f"     F max  {run.radial_deviation_max * 1e6:+8.2f} µm",
                  f"     F min  {run.radial_deviation_min * 1e6:+8.2f} µm",
                  f"     offset {np.linalg.norm(run.centre_offset) * 1e6:8.2f} µm",
                  f"     ΔR     {run.radius_deviation * 1e6:+8.2f} µm", ""]
    if ev.hysteresis is not None:
        lines.append(f"hysteresis H {ev.hysteresis * 1e6:.2f} µm")
    lines.append(f"circularity  {ev.circularity * 1e6:.2f} µm (LSQ)")
    lines.append(f"  min zone   {ev.circularity_min_zone * 1e6:.2f} µm")
    fig.suptitle(title or "Ball-bar circular test: radial deviation [µm]", fontsize=13, x=0.35)
    fig.legend(*ax.get_legend_handles_labels(), loc="upper left", bbox_to_anchor=(0.64, 0.93), fontsize=10,
               frameon=False)
    fig.text(0.65, 0.04, "\n".join(lines), fontsize=10, va="bottom", family="monospace")
    return fig


def diagnosis_figure(ev: "BallbarEvaluation", diag: "BallbarDiagnosis", *, title: str | None = None,
                     max_points: int = 4000) -> "Figure":
    """The diagnostics page: each run's deviation from its own least-squares circle (centre offset and radius
    removed, as ball-bar software shows a test) in a polar plot with the tolerance band ±T/2 about that circle
    (when ``diag.tolerance`` is set), beside the table of diagnosed sources (value ± σ, share of G;
    :func:`pkmstiff.calibration.ballbar_diagnosis.diagnose`)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12.0, 7.0))
    ax = fig.add_axes((0.05, 0.05, 0.45, 0.84), projection="polar")
    devs = np.concatenate([r.fit.residual for r in ev.runs.values()]) * 1e6
    tol_um = None if diag.tolerance is None else diag.tolerance * 1e6
    lo, hi, step = _radial_scale(devs if tol_um is None else np.append(devs, [-tol_um / 2, tol_um / 2]))
    ring = np.linspace(0, 2 * np.pi, 361)
    if tol_um is not None:
        ax.fill_between(ring, -tol_um / 2 - lo, tol_um / 2 - lo, color="tab:green", alpha=0.15, lw=0,
                        label=f"tolerance band ±{tol_um / 2:g} µm (T = {tol_um:g} µm)")
    for lab, run in ev.runs.items():
        verdict = "" if lab not in diag.passed else (" ≤ T" if diag.passed[lab] else " > T")
        _trace(ax, run.theta, run.fit.residual, lo, max_points, color=_COLOURS.get(lab, "k"), lw=1.0,
               label=f"{lab.upper()} (G = {run.circular_deviation * 1e6:.2f} µm{verdict})")
    ax.plot(ring, np.full_like(ring, -lo), color="k", lw=1.4, label="least-squares circle (0 µm)")
    _polar_axes(ax, ev, lo, hi, step)
    fig.legend(*ax.get_legend_handles_labels(), loc="upper left", bbox_to_anchor=(0.55, 0.93), fontsize=10,
               frameon=False)
    rows = [f"{'source':<22}{'value':>16}  {'share of G':>10}"]
    for src in diag.sources:
        val = f"{src.value:+.2f} ± {src.sigma:.2f}"
        rows.append(f"{src.label:<22}{val:>13} {src.unit:<5}{src.share * 100:7.0f} %")
    rows.append(f"{'unexplained (p-v)':<22}{diag.residual_pv * 1e6:>13.2f} {'µm':<5}{diag.residual_share * 100:7.0f} %")
    rows += [f"  {name}: not fitted, {why}" for name, why in diag.not_fitted.items()]
    rows += ["", f"bar {ev.bar_length * 1e3:g} mm, plane {ev.plane.name}, scale {step:g} µm/div",
             "share = peak-to-valley of the source / G of its run"]
    fig.text(0.55, 0.70, "\n".join(rows), fontsize=9.5, va="top", family="monospace")
    fig.suptitle(title or "Ball-bar diagnostics: deviation from the least-squares circle [µm]", fontsize=13, x=0.3)
    return fig


def _radial_scale(devs_um: np.ndarray) -> tuple[float, float, float]:
    """Radial limits (lo, hi) and division step [µm] of a polar deviation plot: about five divisions across the
    traces, two divisions inside the most negative point (limits the distortion of the offset radial axis)."""
    lo_d, hi_d = float(min(devs_um.min(), 0.0)), float(max(devs_um.max(), 0.0))
    span = max(hi_d - lo_d, 1e-3)
    step = _nice_step(span * 0.8)
    return math.floor(lo_d / step) * step - 2 * step, math.ceil(hi_d / step) * step + 0.5 * step, step


def _trace(ax, theta: np.ndarray, dev: np.ndarray, lo: float, max_points: int, **kw) -> None:
    """One run's deviation [m] drawn at radius deviation − lo [µm], sorted by angle and closed; thinned to
    ``max_points`` for drawing only."""
    order = np.argsort(np.mod(theta, 2 * np.pi))
    idx = order[::max(1, len(order) // max_points)]
    th = np.append(np.mod(theta[idx], 2 * np.pi), np.mod(theta[idx[0]], 2 * np.pi) + 2 * np.pi)
    ax.plot(th, np.append(dev[idx], dev[idx[0]]) * 1e6 - lo, **kw)


def _polar_axes(ax, ev: "BallbarEvaluation", lo: float, hi: float, step: float) -> None:
    """Radial ticks labelled in µm of deviation (whole µm when the step is: no "+4e+03"), angle ticks with the
    plane's axis names."""
    ax.set_ylim(0, hi - lo)
    ticks = np.arange(lo + step, hi + 1e-9, step)
    ax.set_yticks(ticks - lo)
    ax.set_yticklabels([("0" if abs(t) <= 1e-9 * step else f"{t:+.0f}" if step >= 1 else f"{t:+.3g}")
                        for t in ticks], fontsize=10)
    ax.set_rlabel_position(67.5)
    ax.set_xticks(np.radians(np.arange(0, 360, 45)))
    ax.grid(True, lw=0.4)
    e1, e2 = axis_names(ev)
    ax.set_xticklabels([f"0° (+{e1})", "45°", f"90° (+{e2})", "135°", f"180° (−{e1})", "225°", f"270° (−{e2})",
                        "315°"], fontsize=10)


def harmonic_spectrum_figure(ev: "BallbarEvaluation", *, n_show: int | None = None,
                             title: str | None = None) -> "Figure":
    """Bar chart of the harmonic amplitudes A_k [µm] (log scale) of each run, the noise threshold of the automatic
    choice and the kept harmonics (filled) against the rejected ones (hollow)."""
    from matplotlib.figure import Figure

    runs = list(ev.runs.values())
    fig = Figure(figsize=(7.5, 3.2 * len(runs)), layout="constrained")
    for i, run in enumerate(runs):
        ax = fig.add_subplot(len(runs), 1, i + 1)
        h, c = run.harmonics, run.choice
        top = n_show if n_show is not None else max(12, 2 * c.n + 4)
        top = min(top, h.n_max)
        k = np.arange(top + 1)
        amp = np.abs(h.amplitude[: top + 1]) * 1e6
        kept = k <= c.n
        colour = _COLOURS.get(run.direction, "k")
        ax.bar(k[kept], amp[kept], color=colour, width=0.7, label=f"kept (n = {c.n}, rule {c.rule})")
        ax.bar(k[~kept], amp[~kept], facecolor="none", edgecolor=colour, width=0.7, label="rejected")
        if not math.isnan(c.threshold):
            ax.axhline(c.threshold * 1e6, color="0.3", ls="--", lw=1,
                       label=f"noise threshold {c.threshold * 1e6:.3g} µm (α = {c.alpha:g})")
        ax.set_yscale("log")
        positive = amp[amp > 0]
        if positive.size:
            ax.set_ylim(max(positive.min() / 3, 1e-6), positive.max() * 3)
        ax.set_xlabel("harmonic k (A0 = |mean radius deviation|)")
        ax.set_ylabel("amplitude A_k [µm]")
        ax.set_xticks(k)
        ax.set_title(title or f"{run.direction.upper()} run: Fourier harmonics (Szatmári eq. 4.9/4.10)", fontsize=10)
        ax.legend(fontsize=9)
        ax.grid(True, axis="y", lw=0.3)
    return fig


def save_ballbar_figures(ev: "BallbarEvaluation", out_dir: str | Path, stem: str = "ballbar",
                         diag: "BallbarDiagnosis | None" = None) -> list[Path]:
    """Write ``<stem>_polar.png``, ``<stem>_spectrum.png`` and (with ``diag``) ``<stem>_diagnosis.png`` into
    ``out_dir``; returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figs = {"polar": polar_deviation_figure(ev), "spectrum": harmonic_spectrum_figure(ev)}
    if diag is not None:
        figs["diagnosis"] = diagnosis_figure(ev, diag)
    paths = [output_path(out, f"{stem}_{k}.png") for k in figs]
    for path, fig in zip(paths, figs.values()):
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=130)
    return paths
