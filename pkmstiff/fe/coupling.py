"""Rigid interface coupling (RBE2-like), constraint transformation and Guyan static condensation.

scikit-fem has no multi-point constraints, so all couplings are imposed by a transformation of the FE
system: the DOF vector u (FE DOFs followed by 6 DOFs per reference point) is written as u = T q, where q
holds the independent, non-fixed DOFs; the reduced stiffness is K_q = T^T K T.

* RBE2: a slave node s follows the rigid-body motion of its reference point r,
  u_s = u_r + theta_r x (x_s - x_r) (small rotations about the global axes).
* Ties (:mod:`pkmstiff.fe.ties`): u_s = sum_b N_b u_b.
* Fixed DOFs are removed from q (u = 0).

Guyan (static) condensation onto the retained DOFs a (the reference-point DOFs):
K_c = K_aa - K_ao K_oo^{-1} K_oa, exact for loads applied only at a.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from pkmstiff.errors import NumericalError


def rbe2_rows(slave_points: np.ndarray, ref_point: np.ndarray) -> np.ndarray:
    """Coefficients (n, 3, 6) of the rigid coupling u_s = u_r + theta x (x_s - x_r) for slave points (3, n)."""
    d = slave_points - np.asarray(ref_point, float).reshape(3, 1)
    n = d.shape[1]
    C = np.zeros((n, 3, 6))
    C[:, 0, 0] = C[:, 1, 1] = C[:, 2, 2] = 1.0
    # theta x d = (ty dz - tz dy, tz dx - tx dz, tx dy - ty dx)
    C[:, 0, 4], C[:, 0, 5] = d[2], -d[1]
    C[:, 1, 3], C[:, 1, 5] = -d[2], d[0]
    C[:, 2, 3], C[:, 2, 4] = d[1], -d[0]
    return C


@dataclass
class ConstraintSet:
    """Accumulates dependent DOFs u_d = C_d u (first definition of a DOF wins) and fixed DOFs u = 0."""

    n_dofs: int

    def __post_init__(self) -> None:
        self._dep: list[np.ndarray] = []
        self._rows: list[sp.csr_matrix] = []
        self._taken = np.zeros(self.n_dofs, dtype=bool)
        self.fixed = np.zeros(self.n_dofs, dtype=bool)

    def is_dependent(self, dofs: np.ndarray) -> np.ndarray:
        return self._taken[dofs]

    def fix(self, dofs: np.ndarray) -> None:
        """Fix DOFs to zero (a fixed DOF keeps no dependency)."""
        self.fixed[np.asarray(dofs, int)] = True

    def add(self, dependent: np.ndarray, C: sp.spmatrix) -> int:
        """Add u[dependent] = C @ u; rows for DOFs already dependent or fixed are skipped. Returns rows added."""
        dependent = np.asarray(dependent, int)
        C = sp.csr_matrix(C)
        keep = ~(self._taken[dependent] | self.fixed[dependent])
        if not np.any(keep):
            return 0
        dep = dependent[keep]
        self._taken[dep] = True
        self._dep.append(dep)
        self._rows.append(C[np.flatnonzero(keep)])
        return int(dep.size)

    def transformation(self, max_depth: int = 32) -> tuple[sp.csr_matrix, np.ndarray]:
        """T (n_dofs, n_q) with u = T q, and the DOF index of each column of T (independent, non-fixed)."""
        n = self.n_dofs
        dep = np.concatenate(self._dep) if self._dep else np.zeros(0, int)
        dep_mask = np.zeros(n, bool)
        dep_mask[dep] = True
        indep = np.flatnonzero(~dep_mask)
        ident = sp.csr_matrix((np.ones(indep.size), (indep, indep)), shape=(n, n))
        if dep.size:
            Crows = sp.vstack(self._rows).tocsr()
            D = sp.csr_matrix((np.ones(dep.size), (dep, np.arange(dep.size))), shape=(n, dep.size))
            A = (ident + D @ Crows).tocsr()
        else:
            A = ident
        # substitute dependent DOFs that refer to other dependent DOFs (chains of ties) until none remain
        dep_cols = sp.diags(dep_mask.astype(float), format="csr")
        for _ in range(max_depth):
            if (A @ dep_cols).nnz == 0:
                break
            A = (A @ A).tocsr()
            A.eliminate_zeros()
        else:
            raise NumericalError(f"constraint chains deeper than {max_depth} levels or cyclic (tie loops)")
        A.data[np.abs(A.data) < 1e-14] = 0.0
        A.eliminate_zeros()
        free = indep[~self.fixed[indep]]
        return A[:, free].tocsr(), free


@dataclass
class Condensation:
    """Guyan condensation of a reduced system onto retained DOFs.

    ``K`` (n_a, n_a) condensed stiffness [N/m, N, N m/rad]; ``recovery`` (n_q, n_a) maps retained
    displacements to all reduced DOFs q (the retained ones included).
    """

    K: np.ndarray
    recovery: np.ndarray


def guyan(Kq: sp.spmatrix, retained: np.ndarray, permc_spec: str = "MMD_AT_PLUS_A") -> Condensation:
    """Static condensation of the symmetric positive definite ``Kq`` onto the DOFs ``retained`` (indices into q).

    Sparse LU (SuperLU) in symmetric mode without pivoting: the minimum-degree ordering of A + A^T
    (default) gave 2-3x less fill and time than COLAMD on the joint models.
    """
    Kq = sp.csr_matrix(Kq)
    n = Kq.shape[0]
    retained = np.asarray(retained, int)
    other = np.setdiff1d(np.arange(n), retained)
    Koo = Kq[other][:, other].tocsc()
    Koa = Kq[other][:, retained].toarray()
    Kaa = Kq[retained][:, retained].toarray()
    try:
        lu = spla.splu(Koo, permc_spec=permc_spec, diag_pivot_thresh=0.0, options={"SymmetricMode": True})
        X = lu.solve(Koa)
    except RuntimeError as exc:
        raise NumericalError(
            "FE system is singular after coupling: a part is not connected (check the ties) or not supported"
        ) from exc
    pivots = np.abs(lu.U.diagonal())
    if pivots.size and pivots.min() <= 1e-12 * pivots.max():
        raise NumericalError(
            "FE system is singular after coupling (zero pivot): the supports leave a rigid-body motion free")
    if not np.all(np.isfinite(X)):
        raise NumericalError("FE system is singular after coupling (non-finite condensation)")
    Kc = Kaa - Koa.T @ X
    Kc = 0.5 * (Kc + Kc.T)
    rec = np.zeros((n, retained.size))
    rec[retained] = np.eye(retained.size)
    rec[other] = -X
    return Condensation(Kc, rec)


def compliance_along(K6: np.ndarray, direction: np.ndarray) -> float:
    """Compliance [m/N] along the unit ``direction`` for a force through the reference point, moments zero.

    Uses the translational block of the compliance C = K^-1 (rotations free), i.e. the deformation in the
    load direction per unit load — the joint-stiffness definition of the spec (docs/theory/components.md).
    """
    d = np.asarray(direction, float)
    d = d / np.linalg.norm(d)
    C = np.linalg.inv(K6)
    return float(d @ C[:3, :3] @ d)


def stiffness_along(K6: np.ndarray, direction: np.ndarray) -> float:
    """Axial stiffness [N/m] = 1 / compliance_along (force along ``direction``, moments zero)."""
    return 1.0 / compliance_along(K6, direction)
