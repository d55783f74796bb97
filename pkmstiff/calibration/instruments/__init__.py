"""Instruments (ball bar, laser tracker, 6-D pose), their set-up, devices and readings (Szatmári §4.3; Denkena
§1.3). :mod:`.base` defines the :class:`Instrument` protocol and the set-up, one module per instrument implements
it (:mod:`.ball_bar`, :mod:`.tracker`, :mod:`.pose`), :mod:`.registry` maps kind names to instruments."""

from pkmstiff.calibration.instruments.ball_bar import BALL_BAR, QC10, BallBar, BallbarDevice, BallbarMeasurement
from pkmstiff.calibration.instruments.base import Instrument, Setup, SetupState, readings, target_points
from pkmstiff.calibration.instruments.pose import POSE, Pose
from pkmstiff.calibration.instruments.registry import instrument, instruments, kinds, register, unregister
from pkmstiff.calibration.instruments.tracker import AT960, TRACKER, PointMeasurement, Tracker, TrackerDevice

__all__ = ["AT960", "BALL_BAR", "POSE", "QC10", "TRACKER", "BallBar", "BallbarDevice", "BallbarMeasurement",
           "Instrument", "PointMeasurement", "Pose", "Setup", "SetupState", "Tracker", "TrackerDevice", "instrument",
           "instruments", "kinds", "readings", "register", "target_points", "unregister"]
