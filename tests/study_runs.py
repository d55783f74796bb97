"""Shared helpers of the study tests: load a script from ``studies/`` (not a package) and run it in --fast mode."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

STUDIES = Path(__file__).resolve().parents[1] / "studies"


def load(name: str):
    """Import ``studies/<name>`` as a module."""
    path = STUDIES / name
    spec = importlib.util.spec_from_file_location(f"study_{path.stem}", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def run_fast(scripts: dict[str, str], tmp_path_factory) -> dict:
    """Each study run once in --fast mode: letter -> (module, output dir, results.json)."""
    out = {}
    for letter, script in scripts.items():
        mod = load(script)
        d = tmp_path_factory.mktemp(f"study_{letter}")
        assert mod.main(["--fast", "--out", str(d)]) == 0
        out[letter] = (mod, d, json.loads((d / "results.json").read_text(encoding="utf-8")))
    return out
