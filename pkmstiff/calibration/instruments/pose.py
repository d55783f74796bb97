"""The 6-D pose instrument (a tracker with a 6-DoF probe): the tracker's target position (3, m) and the
orientation error φ = log(Qᵀ R R_cᵀ) as a rotation vector (3, rad), R_c the commanded orientation."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from pkmstiff.calibration.instruments.base import Setup, SetupState
from pkmstiff.calibration.instruments.file_format import fmt
from pkmstiff.calibration.instruments.tracker import PointMeasurement, Tracker, TrackerDevice

ROTATION_COLUMNS = ("rx_urad", "ry_urad", "rz_urad")


class Pose(Tracker):
    """6-D pose: position as the tracker, plus the orientation error (rows weighted by the platform joint radius
    in rank and condition analyses, :mod:`pkmstiff.calibration.jacobian`)."""

    kind = "pose"
    title = "6-D pose instrument"
    reading_names = ("x", "y", "z", "rx", "ry", "rz")
    reading_units = ("m",) * 3 + ("rad",) * 3
    file_columns = Tracker.file_columns + ROTATION_COLUMNS
    header_keys = Tracker.header_keys + ("angle_resolution_urad", "angle_accuracy_urad")

    def readings(self, setup: Setup, state: SetupState, o: np.ndarray, R: np.ndarray,
                 R_cmd: np.ndarray) -> np.ndarray:
        Q = state.frame_rotation
        rel = np.einsum("ji,njk,nlk->nil", Q, R, R_cmd)  # Qᵀ R R_cᵀ
        return np.concatenate([super().readings(setup, state, o, R, R_cmd), Rotation.from_matrix(rel).as_rotvec()],
                              axis=1)

    def reading_twist(self, setup: Setup, m: np.ndarray, Rv: np.ndarray, source: str) -> np.ndarray:
        H = super().reading_twist(setup, m, Rv, source)
        H[:, 3:6, 3:6] = np.eye(3)
        return H

    def setup_column(self, block: str, component: str, axis: np.ndarray, setup: Setup, R: np.ndarray,
                     m: np.ndarray) -> np.ndarray:
        col = super().setup_column(block, component, axis, setup, R, m)
        if block == "instrument_frame" and component.startswith("r"):
            col[:, 3:6] = -axis
        return col

    def finish_readings(self, device: TrackerDevice, setup: Setup, options: Any, clean: np.ndarray,
                        noisy: np.ndarray, rng: np.random.Generator):
        """The orientation columns get the angle noise (not the position σ drawn for all columns) and are
        quantised to the angle resolution."""
        noisy = noisy.copy()
        sa = device.angle_sigma(options.noise)
        noisy[:, 3:] = clean[:, 3:] + (rng.standard_normal((len(noisy), 3)) * sa if sa > 0 else 0.0)
        out, violations, _ = super().finish_readings(device, setup, options, clean, noisy, rng)
        if options.quantise and device.angle_resolution > 0:
            out[:, 3:6] = np.round(out[:, 3:6] / device.angle_resolution) * device.angle_resolution
        return out, violations, None

    def simulation_summary(self, plan: Any, res: Any) -> dict:
        return {**super().simulation_summary(plan, res),
                "orientation_error_max_urad": float(np.linalg.norm(res.readings[:, 3:], axis=1).max() * 1e6)}

    def _angle_header(self, meas: PointMeasurement) -> list[str]:
        return [f"# angle_resolution_urad: {fmt(meas.angle_resolution / 1e-6)}",
                f"# angle_accuracy_urad: {fmt(meas.angle_accuracy / 1e-6)}"]

    def reading_columns(self, meas: PointMeasurement) -> list[tuple[str, np.ndarray]]:
        return super().reading_columns(meas) + [(name, meas.rotation[:, j] / 1e-6)
                                                for j, name in enumerate(ROTATION_COLUMNS)]

    def _rotation(self, column: Callable[[str], np.ndarray]) -> np.ndarray | None:
        return np.column_stack([column(c) for c in ROTATION_COLUMNS]) * 1e-6


POSE = Pose()
