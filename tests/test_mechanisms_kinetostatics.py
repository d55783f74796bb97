"""Kinetostatics of mechanisms (issue 27, item 1): drive Jacobian, static drive loads and mass matrix against finite
differences of the kinematics; v_max of the Hexaglide's mechanism file equals the machine's."""

from __future__ import annotations

import numpy as np
import pytest

from pkmstiff.mechanisms import forward, inverse, load_mechanism
from pkmstiff.mechanisms.constraints import Frames
from pkmstiff.mechanisms.kinetostatics import G, _bodies, mechanism_kinetostatics

CASES = [("hexa_6rus", [0.02, -0.03, -0.42, 0.05, -0.03, 0.08]),
         ("hybrid_tripod_wrist", [0.0, 0.1, -1.0732, 0.17, 0.0, 0.0]),
         ("five_bar", [0.09, 0.31, 0.0])]


def _positions(mech, q: np.ndarray) -> np.ndarray:
    """World positions (N, B, 3) of every mass of the elastic model."""
    F = Frames(q, mech.dim, derivatives=False)
    out = []
    for li, cog, _, _ in _bodies(mech):
        p = F.t[:, li] + np.einsum("nab,b->na", F.R[:, li], cog[:mech.dim])
        out.append(np.concatenate([p, np.zeros((q.shape[0], 3 - mech.dim))], axis=1))
    return np.stack(out, axis=1)


@pytest.mark.parametrize("name, pose", CASES)
def test_drive_jacobian_loads_and_masses_equal_finite_differences(name, pose):
    """J⁻¹ = ∂s/∂x_c by central differences of the inverse kinematics; τ_g = ∂V/∂s (V = Σ m (−g)·r, virtual work)
    and the translational part of M_s = Σ m J_vᵀ J_v by central differences of the forward kinematics. Step h =
    1e-6 (m or rad): truncation O(h²) ≈ 1e-12, the solver's 1e-12 residual / h ≈ 1e-6 relative: rtol 1e-5."""
    mech = load_mechanism(name)
    sol = inverse(mech, [pose])
    ks = mechanism_kinetostatics(mech, sol)
    n = len(mech.drives)
    h = 1e-6
    # drive rates per output rate: the directions of the point coordinates (orientation held) are columns of J⁻¹
    for r, o in enumerate(ks.outputs):
        if o not in "xyz":
            continue
        dp = np.zeros(mech.pose_size)
        dp["xyz".index(o)] = h
        s_p = inverse(mech, [np.asarray(pose) + dp], start=sol).drives[0]
        s_m = inverse(mech, [np.asarray(pose) - dp], start=sol).drives[0]
        np.testing.assert_allclose(ks.jinv[0, :, r], (s_p - s_m) / (2 * h), rtol=1e-5, atol=1e-6)
    masses = np.array([b[2] for b in _bodies(mech)])
    g = -G * mech.elastic.vertical
    Jv = np.zeros((len(masses), 3, n))
    for c in range(n):
        ds = np.zeros(n)
        ds[c] = h
        pp = _positions(mech, forward(mech, sol.drives + ds, start=sol).q)[0]
        pm = _positions(mech, forward(mech, sol.drives - ds, start=sol).q)[0]
        Jv[:, :, c] = (pp - pm) / (2 * h)
        dV = np.sum(masses * ((pp - pm) @ -g)) / (2 * h)
        assert ks.drive_loads[0, c] == pytest.approx(dV, rel=1e-5, abs=1e-6 * np.abs(ks.drive_loads).max())
    m_trans = np.einsum("b,bic,bid->cd", masses, Jv, Jv)
    # the rotational inertia part of M_s is positive semidefinite: M_s − M_trans ⪰ 0, and equal where no inertia
    rot = ks.mass_matrix[0] - m_trans
    assert np.linalg.eigvalsh(rot).min() > -1e-5 * np.abs(ks.mass_matrix[0]).max()


def test_hexaglide_mechanism_velocities_equal_the_machines(capsys):
    """v_max (eq. 4.79) and U depend only on J⁻¹, the drive speed limits and w: the Hexaglide's mechanism file gives the
    machine's v_max (the limiting drive may differ among tied drives; rtol 1e-9: the two inverse kinematics agree to 1e-12)."""
    import json

    from pkmstiff.cli import main

    assert main(["point", "hexaglide_generic", "--pose", "30,280,-950,2,-1,3", "--json", "--modes", "0"]) == 0
    mech = json.loads(capsys.readouterr().out)
    assert main(["point", "hexaglide", "--pose", "30,280,-950,2,-1,3", "--json", "--modes", "0"]) == 0
    machine = json.loads(capsys.readouterr().out)
    for ax in "xyz":
        assert mech["v_max_m_per_s"][ax] == pytest.approx(machine["v_max_m_per_s"][ax], rel=1e-9)
    assert set(mech["a_max_m_per_s2"]) == set(machine["a_max_m_per_s2"])
    assert all(v > 0 for v in mech["a_max_m_per_s2"].values())
    assert mech["controlled_outputs"][:3] == ["x", "y", "z"]
    # U = (σ_min/σ_max)^½ of W J_C with the machine's weight w (written by the generator): the machine's value, whose
    # κ is certified to rtol 1e-4 (kinematics.condition_number, method "fast"; U = κ^-½: 5e-5), ours is an SVD
    assert mech["transmission_weight_m_per_rad"] == pytest.approx(machine["transmission_weight_m_per_rad"], rel=1e-15)
    assert mech["transmission_quality"] == pytest.approx(machine["transmission_quality"], rel=1e-4)


