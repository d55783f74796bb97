"""Frequency response functions of the SDE model: analytic 1-DOF, modal superposition vs direct solve, peaks."""

from __future__ import annotations

import numpy as np
import pytest

import pkmstiff.multibody as sde
from pkmstiff.errors import InputError
from pkmstiff.multibody.linalg import rotation_about_axis


def oscillator(k: float, m: float, c: float) -> sde.SDEModel:
    """Point mass on a spring k (damper c) along x; y and z held 100x stiffer (separate, undamped modes)."""
    model = sde.SDEModel()
    model.add_point_mass("m", m, [0, 0, 0])
    model.add_sde("s", "m", sde.FRAME, [0, 0, 0], stiffness=np.diag([k, 100 * k, 100 * k]),
                  damping=np.diag([c, 0.0, 0.0]))
    return model


@pytest.mark.parametrize("method", ["modal", "direct"])
def test_one_dof_oscillator_analytic(method):
    """H(ω) = 1 / (k − mω² + i c ω); accelerance = −ω² H."""
    k, m, c = 4e6, 2.5, 150.0
    model = oscillator(k, m, c)
    f = np.linspace(0.0, 400.0, 801)
    w = 2 * np.pi * f
    x = sde.PointDirection("m", [1.0, 0, 0])
    h = sde.receptance(model, f, x, x, method=method)
    ref = 1.0 / (k - m * w**2 + 1j * c * w)
    np.testing.assert_allclose(h[0], ref, rtol=1e-10)  # modal: C diagonal in the modal basis -> exact
    np.testing.assert_allclose(sde.accelerance(model, f, x, x, method=method)[0], -(w**2) * ref, rtol=1e-10)


def test_peak_of_one_dof_oscillator():
    """|H| peaks at ω_n √(1 − 2ζ²) with height 1/(2ζ√(1−ζ²) k) (modal damping ratio ζ)."""
    k, m, zeta = 4e6, 2.5, 0.02
    model = oscillator(k, m, 0.0)
    fn = np.sqrt(k / m) / (2 * np.pi)
    f = np.linspace(100.0, 300.0, 2001)  # 0.1 Hz steps
    x = sde.PointDirection("m", [1.0, 0, 0])
    h = sde.receptance(model, f, x, x, zeta=zeta)
    pf, pm = sde.find_peaks(f, h, max_peaks=3)
    # parabolic refinement on log|H|: error far below the 0.1 Hz step for a peak of half-width ζ f_n = 4 Hz
    np.testing.assert_allclose(pf[0, 0], fn * np.sqrt(1 - 2 * zeta**2), atol=5e-3)
    np.testing.assert_allclose(pm[0, 0], 1 / (2 * zeta * np.sqrt(1 - zeta**2) * k), rtol=1e-4)
    assert np.all(np.isnan(pf[0, 1:]))  # only one resonance in the band


def damped_model(beta: float | None):
    """Rigid body + two point masses with stiffness-proportional SDE damping (C = β K when β is given)."""
    rng = np.random.default_rng(3)
    m = sde.SDEModel()
    m.add_rigid_body("B", 30.0, [0.0, 0.0, 1.0], [2.0, 3.0, 1.5], rotation=rotation_about_axis([1, 2, 3], 0.5))
    m.add_point_mass("A", 8.0, [0.5, 0.0, 1.2])
    m.add_point_mass("C", 0.0, [-0.5, 0.2, 1.0])  # massless: condensed, needs the static residual
    elements = [
        ("G", "B", sde.FRAME, [0.1, 0.2, 0.8], np.diag([4e7, 5e7, 9e7, 2e6, 3e6, 4e6])),
        ("W", "A", "B", [0.5, 0.0, 1.2], np.diag([2e7, 3e7, 1e7])),
        ("X", "A", sde.FRAME, [0.5, 0.0, 1.2], 1e7 * np.eye(3)),
        ("Y", "C", "B", [-0.5, 0.2, 1.0], np.diag([5e7, 2e7, 3e7])),
        ("Z", "C", sde.FRAME, [-0.5, 0.2, 1.0], 2e7 * np.eye(3)),
    ]
    for name, a, b, pt, kk in elements:
        m.add_sde(name, a, b, pt, stiffness=kk, damping=None if beta is None else beta * kk)
    return m, rng


