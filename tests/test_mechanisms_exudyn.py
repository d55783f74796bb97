"""Cross-check of the elastic model of the bundled hybrid machine (tripod + two-axis wrist, issue 27) against an
independent Exudyn model built here from the mechanism file's data.

Exudyn model: rigid bodies for plate, fork and tool (component masses plus the masses the file places on them:
half of each strut at its plate joint, the wrist motors' rotors on the driven link at the joint), point masses for
the three carriages (drive + half a strut), Cartesian springs for drive and guide of each vertical carriage (x' =
guide = z, z' = the x axis for a vertical guide, components.guides.drive_frame), distance springs for the struts
(series of strut, ball joint and the Cardan joint evaluated here at the normal-referenced tilt computed here),
rigid-body springs for the central bearing, the anti-twist and the wrist bearings with their torque motors (6×6 in
the axes of the joint's first link).  The configurations come from the generic solver (verified against
independent solvers to 1e-13 elsewhere).  TCP compliance from Exudyn's nonlinear static solver with ±F, ±2F
(Richardson, as tests/test_exudyn_crosscheck.py), frequencies from ComputeLinearizedSystem; agreement to 1e-6.
"""

from __future__ import annotations

import numpy as np
import pytest

exu = pytest.importorskip("exudyn", reason="exudyn is a test-only dependency (extra 'test'); not installed here")
from exudyn.itemInterface import (
    LoadForceVector,
    LoadTorqueVector,
    MarkerBodyPosition,
    MarkerBodyRigid,
    NodePoint,
    NodeRigidBodyRxyz,
    ObjectConnectorCartesianSpringDamper,
    ObjectConnectorRigidBodySpringDamper,
    ObjectConnectorSpringDamper,
    ObjectGround,
    ObjectMassPoint,
    ObjectRigidBody,
)
from exudyn.rigidBodyUtilities import RotationMatrix2RotXYZ

from components.protocol import ComponentState
from pkmstiff.mechanisms import inverse, load_mechanism
from pkmstiff.mechanisms.constraints import link_rotations
from pkmstiff.mechanisms.stiffness import evaluate_mechanism
from tests.test_exudyn_crosscheck import RTOL, _central, assert_blocks_close, exudyn_frequencies, inertia6

MECH = load_mechanism("hybrid_tripod_wrist")
#: admissible tool poses (x, y, z [m], a, b, c [rad]) around home (0, 0.1, -1.0732; tool axis tilted 30° about x)
POSES = np.array([[0.0, 0.1, -1.073205080757, 0.0, 0.0, 0.0],
                  [0.04, 0.12, -1.05, 0.05, 0.1, 0.0],
                  [-0.05, 0.06, -1.11, -0.08, 0.15, 0.0]])


def _body(mass: float, cog: np.ndarray, inertia: np.ndarray, points: list[tuple[float, np.ndarray]]):
    """Total mass, CoG and inertia about it (home coordinates) of a body with point masses (parallel axes)."""
    total = mass + sum(m for m, _ in points)
    c = (mass * cog + sum(m * p for m, p in points)) / total
    inertia = inertia.copy()
    for m, p in [(mass, cog)] + points:
        d = p - c
        inertia = inertia + m * (d @ d * np.eye(3) - np.outer(d, d))
    return total, c, inertia


