"""Input files: what a reader finds before it opens a path, byte-order marks and quoted CSV cells (issue 22 item 7)."""

from __future__ import annotations

import os

import numpy as np
import pytest

from pkmstiff.cli import main
from pkmstiff.io.inputs import input_file_problem


def test_input_file_problem_names_what_is_there(tmp_path):
    (tmp_path / "f.toml").write_text("x = 1\n")
    os.mkfifo(tmp_path / "pipe")
    os.symlink("loop", tmp_path / "loop")
    os.symlink("missing", tmp_path / "dangling")
    assert input_file_problem(tmp_path / "f.toml") is None
    assert input_file_problem(tmp_path / "nope") == "no such file"
    assert input_file_problem(tmp_path) == "a directory"
    assert "FIFO" in input_file_problem(tmp_path / "pipe")
    assert input_file_problem(tmp_path / "loop") == "a symbolic link loop"
    assert input_file_problem(tmp_path / "dangling") == "a dangling symbolic link"
    assert input_file_problem(tmp_path / "f.toml" / "x").startswith("no such file")
    assert "device" in input_file_problem("/dev/null")


def test_measurement_with_byte_order_mark_and_quoted_cells(tmp_path):
    """A measurement CSV saved by a spreadsheet program (UTF-8 with BOM, quoted cells) reads as the plain file."""
    from pkmstiff.calibration.measurement_file import read_measurement, write_measurement
    from tests.test_ballbar_file import _meas

    from tests.test_calibration_simulate_points import _old_form

    plain = write_measurement(tmp_path / "m.csv", _meas(n=40, plane="XY"))
    lines = plain.read_text(encoding="utf-8").splitlines()
    quoted = lines[:1] + [",".join(f'"{c}"' for c in ln.split(",")) for ln in lines[1:]]
    for name, head in (("bom", []), ("bom_old", _old_form(plain.with_suffix(".json")))):  # header beside / inside
        (tmp_path / f"{name}.csv").write_bytes(b"\xef\xbb\xbf" + ("\n".join(head + quoted) + "\n").encode("utf-8"))
    (tmp_path / "bom.json").write_bytes(b"\xef\xbb\xbf" + plain.with_suffix(".json").read_bytes())
    bom = tmp_path / "bom.csv"
    np.testing.assert_array_equal(read_measurement(tmp_path / "bom_old.csv").reading, read_measurement(plain).reading)
    a, b = read_measurement(plain), read_measurement(bom)
    np.testing.assert_array_equal(a.reading, b.reading)
    np.testing.assert_array_equal(a.poses, b.poses)
    assert a.bar_length == b.bar_length


def test_pose_file_with_byte_order_mark(tmp_path, capsys):
    f = tmp_path / "p.csv"
    f.write_bytes(b"\xef\xbb\xbfx,y,z,a,b,c\n0,0,-1000,0,0,0\n")
    assert main(["pose", "hexaglide", "--poses", str(f)]) == 0
    assert capsys.readouterr().out.count("\n") == 2  # header and one pose


@pytest.mark.parametrize("bad", ["9**9**9 mm", "(9**9)**9 mm", "2^3^4 mm", "1 m**(2)", "1 " + "m*" * 200 + "m"])
def test_unit_expressions_beyond_plain_powers_are_refused_at_once(bad):
    from pkmstiff.errors import InputError
    from pkmstiff.units import parse_quantity

    with pytest.raises(InputError):
        parse_quantity(bad, "m", source="f.toml", key="k", plausible=False)


@pytest.mark.parametrize("good, unit, value", [("2 kg*m^2", "kg*m^2", 2.0), ("3 m**2", "m**2", 3.0),
                                               ("1 s^-1", "1/s", 1.0), ("1.5 mm", "m", 1.5e-3),
                                               ("2 N*m/rad", "N*m/rad", 2.0)])
def test_plain_powers_still_parse(good, unit, value):
    from pkmstiff.units import parse_quantity

    assert parse_quantity(good, unit, plausible=False) == pytest.approx(value, rel=1e-15)


def test_a_quantity_string_parsed_before_still_names_each_files_key():
    # pint's parse of a string is kept (machine files of a study's variants repeat it); the checks are per call
    from pkmstiff.errors import InputError
    from pkmstiff.units import parse_quantity

    assert parse_quantity("1.5 mm", "m", plausible=False) == pytest.approx(1.5e-3, rel=1e-15)
    assert parse_quantity("1.5 mm", "m", plausible=False) == pytest.approx(1.5e-3, rel=1e-15)
    assert parse_quantity("1.5 mm", "mm", plausible=False) == pytest.approx(1.5, rel=1e-15)
    assert parse_quantity("2.5", "dimensionless", plausible=False) == 2.5
    for source, key in (("a.toml", "strut.k"), ("b.toml", "other.k")):
        with pytest.raises(InputError, match=f"{source}.*{key}.*dimension of N/m"):
            parse_quantity("1.5 mm", "N/m", source=source, key=key, plausible=False)
        with pytest.raises(InputError, match=f"{source}.*{key}"):
            parse_quantity("1.5 bogons", "m", source=source, key=key, plausible=False)


def test_measurement_header_beside_the_csv(tmp_path):
    """New files: the CSV holds only the table (pandas reads it with no options), the header is <name>.json; errors
    in the header name the JSON file; a CSV without either header form says so."""
    import json

    import pandas as pd

    from pkmstiff.calibration.measurement_file import read_measurement, write_measurement
    from pkmstiff.errors import InputError
    from tests.test_ballbar_file import _meas

    m = _meas(n=40, plane="XY")
    path = write_measurement(tmp_path / "m.csv", m)
    df = pd.read_csv(path)
    assert list(df.columns[:2]) == ["t_s", "x_mm"] and len(df) == m.n_samples
    np.testing.assert_allclose(df["reading_mm"], m.reading * 1e3, rtol=1e-14, atol=1e-18)  # 15 digits written
    meta = json.loads(path.with_suffix(".json").read_text())
    assert meta["bar_length_mm"] == 150 and meta["fixed_ball_mm"] == [0, 0, 0] and meta["machine"] == "felix"
    meta["bar_length_mm"] = -150
    path.with_suffix(".json").write_text(json.dumps(meta))
    with pytest.raises(InputError, match=r"m\.json.*bar_length_mm"):
        read_measurement(path)
    path.with_suffix(".json").unlink()
    with pytest.raises(InputError, match=r"no header.*m\.json"):
        read_measurement(path)
