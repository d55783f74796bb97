"""Multi-part FE models: parts meshed in local frames, rigid placements, ties, supports, reference points.

A :class:`PartModel` is built once (bases and part stiffness matrices assembled in the parts' local
frames) and then solved for any placement of its part groups (e.g. the strut-side group of a joint rotated
by the tilt angle): a rigidly rotated part has the stiffness Q K Q^T, so only the ties between moving and
fixed groups have to be rebuilt per configuration. :meth:`PartModel.condense` returns the Guyan-condensed
stiffness at the reference points (6 DOF each: ux, uy, uz [m], rx, ry, rz [rad] about the global axes).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np
import scipy.sparse as sp
from skfem import CellBasis, MeshHex

from pkmstiff.errors import NumericalError
from pkmstiff.fe.coupling import Condensation, ConstraintSet, guyan, rbe2_rows
from pkmstiff.fe.elasticity import ElementName, rotate_stiffness, scalar_basis, stiffness_matrix
from pkmstiff.fe.materials import Material
from pkmstiff.fe.ties import tie

Selector = Callable[[np.ndarray], np.ndarray]  # local node coordinates (3, n) -> boolean mask (n,)
Placement = tuple[np.ndarray, np.ndarray]  # (R (3, 3), t (3,)): x_global = R x_local + t


@dataclass(frozen=True)
class Part:
    """A meshed solid in its local frame; parts of one ``group`` move together."""

    name: str
    mesh: MeshHex
    material: Material
    group: str = "base"


@dataclass(frozen=True)
class Tie:
    """Bond the ``slave`` part's surface nodes lying within ``tol`` [m] of the ``master`` part."""

    slave: str
    master: str
    tol: float


@dataclass(frozen=True)
class NodeSet:
    """Nodes of ``part`` selected by ``selector`` applied to the local node coordinates."""

    part: str
    selector: Selector
    boundary_only: bool = True


@dataclass(frozen=True)
class ReferencePoint:
    """RBE2 reference point coupled rigidly to ``nodes``; ``point`` in the local frame of the nodes' part.

    ``fixed``: reference DOFs (0..5 = ux, uy, uz, rx, ry, rz) held at zero; ``retain``: keep the free DOFs
    in the condensed matrix (else they are condensed out, i.e. unloaded).
    """

    name: str
    point: tuple[float, float, float]
    nodes: NodeSet
    fixed: tuple[int, ...] = ()
    retain: bool = True


@dataclass
class Solution:
    """Result of one configuration: condensed stiffness and the data to recover displacement fields."""

    K: np.ndarray  # condensed stiffness over the retained reference DOFs
    retained: list[tuple[str, int]]  # (reference point, dof 0..5) per row of K
    condensation: Condensation
    T: sp.csr_matrix
    placements: dict[str, Placement]
    n_fe_dofs: int
    tie_counts: dict[str, int] = field(default_factory=dict)

    def reference_matrix(self, name: str) -> np.ndarray:
        """Condensed block of one reference point (its retained DOFs)."""
        idx = [i for i, (r, _) in enumerate(self.retained) if r == name]
        return self.K[np.ix_(idx, idx)]

    def displacement(self, retained_displacement: np.ndarray) -> np.ndarray:
        """All DOFs (FE DOFs, then 6 per reference point) for given retained-DOF displacements."""
        return self.T @ (self.condensation.recovery @ np.asarray(retained_displacement, float))


