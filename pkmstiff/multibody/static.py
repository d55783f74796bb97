"""Static analyses of the SDE model (docs/theory/structure.md, Cobet eq. 4.70–4.72).

Units: forces N, moments N m, displacements m, rotations rad; compliances m/N, rad/(N m) (mixed blocks m/(N m) =
rad/N); stiffnesses N/m and N m/rad.  All functions chunk over poses with ``chunk_size`` (memory ∝ chunk·n²).
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from pkmstiff.errors import InputError
from pkmstiff.multibody.assembly import element_deformations, element_energies, element_forces
from pkmstiff.multibody.bodies import RigidBody
from pkmstiff.multibody.inputs import common_poses, pose_array, take
from pkmstiff.multibody.linalg import reference_matrix
from pkmstiff.multibody.solver import StaticSystem
from pkmstiff.multibody.system import SDEModel

DEFAULT_CHUNK = 2048


def point_offset(model: SDEModel, body: str, point: Any | None) -> np.ndarray:
    """Offset Δ = point − body reference point (P, 3) in m; ``point=None`` means the reference point itself."""
    b = model.body(body)
    if point is None:
        return np.zeros((1, 3))
    pt = pose_array(point, (3,), f"point on body '{body}'", "point")
    common_poses([pt.shape[0], b.position.shape[0]], f"point on body '{body}'")
    return pt - b.position


def chunk_point(point: Any | None, sl: slice, source: str = "point") -> np.ndarray | None:
    """A point given for all poses ((3,) or (N, 3)) restricted to the poses of a chunk."""
    if point is None:
        return None
    return take(pose_array(point, (3,), source, "point"), sl)


def point_transform(model: SDEModel, body: str, point: Any | None) -> np.ndarray:
    """Map from body DOFs to the motion of a point: N(Δ) (P, 6, 6) for a rigid body (eq. 4.45), I3 for a point mass."""
    if isinstance(model.body(body), RigidBody):
        return reference_matrix(point_offset(model, body, point))
    return np.eye(3)[None]


def point_load(model: SDEModel, body: str, point: Any | None, force: Any = (0.0, 0.0, 0.0),
               moment: Any = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Generalized load vector f (N, n) of a force F (N) and moment M (N m) acting at ``point`` of ``body``.

    Rigid body: ``f_body = N(Δ)ᵀ (F, M) = (F, M + Δ × F)`` (Cobet eq. 4.71/4.72 with the transpose, spec Note:
    the load transformation is the transpose of the displacement reference matrix by virtual work).
    Point mass: ``f = F`` (a moment cannot act on a point mass).
    """
    source = f"load on body '{body}'"
    fv = pose_array(force, (3,), source, "force")
    mv = pose_array(moment, (3,), source, "moment")
    nmat = point_transform(model, body, point)
    n_p = max(model.n_poses, fv.shape[0], mv.shape[0], nmat.shape[0])
    out = np.zeros((n_p, model.n_dof))
    s = model.dof_index(body)
    if isinstance(model.body(body), RigidBody):
        wrench = np.concatenate(np.broadcast_arrays(fv, mv), axis=1)
        out[:, s] = np.einsum("nji,nj->ni", np.broadcast_to(nmat, (n_p, 6, 6)), np.broadcast_to(wrench, (n_p, 6)))
    else:
        if np.any(mv != 0):
            raise InputError(source, "moment", "zero moment on a point mass (3 translational DOF)", "non-zero")
        out[:, s] = fv
    return out


def point_motion(model: SDEModel, q: np.ndarray, body: str, point: Any | None = None) -> np.ndarray:
    """Motion of a point of a body for displacements q (N, [k,] n): (u, θ) (…, 6) rigid, u (…, 3) point mass."""
    q = np.asarray(q, dtype=float)
    qb = q[..., model.dof_index(body)]
    nmat = point_transform(model, body, point)
    nmat = nmat.reshape(nmat.shape[:1] + (1,) * (q.ndim - 2) + nmat.shape[1:])
    return (nmat @ qb[..., None])[..., 0]


