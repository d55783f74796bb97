"""Building structure models for arrays of poses (chunked) and their summary.
"""

from __future__ import annotations

from typing import Any, Iterator

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.admissibility.pipeline import evaluate_chunk, evaluate_poses
from pkmstiff.errors import InputError
from pkmstiff.kinematics import IK, as_poses, inverse_kinematics
from pkmstiff.kinematics.joint_angles import joint_angles
from pkmstiff.machine.model import Machine
from pkmstiff.structure.layout import StructureLayout, structure_layout
from pkmstiff.structure.model import PKMStructure
from pkmstiff.structure.options import COMPONENT_FAILED, DEFAULT_CHUNK, Array, StructureOptions
from pkmstiff.structure.stiffness import chain_stiffness


def _kinematic_reasons(machine: Machine, ik: IK, options: StructureOptions) -> Array:
    """Reason bits (N,) of poses that cannot be modelled: unreachable, singular (or any check with 'full').

    The pose pipeline decides, on the structure's own inverse kinematics (not repeated here).
    """
    if options.check == "full":
        return evaluate_poses(machine, ik.poses).admissibility.reasons.astype(np.uint32)
    ev = evaluate_chunk(machine, ik.poses, ("singularity",), ik=ik, with_angles=False)
    return ev.admissibility.reasons.astype(np.uint32)


def structure_from_ik(machine: Machine, ik: IK, options: StructureOptions | None = None,
                      layout: StructureLayout | None = None) -> PKMStructure:
    """Structure model for the poses of an inverse-kinematics result (see :func:`build_structure`)."""
    layout = layout or structure_layout(machine, options)
    reasons = _kinematic_reasons(machine, ik, layout.options)
    status = np.zeros(ik.n_poses, np.uint8)
    idx = np.flatnonzero(reasons == 0)
    angles = joint_angles(machine, ik, signed=False)
    ks, good = chain_stiffness(layout, ik, angles, idx)
    status[idx[~good]] |= np.uint8(COMPONENT_FAILED)
    idx, ks = idx[good], ks.take(good)
    w = np.ascontiguousarray(ik.poses[idx, :3])
    R = np.ascontiguousarray(ik.R[idx])
    p, q = np.ascontiguousarray(ik.p[idx]), np.ascontiguousarray(ik.q[idx])
    u = np.ascontiguousarray(ik.unit_d[idx])
    return PKMStructure(layout, np.asarray(ik.poses), reasons, status, idx, w, R, p, q, u, ks)


def build_structure(machine: Machine, poses: ArrayLike, options: StructureOptions | None = None,
                    layout: StructureLayout | None = None) -> PKMStructure:
    """Structure model (docs/theory/structure.md) of ``machine`` at poses ``(N, 6)`` = (x, y, z [m], a, b, c [rad]).

    All poses are held in one SDE model; for large batches use :func:`iter_structures` (chunks) or the batch
    evaluation :func:`pkmstiff.analysis.evaluate_structure`.
    """
    return structure_from_ik(machine, inverse_kinematics(machine, as_poses(poses)), options, layout)


def iter_structures(machine: Machine, poses: ArrayLike, options: StructureOptions | None = None,
                    chunk_size: int = DEFAULT_CHUNK) -> Iterator[tuple[slice, PKMStructure]]:
    """``(slice, structure)`` for consecutive chunks of at most ``chunk_size`` poses (bounded memory)."""
    x = as_poses(poses)
    if chunk_size < 1:
        raise InputError("iter_structures", "chunk_size", "an integer >= 1", chunk_size)
    layout = structure_layout(machine, options)
    for start in range(0, x.shape[0], chunk_size):
        sl = slice(start, min(start + chunk_size, x.shape[0]))
        yield sl, build_structure(machine, x[sl], layout=layout)


def structure_summary(structure: PKMStructure) -> dict[str, Any]:
    """Bodies, DOF and bindings of the model (for reports and the README figure)."""
    m = structure.model
    return {
        "bodies": m.body_names, "dof": m.n_dof, "elements": m.element_names,
        "rigid_bindings": [b.name for b in m.bindings], "tcp_body": structure.tcp_body,
        "separate_spindle": structure.layout.separate_spindle,
        "massless_dofs": len(m.massless_dofs),
    }
