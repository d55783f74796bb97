"""Kinematic calibration: error models, measurement simulation and evaluation (Szatmári 2007, Denkena 2008)."""
