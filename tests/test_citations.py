"""Docstrings cite pages inside the repository (docs/...), and every cited page exists."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CITE = re.compile(r"docs/[\w/-]+\.md")


def test_cited_docs_pages_exist():
    missing = {}
    for top in ("pkmstiff", "components", "studies"):
        for path in (ROOT / top).rglob("*.py"):
            for ref in set(CITE.findall(path.read_text(encoding="utf-8"))):
                if not (ROOT / ref).is_file():
                    missing.setdefault(ref, []).append(str(path.relative_to(ROOT)))
    assert not missing, missing


def test_no_citation_of_the_external_specification():
    pattern = re.compile(r"spec[ /](models|machines|component-data|calibration)\.md|\bspec §")
    bad = [str(p.relative_to(ROOT)) for top in ("pkmstiff", "components", "studies")
           for p in (ROOT / top).rglob("*.py") if pattern.search(p.read_text(encoding="utf-8"))]
    assert not bad, bad
