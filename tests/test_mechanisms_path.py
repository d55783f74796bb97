"""Claim 9 path API (issue 27, item 5): velocities, accelerations and jerk by implicit differentiation (Taylor-mode
residual), against sympy's closed form on the slider-crank and against differences of a tightly solved path."""

from __future__ import annotations

import numpy as np
import pytest

import pkmstiff.mechanisms as mm
from pkmstiff.mechanisms.constraints import fk_system
from pkmstiff.mechanisms.path import path_derivatives, taylor_residual


def _poly(c, t):
    """s, ṡ, s̈, s⃛ of the cubic-plus-quartic s(t) = c0 + c1 t + c2 t² + c3 t³ + c4 t⁴ (per drive column)."""
    c = np.asarray(c, dtype=float)
    s = c[0] + c[1] * t + c[2] * t**2 + c[3] * t**3 + c[4] * t**4
    v = c[1] + 2 * c[2] * t + 3 * c[3] * t**2 + 4 * c[4] * t**3
    a = 2 * c[2] + 6 * c[3] * t + 12 * c[4] * t**2
    j = 6 * c[3] + 24 * c[4] * t
    return s, v, a, j


def test_slider_crank_path_derivatives_equal_sympy_closed_form():
    sp = pytest.importorskip("sympy")
    mech = mm.load_mechanism("slider_crank")
    t, sig = sp.symbols("t sigma")
    coef = (0.004, 0.02, -0.05, 0.03, 0.01)  # s(t) [m]
    # crank angle φ1(s) (link 1 about A): d·Rot(φ)b = (r² + |d|² − l²)/2, d = C(s) − A, b = B0 − A (eq. 10–12)
    A, B0, C0 = (sp.Matrix([sp.Rational(x, 1000), sp.Rational(y, 1000)]) for x, y in ((40, 20), (70, 70), (115, 55)))
    b, d = B0 - A, C0 + sp.Matrix([sig, 0]) - A
    r2, l2 = b.dot(b), (B0 - C0).dot(B0 - C0)
    K = (r2 + d.dot(d) - l2) / 2
    for sign in (1, -1):  # the assembly mode connected to home has φ1(s = 0) = 0
        phi = sp.atan2(d[1], d[0]) - sp.atan2(b[1], b[0]) + sign * sp.acos(K / sp.sqrt(d.dot(d) * r2))
        if abs(float(phi.subs(sig, 0))) < 1e-12:
            break
    assert abs(float(phi.subs(sig, 0))) < 1e-12
    phi = phi.subs(sig, sum(sp.Rational(str(c)) * t**i for i, c in enumerate(coef)))
    t0 = 0.3
    ref = [float(sp.diff(phi, t, k).subs(t, t0).evalf(30)) for k in range(4)]
    sv = _poly(np.array(coef)[:, None], t0)
    pd = path_derivatives(mech, *[x[None] for x in sv], start=None)
    got = pd.q[:, 0, 1, 2]  # link 1's angle φ and its derivatives
    # positions to the solver tolerance; derivatives by exact series arithmetic: rounding only (|φ^(k)| ≤ O(10))
    assert np.abs(got - ref).max() < 1e-8 * max(1.0, np.abs(ref).max())
    # the slider (output point x) follows the drive exactly: ẋ = ṡ, ẍ = s̈, x⃛ = s⃛
    assert np.abs(pd.point[1:, 0, 0] - np.array(sv[1:])[:, 0]).max() < 1e-12


def test_taylor_residual_vanishes_to_third_order_on_the_hybrid():
    mech = mm.load_mechanism("hybrid_tripod_wrist")
    rng = np.random.default_rng(1)
    d = np.column_stack([rng.uniform(-0.1, 0.1, (5, 3)), rng.uniform(-1, 1, 5), np.radians(rng.uniform(20, 60, 5))])
    sv = [d] + [rng.normal(size=(5, 5)) for _ in range(3)]
    pd = path_derivatives(mech, *sv)
    system = fk_system(mech)
    S = np.stack(sv) / np.array([1.0, 1.0, 2.0, 6.0])[:, None, None]
    Q = pd.q / np.array([1.0, 1.0, 2.0, 6.0])[:, None, None, None]
    F = taylor_residual(system, Q, S)
    # coefficient 0 is the evaluated residual; coefficients 1–3 vanish because q_k solve F_q q_k = −G_k
    assert np.abs(F[0] - system.evaluate(pd.solution.q, d, jac=False)[0]).max() < 1e-15
    assert np.abs(F).max() < 1e-12


