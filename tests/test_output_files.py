"""Output files: names from input data stay inside the output directory, and every write is whole or absent
(issue 22, item 7: path traversal, atomic writes)."""

from __future__ import annotations

import os
import re
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from pkmstiff.cli import main
from pkmstiff.errors import OutputPathError
from pkmstiff.io.atomic import atomic_open, atomic_path, atomic_write_text, output_path, safe_stem
from pkmstiff.machine.loader import bundled_machine_dir
from tests.calibration_plans import ONE_CIRCLE_PLAN

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name, stem", [("../../X", "X"), ("/etc/passwd", "etc_passwd"), ("felix:tilt", "felix_tilt"),
                                        ("..", "output"), ("a/../../b", "a_.._.._b"), ("hexaglide", "hexaglide"),
                                        ("C:\\win\\x", "C_win_x"), ("", "output")])
def test_safe_stem_has_no_separator_and_no_leading_dot(name, stem):
    assert safe_stem(name) == stem
    assert "/" not in safe_stem(name) and "\\" not in safe_stem(name) and not safe_stem(name).startswith(".")


def test_output_path_refuses_names_and_links_that_leave_the_directory(tmp_path):
    assert output_path(tmp_path, "a.csv") == tmp_path / "a.csv"
    for bad in ("../a.csv", "/tmp/a.csv", "sub/a.csv", "..", ""):
        with pytest.raises(OutputPathError):
            output_path(tmp_path, bad)
    (tmp_path / "link.csv").symlink_to(tmp_path.parent / "elsewhere.csv")
    with pytest.raises(OutputPathError, match="link"):
        output_path(tmp_path, "link.csv")


def test_section_of_a_machine_named_like_a_path_writes_inside_out(tmp_path, monkeypatch, capsys):
    """A machine file with ``name = "../../evil"`` (or an absolute name): every output lands in ``--out``."""
    text = (bundled_machine_dir() / "hexaglide.toml").read_text(encoding="utf-8")
    for i, name in enumerate(("../../evil", str(tmp_path / "abs" / "evil"))):
        work = tmp_path / f"w{i}" / "a" / "b"
        work.mkdir(parents=True)
        monkeypatch.chdir(work)
        (work / "m.toml").write_text(text.replace('name = "hexaglide"', f'name = "{name}"'), encoding="utf-8")
        assert main(["section", "m.toml", "--plane", "yz", "--step", "100", "--quantities", "kx",
                     "--formats", "csv,npz", "--out", "out", "--quiet"]) == 0
        written = {p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file() and p.name != "m.toml"}
        assert written and all(p.parts[:4] == (f"w{i}", "a", "b", "out") for p in written), written
        for p in written:
            (tmp_path / p).unlink()
    capsys.readouterr()


def test_mechanism_section_of_a_mechanism_named_like_a_path_writes_inside_out(tmp_path, monkeypatch, capsys):
    from pkmstiff.mechanisms.loader import bundled_mechanism_dir

    text = (bundled_mechanism_dir() / "five_bar.toml").read_text(encoding="utf-8")
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    (work / "m.toml").write_text(text.replace('name = "five_bar"', 'name = "../../evil"', 1), encoding="utf-8")
    assert main(["section", "m.toml", "--plane", "xy", "--step", "20", "--formats", "csv", "--out", "out"]) == 0
    written = [p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file() and p.name != "m.toml"]
    assert written and all(p.parts[:3] == ("a", "b", "out") for p in written), written
    capsys.readouterr()


# ------------------------------------------------------------------------------------------------ atomic writes


