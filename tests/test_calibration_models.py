"""Calibration 1: error models, perturbed machines, machine files that extend the nominal one, measurement models."""

import numpy as np
import pytest

import pkmstiff
from pkmstiff.calibration import (
    Setup,
    circle_plan,
    error_model,
    machine_file_text,
    parse_with,
    perturbed_machine,
    simulate_readings,
)
from pkmstiff.calibration.plans import hemisphere_plan
from pkmstiff.errors import InputError
from pkmstiff.kinematics import inverse_kinematics


def test_parameter_counts_and_names(felix, hexaglide):
    p = error_model(felix)
    assert p.n == 42  # Szatmári §4.2.2: 3 x 6 + 3 x 6 + 6
    assert p.names[:7] == ("chain1.base_joint.x", "chain1.base_joint.y", "chain1.base_joint.z",
                           "chain1.platform_joint.x", "chain1.platform_joint.y", "chain1.platform_joint.z",
                           "chain1.strut_offset")
    assert set(p.units) == {"m"}
    g = error_model(hexaglide)
    assert g.n == 6 * 13  # guide start 3, direction 2, drive joint 3, strut 1, platform joint 3, drive zero 1
    assert "chain3.guide_direction.t2" in g.names and g.units[g.index("chain3.guide_direction.t2")] == "rad"
    # nominal values are the machine's own (exact copies)
    assert p.nominal[p.index("chain2.base_joint.z")] == felix.chains.drive_joint[1, 2]
    c = error_model(felix, frame="cylindrical")
    assert c.names[:3] == ("chain1.base_joint.r", "chain1.base_joint.t", "chain1.base_joint.z")
    # radial nominal = joint-circle radius R = 1500 mm (Felix, Szatmári §2.2.2), tangential 0; the machine file
    # gives coordinates to 1e-6 mm, so radii agree to ~1e-9 m
    assert c.nominal[c.index("chain4.base_joint.r")] == pytest.approx(1.5, abs=2e-9)
    assert c.nominal[c.index("chain4.base_joint.t")] == pytest.approx(0.0, abs=2e-9)
    assert c.nominal[c.index("chain5.platform_joint.r")] == pytest.approx(0.6, abs=2e-9)


def test_unknown_parameter_name_is_one_line(felix):
    p = error_model(felix)
    with pytest.raises(InputError) as err:
        p.vector({"chain1.base_joint.q": 1e-3})
    msg = str(err.value)
    assert "\n" not in msg and "chain1.base_joint.q" in msg and "did you mean" in msg
    with pytest.raises(InputError, match="unknown set-up parameter"):
        parse_with("ball-offset,bogus", "ballbar")
    with pytest.raises(InputError, match="set-up parameter of the tracker"):
        parse_with("fixed-ball", "tracker")


def test_perturbed_machine_and_extends_file_round_trip(felix, hexaglide, tmp_path):
    rng = np.random.default_rng(1)
    for m in (felix, hexaglide):
        p = error_model(m, frame="cylindrical")
        delta = rng.uniform(-1.75e-3, 1.75e-3, p.n)  # Szatmári Tab. 5.2 error scale
        real = perturbed_machine(m, p, delta)
        path = tmp_path / f"{m.name}_perturbed.toml"
        path.write_text(machine_file_text(m, p, delta))
        loaded = pkmstiff.load_machine(path)
        for key in ("drive_joint", "platform_joint", "drive_offset", "guide_start", "guide_direction",
                    "strut_length"):
            a, b = getattr(real.chains, key), getattr(loaded.chains, key)
            # repr() of floats round-trips exactly; the loader re-normalises guide directions (1 ulp)
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-15, err_msg=key)
        assert loaded.assumptions == m.assumptions  # everything else inherited from the nominal file


