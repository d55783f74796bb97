"""Rigid bindings eliminated by a null-space basis (docs/theory/structure.md, the preferred method).

Each binding gives constraint rows ``Φ q = 0`` (``Φ = P [G_a, −G_b]`` with ``P`` = axisᵀ, I3 or I6; for an angular
binding ``P = [0, axisᵀ]`` on ``G = N(Δ)``: the rotation rows only).  The basis
``Z`` (N, n, n − n_c) of the null space of Φ is the complement of ``Φᵀ``'s column space from a complete QR
factorisation; the reduced system is ``Zᵀ K Z``, ``Zᵀ M Z``, ``Zᵀ C Z``, ``Zᵀ f`` and ``q = Z q_r``.  Unlike a
penalty stiffness this is exact and produces no spurious modes.
"""

from __future__ import annotations

import numpy as np

from pkmstiff.errors import InputError
from pkmstiff.multibody.bodies import FRAME, RigidBody
from pkmstiff.multibody.linalg import reference_matrix, translation_matrix
from pkmstiff.multibody.system import SDEModel


def _side(model: SDEModel, name: str, point: np.ndarray, dim: int) -> tuple[slice | None, np.ndarray | None]:
    if name == FRAME:
        return None, None
    body = model.body(name)
    s = model.dof_index(name)
    if isinstance(body, RigidBody):
        delta = point - body.position
        return s, (translation_matrix(delta) if dim == 3 else reference_matrix(delta))
    return s, np.broadcast_to(np.eye(3), (1, 3, 3))


def constraint_matrix(model: SDEModel) -> np.ndarray:
    """Φ (N, n_c, n) of all rigid bindings."""
    n_p, n = model.n_poses, model.n_dof
    phi = np.zeros((n_p, model.n_constraints, n))
    row = 0
    for b in model.bindings:
        dim = 6 if b.kind in ("full", "angular") else 3
        for name, sign in ((b.body_a, 1.0), (b.body_b, -1.0)):
            s, g = _side(model, name, b.point, dim)
            if s is None:
                continue
            if b.kind in ("axial", "angular"):
                rows = (b.axis[:, None, :] @ g[:, -3:])[:, 0, :]  # axisᵀ G (translation or rotation rows)
                phi[:, row, s] += sign * rows
            else:
                phi[:, row:row + dim, s] += sign * g
        row += b.n_constraints
    return phi


def null_space_basis(model: SDEModel) -> np.ndarray | None:
    """Z (N, n, n − n_c) with Φ Z = 0 and Zᵀ Z = I, or None without rigid bindings."""
    n_c = model.n_constraints
    if n_c == 0:
        return None
    phi = constraint_matrix(model)
    q, r = np.linalg.qr(np.swapaxes(phi, 1, 2), mode="complete")
    diag = np.abs(np.diagonal(r[:, :n_c, :n_c], axis1=1, axis2=2))
    scale = np.abs(phi).max(axis=(1, 2))
    bad = np.nonzero(diag.min(axis=1) < 1e-10 * scale)[0]
    if bad.size:
        raise InputError("SDEModel", "rigid bindings", "independent constraints (no redundant rigid binding)",
                            f"dependent constraints at poses {bad[:10].tolist()}")
    return q[:, :, n_c:]
