"""Data model of a design-study report (rendered to self-contained HTML and Markdown by ``pkmstiff.report``).

A :class:`Report` holds sections; a section holds text, tables and figures. A :class:`Table` compares variants
(columns) on metrics (rows), each row with its unit; with a ``baseline`` column every other value is also shown in %
of the baseline (like Cobet's Table 5.1). Figures are PNG files. Assumptions (key -> one-line reason; per variant where
they come from its machine file: the renderer prints the shared ones once and only the differences per variant) and
settings (name -> value) are printed in the report; the run's versions are added by the renderer.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any


@dataclass
class Row:
    """One metric: label (e.g. "k_x mean"), unit (e.g. "N/um"), one value per table column (None = not available)."""

    label: str
    unit: str
    values: list[float | None]


@dataclass
class Table:
    caption: str
    columns: list[str]  # variant names
    rows: list[Row] = field(default_factory=list)
    baseline: str | None = None  # a column name: other columns get "% of baseline"
    digits: int = 4  # significant digits
    highlight: tuple[str, ...] = ()  # row labels shown highlighted (e.g. the best variant of an evaluation)

    def add(self, label: str, unit: str, values: list[float | None]) -> "Table":
        if len(values) != len(self.columns):
            raise ValueError(f"table '{self.caption}': row '{label}' has {len(values)} values for "
                             f"{len(self.columns)} columns")
        self.rows.append(Row(label, unit, [None if v is None else float(v) for v in values]))
        return self


@dataclass
class Figure:
    path: Path  # PNG
    caption: str


@dataclass
class Section:
    heading: str
    text: str = ""  # plain paragraphs (blank line = new paragraph)
    tables: list[Table] = field(default_factory=list)
    figures: list[Figure] = field(default_factory=list)


@dataclass
class Report:
    title: str
    summary: str = ""
    sections: list[Section] = field(default_factory=list)
    assumptions: dict[str, str] = field(default_factory=dict)  # the report's own (shared by every variant)
    variant_assumptions: dict[str, dict[str, str]] = field(default_factory=dict)  # variant -> its machine file's
    settings: dict[str, Any] = field(default_factory=dict)

    def section(self, heading: str, text: str = "") -> Section:
        s = Section(heading, text)
        self.sections.append(s)
        return s