def test_a_failing_write_keeps_the_previous_file_and_leaves_no_partial_file(tmp_path):
    target = tmp_path / "result.csv"
    target.write_text("previous\n")
    with pytest.raises(RuntimeError):
        with atomic_open(target, "w") as fh:
            fh.write("half a new fi")
            raise RuntimeError("disk full")
    assert target.read_text() == "previous\n"
    assert [p.name for p in tmp_path.iterdir()] == ["result.csv"]
    with pytest.raises(RuntimeError):
        with atomic_path(tmp_path / "fig.png") as tmp:
            assert tmp.suffix == ".png" and tmp.parent == tmp_path  # writers choose the format by the suffix
            tmp.write_bytes(b"\x89PNG")
            raise RuntimeError("interrupted")
    assert [p.name for p in tmp_path.iterdir()] == ["result.csv"]
    atomic_write_text(target, "new\n")
    assert target.read_text() == "new\n"
    assert oct(target.stat().st_mode & 0o777) == oct(0o666 & ~_umask())  # as open() would have made it


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m


def _limited(limit: int):
    def set_limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return set_limit


@pytest.mark.parametrize("command", ["pose", "section"])
def test_a_file_size_limit_leaves_the_previous_output_intact(tmp_path, command):
    """As a full disk: ``pose --poses … --out old.csv --force`` and ``section … --out DIR --force`` under a 300-byte
    file-size limit fail with one line (exit 2), the previous files keep their content and no temporary file is
    left behind."""
    poses = tmp_path / "poses.csv"
    poses.write_text("".join(f"{x},0,-1000,0,0,0\n" for x in range(0, 200, 10)))
    if command == "pose":
        out = tmp_path / "old.csv"
        argv = ["pose", "hexaglide", "--poses", str(poses), "--out", str(out), "--force"]
    else:
        (tmp_path / "sec").mkdir()
        out = tmp_path / "sec" / "hexaglide_yz.csv"
        argv = ["section", "hexaglide", "--step", "200", "--quantities", "kappa", "--formats", "csv", "--out",
                str(tmp_path / "sec"), "--force", "--quiet"]
    out.write_text("previous result\n")
    before = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*"))
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", PKMSTIFF_CACHE="0", PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-m", "pkmstiff.cli"] + argv, cwd=tmp_path, env=env, capture_output=True,
                       text=True, preexec_fn=_limited(300), timeout=300)
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "File too large" in r.stderr, r.stderr
    assert out.read_text() == "previous result\n"
    after = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*"))
    assert [p for p in after if p not in before and not p.endswith(".json")] == []  # no partial or temporary file


# ------------------------------------------------------------------------------------------- injected strings


def test_markdown_twin_shows_injected_strings_as_text(tmp_path):
    """Strings from a spec or machine file (title, heading, text, caption, assumptions, settings) cannot become HTML
    or links in the Markdown twin; the HTML twin escapes them already."""
    from pkmstiff.report import Report, Table, write_report

    evil = '<script>alert(1)</script> [x](javascript:alert(1)) `code` <img src=x onerror=alert(1)>'
    r = Report(evil, summary=evil)
    s = r.section(evil, evil)
    s.tables.append(Table(evil, ["value"]).add("row " + evil, "1", [1.0]))
    r.assumptions = {evil: evil}
    r.settings = {"k": evil}
    md = write_report(r, tmp_path, run={"date": "d", "pkmstiff": "0"})["md"].read_text(encoding="utf-8")
    import re

    assert "<script" not in md and "<img" not in md and not re.search(r"(?<!\\)\]\(javascript", md)
    assert "&lt;script&gt;" in md and "\\[x\\]" in md and "\\`code\\`" in md


def test_sweep_csv_text_cells_are_not_formulas(tmp_path):
    import csv

    from pkmstiff.evaluation.sweep import SweepResult
    from pkmstiff.io.columns import text_cell

    assert [text_cell(v) for v in ("=1+2", "+1", "-2", "@SUM(A1)", "\tx", "ok", -2.5, 3)] == \
        ["'=1+2", "'+1", "'-2", "'@SUM(A1)", "'\tx", "ok", -2.5, 3]
    res = SweepResult([{"task": 0, "p": "=HYPERLINK(\"http://x\")", "kx [N/um]": -1.5, "error": "@x"}], ["p"])
    rows = list(csv.reader((tmp_path / "s.csv").read_text().splitlines())) if res.to_csv(tmp_path / "s.csv") else []
    assert rows[0] == ["task", "p", "kx_N_per_um", "error"]
    assert rows[1] == ["0", "'=HYPERLINK(\"http://x\")", "-1.5", "'@x"]  # numbers stay numbers


