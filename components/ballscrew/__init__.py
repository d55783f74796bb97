"""Ball-screw drives with indirect measuring system (docs/theory/components.md, Cobet eq. 3.1–3.4, 3.21–3.24).

Axial stiffness of the drive depends on the nut position through the spindle; bearings, nut and nut
connection are constant. Arrangements (Cobet Table 3.1):

* ``fixed_fixed`` (eq. 3.2): two fixed bearings, the nut splits the spindle into l_Sp1 (from the
  motor-side bearing) and l_Sp2 = l_Sp − l_Sp1; equivalent to two paths "fixed bearing (2 k_al) in series
  with a spindle segment" acting in parallel;
* ``fixed_floating`` / ``floating_fixed`` (eq. 3.3): l_eff is the distance from the fixed bearing to the
  nut; the fixed bearing is at the motor end resp. at the far end.

The nut position along the spindle is ``s = nut_offset + drive_position`` measured from the motor-side
bearing (``state.l_eff``, when given, is used directly as l_eff resp. l_Sp1).

:class:`TelescopicBallScrew` is the pod strut drive of the 6X Hexapod (docs/user-guide/machines.md): fixed–floating,
driven by the strut length through l_eff = l_eff_min + (l − l_at_l_eff_min) (Assumption) and evaluated either
with the quadratic fit of Cobet eq. 3.22 (default) or the exact eq. 3.3.
"""

from components.ballscrew.drive import BALLSCREW_MODELS, BallScrewDrive
from components.ballscrew.formulas import (
    ARRANGEMENTS,
    DRIVE_MODELS,
    RANGE_POLICIES,
    apparent_mass_from_geometry,
    apparent_mass_from_inertia,
    fixed_fixed_bearing_spindle,
    fixed_fixed_stiffness_eq_3_2,
    fixed_floating_stiffness,
    max_axial_force,
    spindle_axial_rigidity,
    spindle_stiffness,
)
from components.ballscrew.screw_params import SCREW_DATA, SCREW_DYNAMICS, screw_dynamics
from components.ballscrew.stroke_fit import StrokeFit, fit_stroke_polynomial
from components.ballscrew.telescopic import HEXAPOD_6X_DATA, TELESCOPIC_MODELS, TelescopicBallScrew
from components.protocol import parallel, series  # the connection rules, importable here as before

__all__ = [
    "ARRANGEMENTS", "BALLSCREW_MODELS", "BallScrewDrive", "DRIVE_MODELS", "HEXAPOD_6X_DATA", "MODELS", "RANGE_POLICIES",
    "SCREW_DATA", "SCREW_DYNAMICS", "StrokeFit", "TELESCOPIC_MODELS", "TelescopicBallScrew",
    "apparent_mass_from_geometry", "apparent_mass_from_inertia", "fit_stroke_polynomial",
    "fixed_fixed_bearing_spindle", "fixed_fixed_stiffness_eq_3_2", "fixed_floating_stiffness", "max_axial_force",
    "parallel", "screw_dynamics", "series", "spindle_axial_rigidity", "spindle_stiffness",
]

#: The machine-file models of this package (registered by :mod:`components.registry`).
MODELS = BALLSCREW_MODELS + TELESCOPIC_MODELS
