"""Large arrays of a local worker's result handed over through files in shared memory instead of the result pipe
(issue 25: the serial share of a parallel run).

Through the pipe, a result is pickled in the worker and, in this process, read in pieces into a growing buffer and
unpickled into fresh arrays: two to three copies of every byte and a page fault for every fresh page, all on this
process's result thread while the workers wait for nothing but this process's share. A 1.25 mm section's eight results
(≈ 3 MB each) cost this process 20–24 ms of its 58–65 ms serial CPU that way. Here a worker writes each array of
:data:`OUT_OF_BAND_BYTES` or more into a file of its own in this process's private directory on ``/dev/shm`` (memory,
not disk) and sends a :class:`FileArray` (path, dtype, shape) in its place; this process maps the file copy-on-write
(the array's memory; nothing copied, writable as any array) and unlinks it at once.

Safety: the directory is made by this process (``mkdtemp``: mode 0700, a random name), each file by a worker with
``O_EXCL`` and mode 0600; only raw bytes are read from a file, never a pickle; dtype and shape come through the pipe.
Where there is no ``/dev/shm`` (macOS, Windows), or a file cannot be written (a full ``/dev/shm``: Docker gives 64 MB),
the array travels in the pipe as before. The files a run leaves (tasks cancelled before their result was collected)
are removed when the pools stop, the directory when this process ends, and directories left by processes that died
(untouched for :data:`ORPHAN_SECONDS`) are removed by the next command that makes its own.
"""

from __future__ import annotations

import atexit
import copy
import dataclasses
import mmap
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from contextlib import suppress
from pathlib import Path
from typing import Any, NamedTuple, Self

import numpy as np

#: arrays from this size (bytes) on go through a file: below it a file's five system calls here cost about what the
#: pipe's copies cost
OUT_OF_BAND_BYTES = 256 << 10
#: where the directories are made (a memory file system on Linux)
SHARED_MEMORY = Path("/dev/shm")
_PREFIX = "pkmstiff-results-"
_DIRECTORY: list[str | None] = []  # [this process's directory or None], once made


class FileArray(NamedTuple):
    """An array a worker wrote to ``path`` (raw bytes, C order)."""

    path: str
    dtype: str
    shape: tuple[int, ...]


@dataclasses.dataclass
class WithFiles:
    """A result whose large arrays are :class:`FileArray` s (:func:`restore` maps them)."""

    value: Any


def directory() -> str | None:
    """This process's directory for its workers' result files (made at the first call), None where there is no
    writable ``/dev/shm``."""
    if not _DIRECTORY:
        _DIRECTORY.append(_make_directory())
    return _DIRECTORY[0]


def _make_directory() -> str | None:
    if not (SHARED_MEMORY.is_dir() and os.access(SHARED_MEMORY, os.W_OK | os.X_OK)):
        return None
    _remove_orphans()
    try:
        path = tempfile.mkdtemp(prefix=f"{_PREFIX}{os.getpid()}-", dir=SHARED_MEMORY)
    except OSError:
        return None
    atexit.register(shutil.rmtree, path, True)
    return path


#: a directory of a process that no longer runs is removed once untouched this long (s): a process of another PID
#: namespace sharing ``/dev/shm`` (containers) looks ended from here, but its run touches its directory with every task
ORPHAN_SECONDS = 3600.0


def _remove_orphans() -> None:
    """Remove the directories of this user's processes that ended without removing theirs (killed)."""
    try:
        entries = list(os.scandir(SHARED_MEMORY))
    except OSError:
        return
    now = time.time()
    for e in entries:
        if not e.name.startswith(_PREFIX):
            continue
        try:
            pid = int(e.name[len(_PREFIX):].split("-", 1)[0])
            st = e.stat(follow_symlinks=False)
            if st.st_uid != os.getuid() or not e.is_dir(follow_symlinks=False) or now - st.st_mtime < ORPHAN_SECONDS:
                continue
            os.kill(pid, 0)
        except ProcessLookupError:
            shutil.rmtree(e.path, ignore_errors=True)
        except (ValueError, OSError):
            continue


