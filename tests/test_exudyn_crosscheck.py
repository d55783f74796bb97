"""Cross-check of the Hexaglide 30-DOF structure model against an independent Exudyn model (spec models.md §4, §5).

The Exudyn model is built here from the machine data only: rigid bodies (platform with mass and inertia, massless
spindle), point masses (drives), ground, and Exudyn connectors for the bindings — Cartesian springs W (drive–
ground), distance springs V (drive–platform, stiffness = series of the joint and strut stiffnesses evaluated
here at tilt angles computed here), a 6×6 rigid-body spring U (platform–spindle).  Exudyn linearises the system
(``ComputeLinearizedSystem``); the massless spindle coordinates are condensed and the generalized eigenproblem is
solved with scipy.  The TCP compliance comes from Exudyn's nonlinear static solver with loads ±F and ±2F (central
differences with Richardson extrapolation, so the geometric nonlinearity cancels to fourth order).  Agreement is
required to 1e-6 relative at three poses.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

exu = pytest.importorskip("exudyn", reason="exudyn is a test-only dependency (extra 'test'); not installed here")
from exudyn.itemInterface import (  # noqa: E402
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
from exudyn.rigidBodyUtilities import RotationMatrix2RotXYZ  # noqa: E402

from components.protocol import ComponentState  # noqa: E402
from pkmstiff.analysis import evaluate_structure, tcp_compliance  # noqa: E402
from pkmstiff.kinematics import inverse_kinematics  # noqa: E402
from pkmstiff.machine.loader import load_machine  # noqa: E402
from pkmstiff.machine.roles import machine_components  # noqa: E402
from pkmstiff.multibody import natural_frequencies  # noqa: E402
from pkmstiff.structure import build_structure  # noqa: E402

MACHINE = load_machine("hexaglide")
POSES = np.array([[0.0, 0.0, -1.0, 0.0, 0.0, 0.0],
                  [0.05, 0.25, -0.95, 0.03, -0.02, 0.05],
                  [-0.12, 0.4, -0.85, -0.05, 0.06, -0.1]])
TOOL = 0.15  # m, tool along -z' (machine file): exercises the rotational compliance
RTOL = 1e-6  # issue requirement


def inertia6(inertia: np.ndarray) -> list[float]:
    """Exudyn's [Jxx, Jyy, Jzz, Jyz, Jxz, Jxy]."""
    return [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[1, 2], inertia[0, 2], inertia[0, 1]]


