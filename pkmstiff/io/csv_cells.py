"""Text cells of CSV outputs that a spreadsheet opens as text, never as a formula (CSV injection, issue 22 item 7)."""

from __future__ import annotations

from typing import Any

#: first characters a spreadsheet reads as the start of a formula (OWASP "CSV injection")
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def text_cell(value: Any) -> Any:
    """``value`` for a CSV cell: a string that starts like a formula gets a leading apostrophe (``'=1+2``); numbers
    and other strings are returned unchanged."""
    if isinstance(value, str) and value.startswith(FORMULA_START):
        return "'" + value
    return value
