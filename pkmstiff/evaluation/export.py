"""Export of section results: VTK (.vtu, ParaView), CSV and NPZ, each with metadata and units.

Coordinates are written in mm and quantities in their display units; columns and arrays are named by one rule,
``<name>_<unit>`` (:func:`pkmstiff.io.columns.column_name`: ``x_mm``, ``kx_N_per_um``, ``kappa``). The CSV holds only
the table (``pandas.read_csv(path)`` reads it with no options); the metadata go to ``<name>.json`` beside the CSV or
VTU and into the NPZ (``metadata``). Inadmissible points hold NaN (an empty CSV cell); the reason code (bit mask of
:class:`pkmstiff.admissibility.checks.Reason`) and the admissibility flag are exported too.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pkmstiff.admissibility.checks import Reason
from pkmstiff.evaluation.sections import SectionResult
from pkmstiff.io.atomic import atomic_open, atomic_path, atomic_write_text
from pkmstiff.io.columns import column_name
from pkmstiff.io.columns import sidecar_path as metadata_path  # the name this module's users import
from pkmstiff.io.numeric_csv import write_numeric_csv
from pkmstiff.io.vtk_xml import write_vtk_xml

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
    ParaView (:func:`pkmstiff.io.vtk_xml.write_vtk_xml`); the metadata go to a JSON file beside it
    (``<name>.json``). Readable by meshio."""
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonCore import vtkPoints
    from vtkmodules.vtkCommonDataModel import VTK_QUAD, vtkCellArray, vtkUnstructuredGrid

    nv, nu = res.plane.shape
    idx = np.arange(nv * nu).reshape(nv, nu)
    quads = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], axis=-1).reshape(-1)
    grid = vtkUnstructuredGrid()  # numpy_to_vtk keeps a reference to each array it wraps
    pts = vtkPoints()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(res.plane.points() * MM)))
    grid.SetPoints(pts)
    cells = vtkCellArray()
    cells.SetData(numpy_to_vtk(np.arange(0, quads.size + 1, 4, dtype=np.int64)),
                  numpy_to_vtk(np.ascontiguousarray(quads, np.int64)))
    grid.SetCells(VTK_QUAD, cells)
    for k, v in _columns(res).items():
        if k not in ("x_mm", "y_mm", "z_mm"):
            arr = numpy_to_vtk(np.ascontiguousarray(v, float))
            arr.SetName(k)
            grid.GetPointData().AddArray(arr)
    path = Path(path)
    if path.suffix != ".vtu":
        path = path.with_suffix(".vtu")
    path.parent.mkdir(parents=True, exist_ok=True)
    write_vtk_xml(grid, path)
    atomic_write_text(metadata_path(path), json.dumps(_metadata(res), indent=2))
    return path


def to_csv(res: SectionResult, path: str | Path) -> Path:
    """Write a CSV (a header row, then one row per raster point) and its metadata to ``<name>.json``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    cols = _columns(res)
    atomic_write_text(metadata_path(path), json.dumps(_metadata(res), indent=2))
    with atomic_open(path, "wb") as fh:
        write_numeric_csv(fh, list(cols), list(cols.values()), ".10g")
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
