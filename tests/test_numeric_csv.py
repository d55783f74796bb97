"""The columnar CSV writer (:mod:`pkmstiff.io.numeric_csv`) against :func:`csv.writer` cell by cell, its row
de-duplication against ``np.unique``, and the files the commands write with it (the same bytes as the per-row
writers they replace, whatever the number of threads)."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from pkmstiff.io.columns import write_column_table, write_table
from pkmstiff.io.numeric_csv import BLOCK_ROWS, distinct_rows, write_numeric_csv


def _reference(header, columns, float_format, blank_infinite):
    """What csv.writer writes for the cells, one Python call per cell (the writers this module replaces)."""
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(header)
    for row in zip(*[c.tolist() for c in columns]):
        cells = []
        for x in row:
            if isinstance(x, float):
                blank = not math.isfinite(x) if blank_infinite else math.isnan(x)
                cells.append("" if blank else format(x, float_format))
            else:
                cells.append(str(int(x)))
        w.writerow(cells)
    return buf.getvalue().encode()


def _written(header, columns, float_format, blank_infinite=False):
    fh = io.BytesIO()
    write_numeric_csv(fh, header, columns, float_format, blank_infinite)
    return fh.getvalue()


floats = hnp.arrays(np.float64, st.integers(0, 40), elements=st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64), st.sampled_from([0.0, -0.0, 1.5, -200.625, 1e-320])))


@settings(max_examples=60, deadline=None)
@given(floats, st.sampled_from([".10g", ".6g", ""]), st.booleans(), st.integers(0, 3))
def test_the_bytes_of_csv_writer_for_any_floats_and_integers(x, float_format, blank_infinite, seed):
    """Any floats (NaN, ±inf, -0.0 apart from 0.0, subnormals, repeats) and integers: byte for byte what csv.writer
    writes for the same cells."""
    rng = np.random.default_rng(seed)
    ints = rng.integers(-5, 5, x.size)
    cols = [x, ints, x[::-1].copy(), (ints > 0)]
    head = ["a", "b_mm", "c,d", 'e"f']  # names csv.writer must quote
    assert _written(head, cols, float_format, blank_infinite) == _reference(head, cols, float_format,
                                                                             blank_infinite)


def test_rows_beyond_one_block_and_no_rows(monkeypatch):
    import pkmstiff.io.numeric_csv as nc

    monkeypatch.setattr(nc, "BLOCK_ROWS", 7)  # several blocks, the last one short
    x = np.repeat(np.arange(25.0), 2) / 3
    cols = [x, np.arange(x.size)]
    assert _written(["x", "i"], cols, ".10g") == _reference(["x", "i"], cols, ".10g", False)
    assert _written(["x"], [np.empty(0)], ".10g") == b"x\r\n"
    assert BLOCK_ROWS >= 1 << 16  # the default keeps the kernel calls few
    with pytest.raises(ValueError, match="one 1-D column"):
        _written(["x", "y"], [np.zeros(3)], ".10g")
    with pytest.raises(TypeError, match="float or integer"):
        _written(["s"], [np.array(["a"])], ".10g")


def test_a_column_table_is_the_row_table(tmp_path):
    """write_column_table writes the bytes write_table writes for the same rows (floats through table_cell)."""
    u = np.linspace(-200, 1100, 37)
    deg = np.where(np.arange(37) % 5 == 0, np.nan, np.arange(37) * 1.25)
    deg[3] = np.inf
    meta = {"unit": "deg"}
    a = write_table(tmp_path / "rows.csv", ["y_mm", "max_angle_deg"], zip(u.tolist(), deg.tolist()), meta, ".6g")
    b = write_column_table(tmp_path / "cols.csv", ["y_mm", "max_angle_deg"], [u, deg], meta, ".6g")
    assert a.read_bytes() == b.read_bytes()
    assert a.with_suffix(".json").read_bytes() == b.with_suffix(".json").read_bytes()


@settings(max_examples=40, deadline=None)
@given(hnp.arrays(np.float64, st.tuples(st.integers(0, 30), st.integers(1, 3)),
                  elements=st.sampled_from([0.0, -0.0, 1.0, 2.5, -7.0])))
def test_distinct_rows_are_numpys_unique_rows_in_order_of_first_occurrence(a):
    first, inverse = distinct_rows(a)
    expected = np.sort(np.unique(a, axis=0, return_index=True)[1]) if a.shape[0] else np.empty(0, np.int64)
    np.testing.assert_array_equal(first, expected)  # -0.0 equals 0.0, as for np.unique
    np.testing.assert_array_equal(a[first][inverse], a)


def test_distinct_rows_takes_every_nan_as_one_value():
    a = np.array([[np.nan, 1.0], [np.nan, 1.0], [0.0, 1.0], [-0.0, 1.0], [np.nan, 2.0]])
    first, inverse = distinct_rows(a)
    assert first.tolist() == [0, 2, 4] and inverse.tolist() == [0, 0, 1, 1, 2]
    assert distinct_rows(np.array([3, 1, 3, 2]))[0].tolist() == [0, 1, 3]


@pytest.fixture(scope="module")
def yz(hexaglide):
    from pkmstiff.evaluation.sections import axis_plane, evaluate_section

    return evaluate_section(hexaglide, axis_plane("yz", 0.0, (-0.6, 0.8), (-1.2, -0.5), 0.05), ["kappa", "f1"])


def test_section_files_are_the_same_bytes_on_one_or_two_threads(tmp_path, yz):
    """write_section_outputs on 2 threads writes the files it writes on 1 (the CSV also the bytes of the per-row
    writer it replaced: '.10g' cells, empty where NaN)."""
    from pkmstiff.evaluation.export import _columns
    from pkmstiff.report.outputs import write_section_outputs

    fmts = ("png", "vtu", "csv", "npz")
    one = write_section_outputs(yz, tmp_path / "one", fmts, "s", progress=False, threads=1)
    two = write_section_outputs(yz, tmp_path / "two", fmts, "s", progress=False, threads=2)
    assert [p.name for p in one] == [p.name for p in two]
    assert [p.suffix for p in one][-4:] == [".vtu", ".csv", ".npz", ".json"]  # PNGs first, statistics last
    for a, b in zip(one, two):
        if a.suffix != ".png":  # a PNG's bytes may carry the drawing library's version; its pixels are tested
            assert a.read_bytes() == b.read_bytes(), a.name
    cols = _columns(yz)
    old = io.StringIO(newline="")
    w = csv.writer(old)
    w.writerow(list(cols))
    for row in zip(*cols.values()):
        w.writerow(["" if isinstance(x, float) and np.isnan(x) else f"{x:.10g}" for x in row])
    assert (tmp_path / "one" / "s.csv").read_bytes() == old.getvalue().encode()
