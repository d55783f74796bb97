"""Building structure models from pose evaluations (or arrays of poses, chunked) and their summary.

The structure model takes the pose pipeline's result (:class:`~pkmstiff.admissibility.pipeline.PoseEvaluation`):
the inverse kinematics, the joint angles and the admissibility are computed once, by the pipeline.
"""

from __future__ import annotations

from typing import Any, Iterator

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.admissibility.checks import ALL_CHECKS, Reason
from pkmstiff.admissibility.pipeline import PoseEvaluation, evaluate_poses
from pkmstiff.kinematics import as_poses, singular_mask
from pkmstiff.machine.model import Machine
from pkmstiff.structure.layout import StructureLayout, structure_layout
from pkmstiff.structure.model import PKMStructure
from pkmstiff.structure.options import COMPONENT_FAILED, DEFAULT_CHUNK, Array, StructureModelError, StructureOptions
from pkmstiff.structure.stiffness import chain_stiffness


#: reason bits that keep a pose out of the structure model with the default ``check="kinematic"``
_KINEMATIC = np.uint32(Reason.UNREACHABLE | Reason.SINGULAR)


def structure_evaluation(machine: Machine, poses: ArrayLike, options: StructureOptions | None = None) -> PoseEvaluation:
    """The pose evaluation a structure model needs (:func:`pkmstiff.admissibility.pipeline.evaluate_poses`): the
    singularity check only (``check="kinematic"``, the default), or every check (``"full"``)."""
    if options is not None and options.check == "full":
        return evaluate_poses(machine, poses)
    return evaluate_poses(machine, poses, ("singularity",), drive_load_data=None)


def _model_reasons(machine: Machine, ev: PoseEvaluation, options: StructureOptions) -> Array:
    """Reason bits (N,) of poses that cannot be modelled: unreachable, singular (or any check with ``"full"``),
    read from the evaluation's admissibility (nothing is repeated; user requirements do not count)."""
    reasons = ev.admissibility.reasons.astype(np.uint32)
    if options.check == "full":
        if set(ev.checks) != set(ALL_CHECKS):
            return structure_evaluation(machine, ev.poses, options).admissibility.reasons.astype(np.uint32)
        return reasons & ~np.uint32(Reason.REQUIREMENT)
    if "singularity" not in ev.checks:  # an evaluation without the singularity check: check it here
        reach = ev.ik.all_reachable
        reasons = np.where(reach, 0, np.uint32(Reason.UNREACHABLE)).astype(np.uint32)
        reasons[reach & singular_mask(machine, ev.jinv)] |= np.uint32(Reason.SINGULAR)
    return reasons & _KINEMATIC


def _structure_from_evaluation(machine: Machine, ev: PoseEvaluation, layout: StructureLayout) -> PKMStructure:
    ik = ev.ik
    reasons = _model_reasons(machine, ev, layout.options)
    status = np.zeros(ik.n_poses, np.uint8)
    idx = np.flatnonzero(reasons == 0)
    ks, good = chain_stiffness(layout, ik, ev.angles, idx)
    status[idx[~good]] |= np.uint8(COMPONENT_FAILED)
    idx, ks = idx[good], ks.take(good)
    w = np.ascontiguousarray(ik.poses[idx, :3])
    R = np.ascontiguousarray(ik.R[idx])
    p, q = np.ascontiguousarray(ik.p[idx]), np.ascontiguousarray(ik.q[idx])
    u = np.ascontiguousarray(ik.unit_d[idx])
    return PKMStructure(layout, np.asarray(ik.poses), reasons, status, idx, w, R, p, q, u, ks)


def build_structure(machine: Machine, poses: ArrayLike | PoseEvaluation, options: StructureOptions | None = None,
                    layout: StructureLayout | None = None) -> PKMStructure:
    """Structure model (docs/theory/structure.md) of ``machine`` at N poses.

    ``poses``: the :class:`~pkmstiff.admissibility.pipeline.PoseEvaluation` of the poses (its inverse kinematics,
    joint angles and admissibility are used as they are: nothing is computed twice), or poses ``(N, 6)`` =
    (x, y, z [m], a, b, c [rad]), which are then evaluated once (:func:`structure_evaluation`). Poses that are
    unreachable or singular (with ``options.check == "full"``: that fail any check) are kept unmodelled with their
    reason code.

    All poses are held in one SDE model; for large batches use :func:`iter_structures` (chunks) or the batch
    evaluation :func:`pkmstiff.analysis.evaluate_structure` (the analyses of :mod:`pkmstiff.analysis` also work
    chunk by chunk on a large structure).
    """
    layout = layout or structure_layout(machine, options)
    ev = poses if isinstance(poses, PoseEvaluation) else structure_evaluation(machine, poses, layout.options)
    return _structure_from_evaluation(machine, ev, layout)


def iter_structures(machine: Machine, poses: ArrayLike, options: StructureOptions | None = None,
                    chunk_size: int = DEFAULT_CHUNK) -> Iterator[tuple[slice, PKMStructure]]:
    """``(slice, structure)`` for consecutive chunks of at most ``chunk_size`` poses (bounded memory)."""
    x = as_poses(poses)
    if chunk_size < 1:
        raise StructureModelError("iter_structures", "chunk_size", "an integer >= 1", chunk_size)
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
