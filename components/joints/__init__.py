"""Joint stiffness models (docs/theory/components.md).

A joint stiffness is a scalar axial (tension/compression) stiffness along the strut in N/m that depends
on the joint angles of docs/theory/kinematics.md, handed over in ``state.tilt`` / ``state.swivel`` (rad) in the joint's
own convention (``angle_convention`` = ``"axis"`` | ``"normal"`` | ``None`` for models valid in either).

Models: :class:`ConstantJoint`, :class:`AnalyticJoint330` (Cobet eq. 3.30), :class:`TiltTableJoint`
(clamped cubic spline over tilt, Cobet 3.2.5), :class:`SwivelTiltTableJoint` (bicubic on a (swivel, tilt)
grid) and :class:`ProductJoint` (k_ref · g_φ(φ) · g_θ(θ)); the latter two are the spec's Assumption for
swivel- and tilt-dependent joints.

NaN policy: a NaN tilt gives a NaN stiffness for that pose only (the other poses are unaffected). A NaN
(undefined) swivel gives NaN for swivel-dependent models unless ``undefined_swivel`` names a swivel
angle to use instead. Extrapolation outside a table: ``"clamp"`` (default, spec Assumption) or ``"error"``.
"""

from components.joint_tables import (  # re-exported: the documented entry points are components.joints.*
    JointTable,
    bundled_tables,
    load_joint_table,
    write_joint_table,
)
from components.joints import constant, product, tabulated
from components.joints.base import JOINT_COMMON, JointModel
from components.joints.constant import AnalyticJoint330, ConstantJoint, analytic_3_30
from components.joints.product import ProductJoint
from components.joints.tabulated import SwivelTiltTableJoint, TiltTableJoint, joint_from_table

__all__ = [
    "JointModel", "ConstantJoint", "AnalyticJoint330", "TiltTableJoint", "SwivelTiltTableJoint", "ProductJoint",
    "analytic_3_30", "joint_from_table", "load_joint_table", "write_joint_table", "bundled_tables", "JointTable",
    "JOINT_COMMON", "MODELS",
]

#: The machine-file models of this package (registered by :mod:`components.registry`).
MODELS = constant.MODELS + tabulated.MODELS + product.MODELS
