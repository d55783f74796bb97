"""The one TOML reader of pkmstiff: every TOML input (machine, planar machine and mechanism files, report specs, sweep
files, calibration plans and error files, FE parameter files) is read here, and every failure to read one is an
:class:`~pkmstiff.errors.InputError` naming the file (and, for invalid TOML, the line and column)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from pkmstiff.errors import InputError
from pkmstiff.io.inputs import input_file_problem

#: tomllib's position suffix: "... (at line 3, column 7)" (Python 3.11 and 3.12 keep it only in the message)
_POSITION = re.compile(r"\s*\(at line (\d+), column (\d+)\)$")


def read_toml(path: str | Path, what: str = "TOML file") -> dict[str, Any]:
    """Parse ``path`` (a ``what``, e.g. "machine file"); a missing, unreadable or invalid file raises
    :class:`InputError` with the file, key "(file)", what was expected and what was found."""
    import tomllib  # here: a cached bundled machine needs no TOML parser (start-up time)

    src = str(path)
    problem = input_file_problem(path)
    if problem is not None:
        raise InputError(src, "(file)", f"an existing {what} (a regular file)", problem)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except RecursionError:
        raise InputError(src, "(file)", "TOML nested at most a few hundred levels deep", "deeper nesting") from None
    except PermissionError:
        raise InputError(src, "(file)", f"a readable {what}", "permission denied") from None
    except UnicodeDecodeError as exc:
        raise InputError(src, "(file)", f"a UTF-8 text {what}",
                         f"non-UTF-8 byte 0x{exc.object[exc.start]:02x} at offset {exc.start}") from None
    except tomllib.TOMLDecodeError as exc:
        text = str(exc)
        m = _POSITION.search(text)
        line, column = (int(m.group(1)), int(m.group(2))) if m else (None, None)
        raise InputError(src, "(file)", "valid TOML", _POSITION.sub("", text), line=line, column=column) from None
