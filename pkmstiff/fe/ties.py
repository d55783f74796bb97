"""Tie constraints between non-matching part meshes (bonded contact, "TIE"-like).

A slave node x_s that lies on the surface of a master part is tied to the master displacement field at
the same point: u(x_s) = sum_b N_b(X) u_b, where X are the reference coordinates of x_s in the master
element that contains it (inverse trilinear map, Newton) and N_b the master element's shape functions
(scikit-fem ``lbasis``). Slave nodes are found geometrically: every node of the slave part within
``tol`` of the master part is tied. Curved surfaces are polygonal (see :mod:`pkmstiff.fe.mesh`), so
``tol`` must exceed the chord sag r (1 - cos(pi/n_phi)) of tied cylinders.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree
from skfem import CellBasis, ElementHex1

_HEX1 = ElementHex1()


@dataclass(frozen=True)
class PointLocation:
    """Master element index, reference coordinates (3, n) in [0, 1]^3 and distance [m] of each point."""

    element: np.ndarray
    X: np.ndarray
    distance: np.ndarray


def _trilinear(X: np.ndarray, xe: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (3, n) and Jacobian (3, 3, n) of the trilinear map of elements with vertices xe (3, 8, n)."""
    F = np.zeros((3, X.shape[1]))
    J = np.zeros((3, 3, X.shape[1]))
    for v in range(8):
        phi, dphi = _HEX1.lbasis(X, v)
        F += xe[:, v, :] * phi
        J += xe[:, v, None, :] * dphi[None, :, :]
    return F, J


def locate(basis: CellBasis, points: np.ndarray, candidates: int = 12, iterations: int = 25) -> PointLocation:
    """Closest point of the master mesh to each of ``points`` (3, n): element, reference coords, distance.

    Searches the ``candidates`` elements with the nearest centroids, projects onto each by a clipped
    Newton iteration of the trilinear map and keeps the closest. Points inside an element have distance 0.
    """
    mesh = basis.mesh
    npts = points.shape[1]
    if npts == 0:
        return PointLocation(np.zeros(0, int), np.zeros((3, 0)), np.zeros(0))
    centroids = mesh.p[:, mesh.t].mean(axis=1)
    k = min(candidates, mesh.nelements)
    _, cand = cKDTree(centroids.T).query(points.T, k=k)
    cand = np.asarray(cand).reshape(npts, k)
    el = cand.ravel()
    x = np.repeat(points, k, axis=1)
    xe = mesh.p[:, mesh.t[:, el]]  # (3, 8, n k)
    X = np.full((3, el.size), 0.5)
    for _ in range(iterations):
        F, J = _trilinear(X, xe)
        r = x - F
        # least-squares Newton step (the Jacobian is regular for valid elements)
        dX = np.linalg.solve(J.transpose(2, 0, 1), r.T[:, :, None])[:, :, 0].T
        Xn = np.clip(X + dX, 0.0, 1.0)
        if np.max(np.abs(Xn - X)) < 1e-12:
            X = Xn
            break
        X = Xn
    F, _ = _trilinear(X, xe)
    d = np.linalg.norm(x - F, axis=0).reshape(npts, k)
    best = np.argmin(d, axis=1)
    rows = np.arange(npts)
    return PointLocation(cand[rows, best], X.reshape(3, npts, k)[:, rows, best], d[rows, best])


def interpolation_matrix(basis: CellBasis, loc: PointLocation) -> sp.csr_matrix:
    """Scalar interpolation matrix (n_points, basis.N): row p holds N_b(X_p) of the located element."""
    npts = loc.element.size
    nb = basis.Nbfun
    vals = np.stack([basis.elem.lbasis(loc.X, i)[0] for i in range(nb)])  # (nb, n)
    cols = basis.element_dofs[:, loc.element]  # (nb, n)
    rows = np.broadcast_to(np.arange(npts), (nb, npts))
    W = sp.coo_matrix((vals.ravel(), (rows.ravel(), cols.ravel())), shape=(npts, basis.N)).tocsr()
    W.eliminate_zeros()
    return W


def tie(slave_points: np.ndarray, master: CellBasis, tol: float) -> tuple[np.ndarray, sp.csr_matrix]:
    """Tie the slave nodes within ``tol`` [m] of the master mesh.

    Returns the indices (into ``slave_points``) of the tied nodes and the scalar interpolation matrix
    (n_tied, master.N); the displacement of tied node p is ``W[p] @ u_master`` for each component.
    """
    loc = locate(master, slave_points)
    hit = np.flatnonzero(loc.distance <= tol)
    sub = PointLocation(loc.element[hit], loc.X[:, hit], loc.distance[hit])
    return hit, interpolation_matrix(master, sub)
