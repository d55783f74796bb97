"""Example data shipped with the package: plans and error files of the calibration walkthrough
(docs/user-guide/calibration-walkthrough.md). A path ``example:NAME`` given to a plan or error-file option resolves
to the file ``NAME`` (or ``NAME.toml``) of this folder, so the walkthrough's commands run from any directory.
"""

from __future__ import annotations

from pathlib import Path

from pkmstiff.errors import InputError

#: prefix of a path that names a bundled example file
PREFIX = "example:"


def example_dir() -> Path:
    """The folder of the bundled example files."""
    return Path(__file__).resolve().parent


def example_names() -> list[str]:
    """File names of the bundled examples (plans, error files)."""
    return sorted(p.name for p in example_dir().glob("*.toml"))


def resolve(path: str | Path) -> str | Path:
    """``example:NAME`` -> the bundled file's path; any other path unchanged. An unknown example name is a one-line
    error listing the known ones."""
    text = str(path)
    if not text.startswith(PREFIX):
        return path
    name = text[len(PREFIX):]
    p = example_dir() / name
    if not p.suffix and name:
        p = p.with_suffix(".toml")
    if not name or "/" in name or "\\" in name or not p.is_file():
        raise InputError(text, "example", f"one of {', '.join(PREFIX + n for n in example_names())}",
                                    name or "an empty name")
    return p
