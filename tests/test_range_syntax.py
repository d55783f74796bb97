"""One ``--range`` syntax (AXIS=LO:HI, ...) for section, workspace and rotation-map; the old forms still work with one
deprecation line on stderr and give the same result (issue 22 item 6)."""

from __future__ import annotations

import json

import pytest

from pkmstiff.cli import main
from pkmstiff.errors import SectionArgumentError
from pkmstiff.io.ranges import parse_axis_ranges


def test_parse_axis_ranges():
    assert parse_axis_ranges("y=-600:800, z=-1200:-500", "yz", "mm") == {"y": (-600.0, 800.0),
                                                                           "z": (-1200.0, -500.0)}
    assert parse_axis_ranges("c=-30:30", "abc", "deg", required=False) == {"c": (-30.0, 30.0)}
    for bad, text in (("y=1:0,z=0:1", "LO < HI"), ("y=0:1,y=0:2,z=0:1", "twice"), ("q=0:1,z=0:1", "axis"),
                      ("y,0,1", "AXIS=LO:HI"), ("y=0:1", "missing"), ("y=nan:1,z=0:1", "LO < HI")):
        with pytest.raises(SectionArgumentError, match=text):
            parse_axis_ranges(bad, "yz", "mm")


def _run(capsys, argv):
    assert main(argv) == 0
    out, err = capsys.readouterr()
    return json.loads(out), [ln for ln in err.splitlines() if ln.strip()]


def test_workspace_old_range_form_is_deprecated_and_equal(capsys):
    base = ["workspace", "hexaglide", "--resolution", "100", "--range-step", "10", "--json", "--quiet"]
    new, err_new = _run(capsys, base + ["--range", "c=-10:10"])
    old, err_old = _run(capsys, base + ["--range", "c,-10,10"])
    assert not err_new
    assert len(err_old) == 1 and "deprecated" in err_old[0] and "--range c=-10:10" in err_old[0]
    assert old["volumes_m3"] == new["volumes_m3"] and old["evaluations"] == new["evaluations"]


def test_rotation_map_old_range_form_is_deprecated_and_equal(capsys):
    base = ["rotation-map", "hexaglide", "--plane", "yz", "--at", "0", "--step", "200", "--directions", "+a",
            "--increment", "5", "--json", "--no-plot"]
    new, err_new = _run(capsys, base + ["--range", "y=0:600,z=-1100:-800"])
    old, err_old = _run(capsys, base + ["--u-range", "0,600", "--v-range=-1100,-800"])
    assert not err_new
    assert len(err_old) == 1 and "--range y=0:600,z=-1100:-800" in err_old[0]
    assert old["angles"] == new["angles"]
    assert main(base + ["--range", "y=0:600,z=-1100:-800", "--u-range", "0,600"]) == 2
    assert "either --range or" in capsys.readouterr().err
