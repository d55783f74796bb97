"""On-disk cache of loaded bundled machines (start-up time, issue 12 item 6), in a data-only format (issue 22 item 7).

Loading a machine parses TOML, converts every quantity with pint and builds the convex hull with scipy: ~0.4 s of a
one-pose command's start-up, mostly imports. A bundled machine (by name, with or without options) is therefore stored
after its first load in the user cache directory and read back in a few milliseconds.

The file is data only: one ``.npz`` archive read with ``allow_pickle=False`` that holds the arrays and a JSON
description of the object graph (:func:`encode` / :func:`decode`). Decoding creates objects only of classes defined in
the ``pkmstiff`` and ``components`` packages, without calling their constructors (``__new__`` and the saved
attributes, as pickle does for them), so a planted or foreign file can at worst describe a wrong machine of the
toolkit's own types, never run code. A file is read only when it and its directory belong to the user and are not
writable by group or others; a directory shared with others switches the cache off.

The key is a hash of the Python/numpy versions, the machine name and options and the size and
modification time of every file the result can depend on (the bundled machine files, the machine/unit/io code and the
component library with its data). Machines loaded from a path are never cached (their component data may live
anywhere). Any problem with the cache (no writable directory, a damaged, foreign or unsafe file, an object the format
cannot hold) falls back to the ordinary load; ``PKMSTIFF_CACHE=0`` switches the cache off, ``PKMSTIFF_CACHE_DIR``
moves it.
"""

from __future__ import annotations

import enum
import hashlib
import importlib
import io
import json
import os
import re
import stat
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
SUFFIX = ".npz"
#: modules whose classes a cache file may name
_MODULE = re.compile(r"(pkmstiff|components)(\.[A-Za-z_][A-Za-z0-9_]*)*")


class Unsupported(Exception):
    """An object the data-only format cannot hold, or a file that does not describe one."""


# ------------------------------------------------------------------------------------------------ data-only codec


def encode(obj: Any) -> tuple[str, dict[str, Any]]:
    """``obj`` as (JSON text, arrays): numbers, strings, containers, numpy arrays/scalars/dtypes, enums and objects of
    ``pkmstiff``/``components`` classes (their pickle state); anything else raises :class:`Unsupported`. An object
    reached twice is written once and referred to (``{"ref": n}``), so shared objects stay shared, as with pickle."""
    import numpy as np

    arrays: dict[str, Any] = {}
    seen: dict[int, int] = {}
    alive: list[Any] = []  # every object numbered stays alive, so that its id() is not reused (a state tuple is new)

    def enc(o: Any) -> Any:
        if o is None or isinstance(o, (bool, str)) or type(o) in (int, float):
            return o
        if isinstance(o, np.generic):
            return {"scalar": o.dtype.str, "value": o.item()}
        if isinstance(o, np.dtype):
            return {"dtype": o.str}
        if id(o) in seen:
            return {"ref": seen[id(o)]}
        n = seen[id(o)] = len(seen)
        alive.append(o)
        if type(o) is list:
            return {"list": [enc(v) for v in o], "id": n}
        if type(o) is tuple:
            return {"tuple": [enc(v) for v in o], "id": n}
        if type(o) in (set, frozenset):
            return {type(o).__name__: [enc(v) for v in o], "id": n}
        if type(o) is dict:
            return {"dict": [[enc(k), enc(v)] for k, v in o.items()], "id": n}
        if type(o) is np.ndarray:
            if o.dtype.hasobject:
                raise Unsupported("object array")
            key = f"a{len(arrays)}"
            arrays[key] = o
            return {"array": key, "id": n}
        cls = type(o)
        if not _MODULE.fullmatch(cls.__module__ or "") or "<" in cls.__qualname__:
            raise Unsupported(f"{cls.__module__}.{cls.__qualname__}")
        name = f"{cls.__module__}:{cls.__qualname__}"
        if isinstance(o, enum.Enum):
            return {"enum": name, "value": enc(o.value), "id": n}
        return {"object": name, "id": n, "state": enc(o.__getstate__())}

    return json.dumps(enc(obj), allow_nan=True), arrays


def _class(name: str) -> type:
    module, _, qualname = name.partition(":")
    if not _MODULE.fullmatch(module) or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_.]*", qualname):
        raise Unsupported(name)
    obj: Any = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    if not isinstance(obj, type) or obj.__module__ != module:
        raise Unsupported(name)
    return obj


