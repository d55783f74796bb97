"""Assembly of the global stiffness, damping and mass matrices (docs/theory/structure.md).

Every SDE contributes by the congruence rule (Cobet eq. 4.58–4.69): with ``l = G_a q_a − G_b q_b`` and
``G_ab = [G_a, −G_b]``, the element block ``G_abᵀ K G_ab`` is added to the rows/columns of the DOFs of a and b,
i.e. ``K_aa += G_aᵀKG_a``, ``K_bb += G_bᵀKG_b``, ``K_ab −= G_aᵀKG_b``, ``K_ba −= G_bᵀKG_a``.
Each SDE set is handled by two batched matrix products (one outer product for axial elements); quadrants with
the same target bodies are summed over the elements and added with one slice operation each (no per-pose loops;
per chunk a handful of operations per set).  The matrices are built pose-last and returned as (N, n, n) views.
"""

from __future__ import annotations

import numpy as np

from pkmstiff.multibody.bodies import FRAME, RigidBody
from pkmstiff.multibody.elements import MatrixSpec, SDESet
from pkmstiff.multibody.linalg import reference_matrix, translation_matrix
from pkmstiff.multibody.system import SDEModel


def _side_dofs(model: SDEModel, name: str) -> np.ndarray:
    if name == FRAME:
        return np.zeros(0, dtype=int)
    s = model.dof_index(name)
    return np.arange(s.start, s.stop)


def set_dofs(model: SDEModel, sde_set: SDESet) -> np.ndarray:
    """(E, m) global DOF indices of ``[q_a, q_b]`` per element (frame sides contribute none)."""
    return np.array([np.concatenate([_side_dofs(model, a), _side_dofs(model, b)])
                     for a, b in zip(sde_set.body_a, sde_set.body_b)], dtype=int)


def _side_matrix(model: SDEModel, names: tuple[str, ...], point: np.ndarray, dim: int) -> np.ndarray | None:
    """G of one side for all elements of a set: (P, E, dim, n_side) or None for the frame."""
    first = names[0]
    if first == FRAME:
        return None
    body = model.body(first)
    if not isinstance(body, RigidBody):
        return np.broadcast_to(np.eye(3), (1, len(names), 3, 3))
    pos = [model.body(n).position for n in names]  # each (P_i, 3)
    n_p = max(p.shape[0] for p in pos)
    ref = np.stack([np.broadcast_to(p, (n_p, 3)) for p in pos], axis=1)  # (P, E, 3)
    delta = point - ref
    return translation_matrix(delta) if dim == 3 else reference_matrix(delta)


def set_kinematics(model: SDEModel, sde_set: SDESet) -> np.ndarray:
    """``G_ab = [G_a, −G_b]`` of every element of a set: (P, E, d, m), so that ``l = G_ab [q_a; q_b]``."""
    ga = _side_matrix(model, sde_set.body_a, sde_set.point, sde_set.dim)
    gb = _side_matrix(model, sde_set.body_b, sde_set.point, sde_set.dim)
    parts = [g for g in (ga, None if gb is None else -gb) if g is not None]
    n_p = max(p.shape[0] for p in parts)
    parts = [np.broadcast_to(p, (n_p,) + p.shape[1:]) for p in parts]
    return np.concatenate(parts, axis=-1)


def scatter_plan(model: SDEModel) -> list[list[tuple[slice, slice, int | slice | np.ndarray, slice, slice]]]:
    """Per set: (block rows, block cols, elements, global rows, global cols) for every target block (cached).

    The quadrants aa, ab, ba, bb of the element blocks are summed over all elements of the set with the same
    target bodies (e.g. the platform–platform quadrant of six struts) and added with one slice operation.
    """

    def build() -> list[list[tuple[slice, slice, int | slice | np.ndarray, slice, slice]]]:
        plan = []
        for s in model.sets:
            def side(name: str) -> slice | None:
                return None if name == FRAME else model.dof_index(name)

            da = 0 if s.body_a[0] == FRAME else model.body(s.body_a[0]).n_dof
            local = {"a": slice(0, da), "b": slice(da, None)}
            entries: dict[tuple[str, str, int, int, int, int], list[int]] = {}
            for e, (a, b) in enumerate(zip(s.body_a, s.body_b)):
                for qa, qb, na, nb in (("a", "a", a, a), ("a", "b", a, b), ("b", "a", b, a), ("b", "b", b, b)):
                    ra, rb = side(na), side(nb)
                    if ra is not None and rb is not None:
                        entries.setdefault((qa, qb, ra.start, ra.stop, rb.start, rb.stop), []).append(e)
            items = []
            for (qa, qb, r0, r1, c0, c1), els in entries.items():
                idx: int | slice | np.ndarray = np.array(els)
                if len(els) == 1:
                    idx = els[0]
                elif els == list(range(els[0], els[-1] + 1)):
                    idx = slice(els[0], els[-1] + 1)
                items.append((local[qa], local[qb], idx, slice(r0, r1), slice(c0, c1)))
            plan.append(items)
        return plan

    return model.cached("scatter_plan", build)


