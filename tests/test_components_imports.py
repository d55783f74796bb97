"""The component library depends on the core only through `pkmstiff.units` and `pkmstiff.errors`."""

import ast
from pathlib import Path

import components

ALLOWED = {"pkmstiff.units", "pkmstiff.errors"}


def _pkmstiff_imports(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "pkmstiff"}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module == "pkmstiff":  # `from pkmstiff import x` imports the submodule or name x
                found |= {f"pkmstiff.{a.name}" for a in node.names}
            elif node.module.split(".")[0] == "pkmstiff":
                found.add(node.module)
    return found


def test_components_import_only_units_and_errors_from_pkmstiff():
    files = sorted(Path(components.__file__).parent.rglob("*.py"))
    assert len(files) > 10  # the package was found
    bad = {f"{f.name}: {m}" for f in files for m in _pkmstiff_imports(f) if m not in ALLOWED}
    assert not bad, f"components imports from pkmstiff beyond {sorted(ALLOWED)}: {sorted(bad)}"
