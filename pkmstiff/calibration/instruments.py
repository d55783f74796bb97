"""Instruments and their set-up: double ball bar, laser tracker, 6-D pose measurement (Szatmári §4.3; Denkena §1.3).

A :class:`Setup` holds the nominal set-up; a :class:`SetupState` the actual one (nominal + set-up errors). Readings
are computed from the platform frame (origin o, rotation R) the machine reaches:

* ball bar (docs/theory/calibration.md): r = |o + R (v + Δv) − s_7| + Δr (m);
* tracker: the target position in the instrument frame, Qᵀ (o + R (v + Δv) − τ) (m, 3 per pose);
* pose: the same position (3, m) and the orientation error φ = log(Qᵀ R R_cᵀ) as a rotation vector (3, rad) with
  R_c the commanded orientation.

v is the moving ball / target / reference point in the platform frame (PKS), s_7 the fixed ball (MKS), (τ, Q) the
pose of the instrument frame in the MKS (nominal: identity).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from pkmstiff.errors import InputError

INSTRUMENTS = ("ballbar", "tracker", "pose")
#: readings per pose and their names/units
READINGS = {"ballbar": (("r",), ("m",)), "tracker": (("x", "y", "z"), ("m",) * 3),
            "pose": (("x", "y", "z", "rx", "ry", "rz"), ("m",) * 3 + ("rad",) * 3)}

#: QC10-class ball bar (Szatmári Tab. 4.3): measuring range ±1 mm about the nominal length
BALLBAR_RANGE = 1e-3


def check_instrument(instrument: str, source: str = "--instrument") -> str:
    if instrument not in INSTRUMENTS:
        raise InputError(source, "instrument", f"one of {', '.join(INSTRUMENTS)}", instrument)
    return instrument


@dataclass(frozen=True)
class Setup:
    """Nominal instrument set-up: ``target`` v in the PKS (m); ball bar: ``fixed_ball`` s_7 in the MKS (m) and
    the nominal ``bar_length`` (m); ``measuring_range`` (m) about it (QC10: ±1 mm); ``max_mount_angle`` (rad,
    optional) the largest angle between the bar (moving ball → fixed ball) and the tool axis that the magnetic
    cup permits (Szatmári §4.4.3, collision check; no value given there, so unchecked unless set)."""

    instrument: str
    target: np.ndarray = field(default_factory=lambda: np.zeros(3))
    fixed_ball: np.ndarray | None = None
    bar_length: float | None = None
    measuring_range: float = BALLBAR_RANGE
    max_mount_angle: float | None = None

    def __post_init__(self) -> None:
        check_instrument(self.instrument, "setup")
        object.__setattr__(self, "target", np.asarray(self.target, dtype=float).reshape(3))
        if self.instrument == "ballbar":
            if self.fixed_ball is None or self.bar_length is None or not self.bar_length > 0:
                raise InputError("setup", "fixed_ball/bar_length", "a fixed-ball position and a positive "
                                            "bar length for a ball bar", (self.fixed_ball, self.bar_length))
            object.__setattr__(self, "fixed_ball", np.asarray(self.fixed_ball, dtype=float).reshape(3))

    @property
    def n_readings(self) -> int:
        return len(READINGS[self.instrument][0])

    def state(self) -> SetupState:
        return SetupState(target=self.target.copy(),
                          fixed_ball=None if self.fixed_ball is None else self.fixed_ball.copy())


@dataclass(frozen=True)
class SetupState:
    """Actual set-up: target v + Δv (PKS), fixed ball (MKS), bar-length offset Δr, instrument frame (τ, Q)."""

    target: np.ndarray
    fixed_ball: np.ndarray | None = None
    bar_offset: float = 0.0
    frame_translation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    frame_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))


def target_points(state: SetupState, o: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Moving ball / target in the MKS, o + R v, shape (N, 3)."""
    return o + np.einsum("nij,j->ni", R, state.target)


def readings(setup: Setup, state: SetupState, o: np.ndarray, R: np.ndarray, R_cmd: np.ndarray) -> np.ndarray:
    """Readings (N, k) of the instrument for platform frames (o (N, 3), R (N, 3, 3)); ``R_cmd`` the commanded
    orientations (pose instrument). Units: m, rad (see :data:`READINGS`)."""
    m = target_points(state, o, R)
    if setup.instrument == "ballbar":
        return (np.linalg.norm(m - state.fixed_ball, axis=1) + state.bar_offset)[:, None]
    Q = state.frame_rotation
    pos = (m - state.frame_translation) @ Q
    if setup.instrument == "tracker":
        return pos
    rel = np.einsum("ji,njk,nlk->nil", Q, R, R_cmd)  # Qᵀ R R_cᵀ
    return np.concatenate([pos, Rotation.from_matrix(rel).as_rotvec()], axis=1)
