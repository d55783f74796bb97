"""Ball-bar diagnostics (issue 26 item 8): a synthetic circle test with known axis errors injected at the axis level
(not through the diagnosis' own radial basis: the actual ball position is computed from the perturbed axes and the
reading is the exact distance to the fixed ball) is diagnosed with the injected values."""

from __future__ import annotations

import numpy as np
import pytest

from pkmstiff.calibration.ballbar import evaluate_circular_test
from pkmstiff.calibration.ballbar_diagnosis import SPIKE_WIDTH, diagnose

R = 0.15  # bar length [m]
FEED = 1.0 / 60.0  # 1000 mm/min
TRUE = {"scale_mismatch": 40e-6, "squareness": -30e-6, "servo_tau": 1.5e-3, "backlash_1": 6e-6,
        "backlash_2": -4e-6, "lateral_play_1": 3e-6, "lateral_play_2": -2e-6, "reversal_spike_1": 5e-6,
        "reversal_spike_2": 3e-6, "cyclic_1": 1.5e-6, "cyclic_2": 1.0e-6}
LEAD = 0.01  # screw lead [m]


def _axis_run(direction: int, n: int = 7200, noise: float = 0.0, seed: int = 0, offset=(20e-6, -15e-6)):
    """Actual ball positions from perturbed X, Y axes; returns commanded positions (N, 3) and readings (N,)."""
    rng = np.random.default_rng(seed)
    th = direction * 2 * np.pi * np.arange(n) / n
    x, y = R * np.cos(th), R * np.sin(th)
    omega = FEED / R
    # servo: X lags by tau/2, Y leads by tau/2 (tau = tau_x - tau_y): commanded angle at t - tau_x
    tx, ty = TRUE["servo_tau"] / 2, -TRUE["servo_tau"] / 2
    xa = R * np.cos(th - direction * omega * tx)
    ya = R * np.sin(th - direction * omega * ty)
    vx, vy = -direction * np.sin(th), direction * np.cos(th)  # signs of the axis velocities
    sx, sy = np.sign(vx), np.sign(vy)
    xa = xa * (1 + TRUE["scale_mismatch"] / 2) + TRUE["squareness"] * y
    ya = ya * (1 - TRUE["scale_mismatch"] / 2)
    xa = xa - TRUE["backlash_1"] / 2 * sx + TRUE["lateral_play_2"] / 2 * sy
    ya = ya - TRUE["backlash_2"] / 2 * sy + TRUE["lateral_play_1"] / 2 * sx

    def since(reversals):  # angle travelled since the last reversal of the axis
        return np.minimum(*(np.mod(direction * (th - r), 2 * np.pi) for r in reversals))

    xa = xa + TRUE["reversal_spike_1"] * np.sign(x) * np.exp(-since((0.0, np.pi)) / SPIKE_WIDTH)
    ya = ya + TRUE["reversal_spike_2"] * np.sign(y) * np.exp(-since((np.pi / 2, 3 * np.pi / 2)) / SPIKE_WIDTH)
    xa = xa + TRUE["cyclic_1"] * np.sin(2 * np.pi * x / LEAD + 0.7)
    ya = ya + TRUE["cyclic_2"] * np.sin(2 * np.pi * y / LEAD - 1.2)
    xa, ya = xa + offset[0], ya + offset[1]
    reading = np.hypot(xa, ya) - R + (rng.normal(0.0, noise, n) if noise else 0.0)
    return np.column_stack([x, y, np.zeros(n)]), reading


def _evaluate(noise: float = 0.0):
    pc, rc = _axis_run(+1, noise=noise, seed=1)
    pw, rw = _axis_run(-1, noise=noise, seed=2, offset=(22e-6, -14e-6))  # the set-up moves a little between runs
    direction = np.array(["ccw"] * len(pc) + ["cw"] * len(pw))
    return evaluate_circular_test(np.vstack([pc, pw]), np.concatenate([rc, rw]), (0, 0, 0), R, direction=direction)


def _expected() -> dict[str, tuple[float, str]]:
    """Injected values in the diagnosis' report units."""
    e = {k: v * 1e6 for k, v in TRUE.items() if k != "servo_tau"}
    e["servo_mismatch"] = TRUE["servo_tau"] * 1e3  # ms
    return e


def test_injected_sources_are_diagnosed_noise_free():
    ev = _evaluate()
    diag = diagnose(ev, lead=LEAD, feed=FEED, tolerance=60e-6)
    got = {s.name: s for s in diag.sources}
    assert set(got) == set(_expected()) and not diag.not_fitted
    for name, want in _expected().items():
        # first-order model vs the exact distance: the neglected terms are error²/R (≈ 0.01 µm here), the
        # spikes and cyclic error are projected on the radius; measured ≤ 0.6 % off (lateral play); 1 % + 0.02
        # (µm, ms or µm/m) covers it
        tol = 0.01 * abs(want) + 0.02
        assert got[name].value == pytest.approx(abs(want) if name.startswith("cyclic") else want, abs=tol), name
    assert diag.residual_rms < 0.1e-6
    # the shares: every source's peak-to-valley over that run's G; the largest (squareness or scale) dominate
    assert all(0.0 <= s.share <= 1.5 for s in diag.sources)
    assert diag.sources[0].name in ("scale_mismatch", "squareness", "servo_mismatch")
    assert diag.passed == {lab: g <= 60e-6 for lab, g in diag.G.items()}


def test_injected_sources_within_three_sigma_with_noise():
    ev = _evaluate(noise=0.5e-6)  # QC10 accuracy ±0.5 µm as 1σ
    diag = diagnose(ev, lead=LEAD, feed=FEED)
    exp = _expected()
    for s in diag.sources:
        want = abs(exp[s.name]) if s.name.startswith("cyclic") else exp[s.name]
        bias = 0.01 * abs(want)  # the first-order model's own error (noise-free test above)
        assert abs(s.value - want) <= 4 * s.sigma + bias, (s.name, s.value, want, s.sigma)
    assert diag.residual_rms == pytest.approx(0.5e-6, rel=0.1)


def test_one_direction_leaves_the_direction_dependent_sources_out():
    pc, rc = _axis_run(+1)
    ev = evaluate_circular_test(pc, rc, (0, 0, 0), R, direction=np.array(["ccw"] * len(pc)))
    diag = diagnose(ev)
    assert set(diag.not_fitted) == {"servo mismatch", "lateral play X", "lateral play Y", "cyclic error X",
                                    "cyclic error Y"}
    assert "both directions" in diag.not_fitted["servo mismatch"] and "lead" in diag.not_fitted["cyclic error X"]


def test_a_clean_circle_has_nothing_to_diagnose():
    t = np.linspace(0, 2 * np.pi, 3600, endpoint=False)
    pos = np.column_stack([R * np.cos(t), R * np.sin(t), 0 * t])
    ev = evaluate_circular_test(np.vstack([pos, pos[::-1]]), np.zeros(7200), (0, 0, 0), R,
                                direction=np.array(["ccw"] * 3600 + ["cw"] * 3600))
    diag = diagnose(ev, lead=LEAD, feed=FEED)
    assert all(abs(s.value) < 1e-6 for s in diag.sources)
