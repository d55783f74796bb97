"""Writing output files safely: names confined to the output directory, and whole files or none (issue 22, item 7).

Every writer of the toolkit goes through this module:

* :func:`safe_stem` turns a name taken from an input file (a machine's or mechanism's ``name``) into a file-name stem
  that cannot leave the output directory (no separators, no ``..``, no absolute paths);
* :func:`output_path` joins an output directory and a file name and refuses any result outside the directory;
* :func:`atomic_path` / :func:`atomic_open` / :func:`atomic_write_text` write to a temporary file in the target
  directory and rename it over the target only when the write succeeded, so a failing write (full disk, file-size limit,
  an interrupt) leaves the previous file intact and no partial file behind.
"""

from __future__ import annotations

import os
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Iterator

from pkmstiff.errors import OutputPathError

#: characters kept in a file-name stem taken from input data; everything else becomes '_'
_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]+")


def safe_stem(name: str) -> str:
    """A file-name stem from ``name`` (a machine or mechanism name): letters, digits, ``. _ + -`` only, no leading dot.

    ``"../../x"`` → ``"x"``, ``"/etc/passwd"`` → ``"etc_passwd"``, ``"felix:tilt"`` → ``"felix_tilt"``.
    """
    stem = _UNSAFE.sub("_", str(name)).strip("._")
    return stem or "output"


def output_path(out_dir: str | Path, name: str) -> Path:
    """``out_dir / name``, refused unless it stays inside ``out_dir`` (``name`` is a plain file name)."""
    base = Path(out_dir)
    p = base / name
    if Path(name).name != name or name in ("", ".", ".."):
        raise OutputPathError(f"output file name: expected a plain file name inside {str(base)!r}, found {name!r}")
    root = os.path.realpath(base)
    if os.path.dirname(os.path.realpath(p)) != root:
        raise OutputPathError(f"output file name: expected a file inside {str(base)!r}, found {str(p)!r} "
                              f"(a link that leads elsewhere)")
    return p


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same suffix, so writers that choose the format by suffix keep working);
    on success it is renamed over ``path``, on any error it is removed and ``path`` is left as it was."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=f".tmp{target.suffix}", dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.chmod(tmp_path, 0o666 & ~_umask())
        os.replace(tmp_path, target)
    except BaseException:
        try:
            tmp_path.unlink()
        except OSError:
            pass
        raise


@contextmanager
def atomic_open(path: str | Path, mode: str = "w", **kwargs) -> Iterator[IO]:
    """``open(path, mode, **kwargs)`` written atomically (see :func:`atomic_path`); ``mode`` 'w' or 'wb'."""
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open: expected mode 'w' or 'wb', found {mode!r}")
    with atomic_path(path) as tmp:
        with open(tmp, mode, **kwargs) as fh:
            yield fh


def atomic_write_text(path: str | Path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically; returns ``path``."""
    with atomic_open(path, "w", encoding=encoding, newline="") as fh:
        fh.write(text)
    return Path(path)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
