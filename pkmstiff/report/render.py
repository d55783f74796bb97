"""Render a :class:`pkmstiff.report.model.Report` to a self-contained HTML page and a Markdown twin.

Both come from Jinja2 templates shipped with the package (``pkmstiff/report/templates``: ``report.html.j2`` with
autoescaping on, ``report.md.j2``) and one stylesheet (``style.css``) that the design, calibration and demo reports
share. Text is plain: a paragraph whose lines all start with "- " is a list, any other paragraph is text, and no
Markdown or HTML in it is interpreted.

The HTML file has its CSS inline and every figure embedded as a ``data:image/png;base64`` URI: it opens offline,
loads nothing and runs no script. The Markdown file links the PNGs, copied beside it into ``figures/``, by relative
paths. Both carry the tables (absolute values and, with a baseline column, "% of baseline" for every column — the
baseline itself is 100 %), the assumptions, the settings and a "Run" section with the package versions and the date.
Output is deterministic: the same report gives the same files (except the date, which ``SOURCE_DATE_EPOCH`` or the
``run_info`` argument fixes).
"""

from __future__ import annotations

import base64
import datetime as _dt
import json
import math
import os
import platform
import shutil
import sys
from dataclasses import dataclass
from functools import lru_cache
from importlib import metadata
from pathlib import Path
from typing import Any

from pkmstiff.errors import ArgumentError
from pkmstiff.io.atomic import atomic_path, atomic_write_text
from pkmstiff.plots.section_maps import pretty_unit
from pkmstiff.report.model import Figure, Report, Table

__all__ = ["write_report", "run_info", "format_value", "format_percent", "percent_of_baseline"]

# distributions whose versions the "Run" section lists (importlib.metadata names)
VERSION_PACKAGES = ("pkmstiff", "numpy", "scipy", "numba", "scikit-fem", "pyvista", "matplotlib")

_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

# ----------------------------------------------------------------------------------------------------------- numbers
def format_value(value: float | None, digits: int) -> str:
    """``value`` rounded to ``digits`` significant digits, fixed notation for 1e-3 <= |v| < 1e7, else scientific.

    ``None`` is "n/a"; non-finite values print as "NaN", "inf", "-inf".
    """
    if value is None:
        return "n/a"
    v = float(value)
    if math.isnan(v):
        return "NaN"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    if v == 0.0:
        return "0"
    digits = max(1, int(digits))
    mag = math.floor(math.log10(abs(v)))
    if not -3 <= mag < 7:
        return f"{v:.{digits - 1}e}"
    decimals = digits - 1 - mag
    rounded = round(v, decimals)
    if rounded != 0 and math.floor(math.log10(abs(rounded))) > mag:  # 9.9996 -> 10.00: one decimal fewer
        decimals -= 1
    text = f"{rounded:.{max(decimals, 0)}f}"
    return "0" if float(text) == 0 else text


_COUNT_UNITS = {"count", "points", "evaluations", "poses"}


def _is_count_row(row) -> bool:
    """A row counting things (unit "count", "points", "evaluations", "poses"): whole numbers, printed as integers."""
    vals = [v for v in row.values if v is not None]
    return (row.unit.strip() in _COUNT_UNITS and bool(vals)
            and all(math.isfinite(v) and float(v).is_integer() and abs(v) < 1e15 for v in vals))


def percent_of_baseline(value: float | None, base: float | None) -> float | None:
    """100 · value / base, or None when either is missing, non-finite, or the baseline is zero."""
    if value is None or base is None:
        return None
    v, b = float(value), float(base)
    if not (math.isfinite(v) and math.isfinite(b)) or b == 0.0:
        return None
    return 100.0 * v / b


def format_percent(p: float | None) -> str:
    """A percentage with one decimal ("87.3 %"); "–" when not available."""
    return "–" if p is None else f"{p:.1f} %"


@dataclass(frozen=True)
class _Cell:
    text: str
    kind: str  # "num" | "pct"


