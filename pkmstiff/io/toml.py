"""Reading TOML input files with errors that name the file (machine files, report specs, sweep files)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pkmstiff.errors import InputError
from pkmstiff.io.inputs import input_file_problem


def read_toml(path: str | Path, error: type[InputError] = InputError, what: str = "TOML file") -> dict[str, Any]:
    """Parse ``path``; a missing file or invalid TOML raises ``error(file, "(file)", expected, found)``."""
    import tomllib  # here: a cached bundled machine needs no TOML parser (start-up time)

    src = str(path)
    problem = input_file_problem(path)
    if problem is not None:
        raise error(src, "(file)", f"an existing {what} (a regular file)", problem)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except RecursionError:
        raise error(src, "(file)", "TOML nested at most a few hundred levels deep", "deeper nesting") from None
    except PermissionError:
        raise error(src, "(file)", f"a readable {what}", "permission denied") from None
    except UnicodeDecodeError as exc:
        raise error(src, "(file)", f"a UTF-8 text {what}",
                    f"non-UTF-8 byte 0x{exc.object[exc.start]:02x} at offset {exc.start}") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(src, "(file)", "valid TOML", str(exc)) from None
