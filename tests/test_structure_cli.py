"""``pkmstiff point`` (spatial machines and planar examples): text, JSON keys with units, argument errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pkmstiff.analysis import kinetostatics, natural_frequencies, tcp_compliance
from pkmstiff.cli import main
from pkmstiff.machine.loader import load_machine
from pkmstiff.structure import build_structure


def run(capsys, *args) -> tuple[int, str, str]:
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_point_json_matches_the_analyses(capsys):
    code, out, _ = run(capsys, "point", "hexaglide", "--pose", "0,0,-1000,0,0,0", "--tool-length", "150",
                       "--modes", "3", "--json")
    assert code == 0
    rep = json.loads(out)
    pose = np.array([0.0, 0.0, -1.0, 0.0, 0.0, 0.0])
    st = build_structure(load_machine("hexaglide"), pose)
    c = tcp_compliance(st, 0.15)[0]
    for i, ax in enumerate("xyz"):  # N/µm and N·m/µrad: SI / 1e6
        assert rep["k_N_per_um"][ax] == pytest.approx(1.0 / c[i, i] / 1e6, rel=1e-12)
        assert rep["rotational_stiffness_Nm_per_urad"][ax] == pytest.approx(1.0 / c[3 + i, 3 + i] / 1e6, rel=1e-12)
    np.testing.assert_allclose(rep["frequencies_Hz"], natural_frequencies(st, 3)[0], rtol=1e-9)
    assert len(rep["mode_descriptions"]) == 3 and all("%" in d for d in rep["mode_descriptions"])
    for d in "xyz":
        assert sum(rep["weak_points_percent"][d].values()) == pytest.approx(100.0, rel=1e-9)
    ks = kinetostatics(load_machine("hexaglide"), pose[None])
    assert rep["v_max_m_per_min"]["y"] == pytest.approx(60.0 * rep["v_max_m_per_s"]["y"], rel=1e-12)
    assert rep["v_max_m_per_s"]["y"] == pytest.approx(ks.v_max[0, 1], rel=1e-12)
    assert rep["a_max_m_per_s2"]["-z"] == pytest.approx(ks.a_max[0, 5], rel=1e-12)
    np.testing.assert_allclose(rep["static_drive_loads_N"], ks.drive_loads[0], rtol=1e-12)
    assert rep["tool_length_mm"] == pytest.approx(150.0) and rep["modelled"] is True


def test_point_text_and_unreachable_pose(capsys):
    code, out, _ = run(capsys, "point", "hexaglide", "--pose", "0,0,-1000,0,0,0")
    assert code == 0
    for text in ("k_x =", "N/µm", "N·m/µrad", "Hz", "weak points", "m/min", "m/s²", "static drive loads"):
        assert text in out
    code, out, err = run(capsys, "point", "hexaglide", "--pose", "0,0,500,0,0,0", "--json")
    assert code == 3 and out == "" and "guide" in err and len(err.strip().splitlines()) == 1  # refused
    code, out, _ = run(capsys, "point", "hexaglide", "--pose", "0,0,500,0,0,0", "--json", "--allow-inadmissible")
    rep = json.loads(out)
    assert code == 0 and rep["modelled"] is False and "guide" in rep["model_reasons"][0]
    assert rep["admissible"] is False and rep["analysed_although_inadmissible"] is True
    assert rep["k_N_per_um"]["x"] is None  # NaN becomes null


def test_point_planar_example(capsys):
    code, out, _ = run(capsys, "point", "bipod", "--pose", "0,-707", "--json")
    rep = json.loads(out)
    assert code == 0 and rep["machine_type"] == "planar pod"
    n = np.array([1.0, -0.707]) / np.hypot(1.0, 0.707)
    assert rep["k_N_per_um"]["x"] == pytest.approx(2 * n[0] ** 2, rel=1e-9)  # K = Σ k n nᵀ, k = 1 N/µm
    assert len(rep["frequencies_Hz"]) == 2


@pytest.mark.parametrize("args, msg", [
    (("--pose", "0,0,-1000"), "six"),
    (("--pose", "0,0,-1000,0,0,0", "--tool-length", "-5"), "tool-length"),
])
def test_point_argument_errors(capsys, args, msg):
    code, _, err = run(capsys, "point", "hexaglide", *args)
    assert code == 2 and msg in err
