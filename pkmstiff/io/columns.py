"""Column and array names of every output table, and text cells a spreadsheet opens as text (issue 22 item 6/7).

One naming rule for CSV columns and VTU/NPZ arrays: ``<name>_<unit>`` with the unit written in plain ASCII (``/`` as
``_per_``, ``*`` as ``_``, ``µ`` as ``u``, powers without ``^``): ``x_mm``, ``kx_N_per_um``, ``krx_N_m_per_urad``,
``f1_Hz``; a dimensionless quantity has no suffix (``kappa``). Files written so are read by ``pandas.read_csv(path)``
with no options; their metadata go to a JSON file beside them.
"""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path
from collections.abc import Iterable, Sequence
from typing import IO, Any

import numpy as np

#: first characters a spreadsheet reads as the start of a formula (OWASP "CSV injection")
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")

_UNIT_WORDS = (("µ", "u"), ("°", "deg"), ("%", "pct"), ("²", "2"), ("³", "3"), ("/", "_per_"), ("*", "_"),
               ("·", "_"), ("^", ""), (" ", "_"))


def unit_token(unit: str) -> str:
    """``"N/um"`` -> ``"N_per_um"``, ``"N*m/urad"`` -> ``"N_m_per_urad"``, ``"m^3"`` -> ``"m3"``, ``"1"`` -> ``""``."""
    u = str(unit).strip()
    if u in ("", "1", "-"):
        return ""
    for a, b in _UNIT_WORDS:
        u = u.replace(a, b)
    return re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "", u)).strip("_")


def column_name(name: str, unit: str) -> str:
    """The column/array name of quantity ``name`` in ``unit``: ``column_name("kx", "N/um") == "kx_N_per_um"``."""
    token = unit_token(unit)
    return f"{name}_{token}" if token else name


_LABEL = re.compile(r"^(?P<name>.*?)\s*\[(?P<unit>[^\]]*)\](?P<suffix>.*)$")


def label_column(label: str) -> str:
    """A result label of the Python API (``"kx mean [N/um]"``, ``"components.strut_950.k [N/um]"``) as a file
    column: ``"kx_mean_N_per_um"``, ``"components.strut_950.k_N_per_um"``; a label without a unit keeps its name
    with spaces as ``_``."""
    m = _LABEL.match(label)
    if not m:
        return label.strip().replace(" ", "_")
    name = m["name"].strip().replace(" ", "_")
    return column_name(name, m["unit"]) + m["suffix"].strip().replace(" ", "_")


def text_cell(value: Any) -> Any:
    """``value`` for a CSV cell: a string that starts like a formula gets a leading apostrophe (``'=1+2``); numbers
    and other strings are returned unchanged."""
    if isinstance(value, str) and value.startswith(FORMULA_START):
        return "'" + value
    return value


def sidecar_path(path: str | Path) -> Path:
    """The JSON file beside an output CSV that holds its metadata (``<name>.json``)."""
    return Path(path).with_suffix(".json")


def table_cell(value: Any, float_format: str = ".10g") -> Any:
    """``value`` for a CSV cell: a float in ``float_format`` (empty if NaN or infinite), a string through
    :func:`text_cell`, anything else (int, bool) unchanged."""
    if isinstance(value, (float, np.floating)):
        return format(float(value), float_format) if math.isfinite(value) else ""
    return text_cell(value)


def write_csv(fh: IO[str], header: Sequence[str], rows: Iterable[Sequence[Any]], float_format: str = ".10g") -> None:
    """``header`` and ``rows`` (cells through :func:`table_cell`) to the open text file ``fh``."""
    w = csv.writer(fh)
    w.writerow(list(header))
    w.writerows([[table_cell(v, float_format) for v in r] for r in rows])


def write_column_table(path: str | Path, header: Sequence[str], columns: Sequence[np.ndarray],
                       metadata: dict[str, Any], float_format: str = ".10g") -> Path:
    """:func:`write_table` of numeric columns (1-D arrays, floats or integers), the same bytes as for their rows
    (floats through :func:`table_cell`), written by :func:`pkmstiff.io.numeric_csv.write_numeric_csv` without a
    Python call per cell: for tables of many rows (a rotation map's raster)."""
    from pkmstiff.io.atomic import atomic_open, atomic_write_text
    from pkmstiff.io.numeric_csv import write_numeric_csv

    path = Path(path)
    atomic_write_text(sidecar_path(path), json.dumps(metadata, indent=2, ensure_ascii=False, default=str) + "\n")
    with atomic_open(path, "wb") as fh:
        write_numeric_csv(fh, header, columns, float_format, blank_infinite=True)
    return path


def write_table(path: str | Path, header: Sequence[str], rows: Iterable[Sequence[Any]],
                metadata: dict[str, Any], float_format: str = ".10g") -> Path:
    """Write ``rows`` under ``header`` as a plain CSV (``pandas.read_csv(path)`` reads it with no options) and
    ``metadata`` to :func:`sidecar_path` beside it, both atomically; the JSON is written first, so a CSV never
    stands without its metadata. Returns ``path``."""
    from pkmstiff.io.atomic import atomic_open, atomic_write_text

    path = Path(path)
    atomic_write_text(sidecar_path(path), json.dumps(metadata, indent=2, ensure_ascii=False, default=str) + "\n")
    with atomic_open(path, "w", newline="", encoding="utf-8") as fh:
        write_csv(fh, header, rows, float_format)
    return path
