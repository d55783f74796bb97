"""Export of section results: VTK (.vtu, ParaView), CSV and NPZ, each with metadata and units.

Coordinates are written in mm and quantities in their display units; columns and arrays are named by one rule,
``<name>_<unit>`` (:func:`pkmstiff.io.columns.column_name`: ``x_mm``, ``kx_N_per_um``, ``kappa``). The CSV holds only
the table (``pandas.read_csv(path)`` reads it with no options); the metadata go to ``<name>.json`` beside the CSV or
VTU and into the NPZ (``metadata``). Inadmissible points hold NaN (an empty CSV cell); the reason code (bit mask of
:class:`pkmstiff.admissibility.checks.Reason`) and the admissibility flag are exported too.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from pkmstiff.admissibility.checks import Reason
from pkmstiff.evaluation.sections import SectionResult
from pkmstiff.io.atomic import atomic_open, atomic_path, atomic_write_text
from pkmstiff.io.columns import column_name
from pkmstiff.io.columns import sidecar_path as metadata_path  # the name this module's users import

MM = 1e3


def _columns(res: SectionResult) -> dict[str, np.ndarray]:
    pts = res.plane.points() * MM
    uu, vv = np.meshgrid(res.plane.u_values * MM, res.plane.v_values * MM)
    cols = {"x_mm": pts[:, 0], "y_mm": pts[:, 1], "z_mm": pts[:, 2], "u_mm": uu.ravel(), "v_mm": vv.ravel(),
            "admissible": res.ok.ravel().astype(int), "reason_code": res.reasons.ravel().astype(int)}
    for name in res.values:
        cols[column_name(name, res.units[name])] = res.display(name).ravel()
    return cols


def _metadata(res: SectionResult) -> dict:
    meta = res.metadata()
    meta["reason_bits"] = {r.name: int(r) for r in Reason}
    meta["coordinates_unit"] = "mm"
    meta["plane_axes"] = {"u_mm": res.plane.u_name, "v_mm": res.plane.v_name}  # the in-plane coordinate columns
    meta["columns"] = {column_name(n, res.units[n]): {"quantity": n, "unit": res.units[n]} for n in res.values}
    return meta


def to_vtk(res: SectionResult, path: str | Path) -> Path:
    """Write a ``.vtu`` grid of quad cells (points in mm, one point array per quantity, named with its unit) for
    ParaView; the metadata go to a JSON file beside it (``<name>.json``). Written and readable by meshio."""
    import meshio

    nv, nu = res.plane.shape
    idx = np.arange(nv * nu).reshape(nv, nu)
    quads = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], axis=-1).reshape(-1, 4)
    data = {k: np.asarray(v, float) for k, v in _columns(res).items() if k not in ("x_mm", "y_mm", "z_mm")}
    path = Path(path)
    if path.suffix != ".vtu":
        path = path.with_suffix(".vtu")
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        meshio.write(tmp, meshio.Mesh(res.plane.points() * MM, [("quad", quads)], point_data=data))
    atomic_write_text(metadata_path(path), json.dumps(_metadata(res), indent=2))
    return path


def to_csv(res: SectionResult, path: str | Path) -> Path:
    """Write a CSV (a header row, then one row per raster point) and its metadata to ``<name>.json``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    cols = _columns(res)
    atomic_write_text(metadata_path(path), json.dumps(_metadata(res), indent=2))
    with atomic_open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(list(cols))
        for row in zip(*cols.values()):
            w.writerow(["" if isinstance(x, float) and np.isnan(x) else f"{x:.10g}" for x in row])
    return path


def to_npz(res: SectionResult, path: str | Path) -> Path:
    """Write an NPZ: grids (nv, nu) per quantity in display units, ``u_mm``, ``v_mm``, ``ok``, ``reasons`` and
    ``metadata`` (a JSON string)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {column_name(n, res.units[n]): res.display(n) for n in res.values}
    with atomic_path(path) as tmp:
        np.savez_compressed(tmp, u_mm=res.plane.u_values * MM, v_mm=res.plane.v_values * MM, ok=res.ok,
                            reasons=res.reasons, metadata=json.dumps(_metadata(res)), **arrays)
    return path
