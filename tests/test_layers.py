"""The package's layers import only downward, nothing imports the command line, and ``components`` depends on the
core's units and errors only (issue: one layered package). Checked over the source with ``ast`` (every import
statement, also those inside functions), so a lazy upward import is caught as well."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: layer order, lowest first; modules of one layer may import each other and anything below
LAYERS = [
    ("units", "errors"), ("io",), ("machine",), ("kinematics",), ("admissibility",), ("multibody",), ("structure",),
    ("analysis",), ("evaluation",), ("workspace",), ("fe",), ("calibration", "mechanisms"), ("plots",), ("report",),
    ("api",), ("optimise",), ("app",), ("cli",),
]
RANK = {name: i for i, names in enumerate(LAYERS) for name in names}
#: the package root is a thin facade over machine, kinematics and the study API (``pkmstiff.load_machine``, ...)
RANK["pkmstiff"] = RANK["kinematics"]


def _imports(path: Path, package: str) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import in ``path``; relative imports resolved against ``package``."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.append((node.lineno, mod))
            if mod == "pkmstiff":  # "from pkmstiff import kinematics" names a layer
                out += [(node.lineno, f"pkmstiff.{a.name}") for a in node.names if f"{a.name}" in RANK]
    return out


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in RANK else "pkmstiff"


def _modules(top: str) -> list[tuple[Path, str]]:
    found = []
    for path in sorted((ROOT / top).rglob("*.py")):
        rel = path.relative_to(ROOT).with_suffix("")
        parts = list(rel.parts)
        package = ".".join(parts[:-1]) if parts[-1] != "__init__" else ".".join(parts[:-1])
        found.append((path, package if parts[-1] == "__init__" else ".".join(parts[:-1])))
    return found


def test_every_module_belongs_to_a_known_layer():
    top = {p.name if p.is_dir() else p.stem for p in (ROOT / "pkmstiff").iterdir()
           if (p.is_dir() and (p / "__init__.py").exists()) or (p.suffix == ".py" and p.stem != "__init__")}
    assert top <= set(RANK), sorted(top - set(RANK))


def test_layers_import_only_downward():
    violations = []
    for path, package in _modules("pkmstiff"):
        rel = path.relative_to(ROOT)
        own = _layer(".".join(rel.with_suffix("").parts))
        for line, mod in _imports(path, package):
            if not mod.startswith("pkmstiff"):
                continue
            target = _layer(mod)
            if own == "pkmstiff" and target in ("machine", "kinematics", "errors", "units", "api"):
                continue  # the facade
            if RANK[target] > RANK[own]:
                violations.append(f"{rel}:{line} ({own}) imports {mod} ({target})")
    assert not violations, "\n".join(violations)


def test_no_library_module_imports_the_command_line():
    bad = [f"{path.relative_to(ROOT)}:{line}" for path, package in _modules("pkmstiff")
           if "cli" not in path.relative_to(ROOT).parts
           for line, mod in _imports(path, package) if mod == "pkmstiff.cli" or mod.startswith("pkmstiff.cli.")]
    assert not bad, bad


def test_components_depend_on_units_and_errors_only():
    bad = [f"{path.relative_to(ROOT)}:{line} imports {mod}" for path, package in _modules("components")
           for line, mod in _imports(path, package)
           if mod.startswith("pkmstiff") and mod not in ("pkmstiff.units", "pkmstiff.errors")]
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("layer", sorted(set(RANK) - {"pkmstiff", "calibration", "mechanisms"}))
def test_layer_imports_alone(layer):
    """Each layer imports in a fresh interpreter without pulling in any layer above it (no hidden circles)."""
    import subprocess
    import sys

    code = (f"import sys, pkmstiff.{layer}\n"
            f"above = sorted({{m.split('.')[1] for m in sys.modules if m.startswith('pkmstiff.')}} - {{'{layer}'}})\n"
            f"print(','.join(above))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    loaded = {m for m in out.stdout.strip().split(",") if m}
    higher = {m for m in loaded if m in RANK and RANK[m] > RANK[layer]}
    assert not higher, f"importing pkmstiff.{layer} also imported {sorted(higher)}"
