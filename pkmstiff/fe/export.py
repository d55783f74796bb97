"""Output of FE results: joint-stiffness tables (CSV with provenance) and meshes / deformed shapes (VTU).

The joint table is written with the component library's writer
:func:`components.joint_tables.write_joint_table` (format: README "Joint stiffness tables"), so the file
is validated exactly as the loader will read it. Units at this edge: angles in degrees, stiffness in N/µm
(the writer converts from N/m), lengths in the VTU files in m, displacements in m.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import metadata as importlib_metadata
from pathlib import Path
from typing import Any

import meshio
import numpy as np

from components.joint_tables import write_joint_table
from pkmstiff.fe.assembly import PartModel, Solution
from pkmstiff.fe.joints import SweepResult, element_label, tie_tolerance
from pkmstiff.io.atomic import atomic_path

# VTK hexahedron vertex order expressed in skfem's MeshHex order (V000, V010, V100, V001, V110, V011, V101, V111)
_SKFEM_TO_VTK_HEX = np.array([0, 2, 4, 1, 3, 6, 7, 5])


def versions() -> str:
    """Version string of pkmstiff and the FE libraries (provenance)."""
    out = []
    for pkg in ("pkmstiff", "scikit-fem", "numpy", "scipy"):
        try:
            out.append(f"{pkg} {importlib_metadata.version(pkg)}")
        except importlib_metadata.PackageNotFoundError:
            if pkg == "pkmstiff":
                from pkmstiff import __version__

                out.append(f"pkmstiff {__version__}")
    return ", ".join(out)


def table_metadata(result: SweepResult, name: str | None = None) -> dict[str, str]:
    """Provenance lines of a joint table (keys required by the component library for FE tables)."""
    p = result.params
    src = Path(p.source).name
    force = float(p["load"]["force"])
    notes = "; ".join(f"{k}: {v}" for k, v in p.assumptions.items())
    return {
        "name": name or f"{p.name}_fe",
        "source": f"pkmstiff FE sweep (scikit-fem), parameters {src}",
        "method": "FE",
        "quantity": "axial stiffness along the strut",
        "angle_convention": "axis",
        "load": (f"{force:g} N along the strut at the strut-side connection end (RBE2 reference point, moments "
                 "zero); linear model, stiffness independent of the load"),
        "parameters": json.dumps(p.raw, sort_keys=True, ensure_ascii=False, separators=(",", ":")),
        "mesh_size": (f"{p.mesh_size * 1e3:g} mm (n_phi = {int(p['mesh']['n_phi'])}, {result.n_dofs} DOFs, "
                      f"tie tolerance {tie_tolerance(p) * 1e3:.3g} mm)"),
        "element_type": element_label(p),
        "date": result.date,
        "version": versions(),
        "notes": (f"joint model '{p.name}' ({p.kind}): {p.description}. Assumptions - {notes}").replace("\n", " "),
    }


def write_sweep_table(result: SweepResult, path: str | Path, name: str | None = None) -> Path:
    """Write a sweep as a joint table CSV (tilt_deg, k_N_per_um) with provenance; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        write_joint_table(tmp, result.tilt_deg, result.k, table_metadata(result, name), k_unit="N/m")
    return path


@dataclass(frozen=True)
class FieldMesh:
    """All parts of a placed model as one linear-hexahedron grid with vertex displacements (SI)."""

    points: np.ndarray  # (n, 3) m, placed configuration
    cells: np.ndarray  # (m, 8) VTK hexahedron order
    displacement: np.ndarray  # (n, 3) m
    part_id: np.ndarray  # (m,)
    part_names: tuple[str, ...]


def field_mesh(model: PartModel, solution: Solution, u_all: np.ndarray | None = None) -> FieldMesh:
    """Collect the placed part meshes and the vertex displacements of ``u_all`` (all DOFs of ``solution``)."""
    pts, cells, disp, pid = [], [], [], []
    offset = 0
    for i, (name, part) in enumerate(model.parts.items()):
        b = model.bases[name]
        vert_dofs = b.nodal_dofs[0]  # scalar basis: vertex k carries node index vert_dofs[k]
        x = model.global_nodes(name, solution.placements)[:, vert_dofs].T
        if u_all is None:
            u = np.zeros_like(x)
        else:
            start = model.offset[name]
            u = np.asarray(u_all[start:start + 3 * b.N]).reshape(-1, 3)[vert_dofs]
        pts.append(x)
        disp.append(u)
        cells.append(part.mesh.t.T[:, _SKFEM_TO_VTK_HEX] + offset)
        pid.append(np.full(part.mesh.nelements, i))
        offset += x.shape[0]
    return FieldMesh(np.vstack(pts), np.vstack(cells), np.vstack(disp), np.concatenate(pid),
                     tuple(model.parts))


def write_vtu(fm: FieldMesh, path: str | Path, extra_point_data: dict[str, np.ndarray] | None = None) -> Path:
    """Write a :class:`FieldMesh` as VTU (meshio): point data ``displacement_m``, cell data ``part_id``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    point_data: dict[str, Any] = {"displacement_m": fm.displacement,
                                  "displacement_magnitude_um": np.linalg.norm(fm.displacement, axis=1) * 1e6}
    point_data.update(extra_point_data or {})
    mesh = meshio.Mesh(fm.points, [("hexahedron", fm.cells)], point_data=point_data,
                       cell_data={"part_id": [fm.part_id]})
    mesh.field_data = {name: np.array([i, 3]) for i, name in enumerate(fm.part_names)}
    with atomic_path(path) as tmp:
        meshio.write(tmp, mesh)
    return path