def _set_blocks_pose_last(model: SDEModel, s: SDESet, spec: MatrixSpec) -> np.ndarray:
    """Element blocks ``G_abᵀ K G_ab`` of one set in pose-last layout (E, m, m, P)."""
    g = set_kinematics(model, s)  # (P, E, d, m)
    if spec.matrix is None:  # k n nᵀ: rank one, h = nᵀ G_ab
        h = np.moveaxis((spec.axis[..., None, :] @ g)[..., 0, :], 0, -1)  # (E, m, P)
        k = np.moveaxis(spec.k, 0, -1)[:, None, None, :]
        return k * h[:, :, None, :] * h[:, None, :, :]
    blk = np.swapaxes(g, -1, -2) @ (spec.matrix @ g)
    return np.ascontiguousarray(np.moveaxis(blk, 0, -1))


def _assemble(model: SDEModel, which: str) -> np.ndarray:
    """Dense (N, n, n) matrix; built in pose-last layout (long contiguous inner loops) and returned as a view."""
    n_p, n = model.n_poses, model.n_dof
    out = np.zeros((n, n, n_p))
    for s, items in zip(model.sets, scatter_plan(model)):
        spec = s.stiffness if which == "stiffness" else s.damping
        if spec is None:
            continue
        blk = _set_blocks_pose_last(model, s, spec)  # (E, m, m, P)
        for rows, cols, els, grow, gcol in items:
            part = blk[els, rows, cols]
            out[grow, gcol] += part.sum(axis=0) if part.ndim == 4 else part
    return out.transpose(2, 0, 1)


def stiffness_matrix(model: SDEModel, poses: slice | None = None) -> np.ndarray:
    """Global stiffness matrix K (N, n, n) in N/m, N and N m/rad (docs/theory/structure.md), for all poses or the slice ``poses``.

    Memory N·n²·8 bytes: iterate ``for sl, sub in model.chunks(size)`` for large batches.  The result is a
    (pose-strided) view; use ``np.ascontiguousarray`` if C order is needed.
    """
    return _assemble(model if poses is None else model.poses(poses), "stiffness")


def damping_matrix(model: SDEModel, poses: slice | None = None) -> np.ndarray:
    """Global damping matrix C (N, n, n) in N s/m, N s, N m s/rad from the SDE damping (zero where none is given)."""
    return _assemble(model if poses is None else model.poses(poses), "damping")


def has_damping(model: SDEModel) -> bool:
    return any(s.damping is not None for s in model.sets)


def mass_blocks(model: SDEModel) -> list[tuple[slice, np.ndarray]]:
    """Diagonal mass blocks ``(dof slice, (N, d, d))``: ``m I3`` resp. ``diag(m I3, I_cg)`` (docs/theory/structure.md)."""
    n_p = model.n_poses
    out = []
    for b in model.bodies:
        s = model.dof_index(b.name)
        blk = np.zeros((n_p, b.n_dof, b.n_dof))
        blk[:, [0, 1, 2], [0, 1, 2]] = b.mass[:, None]
        if isinstance(b, RigidBody):
            blk[:, 3:, 3:] = b.inertia
        out.append((s, blk))
    return out


def mass_matrix(model: SDEModel, poses: slice | None = None) -> np.ndarray:
    """Global block-diagonal mass matrix M (N, n, n) in kg and kg m² (docs/theory/structure.md)."""
    model = model if poses is None else model.poses(poses)
    n = model.n_dof
    out = np.zeros((model.n_poses, n, n))
    for s, blk in mass_blocks(model):
        out[:, s, s] = blk
    return out


def _expand(arr: np.ndarray, extra: int) -> np.ndarray:
    """Insert ``extra`` axes after the pose axis (to broadcast against e.g. a mode axis)."""
    return arr.reshape(arr.shape[:1] + (1,) * extra + arr.shape[1:])


def element_deformations(model: SDEModel, q: np.ndarray) -> list[np.ndarray]:
    """Deformation ``l = G_a q_a − G_b q_b`` of every element, one (N, ..., E, d) array per set (m, rad).

    ``q`` (N, n) or (N, k, n) (e.g. k mode shapes); extra axes are carried along.
    """
    q = np.asarray(q, dtype=float)
    extra = q.ndim - 2
    out = []
    for s in model.sets:
        g = _expand(set_kinematics(model, s), extra)
        qe = q[..., set_dofs(model, s)]  # (N, ..., E, m)
        out.append((g @ qe[..., None])[..., 0])
    return out


def element_forces(model: SDEModel, q: np.ndarray) -> list[np.ndarray]:
    """Element forces ``K l`` (N, ..., E, d) per set, in N (and N m for the rotational part of 6×6 elements).

    Sign: the force the element exerts on side b (side a receives the opposite).
    """
    q = np.asarray(q, dtype=float)
    return [(_expand(s.stiffness.full(), q.ndim - 2) @ lv[..., None])[..., 0]
            for s, lv in zip(model.sets, element_deformations(model, q))]


def element_energies(model: SDEModel, q: np.ndarray) -> np.ndarray:
    """Strain energy ``½ lᵀ K l`` of every element (N, ..., n_elements) in J (order of ``model.element_names``)."""
    q = np.asarray(q, dtype=float)
    parts = []
    for lv, fv in zip(element_deformations(model, q), element_forces(model, q)):
        parts.append(0.5 * np.einsum("...i,...i->...", lv, fv))
    return np.concatenate(parts, axis=-1)
