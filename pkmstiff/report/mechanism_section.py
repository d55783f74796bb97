"""Writing a mechanism section (:class:`pkmstiff.mechanisms.section.MechanismSection`) to files: the files of
``pkmstiff section MECHANISM --out`` (also the app's export)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.io.atomic import atomic_path, output_path
from pkmstiff.io.columns import column_name


def section_where(mech, plane: str, at_mm: float, orientation, tool_length_mm: float | None) -> dict[str, Any]:
    """Where a mechanism section lies, as its CSV metadata and JSON summary state it (mm, degrees; ``at_mm`` None
    for a planar mechanism, ``tool_length_mm`` only where a tool tip was given)."""
    where = {"mechanism": mech.name, "plane": plane, "at_mm": None if mech.dim == 2 else at_mm,
             "orientation_deg": [float(np.degrees(a)) for a in orientation]}
    if tool_length_mm is not None:
        where["tool_length_mm"] = float(tool_length_mm)
    return where


def write_mechanism_section(sec, out: Path, stem: str, formats: list[str], where: dict[str, Any]) -> list[Path]:
    """PNG maps (each quantity and the admissibility reasons), CSV (with ``where``, the units and the reason bits in
    ``<stem>.json`` beside it) and NPZ of a mechanism section in ``out``."""

    paths = []
    out.mkdir(parents=True, exist_ok=True)
    if "png" in formats:
        from pkmstiff.plots.mechanism_section import plot_mechanism_quantity, plot_mechanism_reasons

        paths += [plot_mechanism_quantity(sec, n, output_path(out, f"{stem}_{n}.png")) for n in sec.values]
        paths.append(plot_mechanism_reasons(sec, output_path(out, f"{stem}_admissibility.png")))
    U, V = np.meshgrid(sec.u_values, sec.v_values)
    u, v = sec.plane[0], sec.plane[1]
    if "csv" in formats:
        from pkmstiff.io.columns import write_table
        from pkmstiff.mechanisms.evaluate import REASONS

        p = output_path(out, f"{stem}.csv")
        cols = [sec.display(n).ravel() for n in sec.values]
        rows = ([U.flat[i] * 1e3, V.flat[i] * 1e3, str(sec.status.flat[i]), int(sec.reasons.flat[i]),
                 int(sec.ok.flat[i])] + [float(c[i]) for c in cols] for i in range(U.size))
        meta = {**where,
                "units": {column_name(n, sec.units[n]): sec.units[n] for n in sec.values},
                "reasons": {"meaning": "bit mask of the inadmissibility reasons (0 = admissible)",
                            "bits": {k: int(b) for k, b in REASONS.items()}},
                "empty_cells": "no value (inadmissible point)"}
        write_table(p, [f"{u}_mm", f"{v}_mm", "status", "reasons", "admissible"]
                    + [column_name(n, sec.units[n]) for n in sec.values], rows, meta, ".6g")
        paths.append(p)
    if "npz" in formats:
        p = output_path(out, f"{stem}.npz")
        with atomic_path(p) as tmp:
            np.savez_compressed(tmp, **{f"{u}_mm": sec.u_values * 1e3, f"{v}_mm": sec.v_values * 1e3,
                                        "reasons": sec.reasons, "admissible": sec.ok},
                                **{column_name(n, sec.units[n]): sec.display(n) for n in sec.values})
        paths.append(p)
    return paths