class PartModel:
    """Assembly of parts joined by ties, supported by fixed node sets / reference points."""

    def __init__(self, parts: Sequence[Part], ties: Sequence[Tie] = (), clamps: Sequence[NodeSet] = (),
                 references: Sequence[ReferencePoint] = (), element: ElementName = "hex20") -> None:
        names = [p.name for p in parts]
        if len(set(names)) != len(names):
            raise ValueError(f"part names must be unique, found {names}")
        self.parts = {p.name: p for p in parts}
        self.ties = list(ties)
        self.clamps = list(clamps)
        self.references = list(references)
        self.element = element
        for t in self.ties:
            for side in (t.slave, t.master):
                if side not in self.parts:
                    raise ValueError(f"tie {t.slave}->{t.master}: unknown part '{side}' (parts: {names})")
        self.bases: dict[str, CellBasis] = {}
        self.K_local: dict[str, sp.csr_matrix] = {}
        self.offset: dict[str, int] = {}
        self.boundary: dict[str, np.ndarray] = {}
        n = 0
        for p in parts:
            b = scalar_basis(p.mesh, element)
            self.bases[p.name] = b
            self.K_local[p.name] = stiffness_matrix(b, p.material)
            self.offset[p.name] = n
            self.boundary[p.name] = np.unique(b.get_dofs().all())
            n += 3 * b.N
        self.n_fe = n
        self._check_connected()
        self.groups = sorted({p.group for p in parts})
        # ties inside one group do not depend on the placement: located once
        self._tie_cache: dict[tuple[str, str, float], tuple[np.ndarray, sp.csr_matrix]] = {}

    def _check_connected(self) -> None:
        """Every part must reach a support (clamp or reference point with fixed DOFs) through ties."""
        supported = {c.part for c in self.clamps} | {r.nodes.part for r in self.references if r.fixed}
        adj: dict[str, set[str]] = {name: set() for name in self.parts}
        for t in self.ties:
            adj[t.slave].add(t.master)
            adj[t.master].add(t.slave)
        seen, todo = set(supported), list(supported)
        while todo:
            for nb in adj[todo.pop()] - seen:
                seen.add(nb)
                todo.append(nb)
        loose = sorted(set(self.parts) - seen)
        if loose:
            raise NumericalError(f"part(s) {', '.join(loose)} not connected by ties to any support "
                                  "(clamp or reference point with fixed DOFs): the FE system would be singular")

    @property
    def n_nodes(self) -> int:
        return self.n_fe // 3

    def nodes(self, part: str) -> np.ndarray:
        """Local node coordinates (3, N) of a part."""
        return self.bases[part].doflocs

    def select(self, ns: NodeSet) -> np.ndarray:
        """Node indices (within the part) of a node set; raises if the set is empty."""
        if ns.part not in self.parts:
            raise ValueError(f"node set: unknown part '{ns.part}'")
        cand = self.boundary[ns.part] if ns.boundary_only else np.arange(self.bases[ns.part].N)
        sel = cand[np.asarray(ns.selector(self.nodes(ns.part)[:, cand]), bool)]
        if sel.size == 0:
            raise ValueError(f"node set on part '{ns.part}' selects no node")
        return sel

    def _dofs(self, part: str, nodes: np.ndarray) -> np.ndarray:
        return (self.offset[part] + 3 * np.asarray(nodes)[:, None] + np.arange(3)).ravel()

    def global_nodes(self, part: str, placements: Mapping[str, Placement]) -> np.ndarray:
        R, t = _placement(placements, self.parts[part].group)
        return R @ self.nodes(part) + t[:, None]

    def stiffness(self, placements: Mapping[str, Placement]) -> sp.csr_matrix:
        """Block-diagonal FE stiffness of all parts in their placed (global) orientation."""
        blocks = []
        for name, p in self.parts.items():
            R, _ = _placement(placements, p.group)
            K = self.K_local[name]
            blocks.append(K if np.allclose(R, np.eye(3)) else rotate_stiffness(K, R))
        return sp.block_diag(blocks, format="csr")

    def condense(self, placements: Mapping[str, Placement] | None = None,
                 permc_spec: str = "MMD_AT_PLUS_A") -> Solution:
        """Guyan-condensed stiffness at the retained reference DOFs for the given group placements."""
        placements = dict(placements or {})
        n_ref = len(self.references)
        n = self.n_fe + 6 * n_ref
        cs = ConstraintSet(n)
        ref_index = {r.name: self.n_fe + 6 * i for i, r in enumerate(self.references)}
        # supports first (a fixed DOF keeps no dependency), then rigid couplings, then ties
        for c in self.clamps:
            cs.fix(self._dofs(c.part, self.select(c)))
        for r in self.references:
            cs.fix(ref_index[r.name] + np.asarray(r.fixed, int))
        for r in self.references:
            nodes = self.select(r.nodes)
            xs = self.global_nodes(r.nodes.part, placements)[:, nodes]
            xr = self._reference_position(r, placements)
            C = rbe2_rows(xs, xr)  # (n, 3, 6)
            cols = ref_index[r.name] + np.arange(6)
            m = nodes.size
            rows = np.repeat(np.arange(3 * m), 6)
            Cm = sp.csr_matrix((C.reshape(3 * m, 6).ravel(), (rows, np.tile(cols, 3 * m))), shape=(3 * m, n))
            cs.add(self._dofs(r.nodes.part, nodes), Cm)
        counts: dict[str, int] = {}
        for tspec in self.ties:
            counts[f"{tspec.slave}->{tspec.master}"] = self._add_tie(cs, tspec, placements, n)
        T, free = cs.transformation()
        K = sp.block_diag([self.stiffness(placements), sp.csr_matrix((6 * n_ref, 6 * n_ref))], format="csr")
        Kq = (T.T @ K @ T).tocsr()
        col_of = {dof: j for j, dof in enumerate(free)}
        retained, labels = [], []
        for r in self.references:
            if not r.retain:
                continue
            for d in range(6):
                dof = ref_index[r.name] + d
                if dof in col_of:
                    retained.append(col_of[dof])
                    labels.append((r.name, d))
        if not retained:
            raise ValueError("no retained reference DOF: add a ReferencePoint with retain=True")
        cond = guyan(Kq, np.array(retained), permc_spec=permc_spec)
        self._check_regular(cond.K, labels)
        return Solution(cond.K, labels, cond, T, placements, self.n_fe, counts)

    def _check_regular(self, K: np.ndarray, labels: list[tuple[str, int]]) -> None:
        """The condensed matrix must be positive definite (rotations scaled by the model size to compare)."""
        pts = np.hstack([self.nodes(name) for name in self.parts])
        size = float(np.linalg.norm(pts.max(axis=1) - pts.min(axis=1)))
        scale = np.array([1.0 if d < 3 else 1.0 / size for _, d in labels])
        w = np.linalg.eigvalsh(scale[:, None] * K * scale[None, :])
        if w.min() <= 1e-10 * w.max():
            raise NumericalError("FE system is singular: the supports leave a rigid-body motion of the reference "
                                  "point(s) free (condensed stiffness not positive definite)")

    def _reference_position(self, r: ReferencePoint, placements: Mapping[str, Placement]) -> np.ndarray:
        R, t = _placement(placements, self.parts[r.nodes.part].group)
        return R @ np.asarray(r.point, float) + t

    def _add_tie(self, cs: ConstraintSet, t: Tie, placements: Mapping[str, Placement], n: int) -> int:
        slave_nodes = self.boundary[t.slave]
        key = (t.slave, t.master, t.tol)
        if key in self._tie_cache:
            hit, W = self._tie_cache[key]
        else:
            xs = self.global_nodes(t.slave, placements)[:, slave_nodes]
            Rm, tm = _placement(placements, self.parts[t.master].group)
            xs_in_master = Rm.T @ (xs - tm[:, None])
            hit, W = tie(xs_in_master, self.bases[t.master], t.tol)
            if self.parts[t.slave].group == self.parts[t.master].group:
                self._tie_cache[key] = (hit, W)
        if hit.size == 0:
            raise NumericalError(
                f"tie {t.slave}->{t.master}: no node of '{t.slave}' lies within {t.tol * 1e3:g} mm of "
                f"'{t.master}' (parts not touching?)")
        m = hit.size
        # component-wise interpolation: slave dof 3 s + i = sum_b W[s, b] * master dof 3 b + i
        W = W.tocoo()
        rows = (3 * W.row[:, None] + np.arange(3)).ravel()
        cols = (self.offset[t.master] + 3 * W.col[:, None] + np.arange(3)).ravel()
        vals = np.repeat(W.data, 3)
        Cm = sp.csr_matrix((vals, (rows, cols)), shape=(3 * m, n))
        return cs.add(self._dofs(t.slave, slave_nodes[hit]), Cm) // 3


def _placement(placements: Mapping[str, Placement], group: str) -> Placement:
    if group in placements:
        R, t = placements[group]
        return np.asarray(R, float), np.asarray(t, float)
    return np.eye(3), np.zeros(3)
