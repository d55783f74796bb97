"""Forward kinematics: damped Newton with QR steps and a per-pose status report (docs/theory/kinematics.md, Cobet §1.6).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.errors import ArgumentError
from pkmstiff.kinematics.arrays import Array, as_poses
from pkmstiff.kinematics.inverse import IK, inverse_kinematics
from pkmstiff.kinematics.jacobians import cardan_inverse_jacobian, inverse_jacobian
from pkmstiff.machine.model import Machine

FK_STATUS = ("converged", "max_iter", "singular_jacobian", "unreachable", "stalled")


_FK_REASON = {
    "max_iter": "no convergence within max_iter Newton iterations",
    "singular_jacobian": "Cardan inverse Jacobian numerically singular at an iterate "
    "(start pose near a singularity, or |b| = 90 deg)",
    "unreachable": "inverse kinematics undefined (a glide strut cannot reach its guide) "
    "at the start pose or at every damped trial step",
    "stalled": "the residual cannot be reduced along the Newton direction "
    "(drive coordinates probably not attainable from this start pose)",
}


#: ratio min|R_kk| / max|R_kk| of the QR factor below which the Newton matrix counts as singular
_FK_SINGULAR_RCOND = 1e-13


_ARMIJO = 1e-4


@dataclass(frozen=True)
class FKResult:
    """Result of :func:`forward_kinematics` for N targets."""

    poses: Array  #: (N, 6) last iterate x, y, z [m], a, b, c [rad]
    converged: Array  #: (N,) bool
    iterations: Array  #: (N,) int, Newton steps taken
    residual: Array  #: (N,) m, ‖q° − q(x)‖₂ at the returned pose (NaN if unreachable)
    step: Array  #: (N,) ‖Δx‖₂ of the last computed Newton step (mixed m/rad)
    status: Array  #: (N,) str, one of FK_STATUS

    def failures(self) -> dict[str, Array]:
        """Indices of the poses that did not converge, per reason."""
        return {s: np.flatnonzero(self.status == s) for s in FK_STATUS[1:] if np.any(self.status == s)}

    def report(self, max_list: int = 10) -> str:
        """Human-readable summary: how many poses failed, which, and why."""
        N = self.converged.size
        nf = int(N - self.converged.sum())
        if nf == 0:
            return f"forward kinematics: all {N} poses converged (max {int(self.iterations.max(initial=0))} iterations)"
        lines = [f"forward kinematics: {nf} of {N} poses did not converge"]
        for s, idx in self.failures().items():
            shown = ", ".join(str(i) for i in idx[:max_list]) + (", ..." if idx.size > max_list else "")
            lines.append(f"  {s} ({idx.size}): {_FK_REASON[s]}; poses [{shown}]")
        return "\n".join(lines)


def _back_substitute(Rm: Array, y: Array) -> Array:
    """Solve upper triangular Rm (M, n, n) x = y (M, n), vectorised; inf/NaN where a diagonal is 0."""
    n = Rm.shape[1]
    x = np.zeros_like(y)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for i in range(n - 1, -1, -1):
            x[:, i] = (y[:, i] - np.einsum("mj,mj->m", Rm[:, i, i + 1 :], x[:, i + 1 :])) / Rm[:, i, i]
    return x


def _drive_residual(machine: Machine, x: Array, target: Array) -> tuple[IK, Array, Array]:
    ik = inverse_kinematics(machine, x)
    res = target - ik.drive
    rn = np.sqrt(np.einsum("mi,mi->m", res, res))
    return ik, res, np.where(np.isfinite(rn), rn, np.inf)


def forward_kinematics(
    machine: Machine,
    drive_coords: ArrayLike,
    x0: ArrayLike,
    tol_q: float = 1e-12,
    tol_x: float = 1e-12,
    max_iter: int = 50,
    damping: bool = True,
    max_backtrack: int = 30,
) -> FKResult:
    """Forward kinematics by Newton's method on the inverse kinematics (Cobet eq. A.12–A.17, docs/theory/kinematics.md).

    ``drive_coords`` (N, n) or (n,) in m (glide λ_i, pod l_i); start poses ``x0`` (N, 6) or (6,).
    Each step solves J⁻¹(x_k) Δx = q° − q(x_k) with the Cardan inverse Jacobian (A.20) as a linear
    least-squares problem by Householder QR (``np.linalg.qr``, A.14–A.17), vectorised over N.
    Stops when ‖q° − q(x_k)‖₂ ≤ ``tol_q`` [m] and ‖Δx_k‖₂ ≤ ``tol_x`` [m, rad] (Assumption: 1e-12,
    max 50 iterations, docs/theory/kinematics.md).

    ``damping=True`` (toolkit addition; the dissertation's Newton method has no step-size control):
    backtracking line search — the step x_k + α Δx_k with α = 1, 1/2, 1/4, … (at most
    ``max_backtrack`` halvings) is accepted when ‖q° − q‖₂ ≤ (1 − 1e-4 α) ‖q° − q(x_k)‖₂ (Armijo) or
    already ≤ ``tol_q``; trial poses at which a glide chain is unreachable are rejected.
    ``damping=False`` takes full steps (stops as ``unreachable`` if the full step leaves the IK domain).

    Never raises for non-convergence: see ``FKResult.converged``, ``status`` and ``report()``.
    """
    q_target = np.asarray(drive_coords, dtype=float)
    n = machine.n_chains
    if q_target.ndim == 1:
        q_target = q_target[None]
    if q_target.ndim != 2 or q_target.shape[1] != n:
        raise ArgumentError(
            f"drive_coords: expected shape ({n},) or (N, {n}) in m, found {np.shape(drive_coords)}"
        )
    if not np.isfinite(q_target).all():
        raise ArgumentError("drive_coords: expected finite values in m, found NaN/inf")
    x0a = as_poses(x0, "x0")
    N = max(q_target.shape[0], x0a.shape[0])
    try:
        q_target = np.broadcast_to(q_target, (N, n)).copy()
        x = np.broadcast_to(x0a, (N, 6)).copy()
    except ValueError as exc:
        raise ArgumentError(
            f"forward_kinematics: drive_coords ({q_target.shape[0]} rows) and x0 ({x0a.shape[0]} rows) "
            "must have the same number of rows or one of them a single row"
        ) from exc

    status = np.full(N, "running", dtype=object)
    iterations = np.zeros(N, dtype=int)
    step = np.full(N, np.nan)
    residual = np.full(N, np.nan)

    for it in range(max_iter + 1):
        act = np.flatnonzero(status == "running")
        if act.size == 0:
            break
        xa, qa = x[act], q_target[act]
        ika, resa, rna = _drive_residual(machine, xa, qa)
        residual[act] = rna
        unreach = ~np.isfinite(rna)  # only possible at the start pose: trial steps must be reachable
        A = cardan_inverse_jacobian(inverse_jacobian(machine, ika), ika)
        A[unreach] = np.eye(6)
        Q, Rm = np.linalg.qr(A)
        dx = _back_substitute(Rm, np.einsum("mji,mj->mi", Q, np.where(unreach[:, None], 0.0, resa)))
        diag = np.abs(np.einsum("mii->mi", Rm))
        singular = ~(diag.min(axis=1) > _FK_SINGULAR_RCOND * diag.max(axis=1)) | ~np.isfinite(dx).all(axis=1)
        dn = np.sqrt(np.einsum("mi,mi->m", dx, dx))
        step[act] = np.where(unreach, np.nan, dn)
        conv = (rna <= tol_q) & (dn <= tol_x) & ~singular
        status[act[unreach]] = "unreachable"
        status[act[conv]] = "converged"
        status[act[singular & ~conv & ~unreach]] = "singular_jacobian"
        go = ~conv & ~singular & ~unreach
        if it == max_iter:
            status[act[go]] = "max_iter"
            break
        act, xa, dx, rna, qa = act[go], xa[go], dx[go], rna[go], qa[go]
        if act.size == 0:
            continue
        alpha = np.ones(act.size)
        accepted = np.zeros(act.size, dtype=bool)
        ever_reachable = np.zeros(act.size, dtype=bool)
        new_x = xa.copy()
        for _bt in range(max_backtrack + 1 if damping else 1):
            tr = np.flatnonzero(~accepted)
            if tr.size == 0:
                break
            xt = xa[tr] + alpha[tr, None] * dx[tr]
            _, _, rnt = _drive_residual(machine, xt, qa[tr])
            reach = np.isfinite(rnt)
            ever_reachable[tr] |= reach
            ok = reach & ((rnt <= (1.0 - _ARMIJO * alpha[tr]) * rna[tr]) | (rnt <= tol_q) | (not damping))
            new_x[tr[ok]] = xt[ok]
            accepted[tr[ok]] = True
            alpha[tr[~ok]] *= 0.5
        x[act[accepted]] = new_x[accepted]
        iterations[act[accepted]] += 1
        status[act[~accepted & ~ever_reachable]] = "unreachable"
        status[act[~accepted & ever_reachable]] = "stalled"

    status[status == "running"] = "max_iter"
    status = status.astype(str)
    return FKResult(
        poses=x,
        converged=status == "converged",
        iterations=iterations,
        residual=np.where(np.isfinite(residual), residual, np.nan),
        step=step,
        status=status,
    )