@pytest.mark.parametrize("name, pose", [("hexaglide_generic", [0.03, 0.28, -0.95, 0.0, 0.0, 0.0]),
                                        ("hexa_6rus", [0.02, -0.03, -0.42, 0.05, -0.03, 0.08])])
def test_acceleration_bound_is_the_drive_force_balance(name, pose):
    """a_max in a direction e: the limiting drive's force τ_g + c + a·μ reaches its available force T exactly, and
    no drive exceeds it; v_max drives the limiting drive at its speed limit (linear drives: N, m/s; the 6-RUS's
    rotary drives: N m, rad/s from max_torque, max_angular_speed)."""
    mech = load_mechanism(name)
    sol = inverse(mech, [pose])
    ks = mechanism_kinetostatics(mech, sol)
    from pkmstiff.mechanisms.kinetostatics import ACCELERATION_DIRECTIONS, _drive_limits

    avail = _drive_limits(mech, "max_force", np.nan) - _drive_limits(mech, "force_reserve", 0.0)
    coul = _drive_limits(mech, "coulomb_friction", 0.0)
    for k, lab in enumerate(ACCELERATION_DIRECTIONS):
        e = np.zeros(6)
        e["xyz".index(lab[-1])] = -1.0 if lab.startswith("-") else 1.0
        qdd = ks.jinv[0] @ e
        force = ks.drive_loads[0] + coul * np.sign(qdd) + ks.a_max[0, k] * (ks.mass_matrix[0] @ qdd)
        assert np.all(np.abs(force) <= avail * (1 + 1e-9))
        assert abs(force[ks.a_limiting[0, k]]) == pytest.approx(avail[ks.a_limiting[0, k]], rel=1e-9)
    speed = _drive_limits(mech, "max_speed", np.nan)
    assert np.all(np.isfinite(speed)) and np.all(np.isfinite(ks.a_max))
    for k, lab in enumerate(ks.velocity_labels):
        rates = np.abs(ks.jinv[0, :, "xyz".index(lab)]) * ks.v_max[0, k]
        assert np.all(rates <= speed * (1 + 1e-12))
        assert rates[ks.v_limiting[0, k]] == pytest.approx(speed[ks.v_limiting[0, k]], rel=1e-12)


HEXAGLIDE_POSES = [[0.0, 0.0, -1.0, 0.0, 0.0, 0.0], [0.03, 0.28, -0.95, 0.03, -0.02, 0.05],
                   [-0.2, 0.5, -1.1, 0.0, 0.05, 0.0], [0.25, 0.1, -0.85, -0.04, 0.0, 0.1]]


@pytest.mark.parametrize("option, strut_share", [("", 1.0), (":drive_load_platform_only", 0.0)])
def test_hexaglide_mechanism_accelerations_and_drive_loads_equal_the_machines(option, strut_share):
    """The machine's a_max and static drive loads (eq. 4.86, 4.90 with M_A = drives, M_P = platform, gravity on
    platform + ``drive_load_strut_mass`` × the six struts at the platform CoG) from the mechanism file's lumped masses
    and its ``[elastic] drive_load_strut_mass`` (written by the generator from the machine's limits key). Both use the
    same formulas; J⁻¹ of the two inverse kinematics agree to ~1e-12 relative, so rtol 1e-9 leaves 1000× margin for
    the linear solves (κ(J) ≲ 1e2 here). The platform-only option checks that the strut share is the only
    difference (without it the loads were 117.24 / 187.58 = 0.625 of the machine's)."""
    import dataclasses

    from pkmstiff.analysis.kinetostatics import kinetostatics
    from pkmstiff.machine import load_machine

    machine = kinetostatics(load_machine("hexaglide" + option), np.array(HEXAGLIDE_POSES))
    mech = load_mechanism("hexaglide_generic")
    assert mech.elastic.drive_load_strut_mass == 1.0
    mech = dataclasses.replace(mech, elastic=dataclasses.replace(mech.elastic, drive_load_strut_mass=strut_share))
    ks = mechanism_kinetostatics(mech, inverse(mech, HEXAGLIDE_POSES))
    assert ks.acceleration_labels == machine.acceleration_labels
    assert np.all(np.isfinite(machine.a_max)) and np.all(machine.a_max > 0)
    np.testing.assert_allclose(ks.a_max, machine.a_max, rtol=1e-9)
    np.testing.assert_allclose(ks.drive_loads, machine.drive_loads, rtol=0,
                               atol=1e-9 * np.abs(machine.drive_loads).max())


