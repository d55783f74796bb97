"""JSON Schemas of the documents the command line prints with ``--json`` (``pose``, ``point``); package data.

``schema_path("point")`` gives the file; every document carries its identifier in the key ``schema``
(``pkmstiff/point/1``): the number changes whenever a key is renamed or removed.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

SCHEMA_DIR = Path(__file__).resolve().parent


def schema_path(command: str) -> Path:
    return SCHEMA_DIR / f"{command}.schema.json"


def load_schema(command: str) -> dict[str, Any]:
    return json.loads(schema_path(command).read_text(encoding="utf-8"))