def test_hybrid_path_derivatives_equal_differences_of_a_tightly_solved_path():
    mech = mm.load_mechanism("hybrid_tripod_wrist")
    c = np.array([[0.02, -0.01, 0.03, 0.4, 0.6], [0.05, 0.02, -0.04, 0.8, 0.3], [-0.03, 0.04, 0.02, -0.5, 0.2],
                  [0.01, -0.02, 0.01, 0.3, -0.1], [0.0, 0.01, -0.01, 0.2, 0.05]])
    t0, h = 0.4, 1e-3
    ts = t0 + h * np.array([-2, -1, 0, 1, 2])
    sv = _poly(c[:, None, :], ts[:, None])
    pd = path_derivatives(mech, *sv, start=mm.forward(mech, sv[0][2:3], steps=8).q)
    assert pd.solution.converged.all()
    # fourth-order central differences of the next lower derivative (exact to rounding itself):
    # f'(t0) ≈ (f(−2h) − 8f(−h) + 8f(h) − f(2h))/(12h): truncation h⁴ f⁽⁵⁾/30 ≈ 1e-13, rounding 1e-13/h = 1e-10
    for k in range(1, 4):
        f = pd.q[k - 1].reshape(5, -1)
        fd = (f[0] - 8 * f[1] + 8 * f[3] - f[4]) / (12 * h)
        assert np.abs(fd - pd.q[k, 2].ravel()).max() < 1e-8 * max(1.0, np.abs(pd.q[k, 2]).max()), k
    # the output point's and the Cardan pose's derivatives likewise (coefficient 0 = the solved pose)
    assert np.abs(pd.pose[0] - pd.solution.poses).max() < 1e-13
    for ser in (pd.point, pd.pose):
        for k in range(1, 4):
            f = ser[k - 1]
            fd = (f[0] - 8 * f[1] + 8 * f[3] - f[4]) / (12 * h)
            assert np.abs(fd - ser[k, 2]).max() < 1e-8 * max(1.0, np.abs(ser[k, 2]).max()), k
    # ω = E(a, b)·(ȧ, ḃ, ċ) (pkmstiff.kinematics.rotation.cardan_rate_matrix) ties ω to the Cardan rates
    from pkmstiff.kinematics.rotation import cardan_rate_matrix

    E = cardan_rate_matrix(pd.pose[0, :, 3], pd.pose[0, :, 4])
    assert np.abs(np.einsum("nab,nb->na", E, pd.pose[1, :, 3:]) - pd.omega[0]).max() < 1e-12