def solve_static(model: SDEModel, f: np.ndarray, chunk_size: int = DEFAULT_CHUNK) -> np.ndarray:
    """Static displacements q = K⁻¹ f (solved, eq. 4.70) for loads f (N, n) or (N, n, r)."""
    f = np.asarray(f, dtype=float)
    n_p = max(model.n_poses, f.shape[0])
    out = np.zeros((n_p,) + f.shape[1:])
    for sl, sub in model.chunks(chunk_size, n_p):
        out[sl] = StaticSystem(sub).solve(f[sl] if f.shape[0] > 1 else f)
    return out


def _n_total(model: SDEModel, point: Any | None, body: str) -> int:
    """Number of poses of an analysis at a (possibly per-pose) point."""
    if point is None:
        return model.n_poses
    return max(model.n_poses, pose_array(point, (3,), f"point on body '{body}'", "point").shape[0])


def point_compliance(model: SDEModel, body: str, point: Any | None = None,
                     chunk_size: int = DEFAULT_CHUNK) -> np.ndarray:
    """Compliance at a point of a body (N, 6, 6) (rigid) or (N, 3, 3) (point mass).

    ``C = N(Δ) (K⁻¹)_bb N(Δ)ᵀ``: column j = motion (u, θ) of the point for a unit force (j < 3) or moment (j ≥ 3)
    at the point (for the TCP: ``point`` = tool tip on the spindle body).  Symmetric (Maxwell–Betti).
    """
    n_p = _n_total(model, point, body)
    d = model.body(body).n_dof
    out = np.zeros((n_p, d, d))
    for sl, sub in model.chunks(chunk_size, n_p):
        out[sl] = StaticSystem(sub).body_compliance(body, point_transform(sub, body, chunk_point(point, sl)))
    return out


def point_stiffness(model: SDEModel, body: str, point: Any | None = None,
                    chunk_size: int = DEFAULT_CHUNK) -> np.ndarray:
    """Stiffness at a point of a body (N, 6, 6)/(N, 3, 3) = inverse of :func:`point_compliance`.

    Computed without inversion as ``N(Δ)⁻ᵀ K_cond N(Δ)⁻¹`` with ``N(Δ)⁻¹ = N(−Δ)`` and the stiffness ``K_cond``
    statically condensed onto the body.  Translational block N/m, rotational N m/rad.
    """
    n_p = _n_total(model, point, body)
    d = model.body(body).n_dof
    out = np.zeros((n_p, d, d))
    for sl, sub in model.chunks(chunk_size, n_p):
        kc = StaticSystem(sub).condensed_stiffness(body)
        if d == 6:
            ninv = reference_matrix(-point_offset(sub, body, chunk_point(point, sl)))
            kc = np.swapaxes(ninv, 1, 2) @ kc @ ninv
        out[sl] = kc
    return out


def directional_stiffness(compliance: np.ndarray, direction: Any, rotational: bool = False) -> np.ndarray:
    """Stiffness in direction e: ``k_e = |F| / (e·u) = 1 / (eᵀ C e)`` for a unit force along e (docs/theory/structure.md).

    ``compliance`` (N, 6, 6) or (N, 3, 3); ``direction`` (3,) or (k, 3) (normalised here).  ``rotational=True``
    uses the rotational block (moment about e, rotation about e): N m/rad instead of N/m.  Returns (N,) or (N, k).
    """
    e = np.asarray(direction, dtype=float)
    single = e.ndim == 1
    e = np.atleast_2d(e)
    norm = np.linalg.norm(e, axis=1)
    if np.any(norm == 0) or e.shape[1] != 3:
        raise InputError("directional_stiffness", "direction", "non-zero vectors of shape (3,) or (k, 3)", e.shape)
    e = e / norm[:, None]
    block = compliance[:, 3:, 3:] if rotational else compliance[:, :3, :3]
    if rotational and compliance.shape[-1] != 6:
        raise InputError("directional_stiffness", "rotational", "a 6x6 compliance", compliance.shape)
    k = 1.0 / np.einsum("ki,nij,kj->nk", e, block, e)
    return k[:, 0] if single else k