def clear() -> None:
    """Remove the result files no one collected (the pools have stopped)."""
    if _DIRECTORY and _DIRECTORY[0] is not None:
        with suppress(OSError):  # also: gone already (this process is ending)
            for e in os.scandir(_DIRECTORY[0]):
                with suppress(OSError):
                    os.unlink(e.path)


class OutputTarget(NamedTuple):
    """Where a task writes its part of a :class:`SharedOutput` (picklable: the file and, per array, its byte offset,
    shape and dtype)."""

    path: str
    layout: dict[str, tuple[int, tuple[int, ...], str]]

    def writer(self) -> OutputWriter:
        return OutputWriter(self)


class OutputWriter:
    """A task's open handle on an :class:`OutputTarget` (a context manager)."""

    def __init__(self, target: OutputTarget):
        self.target = target
        self.fd = os.open(target.path, os.O_WRONLY)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *_: object) -> None:
        os.close(self.fd)

    def put(self, name: str, start: int, values: np.ndarray) -> None:
        """Columns ``start`` … ``start + k - 1`` (along the last axis) of array ``name`` := ``values`` (..., k)."""
        offset, shape, dtype = self.target.layout[name]
        dt = np.dtype(dtype)
        v = np.ascontiguousarray(values, dt)
        n, k = shape[-1], v.shape[-1]
        if v.shape[:-1] != tuple(shape[:-1]) or start < 0 or start + k > n:
            raise ValueError(f"{name}: part of shape {v.shape} at column {start} does not fit {shape}")
        rows = v.reshape(-1, k)
        for r in range(rows.shape[0]):
            _pwrite_all(self.fd, rows[r], offset + (r * n + start) * dt.itemsize)


def _pwrite_all(fd: int, a: np.ndarray, at: int) -> None:
    """The bytes of the C-contiguous array ``a`` into file ``fd`` from byte ``at`` on (``pwrite`` may write less
    than asked)."""
    view = memoryview(a).cast("B")
    while view:
        done = os.pwrite(fd, view, at)
        view, at = view[done:], at + done


