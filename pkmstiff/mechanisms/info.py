"""Structure of a mechanism: links, joints, equation count, rank and mobility by singular-value gap at home."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pkmstiff.mechanisms.constraints import model_system
from pkmstiff.mechanisms.linalg import gap_rank
from pkmstiff.mechanisms.model import Mechanism
from pkmstiff.mechanisms.reduced import leg_plan
from pkmstiff.mechanisms.solver import home


@dataclass
class MechanismInfo:
    name: str
    dimension: int
    links: tuple[str, ...]
    joints: list[dict]
    unknowns: int  #: link coordinates (6 or 3 per link, eq. 1-2 / 9)
    equations: int  #: model equations incl. the ground's fixed coordinates
    rank: int  #: rank of the model Jacobian at home (singular-value gap)
    mobility: int  #: unknowns − rank
    drives: tuple[str, ...]
    singular_values: np.ndarray  #: of the model Jacobian at home, descending
    #: forward-kinematics path chosen at load: "length_legs" (Newton on the output link's 6 coordinates, legs in
    #: closed form, :mod:`pkmstiff.mechanisms.reduced`) or "full" (all link coordinates)
    forward_path: str = "full"


def info(mech: Mechanism) -> MechanismInfo:
    """Equation count, rank and mobility (DOF of the mechanism) of the model equations at home."""
    sysm = model_system(mech)
    _, J = sysm.evaluate(home(mech))
    s = np.linalg.svd(J[0], compute_uv=False)
    rank = int(gap_rank(s))
    joints = [{"name": j.name, "type": j.type, "links": [mech.links[j.links[0]], mech.links[j.links[1]]],
               "drive": j.drive.name if j.drive else None} for j in mech.joints]
    path = "length_legs" if leg_plan(mech) is not None else "full"
    return MechanismInfo(mech.name, mech.dim, mech.links, joints, sysm.n, sysm.m, rank, sysm.n - rank,
                         mech.drive_names, s, path)
