"""Report renderer (pkmstiff.report.render) and report specs (pkmstiff.report.spec, ``pkmstiff report``)."""

from __future__ import annotations

import base64
import re
import struct
import sys
import zlib
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pkmstiff.errors import ArgumentError
from pkmstiff.report import Figure, Report, Table, write_report
from pkmstiff.report.render import format_value, percent_of_baseline

RUN = {"date": "2024-01-01T00:00:00+00:00", "python": "3.11", "pkmstiff": "0.1.0"}


def _png(path: Path, width: int = 3, height: int = 2, rgb=(200, 30, 30)) -> Path:
    """A tiny valid PNG written by hand (independent of matplotlib/pyvista)."""
    raw = b"".join(b"\x00" + bytes(rgb) * width for _ in range(height))

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    return path


class _Tables(HTMLParser):
    """Collects the text of every <td>/<th> per row, per table, and every <img src>."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: list[list[list[str]]] = []
        self.imgs: list[str] = []
        self._cell: list[str] | None = None
        self.scripts = 0
        self.links: list[str] = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "img":
            self.imgs.append(a["src"])
        elif tag == "script":
            self.scripts += 1
        elif tag in ("link", "a") and a.get("href"):
            self.links.append(a["href"])

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1][-1].append("".join(self._cell))
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def _report(tmp_path: Path) -> Report:
    r = Report("Variants <&> test", summary="Compares <b>two</b> variants.")
    s = r.section("Comparison", "First paragraph.\n\nSecond & last.")
    t = Table("Table 5.1 style", ["orig", "v1", "v2"], baseline="orig", digits=4)
    t.add("k_x mean", "N/um", [20.0, 25.0, 15.5])
    t.add("volume", "m^3", [0.25, None, 0.3125])
    t.add("zero base", "-", [0.0, 1.0, 2.0])
    s.tables.append(t)
    s.figures.append(Figure(_png(tmp_path / "a.png"), "map <kx>"))
    s2 = r.section("More")
    s2.tables.append(Table("no baseline", ["a", "b"]).add("n", "1", [1234567.0, 0.000123456]))
    sub = tmp_path / "other"
    sub.mkdir(exist_ok=True)
    s2.figures.append(Figure(_png(sub / "a.png", rgb=(0, 0, 255)), "same file name, other dir"))
    r.assumptions = {"z.key": "last", "a.key": "first <x>"}
    r.settings = {"step_mm": 10.0, "planes": ["yz"], "fast": False}
    return r


def test_html_tables_percentages_and_escaping(tmp_path):
    out = write_report(_report(tmp_path), tmp_path / "out", run=RUN)
    text = out["html"].read_text(encoding="utf-8")
    p = _Tables()
    p.feed(text)
    head, *rows = p.tables[0]
    assert head == ["Metric", "Unit", "orig", "% of orig", "v1", "% of orig", "v2", "% of orig"]
    # hand values: 25/20 = 125 %, 15.5/20 = 77.5 %, 0.3125/0.25 = 125 %; the baseline itself is 100 %
    assert rows[0] == ["k_x mean", "N/µm", "20.00", "100.0 %", "25.00", "125.0 %", "15.50", "77.5 %"]
    assert rows[1] == ["volume", "m³", "0.2500", "100.0 %", "n/a", "–", "0.3125", "125.0 %"]
    assert rows[2] == ["zero base", "-", "0", "–", "1.000", "–", "2.000", "–"]  # % of a zero baseline undefined
    # without baseline: no % columns; 4 significant digits, fixed notation up to 1e7, scientific below 1e-3
    assert p.tables[1] == [["Metric", "Unit", "a", "b"], ["n", "1", "1235000", "1.235e-04"]]
    # escaping: user text never becomes markup
    assert "<b>two</b>" not in text and "&lt;b&gt;two&lt;/b&gt;" in text
    assert "Variants &lt;&amp;&gt; test" in text and "map &lt;kx&gt;" in text
    # assumptions sorted by key, settings present, run section with the given versions
    assert text.index("a.key") < text.index("z.key")
    assert "step_mm" in text and "2024-01-01T00:00:00+00:00" in text
    # self-contained: no script, no external reference at all
    assert p.scripts == 0 and "http" not in text.lower() and "src=\"figures" not in text
    assert all(h.startswith("#") for h in p.links)


def test_html_embeds_the_exact_png_bytes(tmp_path):
    r = _report(tmp_path)
    out = write_report(r, tmp_path / "out", run=RUN)
    p = _Tables()
    p.feed(out["html"].read_text(encoding="utf-8"))
    assert len(p.imgs) == 2
    for src, fig in zip(p.imgs, [f for s in r.sections for f in s.figures]):
        prefix = "data:image/png;base64,"
        assert src.startswith(prefix)
        assert base64.b64decode(src[len(prefix):]) == Path(fig.path).read_bytes()


def test_markdown_twin_links_resolve(tmp_path):
    r = _report(tmp_path)
    out = write_report(r, tmp_path / "out", run=RUN)
    md = out["md"].read_text(encoding="utf-8")
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    assert len(links) == 2 and len(set(links)) == 2  # same file name in two folders: two distinct copies
    for link, fig in zip(links, [f for s in r.sections for f in s.figures]):
        assert not Path(link).is_absolute()
        target = out["md"].parent / link
        assert target.read_bytes() == Path(fig.path).read_bytes()
    assert "| k_x mean | N/µm | 20.00 | 100.0 % | 25.00 | 125.0 % | 15.50 | 77.5 % |" in md
    assert "## Assumptions" in md and "## Settings" in md and "## Run" in md
    assert md.index("| a.key |") < md.index("| z.key |")  # assumptions sorted, one table row each


def test_figures_inside_out_dir_are_linked_in_place(tmp_path):
    out_dir = tmp_path / "out"
    (out_dir / "maps").mkdir(parents=True)
    r = Report("t")
    r.section("s").figures.append(Figure(_png(out_dir / "maps" / "k.png"), "k"))
    out = write_report(r, out_dir, run=RUN)
    assert "](maps/k.png)" in out["md"].read_text() and not (out_dir / "figures").exists()


def test_deterministic_output(tmp_path):
    a = write_report(_report(tmp_path), tmp_path / "o1", run=RUN)
    b = write_report(_report(tmp_path), tmp_path / "o2", run=RUN)
    assert a["html"].read_bytes() == b["html"].read_bytes()
    assert a["md"].read_bytes() == b["md"].read_bytes()


def test_run_section_lists_versions(tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "0")
    out = write_report(Report("t"), tmp_path)
    md = out["md"].read_text()
    for name in ("pkmstiff", "python", "numpy", "scipy", "numba", "scikit-fem", "pyvista"):
        assert re.search(rf"^\| {name} \| \S", md, re.M), name
    assert "| date | 1970-01-01T00:00:00+00:00 |" in md
    import numpy

    assert f"| numpy | {numpy.__version__} |" in md


def test_bad_input_is_rejected_before_writing(tmp_path):
    r = Report("t")
    r.section("s").tables.append(Table("cap", ["a", "b"], baseline="c").add("x", "1", [1, 2]))
    with pytest.raises(ArgumentError, match="table 'cap': baseline 'c'"):
        write_report(r, tmp_path / "o")
    assert not (tmp_path / "o").exists()
    r = Report("t")
    (tmp_path / "x.png").write_text("not a png")
    r.section("s").figures.append(Figure(tmp_path / "x.png", "fake"))
    with pytest.raises(ArgumentError, match="expected a PNG file"):
        write_report(r, tmp_path / "o")
    r.sections[0].figures[0] = Figure(tmp_path / "missing.png", "gone")
    with pytest.raises(ArgumentError, match="does not exist"):
        write_report(r, tmp_path / "o")


@settings(max_examples=200, deadline=None)
@given(st.floats(min_value=-1e12, max_value=1e12, allow_nan=False).filter(lambda v: v != 0),
       st.integers(min_value=1, max_value=8))
def test_format_value_keeps_the_significant_digits(v, digits):
    text = format_value(v, digits)
    # the printed number rounds the value to `digits` significant digits: relative error <= half a unit in the
    # last digit (5 * 10^-digits), plus float slack
    assert abs(float(text) - v) <= 0.5 * 10.0 ** (1 - digits) * abs(v) * (1 + 1e-9) + 1e-300


@given(st.floats(min_value=1e-6, max_value=1e6), st.floats(min_value=1e-6, max_value=1e6))
def test_percent_round_trip(base, v):
    p = percent_of_baseline(v, base)
    assert p is not None and np.isclose(p * base / 100.0, v, rtol=1e-12)  # float round-off only
    assert percent_of_baseline(base, base) == pytest.approx(100.0, rel=1e-15)


# ------------------------------------------------------------------------------------------------- report specs
import math  # noqa: E402

from pkmstiff.errors import InputError
from pkmstiff.report.build import build_report  # noqa: E402
from pkmstiff.report.spec import fast_spec, load_spec  # noqa: E402

SPECS = Path(__file__).resolve().parents[1] / "studies" / "specs"

MINI = """
[report]
title = "mini"
baseline = "orig"
machine_rows = ["transmission_weight", "tool_length"]
[report.assumptions]
"mine" = "a spec-level assumption"

