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
:mod:`~pkmstiff.mechanisms.generate` (generic mechanisms of the closed-form machines), :mod:`~pkmstiff.mechanisms.info`.
"""

#: public name -> module (imported on first use, so that ``pkmstiff pose``/``section`` can ask
#: :func:`is_mechanism` without loading the compiled solver and numba)
_FACADE = {
    "DriveRange": "pkmstiff.mechanisms.continuation",
    "RangeEnd": "pkmstiff.mechanisms.continuation",
    "drive_ranges": "pkmstiff.mechanisms.continuation",
    "Rates": "pkmstiff.mechanisms.derivatives",
    "rates": "pkmstiff.mechanisms.derivatives",
    "REASONS": "pkmstiff.mechanisms.evaluate",
    "MechanismEvaluation": "pkmstiff.mechanisms.evaluate",
    "evaluate": "pkmstiff.mechanisms.evaluate",
    "reason_names": "pkmstiff.mechanisms.evaluate",
    "identification_jacobian": "pkmstiff.mechanisms.identification",
    "parameters": "pkmstiff.mechanisms.identification",
    "with_parameters": "pkmstiff.mechanisms.identification",
    "MechanismInfo": "pkmstiff.mechanisms.info",
    "info": "pkmstiff.mechanisms.info",
    "bundled_mechanisms": "pkmstiff.mechanisms.loader",
    "is_mechanism": "pkmstiff.mechanisms.loader",
    "load_mechanism": "pkmstiff.mechanisms.loader",
    "mechanism_from_dict": "pkmstiff.mechanisms.loader",
    "Joint": "pkmstiff.mechanisms.model",
    "Mechanism": "pkmstiff.mechanisms.model",
    "Output": "pkmstiff.mechanisms.model",
    "STATUS": "pkmstiff.mechanisms.solver",
    "Solution": "pkmstiff.mechanisms.solver",
    "forward": "pkmstiff.mechanisms.solver",
    "home": "pkmstiff.mechanisms.solver",
    "inverse": "pkmstiff.mechanisms.solver",
    "joint_values": "pkmstiff.mechanisms.solver",
    "output_pose": "pkmstiff.mechanisms.solver",
}


def __getattr__(name: str):
    if name in _FACADE:
        import importlib

        return getattr(importlib.import_module(_FACADE[name]), name)
    raise AttributeError(f"module 'pkmstiff.mechanisms' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + list(_FACADE))


__all__ = ["DriveRange", "Joint", "Mechanism", "MechanismEvaluation", "MechanismInfo", "Output", "REASONS",
           "RangeEnd", "Rates", "STATUS", "Solution", "bundled_mechanisms", "drive_ranges", "evaluate", "forward",
           "home", "identification_jacobian", "info", "inverse", "is_mechanism", "joint_values", "load_mechanism",
           "mechanism_from_dict", "output_pose", "parameters", "rates", "reason_names", "with_parameters"]