def _table_grid(table: Table) -> tuple[list[tuple[str, str]], list[tuple[str, str, list[_Cell]]]]:
    """Header [(text, kind)] and rows [(label, unit, cells)]; with a baseline each column is followed by its %."""
    if table.baseline is not None and table.baseline not in table.columns:
        raise ArgumentError(f"table '{table.caption}': baseline {table.baseline!r} is not one of its columns "
                          f"{table.columns}")
    for row in table.rows:
        if len(row.values) != len(table.columns):
            raise ArgumentError(f"table '{table.caption}': row '{row.label}' has {len(row.values)} values for "
                              f"{len(table.columns)} columns")
    ib = None if table.baseline is None else table.columns.index(table.baseline)
    header: list[tuple[str, str]] = [("Metric", "head"), ("Unit", "head")]
    for c in table.columns:
        header.append((c, "head"))
        if ib is not None:
            header.append((f"% of {table.baseline}", "pct"))
    rows = []
    for row in table.rows:
        cells = []
        count = _is_count_row(row)
        for j, v in enumerate(row.values):
            cells.append(_Cell(str(int(v)) if count and v is not None else format_value(v, table.digits), "num"))
            if ib is not None:
                cells.append(_Cell(format_percent(percent_of_baseline(v, row.values[ib])), "pct"))
        rows.append((row.label, pretty_unit(row.unit), cells))
    return header, rows


# ---------------------------------------------------------------------------------------------------------- run info
def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        if dist == "pkmstiff":  # running from a source tree that is not installed
            from pkmstiff import __version__

            return __version__
        return "not installed"


def run_info() -> dict[str, str]:
    """Versions of Python and the numerical packages, the platform and the date (UTC, ISO 8601).

    ``SOURCE_DATE_EPOCH`` (seconds) fixes the date for reproducible output.
    """
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    now = (_dt.datetime.fromtimestamp(int(epoch), _dt.timezone.utc) if epoch and epoch.isdigit()
           else _dt.datetime.now(_dt.timezone.utc))
    info = {"date": now.replace(microsecond=0).isoformat(), "python": platform.python_version()}
    for dist in VERSION_PACKAGES:
        info[dist] = _version(dist)
    info["platform"] = f"{platform.system()} {platform.machine()}"
    if sys.argv and sys.argv[0]:
        program = Path(sys.argv[0]).name
        # ``python -m pkmstiff.cli`` names the module's __main__.py; the user ran the pkmstiff command
        info["command"] = " ".join(["pkmstiff" if program == "__main__.py" else program, *sys.argv[1:]])
    return info


def _setting_text(value: Any) -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, float):
        return format_value(value, 6)
    try:
        return json.dumps(value, sort_keys=True, default=str, ensure_ascii=False)
    except (TypeError, ValueError):
        return str(value)


# ----------------------------------------------------------------------------------------------------------- figures
def _check_png(fig: Figure, where: str) -> bytes:
    path = Path(fig.path)
    if not path.is_file():
        raise ArgumentError(f"{where} ('{fig.caption}'): figure file {path} does not exist")
    data = path.read_bytes()
    if not data.startswith(_PNG_MAGIC):
        raise ArgumentError(f"{where} ('{fig.caption}'): expected a PNG file, found {path} "
                          f"(starts with {data[:8]!r})")
    return data


def _place_figures(report: Report, out_dir: Path) -> list[list[tuple[Figure, bytes, str]]]:
    """Per section: (figure, PNG bytes, path relative to out_dir). Figures outside out_dir are copied to figures/."""
    out_res = out_dir.resolve()
    used: set[str] = set()
    placed = []
    n = 0
    for section in report.sections:
        items = []
        for fig in section.figures:
            n += 1
            data = _check_png(fig, f"section '{section.heading}', figure {n}")
            src = Path(fig.path).resolve()
            try:
                rel = src.relative_to(out_res).as_posix()
            except ValueError:
                stem, k = src.stem, 1
                rel = f"figures/{stem}.png"
                while rel in used:
                    k += 1
                    rel = f"figures/{stem}_{k}.png"
                dst = out_dir / rel
                dst.parent.mkdir(parents=True, exist_ok=True)
                with atomic_path(dst) as tmp:
                    shutil.copyfile(src, tmp)
            used.add(rel)
            items.append((fig, data, rel))
        placed.append(items)
    return placed


def _anchor(i: int) -> str:
    return f"s{i + 1}"


