"""Static deflection of the structure model under its own weight and an optional load at the TCP (issue 17 item 4;
structure model of Cobet §4.2–4.7, static solve eq. 4.70–4.72; docs/theory/structure.md).

Gravity load (the masses of the structure model, :func:`pkmstiff.structure.structure_layout`), per pose:

* **loaded**: every body of the SDE model carries ``m g`` at its translational DOFs.  A rigid body's reference point
  is its centre of gravity (:mod:`pkmstiff.multibody.bodies`), so its weight is exactly ``(m g, 0)`` in its own
  DOFs, whatever its orientation: the platform (with the platform-side share of each strut, the platform joints'
  masses and, without a ``platform_spindle`` stiffness, the spindle merged into it), the spindle body (if separate;
  the Hexaglide's is massless) and the drive point masses at the drive joints (drive, guide carriage, drive
  suspension, drive-side strut share, drive-joint mass) wherever the drive is elastically suspended;
* **not loaded** (carried directly by the frame, so they cannot deflect the TCP in this model): the masses at rigidly
  suspended drives (a pod without ``drive_suspension`` stiffness: the drive, its joint and the drive-side strut
  share), and the machine frame itself (rigid, Assumption of the structure model).
* **Assumption** (of the structure model, the machine file's ``strut_mass_shares``): each strut's mass is lumped at
  its joints in the machine's shares — by default half at either joint, for a uniform straight strut between two
  spherical/universal joints the exact static equivalent of its distributed weight (moment balance about either
  end); none where the drive and platform masses already hold the struts (the Hexaglide, machines.md §1.7 item 10).
  The strut's own bending under its weight (a sag between the joints) does not move the joints and is ignored.

Then ``K q = f`` (stacked solves over the poses, :func:`pkmstiff.multibody.solve_static`) and the TCP motion
``(u, θ)`` of the tool body (spindle, or platform when merged).  Everything is linear: the deflection scales with
``|g|`` and with the load.  Gravity is the machine file's ``machine.gravity`` unless given.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

import pkmstiff.multibody as sde
from pkmstiff.admissibility.pipeline import PoseEvaluation
from pkmstiff.analysis._common import Array, by_parts, load_body
from pkmstiff.kinematics import as_poses
from pkmstiff.machine.model import Machine
from pkmstiff.multibody.assembly import stiffness_matrix
from pkmstiff.structure import (
    DEFAULT_CHUNK,
    NOT_POSITIVE_DEFINITE,
    PKMStructure,
    StructureModelError,
    StructureOptions,
    iter_structures,
)


def _gravity_vector(machine: Machine, gravity: ArrayLike | None) -> np.ndarray:
    g = np.asarray(machine.gravity if gravity is None else gravity, dtype=float)
    if g.shape != (3,) or not np.all(np.isfinite(g)):
        raise StructureModelError("gravity", "gravity", "a finite vector (3,) in m/s^2", gravity)
    return g


def gravity_load(st: PKMStructure, gravity: ArrayLike | None = None) -> Array:
    """Generalized gravity load f (M, n_dof) [N] of the modelled poses: ``m g`` at the translational DOFs of
    every body (rigid bodies are referred to their centre of gravity; module docstring for what is loaded)."""
    g = _gravity_vector(st.machine, gravity)
    model = st.model
    f = np.zeros((model.n_poses, model.n_dof))
    for body in model.bodies:
        s = model.dof_index(body.name)
        f[:, s.start:s.start + 3] = np.broadcast_to(body.mass, (model.n_poses,))[:, None] * g
    return f


def structure_deflection(st: PKMStructure, tool_length: float | ArrayLike | None = None,
                         gravity: ArrayLike | None = None, force: Any = (0.0, 0.0, 0.0),
                         moment: Any = (0.0, 0.0, 0.0), weight: bool = True) -> Array:
    """TCP motion (N, 6) [m, rad] of a built structure under gravity (``weight``) plus a force [N] and moment
    [N m] at the TCP: ``u = C_TCP-row(K⁻¹ f)``; NaN where a pose is not modelled.  ``tool_length`` as in
    :meth:`PKMStructure.tcp` (a vector (3,) in the PKS is any point of the tool body)."""
    def one(st: PKMStructure) -> Array:
        if st.empty:
            return st.scatter(np.zeros((0, 6)))
        body = load_body(st)
        tcp = st.tcp(tool_length)
        f = sde.point_load(st.model, body, tcp, force=force, moment=moment)
        if weight:
            f = f + gravity_load(st, gravity)
        q = sde.solve_static(st.model, f)
        return st.scatter(sde.point_motion(st.model, q, body, tcp))

    return by_parts(st, one)


def _not_pd(k: np.ndarray) -> np.ndarray:
    eig = np.linalg.eigvalsh(k)
    return ~(eig[:, 0] > 1e-13 * np.abs(eig[:, -1]))


def gravity_deflection(machine: Machine, poses: ArrayLike | PoseEvaluation | PKMStructure,
                       tool_length: float | ArrayLike | None = None,
                       gravity: ArrayLike | None = None, force: Any = (0.0, 0.0, 0.0),
                       moment: Any = (0.0, 0.0, 0.0), weight: bool = True,
                       options: StructureOptions | None = None, chunk_size: int = DEFAULT_CHUNK) -> Array:
    """TCP deflection (N, 6): translation [m] and rotation [rad] of the tool tip under the weight of the
    structure model (module docstring) plus an optional force [N] / moment [N m] at the TCP, at N poses: poses
    (N, 6), their :class:`~pkmstiff.admissibility.pipeline.PoseEvaluation`, or a structure built from them (then
    nothing is built again).

    Chunked over poses (memory ∝ chunk · n_dof²); NaN where a pose cannot be modelled (unreachable, singular,
    component out of range, stiffness not positive definite).  Raises :class:`StructureModelError` when the
    machine has no stiffness data.
    """
    x = poses.poses if isinstance(poses, (PoseEvaluation, PKMStructure)) else as_poses(poses)
    out = np.full((x.shape[0], 6), np.nan)
    for sl, st in iter_structures(machine, poses, options, chunk_size):
        for _ in range(3):
            try:
                out[sl] = structure_deflection(st, tool_length, gravity, force, moment, weight)
                break
            except sde.SingularModelError:
                st = st.without(_not_pd(np.ascontiguousarray(stiffness_matrix(st.model))), NOT_POSITIVE_DEFINITE)
    return out


__all__ = ["gravity_deflection", "gravity_load", "structure_deflection"]