def test_modal_superposition_equals_direct_for_proportional_damping():
    """C = β K (from the SDE damping): modal superposition equals (K − ω²M + iωC)⁻¹; excitation and response at
    different points of different bodies, incl. excitation on the massless one."""
    m, _ = damped_model(beta=2e-4)
    f = np.linspace(0.0, 500.0, 251)
    out = sde.PointDirection("B", [0.3, -0.4, 0.87], point=[0.2, 0.1, 0.7])
    for inp in (sde.PointDirection("A", [1.0, 0.5, 0.0]), sde.PointDirection("C", [0, 0, 1.0]),
                sde.PointDirection("B", [0, 1.0, 0], rotation=True)):
        hm = sde.receptance(m, f, out, inp, method="modal")
        hd = sde.receptance(m, f, out, inp, method="direct")
        # both exact: differences are round-off of solves near resonance (|H| up to ~1e-5 m/N)
        np.testing.assert_allclose(hm, hd, rtol=1e-8, atol=1e-12 * np.abs(hd).max())


def test_massless_residual_with_modal_damping():
    """Response and excitation on the massless body: only here the static residual K_ss⁻¹ of the condensed DOFs
    contributes (with modal damping ζ it is undamped in both methods, so they agree exactly)."""
    m, _ = damped_model(beta=None)
    f = np.linspace(0.0, 500.0, 251)
    c_dir = sde.PointDirection("C", [0.2, 1.0, 0.3])
    hm = sde.receptance(m, f, c_dir, c_dir, zeta=0.05, method="modal")
    hd = sde.receptance(m, f, c_dir, c_dir, zeta=0.05, method="direct")
    np.testing.assert_allclose(hm, hd, rtol=1e-8, atol=1e-12 * np.abs(hd).max())


def test_modal_damping_ratio_both_methods_and_reciprocity():
    """A modal damping ratio ζ gives the same FRF by superposition and by the direct solve with
    C = M Φ diag(2ζω) Φᵀ M; receptance is reciprocal, H_ij = H_ji."""
    m, _ = damped_model(beta=None)
    f = np.linspace(1.0, 500.0, 200)
    p1 = sde.PointDirection("B", [1.0, 0, 0], point=[0.0, 0.0, 1.4])
    p2 = sde.PointDirection("A", [0, 1.0, 1.0])
    hm = sde.receptance(m, f, p1, p2, zeta=0.03)
    hd = sde.receptance(m, f, p1, p2, zeta=0.03, method="direct")
    np.testing.assert_allclose(hm, hd, rtol=1e-8, atol=1e-12 * np.abs(hd).max())
    np.testing.assert_allclose(sde.receptance(m, f, p2, p1, zeta=0.03), hm, rtol=1e-10,
                               atol=1e-14 * np.abs(hm).max())


def test_static_limit_equals_compliance():
    """At ω = 0 the receptance equals the static compliance at the point."""
    m, _ = damped_model(beta=None)
    tcp = [0.2, 0.1, 0.7]
    comp = sde.point_compliance(m, "B", tcp)[0]
    h = sde.receptance(m, [0.0], sde.PointDirection("B", [0, 0, 1.0], tcp), sde.PointDirection("B", [0, 0, 1.0], tcp))
    np.testing.assert_allclose(h[0, 0].real, comp[2, 2], rtol=1e-11)


def test_bad_frf_input():
    m = oscillator(1e6, 1.0, 0.0)
    x = sde.PointDirection("m", [1.0, 0, 0])
    with pytest.raises(InputError, match="freq_hz"):
        sde.receptance(m, [-1.0], x, x)
    with pytest.raises(InputError, match="zeta"):
        sde.receptance(m, [1.0], x, x, zeta=[0.1, 0.2])
    with pytest.raises(InputError, match="moment"):
        sde.receptance(m, [1.0], x, sde.PointDirection("m", [1.0, 0, 0], rotation=True))
