"""Writing a section result to files: a PNG map per quantity, VTU/CSV/NPZ of all quantities, statistics JSON."""

from __future__ import annotations

import json
from pathlib import Path

from pkmstiff.evaluation.sections import SectionResult, section_summary
from pkmstiff.io.atomic import atomic_write_text, output_path

#: a section with at least this many (raster points × quantities) shows progress while its files are written
WRITE_PROGRESS_VALUES = 200_000


def write_section_outputs(res: SectionResult, out: Path, formats, stem: str, progress: bool | None = None
                          ) -> list[Path]:
    """PNG per quantity plus VTU/CSV/NPZ of all quantities and a statistics JSON. ``progress`` (None: for sections
    of at least :data:`WRITE_PROGRESS_VALUES` values) shows a bar on a terminal, else a line every 10 s, per file."""
    from pkmstiff.evaluation.export import to_csv, to_npz, to_vtk
    from pkmstiff.evaluation.progress import progress as with_progress

    out.mkdir(parents=True, exist_ok=True)
    jobs: list = []
    if "png" in formats:
        from pkmstiff.plots.section_maps import plot_section

        jobs += [(lambda n=n: plot_section(res, n, output_path(out, f"{stem}_{n}.png"))) for n in res.values]
    writers = {"vtu": to_vtk, "csv": to_csv, "npz": to_npz}
    jobs += [(lambda w=w, ext=ext: w(res, output_path(out, f"{stem}.{ext}"))) for ext, w in writers.items()
             if ext in formats]
    if progress is None:
        progress = res.ok.size * max(len(res.values), 1) >= WRITE_PROGRESS_VALUES
    paths = [job() for job in with_progress(jobs, progress, "writing", "file")]
    stats = output_path(out, f"{stem}_statistics.json")
    atomic_write_text(stats, json.dumps(section_summary(res), indent=2))
    paths.append(stats)
    return paths
