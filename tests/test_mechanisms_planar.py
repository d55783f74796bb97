"""The planar examples as mechanism files (``biglide_generic``, ``bipod_generic``, generated from
pkmstiff/machine/bundled/planar by :func:`pkmstiff.mechanisms.generate.planar_mechanism_dict`): the generic elastic
model and kinetostatics equal the planar structure model of :mod:`pkmstiff.analysis.planar` (an independent,
hand-placed SDE model), so ``pkmstiff section NAME_generic`` maps the planar examples in their plane of motion;
``pkmstiff section biglide`` says so in one line."""

from __future__ import annotations

import numpy as np
import pytest

import pkmstiff.multibody as sde
from pkmstiff.analysis.planar import (
    load_planar,
    planar_inverse_jacobian,
    planar_inverse_kinematics,
    planar_kinetostatics,
    planar_modes,
    planar_reasons,
    planar_stiffness,
    planar_structure,
)
from pkmstiff.mechanisms import evaluate, inverse, load_mechanism
from pkmstiff.mechanisms.kinetostatics import mechanism_kinetostatics
from pkmstiff.mechanisms.structure import mechanism_structure

NAMES = ("biglide", "bipod")
#: the two models place the same elements at configurations that agree to ~1e-13 (measured: k 2e-13, f 1e-13,
#: a_max 2e-13); 1e-9 as for the spatial machines' mechanism files
RTOL = 1e-9


def _admissible_positions(pm, n: int, seed: int) -> np.ndarray:
    """n random platform positions (x, y) [m] where the planar model has no inadmissibility reason."""
    rng = np.random.default_rng(seed)
    xy = np.column_stack([rng.uniform(-0.4, 0.4, 4 * n), rng.uniform(0.1, 1.0, 4 * n)])
    ik = planar_inverse_kinematics(pm, xy)
    reasons, _ = planar_reasons(pm, ik, planar_inverse_jacobian(pm, ik))
    good = xy[reasons == 0]
    assert len(good) >= n
    return good[:n]


@pytest.mark.parametrize("name", NAMES)
def test_planar_mechanism_files_equal_the_planar_models(name):
    """k_x, k_y, every natural frequency, a_max along ±x, ±y and the static drive loads at 100 poses."""
    pm, mech = load_planar(name), load_mechanism(f"{name}_generic")
    xy = _admissible_positions(pm, 100, 11)
    poses = np.column_stack([xy, np.zeros(len(xy))])
    ps = planar_structure(pm, xy)
    k_ref = 1.0 / np.diagonal(np.linalg.inv(planar_stiffness(ps)), axis1=1, axis2=2)
    f_ref = planar_modes(ps).frequencies_hz
    ms = mechanism_structure(mech, poses)
    assert ms.ok.all()
    ev = sde.evaluate_point(ms.model, ms.load_body, ms.load_point, f_ref.shape[1])
    compliance = np.diagonal(ev.compliance, axis1=1, axis2=2)[:, :2]
    np.testing.assert_allclose(ms.scatter(1.0 / compliance), k_ref, rtol=RTOL)
    np.testing.assert_allclose(ms.scatter(ev.frequencies_hz), f_ref, rtol=RTOL)
    ks = mechanism_kinetostatics(mech, inverse(mech, poses))
    pk = planar_kinetostatics(pm, xy, directions=((1, 0), (-1, 0), (0, 1), (0, -1)))
    assert ks.acceleration_labels == ["x", "-x", "y", "-y"]
    np.testing.assert_allclose(ks.a_max, pk.a_max, rtol=RTOL)
    np.testing.assert_allclose(ks.drive_loads, pk.drive_loads, rtol=0, atol=RTOL * np.abs(pk.drive_loads).max())


@pytest.mark.parametrize("name", NAMES)
def test_planar_mechanism_files_have_the_planar_workspace(name):
    """Admissible (no reason) on a raster exactly where the planar model's reasons are none, except where a drive
    sits on its limit to rounding (λ = 0 of the biglide at x = ±400 mm, y = 800 mm: −2e-15 m in the generic
    solver)."""
    pm, mech = load_planar(name), load_mechanism(f"{name}_generic")
    X, Y = np.meshgrid(np.linspace(-0.45, 0.45, 19), np.linspace(0.05, 1.05, 21))
    xy = np.column_stack([X.ravel(), Y.ravel()])
    ik = planar_inverse_kinematics(pm, xy)
    reasons, _ = planar_reasons(pm, ik, planar_inverse_jacobian(pm, ik))
    ev = evaluate(mech, np.column_stack([xy, np.zeros(len(xy))]))
    lo, hi = ((np.zeros(2), pm.guide_length) if pm.kind == "glide" else (pm.length_min, pm.length_max))
    drive = ik.drive if pm.kind == "glide" else ik.length
    on_limit = np.any(np.minimum(np.abs(drive - lo), np.abs(drive - hi)) < 1e-9, axis=1)
    differ = (reasons == 0) != (ev.reasons == 0)
    assert (reasons == 0).sum() > 100
    assert not np.any(differ & ~on_limit), xy[differ & ~on_limit]


def test_section_of_a_planar_example_names_its_mechanism_file(capsys, tmp_path):
    from pkmstiff.cli import main

    assert main(["section", "biglide", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "pkmstiff section biglide_generic" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name, pose", [("biglide", "100,600"), ("bipod", "0,-707")])
def test_point_of_the_mechanism_file_equals_the_planar_point(capsys, name, pose):
    """``pkmstiff point NAME_generic`` prints the planar example's k_x, k_y and frequencies (rtol 1e-9, as above;
    the bipod's platform rotation is held: no rotational stiffness, n/a).  The bipod's pose below its base line is
    the other assembly mode than home's (0, 500) mm: the mechanism is solved there with ``--start-pose`` in it, and
    is refused without (other working mode, exit 3)."""
    import json

    from pkmstiff.cli import main

    assert main(["point", name, "--pose", pose, "--json"]) == 0
    ref = json.loads(capsys.readouterr().out)
    start = ["--start-pose", pose + ",0"] if name == "bipod" else []
    if start:
        assert main(["point", f"{name}_generic", "--pose", pose + ",0"]) == 3
        assert "other working mode" in capsys.readouterr().err
    assert main(["point", f"{name}_generic", "--pose", pose + ",0", "--json", *start]) == 0
    got = json.loads(capsys.readouterr().out)
    for ax in "xy":
        assert got["k_N_per_um"][ax] == pytest.approx(ref["k_N_per_um"][ax], rel=RTOL)
    assert got["frequencies_Hz"] == pytest.approx(ref["frequencies_Hz"], rel=RTOL)
    assert got.get("rotational_stiffness_Nm_per_urad", {}).get("z") is None