def exudyn_hybrid(q: np.ndarray):
    comps = MECH.elastic.components
    jp = {j.name: j.point for j in MECH.joints}
    t, R = q[:, :3], link_rotations(q[:, 3:], 3)[0]
    L = {n: i for i, n in enumerate(MECH.links)}
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ObjectGround())
    strut_m = comps["tripod_strut"].mass
    bodies = {}
    defs = {  # link: (component, origin of its CoG, point masses at home points)
        "plate": ("plate", np.array([0, 0, -0.8]), [(strut_m / 2, jp[f"plate_cardan{i}"]) for i in (1, 2, 3)]),
        "fork": ("fork", np.array([0, 0, -0.9]), [(comps["wrist_motor_1"].mass, jp["V1"])]),
        "tool": ("spindle", np.array([0, 0.05, -0.986602540378]), [(comps["wrist_motor_2"].mass, jp["V2"])]),
    }
    for link, (cname, origin, pts) in defs.items():
        c = comps[cname]
        m, cog, inertia = _body(c.mass, origin + c.cog, np.asarray(c.inertia, float), pts)
        i = L[link]
        node = mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=list(t[i] + R[i] @ cog)
                                             + list(RotationMatrix2RotXYZ(R[i]))))
        bodies[link] = (mbs.AddObject(ObjectRigidBody(mass=m, inertia=inertia6(inertia), nodeNumber=node)), i, cog)

    def marker(link: str, world: np.ndarray, rigid: bool, turn: np.ndarray | None = None):
        """A marker at the world point ``world`` of ``link``; a rigid one turned by ``turn`` (body axes)."""
        body, local = (ground, world) if link == "frame" else (
            bodies[link][0], R[L[link]].T @ (world - (t[L[link]] + R[L[link]] @ bodies[link][2])))
        if rigid and turn is not None:
            return mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localHT=exu.HT(rotation=turn,
                                                                                translation=list(local))))
        return mbs.AddMarker((MarkerBodyRigid if rigid else MarkerBodyPosition)(bodyNumber=body,
                                                                                 localPosition=list(local)))

    k_a, guide = comps["carriage_drive"].k, comps["carriage_guide"]
    plate_i = L["plate"]
    cardan_axes = {1: np.array([-1.0, 0, 0]), 2: np.array([0.5, -0.866025403784, 0]),
                   3: np.array([0.5, 0.866025403784, 0])}
    for k in (1, 2, 3):
        s = L[f"strut{k}"]
        q_k = t[s] + R[s] @ jp[f"slider{k}"]  # carriage point (on the vertical guide)
        p_k = t[s] + R[s] @ jp[f"plate_cardan{k}"]
        node = mbs.AddObject(ObjectMassPoint(mass=comps["carriage_drive"].mass + strut_m / 2,
                                             nodeNumber=mbs.AddNode(NodePoint(referenceCoordinates=list(q_k)))))
        m_node = mbs.AddMarker(MarkerBodyPosition(bodyNumber=node, localPosition=[0.0, 0.0, 0.0]))
        # vertical guide: x' = z (drive), z' = x (fallback of drive_frame), y' = z' × x' = -y
        k_xyz = [guide.count * guide.k_vertical, guide.count * guide.k_horizontal, k_a]
        mbs.AddObject(ObjectConnectorCartesianSpringDamper(markerNumbers=[marker("frame", q_k, False), m_node],
                                                           stiffness=k_xyz, damping=[0.0] * 3))
        u = (q_k - p_k) / np.linalg.norm(q_k - p_k)  # from the plate joint into the strut
        tilt = np.arcsin(np.clip((R[plate_i] @ cardan_axes[k]) @ u, -1, 1) / np.linalg.norm(cardan_axes[k]))
        k_card = comps["plate_cardan"].stiffness(ComponentState(tilt=[tilt]))[0]
        k_v = 1.0 / (1.0 / comps["tripod_strut"].k + 1.0 / comps["carriage_ball_joint"].k + 1.0 / k_card)
        mbs.AddObject(ObjectConnectorSpringDamper(markerNumbers=[m_node, marker("plate", p_k, False)], stiffness=k_v,
                                                  damping=0.0, referenceLength=float(np.linalg.norm(q_k - p_k))))
    def rotation(link: str) -> np.ndarray:
        return np.eye(3) if link == "frame" else R[L[link]]

    def spring6(a: str, b: str, point: np.ndarray, k6: np.ndarray) -> None:
        """6×6 spring in the axes of link a; marker 1 turned onto marker 0 so that the spring is relaxed in the
        configuration (Exudyn measures the relative rotation of the two marker frames)."""
        mbs.AddObject(ObjectConnectorRigidBodySpringDamper(
            markerNumbers=[marker(a, point, True), marker(b, point, True, rotation(b).T @ rotation(a))],
            stiffness=k6, damping=np.zeros((6, 6))))

    # central bearing (point_on_axis plate/frame at the frame's origin): plate axes; anti-twist: frame axes
    spring6("plate", "frame", np.zeros(3), comps["central_bearing"].matrix)
    spring6("frame", "plate", np.zeros(3), comps["central_twist"].matrix)
    for joint, a, b, bearing, motor, axis in (("V1", "plate", "fork", "wrist_bearing_1", "wrist_motor_1", 2),
                                              ("V2", "fork", "tool", "wrist_bearing_2", "wrist_motor_2", 3)):
        k6 = comps[bearing].matrix.copy()
        k6[3 + axis % 3, 3 + axis % 3] += comps[motor].k  # V1 about the plate's z, V2 about the fork's x
        spring6(a, b, t[L[b]] + R[L[b]] @ jp[joint], k6)
    o_tool, _, cog_tool = bodies["tool"]
    tcp_local = list(MECH.output.point - cog_tool)
    m_tf = mbs.AddMarker(MarkerBodyPosition(bodyNumber=o_tool, localPosition=tcp_local))
    m_tm = mbs.AddMarker(MarkerBodyRigid(bodyNumber=o_tool, localPosition=tcp_local))
    loads = (mbs.AddLoad(LoadForceVector(markerNumber=m_tf, loadVector=[0.0] * 3)),
             mbs.AddLoad(LoadTorqueVector(markerNumber=m_tm, loadVector=[0.0] * 3)))
    mbs.Assemble()
    return mbs, o_tool, tcp_local, loads


@pytest.fixture(scope="module")
def solution():
    sol = inverse(MECH, POSES)
    assert sol.converged.all()
    return sol


def test_hybrid_stiffness_and_frequencies_equal_the_exudyn_model(solution):
    res = evaluate_mechanism(MECH, solution, n_modes=6)
    assert res.ok.all()
    for i in range(len(POSES)):
        mbs, o_tool, tcp_local, loads = exudyn_hybrid(solution.q[i])
        f_ref = exudyn_frequencies(mbs)
        F = 50.0
        c_ref = (4.0 * _central(mbs, o_tool, tcp_local, loads, F) - _central(mbs, o_tool, tcp_local, loads, 2 * F)) / 3
        assert_blocks_close(res.compliance[i], c_ref, RTOL)
        np.testing.assert_allclose(res.frequencies_hz[i], f_ref[:6], rtol=RTOL)
