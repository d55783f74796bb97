"""Shared helpers of the design-study scripts in ``studies/`` (issue 8).

Small and stable on purpose (used by several study scripts): command-line arguments, statistics rows with the
relative deviation, a side-by-side map figure with a shared colour scale (matplotlib), the machine file's
assumptions for a report, and writing the report. SI units inside; the display units (N/µm, mm, deg, Hz) are
named wherever a value leaves a function.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np

import pkmstiff
from pkmstiff import ColourScale, robust_clim

STAT_KEYS = ("max", "mean", "min")


def parse_args(argv: Sequence[str] | None, letter: str, description: str) -> argparse.Namespace:
    """``--out DIR`` (default ``out/studies/<letter>``) and ``--fast`` (coarse resolution for CI)."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--out", type=Path, default=Path("out") / "studies" / letter, help="output directory")
    ap.add_argument("--fast", action="store_true", help="coarse resolution (CI smoke run)")
    return ap.parse_args(argv)


def relative_deviation_percent(value: float, baseline: float) -> float:
    """(value − baseline) / baseline in % (NaN for a zero or non-finite baseline)."""
    if not np.isfinite(baseline) or baseline == 0.0:
        return float("nan")
    return 100.0 * (float(value) - float(baseline)) / float(baseline)


def common_mask(results: Iterable[pkmstiff.SectionMap]) -> np.ndarray:
    """Raster points admissible in every result (variants are compared on the same points)."""
    masks = [r.ok for r in results]
    return np.logical_and.reduce(masks) if masks else np.zeros(0, bool)


def masked_stats(values: np.ndarray, mask: np.ndarray) -> dict[str, float]:
    """min/mean/max and count of the finite ``values`` where ``mask`` is true (unit of ``values``)."""
    v = values[mask]
    v = v[np.isfinite(v)]
    if not v.size:
        return {"min": float("nan"), "mean": float("nan"), "max": float("nan"), "count": 0}
    return {"min": float(v.min()), "mean": float(v.mean()), "max": float(v.max()), "count": int(v.size)}


def add_stat_rows(table: pkmstiff.Table, label: str, unit: str, stats: Sequence[dict[str, float]],
                  keys: Iterable[str] = STAT_KEYS) -> None:
    """One row per statistic (``"<label> max"`` …), one value per table column from ``stats`` (same order)."""
    for key in keys:
        table.add(f"{label} {key}", unit, [s[key] for s in stats])


def machine_assumptions(*machines: pkmstiff.Machine) -> dict[str, str]:
    """The machine files' ``[assumptions]`` (including those of selected options) for a report, without repeats.

    Keys are prefixed by the machine's base name (``"hexaglide: tool"``); an entry that differs between variants
    of the same file is prefixed by the variant's full name (``"hexaglide:old_joints_fe: …"``).
    """
    out: dict[str, str] = {}
    for m in machines:
        base = m.name.split(":", 1)[0]
        for k, v in m.assumptions.items():
            key = f"{base}: {k}"
            if out.get(key, v) != v:
                key = f"{m.name}: {k}"
            out[key] = v
    return out


@dataclass
class MapPanel:
    """One map of a side-by-side figure: values (nv, nu) in ``unit`` on ``res.plane``; NaN = not shown."""

    res: pkmstiff.SectionMap
    values: np.ndarray
    title: str
    unit: str
    cmap: str = "viridis"
    clim: tuple[float, float] | ColourScale | None = None


def shared_clim(*arrays: np.ndarray) -> ColourScale:
    """Common colour scale over the finite values of all arrays: min..max, or logarithmic / cut at a percentile
    where one hot spot would flatten the rest (pkmstiff.robust_clim; the colour bar says so)."""
    return robust_clim(*arrays)


def symmetric_clim(values: np.ndarray, percentile: float = 100.0) -> tuple[float, float]:
    """Colour limits symmetric about zero (for relative deviations), at a percentile of |values| (100 = max)."""
    finite = np.abs(values[np.isfinite(values)])
    m = float(np.percentile(finite, percentile)) if finite.size else 1.0
    return (-m, m) if m > 0 else (-1.0, 1.0)


def deviation_colours(rel: np.ndarray, percentile: float = 100.0) -> tuple[str, tuple[float, float]]:
    """Colour map and limits for a relative-deviation map: sequential from 0 if one-sided, else diverging."""
    finite = rel[np.isfinite(rel)]
    if finite.size and finite.min() >= 0.0:
        return "YlOrRd", (0.0, float(np.percentile(finite, percentile)) or 1.0)
    if finite.size and finite.max() <= 0.0:
        return "YlGnBu_r", (-float(np.percentile(-finite, percentile)) or -1.0, 0.0)
    return "RdBu_r", symmetric_clim(rel, percentile)


def plot_maps(panels: Sequence[MapPanel], path: str | Path, title: str, ncols: int | None = None) -> Path:
    """PNG with the panels side by side: colour map (positions of O' in mm), admissible outline, colour bar each."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ncols = ncols or len(panels)
    nrows = int(np.ceil(len(panels) / ncols))
    p0 = panels[0].res.plane
    aspect = (p0.v_values[-1] - p0.v_values[0]) / (p0.u_values[-1] - p0.u_values[0])
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.6 * ncols, 0.8 + 4.0 * aspect * nrows + 0.4), squeeze=False,
                             constrained_layout=True)
    for ax in axes.ravel()[len(panels):]:
        ax.set_visible(False)
    for ax, pan in zip(axes.ravel(), panels):
        pl = pan.res.plane
        u, v = pl.u_values * 1e3, pl.v_values * 1e3
        scale = pan.clim if isinstance(pan.clim, ColourScale) else \
            ColourScale(*pan.clim) if pan.clim is not None else shared_clim(pan.values)
        clim = (scale.lo, scale.hi)
        mesh = ax.pcolormesh(u, v, np.ma.masked_invalid(pan.values), cmap=pan.cmap, norm=scale.norm(),
                             shading="nearest", rasterized=True)
        if pan.res.ok.any() and not pan.res.ok.all():
            ax.contour(u, v, pan.res.ok.astype(float), levels=[0.5], colors="black", linewidths=1.0)
        ax.set_aspect("equal")
        ax.set_xlabel(f"{pl.u_name} [mm]")
        ax.set_ylabel(f"{pl.v_name} [mm]")
        ax.set_title(pan.title, fontsize=10)
        cb = fig.colorbar(mesh, ax=ax, shrink=0.85, extend=scale.extend(pan.values))
        scale.label_colorbar(cb, pan.unit.replace("urad", "µrad").replace("um", "µm"))
    fig.suptitle(title, fontsize=11)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_outputs(report: pkmstiff.Report, out_dir: Path, results: dict[str, Any]) -> dict[str, Path]:
    """Write ``report.html`` / ``report.md`` (pkmstiff.report.write_report) and ``results.json`` (key numbers)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "results.json").write_text(json.dumps(results, indent=2, default=_json_default), encoding="utf-8")
    paths = pkmstiff.write_report(report, out_dir)
    return {k: Path(v) for k, v in paths.items()}


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


class Stopwatch:
    """Wall-clock time since construction (s); ``lap(name)`` records named intervals for the report settings."""

    def __init__(self) -> None:
        self.start = self._last = time.perf_counter()
        self.laps: dict[str, float] = {}

    def lap(self, name: str) -> float:
        now = time.perf_counter()
        self.laps[name] = round(now - self._last, 2)
        self._last = now
        return self.laps[name]

    @property
    def total(self) -> float:
        return round(time.perf_counter() - self.start, 2)