# ------------------------------------------------------------------------------------------------------- text blocks
def text_blocks(text: str) -> list[tuple[str, list[str]]]:
    """Plain text as blocks: ("ul", items) for a paragraph whose lines all start with "- ", else ("p", lines).
    Paragraphs are separated by blank lines."""
    out = []
    for para in (p.strip() for p in text.strip().split("\n\n")):
        if not para:
            continue
        lines = [ln.strip() for ln in para.split("\n")]
        if all(ln.startswith("- ") for ln in lines):
            out.append(("ul", [ln[2:].strip() for ln in lines]))
        else:
            out.append(("p", lines))
    return out


# ---------------------------------------------------------------------------------------- assumptions and settings
@dataclass(frozen=True)
class Assumptions:
    """Assumptions once: those every variant shares (with the report's own) and a table of the differences."""

    shared: list[tuple[str, str]]
    variants: list[str]
    per_variant: list[tuple[str, list[str]]]

    @property
    def per_variant_rows(self) -> list[list[str]]:
        return [[k, *vals] for k, vals in self.per_variant]


def merge_assumptions(report: Report) -> Assumptions:
    """Shared assumptions (the report's and every key all variants state with the same reason) and, per key that
    differs, the reason per variant ("—" where a variant has none)."""
    shared = dict(report.assumptions)
    per = report.variant_assumptions
    names = list(per)
    keys = sorted({k for a in per.values() for k in a})
    rows = []
    for k in keys:
        vals = [per[n].get(k) for n in names]
        if all(v is not None and v == vals[0] for v in vals):
            shared.setdefault(k, vals[0])
        else:
            rows.append((k, ["—" if v is None else v for v in vals]))
    return Assumptions(sorted(shared.items()), names, rows)


_PACKAGE_DIR = Path(__file__).resolve().parents[1]


def display_path(text: str, out_dir: Path) -> str:
    """An absolute path as the reader should see it: "bundled: <path in the package>" for a file shipped with
    pkmstiff, else relative to the report's directory. Other text is returned as it is."""
    p = Path(text)
    if not p.is_absolute():
        return text
    try:
        return "bundled: " + p.resolve().relative_to(_PACKAGE_DIR).as_posix()
    except ValueError:
        return Path(os.path.relpath(p.resolve(), out_dir.resolve())).as_posix()


def settings_rows(settings: dict[str, Any], out_dir: Path) -> list[tuple[str, str]]:
    """Settings as (name, value) rows: nested tables flattened to "outer › inner", lists joined with commas,
    absolute paths shown by :func:`display_path`."""
    rows: list[tuple[str, str]] = []

    def value_text(v: Any) -> str:
        if isinstance(v, (list, tuple)):
            return ", ".join(value_text(x) for x in v) if v else "—"
        if v is None:
            return "—"
        if isinstance(v, bool):
            return "yes" if v else "no"
        if isinstance(v, (str, Path)):
            return display_path(str(v), out_dir)
        if isinstance(v, float):
            return f"{v:.6g}"
        return _setting_text(v)

    def walk(prefix: str, d: dict[str, Any]) -> None:
        for k in sorted(d):
            name = f"{prefix} › {k}" if prefix else str(k)
            if isinstance(d[k], dict) and d[k]:
                walk(name, d[k])
            else:
                rows.append((name, value_text(d[k])))

    walk("", settings)
    return rows


# --------------------------------------------------------------------------------------------------------- templates
def _md_text(text: str, inline: bool = True) -> str:
    """Text from a spec or machine file as literal Markdown: HTML special characters as entities (a Markdown viewer
    renders raw HTML), link/image brackets and code ticks escaped; one line where ``inline``."""
    t = str(text).replace("\\", "\\\\").replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    t = t.replace("[", "\\[").replace("]", "\\]").replace("`", "\\`")
    return " ".join(t.split("\n")) if inline else t


def _md_table(header: list[str], rows, right: list[bool]) -> str:
    def cell(x: Any) -> str:
        return _md_text(str(x)).replace("|", "\\|")

    out = ["| " + " | ".join(cell(h) for h in header) + " |",
           "|" + "|".join("---:" if r else "---" for r in right) + "|"]
    out += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return "\n".join(out) + "\n"


