"""CSV joint-stiffness tables with provenance: reader, validator and writer.

File format (see the README section "Joint stiffness tables"):

* leading metadata lines ``# key: value``; required keys ``name``, ``source``, ``method``
  (``measured`` | ``FE`` | ``analytic``), ``quantity``, ``angle_convention`` (``axis`` | ``normal``);
  optional ``load``, ``notes`` (any further ``key: value`` is kept); FE tables additionally require
  ``parameters``, ``mesh_size``, ``element_type``, ``date``, ``version``;
* a header row, then one data row per support point:
  1-D ``tilt_deg,k_N_per_um``; 2-D long format ``swivel_deg,tilt_deg,k_N_per_um`` ordered by swivel,
  then tilt, on a complete rectangular grid.

Angles are in degrees and stiffness in N/µm in the file; :class:`JointTable` holds SI values (rad, N/m).
Bundled tables live in ``components/tables/`` and are found by their file stem.
"""

from __future__ import annotations

import importlib.resources
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from pkmstiff.errors import InputError, JointTableNotFound  # JointTableNotFound re-exported here
from pkmstiff.units import si, to_unit

METHODS: tuple[str, ...] = ("measured", "FE", "analytic")
CONVENTIONS: tuple[str, ...] = ("axis", "normal")
REQUIRED_KEYS: tuple[str, ...] = ("name", "source", "method", "quantity", "angle_convention")
FE_REQUIRED_KEYS: tuple[str, ...] = ("parameters", "mesh_size", "element_type", "date", "version")
HEADER_1D: tuple[str, ...] = ("tilt_deg", "k_N_per_um")
HEADER_2D: tuple[str, ...] = ("swivel_deg", "tilt_deg", "k_N_per_um")
_KEY_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


@dataclass(frozen=True, eq=False)
class JointTable:
    """A joint-stiffness table in SI units.

    ``tilt`` (n_t,) rad ascending; ``swivel`` (n_s,) rad ascending or ``None`` for a 1-D table;
    ``stiffness`` N/m, shape (n_t,) or (n_s, n_t); ``metadata`` = the ``# key: value`` lines.
    """

    name: str
    path: str
    tilt: np.ndarray
    stiffness: np.ndarray
    metadata: dict[str, str] = field(default_factory=dict)
    swivel: np.ndarray | None = None

    @property
    def method(self) -> str:
        return self.metadata["method"]

    @property
    def angle_convention(self) -> str:
        return self.metadata["angle_convention"]

    @property
    def provenance(self) -> str:
        """One-line provenance: method, source and file."""
        return f"{self.metadata.get('method', '?')}: {self.metadata.get('source', '?')} [{self.path}]"


def bundled_tables() -> list[str]:
    """Names (file stems) of the tables shipped in ``components/tables/``."""
    root = importlib.resources.files("components").joinpath("tables")
    return sorted(p.name[:-4] for p in root.iterdir() if p.name.endswith(".csv"))


def resolve_table_path(name_or_path: str | Path, base_dir: str | Path | None = None) -> Path:
    """Path of a bundled table (by name) or of a file (absolute, or relative to ``base_dir``)."""
    text = str(name_or_path)
    looks_like_path = isinstance(name_or_path, Path) or "/" in text or "\\" in text or text.endswith(".csv")
    if not looks_like_path:
        candidate = importlib.resources.files("components").joinpath("tables", f"{text}.csv")
        if candidate.is_file():
            return Path(str(candidate))
    path = Path(text)
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    if path.is_file():
        return path
    raise JointTableNotFound(
        str(path), "table", f"an existing CSV file or a bundled table name (one of {', '.join(bundled_tables())})",
        f"no file at {path}")


def load_joint_table(name_or_path: str | Path, *, base_dir: str | Path | None = None) -> JointTable:
    """Load and validate a joint table by bundled name (file stem) or path; returns SI values.

    Raises :class:`~pkmstiff.units.InputError` naming the file, the line and the column of any problem.
    """
    path = resolve_table_path(name_or_path, base_dir)
    return parse_joint_table(path.read_text(encoding="utf-8"), source=str(path))


