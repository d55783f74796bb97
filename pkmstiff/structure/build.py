"""Building structure models from pose evaluations (or arrays of poses, chunked) and their summary.

The structure model takes the pose pipeline's result (:class:`~pkmstiff.admissibility.pipeline.PoseEvaluation`):
the inverse kinematics, the joint angles and the admissibility are computed once, by the pipeline.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.admissibility.checks import ALL_CHECKS, Reason
from pkmstiff.admissibility.pipeline import PoseEvaluation, evaluate_poses
from pkmstiff.kinematics import as_poses, singular_mask
from pkmstiff.machine.model import Machine
from pkmstiff.structure import options as _options
from pkmstiff.structure.layout import StructureLayout, structure_layout
from pkmstiff.structure.model import PKMStructure
from pkmstiff.structure.options import COMPONENT_FAILED, Array, StructureModelError, StructureOptions
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

    Built chunk by chunk (:data:`~pkmstiff.structure.DEFAULT_CHUNK` poses, bounded work space); the analyses of
    :mod:`pkmstiff.analysis` also work part by part on a large structure (:meth:`PKMStructure.parts`).
    """
    layout = layout or structure_layout(machine, options)
    if isinstance(poses, PoseEvaluation):
        n = len(poses.poses)
        if n <= _options.DEFAULT_CHUNK:
            return _structure_from_evaluation(machine, poses, layout)
    else:
        poses = as_poses(poses)
        n = len(poses)
        if n <= _options.DEFAULT_CHUNK:
            return _structure_from_evaluation(machine, structure_evaluation(machine, poses, layout.options), layout)
    return PKMStructure.concatenate([st for _, st in _chunks(machine, poses, layout, _options.DEFAULT_CHUNK)])


def _chunks(machine: Machine, poses: np.ndarray | PoseEvaluation, layout: StructureLayout,
            chunk_size: int) -> Iterator[tuple[slice, PKMStructure]]:
    n = len(poses.poses) if isinstance(poses, PoseEvaluation) else len(poses)
    for start in range(0, n, chunk_size):
        sl = slice(start, min(start + chunk_size, n))
        ev = poses.subset(sl) if isinstance(poses, PoseEvaluation) else structure_evaluation(
            machine, poses[sl], layout.options)
        yield sl, _structure_from_evaluation(machine, ev, layout)


def iter_structures(machine: Machine, poses: ArrayLike | PoseEvaluation | PKMStructure,
                    options: StructureOptions | None = None, chunk_size: int | None = None
                    ) -> Iterator[tuple[slice, PKMStructure]]:
    """``(slice, structure)`` for consecutive chunks of at most ``chunk_size`` poses (default
    :data:`~pkmstiff.structure.DEFAULT_CHUNK`; bounded memory) of poses ``(N, 6)``, of their evaluation, or of a
    built structure (its :meth:`~PKMStructure.parts`)."""
    size = _options.DEFAULT_CHUNK if chunk_size is None else chunk_size
    if size < 1:
        raise StructureModelError("iter_structures", "chunk_size", "an integer >= 1", chunk_size)
    if isinstance(poses, PKMStructure):
        yield from poses.parts(size)
        return
    src = poses if isinstance(poses, PoseEvaluation) else as_poses(poses)
    yield from _chunks(machine, src, structure_layout(machine, options), size)


def structure_summary(structure: PKMStructure) -> dict[str, Any]:
    """Bodies, DOF and bindings of the model (for reports and the README figure)."""
    m = structure.model
    return {
        "bodies": m.body_names, "dof": m.n_dof, "elements": m.element_names,
        "rigid_bindings": [b.name for b in m.bindings], "tcp_body": structure.tcp_body,
        "separate_spindle": structure.layout.separate_spindle,
        "massless_dofs": len(m.massless_dofs),
    }
