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

from pkmstiff.io.atomic import atomic_path, output_path

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from pkmstiff.calibration.ballbar import BallbarEvaluation

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
    lo_d, hi_d = float(min(devs.min(), 0.0)), float(max(devs.max(), 0.0))
    span = max(hi_d - lo_d, 1e-3)
    step = _nice_step(span * 0.8)  # about five divisions across the traces
    lo = math.floor(lo_d / step) * step - 2 * step  # two divisions inside the most negative point: limits distortion
    hi = math.ceil(hi_d / step) * step + 0.5 * step
    for lab, run in ev.runs.items():
        order = np.argsort(np.mod(run.theta, 2 * np.pi))
        every = max(1, len(order) // max_points)
        idx = order[::every]
        th = np.append(np.mod(run.theta[idx], 2 * np.pi), np.mod(run.theta[idx[0]], 2 * np.pi) + 2 * np.pi)
        d = np.append(run.deviation[idx], run.deviation[idx[0]]) * 1e6
        colour = _COLOURS.get(lab, "k")
        ax.plot(th, d - lo, color=colour, lw=0.8, alpha=0.55 if show_filtered else 1.0,
                label=f"{lab.upper()} readings (G = {run.circular_deviation * 1e6:.2f} µm)")
        if show_filtered:
            grid = np.linspace(0, 2 * np.pi, 721)
            f = run.harmonics.evaluate(grid, run.choice.n) * 1e6
            ax.plot(grid, f - lo, color=colour, lw=1.6, ls="--",
                    label=f"{lab.upper()} filtered, {run.choice.n} harmonic{'s' if run.choice.n != 1 else ''}")
    ring = np.linspace(0, 2 * np.pi, 361)
    ax.plot(ring, np.full_like(ring, -lo), color="k", lw=1.4, label="nominal circle (0 µm)")
    ax.set_ylim(0, hi - lo)
    ticks = np.arange(lo + step, hi + 1e-9, step)
    ax.set_yticks(ticks - lo)
    ax.set_yticklabels([("0" if abs(t) <= 1e-9 * step else f"{t:+.0f}" if step >= 1 else f"{t:+.3g}")
                        for t in ticks], fontsize=10)  # whole µm when the step is (no "+4e+03")
    ax.set_rlabel_position(67.5)
    ax.set_xticks(np.radians(np.arange(0, 360, 45)))
    ax.grid(True, lw=0.4)
    e1, e2 = _axis_names(ev)
    ax.set_xticklabels([f"0° (+{e1})", "45°", f"90° (+{e2})", "135°", f"180° (−{e1})", "225°", f"270° (−{e2})",
                        "315°"], fontsize=10)
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


def _axis_names(ev: "BallbarEvaluation") -> tuple[str, str]:
    names = {"XY": ("X", "Y"), "YZ": ("Y", "Z"), "ZX": ("Z", "X"), "XZ": ("X", "Z")}
    return names.get(ev.plane.name, ("e1", "e2"))


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


def save_ballbar_figures(ev: "BallbarEvaluation", out_dir: str | Path, stem: str = "ballbar") -> list[Path]:
    """Write ``<stem>_polar.png`` and ``<stem>_spectrum.png`` into ``out_dir``; returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [output_path(out, f"{stem}_polar.png"), output_path(out, f"{stem}_spectrum.png")]
    for path, fig in zip(paths, (polar_deviation_figure(ev), harmonic_spectrum_figure(ev))):
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=130)
    return paths
