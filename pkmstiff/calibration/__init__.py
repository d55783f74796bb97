"""Calibration layer: geometric error models, measurement models, the identification Jacobian, identifiability,
measurement plans and Denkena's implicit double-pendulum example (Szatmári 2007 §4.2–4.4; Denkena et al. 2008
§1.2–1.5; the readings of docs/theory/calibration.md).

Modules: :mod:`.parameters` (named error parameters, Cartesian/cylindrical frames), :mod:`.instruments` (the
Instrument protocol, one module per instrument — ball bar, tracker, 6-D pose — with its set-up, readings, devices and
measurement-file columns; the registry of kind names), :mod:`.perturb` (perturbed machine, machine file that ``extends`` the
nominal one), :mod:`.plans` (plans, default plans, TOML plans, plan checks), :mod:`.measurement` (simulated readings
through the forward kinematics), :mod:`.jacobian` (analytic identification Jacobian), :mod:`.gauges` (named gauge
freedoms), :mod:`.identifiability` (rank, base parameters, condition, orthogonality, O1–O5), :mod:`.implicit`
(implicit-function-theorem sensitivities), :mod:`.pendulum` (Denkena's double pendulum).
The ball-bar circle/Fourier evaluation lives in :mod:`.ballbar` (imported on its own); the workflow of
``calibrate identify`` / ``calibrate report`` (identification, uncertainty, validation; typed results) in
:mod:`.workflow`, the circles of a ball-bar measurement in :mod:`.circles`.
"""

from pkmstiff.calibration.gauges import GaugeCandidate, gauge_candidates
from pkmstiff.calibration.identifiability import (
                                                  GaugeFreedom,
                                                  Identifiability,
                                                  analyse,
                                                  identifiability,
                                                  numerical_rank,
                                                  observability_indices,
                                                  orthogonality_matrix,
)
from pkmstiff.calibration.instruments import Instrument, Setup, SetupState, instrument, readings
from pkmstiff.calibration.jacobian import IdentificationJacobian, identification_jacobian
from pkmstiff.calibration.measurement import reached_poses, simulate_readings
from pkmstiff.calibration.parameters import FRAMES, ParameterSet, error_model, parse_errors, parse_with
from pkmstiff.calibration.perturb import machine_file_text, perturbed_machine, perturbed_state
from pkmstiff.calibration.plans import (
                                                  Plan,
                                                  Segment,
                                                  check_plan,
                                                  circle_plan,
                                                  default_plan,
                                                  default_setup,
                                                  grid_plan,
                                                  hemisphere_plan,
                                                  read_plan,
                                                  tilt_torsion_matrix,
                                                  workspace_centre,
)

__all__ = [
                                                  "FRAMES",
                                                  "GaugeCandidate",
                                                  "GaugeFreedom",
                                                  "Identifiability",
                                                  "Instrument",
                                                  "IdentificationJacobian",
                                                  "ParameterSet",
                                                  "Plan",
                                                  "Segment",
                                                  "Setup",
                                                  "SetupState",
                                                  "analyse",
                                                  "check_plan",
                                                  "circle_plan",
                                                  "default_plan",
                                                  "default_setup",
                                                  "error_model",
                                                  "gauge_candidates",
                                                  "grid_plan",
                                                  "hemisphere_plan",
                                                  "identifiability",
                                                  "identification_jacobian",
                                                  "instrument",
                                                  "machine_file_text",
                                                  "numerical_rank",
                                                  "observability_indices",
                                                  "orthogonality_matrix",
                                                  "parse_errors",
                                                  "parse_with",
                                                  "perturbed_machine",
                                                  "perturbed_state",
                                                  "reached_poses",
                                                  "read_plan",
                                                  "readings",
                                                  "simulate_readings",
                                                  "tilt_torsion_matrix",
                                                  "workspace_centre",
]