def test_drive_offset_shifts_the_drive_coordinate(felix):
    p = error_model(felix)
    delta = p.vector({"chain2.strut_offset": 1e-3})
    real = perturbed_machine(felix, p, delta)
    pose = np.array([0.1, -0.05, 0.02, 0.03, -0.02, 0.05])
    a, b = inverse_kinematics(felix, pose), inverse_kinematics(real, pose)
    # the strut is 1 mm longer for the same command: the controller's coordinate is 1 mm smaller (exact in IEEE)
    np.testing.assert_allclose(b.drive - a.drive, [[0, -1e-3, 0, 0, 0, 0]], atol=1e-15)
    np.testing.assert_array_equal(a.length, b.length)


def test_nominal_machine_reads_the_bar_length(felix):
    setup = Setup("ballbar", target=np.zeros(3), fixed_ball=np.zeros(3), bar_length=0.3)
    p = error_model(felix, setup=setup, setup_blocks=("ball_offset", "fixed_ball", "bar_offset"))
    for plan in (hemisphere_plan(setup, n=120), circle_plan(setup, "XZ", 36, tilt=np.radians(10))):
        r = simulate_readings(felix, p, np.zeros(p.n), plan)
        np.testing.assert_allclose(r[:, 0], 0.3, rtol=0, atol=1e-12)  # issue 16 acceptance level, 1e-12 m


def test_simulated_reading_of_a_pure_setup_error(felix):
    """Bar offset Δr adds to every reading; a fixed-ball shift e changes r by −û·e to first order."""
    setup = Setup("ballbar", target=np.zeros(3), fixed_ball=np.zeros(3), bar_length=0.3)
    p = error_model(felix, setup=setup, setup_blocks=("fixed_ball", "bar_offset"))
    plan = circle_plan(setup, "XY", 24)
    r = simulate_readings(felix, p, p.vector({"bar_offset": 2e-4}), plan)
    np.testing.assert_allclose(r[:, 0], 0.3002, atol=1e-12)
    e = 1e-6
    r = simulate_readings(felix, p, p.vector({"fixed_ball.x": e}), plan)
    t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    # second-order remainder e²/(2 r) = 1.7e-12 m
    np.testing.assert_allclose(r[:, 0] - 0.3, -e * np.cos(t), atol=5e-12)


def test_perturbed_machine_reaches_another_pose(felix):
    from pkmstiff.calibration import reached_poses
    p = error_model(felix)
    delta = p.vector({"chain1.base_joint.x": 1e-3})
    x = np.array([[0.05, 0.02, 0.1, 0.02, 0.01, -0.03]])
    reached = reached_poses(felix, p, delta, x)
    real = perturbed_machine(felix, p, delta)
    # the reached pose reproduces the commanded drive values on the real machine (FK tolerance 1e-13 m)
    np.testing.assert_allclose(inverse_kinematics(real, reached).drive, inverse_kinematics(felix, x).drive,
                               atol=1e-12)
    assert np.abs(reached - x).max() > 1e-5  # and differs from the commanded pose


def test_error_table_with_units(felix, hexaglide):
    from pkmstiff.calibration.parameters import parse_errors
    p = error_model(felix)
    d = parse_errors({"chain1.base_joint.x": "0.5 mm", "chain6.strut_offset": -2e-4}, p)
    assert d[p.index("chain1.base_joint.x")] == pytest.approx(5e-4, rel=1e-15)
    assert d[p.index("chain6.strut_offset")] == -2e-4 and np.count_nonzero(d) == 2
    g = error_model(hexaglide)
    d = parse_errors({"chain2.guide_direction.t1": "0.2 mrad"}, g)
    assert d[g.index("chain2.guide_direction.t1")] == pytest.approx(2e-4, rel=1e-15)
    with pytest.raises(InputError, match="chain1.base_joint.x.*dimension of m"):
        parse_errors({"chain1.base_joint.x": "3 deg"}, p)
    with pytest.raises(InputError, match="unknown parameter"):
        parse_errors({"chain7.base_joint.x": 1e-3}, p)