def test_cli_path_over_a_drive_file(tmp_path, capsys):
    import csv

    from pkmstiff.cli import main

    mech = mm.load_mechanism("slider_crank")
    f = tmp_path / "d.csv"
    # one sample with its rates given: the CSV's pose derivatives equal path_derivatives' (mm, mm/s^k)
    f.write_text("t_s,s_mm,s_mm_per_s,s_mm_per_s2,s_mm_per_s3\n0.3,10,20,-30,6\n")
    out = tmp_path / "o.csv"
    assert main(["mechanism", "path", "slider_crank", "--drives-file", str(f), "--out", str(out)]) == 0
    assert "1 samples" in capsys.readouterr().out
    rows = list(csv.DictReader(out.open()))
    pd = path_derivatives(mech, [[0.01]], [[0.02]], [[-0.03]], [[0.006]])
    for k, suf in enumerate(("", "_per_s", "_per_s2", "_per_s3")):
        assert abs(float(rows[0][f"y_mm{suf}"]) - pd.pose[k, 0, 1] * 1e3) < 1e-6 * max(1, abs(pd.pose[k, 0, 1] * 1e3))
        assert abs(float(rows[0][f"phi_deg{suf}"]) - np.degrees(pd.pose[k, 0, 2])) < 1e-6 * max(
            1, abs(np.degrees(pd.pose[k, 0, 2])))
    # an existing --out needs --force; bad files give one line naming file, line and column
    def fails(argv, text):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert text in err and err.count("\n") == 1, err

    fails(["mechanism", "path", "slider_crank", "--drives-file", str(f), "--out", str(out)], "exists")
    f.write_text("t_s,s_mm\n0,1\n0.1,x\n")
    fails(["mechanism", "path", "slider_crank", "--drives-file", str(f)],
          "line 3, column s_mm: expected a number, found 'x'")
    f.write_text("t_s,q_mm\n0,1\n")
    fails(["mechanism", "path", "slider_crank", "--drives-file", str(f)], "missing s_mm")
    # samples without rates: a quintic spline through them (a quadratic path is reproduced exactly)
    t = np.linspace(0, 0.5, 8)
    f.write_text("t_s,s_mm\n" + "".join(f"{float(a)!r},{float(1e3 * (0.01 * a + 0.04 * a * a))!r}\n" for a in t))
    assert main(["mechanism", "path", "slider_crank", "--drives-file", str(f), "--out", str(out), "--force"]) == 0
    rows = list(csv.DictReader(out.open()))
    assert abs(float(rows[3]["x_mm_per_s2"]) - 80.0) < 1e-6 and abs(float(rows[3]["x_mm_per_s3"])) < 1e-5


@pytest.mark.parametrize("q1_deg", [90.0, 90.0 + 1e-5, -90.0, 60.0])
def test_link_rates_at_phi_y_90_degrees_equal_the_closed_form(tmp_path, q1_deg):
    # the arm turns about y (its Euler angle φy = q1: the parametrisation singularity at ±90°), the hand about the
    # arm's x axis: ω_arm = q̇1 e_y, ω_hand = q̇1 e_y + q̇2 u with u = Ry(q1) e_x, and the hand point w = Ry Rx p
    # has ẇ = ω×w, ẅ = ω̇×w + ω×ẇ, w⃛ = ω̈×w + 2ω̇×ẇ + ω×ẅ; the series run in rotation-vector coordinates
    from tests.test_mechanisms_solver import ARM

    p = tmp_path / "arm.toml"
    p.write_text(ARM)
    mech = mm.load_mechanism(p)
    d = np.radians([[q1_deg, 30.0]])
    sd, sdd, sddd = np.array([[0.7, -0.4]]), np.array([[0.3, 0.9]]), np.array([[-1.1, 0.5]])
    pd = path_derivatives(mech, d, sd, sdd, sddd)
    assert pd.solution.converged.all()
    ey = np.array([0.0, 1.0, 0.0])
    q1 = d[0, 0]
    u = np.array([np.cos(q1), 0.0, -np.sin(q1)])
    wa = [sd[0, 0] * ey, sdd[0, 0] * ey, sddd[0, 0] * ey]
    du = np.cross(wa[0], u)
    ddu = np.cross(wa[1], u) + np.cross(wa[0], du)
    wh = [wa[0] + sd[0, 1] * u, wa[1] + sdd[0, 1] * u + sd[0, 1] * du,
          wa[2] + sddd[0, 1] * u + 2 * sdd[0, 1] * du + sd[0, 1] * ddu]
    # rounding only: exact series arithmetic on O(1) quantities (measured ≤ 1e-15)
    assert np.abs(pd.link_omega[:, 0, 1] - np.array(wa)).max() < 1e-12
    assert np.abs(pd.link_omega[:, 0, 2] - np.array(wh)).max() < 1e-12
    w = pd.point[0, 0]
    wd = np.cross(wh[0], w)
    wdd = np.cross(wh[1], w) + np.cross(wh[0], wd)
    wddd = np.cross(wh[2], w) + 2 * np.cross(wh[1], wd) + np.cross(wh[0], wdd)
    assert np.abs(pd.point[1:, 0] - np.array([wd, wdd, wddd])).max() < 1e-12
