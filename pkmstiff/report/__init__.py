"""Design-study reports: data model (:mod:`.model`), rendering to self-contained HTML + Markdown (:mod:`.render`)
and report specs in TOML (:mod:`.spec`, the ``pkmstiff report`` command)."""

from pkmstiff.report.model import Figure, Report, Row, Section, Table
from pkmstiff.report.render import run_info, write_report

__all__ = ["Figure", "Report", "Row", "Section", "Table", "run_info", "write_report"]