def decode(text: str, arrays: Any) -> Any:
    """The object :func:`encode` described (``arrays``: a mapping of the archive's arrays)."""
    import numpy as np

    made: dict[int, Any] = {}

    def keep(o: dict, value: Any) -> Any:
        made[o["id"]] = value
        return value

    def dec(o: Any) -> Any:
        if not isinstance(o, dict):
            if isinstance(o, list):  # lists appear only inside the tagged forms below
                raise Unsupported("untagged list")
            return o
        tag, val = next(iter(o.items()))
        if tag == "ref":
            return made[val]
        if tag == "scalar":
            return np.dtype(val).type(o["value"])
        if tag == "dtype":
            return np.dtype(val)
        if tag == "list":
            out = keep(o, [])
            out += [dec(v) for v in val]
            return out
        if tag == "dict":
            d = keep(o, {})
            for k, v in val:
                d[dec(k)] = dec(v)
            return d
        if tag == "tuple":
            return keep(o, tuple(dec(v) for v in val))
        if tag in ("set", "frozenset"):
            return keep(o, (set if tag == "set" else frozenset)(dec(v) for v in val))
        if tag == "array":
            return keep(o, np.array(arrays[val]))
        cls = _class(val)
        if tag == "enum" and issubclass(cls, enum.Enum):
            return keep(o, cls(dec(o["value"])))
        if tag != "object":
            raise Unsupported(tag)
        new = keep(o, object.__new__(cls))
        state = dec(o["state"])
        if "__setstate__" in _own_attrs(cls):
            new.__setstate__(state)
            return new
        slots = None
        if isinstance(state, tuple) and len(state) == 2:
            state, slots = state
        for k, v in {**(state or {}), **(slots or {})}.items():
            object.__setattr__(new, k, v)
        return new

    return dec(json.loads(text))


def _own_attrs(cls: type) -> set[str]:
    """Attributes defined by ``cls`` or its bases other than ``object``."""
    return {k for c in cls.__mro__ if c is not object for k in vars(c)}


def _safe(path: Path) -> bool:
    """``path`` (file or directory) belongs to this user and is not writable by group or others."""
    st = os.lstat(path)
    return (st.st_uid == os.getuid() and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)
            and (stat.S_ISREG(st.st_mode) or stat.S_ISDIR(st.st_mode)))


def _read(path: Path) -> Any:
    import numpy as np

    if not (_safe(path.parent) and _safe(path)):
        raise Unsupported(f"{path}: not owned by the user, or writable by others")
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    meta = arrays.pop("__json__")
    return decode(meta.tobytes().decode("utf-8"), arrays)


def _write(path: Path, obj: Any) -> None:
    import numpy as np

    text, arrays = encode(obj)
    buf = io.BytesIO()
    np.savez(buf, __json__=np.frombuffer(text.encode("utf-8"), dtype=np.uint8), **arrays)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "wb") as fh:
            fh.write(buf.getvalue())
        os.replace(tmp, path)
    except BaseException:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


def _prune(d: Path) -> None:
    import time

    now = time.time()
    for f in d.glob("machine-*"):
        try:
            if f.suffix == ".pickle" or now - max(f.stat().st_mtime, f.stat().st_atime) > MAX_AGE_S:
                f.unlink()  # old entries, and every pickle of earlier versions (never read again)
        except OSError:
            pass


def cached_load(name: str, options: list[str], load: Callable[[], Any]) -> Any:
    """``load()`` through the cache (``name`` a bundled machine name, ``options`` its selected options)."""
    d = cache_dir()
    if d is None:
        return load()
    try:
        path = d / f"machine-{name}-{cache_key(name, options)}{SUFFIX}"
    except Exception:  # noqa: BLE001 (cache is an optimisation only)
        return load()
    try:
        return _read(path)
    except Exception:  # noqa: BLE001 (missing, damaged, unsafe or from another version: load and store afresh)
        pass
    machine = load()
    try:
        d.mkdir(parents=True, exist_ok=True, mode=0o700)
        if _safe(d):
            _write(path, machine)
            _prune(d)
    except Exception:  # noqa: BLE001 (read-only home, full disk, a component the format cannot hold: no cache)
        pass
    return machine
