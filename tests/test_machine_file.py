"""Machine files: bundled machines load, data match the spec, invalid files give readable errors."""

import re

import numpy as np
import pytest

from pkmstiff import UnknownMachineError, bundled_machines, load_machine
from pkmstiff.errors import InputError
from pkmstiff.machine.loader import bundled_machine_dir

EXPECTED = {"hexaglide", "hexaglide_v1", "hexaglide_v2", "hexapod_6x", "linapod", "paralix"}


def test_bundled_machines_load():
    assert EXPECTED <= set(bundled_machines())
    for name in EXPECTED:
        m = load_machine(name)
        assert m.n_chains == 6
        # every bundled file documents its assumptions
        assert m.assumptions, name
        # direction vectors are normalised on load
        for arr in (m.chains.drive_axis, m.chains.platform_axis, m.chains.platform_reference):
            np.testing.assert_allclose(np.linalg.norm(arr, axis=1), 1.0, rtol=1e-12)


def test_hexaglide_values_from_spec():
    m = load_machine("hexaglide")
    assert m.kind == "glide"
    np.testing.assert_allclose(m.chains.guide_start[0], [1.35, 0.80, 0.0])
    np.testing.assert_allclose(m.chains.strut_length, [1.0, 1.0, 0.95, 0.95, 0.95, 0.95])
    np.testing.assert_allclose(m.chains.drive_joint[:, 2], -0.15)
    assert m.joint_types["iwf_3dof"].tilt_min == pytest.approx(np.deg2rad(5.0))
    # w = 0.5 m / (pi/9) (eq. 5.1)
    assert m.transmission_weight == pytest.approx(0.5 / (np.pi / 9), rel=1e-12)
    assert m.hull.vertices.shape == (28, 3)
    assert m.chains.guide == ("y800", "y800", "y400", "y400", "y000", "y000")


def test_variants_extend_the_original():
    v1 = load_machine("hexaglide_v1")
    np.testing.assert_allclose(v1.chains.strut_length, [1.077, 1.077, 0.95, 0.95, 1.153, 1.153])
    np.testing.assert_allclose(v1.chains.guide_length, 2.7)  # the "t_i" column holds strut lengths (spec note)
    np.testing.assert_allclose(v1.chains.drive_joint[:, 2], -0.15)  # inherited offset
    np.testing.assert_allclose(v1.chains.platform_axis[5], np.array([-0.430, -0.903, 0]) / np.hypot(0.43, 0.903))
    printed = load_machine("hexaglide_v1:printed_values")
    np.testing.assert_allclose(printed.chains.platform_axis[5], np.array([0.430, -0.903, 0]) / np.hypot(0.43, 0.903))
    assert load_machine("hexaglide_v1", options=["pattern_hull"]).hull.vertices[0, 0] == pytest.approx(0.101)


def test_spec_corrections_and_printed_options():
    assert load_machine("hexapod_6x").chains.drive_joint[2, 1] == pytest.approx(-0.419)
    assert load_machine("hexapod_6x:printed_values").chains.drive_joint[2, 1] == pytest.approx(0.419)
    assert load_machine("paralix").chains.guide_start[2, 1] == pytest.approx(-0.190)
    assert load_machine("paralix:printed_values").chains.guide_start[2, 1] == pytest.approx(-0.109)
    assert load_machine("linapod").chains.platform_joint[3, 0] == pytest.approx(0.115)
    assert load_machine("linapod:printed_values").chains.platform_joint[3, 0] == pytest.approx(0.145)


def test_load_by_path_and_units(tmp_path):
    text = (bundled_machine_dir() / "hexaglide.toml").read_text()
    text = text.replace("guide_length = 2.7", 'guide_length = "2700 mm"')
    text = text.replace('strut_radius = "25 mm"', 'strut_radius = "0.984252 in"')
    p = tmp_path / "hx.toml"
    p.write_text(text)
    m = load_machine(p)
    np.testing.assert_allclose(m.chains.guide_length, 2.7, rtol=1e-12)
    np.testing.assert_allclose(m.chains.strut_radius, 0.025, rtol=1e-6)


def _bad(tmp_path, old, new, count=1):
    text = (bundled_machine_dir() / "hexaglide.toml").read_text()
    assert old in text, old
    p = tmp_path / "bad.toml"
    p.write_text(text.replace(old, new, count))
    return p