def parse_joint_table(text: str, *, source: str) -> JointTable:
    """Parse the text of a joint table (``source`` names it in error messages)."""
    lines = text.splitlines()
    metadata: dict[str, str] = {}
    i = 0
    while i < len(lines) and (not lines[i].strip() or lines[i].lstrip().startswith("#")):
        raw = lines[i].strip()
        if raw:
            _parse_metadata_line(raw, i + 1, metadata, source)
        i += 1
    _validate_metadata(metadata, source)
    if i >= len(lines):
        raise InputError(source, "header", f"a header row {','.join(HEADER_1D)} or {','.join(HEADER_2D)}",
                         "end of file")
    header = tuple(c.strip() for c in lines[i].split(","))
    if header not in (HEADER_1D, HEADER_2D):
        raise InputError(source, f"line {i + 1} (header)",
                         f"the columns {','.join(HEADER_1D)} (tilt table) or {','.join(HEADER_2D)} "
                         "(swivel-tilt table)", ",".join(header))
    rows: list[tuple[int, list[float]]] = []
    for j in range(i + 1, len(lines)):
        raw = lines[j].strip()
        if not raw or raw.startswith("#"):
            continue
        cells = [c.strip() for c in raw.split(",")]
        if len(cells) != len(header):
            raise InputError(source, f"line {j + 1}", f"{len(header)} comma-separated values ({','.join(header)})",
                             raw)
        rows.append((j + 1, [_number(c, source, j + 1, col) for c, col in zip(cells, header)]))
    if len(rows) < 2:
        raise InputError(source, "data rows", "at least 2 support points", f"{len(rows)} row(s)")
    data = np.array([r for _, r in rows])
    line_no = [n for n, _ in rows]
    k_col = data[:, -1]
    bad = np.flatnonzero(k_col <= 0)
    if bad.size:
        raise InputError(source, f"line {line_no[bad[0]]}, column k_N_per_um", "a positive stiffness in N/um",
                         float(k_col[bad[0]]))
    name = metadata["name"]
    if header == HEADER_1D:
        _check_increasing(data[:, 0], line_no, "tilt_deg", source)
        return JointTable(name=name, path=source, tilt=np.deg2rad(data[:, 0]), stiffness=si(k_col, "N/um"),
                          metadata=metadata)
    swivel, tilt, grid = _grid_from_long(data, line_no, source)
    return JointTable(name=name, path=source, tilt=np.deg2rad(tilt), stiffness=si(grid, "N/um"),
                      metadata=metadata, swivel=np.deg2rad(swivel))


def _parse_metadata_line(raw: str, line: int, metadata: dict[str, str], source: str) -> None:
    body = raw.lstrip("#").strip()
    if not body:
        return
    key, sep, value = body.partition(":")
    key = key.strip()
    if not sep or not _KEY_RE.match(key):
        raise InputError(source, f"line {line}", "a metadata line '# key: value'", raw)
    if key in metadata:
        raise InputError(source, f"line {line}", f"metadata key '{key}' only once", raw)
    metadata[key] = value.strip()


def _validate_metadata(metadata: dict[str, str], source: str) -> None:
    for key in REQUIRED_KEYS:
        if not metadata.get(key):
            raise InputError(source, f"metadata '{key}'", f"a line '# {key}: ...' before the header", "missing")
    method = {m.lower(): m for m in METHODS}.get(metadata["method"].lower())
    if method is None:
        raise InputError(source, "metadata 'method'", f"one of {', '.join(METHODS)}", metadata["method"])
    metadata["method"] = method
    if metadata["angle_convention"] not in CONVENTIONS:
        raise InputError(source, "metadata 'angle_convention'", f"one of {', '.join(CONVENTIONS)}",
                         metadata["angle_convention"])
    if method == "FE":
        missing = [key for key in FE_REQUIRED_KEYS if not metadata.get(key)]
        if missing:
            raise InputError(source, f"metadata '{missing[0]}'", "the provenance lines '# key: ...' required for "
                             f"FE tables: {', '.join(FE_REQUIRED_KEYS)}", f"missing {', '.join(missing)}")


def _number(cell: str, source: str, line: int, column: str) -> float:
    try:
        value = float(cell)
    except ValueError:
        raise InputError(source, f"line {line}, column {column}", "a number", cell) from None
    if not np.isfinite(value):
        raise InputError(source, f"line {line}, column {column}", "a finite number", cell)
    return value


