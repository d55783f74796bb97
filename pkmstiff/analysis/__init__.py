"""Analyses of the PKM structure model (docs/theory/structure.md): static stiffness and weak points at the TCP, modal
analysis, frequency response, kinetostatics, the deflection under gravity (:mod:`.gravity`), and a chunked batch
evaluation for pose maps.

Build the model with :func:`pkmstiff.structure.build_structure`, then call the functions below; every result has
the leading pose axis N and is NaN where a pose could not be modelled (``structure.failing(i)`` says why).
"""

from pkmstiff.analysis.batch import StructureBatch, evaluate_structure
from pkmstiff.analysis.frf import FRFResult, tcp_frf
from pkmstiff.analysis.gravity import gravity_deflection, gravity_load, structure_deflection
from pkmstiff.analysis.kinetostatics import (
                            DEFAULT_ACCELERATION_DIRECTIONS,
                            DEFAULT_VELOCITY_DIRECTIONS,
                            DriveData,
                            Kinetostatics,
                            KinetostaticsOptions,
                            drive_data,
                            kinetostatics,
                            max_acceleration,
                            max_velocity,
                            twist_directions,
)
from pkmstiff.analysis.modal import ModalAnalysis, modal_analysis, natural_frequencies
from pkmstiff.analysis.static import (
                            Deformation,
                            WeakPoints,
                            axis_stiffness,
                            directional_stiffness,
                            static_deformation,
                            tcp_compliance,
                            tcp_stiffness_matrix,
                            weak_points,
)

__all__ = [
    "StructureBatch", "evaluate_structure", "FRFResult", "tcp_frf", "DEFAULT_ACCELERATION_DIRECTIONS",
    "DEFAULT_VELOCITY_DIRECTIONS", "DriveData", "Kinetostatics", "KinetostaticsOptions", "drive_data",
    "kinetostatics", "max_acceleration", "max_velocity", "twist_directions", "ModalAnalysis", "modal_analysis",
    "natural_frequencies", "gravity_deflection", "gravity_load", "structure_deflection", "Deformation", "WeakPoints",
    "axis_stiffness", "directional_stiffness",
    "static_deformation", "tcp_compliance", "tcp_stiffness_matrix", "weak_points",
]