def exudyn_hexaglide(pose: np.ndarray, machine=MACHINE):
    """Independent Exudyn model at one pose; returns (mbs, spindle object, TCP in spindle coordinates, loads)."""
    mc = machine_components(machine)
    ch = machine.chains
    ik = inverse_kinematics(machine, pose[None])
    R, w = ik.R[0], pose[:3]
    q, p = ik.q[0], ik.p[0]
    u = (p - q) / np.linalg.norm(p - q, axis=1)[:, None]
    strut_mass = np.array([s.mass for s in mc.strut])
    # platform body: M_P (117.24 kg at O', inertia in PKS axes) plus the machine file's platform share of every strut
    # at its platform joint; the drive share goes to the drive masses (strut_mass_shares: none on the Hexaglide,
    # whose drive and platform masses already hold the struts; half at either joint with strut_mass_split)
    share_drive, share_platform = machine.strut_mass_shares
    at_drive, at_platform = share_drive * strut_mass, share_platform * strut_mass
    m_pl = mc.platform.mass + at_platform.sum()
    cog_pks = (mc.platform.mass * mc.platform.cog + (at_platform[:, None] * ch.platform_joint).sum(axis=0)) / m_pl
    i_pl = mc.platform.inertia.copy()
    for m_i, r in [(mc.platform.mass, mc.platform.cog)] + list(zip(at_platform, ch.platform_joint)):
        d = r - cog_pks
        i_pl = i_pl + m_i * (d @ d * np.eye(3) - np.outer(d, d))
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ObjectGround())
    rot = list(RotationMatrix2RotXYZ(R))
    cog = w + R @ cog_pks
    n_pl = mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=list(cog) + rot))
    o_pl = mbs.AddObject(ObjectRigidBody(mass=m_pl, inertia=inertia6(i_pl), nodeNumber=n_pl))
    o_sp = mbs.AddObject(ObjectRigidBody(mass=0.0, inertia=[0.0] * 6,  # all of M_P on the platform: massless
                                         nodeNumber=mbs.AddNode(NodeRigidBodyRxyz(referenceCoordinates=list(w) + rot))))
    guide = mc.guide[0]
    tilt_d = np.arccos(np.clip(np.abs(np.einsum("cj,cj->c", ch.drive_axis, u)), 0.0, 1.0))
    tilt_p = np.arccos(np.clip(np.abs(np.einsum("cj,cj->c", ch.platform_axis @ R.T, u)), 0.0, 1.0))
    for i in range(6):
        assert abs(abs(ch.guide_direction[i, 0]) - 1.0) < 1e-12  # input check: guides along ±x, z' vertical
        k_w = [mc.drive[i].k_axial, guide.count * guide.k_horizontal, guide.count * guide.k_vertical]
        k_v = 1.0 / (1.0 / mc.drive_joint[i].stiffness(ComponentState(tilt=[tilt_d[i]]))[0]
                     + 1.0 / mc.strut[i].k
                     + 1.0 / mc.platform_joint[i].stiffness(ComponentState(tilt=[tilt_p[i]]))[0])
        o_dr = mbs.AddObject(ObjectMassPoint(mass=mc.drive[i].mass + at_drive[i],
                                             nodeNumber=mbs.AddNode(NodePoint(referenceCoordinates=list(q[i])))))
        m_dr = mbs.AddMarker(MarkerBodyPosition(bodyNumber=o_dr, localPosition=[0.0, 0.0, 0.0]))
        m_gr = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=list(q[i])))
        mbs.AddObject(ObjectConnectorCartesianSpringDamper(markerNumbers=[m_gr, m_dr], stiffness=k_w,
                                                           damping=[0.0] * 3))
        m_pj = mbs.AddMarker(MarkerBodyPosition(bodyNumber=o_pl, localPosition=list(R.T @ (p[i] - cog))))
        mbs.AddObject(ObjectConnectorSpringDamper(markerNumbers=[m_dr, m_pj], stiffness=k_v, damping=0.0,
                                                  referenceLength=float(np.linalg.norm(p[i] - q[i]))))
    # U at O' in platform axes (machines.md §1.4: K_P diagonal, rotational entries in N m/µrad)
    m_pu = mbs.AddMarker(MarkerBodyRigid(bodyNumber=o_pl, localPosition=list(R.T @ (w - cog))))
    m_su = mbs.AddMarker(MarkerBodyRigid(bodyNumber=o_sp, localPosition=[0.0, 0.0, 0.0]))
    k_u = np.diag([1603e6, 1567e6, 588e6, 4348e6, 5115e6, 2564e6])
    mbs.AddObject(ObjectConnectorRigidBodySpringDamper(markerNumbers=[m_pu, m_su], stiffness=k_u,
                                                       damping=np.zeros((6, 6))))
    tcp_local = [0.0, 0.0, -TOOL]
    m_tf = mbs.AddMarker(MarkerBodyPosition(bodyNumber=o_sp, localPosition=tcp_local))
    m_tm = mbs.AddMarker(MarkerBodyRigid(bodyNumber=o_sp, localPosition=tcp_local))
    loads = (mbs.AddLoad(LoadForceVector(markerNumber=m_tf, loadVector=[0.0] * 3)),
             mbs.AddLoad(LoadTorqueVector(markerNumber=m_tm, loadVector=[0.0] * 3)))
    mbs.Assemble()
    return mbs, o_sp, tcp_local, loads


def exudyn_frequencies(mbs) -> np.ndarray:
    M, K, _ = mbs.ComputeLinearizedSystem()
    massless = np.flatnonzero(np.diag(M) == 0.0)
    keep = np.setdiff1d(np.arange(M.shape[0]), massless)
    kc = K[np.ix_(keep, keep)] - K[np.ix_(keep, massless)] @ np.linalg.solve(K[np.ix_(massless, massless)],
                                                                              K[np.ix_(massless, keep)])
    lam = scipy.linalg.eigh(0.5 * (kc + kc.T), M[np.ix_(keep, keep)], eigvals_only=True)
    return np.sqrt(lam) / (2 * np.pi)


def exudyn_tcp_compliance(mbs, o_sp, tcp_local, loads, F: float = 100.0) -> np.ndarray:
    """6×6 TCP compliance from static solves with ±F and ±2F (Richardson: (4 C(F) − C(2F))/3 removes the O(F²)
    error of the central difference); F in N (N m for moments)."""
    return (4.0 * _central(mbs, o_sp, tcp_local, loads, F) - _central(mbs, o_sp, tcp_local, loads, 2 * F)) / 3.0


