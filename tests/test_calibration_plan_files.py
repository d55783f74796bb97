"""Measurement plans (issue 16 item 2): circles in any plane with a tilt schedule, hemisphere paths with spline
orientation nodes, grids; TOML reading, plan checks with one-line errors, nominal readings of the new kinds."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pkmstiff.calibration import Setup, check_plan, circle_plan, error_model, hemisphere_plan, read_plan
from pkmstiff.calibration.plans import plane_axes, spline_orientations, tilt_torsion_matrix
from pkmstiff.calibration.simulation import SimulationOptions, simulate
from pkmstiff.errors import InadmissibleError, InputError
from pkmstiff.kinematics.rotation import cardan_matrix


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 1e-3))
def test_plane_axes_are_a_right_handed_frame_about_the_normal(n):
    e1, e2 = plane_axes(np.array(n))
    nn = np.array(n) / np.linalg.norm(n)
    F = np.c_[e1, e2, nn]
    assert np.allclose(F.T @ F, np.eye(3), atol=1e-12)  # orthonormal to rounding
    assert np.allclose(np.cross(e1, e2), nn, atol=1e-12)  # counter-clockwise about n


def test_spline_orientations_pass_through_their_nodes():
    nodes = np.radians([[2.0, 0.0, 1.0], [6.0, 90.0, -2.0], [4.0, 200.0, 0.0], [1.0, 300.0, 3.0]])
    s = np.arange(4) / 4
    assert np.allclose(spline_orientations(nodes, s, periodic=True), nodes, atol=1e-14)  # interpolation
    # periodic and unwrapped: L turns once (300° -> 360°), B and D close; value continuous across s = 1
    f = spline_orientations(nodes, np.array([1 - 1e-6, 1e-6]), periodic=True)
    assert np.allclose(f[0] - [0, 2 * np.pi, 0], f[1], atol=1e-5)  # |Δ| ≤ slope · 2e-6, slopes here ≲ 5 rad
    assert np.allclose(spline_orientations(nodes, np.array([1.0]), periodic=True), nodes[:1], atol=1e-14)
    s5 = np.linspace(0, 1, 5)
    n5 = np.vstack([nodes, nodes[:1] * 2])
    d = spline_orientations(n5, s5, periodic=False) - n5
    assert np.allclose(np.angle(np.exp(1j * d)), 0.0, atol=1e-14)  # the nodes, up to whole turns of L and D


def test_circle_with_a_normal_and_a_tilt_schedule(felix):
    setup = Setup("ballbar", target=np.zeros(3), fixed_ball=np.zeros(3), bar_length=0.15)
    nodes = np.radians([[0.0, 0.0, 0.0], [5.0, 90.0, 3.0], [5.0, 180.0, 0.0], [5.0, 270.0, -3.0]])
    n = np.array([1.0, 1.0, 2.0])
    plan = circle_plan(setup, n, 72, nodes=nodes)
    x = plan.poses
    P = x[:, :3]  # target at the platform origin
    assert np.allclose(np.linalg.norm(P, axis=1), 0.15, atol=1e-12)  # on the circle
    assert np.allclose(P @ n, 0.0, atol=1e-12)  # in the plane
    R = cardan_matrix(x[:, 3], x[:, 4], x[:, 5])
    Rn = tilt_torsion_matrix(nodes[:, 0], nodes[:, 1], nodes[:, 2])
    assert np.allclose(R[::18], Rn, atol=1e-12)  # the schedule passes through its nodes (72 / 4 = 18)
    res = simulate(felix, error_model(felix, setup=setup), np.zeros(42), plan,
                   options=SimulationOptions(feed=0.1, noise="none", quantise=False))
    assert np.max(np.abs(res.readings[:, 0] - 0.15)) <= 1e-12  # done-when: nominal reads the bar length


def test_hemisphere_with_orientation_nodes(felix):
    setup = Setup("ballbar", target=np.zeros(3), fixed_ball=np.zeros(3), bar_length=0.3)
    nodes = np.radians([[5.0, 0.0, 0.0], [10.0, 120.0, 5.0], [5.0, 240.0, -5.0], [8.0, 30.0, 0.0], [3.0, 90.0, 0.0]])
    plan = hemisphere_plan(setup, n=201, turns=2.0, nodes=nodes)
    check_plan(felix, plan)
    x = plan.poses
    R = cardan_matrix(x[:, 3], x[:, 4], x[:, 5])
    assert np.allclose(R[::50], tilt_torsion_matrix(*nodes.T), atol=1e-12)  # nodes at s = j / 4
    res = simulate(felix, error_model(felix, setup=setup), np.zeros(42), plan,
                   options=SimulationOptions(feed=0.2, noise="none", quantise=False, directions=("ccw",)))
    assert np.max(np.abs(res.readings[:, 0] - 0.3)) <= 1e-12  # done-when


PLAN = """
[plan]
name = "mixed"
instrument = "ballbar"
[setup]
fixed_ball = ["0 mm", "0 mm", "0 mm"]
bar_length = "150 mm"
max_mount_angle = "150 deg"
[[paths]]
kind = "circle"
normal = [1, 1, 2]
points = 72
nodes = [["0 deg", "0 deg", "0 deg"], ["5 deg", "90 deg", "3 deg"], ["5 deg", "180 deg", "0 deg"]]
[[paths]]
kind = "hemisphere"
points = 100
turns = 1
nodes = [["5 deg", "0 deg", "0 deg"], ["10 deg", "120 deg", "5 deg"]]
"""


def test_toml_plan_with_nodes_reads_and_checks(tmp_path, felix):
    p = tmp_path / "p.toml"
    p.write_text(PLAN)
    plan = read_plan(p)
    assert plan.n_poses == 172 and [s.kind for s in plan.segments] == ["path", "path"]
    check_plan(felix, plan)
    p.write_text(PLAN.replace('"150 deg"', '"30 deg"'))
    with pytest.raises(InadmissibleError, match=r"poses tilt the ball bar beyond the cup's 30 deg .* first pose"):
        check_plan(felix, read_plan(p))


def test_tracker_grid_from_toml(tmp_path, felix):
    p = tmp_path / "g.toml"
    p.write_text('[plan]\ninstrument = "tracker"\n[[paths]]\nkind = "grid"\ncentre = [0, 0, 0]\n'
                 'half_width = "50 mm"\npoints = 2\n')
    plan = read_plan(p)
    assert plan.n_poses == 24 and plan.segments[0].kind == "points"
    check_plan(felix, plan)


@pytest.mark.parametrize("patch,needle", [
    (('normal = [1, 1, 2]', 'normal = [1, 1, 2]\nplane = "XY"'), "either plane or normal"),
    (('normal = [1, 1, 2]', 'normal = [0, 0, 0]'), "a non-zero normal vector"),
    (('nodes = [["5 deg", "0 deg", "0 deg"], ["10 deg", "120 deg", "5 deg"]]', 'nodes = [["5 deg", "0 deg"]]'),
     "paths[2].nodes"),
    (('kind = "hemisphere"', 'kind = "spiral"'), "circle, hemisphere, grid or poses"),
])
def test_malformed_plan_files(tmp_path, patch, needle):
    p = tmp_path / "p.toml"
    p.write_text(PLAN.replace(*patch))
    with pytest.raises(InputError) as exc:
        read_plan(p)
    assert needle in str(exc.value) and "\n" not in str(exc.value)


def test_plan_outside_the_workspace_names_first_pose_and_count(felix):
    setup = Setup("ballbar", target=np.zeros(3), fixed_ball=np.array([0.0, 0.0, 3.0]), bar_length=0.15)
    with pytest.raises(InadmissibleError, match=r"72 of 72 poses not admissible on felix: pose 1 \(") as exc:
        check_plan(felix, circle_plan(setup, "XY", 72))
    assert "\n" not in str(exc.value)
