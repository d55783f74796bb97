"""Batched static solves of K q = f without forming K⁻¹ (docs/theory/structure.md: solve, do not invert).

Without rigid bindings the solver eliminates bodies one at a time (a block LDLᵀ over the body graph in
minimum-degree order; e.g. in the PKM model every drive only couples to the platform), so a solve costs a few
small batched 3×3/6×6 solves per body instead of a dense n×n factorisation.  With rigid bindings the reduced
dense system ``Zᵀ K Z`` is solved directly.  Every pivot is checked for positive definiteness: an
under-restrained model raises :class:`NumericalError` naming the poses and body.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pkmstiff.errors import NumericalError
from pkmstiff.multibody.assembly import stiffness_matrix
from pkmstiff.multibody.bodies import FRAME
from pkmstiff.multibody.constraints import null_space_basis
from pkmstiff.multibody.linalg import solve_lower, solve_upper_t
from pkmstiff.multibody.system import SDEModel

UNDER_RESTRAINED = "the model is under-restrained (missing SDE or frame binding) or has a zero stiffness"


def cholesky_checked(a: np.ndarray, what: str, hint: str = UNDER_RESTRAINED) -> np.ndarray:
    """Lower Cholesky factor of (N, …, d, d) matrices; :class:`NumericalError` naming the poses if any is
    not positive definite."""
    try:
        return np.linalg.cholesky(a)
    except np.linalg.LinAlgError:
        d = a.shape[-1]
        eig = np.linalg.eigvalsh(a.reshape(-1, d, d)).reshape(a.shape[0] if a.ndim > 2 else 1, -1, d)
        bad = np.nonzero((eig[..., 0] <= 0).any(axis=1))[0]
        if bad.size == 0:  # failed on round-off: report the worst pose
            rel = eig[..., 0] / np.maximum(np.abs(eig[..., -1]), 1e-300)
            bad = np.array([int(np.argmin(rel.min(axis=1)))])
        raise NumericalError(
            f"matrix not positive definite ({what}) at poses {bad[:10].tolist()}{' ...' if bad.size > 10 else ''}: "
            f"{hint}; min eigenvalue {eig[bad[0]].min():.3e}"
        ) from None


def check_positive_definite(a: np.ndarray, what: str, hint: str = UNDER_RESTRAINED) -> None:
    """Raise :class:`NumericalError` if any of the (N, …, d, d) matrices is not positive definite."""
    cholesky_checked(a, what, hint)


@dataclass(frozen=True)
class EliminationPlan:
    """Body elimination order (symbolic factorisation).

    ``steps``: groups of bodies eliminated together (same DOF count, same remaining neighbours, not coupled to
    each other, e.g. the six drives of a PKM) with those neighbours (incl. fill-in); ``kept``: bodies not
    eliminated; ``pairs``: all structurally non-zero blocks (i, j), i <= j, incl. fill-in.
    """

    slices: tuple[slice, ...]
    names: tuple[str, ...]
    steps: tuple[tuple[tuple[int, ...], tuple[int, ...]], ...]
    kept: tuple[int, ...]
    pairs: tuple[tuple[int, int], ...]


def elimination_plan(model: SDEModel, keep: tuple[str, ...] = ()) -> EliminationPlan:
    """Greedy minimum-degree elimination of all bodies except ``keep`` (cached per model structure)."""

    def build() -> EliminationPlan:
        names = tuple(model.body_names)
        index = {n: i for i, n in enumerate(names)}
        adj: dict[int, set[int]] = {i: set() for i in range(len(names))}
        for s in model.sets:
            for a, b in zip(s.body_a, s.body_b):
                if a != FRAME and b != FRAME:
                    adj[index[a]].add(index[b])
                    adj[index[b]].add(index[a])
        pairs = {(i, i) for i in adj} | {(min(i, j), max(i, j)) for i in adj for j in adj[i]}
        kept = tuple(index[k] for k in keep)
        slices = tuple(model.dof_index(n) for n in names)
        size = [s.stop - s.start for s in slices]
        remaining = set(adj) - set(kept)
        steps: list[tuple[list[int], tuple[int, ...]]] = []
        while remaining:
            last = steps[-1] if steps else None
            i = min(remaining, key=lambda j: (len(adj[j]), not (last and tuple(sorted(adj[j])) == last[1]
                                                                and size[j] == size[last[0][0]]), j))
            nb = tuple(sorted(adj[i]))
            for j in nb:
                adj[j].discard(i)
                adj[j].update(k for k in nb if k != j)
                pairs.update((min(j, k), max(j, k)) for k in nb)
            if steps and steps[-1][1] == nb and size[steps[-1][0][0]] == size[i]:
                steps[-1][0].append(i)
            else:
                steps.append(([i], nb))
            remaining.discard(i)
            del adj[i]
        return EliminationPlan(slices, names, tuple((tuple(m), nb) for m, nb in steps), kept, tuple(sorted(pairs)))

    return model.cached(("elimination", keep), build)


class BlockFactor:
    """Numeric block elimination (block LDLᵀ with Cholesky-factored pivots) of K (N, n, n) following an
    :class:`EliminationPlan`.  Per step: ``L = chol(K_ii)``, ``Y = L⁻¹ K_in``, ``K_nn −= Yᵀ Y``.
    ``kept_matrix`` is the stiffness statically condensed onto the kept bodies (Schur complement).
    """

    def __init__(self, plan: EliminationPlan, k: np.ndarray):
        self.plan = plan
        sl = plan.slices
        blocks: dict[tuple[int, int], np.ndarray] = {}
        for i, j in plan.pairs:
            blocks[(i, j)] = k[:, sl[i], sl[j]]
            if i != j:
                blocks[(j, i)] = k[:, sl[j], sl[i]]
        self.steps = []
        for members, nb in plan.steps:
            kii = np.stack([blocks.pop((i, i)) for i in members], axis=1)  # (N, G, d, d)
            lower = cholesky_checked(kii, f"eliminating {[plan.names[i] for i in members]}")
            y, offs = None, np.zeros(1, dtype=int)
            if nb:
                kin = np.stack([np.concatenate([blocks.pop((i, j)) for j in nb], axis=-1) for i in members], axis=1)
                for i in members:
                    for j in nb:
                        del blocks[(j, i)]
                y = solve_lower(lower, kin)  # (N, G, d, w)
                yf = y.reshape(y.shape[0], -1, y.shape[-1])
                upd = np.swapaxes(yf, 1, 2) @ yf
                offs = np.cumsum([0] + [sl[j].stop - sl[j].start for j in nb])
                for a, j in enumerate(nb):
                    for b, m in enumerate(nb):
                        blocks[(j, m)] = blocks[(j, m)] - upd[:, offs[a]:offs[a + 1], offs[b]:offs[b + 1]]
            self.steps.append((members, nb, lower, y, offs))
        self.kept_matrix = self.kept_lower = None
        if plan.kept:
            self.kept_matrix = np.concatenate(
                [np.concatenate([blocks[(i, j)] for j in plan.kept], axis=2) for i in plan.kept], axis=1)
            self.kept_lower = cholesky_checked(self.kept_matrix, "condensed system")

    def kept_compliance(self, right: np.ndarray | None = None) -> np.ndarray:
        """``Rᵀ K_kept⁻¹ R`` (``R`` = identity if None) from the Cholesky factor: ``(L⁻¹R)ᵀ (L⁻¹R)``."""
        lk = self.kept_lower
        rhs = np.broadcast_to(np.eye(lk.shape[-1]), lk.shape) if right is None else right
        y = solve_lower(lk, rhs)
        return np.swapaxes(y, -1, -2) @ y

    def _gather(self, x: np.ndarray, members: tuple[int, ...]) -> np.ndarray:
        return np.stack([x[:, self.plan.slices[i]] for i in members], axis=1)  # (N, G, d, r)

    def solve(self, f: np.ndarray) -> np.ndarray:
        """q (N, n, r) for f (N, n, r)."""
        sl = self.plan.slices
        f = np.array(f, dtype=float, copy=True)
        z = []
        for members, nb, lower, y, offs in self.steps:
            zg = solve_lower(lower, self._gather(f, members))  # L⁻¹ f_i
            z.append(zg)
            if nb:
                red = (np.swapaxes(y, -1, -2) @ zg).sum(axis=1)  # K_ni K_ii⁻¹ f_i = Yᵀ z
                for a, j in enumerate(nb):
                    f[:, sl[j]] -= red[:, offs[a]:offs[a + 1]]
        q = np.zeros_like(f)
        if self.kept_matrix is not None:
            idx = np.concatenate([np.arange(sl[i].start, sl[i].stop) for i in self.plan.kept])
            q[:, idx] = solve_upper_t(self.kept_lower, solve_lower(self.kept_lower, f[:, idx]))
        for (members, nb, lower, y, offs), zg in zip(reversed(self.steps), reversed(z)):
            if nb:
                qn = np.concatenate([q[:, sl[j]] for j in nb], axis=1)
                zg = zg - y @ qn[:, None]
            qg = solve_upper_t(lower, zg)  # q_i = L⁻ᵀ (z − Y q_n)
            for g, i in enumerate(members):
                q[:, sl[i]] = qg[:, g]
        return q


class StaticSystem:
    """Stiffness of one chunk of poses prepared for repeated solves (block elimination or reduced dense)."""

    def __init__(self, model: SDEModel, k: np.ndarray | None = None):
        self.model = model
        self.k = stiffness_matrix(model) if k is None else k
        self.z = null_space_basis(model)
        self._factors: dict[tuple[str, ...], BlockFactor] = {}
        if self.z is not None:
            self.k_reduced = np.swapaxes(self.z, 1, 2) @ self.k @ self.z
            check_positive_definite(self.k_reduced, "reduced system with rigid bindings")

    def _factor(self, keep: tuple[str, ...]) -> BlockFactor:
        if keep not in self._factors:
            self._factors[keep] = BlockFactor(elimination_plan(self.model, keep), self.k)
        return self._factors[keep]

    def solve(self, f: np.ndarray) -> np.ndarray:
        """Displacements q for loads f: (N, n) -> (N, n) or (N, n, r) -> (N, n, r)."""
        f = np.asarray(f, dtype=float)
        vec = f.ndim == 2
        f3 = f[..., None] if vec else f
        f3 = np.broadcast_to(f3, (max(self.k.shape[0], f3.shape[0]),) + f3.shape[1:])
        if self.z is None:
            q = self._factor(()).solve(f3)
        else:
            q = self.z @ np.linalg.solve(self.k_reduced, np.swapaxes(self.z, 1, 2) @ f3)
        return q[..., 0] if vec else q

    def body_compliance(self, body: str, transform: np.ndarray | None = None) -> np.ndarray:
        """Compliance of the body DOFs ``(K⁻¹)_bb`` (N, d, d), or ``T (K⁻¹)_bb Tᵀ`` for a point transform ``T``
        (e.g. ``N(Δ)``, giving the compliance at a point).  Symmetric by construction."""
        s = self.model.dof_index(body)
        if self.z is None:
            fac = self._factor((body,))
            return fac.kept_compliance(None if transform is None else np.swapaxes(transform, -1, -2))
        zb = self.z[:, s, :]
        if transform is not None:
            zb = transform @ zb
        return zb @ np.linalg.solve(self.k_reduced, np.swapaxes(zb, 1, 2))

    def condensed_stiffness(self, body: str) -> np.ndarray:
        """Stiffness condensed onto the DOFs of ``body`` (N, d, d) (static condensation of all other DOFs)."""
        if self.z is None:
            return self._factor((body,)).kept_matrix.copy()
        comp = self.body_compliance(body)
        check_positive_definite(comp, f"compliance of body '{body}' "
                                      "(rigidly bound directions have no finite stiffness)")
        return np.linalg.solve(comp, np.broadcast_to(np.eye(comp.shape[-1]), comp.shape))