def axis_stiffness(compliance: np.ndarray) -> np.ndarray:
    """Directional stiffnesses along x, y, z (N/m) and, for 6×6 compliances, about x, y, z (N m/rad): (N, 3|6)."""
    diag = np.diagonal(compliance, axis1=1, axis2=2)
    return 1.0 / diag


def body_displacements(model: SDEModel, q: np.ndarray) -> dict[str, np.ndarray]:
    """Displacement of every body, ``{name: (N, 3|6)}`` (u in m, θ in rad)."""
    return {n: np.asarray(q)[..., model.dof_index(n)] for n in model.body_names}


def sde_deformations(model: SDEModel, q: np.ndarray) -> dict[str, np.ndarray]:
    """Deformation ``l`` of every SDE, ``{name: (N, 3|6)}`` (m, rad)."""
    out = {}
    for s, lv in zip(model.sets, element_deformations(model, q)):
        for e, name in enumerate(s.names):
            out[name] = lv[..., e, :]
    return out


def sde_forces(model: SDEModel, q: np.ndarray) -> dict[str, np.ndarray]:
    """Force ``K l`` of every SDE, ``{name: (N, 3|6)}`` (N, N m), acting on its side b (−: on side a)."""
    out = {}
    for s, fv in zip(model.sets, element_forces(model, q)):
        for e, name in enumerate(s.names):
            out[name] = fv[..., e, :]
    return out


Groups = None | str | Mapping[str, Sequence[str]]


def group_matrix(model: SDEModel, groups: Groups) -> tuple[list[str], np.ndarray]:
    """Labels and 0/1 matrix (n_elements, n_groups) summing element values into groups.

    ``groups``: None = every element on its own; ``"group"`` = the ``group`` given when the elements were added;
    a mapping ``{label: [element names]}`` (every element at most once; elements not listed form ``"other"``).
    """
    names = model.element_names
    if groups is None:
        return names, np.eye(len(names))
    if groups == "group":
        labels = list(dict.fromkeys(model.element_groups))
        mat = np.array([[g == lab for lab in labels] for g in model.element_groups], dtype=float)
        return labels, mat
    if isinstance(groups, str):
        raise InputError("groups", "groups", "None, 'group' or a mapping label -> element names", groups)
    labels = list(groups)
    index = {n: i for i, n in enumerate(names)}
    mat = np.zeros((len(names), len(labels) + 1))
    for j, lab in enumerate(labels):
        for n in groups[lab]:
            if n not in index:
                raise InputError("groups", lab, f"element names from {names}", n)
            if mat[index[n]].any():
                raise InputError("groups", lab, "each element in at most one group", n)
            mat[index[n], j] = 1.0
    rest = mat.sum(axis=1) == 0
    mat[rest, -1] = 1.0
    if rest.any():
        labels.append("other")
    else:
        mat = mat[:, :-1]
    return labels, mat


def energy_shares(model: SDEModel, q: np.ndarray, groups: Groups = None) -> tuple[list[str], np.ndarray]:
    """Share of each SDE (or group) in the total strain energy ``Σ ½ lᵀ K l`` for displacements q: (N, ..., k).

    For a static load the total strain energy is ``½ fᵀ q``, so the shares split the compliance in the load
    direction among the elements ("weak points"); they sum to 1.
    """
    energy = element_energies(model, q)
    labels, mat = group_matrix(model, groups)
    grouped = energy @ mat
    total = grouped.sum(axis=-1, keepdims=True)
    return labels, grouped / np.where(total > 0, total, 1.0)


def weak_points(model: SDEModel, body: str, point: Any | None, direction: Any, groups: Groups = None,
                moment: bool = False, chunk_size: int = DEFAULT_CHUNK) -> tuple[list[str], np.ndarray]:
    """Strain-energy shares of the SDEs (or groups) for a unit force (``moment=True``: unit moment) along
    ``direction`` at ``point`` of ``body``: each element's share of the compliance ``e·u`` in that direction."""
    e = np.asarray(direction, dtype=float)
    e = e / np.linalg.norm(e)
    load = point_load(model, body, point, moment=e) if moment else point_load(model, body, point, force=e)
    q = solve_static(model, load, chunk_size)
    return energy_shares(model, q, groups)
