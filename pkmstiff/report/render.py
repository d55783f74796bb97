"""Render a :class:`pkmstiff.report.model.Report` to a self-contained HTML page and a Markdown twin.

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
import html
import json
import math
import os
import platform
import shutil
import sys
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

from pkmstiff.errors import ReportError  # noqa: F401 (re-exported)
from pkmstiff.io.atomic import atomic_path, atomic_write_text
from pkmstiff.report.model import Figure, Report, Table

__all__ = ["ReportError", "write_report", "run_info", "format_value", "format_percent", "percent_of_baseline"]

# distributions whose versions the "Run" section lists (importlib.metadata names)
VERSION_PACKAGES = ("pkmstiff", "numpy", "scipy", "numba", "scikit-fem", "pyvista", "matplotlib")

_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

_CSS = """
body{font-family:-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;max-width:75em;margin:2em auto;padding:0 1em;
color:#222;line-height:1.45}
h1{border-bottom:2px solid #444;padding-bottom:.2em}
h2{border-bottom:1px solid #bbb;padding-bottom:.1em;margin-top:1.8em}
table{border-collapse:collapse;margin:.8em 0 1.4em 0;font-size:.92em}
caption{caption-side:top;text-align:left;font-weight:bold;padding:.3em 0}
th,td{border:1px solid #bbb;padding:.25em .6em}
th{background:#eee}
td.num{text-align:right;font-variant-numeric:tabular-nums}
td.pct{text-align:right;color:#555;font-variant-numeric:tabular-nums}
th.pct{background:#f6f6f6;font-weight:normal}
tr.base td{font-weight:bold}
div.figures{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start}
figure{margin:.5em 0 1.2em 0;flex:0 1 36.5em;max-width:100%}
figure img{width:100%;height:auto;border:1px solid #ddd}
figcaption{font-size:.9em;color:#444}
dl.assumptions dt{font-weight:bold;margin-top:.4em}
dl.assumptions dd{margin-left:1.5em}
nav ul{columns:2}
.meta{color:#555;font-size:.9em}
"""




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
        raise ReportError(f"table '{table.caption}': baseline {table.baseline!r} is not one of its columns "
                          f"{table.columns}")
    for row in table.rows:
        if len(row.values) != len(table.columns):
            raise ReportError(f"table '{table.caption}': row '{row.label}' has {len(row.values)} values for "
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
        rows.append((row.label, row.unit, cells))
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
        info["command"] = " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])
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
        raise ReportError(f"{where} ('{fig.caption}'): figure file {path} does not exist")
    data = path.read_bytes()
    if not data.startswith(_PNG_MAGIC):
        raise ReportError(f"{where} ('{fig.caption}'): expected a PNG file, found {path} "
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


# -------------------------------------------------------------------------------------------------------------- HTML
def _html_paragraphs(text: str) -> str:
    paras = [p.strip() for p in text.strip().split("\n\n") if p.strip()]
    return "".join(f"<p>{html.escape(p).replace(chr(10), '<br>')}</p>\n" for p in paras)


def _html_table(table: Table, number: int) -> str:
    header, rows = _table_grid(table)
    e = html.escape
    out = [f'<table>\n<caption>Table {number}: {e(table.caption)}</caption>\n<thead><tr>']
    for text, kind in header:
        out.append(f'<th class="pct">{e(text)}</th>' if kind == "pct" else f"<th>{e(text)}</th>")
    out.append("</tr></thead>\n<tbody>\n")
    for label, unit, cells in rows:
        out.append(f"<tr><td>{e(label)}</td><td>{e(unit)}</td>")
        out.extend(f'<td class="{c.kind}">{e(c.text)}</td>' for c in cells)
        out.append("</tr>\n")
    out.append("</tbody>\n</table>\n")
    return "".join(out)


def _render_html(report: Report, placed, info: dict[str, str]) -> str:
    e = html.escape
    parts = ["<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n",
             f"<title>{e(report.title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n",
             f"<h1>{e(report.title)}</h1>\n",
             f'<p class="meta">pkmstiff {e(info.get("pkmstiff", ""))} — {e(info.get("date", ""))}</p>\n']
    if report.summary.strip():
        parts.append(_html_paragraphs(report.summary))
    toc = [f'<li><a href="#{_anchor(i)}">{e(s.heading)}</a></li>' for i, s in enumerate(report.sections)]
    toc += ['<li><a href="#assumptions">Assumptions</a></li>', '<li><a href="#settings">Settings</a></li>',
            '<li><a href="#run">Run</a></li>']
    parts.append("<nav><h2>Contents</h2><ul>" + "".join(toc) + "</ul></nav>\n")
    nt = nf = 0
    for i, (section, figs) in enumerate(zip(report.sections, placed)):
        parts.append(f'<section id="{_anchor(i)}">\n<h2>{e(section.heading)}</h2>\n')
        parts.append(_html_paragraphs(section.text))
        for table in section.tables:
            nt += 1
            parts.append(_html_table(table, nt))
        if figs:
            parts.append('<div class="figures">\n')
        for fig, data, _rel in figs:
            nf += 1
            b64 = base64.b64encode(data).decode("ascii")
            parts.append(f'<figure><img src="data:image/png;base64,{b64}" alt="{e(fig.caption)}">'
                         f"<figcaption>Figure {nf}: {e(fig.caption)}</figcaption></figure>\n")
        if figs:
            parts.append("</div>\n")
        parts.append("</section>\n")
    parts.append('<section id="assumptions">\n<h2>Assumptions</h2>\n')
    if report.assumptions:
        parts.append('<dl class="assumptions">\n')
        for key in sorted(report.assumptions):
            parts.append(f"<dt>{e(key)}</dt><dd>{e(str(report.assumptions[key]))}</dd>\n")
        parts.append("</dl>\n")
    else:
        parts.append("<p>None recorded.</p>\n")
    parts.append("</section>\n")
    parts.append('<section id="settings">\n<h2>Settings</h2>\n')
    parts.append(_html_kv(report.settings, "Setting", sort=True))
    parts.append("</section>\n")
    parts.append('<section id="run">\n<h2>Run</h2>\n')
    parts.append(_html_kv(info, "Item", sort=False))
    parts.append("</section>\n</body>\n</html>\n")
    return "".join(parts)


def _html_kv(d: dict[str, Any], key_head: str, sort: bool) -> str:
    if not d:
        return "<p>None recorded.</p>\n"
    e = html.escape
    keys = sorted(d) if sort else list(d)
    rows = "".join(f"<tr><td>{e(str(k))}</td><td>{e(_setting_text(d[k]))}</td></tr>\n" for k in keys)
    return f"<table>\n<thead><tr><th>{key_head}</th><th>Value</th></tr></thead>\n<tbody>\n{rows}</tbody>\n</table>\n"


# ---------------------------------------------------------------------------------------------------------- Markdown
def _md_text(text: str, inline: bool = True) -> str:
    """Text from a spec or machine file as literal Markdown: HTML special characters as entities (a Markdown viewer
    renders raw HTML), link/image brackets and code ticks escaped; one line where ``inline``."""
    t = text.replace("\\", "\\\\").replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    t = t.replace("[", "\\[").replace("]", "\\]").replace("`", "\\`")
    return " ".join(t.split("\n")) if inline else t


def _md_cell(text: str) -> str:
    return _md_text(text).replace("|", "\\|")


def _md_table(header: list[str], rows: list[list[str]], right: list[bool]) -> str:
    out = ["| " + " | ".join(_md_cell(h) for h in header) + " |",
           "|" + "|".join("---:" if r else "---" for r in right) + "|"]
    out += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(out) + "\n"


def _render_md(report: Report, placed, info: dict[str, str]) -> str:
    parts = [f"# {_md_text(report.title)}\n\n", f"*pkmstiff {info.get('pkmstiff', '')} — {info.get('date', '')}*\n\n"]
    if report.summary.strip():
        parts.append(_md_text(report.summary.strip(), inline=False) + "\n\n")
    nt = nf = 0
    for section, figs in zip(report.sections, placed):
        parts.append(f"## {_md_text(section.heading)}\n\n")
        if section.text.strip():
            parts.append(_md_text(section.text.strip(), inline=False) + "\n\n")
        for table in section.tables:
            nt += 1
            header, rows = _table_grid(table)
            parts.append(f"**Table {nt}: {_md_text(table.caption)}**\n\n")
            parts.append(_md_table([h for h, _ in header],
                                   [[label, unit] + [c.text for c in cells] for label, unit, cells in rows],
                                   [False, False] + [True] * (len(header) - 2)))
            parts.append("\n")
        for fig, _data, rel in figs:
            nf += 1
            alt = _md_text(fig.caption.replace("[", "(").replace("]", ")"))
            parts.append(f"![{alt}]({rel})\n\n*Figure {nf}: {_md_text(fig.caption)}*\n\n")
    parts.append("## Assumptions\n\n")
    if report.assumptions:
        parts.extend(f"- **{_md_text(k)}**: {_md_text(str(report.assumptions[k]))}\n" for k in sorted(report.assumptions))
        parts.append("\n")
    else:
        parts.append("None recorded.\n\n")
    parts.append("## Settings\n\n")
    if report.settings:
        keys = sorted(report.settings)
        parts.append(_md_table(["Setting", "Value"], [[str(k), _setting_text(report.settings[k])] for k in keys],
                               [False, False]))
    else:
        parts.append("None recorded.\n")
    parts.append("\n## Run\n\n")
    parts.append(_md_table(["Item", "Value"], [[k, _setting_text(v)] for k, v in info.items()], [False, False]))
    return "".join(parts)


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

    Returns ``{"html": Path, "md": Path}``. Raises :class:`ReportError` for a baseline that is not a column, a row
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
    atomic_write_text(html_path, _render_html(report, placed, info))
    atomic_write_text(md_path, _render_md(report, placed, info))
    return {"html": html_path, "md": md_path}
