"""Generic link-and-joint kinematics of parallel and hybrid machines (DE 10 2004 026 707 A1; calibration.md §3).

    >>> import pkmstiff.mechanisms as mm
    >>> m = mm.load_mechanism("slider_crank")
    >>> sol = mm.forward(m, [[0.01]])          # drive value 10 mm → configuration
    >>> sol.status[0]
    'converged'

Modules: :mod:`~pkmstiff.mechanisms.model` (links, joints), :mod:`~pkmstiff.mechanisms.loader` (files, validation),
:mod:`~pkmstiff.mechanisms.constraints` (elementary constraints with analytic Jacobians),
:mod:`~pkmstiff.mechanisms.linalg` (pivoted-QR steps, rank by singular-value gap),
:mod:`~pkmstiff.mechanisms.solver` (damped Newton, inverse/forward kinematics, continuation),
:mod:`~pkmstiff.mechanisms.continuation` (drive ranges), :mod:`~pkmstiff.mechanisms.derivatives` (velocities,
accelerations), :mod:`~pkmstiff.mechanisms.evaluate` (machine-like evaluation, joint limits),
:mod:`~pkmstiff.mechanisms.identification` (calibration parameters and Jacobian),
:mod:`~pkmstiff.mechanisms.generate` (generic mechanisms of the closed-form machines), :mod:`~pkmstiff.mechanisms.info`,
:mod:`~pkmstiff.mechanisms.elastic` (``[components]``/``[elastic]`` of a file), :mod:`~pkmstiff.mechanisms.structure`
(the elastic model in the multibody layer), :mod:`~pkmstiff.mechanisms.stiffness` (stiffness, modes, weak points,
FRF).
"""

from pkmstiff.mechanisms.continuation import DriveRange, RangeEnd, drive_ranges
from pkmstiff.mechanisms.derivatives import Rates, rates
from pkmstiff.mechanisms.evaluate import REASONS, MechanismEvaluation, evaluate, reason_names
from pkmstiff.mechanisms.identification import identification_jacobian, parameters, with_parameters
from pkmstiff.mechanisms.info import MechanismInfo, info
from pkmstiff.mechanisms.loader import bundled_mechanisms, is_mechanism, load_mechanism, mechanism_from_dict
from pkmstiff.mechanisms.model import Joint, Mechanism, Output
from pkmstiff.mechanisms.solver import STATUS, Solution, forward, home, inverse, joint_values, output_pose

__all__ = ["DriveRange", "Joint", "Mechanism", "MechanismEvaluation", "MechanismInfo", "Output", "REASONS",
           "RangeEnd", "Rates", "STATUS", "Solution", "bundled_mechanisms", "drive_ranges", "evaluate", "forward",
           "home", "identification_jacobian", "info", "inverse", "is_mechanism", "joint_values", "load_mechanism",
           "mechanism_from_dict", "output_pose", "parameters", "rates", "reason_names", "with_parameters"]
