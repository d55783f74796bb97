"""Checking an input path before opening it (issue 22 item 7).

Opening a FIFO for reading blocks until a writer appears (forever, for a command run by hand), a character device such
as ``/dev/zero`` never ends, and "does not exist" is the wrong answer for a directory or a symbolic-link loop. Every
reader asks :func:`input_file_problem` first and reports what it found in one line.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path


def input_file_problem(path: str | Path) -> str | None:
    """None when ``path`` is an existing regular file (after following links); else what it is instead, e.g.
    ``"no such file"``, ``"a directory"``, ``"a FIFO (named pipe)"``, ``"a symbolic link loop"``."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "a dangling symbolic link" if os.path.islink(path) else "no such file"
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return "a symbolic link loop"
        if exc.errno == errno.ENOTDIR:
            return "no such file (a part of the path is a file)"
        if exc.errno == errno.ENAMETOOLONG:
            return "a path that is too long"
        return exc.strerror or type(exc).__name__
    except ValueError:  # an embedded NUL byte
        return "an invalid path"
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe), not a regular file"
    if stat.S_ISSOCK(mode):
        return "a socket, not a regular file"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device, not a regular file"
    return "not a regular file"


def read_text_file(path: str | Path, expected: str) -> str:
    """The text of the UTF-8 input file ``path`` (a byte-order mark, as spreadsheet programs write, is dropped);
    every problem is a one-line :class:`~pkmstiff.errors.InputError` naming the file: not a regular file (found
    what, ``expected`` says what was wanted, e.g. ``"a raw ball-bar series"``), not UTF-8, unreadable."""
    from pkmstiff.errors import InputError

    src = str(path)
    problem = input_file_problem(src)
    if problem is not None:
        raise InputError(src, reason="file not found" if problem == "no such file" else
                         f"expected {expected}, found {problem}")
    try:
        return Path(src).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError(src, reason="file not found") from None
    except UnicodeDecodeError as exc:
        raise InputError(src, reason=f"expected a UTF-8 text file, found the non-UTF-8 byte "
                                     f"0x{exc.object[exc.start]:02x} at offset {exc.start}") from None
    except OSError as exc:
        raise InputError(src, reason=f"cannot read the file ({exc.__class__.__name__})") from None
