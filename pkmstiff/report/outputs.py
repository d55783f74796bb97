"""Writing a section result to files: a PNG map per quantity, VTU/CSV/NPZ of all quantities, statistics JSON."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from pkmstiff.evaluation.sections import SectionResult, section_summary
from pkmstiff.io.atomic import atomic_write_text, output_path

#: a section with at least this many (raster points × quantities) shows progress while its files are written
WRITE_PROGRESS_VALUES = 200_000


def write_section_outputs(res: SectionResult, out: Path, formats, stem: str, progress: bool | None = None,
                          threads: int = 1) -> list[Path]:
    """PNG per quantity plus VTU/CSV/NPZ of all quantities and a statistics JSON. ``progress`` (None: for sections
    of at least :data:`WRITE_PROGRESS_VALUES` values) shows a bar on a terminal, else a line every 10 s, per file.
    ``threads`` > 1: the files are written at once on that many threads, the longest first (VTK's writer, zlib and
    the CSV's row kernel release the GIL; the PNGs one after another on one thread). Returns the paths in the order
    PNGs, VTU, CSV, NPZ, statistics."""
    from concurrent.futures import ThreadPoolExecutor, as_completed

    from pkmstiff.evaluation.export import to_csv, to_npz, to_vtk
    from pkmstiff.evaluation.progress import progress as with_progress

    out.mkdir(parents=True, exist_ok=True)
    writers = {"vtu": to_vtk, "csv": to_csv, "npz": to_npz}
    jobs: dict[str, Callable[[], list[Path]]] = {
        ext: (lambda w=w, ext=ext: [w(res, output_path(out, f"{stem}.{ext}"))]) for ext, w in writers.items()
        if ext in formats}
    if "png" in formats and res.values:
        from pkmstiff.plots.section_maps import plot_section

        jobs["png"] = lambda: [plot_section(res, n, output_path(out, f"{stem}_{n}.png")) for n in res.values]
    # the longest first (measured at 0.625 mm, one quantity: VTU 1.5, CSV 1.3, a PNG 1.2, NPZ 0.3 s)
    jobs = {k: jobs[k] for k in ("vtu", "csv", "png", "npz") if k in jobs}
    if progress is None:
        progress = res.ok.size * max(len(res.values), 1) >= WRITE_PROGRESS_VALUES
    with ThreadPoolExecutor(max(1, min(threads, len(jobs)))) as ex:
        done = {k: ex.submit(job) for k, job in jobs.items()}
        for _ in with_progress(as_completed(done.values()), progress, "writing", "file", total=len(done)):
            pass
        written = {k: f.result() for k, f in done.items()}
    paths = [p for k in ("png", *writers) if k in written for p in written[k]]
    stats = output_path(out, f"{stem}_statistics.json")
    atomic_write_text(stats, json.dumps(section_summary(res), indent=2))
    paths.append(stats)
    return paths