class SharedOutput:
    """Arrays of a run's result written in place by its tasks: one file in this process's directory, mapped here
    (shared), each task writing its columns with ``pwrite`` (:class:`OutputWriter`); no result crosses the pipe and
    nothing is joined here. :meth:`create` returns None where there is no directory (then results travel as usual).
    :meth:`close` unlinks the file once the tasks are done (the arrays stay)."""

    def __init__(self, path: str, layout: dict[str, tuple[int, tuple[int, ...], str]], buf: mmap.mmap):
        self.target = OutputTarget(path, layout)
        self.arrays = {name: np.ndarray(shape, np.dtype(dt), buffer=buf, offset=off)
                       for name, (off, shape, dt) in layout.items()}

    @classmethod
    def create(cls, arrays: dict[str, tuple[tuple[int, ...], Any]]) -> SharedOutput | None:
        where = directory()
        if where is None:
            return None
        layout, size = {}, 0
        for name, (shape, dtype) in arrays.items():
            dt = np.dtype(dtype)
            layout[name] = (size, tuple(int(x) for x in shape), dt.str)
            size += -(-int(np.prod(shape, dtype=np.int64)) * dt.itemsize // 64) * 64  # each array 64-byte aligned
        try:
            free = os.statvfs(where)
            if free.f_bavail * free.f_frsize < 2 * size:  # no room: the parts come back through the pipe
                return None
            fd, path = tempfile.mkstemp(dir=where)
        except OSError:
            return None
        try:
            os.ftruncate(fd, max(size, 1))
            buf = mmap.mmap(fd, max(size, 1), flags=mmap.MAP_SHARED, prot=mmap.PROT_READ | mmap.PROT_WRITE)
        except OSError:
            with suppress(OSError):
                os.unlink(path)
            return None
        finally:
            os.close(fd)
        return cls(path, layout, buf)

    def copies(self) -> dict[str, np.ndarray]:
        """Ordinary arrays with what the file holds (zeros where nothing was written), read with ``pread``: where a
        write was refused the file may have holes, and touching a hole through the mapping of a full ``/dev/shm``
        would kill the process (SIGBUS)."""
        out = {}
        fd = os.open(self.target.path, os.O_RDONLY)
        try:
            for name, (off, shape, dt) in self.target.layout.items():
                a = np.zeros(shape, np.dtype(dt))
                view, at = memoryview(a).cast("B"), off
                while view:
                    got = os.preadv(fd, [view], at)
                    if got == 0:
                        break
                    view, at = view[got:], at + got
                out[name] = a
        finally:
            os.close(fd)
        return out

    def close(self) -> None:
        with suppress(OSError):
            os.unlink(self.target.path)


def call(where: str | None, fn: Callable[..., Any], *args: Any) -> Any:
    """In a worker: ``fn(*args)`` with its large arrays written to files in ``where`` (None: as it is)."""
    out = fn(*args)
    if where is None:
        return out
    moved = [False]
    value = _to_files(out, where, moved)
    return WithFiles(value) if moved[0] else out


def restore(result: Any) -> Any:
    """In this process: a worker's result with its files mapped as arrays (and removed)."""
    return _from_files(result.value) if isinstance(result, WithFiles) else result


def _to_files(obj: Any, where: str, moved: list[bool]) -> Any:
    if isinstance(obj, np.ndarray):
        if obj.nbytes < OUT_OF_BAND_BYTES or obj.dtype.hasobject or obj.dtype.fields is not None:
            return obj
        handle = _write(obj, where)
        moved[0] = moved[0] or handle is not None
        return obj if handle is None else handle
    return _walk(obj, lambda x: _to_files(x, where, moved))


def _from_files(obj: Any) -> Any:
    return _read(obj) if isinstance(obj, FileArray) else _walk(obj, _from_files)


def _walk(obj: Any, fn: Callable[[Any], Any]) -> Any:
    """``obj`` with ``fn`` applied to the items of its containers (tuples, lists, dicts, dataclass instances)."""
    if isinstance(obj, tuple) and not hasattr(obj, "_fields"):
        return tuple(fn(x) for x in obj)
    if isinstance(obj, list):
        return [fn(x) for x in obj]
    if isinstance(obj, dict):
        return {k: fn(v) for k, v in obj.items()}
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        new = copy.copy(obj)
        for f in dataclasses.fields(obj):
            object.__setattr__(new, f.name, fn(getattr(obj, f.name)))
        return new
    return obj


def _write(a: np.ndarray, where: str) -> FileArray | None:
    a = np.ascontiguousarray(a)
    try:
        fd, path = tempfile.mkstemp(dir=where)  # O_EXCL, mode 0600
    except OSError:
        return None
    try:
        _pwrite_all(fd, a, 0)
    except OSError:  # full: the pipe takes it
        with suppress(OSError):
            os.unlink(path)
        return None
    finally:
        os.close(fd)
    return FileArray(path, a.dtype.str, tuple(a.shape))


def _read(h: FileArray) -> np.ndarray:
    fd = os.open(h.path, os.O_RDONLY)
    try:
        os.unlink(h.path)
        dtype = np.dtype(h.dtype)
        size = int(np.prod(h.shape, dtype=np.int64)) * dtype.itemsize
        held = os.fstat(fd).st_size
        if held != size:
            raise OSError(f"{h.path}: a worker's result file holds {held} bytes, expected {size}")
        buf = mmap.mmap(fd, size, flags=mmap.MAP_PRIVATE, prot=mmap.PROT_READ | mmap.PROT_WRITE)
    finally:
        os.close(fd)
    return np.frombuffer(buf, dtype).reshape(h.shape)
