"""Generic spring–damper (SDE) multibody model and its analyses (docs/theory/structure.md).

Build an :class:`SDEModel` from point masses, rigid bodies, stiffness–damping elements and rigid bindings, then
call the analysis functions below.  Everything is vectorised over a leading pose axis and chunked over poses.
"""

from pkmstiff.multibody.assembly import (
                       damping_matrix,
                       element_deformations,
                       element_energies,
                       element_forces,
                       mass_matrix,
                       stiffness_matrix,
)
from pkmstiff.multibody.batch import PointEvaluation, evaluate_point
from pkmstiff.multibody.bodies import FRAME, PointMass, RigidBody, combine_rigid, make_point_mass, make_rigid_body
from pkmstiff.multibody.constraints import constraint_matrix, null_space_basis
from pkmstiff.multibody.frf import PointDirection, accelerance, find_peaks, load_vector, receptance
from pkmstiff.multibody.modal import (
                       MOTION_LABELS,
                       ModalResult,
                       ModeAxes,
                       describe_modes,
                       dynamic_dofs,
                       kinetic_energy_shares,
                       mode_axes,
                       mode_label,
                       modes,
                       motion_shares,
                       natural_frequencies,
                       strain_energy_shares,
)
from pkmstiff.multibody.static import (
                       axis_stiffness,
                       body_displacements,
                       directional_stiffness,
                       energy_shares,
                       group_matrix,
                       point_compliance,
                       point_load,
                       point_motion,
                       point_stiffness,
                       sde_deformations,
                       sde_forces,
                       solve_static,
                       weak_points,
)
from pkmstiff.multibody.system import DOF_NAMES, SDEModel

__all__ = [
    "FRAME", "DOF_NAMES", "MOTION_LABELS", "SDEModel", "PointMass", "RigidBody", "make_point_mass", "make_rigid_body",
    "combine_rigid", "stiffness_matrix", "mass_matrix", "damping_matrix", "element_deformations", "element_forces",
    "element_energies", "constraint_matrix", "null_space_basis",
    "point_load", "point_motion", "solve_static", "point_compliance", "point_stiffness", "directional_stiffness",
    "axis_stiffness", "body_displacements", "sde_deformations", "sde_forces", "energy_shares", "group_matrix",
    "weak_points",
    "ModalResult", "modes", "natural_frequencies", "kinetic_energy_shares", "strain_energy_shares",
    "motion_shares", "describe_modes", "dynamic_dofs", "mode_label", "ModeAxes", "mode_axes",
    "PointDirection", "load_vector", "receptance", "accelerance", "find_peaks",
    "PointEvaluation", "evaluate_point",
]
