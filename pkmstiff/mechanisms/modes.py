"""Working and assembly modes of a mechanism configuration: a sign signature that changes only across a singularity.

The patent notes that a continuation in small steps from a known configuration finds the solution connected to it,
but that some structures can flip ("Umklappen") from one configuration into another (DE 10 2004 026 707 A1 [0018];
calibration.md §3).  Gosselin & Angeles (1990, "Singularity analysis of closed-loop kinematic chains", IEEE Trans.
Robot. Autom. 6(3)) separate the two kinds of flip: the inverse-kinematics Jacobian loses rank at a *serial* (type 1)
singularity — the boundary between working modes, e.g. the elbow of a five-bar leg — and the forward-kinematics
Jacobian at a *parallel* (type 2) singularity — the boundary between assembly modes, e.g. the bipod's struts in line;
Chablat & Wenger (1998, "Working modes and aspects in fully parallel manipulators", ICRA) define the working modes of
a leg by the sign of its Jacobian's determinant.  For the generic link-and-joint model this module reads both from
the solver's own equations:

1. the Jacobian F_q of the inverse (model + output equations) and of the forward kinematics (model + drive
   equations), over the free coordinates with rotations as incremental world-frame rotation vectors (continuous at
   every orientation), is made square by projecting each three-row constraint of rank 2 (common axis 1C, point on
   an axis 1E, output axis) on the two directions ⊥ its axis carried by link j (R_j b₁, R_j b₂): a continuous
   function of the configuration whose zeros are exactly the rank losses;
2. its rows and columns are permuted once per system to block-triangular form (a maximum matching of rows to
   columns, then the strongly connected components of the matched pattern: the Dulmage–Mendelsohn fine
   decomposition), so det F_q = ± Π det(A_ii), one diagonal block per leg or loop that can flip on its own;
3. the **signature** is the sign of every det(A_ii) — of the inverse and of the forward kinematics — with 0 where
   σ_min/σ_max of A_ii is below the solver's singular bound 1e-7 (on a singularity of that block).

Two configurations with a signature that differs in a nonzero entry are in different working or assembly modes:
every continuous path between them crosses a singularity.  A model whose projected system is not square
(an overconstrained linkage) has no signature (an empty one: nothing is compared).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pkmstiff.mechanisms.constraints import Frames, System, _perp, fk_system, ik_system
from pkmstiff.mechanisms.model import Mechanism

Array = NDArray[np.float64]

#: σ_min/σ_max of a diagonal block below this: the block is singular (signature entry 0) — the solver's default
#: ``singular_tol`` (:func:`pkmstiff.mechanisms.solver.inverse`), so a point flagged here is one the solver would
#: call singular were that block its whole system
ZERO = 1e-7
#: constraint kinds with three rows of rank 2 (in space): projected on the two directions ⊥ their axis
_RANK2 = ("1C", "1E", "out_axis")


@dataclass(frozen=True)
class _Plan:
    rows: np.ndarray  #: (n,) rows of the projected Jacobian in block order
    cols: np.ndarray  #: (n,) columns (free coordinates) in block order
    blocks: tuple[tuple[int, int], ...]  #: (start, stop) of every diagonal block in that order


def _projected(system: System, q: Array, target: Array | None) -> Array:
    """The solver's reduced Jacobian (N, m, n_free) with every rank-2 three-row constraint projected on two rows."""
    _, J = system.evaluate(q, target, reduced=True, omega=True)
    mech = system.mech
    if mech.dim == 2:
        return J
    F = Frames(q, 3, derivatives=False)
    off = system.n_fixed_rows
    parts, start = [], 0
    for b in system.blocks:
        if b.kind == "fixed":
            continue
        r0 = b.row0 - off
        if b.kind in _RANK2:
            parts.append(J[:, start:r0])
            B = np.stack([np.stack([p, np.cross(a, p)], axis=-1) for a in b.a for p in [_perp(a)]])  # (nc, 3, 2)
            W = F.R[:, b.j] @ B[None]  # (N, nc, 3, 2): the perpendiculars carried by link j
            rows = J[:, r0:r0 + b.rows].reshape(J.shape[0], b.n, 3, -1)
            parts.append(np.einsum("nkac,nkaf->nkcf", W, rows).reshape(J.shape[0], 2 * b.n, -1))
            start = r0 + b.rows
    parts.append(J[:, start:])
    return np.concatenate(parts, axis=1)


