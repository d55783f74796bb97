"""Write the constraints file CI installs the pinned run from (.ci/constraints.txt): the exact versions, in the
running environment, of pkmstiff's dependencies and its ``test`` extra and of everything they require (markers
evaluated for this Python and platform). pkmstiff itself and unrelated packages of the environment are left out.

    python .ci/freeze.py > .ci/constraints.txt     # in a virtual environment where the suite passes
"""

from __future__ import annotations

import sys
import tomllib
from importlib import metadata
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name


def closure(requirements: list[str]) -> dict[str, str]:
    """{distribution name: installed version} of the requirements and, recursively, theirs."""
    todo = [(Requirement(r), "") for r in requirements]
    found: dict[str, str] = {}
    seen: set[tuple[str, frozenset[str]]] = set()
    while todo:
        req, extra = todo.pop()
        if req.marker is not None and not req.marker.evaluate({"extra": extra}):
            continue
        key = (canonicalize_name(req.name), frozenset(req.extras))
        if key in seen:
            continue
        seen.add(key)
        dist = metadata.distribution(req.name)  # fails loudly when a requirement is not installed
        found[dist.metadata["Name"]] = dist.version
        for sub in dist.requires or []:
            r = Requirement(sub)
            for ex in req.extras or {""}:
                todo.append((r, ex))
    return found


def main() -> int:
    project = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())["project"]
    reqs = list(project["dependencies"]) + list(project["optional-dependencies"]["test"])
    pins = closure(reqs)
    pins.pop(project["name"], None)
    py = f"{sys.version_info.major}.{sys.version_info.minor}"
    print(f"# written by .ci/freeze.py (Python {py}); see docs/development.md")
    for name in sorted(pins, key=str.lower):
        print(f"{name}=={pins[name]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