[[variants]]
name = "orig"
machine = "hexaglide"
tool_length_mm = 150

[[variants]]
name = "soft"
machine = "hexaglide"
tool_length_mm = 150
overrides = { "components.strut_950.k" = "100 N/um", components.strut_1000.k = "100 N/um" }

[[sections]]
plane = "yz"
at_mm = 0
range = "y=-200:800,z=-1100:-500"
step_mm = 50
quantities = ["kx", "U"]
statistics = ["min", "mean", "max", "area"]
maps = MAPS

[[points]]
pose = [0, 0, -1000, 0, 0, 0]
quantities = ["kx", "f1"]

[options]
fast_step_mm = 100
"""


def _mini(tmp_path: Path, maps: bool = False, extra: str = "") -> Path:
    p = tmp_path / "mini.toml"
    p.write_text(MINI.replace("MAPS", "true" if maps else "false") + extra)
    return p


def _rows(report) -> dict[str, list]:
    t = report.sections[0].tables[0]
    return {r.label: (r.unit, r.values) for r in t.rows}


def test_spec_table_matches_direct_evaluation(tmp_path):
    from pkmstiff import load_machine
    from pkmstiff.analysis import evaluate_structure
    from pkmstiff.evaluation.sections import axis_plane, evaluate_section
    from pkmstiff.machine.variants import machine_with

    spec = load_spec(_mini(tmp_path))
    rep = build_report(spec, tmp_path / "out")
    rows = _rows(rep)
    plane = axis_plane("yz", 0.0, (-0.2, 0.8), (-1.1, -0.5), 0.05)
    soft = machine_with("hexaglide", {"components.strut_950.k": "100 N/um", "components.strut_1000.k": "100 N/um"})
    for j, m in enumerate([load_machine("hexaglide"), soft]):
        st = evaluate_section(m, plane, ["kx", "U"], tool_length=0.15, progress=False).statistics()
        for q in ("kx", "U"):
            for stat in ("min", "mean", "max"):
                # same evaluation path and raster: identical up to float summation order
                assert rows[f"{q} {stat}"][1][j] == pytest.approx(st[q][stat], rel=1e-12)
        assert rows["kx admissible area"] == ("m^2", rows["kx admissible area"][1])
        assert rows["kx admissible area"][1][j] == pytest.approx(st["kx"]["admissible_area_m2"], rel=1e-12)
        # point row against the structure batch (a different entry point than the quantity registry)
        k = evaluate_structure(m, np.array([[0, 0, -1.0, 0, 0, 0]]), tool_length=0.15, n_modes=1)
        assert rows["kx at x, y, z = 0, 0, -1000 mm, a, b, c = 0, 0, 0 deg"][1][j] == pytest.approx(
            k.stiffness[0, 0] / 1e6, rel=1e-9)  # N/m -> N/um; same model, float round-off only
    assert rows["kx mean"][0] == "N/um" and rows["U max"][0] == "1"
    # softer struts (344 -> 100 N/um) make the chain softer in series: every statistic of kx drops
    assert all(rows[f"kx {s}"][1][1] < rows[f"kx {s}"][1][0] for s in ("min", "mean", "max"))
    # U is kinematic: unchanged by a stiffness override (exactly the same computation)
    assert rows["U mean"][1][0] == rows["U mean"][1][1]
    assert rows["tool length"] == ("mm", [150.0, 150.0])
    assert rows["transmission quality weight w (eq. 4.77)"][1][0] == pytest.approx(0.5 / math.radians(20), rel=1e-12)
    # assumptions: the spec's own and the machine file's, prefixed with the variant
    assert rep.assumptions["mine"] == "a spec-level assumption"
    assert "hull" in rep.variant_assumptions["orig"] and "hull" in rep.variant_assumptions["soft"]
    assert rep.settings["variant soft"]["overrides"]["components.strut_950.k"] == "100 N/um"


def test_spec_report_writes_maps_and_html(tmp_path):
    from pkmstiff.cli import main

    spec = _mini(tmp_path, maps=True)
    assert main(["report", str(spec), "--out", str(tmp_path / "out"), "--quiet", "--fast"]) == 0
    html_text = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    p = _Tables()
    p.feed(html_text)
    assert len(p.imgs) == 4 and all(s.startswith("data:image/png;base64,") for s in p.imgs)  # 2 quantities x 2
    assert "http" not in html_text.lower()
    head = p.tables[0][0]
    assert head == ["Metric", "Unit", "orig", "% of orig", "soft", "% of orig"]
    md = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    for link in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md):
        assert (tmp_path / "out" / link).is_file()
    assert "| section 1 › step_mm | 100 |" in md  # --fast used the spec's fast_step_mm


def test_fast_spec_defaults(tmp_path):
    spec = load_spec(_mini(tmp_path, extra='[workspace]\nresolution_mm = 10\n'))
    f = fast_spec(spec)
    assert f.sections[0].step == pytest.approx(0.1) and f.workspace.resolution == pytest.approx(0.04)  # 4 x 10 mm


@pytest.mark.parametrize("edit, key", [
    (("[report]\n", "[report]\ncolour = 1\n"), "report.colour"),
    (('baseline = "orig"', 'baseline = "nope"'), "report.baseline"),
    (('quantities = ["kx", "U"]', 'quantities = ["kx", "nonsense"]'), "sections[1].quantities"),
    (('range = "y=-200:800,z=-1100:-500"', 'range = "y=-200:800"'), "sections[1].range"),
    (('statistics = ["min", "mean", "max", "area"]', 'statistics = ["median"]'), "sections[1].statistics"),
    (("pose = [0, 0, -1000, 0, 0, 0]", "pose = [0, 0, -1000]"), "points[1].pose"),
    (("step_mm = 50", "step_mm = -5"), "sections[1].step_mm"),
    (('name = "soft"', 'name = "orig"'), "variants"),
])
def test_spec_errors_name_the_key(tmp_path, edit, key):
    p = tmp_path / "bad.toml"
    p.write_text(MINI.replace("MAPS", "false").replace(*edit))
    with pytest.raises(InputError) as exc:
        load_spec(p)
    assert f"key '{key}" in str(exc.value) and str(p) in str(exc.value)


def test_bad_override_is_a_machine_file_error(tmp_path):
    from pkmstiff.cli import main
    from pkmstiff.errors import InputError

    p = tmp_path / "bad.toml"
    p.write_text(MINI.replace("MAPS", "false").replace('"components.strut_950.k" = "100 N/um"',
                                                       '"components.strut_950.k" = "100 kg"'))
    with pytest.raises(InputError, match=r"key 'components.strut_950.k': expected a quantity with the "
                                               r"dimension of N/m"):
        build_report(load_spec(p), tmp_path / "out")
    assert main(["report", str(p), "--out", str(tmp_path / "o2"), "--quiet"]) == 2  # clean CLI error, no traceback


@pytest.mark.parametrize("spec", sorted(SPECS.glob("*.toml")), ids=lambda p: p.stem)
def test_bundled_specs_are_valid(spec):
    s = load_spec(spec)
    assert s.variants and (s.baseline is None or s.baseline in [v.name for v in s.variants])
    from pkmstiff.machine.variants import machine_with

    for v in s.variants:  # every variant's machine, options and overrides build
        machine_with(v.machine, v.overrides, v.options)


def test_count_rows_print_as_integers():
    from pkmstiff.report.model import Table
    from pkmstiff.report.render import _table_grid as table_cells

    t = Table("counts", ["A", "B"], baseline="A").add("candidates", "evaluations", [936, 900]).add("k", "N/um", [20.0, 25.0])
    _, rows = table_cells(t)
    assert [c.text for c in rows[0][2]][::2] == ["936", "900"]  # a count row: integers
    assert [c.text for c in rows[1][2]][::2] == ["20.00", "25.00"]  # a measured row keeps its significant digits


EVALUATION = """
[[evaluation]]
metric = "kx mean"
weight = 2
[[evaluation]]
metric = "U mean"
weight = 1
better = "lower"
"""


def test_weighted_scores_by_hand():
    from pkmstiff.report import weighted

    # three variants, two criteria: k (higher better) 10, 20, 30; mass (lower better) 5, 5, 8
    x = np.array([[10.0, 5.0], [20.0, 5.0], [30.0, 8.0]])
    better = np.array([True, False])
    u = weighted.utilities(x, better)
    np.testing.assert_allclose(u, [[0.0, 1.0], [0.5, 1.0], [1.0, 0.0]])
    s = weighted.scores(x, np.array([1.0, 1.0]), better)  # (0 + 1)/2, (0.5 + 1)/2, (1 + 0)/2
    np.testing.assert_allclose(s, [50.0, 75.0, 50.0])
    assert weighted.ranking(s) == [1, 0, 2]  # tie 0 / 2 keeps the given order
    assert weighted.ranking(weighted.scores(x, np.array([3.0, 1.0]), better)) == [2, 1, 0]  # 75 > 62.5 > 25
    sens = {(j, f): r for j, f, r in weighted.sensitivity(x, np.array([1.0, 1.0]), better)}
    assert sens[(0, 0.0)] == [0, 1, 2] and sens[(1, 0.0)] == [2, 1, 0]
    np.testing.assert_allclose(weighted.utilities(np.array([[1.0], [np.nan]]), np.array([True])), [[1.0], [0.0]])


def test_weighted_evaluation_section_and_html_checks(tmp_path):
    from tests.report_checks import check_report

    spec = load_spec(_mini(tmp_path, extra=EVALUATION))
    assert [(c.metric, c.weight, c.higher_is_better) for c in spec.evaluation] == [("kx mean", 2.0, True),
                                                                                   ("U mean", 1.0, False)]
    rep = build_report(spec, tmp_path / "out")
    sec = next(s for s in rep.sections if s.heading == "Weighted evaluation")
    rows = {r.label: r.values for r in sec.tables[0].rows}
    comparison = _rows(rep)
    kx, U = comparison["kx mean"][1], comparison["U mean"][1]
    # two variants: the better one on a criterion gets 100 points, the other 0
    u_kx = [100.0 * (v == max(kx)) for v in kx]
    u_U = [100.0 * (v == min(U)) for v in U]
    expect = [(2 * a + b) / 3 for a, b in zip(u_kx, u_U)]
    np.testing.assert_allclose(rows["weighted score"], expect, rtol=1e-12)
    assert "x0" in sec.text and "x2" in sec.text
    out = write_report(rep, tmp_path / "out", run=RUN)
    check_report(out["html"].read_text(encoding="utf-8"), out["md"].read_text(encoding="utf-8"))


def test_evaluation_metric_must_be_a_table_row(tmp_path, monkeypatch):
    from pkmstiff.errors import InputError
    from pkmstiff.report import build
    from pkmstiff.report.build import comparison_labels

    spec = load_spec(_mini(tmp_path, extra='[[evaluation]]\nmetric = "nope"\n'))

    def no_evaluation(*a, **k):
        raise AssertionError("evaluated before the spec's metric was checked")

    with monkeypatch.context() as mp:  # the one-line error comes before any machine is loaded or evaluated
        mp.setattr(build, "_load_variant", no_evaluation)
        mp.setattr(build, "spec_cost", no_evaluation)
        with pytest.raises(InputError, match=r"evaluation\[1\].metric.*'nope'"):
            build_report(spec, tmp_path / "out")
        with pytest.raises(InputError, match=r"evaluation\[1\].metric.*'nope'"):
            build.run_spec(_mini(tmp_path, extra='[[evaluation]]\nmetric = "nope"\n'), tmp_path / "out2",
                           check=no_evaluation)
    assert not (tmp_path / "out").exists() and not (tmp_path / "out2").exists()
    # the labels known before the evaluation are the rows the evaluation fills
    good = load_spec(_mini(tmp_path))
    assert comparison_labels(good) == list(_rows(build_report(good, tmp_path / "out3")))
    with pytest.raises(InputError, match="evaluation\\[1\\].better"):
        load_spec(_mini(tmp_path, extra='[[evaluation]]\nmetric = "kx mean"\nbetter = "more"\n'))


def test_run_info_names_the_command_the_user_typed(monkeypatch):
    from pkmstiff.report.render import run_info

    # ``python -m pkmstiff.cli`` puts the module's __main__.py in argv[0]: the report names the pkmstiff command
    monkeypatch.setattr(sys, "argv", ["/x/pkmstiff/cli/__main__.py", "report", "spec.toml"])
    assert run_info()["command"] == "pkmstiff report spec.toml"
    monkeypatch.setattr(sys, "argv", ["/usr/bin/pkmstiff", "demo"])
    assert run_info()["command"] == "pkmstiff demo"
