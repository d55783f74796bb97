"""Large result arrays of local workers through files in shared memory (pkmstiff.evaluation.result_files)."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
import time
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
    recent = tmp_path / f"pkmstiff-results-{pid}-ghi"  # an ended pid's, touched a moment ago: another namespace's?
    recent.mkdir()
    old = time.time() - 2 * result_files.ORPHAN_SECONDS
    os.utime(orphan, (old, old))
    os.utime(mine, (old, old))
    monkeypatch.setattr(result_files, "SHARED_MEMORY", tmp_path)
    made = result_files._make_directory()
    assert made is not None and os.path.dirname(made) == str(tmp_path)
    assert stat.S_IMODE(os.stat(made).st_mode) == 0o700
    assert not orphan.exists() and mine.exists() and recent.exists()


def test_tasks_write_their_columns_into_a_shared_output():
    out = result_files.SharedOutput.create({"ok": ((10,), bool), "vals": ((3, 10), float)})
    assert out is not None
    try:
        with out.target.writer() as w:  # as a worker does, in two parts
            w.put("ok", 0, np.array([True, False, True]))
            w.put("vals", 0, np.arange(9.0).reshape(3, 3))
        with out.target.writer() as w:
            w.put("ok", 3, np.ones(7, bool))
            w.put("vals", 3, -np.arange(21.0).reshape(3, 7))
            with pytest.raises(ValueError, match="does not fit"):
                w.put("vals", 8, np.zeros((3, 3)))
    except BaseException:
        out.close()
        raise
    # ordinary arrays read with pread (what a refused write leaves falls back to): the same values
    copies = out.copies()
    assert all(np.array_equal(copies[k], out.arrays[k]) and not np.shares_memory(copies[k], out.arrays[k])
               for k in out.arrays)
    out.close()
    assert not os.path.exists(out.target.path)  # unlinked; the arrays stay
    assert out.arrays["ok"].tolist() == [True, False, True] + [True] * 7
    expect = np.concatenate([np.arange(9.0).reshape(3, 3), -np.arange(21.0).reshape(3, 7)], axis=1)
    assert out.arrays["vals"].tobytes() == expect.tobytes()


def test_a_shared_output_with_unwritten_columns_reads_back_zeros_there():
    out = result_files.SharedOutput.create({"vals": ((2, 100_000), float)})
    assert out is not None
    try:
        with out.target.writer() as w:
            w.put("vals", 50_000, np.ones((2, 50_000)))
        got = out.copies()["vals"]
    finally:
        out.close()
    assert (got[:, :50_000] == 0).all() and (got[:, 50_000:] == 1).all()


def test_no_shared_output_where_the_directory_lacks_room(monkeypatch):
    class Full:
        f_bavail, f_frsize = 10, 4096

    monkeypatch.setattr(result_files.os, "statvfs", lambda _: Full())
    assert result_files.SharedOutput.create({"vals": ((2, 100_000), float)}) is None


def test_sections_are_the_same_whether_workers_write_in_place_or_return_their_parts(monkeypatch):
    """--jobs 2 with the shared output, with every write refused (a full /dev/shm: the parts come back) and serially:
    the same bytes."""
    from pkmstiff.evaluation import sections
    from pkmstiff.evaluation.sections import axis_plane, evaluate_section
    from pkmstiff.machine.variants import machine_with

    machine = machine_with("hexaglide")
    plane = axis_plane("yz", 0.0, (-0.2, 0.4), (-1.2, -0.6), 0.01)
    kw = {"quantities": ["kx", "f1"], "chunk_size": 512, "progress": False}
    made = []
    create = result_files.SharedOutput.create
    monkeypatch.setattr(result_files.SharedOutput, "create", lambda arrays: made.append(create(arrays)) or made[-1])
    try:
        serial = evaluate_section(machine, plane, **kw)
        assert made == []  # serially nothing is shared
        in_place = evaluate_section(machine, plane, n_jobs=2, **kw)
        assert in_place.plan is not None and in_place.plan.parallel and made[-1] is not None
        assert np.shares_memory(in_place.ok, made[-1].arrays["ok"])  # the workers' columns, not a joined copy
        assert _files(result_files.directory()) == []

        def refused(*_a):
            raise OSError(28, "No space left on device")

        monkeypatch.setattr(sections, "_put", lambda *a: False)  # here: the first chunk and the fallback
        monkeypatch.setattr(result_files.os, "pwrite", refused)  # in the workers forked from now on
        parallel.shutdown()
        returned = evaluate_section(machine, plane, n_jobs=2, **kw)
    finally:
        parallel.shutdown()
    for r in (in_place, returned):
        assert r.ok.tobytes() == serial.ok.tobytes() and r.reasons.tobytes() == serial.reasons.tobytes()
        for name in ("kx", "f1"):
            assert r.values[name].tobytes() == serial.values[name].tobytes()
        assert r.kappa.tobytes() == serial.kappa.tobytes()