def _central(mbs, o_sp, tcp_local, loads, F: float) -> np.ndarray:
    ss = exu.SimulationSettings()
    ss.staticSolver.newton.relativeTolerance = 1e-8  # force round-off ~1e-7 N limits the residual (k ~ 1e9 N/m)
    ss.staticSolver.newton.absoluteTolerance = 1e-6
    ss.staticSolver.verboseMode = 0
    ss.solution.file.write = False
    ss.show.statistics = False
    ss.show.computationTime = False
    ot = exu.OutputVariableType
    cfg_ref, cfg_cur = exu.ConfigurationType.Reference, exu.ConfigurationType.Current

    def tcp_state(cfg):
        x = np.array(mbs.GetObjectOutputBody(o_sp, ot.Position, localPosition=tcp_local, configuration=cfg))
        a = np.array(mbs.GetObjectOutputBody(o_sp, ot.RotationMatrix, localPosition=tcp_local,
                                             configuration=cfg)).reshape(3, 3)
        return x, a

    x0, a0 = tcp_state(cfg_ref)
    C = np.zeros((6, 6))
    for j in range(6):
        resp = []
        for sign in (1.0, -1.0):
            load = np.zeros(6)
            load[j] = sign * F
            mbs.SetLoadParameter(loads[0], "loadVector", list(load[:3]))
            mbs.SetLoadParameter(loads[1], "loadVector", list(load[3:]))
            mbs.SolveStatic(ss)
            x, a = tcp_state(cfg_cur)
            dr = a @ a0.T  # small rotation in global axes: dR ≈ I + [θ]×
            theta = 0.5 * np.array([dr[2, 1] - dr[1, 2], dr[0, 2] - dr[2, 0], dr[1, 0] - dr[0, 1]])
            resp.append(np.concatenate([x - x0, theta]))
        C[:, j] = (resp[0] - resp[1]) / (2 * F)
    return C


def assert_blocks_close(actual: np.ndarray, expected: np.ndarray, rtol: float) -> None:
    """Compare the translational, rotational and coupling blocks each relative to its own magnitude (units differ)."""
    t, r = slice(0, 3), slice(3, 6)
    scale_t, scale_r = np.abs(expected[t, t]).max(), np.abs(expected[r, r]).max()
    for a, b, scale in ((t, t, scale_t), (r, r, scale_r), (t, r, np.sqrt(scale_t * scale_r)),
                        (r, t, np.sqrt(scale_t * scale_r))):
        assert np.abs(actual[a, b] - expected[a, b]).max() <= rtol * scale, (a, b)
    np.testing.assert_allclose(np.diag(actual), np.diag(expected), rtol=rtol)


@pytest.fixture(scope="module")
def reference():
    out = []
    for pose in POSES:
        mbs, o_sp, tcp_local, loads = exudyn_hexaglide(pose)
        out.append((exudyn_frequencies(mbs), exudyn_tcp_compliance(mbs, o_sp, tcp_local, loads)))
    return out


def test_eigenfrequencies_equal_the_exudyn_model(reference):
    st = build_structure(MACHINE, POSES)
    f_all = natural_frequencies(st.model, 24)  # all 24 dynamic DOFs (6 massless spindle DOFs condensed)
    batch = evaluate_structure(MACHINE, POSES, tool_length=TOOL, n_modes=6)
    for i, (f_ref, _) in enumerate(reference):
        np.testing.assert_allclose(f_all[i], f_ref, rtol=RTOL)
        np.testing.assert_allclose(batch.frequencies_hz[i], f_ref[:6], rtol=RTOL)


def test_tcp_compliance_equals_the_exudyn_model(reference):
    st = build_structure(MACHINE, POSES)
    c = tcp_compliance(st, TOOL)
    batch = evaluate_structure(MACHINE, POSES, tool_length=TOOL, n_modes=0)
    for i, (_, c_ref) in enumerate(reference):
        assert_blocks_close(c[i], c_ref, RTOL)
        assert_blocks_close(batch.compliance[i], c_ref, RTOL)


def test_eigenfrequencies_with_the_strut_mass_split_equal_the_exudyn_model():
    """The half-and-half strut-mass lumping (option strut_mass_split) puts mass on the drives and the platform."""
    split = load_machine("hexaglide", options=["strut_mass_split"])
    assert split.strut_mass_shares == (0.5, 0.5)  # input check: the option this test is about
    mbs, *_ = exudyn_hexaglide(POSES[1], split)
    f_ref = exudyn_frequencies(mbs)
    f = natural_frequencies(build_structure(split, POSES[1:2]).model, 24)
    np.testing.assert_allclose(f[0], f_ref, rtol=RTOL)
