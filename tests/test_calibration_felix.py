"""Felix (Szatmári's hexapod) as a bundled machine: given data and the assumed layout's reachability
(calibration.md §1: the thesis's test circles and the R = 300 mm hemisphere path must be admissible)."""

import numpy as np
import pytest

import pkmstiff
from pkmstiff.admissibility import evaluate_poses
from pkmstiff.calibration import Setup, hemisphere_plan
from pkmstiff.calibration.plans import circle_positions


def test_given_data(felix):
    ch = felix.chains
    assert felix.kind == "pod" and felix.n_chains == 6
    # joint circles R = 1500 / 600 mm, each in a plane (file coordinates to 1e-6 mm)
    np.testing.assert_allclose(np.hypot(ch.drive_joint[:, 0], ch.drive_joint[:, 1]), 1.5, atol=2e-9)
    np.testing.assert_allclose(np.hypot(ch.platform_joint[:, 0], ch.platform_joint[:, 1]), 0.6, atol=2e-9)
    assert np.ptp(ch.drive_joint[:, 2]) == 0 and np.ptp(ch.platform_joint[:, 2]) == 0
    np.testing.assert_allclose(ch.length_min, 1.533, rtol=1e-15)  # "1533.0 mm" through pint: 1 ulp
    np.testing.assert_allclose(ch.length_max, 2.513, rtol=1e-15)
    # origin = platform centre with every strut at its zero, 2000.0 mm (coordinates to 1e-9 m)
    np.testing.assert_allclose(pkmstiff.inverse_kinematics(felix, np.zeros(6)).length, 2.0, atol=1e-8)
    assert all("\n" not in v for v in felix.assumptions.values()) and len(felix.assumptions) >= 5


def test_thesis_test_circles_are_admissible(felix):
    """Szatmári §5.3, Tab. 5.1: R = 300 mm circles about (0,0,0), (400,0,0), (-200,±346,0) in XY, XZ, YZ."""
    centres = [(0, 0, 0), (0.4, 0, 0), (-0.2, 0.346, 0), (-0.2, -0.346, 0)]
    P = np.vstack([circle_positions(np.array(c), 0.3, plane, 72) for c in centres for plane in ("XY", "XZ", "YZ")])
    ev = evaluate_poses(felix, np.c_[P, np.zeros((len(P), 3))])
    assert ev.ok.all(), ev.admissibility.summary()
    # margins to the strut limits (the layout's choice of alpha = 20 deg): at least 10 mm on either side
    assert ev.strut_length.min() >= 1.533 + 0.010 and ev.strut_length.max() <= 2.513 - 0.010


@pytest.mark.parametrize("tilt_deg", [0, 20, 25])
def test_hemisphere_path_is_admissible(felix, tilt_deg):
    setup = Setup("ballbar", target=np.zeros(3), fixed_ball=np.zeros(3), bar_length=0.3)
    plan = hemisphere_plan(setup, tilt=np.radians(tilt_deg), torsion=np.radians(min(tilt_deg, 15)))
    assert evaluate_poses(felix, plan.poses).ok.all()
