"""Drive limits shared by the drive models: declaration and reader (Cobet eq. 4.89, docs/theory/kinetostatics.md).

The values go to :attr:`components.protocol.Component.limits` (SI, keys in
:data:`components.protocol.LIMIT_UNITS`); a limit that is not given is absent from the dict.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from components.params import Param

if TYPE_CHECKING:
    from components.reader import Params

DRIVE_LIMITS: tuple[Param, ...] = (
    Param("max_force", "N", None, "maximum drive force", min_value=0.0),
    Param("force_reserve", "N", None, "force reserve (static friction + safety)", min_value=0.0),
    Param("max_speed", "m/s", None, "maximum drive speed", min_value=0.0),
    Param("coulomb_friction", "N", None, "Coulomb friction coefficient C (eq. 4.89)", min_value=0.0),
    Param("viscous_friction", "N*s/m", None, "viscous friction coefficient V (eq. 4.89)", min_value=0.0),
)


#: the limits of a rotary drive (mechanism files): torques and angular speed, the counterparts of DRIVE_LIMITS
ROTARY_DRIVE_LIMITS: tuple[Param, ...] = (
    Param("max_torque", "N*m", None, "maximum drive torque", min_value=0.0),
    Param("torque_reserve", "N*m", None, "torque reserve (static friction + safety)", min_value=0.0),
    Param("max_angular_speed", "rad/s", None, "maximum drive angular speed", min_value=0.0),
    Param("coulomb_torque", "N*m", None, "Coulomb friction torque C (eq. 4.89)", min_value=0.0),
)


def drive_limits(p: "Params", declared: tuple[Param, ...] = DRIVE_LIMITS) -> dict[str, float]:
    """The drive limits given in the table (declared in ``declared``: :data:`DRIVE_LIMITS` or
    :data:`ROTARY_DRIVE_LIMITS`), SI."""
    out = {}
    for decl in declared:
        value = p[decl.key]
        if value is not None:
            out[decl.key] = value
    return out
