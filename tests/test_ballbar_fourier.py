"""Fourier semantics of the ball-bar evaluation (Szatmári eq. 4.9/4.10, Fig. 4.27) and the region-B rule (Fig. 4.29)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pkmstiff.calibration.ballbar import (choose_harmonics, evaluate_circular_test, evaluate_run, fourier_harmonics,
                                          reconstruct)
from pkmstiff.errors import BallbarError
from tests.ballbar_synth import QC10_NOISE, QC10_RESOLUTION, circle_run

R = 0.15  # 150 mm bar (Szatmári Tab. 4.3 nominal lengths)


def _harm(run):
    return fourier_harmonics(run.theta, run.reading)


def test_centre_offset_gives_A1_equal_to_offset():
    e = np.array([40e-6, -25e-6])
    run = circle_run(R, 1024, offset=tuple(e), start=0.3)
    h = _harm(run)
    emag = float(np.linalg.norm(e))
    # |e + R u| − R = e·u + (e² − (e·u)²)/(2R) + O(e³/R²): the first-order term is A1 = |e|, φ1 = direction of e;
    # the second-order part only feeds A0 and A2 (each e²/(4R) ≈ 1.6e-9 m), so A1 is exact to O(e³/R²) ~ 1e-13 m
    assert h.amplitude[1] == pytest.approx(emag, abs=1e-12)
    assert math.isclose(h.phase[1], math.atan2(e[1], e[0]) % (2 * math.pi), abs_tol=1e-9)
    assert h.amplitude[0] == pytest.approx(emag**2 / (4 * R), rel=1e-3)  # second-order term, to O(e/R)
    assert h.amplitude[2] == pytest.approx(emag**2 / (4 * R), rel=1e-3)
    assert np.all(h.amplitude[3:] < 1e-12)  # O(e³/R²) ≈ 1e-13 m


def test_radius_error_gives_A0_only():
    run = circle_run(R, 1000, radius_error=-7.5e-6)
    h = _harm(run)
    # a pure radius error is a constant deviation: A0 = ΔR exactly, other harmonics at rounding level of R·eps
    assert h.amplitude[0] == pytest.approx(-7.5e-6, abs=1e-15)
    assert np.max(h.amplitude[1:]) < 1e-15


def test_ellipse_gives_A2_with_phase_of_major_axis():
    delta = 6e-6
    run = circle_run(R, 2048, ellipse=delta)
    h = _harm(run)
    # x stretched by δ, y shrunk by δ: |A| = R + δ cos 2θ + O(δ²/R) (δ²/R = 2.4e-10 m)
    assert h.amplitude[2] == pytest.approx(delta, abs=3 * delta**2 / R)
    assert math.isclose(math.cos(h.phase[2]), 1.0, abs_tol=1e-9)  # major axis along e1
    assert h.amplitude[1] < 1e-15 and h.amplitude[3] < 1e-15


@pytest.mark.parametrize("k", [3, 4, 7])
def test_lobes_give_their_harmonic(k):
    run = circle_run(R, 1500, lobes={k: (2e-6, 0.7)}, start=1.1)
    h = _harm(run)
    # a pure radial lobe c cos(kθ − ψ) is exactly harmonic k (no geometry nonlinearity: the path is radial)
    assert h.amplitude[k] == pytest.approx(2e-6, rel=1e-9)
    assert math.isclose(h.phase[k], 0.7, abs_tol=1e-9)
    others = np.delete(h.amplitude, [0, k])
    assert np.max(others) < 1e-15


def _mixed(noise, seed=3, n=4096, jitter=0.0):
    return circle_run(R, n, offset=(15e-6, 9e-6), radius_error=3e-6, ellipse=5e-6,
                      lobes={3: (2e-6, 0.5), 4: (1.2e-6, 2.0)}, noise=noise,
                      resolution=QC10_RESOLUTION if noise else 0.0, seed=seed, jitter=jitter)


@pytest.mark.parametrize("seed,jitter", [(1, 0.0), (2, 0.0), (3, 0.3), (4, 0.45)])
def test_qc10_noise_auto_harmonics_reconstruct_within_5_percent(seed, jitter):
    run = _mixed(QC10_NOISE, seed=seed, jitter=jitter)
    h = _harm(run)
    choice = choose_harmonics(h)
    # the signal has harmonics 0..4 of ≥ 1.2 µm; the threshold is ≈ 0.06 µm, second-order terms ≈ 1e-3 µm
    assert choice.n == 4
    assert choice.noise_sd == pytest.approx(QC10_NOISE, rel=0.15)  # median-based estimate from ~1000 harmonics
    rec = reconstruct(h, run.theta, choice.n)
    pv = np.ptp(run.true_deviation)
    err = np.max(np.abs(rec - run.true_deviation))
    assert err <= 0.05 * pv  # the acceptance: within 5 % of the true deviation
    # and in fact near the statistical limit: 9 fitted coefficients of σ·√(2/N) each (jitter adds a little)
    assert err < 0.3e-6


def test_region_b_rule_beats_regions_a_and_c():
    run = _mixed(QC10_NOISE, seed=7)
    h = _harm(run)
    n = choose_harmonics(h).n

    def rms(m):
        return float(np.sqrt(np.mean((reconstruct(h, run.theta, m) - run.true_deviation) ** 2)))

    # region A (too few) leaves shape error, region C (too many) keeps noise: the chosen n is best of the three
    assert rms(n) < rms(n - 1)
    assert rms(n) < rms(h.n_max // 2)


def test_no_signal_chooses_zero_harmonics_or_few_false_alarms():
    false_alarms = 0
    for seed in range(20):
        run = circle_run(R, 2048, noise=QC10_NOISE, seed=seed)
        false_alarms += choose_harmonics(_harm(run), alpha=0.01).n > 0
    # α = 1 % per run: 20 runs give ≥ 3 false alarms with probability < 0.1 %
    assert false_alarms <= 2


def test_min_relative_applies_szatmari_5_percent_rule():
    run = _mixed(0.0)
    h = _harm(run)
    # without noise the threshold is tiny; A1 = 17.5 µm, A3 = 2 µm (11.4 %), A4 = 1.2 µm (6.9 %)
    assert choose_harmonics(h, min_relative=0.05).n == 4
    assert choose_harmonics(h, min_relative=0.10).n == 3
    assert choose_harmonics(h, min_relative=0.12).n == 2


def test_nonuniform_samples_are_interpolated():
    run = _mixed(0.0, n=3000, jitter=0.45)
    h = _harm(run)
    assert h.resampled
    # linear interpolation of a smooth 4-harmonic signal on a 0.12° grid: error ~ (kΔ)²/8 · A ≈ 1e-5 relative
    assert h.amplitude[3] == pytest.approx(2e-6, rel=1e-3)
    assert h.amplitude[4] == pytest.approx(1.2e-6, rel=1e-3)


def test_incomplete_revolution_is_an_error():
    run = circle_run(R, 1000)
    keep = np.mod(run.theta, 2 * np.pi) < math.radians(300)
    with pytest.raises(BallbarError, match="full revolution"):
        fourier_harmonics(run.theta[keep], run.reading[keep])


def test_too_few_samples_for_auto():
    th = np.linspace(0, 2 * np.pi, 32, endpoint=False)
    h = fourier_harmonics(th, np.cos(th))
    with pytest.raises(BallbarError, match="at least 64 samples"):
        choose_harmonics(h)
    with pytest.raises(BallbarError, match="0..15"):
        evaluate_run(th, np.cos(th), R, harmonics=16)


def test_centre_offset_fit_matches_A1_first_order():
    e = (20e-6, 35e-6)
    run = circle_run(R, 2000, offset=e, noise=QC10_NOISE, seed=5)
    P = run.positions
    ev = evaluate_circular_test(P, run.reading, (0, 0, 0), R)
    r = ev.runs["ccw"]
    # LSQ centre and the first harmonic agree to O(noise/√N) ≈ 0.02 µm and O(e²/R) ≈ 1e-5 µm
    assert np.allclose(r.centre_offset, e, atol=0.05e-6)
    assert r.harmonics.amplitude[1] == pytest.approx(np.hypot(*e), abs=0.05e-6)


amp = st.floats(0.0, 5e-6)
phase = st.floats(0.0, 2 * math.pi)


@settings(max_examples=60, deadline=None)
@given(amps=st.lists(amp, min_size=5, max_size=5), phases=st.lists(phase, min_size=5, max_size=5),
       n=st.integers(64, 600), start=phase, delta=st.floats(-10.0, 10.0), direction=st.sampled_from([1, -1]))
def test_rotation_of_sample_phase_shifts_phases_only(amps, phases, n, start, delta, direction):
    th = start + direction * np.arange(n) * (2 * np.pi / n)
    d = amps[0] + sum(amps[k] * np.cos(k * th - phases[k]) for k in range(1, 5))
    h0 = fourier_harmonics(th, d)
    h1 = fourier_harmonics(th + delta, d)  # the same readings attributed to angles rotated by δ
    scale = max(max(amps), 1e-9)
    # amplitudes invariant; exact up to FFT rounding (~1e-15 · N-independent scale)
    assert np.allclose(h1.amplitude, h0.amplitude, atol=1e-12 * scale)
    # band-limited signal on a uniform grid: the harmonics are recovered exactly
    assert np.allclose(h0.amplitude[1:5], amps[1:], atol=1e-12 * scale)
    # phases shift by kδ (compare on the unit circle; only where the amplitude is well above rounding)
    k = np.arange(h0.n_max + 1)
    big = h0.amplitude > 1e-6 * scale
    big[0] = False
    z0 = np.exp(1j * (h0.phase + k * delta))
    z1 = np.exp(1j * h1.phase)
    assert np.allclose(z1[big], z0[big], atol=1e-8)


def _revolutions(k: int, n: int = 2000, **kw):
    """The same circle travelled ``k`` times (new noise each time), angles continuing (time order); the readings
    are the radial deviations (bar length = radius)."""
    runs = [circle_run(n=n, seed=s, **kw) for s in range(k)]
    theta = np.concatenate([r.theta + 2 * np.pi * i for i, r in enumerate(runs)])
    return theta, np.concatenate([r.reading for r in runs])


def test_several_revolutions_are_analysed_per_revolution():
    """Issue 22, bad input 2: a circle repeated 20 times keeps the harmonics of ONE revolution (n_max = n/2 - 1 of
    the per-revolution sampling, not of all samples) and finds the same lobe as one revolution: the averaged
    revolution has the same signal and σ/√20 noise, so the A3 amplitude agrees within 5 noise scales."""
    lobe = {3: (2e-6, 0.3)}
    th1, d1 = _revolutions(1, noise=QC10_NOISE, lobes=lobe)
    th20, d20 = _revolutions(20, noise=QC10_NOISE, lobes=lobe)
    h1, h20 = fourier_harmonics(th1, d1), fourier_harmonics(th20, d20)
    assert h20.n_max == h1.n_max == 999
    assert h20.n_samples == 40000  # the noise scale of the auto rule uses every sample
    scale = QC10_NOISE * math.sqrt(2 / 2000)  # Rayleigh scale of one revolution's harmonics
    assert h20.amplitude[3] == pytest.approx(2e-6, abs=5 * scale / math.sqrt(20))
    assert h1.amplitude[3] == pytest.approx(2e-6, abs=5 * scale)
    assert choose_harmonics(h20).n == 3


def test_revolution_noise_estimate_uses_all_samples():
    """The noise σ per sample estimated from the averaged revolution matches the simulated σ (within 10 %: the
    robust median estimate over ~250 band harmonics has a relative spread of a few per cent)."""
    th, d = _revolutions(20, noise=QC10_NOISE)
    assert choose_harmonics(fourier_harmonics(th, d)).noise_sd == pytest.approx(QC10_NOISE, rel=0.1)


def test_reconstruct_in_blocks_equals_the_direct_sum():
    """reconstruct() evaluates (samples × harmonics) in blocks: the same sum as the one-matrix formula (1e-12 of
    the amplitude scale: only the summation order of the matrix products differs)."""
    from pkmstiff.calibration import ballbar

    th, d = _revolutions(1, n=5000, noise=QC10_NOISE, lobes={2: (1e-6, 0.1), 7: (3e-7, 2.0)})
    h = fourier_harmonics(th, d)
    n = 600
    k = np.arange(1, n + 1)
    direct = h.amplitude[0] + np.cos(th[:, None] * k - h.phase[1:n + 1]) @ h.amplitude[1:n + 1]
    assert ballbar.RECONSTRUCT_CHUNK // n < th.size  # several blocks
    np.testing.assert_allclose(ballbar.reconstruct(h, th, n), direct, rtol=0, atol=1e-12 * np.abs(direct).max())