def _md_blocks(text: str) -> str:
    parts = []
    for kind, lines in text_blocks(text):
        if kind == "ul":
            parts.append("\n".join(f"- {_md_text(x)}" for x in lines))
        else:
            parts.append("  \n".join(_md_text(x) for x in lines))
    return "\n\n".join(parts) + ("\n" if parts else "")


@lru_cache(maxsize=2)
def _environment(kind: str):
    """The Jinja2 environment of the package's templates: autoescape for HTML, Markdown escaping by filter."""
    import jinja2

    env = jinja2.Environment(loader=jinja2.PackageLoader("pkmstiff.report", "templates"),
                             autoescape=(kind == "html"), keep_trailing_newline=True, trim_blocks=False,
                             undefined=jinja2.StrictUndefined)
    env.globals.update(split_blocks=text_blocks, mdblocks=_md_blocks, mdtable=_md_table)
    env.filters["md"] = _md_text
    return env


def stylesheet() -> str:
    """The stylesheet every pkmstiff report uses (``templates/style.css``)."""
    from importlib.resources import files

    return files("pkmstiff.report").joinpath("templates/style.css").read_text(encoding="utf-8")


def render_template(name: str, **context: Any) -> str:
    """Render ``templates/<name>`` (HTML with autoescaping when the name ends in .html.j2) with the stylesheet."""
    env = _environment("html" if name.endswith(".html.j2") else "md")
    return env.get_template(name).render(css=stylesheet(), **context)


def _context(report: Report, placed, info: dict[str, str], out_dir: Path) -> dict[str, Any]:
    sections = []
    nt = nf = 0
    for i, (section, figs) in enumerate(zip(report.sections, placed)):
        tables = []
        for table in section.tables:
            nt += 1
            header, rows = _table_grid(table)
            tables.append({"number": nt, "caption": table.caption, "header": header, "rows": rows,
                           "md_rows": [[label, unit] + [c.text for c in cells] for label, unit, cells in rows],
                           "right": [False, False] + [True] * (len(header) - 2), "best": table.highlight})
        figures = []
        for fig, data, rel in figs:
            nf += 1
            figures.append({"number": nf, "caption": fig.caption, "rel": rel,
                            "alt": fig.caption.replace("[", "(").replace("]", ")"),
                            "b64": base64.b64encode(data).decode("ascii")})
        sections.append({"anchor": _anchor(i), "heading": section.heading, "text": section.text,
                         "tables": tables, "figures": figures})
    return {"report": report, "sections": sections, "info": info, "assumptions": merge_assumptions(report),
            "settings": settings_rows(report.settings, out_dir)}


# ------------------------------------------------------------------------------------------------------------ public
def write_report(report: Report, out_dir: str | Path, *, stem: str = "report",
                 run: dict[str, str] | None = None) -> dict[str, Path]:
    """Write ``<out_dir>/<stem>.html`` (self-contained) and ``<out_dir>/<stem>.md`` (+ ``figures/``).

    Parameters
    ----------
    report : the report (``pkmstiff.report.model.Report``).
    out_dir : output directory, created if missing. Figures already inside it are linked where they are; others
        are copied to ``out_dir/figures/``.
    stem : file name stem of both files.
    run : the "Run" section (name -> text); default :func:`run_info` (versions, platform, date).

    Returns ``{"html": Path, "md": Path}``. Raises :class:`ArgumentError` for a baseline that is not a column, a row
    with the wrong number of values, or a figure that is missing or not a PNG — before anything is written.
    """
    out = Path(out_dir)
    info = dict(run_info() if run is None else run)
    for section in report.sections:  # validate every table before writing anything
        for table in section.tables:
            _table_grid(table)
    for section in report.sections:
        for fig in section.figures:
            _check_png(fig, f"section '{section.heading}'")
    out.mkdir(parents=True, exist_ok=True)
    placed = _place_figures(report, out)
    html_path = out / f"{stem}.html"
    md_path = out / f"{stem}.md"
    ctx = _context(report, placed, info, out)
    atomic_write_text(html_path, render_template("report.html.j2", **ctx))
    atomic_write_text(md_path, render_template("report.md.j2", **ctx))
    return {"html": html_path, "md": md_path}