def _plan(system: System, pattern: np.ndarray) -> _Plan | None:
    """Block-triangular order of a square structural pattern (None: not square or structurally singular)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components, maximum_bipartite_matching

    m, n = pattern.shape
    if m != n:
        return None
    match = maximum_bipartite_matching(csr_matrix(pattern), perm_type="column")  # row i ↔ column match[i]
    if (match < 0).any():
        return None
    A = pattern[:, match]  # matched columns on the diagonal
    nb, label = connected_components(csr_matrix(A), directed=True, connection="strong")
    order = np.argsort(label, kind="stable")
    bounds = np.searchsorted(label[order], np.arange(nb + 1))
    return _Plan(order, match[order], tuple((int(bounds[i]), int(bounds[i + 1])) for i in range(nb)))


def _system_plan(system: System, q: Array, target: Array | None) -> _Plan | None:
    key = "_mode_plan"
    if key not in system.__dict__:
        J = _projected(system, q[:1], None if target is None else target[:1])
        rng = np.random.default_rng(0)  # a generic configuration: no structural zero hidden by a symmetric home
        qr = q[:1] + 1e-3 * rng.standard_normal(q[:1].shape)
        Jr = _projected(system, qr, None if target is None else target[:1])
        system.__dict__[key] = _plan(system, (J[0] != 0) | (Jr[0] != 0))
    return system.__dict__[key]


def _signs(system: System, q: Array, target: Array | None) -> Array:
    plan = _system_plan(system, q, target)
    if plan is None:
        return np.zeros((q.shape[0], 0), dtype=np.int8)
    J = _projected(system, q, target)[:, plan.rows][:, :, plan.cols]
    out = np.zeros((q.shape[0], len(plan.blocks)), dtype=np.int8)
    for i, (a, b) in enumerate(plan.blocks):
        A = J[:, a:b, a:b]
        sign = np.linalg.slogdet(A)[0]
        sv = np.linalg.svd(A, compute_uv=False)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[:, i] = np.where(sv[:, -1] >= ZERO * sv[:, 0], sign, 0)
    return out


def signature(mech: Mechanism, q: Array) -> Array:
    """(N, k) signs (−1, 0, +1) of the diagonal blocks of the inverse- and forward-kinematics Jacobians at the
    configurations q (N, L, d); 0 on a singularity of that block.  NaN configurations give 0."""
    from pkmstiff.mechanisms.solver import joint_values, output_pose

    q = np.asarray(q, dtype=float)
    good = np.isfinite(q).all(axis=(1, 2))
    qq = np.where(good[:, None, None], q, 0.0)
    parts = []
    if mech.output is not None:
        parts.append(_signs(ik_system(mech), qq, output_pose(mech, qq)))
    if mech.drives:
        drv = joint_values(mech, qq, [i for i, j in enumerate(mech.joints) if j.drive is not None])
        parts.append(_signs(fk_system(mech), qq, drv))
    out = np.concatenate(parts, axis=1) if parts else np.zeros((q.shape[0], 0), dtype=np.int8)
    out[~good] = 0
    return out


def reference(start: Array, first: Array) -> Array:
    """The mode a continuation keeps: the start's signature (k,), its zero entries (a start on a singularity, e.g.
    the hybrid's home at the wrist singularity) taken from ``first`` (k,), the first configuration solved from it."""
    return np.where(start != 0, start, first).astype(np.int8)


def other_mode(sig: Array, ref: Array) -> Array:
    """(N,) True where a signature (N, k) has a nonzero entry of the opposite sign to the reference (k,)."""
    return ((sig * ref[None]) < 0).any(axis=1)


def on_singularity(sig: Array, ref: Array) -> Array:
    """(N,) True where a block that is regular in the reference is singular (entry 0)."""
    return ((sig == 0) & (ref[None] != 0)).any(axis=1)
