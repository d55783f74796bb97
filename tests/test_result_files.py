"""Large result arrays of local workers through files in shared memory (pkmstiff.evaluation.result_files)."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from dataclasses import dataclass

import numpy as np
import pytest

from pkmstiff.evaluation import parallel, result_files

pytestmark = pytest.mark.skipif(result_files.directory() is None, reason="no writable /dev/shm")


@dataclass
class _Part:
    keys: np.ndarray
    counts: list[int]
    inner: tuple | None = None


def _result(n: int = 100_000) -> tuple:
    rng = np.random.default_rng(5)
    big = rng.normal(size=(3, n))
    flags = rng.random(n) < 0.5
    return (big, flags, np.arange(10), {"s": 1.5, "keys": np.arange(n, dtype=np.int64)},
            _Part(np.arange(n, dtype=np.int64)[::-1].copy(), [1, 2], (np.ones((n, 8), bool), "x")))


def _same(a, b) -> None:
    assert type(a) is type(b)
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            _same(x, y)
    elif isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            _same(a[k], b[k])
    elif isinstance(a, _Part):
        _same((a.keys, a.counts, a.inner), (b.keys, b.counts, b.inner))
    else:
        assert a == b


def _files(where: str) -> list[str]:
    return sorted(os.listdir(where))


def test_round_trip_gives_the_same_bytes_and_leaves_no_file(tmp_path):
    where = str(tmp_path)
    out = result_files.call(where, _result)
    assert isinstance(out, result_files.WithFiles)
    # the large arrays (≥ OUT_OF_BAND_BYTES) went to files, private to this user; the small one stayed
    assert isinstance(out.value[0], result_files.FileArray) and isinstance(out.value[1], np.ndarray)
    assert isinstance(out.value[4].keys, result_files.FileArray)
    assert len(_files(where)) == 4  # big, the dict's keys, the dataclass's keys and its (n, 8) flags
    for name in _files(where):
        assert stat.S_IMODE(os.stat(os.path.join(where, name)).st_mode) == 0o600
    back = result_files.restore(out)
    _same(back, _result())
    assert _files(where) == []
    back[0][0, 0] = 42.0  # writable, as an array from the pipe is
    assert back[0][0, 0] == 42.0


def test_small_results_and_no_directory_travel_as_they_are(tmp_path):
    small = (np.arange(5), {"a": 1})
    assert result_files.call(str(tmp_path), lambda: small) is small
    big = _result()
    assert result_files.call(None, lambda: big) is big


def test_a_file_that_cannot_be_written_leaves_the_array_in_the_result(tmp_path, monkeypatch):
    def full(*_a, **_k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(result_files.tempfile, "mkstemp", full)
    big = _result()
    assert result_files.call(str(tmp_path), lambda: big) is big
    assert _files(str(tmp_path)) == []


def test_the_local_pool_hands_large_results_over_through_files():
    try:
        futures = [parallel.submit(2, _result, n) for n in (100_000, 50_000)]
        got = [parallel.result(f, 2) for f in futures]
    finally:
        parallel.shutdown()
    _same(got[0], _result(100_000))
    _same(got[1], _result(50_000))
    assert _files(result_files.directory()) == []


def test_directories_of_ended_processes_are_removed(monkeypatch, tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True,
                          check=True)
    pid = int(dead.stdout)
    orphan = tmp_path / f"pkmstiff-results-{pid}-abc"
    orphan.mkdir()
    (orphan / "x").write_bytes(b"1")
    mine = tmp_path / f"pkmstiff-results-{os.getpid()}-def"  # a live process's (this one)
    mine.mkdir()
    monkeypatch.setattr(result_files, "SHARED_MEMORY", tmp_path)
    made = result_files._make_directory()
    assert made is not None and os.path.dirname(made) == str(tmp_path)
    assert stat.S_IMODE(os.stat(made).st_mode) == 0o700
    assert not orphan.exists() and mine.exists()
