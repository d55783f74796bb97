"""Parametric platform model: 6x6 stiffness at the spindle reference point, symmetry, output, CLI."""

import argparse
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from components.registry import build_component
from pkmstiff.cli.fe import cmd_fe_platform
from pkmstiff.fe.platform import component_toml, load_platform_parameters, platform_stiffness
from pkmstiff.units import InputError

PARAMS = Path(__file__).resolve().parents[1] / "pkmstiff" / "fe" / "params" / "hexaglide_platform.toml"
COARSE = 0.04  # m; ~13k DOFs, 1-2 s; the diagonal differs from the 30 mm mesh by < 4 %


@pytest.fixture(scope="module")
def pinned():
    return platform_stiffness(load_platform_parameters(PARAMS).with_mesh(size=COARSE))


def test_matrix_is_symmetric_positive_definite(pinned):
    K = pinned.K
    assert np.abs(K - K.T).max() <= 1e-9 * np.abs(K).max()
    assert np.linalg.eigvalsh(K).min() > 0


def test_mirror_symmetry_of_the_hexaglide_joint_layout(pinned):
    """Joint points and mesh are mirror-symmetric in x': x-odd and x-even DOFs decouple (ux, ry, rz vs uy, uz, rx)."""
    K = pinned.K
    odd, even = [0, 4, 5], [1, 2, 3]
    scale = np.sqrt(np.outer(np.diag(K), np.diag(K)))
    assert np.abs(K[np.ix_(odd, even)] / scale[np.ix_(odd, even)]).max() < 1e-8


def test_clamped_supports_are_stiffer_than_pinned(pinned, tmp_path):
    text = PARAMS.read_text(encoding="utf-8").replace('support = "pinned"', 'support = "clamped"')
    path = tmp_path / "clamped.toml"
    path.write_text(text, encoding="utf-8")
    clamped = platform_stiffness(load_platform_parameters(path).with_mesh(size=COARSE))
    # more constraints -> K_clamped - K_pinned positive semi-definite (eigenvalues >= -round-off)
    w = np.linalg.eigvalsh(clamped.K - pinned.K)
    assert w.min() >= -1e-9 * np.abs(pinned.K).max()
    assert w.max() > 0


def test_component_toml_builds_the_library_body_stiffness(pinned):
    text = component_toml(pinned, "platform_fe")
    raw = tomllib.loads(text)["components"]["platform_fe"]
    comp = build_component("platform_fe", raw)
    # written with 6 significant digits
    assert comp.matrix == pytest.approx(pinned.K, rel=1e-5, abs=1e-5 * np.abs(pinned.K).max())
    assert text.startswith("# 6x6 platform stiffness")


def test_fe_platform_command(tmp_path, capsys):
    base = dict(params=str(PARAMS), name="platform_stiffness", mesh_size=COARSE * 1e3, vtu=None, quiet=False)
    assert cmd_fe_platform(argparse.Namespace(out=str(tmp_path / "k.csv"), **base)) == 0
    table = pd.read_csv(tmp_path / "k.csv", index_col="row")  # a plain table: row label + ux..rz, units in k.json
    assert list(table.columns) == list(table.index) == ["ux", "uy", "uz", "rx", "ry", "rz"]
    K = table.to_numpy()
    assert K.shape == (6, 6) and np.all(np.diag(K) > 0)
    assert (tmp_path / "k.json").is_file()
    assert "N*m/urad" in capsys.readouterr().out
    assert cmd_fe_platform(argparse.Namespace(out=str(tmp_path / "k.toml"), **base)) == 0
    assert "body_stiffness" in (tmp_path / "k.toml").read_text(encoding="utf-8")
    with pytest.raises(InputError, match=r"\.toml or \.csv"):
        cmd_fe_platform(argparse.Namespace(out=str(tmp_path / "k.txt"), **base))


@pytest.mark.parametrize("old, new, key", [
    ("[-0.08, -0.18, 0.15]]", "[-0.08, -0.18, 0.15], [0.5, 0.0, 0.15]]", "joints.points[6]"),
    ('support = "pinned"', 'support = "glued"', "joints.support"),
    ('bore_radius = "60 mm"', 'bore_radius = "95 mm"', "spindle_housing.outer_radius"),
    ('thickness = "30 mm"', 'thickness = "-30 mm"', "plate.thickness"),
])
def test_bad_platform_parameters_name_the_key(tmp_path, old, new, key):
    text = PARAMS.read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / "bad.toml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    with pytest.raises(InputError) as exc:
        load_platform_parameters(path)
    assert key in str(exc.value)