def test_drive_load_strut_mass_is_a_fraction():
    """``[elastic] drive_load_strut_mass`` outside [0, 1] is refused at load, naming the key."""
    from pkmstiff.errors import InputError
    from pkmstiff.machine import load_machine
    from pkmstiff.mechanisms.generate import HOME_POSES, mechanism_dict
    from pkmstiff.mechanisms.loader import mechanism_from_dict

    table = mechanism_dict(load_machine("hexaglide"), np.array(HOME_POSES["hexaglide"]))
    table["elastic"]["drive_load_strut_mass"] = 1.5
    with pytest.raises(InputError, match="drive_load_strut_mass"):
        mechanism_from_dict(table, "<test>")


def test_6x_mechanism_accelerations_and_drive_loads_equal_the_machines():
    """The 6X's mechanism file gives the machine's a_max and static drive loads at 100 poses (those of the k/f
    equality, tests/test_mechanisms_elastic.py): its telescopic drives' mass (the ball screw's apparent spindle mass
    49.19 kg, Cobet eq. 3.4) is the drive-coordinate mass M_A of eq. 4.86 (no weight, eq. 4.90). rtol 1e-9 as for
    the Hexaglide: the same formulas on J⁻¹ of two inverse kinematics that agree to ~1e-12 (measured 2e-14)."""
    from pkmstiff.analysis.kinetostatics import drive_data, kinetostatics
    from pkmstiff.machine import load_machine
    from pkmstiff.mechanisms.generate import HOME_POSES

    rng = np.random.default_rng(7)
    poses = np.asarray(HOME_POSES["hexapod_6x"]) + np.column_stack([rng.uniform(-0.1, 0.1, (100, 3)),
                                                                    rng.uniform(-0.08, 0.08, (100, 3))])
    machine = load_machine("hexapod_6x")
    ref = kinetostatics(machine, poses)
    mech = load_mechanism("hexapod_6x_generic")
    ks = mechanism_kinetostatics(mech, inverse(mech, poses))
    m_a = drive_data(machine).mass
    assert np.all(m_a > 49.0)  # the apparent mass is there to be matched
    assert np.all(np.isfinite(ref.a_max)) and np.all(ref.a_max > 0)
    np.testing.assert_allclose(ks.a_max, ref.a_max, rtol=1e-9)
    np.testing.assert_array_equal(ks.a_limiting, ref.a_limiting)
    np.testing.assert_allclose(ks.drive_loads, ref.drive_loads, rtol=0, atol=1e-9 * np.abs(ref.drive_loads).max())


def _hexa_table(servo_inertia: float, crank_rotor: float) -> dict:
    """hexa_6rus's table with the servos' rotor ``inertia`` [kg m²], or the same inertia about each crank's drive
    axis added to the crank body's inertia tensor (``crank_rotor``)."""
    import tomllib

    from pkmstiff.mechanisms.loader import bundled_mechanism_dir

    table = tomllib.loads((bundled_mechanism_dir() / "hexa_6rus.toml").read_text())
    table["components"]["servo"]["inertia"] = f"{servo_inertia} kg*m^2"
    joints = {j["name"]: j for j in table["joints"]}
    for i in range(1, 7):
        a = np.asarray(joints[f"R{i}"]["axis"], float)
        a /= np.linalg.norm(a)
        body = dict(table["components"]["crank"])
        body["inertia"] = (np.diag(body["inertia"]) + crank_rotor * np.outer(a, a)).tolist()
        table["components"][f"crank{i}"] = body
        table["elastic"]["links"][f"crank{i}"]["body"] = f"crank{i}"
    return table


def test_rotary_drive_inertia_is_the_rotor_about_the_drive_axis():
    """A rotary drive's ``inertia`` J (rotor behind its gear) is a drive-coordinate inertia: for a servo fixed to the
    ground it equals J about the drive axis added to the driven crank's inertia tensor (kinetic energy ½ J θ̇² both
    ways) — M_s and a_max of the two files agree to rounding (rtol 1e-12); the static drive loads do not change."""
    from pkmstiff.mechanisms.loader import mechanism_from_dict

    pose = [[0.02, -0.03, -0.42, 0.05, -0.03, 0.08], [0.0, 0.0, -0.4, 0.0, 0.0, 0.0]]
    rotor = mechanism_from_dict(_hexa_table(0.004, 0.0), "<rotor>")
    crank = mechanism_from_dict(_hexa_table(0.0, 0.004), "<crank>")
    base = mechanism_from_dict(_hexa_table(0.0, 0.0), "<none>")
    ks_r, ks_c, ks_0 = (mechanism_kinetostatics(m, inverse(m, pose)) for m in (rotor, crank, base))
    np.testing.assert_allclose(ks_r.mass_matrix, ks_c.mass_matrix, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(ks_r.mass_matrix - ks_0.mass_matrix, np.broadcast_to(0.004 * np.eye(6), (2, 6, 6)),
                               rtol=0, atol=1e-15)
    np.testing.assert_allclose(ks_r.a_max, ks_c.a_max, rtol=1e-12)
    assert np.all(ks_r.a_max < ks_0.a_max)
    np.testing.assert_allclose(ks_r.drive_loads, ks_0.drive_loads, rtol=1e-14)