def _check_increasing(values: np.ndarray, line_no: list[int], column: str, source: str) -> None:
    bad = np.flatnonzero(np.diff(values) <= 0)
    if bad.size:
        j = bad[0] + 1
        raise InputError(source, f"line {line_no[j]}, column {column}",
                         f"strictly increasing angles (previous row: {values[j - 1]:g})", float(values[j]))


def _grid_from_long(data: np.ndarray, line_no: list[int], source: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rectangular (swivel, tilt) grid from long-format rows ordered by swivel, then tilt."""
    sw = data[:, 0]
    starts = np.concatenate(([0], np.flatnonzero(np.diff(sw) != 0) + 1))
    ends = np.concatenate((starts[1:], [len(sw)]))
    swivel = sw[starts]
    _check_increasing(swivel, [line_no[s] for s in starts], "swivel_deg", source)
    tilt = data[starts[0]:ends[0], 1]
    for s, e in zip(starts, ends):
        block = data[s:e, 1]
        _check_increasing(block, line_no[s:e], "tilt_deg", source)
        if block.shape != tilt.shape or np.any(block != tilt):
            raise InputError(source, f"lines {line_no[s]}-{line_no[e - 1]}, column tilt_deg",
                             f"the same tilt angles for every swivel angle ({tilt.tolist()})", block.tolist())
    if swivel.size < 2 or tilt.size < 2:
        raise InputError(source, "data rows", "at least 2 swivel and 2 tilt angles",
                         f"{swivel.size} swivel x {tilt.size} tilt")
    return swivel, tilt, data[:, 2].reshape(swivel.size, tilt.size)


def write_joint_table(
    path: str | Path,
    tilt_deg: Any,
    k: Any,
    metadata: Mapping[str, Any],
    *,
    swivel_deg: Any = None,
    k_unit: str = "N/m",
) -> Path:
    """Write a joint table in the CSV format above and return its path.

    ``tilt_deg`` (n_t,) and ``swivel_deg`` (n_s,) are in degrees; ``k`` is in ``k_unit`` (default SI, N/m),
    shape (n_t,) or (n_s, n_t) for a swivel-tilt table; it is written in N/µm. ``metadata`` must satisfy
    the same rules as on reading (required keys, method, convention, FE provenance); it is validated, and
    the data by re-parsing the text, before anything is written.
    """
    path = Path(path)
    meta = {str(key): str(value) for key, value in metadata.items()}
    for key, value in meta.items():
        if not _KEY_RE.match(key) or "\n" in value:
            raise InputError(str(path), f"metadata '{key}'", "a key of letters/digits/_ and a one-line value", value)
    tilt = np.asarray(tilt_deg, dtype=float)
    k_um = np.asarray(to_unit(si(np.asarray(k, dtype=float), k_unit), "N/um"), dtype=float)
    out = [f"# {key}: {value}" for key, value in meta.items()]
    if swivel_deg is None:
        if tilt.ndim != 1 or k_um.shape != tilt.shape:
            raise InputError(str(path), "k", f"an array of shape {tilt.shape} matching tilt_deg", f"shape {k_um.shape}")
        out.append(",".join(HEADER_1D))
        out += [f"{_fmt(t)},{_fmt(v)}" for t, v in zip(tilt, k_um)]
    else:
        swivel = np.asarray(swivel_deg, dtype=float)
        if swivel.ndim != 1 or tilt.ndim != 1 or k_um.shape != (swivel.size, tilt.size):
            raise InputError(str(path), "k", f"an array of shape ({swivel.size}, {tilt.size}) = (swivel, tilt)",
                             f"shape {k_um.shape}")
        out.append(",".join(HEADER_2D))
        out += [f"{_fmt(s)},{_fmt(t)},{_fmt(k_um[a, b])}" for a, s in enumerate(swivel) for b, t in enumerate(tilt)]
    text = "\n".join(out) + "\n"
    parse_joint_table(text, source=str(path))  # same validation as on reading
    path.write_text(text, encoding="utf-8")
    return path


def _fmt(x: float) -> str:
    return repr(float(x))