def test_sweep_progress_is_periodic_lines_off_a_terminal(monkeypatch, capsys):
    """stderr redirected: one plain line every PROGRESS_INTERVAL_S, no bar redraws (carriage returns)."""
    import itertools

    from pkmstiff.evaluation import progress as prog

    clock = itertools.count(0.0, 4.0)  # each item takes 4 s
    monkeypatch.setattr(prog.time, "perf_counter", lambda: next(clock))
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False, raising=False)
    assert list(prog.progress(range(10), True, "sweep", "task")) == list(range(10))
    err = capsys.readouterr().err
    lines = err.splitlines()
    assert "\r" not in err and 3 <= len(lines) <= 4 and all(ln.startswith("sweep: ") for ln in lines)
    assert "task" in lines[0] and "/10 tasks" in lines[0]


# ------------------------------------------------------------------------------- every CSV opens with pandas


#: unit suffixes of the column rule (pkmstiff.io.columns) met in the CSVs below; a column with one holds numbers
_UNIT_SUFFIXES = ("_mm", "_deg", "_m", "_rad", "_s", "_Hz", "_N_per_um", "_N_m_per_urad", "_N_per_urad", "_um",
                  "_m2", "_m3", "_pct")
_COLUMN = re.compile(r"[A-Za-z][A-Za-z0-9_.]*")  # no spaces, brackets, slashes or units in words

_TINY_SWEEP = """[sweep]
machine = "hexaglide"
mode = "grid"
[[parameters]]
path = "components.strut_950.k"
unit = "N/um"
values = [150, 344]
[[evaluations]]
kind = "point"
pose = [0, 0, -1000, 0, 0, 0]
quantities = ["kx", "f1"]
"""


def _five_bar(d: Path) -> str:
    from pkmstiff.mechanisms.loader import bundled_mechanism_dir

    return str(bundled_mechanism_dir() / "five_bar.toml")


def _poses(d: Path) -> str:
    (d / "poses.csv").write_text("x,y,z,a,b,c\n0,0,-850,0,0,0\n0,0,-1000,0,0,0\n", encoding="utf-8")
    return str(d / "poses.csv")


def _file(name: str, text: str):
    def make(d: Path) -> str:
        (d / name).write_text(text, encoding="utf-8")
        return str(d / name)
    return make


#: every command that writes a CSV, on a tiny case: (id, argv with {o} = output dir and {NAME} = made inputs)
CSV_WRITERS = [
    ("pose", ["pose", "hexaglide", "--poses", "{poses}", "--out", "{o}/b.csv"]),
    ("point", ["point", "hexaglide", "--poses", "{poses}", "--modes", "2", "--out", "{o}/b.csv"]),
    ("section", ["section", "hexaglide", "--plane", "yz", "--step", "100", "--quantities", "kx,kappa", "--formats",
                 "csv", "--out", "{o}", "--quiet"]),
    ("mechanism-section", ["section", "{five_bar}", "--plane", "xy", "--step", "40", "--formats", "csv",
                           "--out", "{o}"]),
    ("sweep", ["sweep", "{sweep}", "--out", "{o}/s.csv", "--quiet"]),
    ("workspace", ["workspace", "hexaglide", "--resolution", "100", "--no-plot", "--quiet", "--out", "{o}"]),
    ("rotation-map", ["rotation-map", "hexaglide", "--plane", "yz", "--range", "y=0:600,z=-1100:-800", "--step",
                      "150", "--directions", "+a", "--increment", "5", "--no-plot", "--out", "{o}"]),
    ("rotation-map-point", ["rotation-map", "hexaglide", "--point", "0,0,-1000", "--directions", "+a", "--range",
                            "b=-10:10,c=-10:10", "--step", "10", "--increment", "5", "--no-plot", "--out", "{o}"]),
    ("fe-platform", ["fe-platform", "pkmstiff/fe/params/hexaglide_platform.toml", "--mesh-size", "60", "--quiet",
                     "--out", "{o}/K.csv"]),
    ("calibrate-simulate", ["calibrate", "simulate", "felix", "--plan", "{plan}", "--errors",
                            "example:felix_errors.toml", "--seed", "1", "--feed", "3000", "--sample-rate", "5",
                            "--out", "{o}/m.csv"]),
]  # 'report' writes no CSV; 'demo' writes the section CSV (evaluation.export.to_csv) tested here via 'section'

