"""Writing a section result to files: a PNG map per quantity, VTU/CSV/NPZ of all quantities, statistics JSON."""

from __future__ import annotations

import json
from pathlib import Path

from pkmstiff.evaluation.sections import SectionResult, section_summary
from pkmstiff.io.atomic import atomic_write_text, output_path


def write_section_outputs(res: SectionResult, out: Path, formats, stem: str) -> list[Path]:
    """PNG per quantity plus VTU/CSV/NPZ of all quantities and a statistics JSON."""
    from pkmstiff.evaluation.export import to_csv, to_npz, to_vtk

    paths = []
    out.mkdir(parents=True, exist_ok=True)
    if "png" in formats:
        from pkmstiff.plots.section_maps import plot_section

        paths += [plot_section(res, n, output_path(out, f"{stem}_{n}.png")) for n in res.values]
    if "vtu" in formats:
        paths.append(to_vtk(res, output_path(out, f"{stem}.vtu")))
    if "csv" in formats:
        paths.append(to_csv(res, output_path(out, f"{stem}.csv")))
    if "npz" in formats:
        paths.append(to_npz(res, output_path(out, f"{stem}.npz")))
    stats = output_path(out, f"{stem}_statistics.json")
    atomic_write_text(stats, json.dumps(section_summary(res), indent=2))
    paths.append(stats)
    return paths