# (description, replacement, regex the message must match) — each message names the file, the key, the
# expectation and the finding
BAD_INPUTS = [
    ("missing key", ("strut_length = 1.0\n", "", 1), r"chains\[1\]\.strut_length.*required.*missing key"),
    ("wrong shape", ("guide_start = [1.35, 0.80, 0.00]", "guide_start = [1.35, 0.80]", 1),
     r"chains\[1\]\.guide_start.*shape \(3\).*shape \(2,\)"),
    ("wrong unit", ('strut_radius = "25 mm"', 'strut_radius = "25 kg"', 1),
     r"chain_defaults\.strut_radius|chains\[1\]\.strut_radius.*dimension of m.*25 kg"),
    ("negative length", ("strut_length = 1.0", "strut_length = -1.0", 1),
     r"chains\[1\]\.strut_length.*positive.*-1\.0"),
    ("zero direction", ("guide_direction = [-1.0, 0.0, 0.0]", "guide_direction = [0.0, 0.0, 0.0]", 1),
     r"chains\[1\]\.guide_direction.*non-zero direction"),
    ("NaN", ("guide_length = 2.7", "guide_length = nan", 1), r"guide_length.*finite.*nan"),
    ("unknown component reference", ('drive = "linear_motor_1"', 'drive = "nonexistent"', 1),
     r"chains\[1\]\.components\.drive.*component defined under \[components\].*nonexistent"),
    ("unknown component model", ('model = "guide_carriages"', 'model = "guide_carriage"', 1),
     r"components\.schneeberger_35x4\.model.*one of the component models.*guide_carriage'"),
    ("bad component parameter", ('k_horizontal = "1130 N/um"', 'k_horizontal = "-1130 N/um"', 1),
     r"components\.schneeberger_35x4\.k_horizontal"),
    ("unknown joint type", ('drive_joint_type = "iwf_3dof"', 'drive_joint_type = "iwf_9dof"', 1),
     r"drive_joint_type.*one of the joint types.*iwf_9dof"),
    ("unknown key", ("strut_length = 1.0\n", "strut_lenght = 1.0\n", 1), r"chains\[1\]\.strut_lenght.*unknown key"),
    ("bad enum", ('type = "glide"', 'type = "slide"', 1), r"machine\.type.*'pod' or 'glide'.*slide"),
    ("min > max", ('tilt_min = "5 deg"', 'tilt_min = "5 deg"\ntilt_max = "2 deg"', 1),
     r"joint_types\.iwf_3dof\.tilt_min.*<= tilt_max"),
    ("bad TOML", ("[machine]", "[machine", 1), r"valid TOML"),
    ("degenerate hull", ("vertices = [", "vertices = [[0,0,0],[1,0,0],[0,1,0]]\nold_vertices = [", 1),
     r"hull\.old_vertices.*unknown key"),
]


@pytest.mark.parametrize("desc,repl,pattern", BAD_INPUTS, ids=[b[0] for b in BAD_INPUTS])
def test_invalid_machine_files(tmp_path, desc, repl, pattern):
    p = _bad(tmp_path, *repl)
    with pytest.raises(InputError) as exc:
        load_machine(p)
    msg = str(exc.value)
    assert str(p) in msg, msg  # names the file
    assert re.search(pattern, msg), msg
    assert "Traceback" not in msg


def test_unknown_machine():
    with pytest.raises(UnknownMachineError, match=r"unknown machine 'hexagon'.*bundled: .*hexaglide"):
        load_machine("hexagon")
    with pytest.raises(UnknownMachineError, match="does not exist"):
        load_machine("/nonexistent/machine.toml")


def test_unknown_option():
    with pytest.raises(InputError, match=r"key 'options'.*printed_values.*not_an_option"):
        load_machine("hexapod_6x:not_an_option")


def test_pod_length_limits_validated(tmp_path):
    text = (bundled_machine_dir() / "hexapod_6x.toml").read_text().replace("length_max = 2.57", "length_max = 1.0")
    p = tmp_path / "pod.toml"
    p.write_text(text)
    with pytest.raises(InputError, match=r"length_max.*> length_min"):
        load_machine(p)


def test_frame_limits_validated(tmp_path):
    m = load_machine("hexaglide")  # no bed cut (machines.md §1.7 item 3); O' below the drive-joint plane
    np.testing.assert_allclose(m.limits.position_min, [-np.inf, -np.inf, -np.inf])
    np.testing.assert_allclose(m.limits.position_max, [np.inf, np.inf, -0.15])
    bed = load_machine("hexaglide:machine_bed")
    np.testing.assert_allclose(bed.limits.position_min, [-np.inf, -np.inf, -1.1])
    text = (bundled_machine_dir() / "hexaglide.toml").read_text()
    for bad, pattern in [('frame = { z_min = "-100 mm", z_max = "-150 mm" }', r"limits\.frame\.z_min.*below z_max"),
                         ('frame = { z_low = "-1100 mm" }', r"limits\.frame\.z_low.*unknown key")]:
        p = tmp_path / "f.toml"
        p.write_text(text.replace('frame = { z_max = "-150 mm" }', bad))
        with pytest.raises(InputError, match=pattern):
            load_machine(p)
