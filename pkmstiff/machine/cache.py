"""On-disk cache of loaded bundled machines (start-up time, issue 12 item 6).

Loading a machine parses TOML, converts every quantity with pint and builds the convex hull with scipy: ~0.4 s of a
one-pose command's start-up, mostly imports. A bundled machine (by name, with or without options) is therefore stored
after its first load as a pickle in the user cache directory and read back in well under a millisecond.

The key is a hash of the Python/numpy versions, the machine name and options and the size and
modification time of every file the result can depend on (the bundled machine files, the machine/unit/io code and the
component library with its data). Machines loaded from a path are never cached (their component data may live
anywhere). Any problem with the cache (no writable directory, a damaged or foreign file) falls back to the ordinary
load; ``PKMSTIFF_CACHE=0`` switches the cache off, ``PKMSTIFF_CACHE_DIR`` moves it.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import sys
from pathlib import Path
from typing import Any, Callable

_PKG = Path(__file__).resolve().parent.parent


def cache_dir() -> Path | None:
    """The directory of the cache, or None when it is switched off (``PKMSTIFF_CACHE=0``)."""
    if os.environ.get("PKMSTIFF_CACHE", "1").strip().lower() in ("0", "off", "no", "false"):
        return None
    if os.environ.get("PKMSTIFF_CACHE_DIR"):
        return Path(os.environ["PKMSTIFF_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "pkmstiff"


def _dependency_files() -> list[Path]:
    """Every file a bundled machine's loaded form depends on."""
    roots = [_PKG / "machine", _PKG / "io"]
    files = [_PKG / "units.py", _PKG / "errors.py", _PKG / "__init__.py"]
    try:
        import importlib.util

        spec = importlib.util.find_spec("components")
        if spec is not None and spec.origin:
            roots.append(Path(spec.origin).parent)
    except (ImportError, ValueError):
        pass
    for root in roots:
        for dirpath, dirnames, filenames in os.walk(root):
            dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
            files += [Path(dirpath) / f for f in sorted(filenames) if not f.endswith((".pyc", ".pyo"))]
    return files


def cache_key(name: str, options: list[str]) -> str:
    import numpy

    h = hashlib.sha256()  # the package version is covered by the stat of pkmstiff/__init__.py, which defines it
    h.update(repr((sys.version, numpy.__version__, name, list(options), str(_PKG))).encode())
    for f in _dependency_files():
        try:
            st = f.stat()
        except OSError:
            continue
        h.update(f"{f}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
    return h.hexdigest()[:32]


#: cache files not read or written for this long are removed when a new one is written (old package versions)
MAX_AGE_S = 30 * 24 * 3600


def _prune(d: Path) -> None:
    import time

    now = time.time()
    for f in d.glob("machine-*.pickle"):
        try:
            if now - max(f.stat().st_mtime, f.stat().st_atime) > MAX_AGE_S:
                f.unlink()
        except OSError:
            pass


def cached_load(name: str, options: list[str], load: Callable[[], Any]) -> Any:
    """``load()`` through the cache (``name`` a bundled machine name, ``options`` its selected options)."""
    d = cache_dir()
    if d is None:
        return load()
    try:
        path = d / f"machine-{name}-{cache_key(name, options)}.pickle"
    except Exception:  # noqa: BLE001 (cache is an optimisation only)
        return load()
    try:
        with open(path, "rb") as fh:
            return pickle.load(fh)
    except Exception:  # noqa: BLE001 (missing, damaged or from another version: load and store afresh)
        pass
    machine = load()
    try:
        d.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        with open(tmp, "wb") as fh:
            pickle.dump(machine, fh, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(tmp, path)
        _prune(d)
    except Exception:  # noqa: BLE001 (read-only home, full disk, unpicklable user component: no cache)
        try:
            tmp.unlink()  # type: ignore[possibly-undefined]
        except Exception:  # noqa: BLE001
            pass
    return machine