_INPUTS = {"poses": _poses, "five_bar": _five_bar, "sweep": _file("sweep.toml", _TINY_SWEEP),
           "plan": _file("plan.toml", ONE_CIRCLE_PLAN)}


@pytest.mark.parametrize("argv", [a for _, a in CSV_WRITERS], ids=[i for i, _ in CSV_WRITERS])
def test_every_csv_the_cli_writes_opens_with_pandas_and_follows_the_column_rule(argv, tmp_path, monkeypatch, capsys):
    """``pandas.read_csv(path)`` with no options reads every CSV, its columns follow the ``<name>_<unit>`` rule,
    unit-suffixed columns hold numbers, and the metadata sit in a JSON file (beside it or in the output directory)."""
    import json

    import pandas as pd

    monkeypatch.chdir(ROOT)
    inputs, out = tmp_path / "in", tmp_path / "out"
    inputs.mkdir()
    names = {k: make(inputs) for k, make in _INPUTS.items() if any("{" + k + "}" in a for a in argv)}
    assert main([a.format(o=out, **names) for a in argv]) == 0, capsys.readouterr().err
    csvs = sorted(out.rglob("*.csv"))
    assert csvs, "no CSV written"
    for path in csvs:
        table = pd.read_csv(path)
        assert len(table) and len(table.columns) >= 2, path
        for col in table.columns:
            assert _COLUMN.fullmatch(col), f"{path.name}: column {col!r} breaks the column rule"
            if col.endswith(_UNIT_SUFFIXES) and table[col].notna().any():
                assert pd.api.types.is_numeric_dtype(table[col]), f"{path.name}: {col} is not numeric"
        meta = [path.with_suffix(".json")] + sorted(path.parent.glob("*.json"))
        assert any(m.is_file() for m in meta), f"{path.name}: no JSON metadata"
        json.loads(next(m for m in meta if m.is_file()).read_text(encoding="utf-8"))
    capsys.readouterr()


def test_fe_joint_table_is_the_documented_comment_exception(tmp_path, monkeypatch, capsys):
    """``fe-joint --out`` writes a component input table: ``# key: value`` provenance the joint-table reader reads,
    then ``tilt_deg,k_N_per_um``; pandas needs ``comment="#"`` (docs/user-guide/fe.md says so)."""
    import pandas as pd

    from components.joint_tables import load_joint_table

    monkeypatch.chdir(ROOT)
    out = tmp_path / "j.csv"
    assert main(["fe-joint", "pkmstiff/fe/params/iwf_2dof_improved.toml", "--angles", "0,45", "--mesh-size", "30",
                 "--n-phi", "8", "--quiet", "--out", str(out)]) == 0
    table = pd.read_csv(out, comment="#")
    assert list(table.columns) == ["tilt_deg", "k_N_per_um"] and list(table["tilt_deg"]) == [0, 45]
    assert load_joint_table(out).metadata  # the component reader reads the provenance lines
    assert 'comment="#"' in (ROOT / "docs" / "user-guide" / "fe.md").read_text(encoding="utf-8")
    capsys.readouterr()
