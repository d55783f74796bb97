"""Damped Newton on model + control equations; inverse and forward kinematics with continuation from home.

DE 10 2004 026 707 A1 [0019], [0051]: the total system (model equations, control equations) is a root-finding
problem solved by the damped Newton method with Householder steps.  Here each step is the least-squares
solution by pivoted Householder QR (:func:`pkmstiff.mechanisms.linalg.lstsq_pivoted`), damped by halving until the
residual norm drops (Armijo).  Continuation ([0018]: small steps from a known configuration) goes from home (or a
given start) to the target in equal steps; poses that fail are retried with twice as many steps (step control).

Status per pose: ``converged``; ``singular`` (converged, but the Jacobian is rank deficient by the singular-value
gap or σ_min/σ_max < ``singular_tol``); ``no_solution`` (the residual stalls above the tolerance: outside the
reachable set); ``max_iter``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pkmstiff.errors import ArgumentError
from pkmstiff.kinematics.rotation import cardan_angles
from pkmstiff.mechanisms import reduced
from pkmstiff.mechanisms.constraints import (Frames, System, cardan_pose_rotation, fk_system, ik_system,
                                             rotation_log, wrap)
from pkmstiff.mechanisms.linalg import gap_rank, lstsq_step, singular_values
from pkmstiff.mechanisms.model import Mechanism
from pkmstiff.mechanisms.outputs import output_condition

Array = NDArray[np.float64]

#: ``other_mode``: a configuration was found, but in another working or assembly mode than the continuation's start
#: (:mod:`pkmstiff.mechanisms.modes`; set by the continuations that keep the mode: sections, ``point``)
STATUS = ("converged", "singular", "no_solution", "max_iter", "other_mode")
#: QR-diagonal ratio below which the exact singular values are computed for the status
_SUSPECT_RCOND = 1e-5
#: σ-ratio estimate (Cholesky of JᵀJ, :func:`~pkmstiff.mechanisms.linalg.lstsq_step`) above which a converged
#: pose counts as regular without a QR/SVD: 1e3 above the suspect bound and 1e3 above ``singular_tol``
_FINISH_SCREEN = 1e-4
_ARMIJO = 1e-4
#: full Newton steps the watchdog (:func:`_newton_loop`) takes before it judges a rejected step: near the hybrid's
#: wrist singularity the residual rises ~10⁴-fold after the first step and is below the start after four
_WATCHDOG_STEPS = 6
#: default continuation: no step changes an angle (revolute drive, output angle) by more than this [rad] …
MAX_ANGLE_STEP = np.radians(15.0)
#: … or a length (linear drive, output position) by more than this fraction of the mechanism's length scale, so that
#: each Newton solve starts inside the basin of the configuration reached along the path (patent [0018]); larger
#: changes are subdivided into equal steps (at least ``steps``)
MAX_LENGTH_STEP = 0.25
#: intermediate continuation steps are solved to this multiple of the tolerance (1e-6 of the length scale by
#: default): they only have to land in the next step's basin, whose size is the step itself (≥ 1e-3 typically)
_PATH_TOL = 1e7


@dataclass
class Solution:
    """Configurations of N solves (SI): link coordinates, drive values, output pose and status per pose."""

    mech: Mechanism
    q: Array  #: (N, L, d) link frame coordinates t [m], φ [rad]
    status: Array  #: (N,) str, one of STATUS
    iterations: Array  #: (N,) int, Newton steps (all continuation steps)
    residual: Array  #: (N,) max |F| of the solved equations (m, rad)
    rank: Array  #: (N,) rank of the solve Jacobian (free coordinates) by the singular-value gap
    n_free: int  #: number of free coordinates (full rank)
    rcond: Array  #: (N,) reciprocal condition estimate at the last iterate: σ_min/σ_max estimate of the normal-equation
    #: step, or min/max |R_kk| where the pivoted QR was used (see linalg.lstsq_step)
    sigma_ratio: Array  #: (N,) σ_min/σ_max where computed (suspect poses), else NaN
    #: (N,) κ of ∂x_c/∂s of the controlled outputs (:mod:`pkmstiff.mechanisms.outputs`), set by the forward
    #: kinematics (NaN where no configuration was found or without an output check); None from the inverse
    output_kappa: Array | None = None

    @property
    def converged(self) -> Array:
        return self.status == "converged"

    @property
    def ok(self) -> Array:
        """Converged, singular or not (a configuration was found)."""
        return (self.status == "converged") | (self.status == "singular")

    @property
    def drives(self) -> Array:
        """(N, n_drives) drive values (m or rad, see ``mech.drive_units``); NaN where no configuration was found."""
        v = joint_values(self.mech, self.q, [i for i, j in enumerate(self.mech.joints) if j.drive is not None])
        return np.where(self.ok[:, None], v, np.nan)

    @property
    def poses(self) -> Array:
        """(N, 6) output poses x, y, z [m], a, b, c [rad] (Cardan, pkmstiff convention) or (N, 3) planar."""
        return np.where(self.ok[:, None], output_pose(self.mech, self.q), np.nan)

    def summary(self) -> dict[str, int]:
        return {s: int(np.sum(self.status == s)) for s in STATUS}


def joint_values(mech: Mechanism, q: Array, joints: list[int]) -> Array:
    """Joint variables (N, len(joints)): linear displacement along the axis + offset (eq. 8) [m], relative angle
    about the axis + offset [rad], or tilt between the axis on both links [rad] (spherical/cardan).

    Joints of one kind of variable are evaluated together (one vectorised call per kind)."""
    F = Frames(q, mech.dim)
    D = mech.dim
    out = np.full((q.shape[0], len(joints)), np.nan)
    groups: dict[str, list[int]] = {}
    for c, ji in enumerate(joints):
        groups.setdefault(mech.joints[ji].variable or "", []).append(c)
    for var, cols in groups.items():
        jts = [mech.joints[joints[c]] for c in cols]
        j = np.array([jt.links[0] for jt in jts])
        k = np.array([jt.links[1] for jt in jts])
        off = np.array([jt.drive.offset if jt.drive is not None else 0.0 for jt in jts])
        if var == "linear":
            P = np.array([jt.point for jt in jts])
            u, _ = F.vector(j, np.array([jt.axis for jt in jts]))
            out[:, cols] = np.einsum("nca,nca->nc", F.point(k, P)[0] - F.point(j, P)[0], u) + off
        elif var == "angle":
            if D == 2:
                out[:, cols] = q[:, k, 2] - q[:, j, 2] + off
            else:
                from pkmstiff.mechanisms.constraints import _perp

                b = np.array([_perp(jt.axis) for jt in jts])
                A, _ = F.vector(j, np.array([jt.axis for jt in jts]))
                U, _ = F.vector(j, b)
                V, _ = F.vector(k, b)
                S = np.einsum("nca,nca->nc", A, np.cross(U, V))
                out[:, cols] = np.arctan2(S, np.einsum("nca,nca->nc", U, V)) + off
        elif var == "tilt":
            ax = np.array([jt.axis for jt in jts])
            Uj, _ = F.vector(j, ax)
            Uk, _ = F.vector(k, ax)
            out[:, cols] = np.arccos(np.clip(np.einsum("nca,nca->nc", Uj, Uk), -1.0, 1.0))
    return out


def output_pose(mech: Mechanism, q: Array) -> Array:
    """Output pose of configurations q: world position of the output point and the link's rotation relative to
    home as Cardan angles a, b, c (pkmstiff convention; planar φ)."""
    o = mech.output
    if o is None:
        raise ArgumentError(f"mechanism '{mech.name}' has no [output]: no pose defined")
    F = Frames(q, mech.dim, derivatives=False)
    w, _ = F.point(np.array([o.link]), o.point[None])
    if mech.dim == 2:
        return np.concatenate([w[:, 0], q[:, o.link, 2:3]], axis=1)
    return np.concatenate([w[:, 0], cardan_angles(F.R[:, o.link])], axis=1)


def newton(system: System, q0: Array, target: Array | None, tol: float, max_iter: int = 30,
           max_backtrack: int = 30) -> tuple[Array, Array, Array, Array, Array, Array]:
    """Damped Newton with pivoted-QR least-squares steps, vectorised over N (q0 (N, L, d)).

    Link rotations are updated multiplicatively by incremental rotation vectors (:meth:`System.step`), so a link
    at φy = ±90° (the Euler angles' singularity) is an ordinary configuration for the solver and its rank check.

    Converged when max |F| ≤ ``tol``.  A full step is tried first, its residual and Jacobian are kept for the
    next iteration when it reduces ‖F‖ (Armijo); otherwise the step is halved.  Returns q, status (str:
    converged/no_solution/max_iter), iterations, residual (max |F|), rank and rcond of the pivoted QR at the last
    factorised iterate.  Fixed coordinates are held at their values (their rows drop out).
    """
    N, L, d = q0.shape
    q = q0.reshape(N, L * d).copy()
    for b in system.blocks:
        if b.kind == "fixed":
            q[:, b.j * d + b.coord] = b.value
    if system.plan is not None and N:
        out = _newton_fused(system, q, target, tol, max_iter, max_backtrack)
    else:
        out = _newton_loop(system, q, target, tol, max_iter, max_backtrack)
    slow = np.flatnonzero(out[1] == "max_iter")
    if slow.size:  # creeping damped steps: redo with the watchdog (see _newton_loop)
        out = (out[0], out[1].astype(f"<U{max(map(len, STATUS))}"), *out[2:])
        redo = _newton_loop(system, q[slow], None if target is None else target[slow], tol, max_iter,
                            max_backtrack, watchdog=True)
        for o, a in zip(out, redo):
            o[slow] = a
        out[2][slow] += max_iter
    return out


def _newton_fused(system: System, q: Array, target: Array | None, tol: float, max_iter: int, max_backtrack: int
                  ) -> tuple[Array, Array, Array, Array, Array, Array, Array]:
    """:func:`newton` by the compiled per-pose solve (:func:`pkmstiff.mechanisms.fused.newton`); the poses that
    need the rank-revealing step go on in :func:`_newton_loop` from where they stopped, with the iterations left."""
    from pkmstiff.mechanisms import fused
    from pkmstiff.mechanisms.linalg import NORMAL_SCREEN

    N = q.shape[0]
    L, d = len(system.mech.links), system.mech.dof_per_link
    Rt = cardan_pose_rotation(np.asarray(target, dtype=float)[:, 3:6]) if system._has_rt else None
    q, code, iters, resid, rcond, spent = fused.newton(system, q, target, Rt, tol, max_iter, max_backtrack,
                                                       NORMAL_SCREEN, 2, _ARMIJO)
    status = np.array(["converged", "no_solution", "max_iter", "running"])[code]
    rank = np.full(N, system.free.size, dtype=int)
    chol = np.isfinite(rcond)
    fb = np.flatnonzero(code == fused.FALLBACK)
    for left in np.unique(max_iter - spent[fb]):
        idx = fb[max_iter - spent[fb] == left]
        qq, st, it, rs, rk, rc, ch = _newton_loop(system, q[idx], None if target is None else target[idx], tol,
                                                  int(left), max_backtrack)
        q[idx] = qq.reshape(idx.size, -1)
        status[idx], iters[idx], resid[idx], rank[idx], rcond[idx], chol[idx] = st, iters[idx] + it, rs, rk, rc, ch
    return q.reshape(N, L, d), status.astype(str), iters, resid, rank, rcond, chol


def _newton_loop(system: System, q: Array, target: Array | None, tol: float, max_iter: int, max_backtrack: int,
                 watchdog: bool = False) -> tuple[Array, Array, Array, Array, Array, Array, Array]:
    """:func:`newton` vectorised over the poses in numpy (planar systems, and poses needing the pivoted QR).

    ``watchdog``: a full step that the Armijo test rejects is still taken where, after up to
    ``_WATCHDOG_STEPS`` − 1 further full Newton steps from it, the residual passes the test against the one before (the watchdog technique, Chamberlain et al. 1982; Nocedal &
    Wright §15.6).  Near a singularity of the solved outputs (the hybrid's wrist: the tool axis 1e-7 rad from the
    strut, V1 0.7 rad off) the full step overshoots in the well-determined coordinates by the square of the large
    step in the ill-determined one, and the next steps remove that: the monotone line search creeps there with
    ~1 % steps (``max_iter``); with the watchdog the final continuation step converges in 7 Newton steps."""
    N = q.shape[0]
    L, d = len(system.mech.links), system.mech.dof_per_link
    q = q.copy()
    free = system.free
    status = np.full(N, "running", dtype=object)
    iters = np.zeros(N, dtype=int)
    resid = np.full(N, np.inf)
    rank = np.full(N, free.size, dtype=int)
    rcond = np.full(N, np.nan)
    chol = np.zeros(N, dtype=bool)  # the last step was the normal-equation one (rcond = its σ-ratio estimate)
    shape = (L, d)

    def ev(idx, qq, jac=True):
        return system.evaluate(qq.reshape(-1, *shape), None if target is None else target[idx], jac, reduced=True,
                               omega=True)

    act = np.arange(N)
    r, J = ev(act, q)
    for it in range(max_iter + 1):
        rn = np.abs(r).max(axis=1)
        resid[act] = rn
        done = rn <= tol
        status[act[done]] = "converged"
        if done.any():
            keep = ~done
            act, r, J, rn = act[keep], r[keep], J[keep], rn[keep]
        if act.size == 0:
            break
        if it == max_iter:
            status[act] = "max_iter"
            break
        dx, rk, rc, used_qr = lstsq_step(J, r, pattern=system.sparsity)
        rank[act] = rk
        rcond[act] = rc
        chol[act] = ~used_qr
        r2 = np.einsum("nm,nm->n", r, r)
        qt = system.step(q[act], dx)
        rt, Jt = ev(act, qt)
        rt2 = np.einsum("nm,nm->n", rt, rt)
        ok = np.isfinite(rt2) & ((rt2 <= (1.0 - _ARMIJO) ** 2 * r2) | (np.abs(rt).max(axis=1) <= tol))
        bad = np.flatnonzero(~ok)
        if bad.size == 0:  # the usual case: every full step accepted, no copies
            q[act] = qt
            iters[act] += 1
            r, J = rt, Jt
            continue
        if watchdog:
            pend, qw, rw, Jw = bad, qt[bad], rt[bad], Jt[bad]
            for k in range(1, _WATCHDOG_STEPS):
                fin = np.isfinite(rw).all(axis=1) & np.isfinite(Jw).all(axis=(1, 2))
                pend, qw, rw, Jw = pend[fin], qw[fin], rw[fin], Jw[fin]
                if pend.size == 0:
                    break
                dxw, _, _, _ = lstsq_step(Jw, rw, pattern=system.sparsity)
                qw = system.step(qw, dxw)
                rw, Jw = ev(act[pend], qw)
                rw2 = np.einsum("nm,nm->n", rw, rw)
                w = np.isfinite(rw2) & (rw2 <= (1.0 - _ARMIJO) ** 2 * r2[pend])
                wi = pend[w]
                qt[wi], rt[wi], Jt[wi] = qw[w], rw[w], Jw[w]
                iters[act[wi]] += k
                ok[wi] = True
                pend, qw, rw, Jw = pend[~w], qw[~w], rw[~w], Jw[~w]
            bad = np.flatnonzero(~ok)
            if bad.size == 0:
                q[act] = qt
                iters[act] += 1
                r, J = rt, Jt
                continue
        q[act[ok]] = qt[ok]
        iters[act[ok]] += 1
        rt[bad], Jt[bad] = r[bad], J[bad]
        r, J = rt, Jt
        alpha = np.full(bad.size, 0.5)
        accepted = np.zeros(bad.size, dtype=bool)
        for _ in range(max_backtrack):
            tr = np.flatnonzero(~accepted)
            if tr.size == 0:
                break
            qb = system.step(q[act[bad[tr]]], alpha[tr, None] * dx[bad[tr]])
            rb, _ = ev(act[bad[tr]], qb, jac=False)
            rb2 = np.einsum("nm,nm->n", rb, rb)
            okb = np.isfinite(rb2) & (rb2 <= (1.0 - _ARMIJO * alpha[tr]) ** 2 * r2[bad[tr]])
            q[act[bad[tr[okb]]]] = qb[okb]
            accepted[tr[okb]] = True
            alpha[tr[~okb]] *= 0.5
        if bad.size:
            iters[act[bad[accepted]]] += 1
            upd = bad[accepted]
            if upd.size:
                r[upd], J[upd] = ev(act[upd], q[act[upd]])
            stalled = bad[~accepted]
            status[act[stalled]] = np.where(rn[stalled] <= 10.0 * tol, "converged", "no_solution")
            alive = np.ones(act.size, dtype=bool)
            alive[stalled] = False
            act, r, J = act[alive], r[alive], J[alive]
    return q.reshape(N, L, d), status.astype(str), iters, resid, rank, rcond, chol


def _finish(system: System, q: Array, status: Array, iters, resid, rank, rcond, chol, target,
            singular_tol) -> Solution:
    """Rank of the final Jacobian of every converged pose and the status ``singular`` where it is deficient.

    Screen: poses whose σ_min/σ_max estimate from the Cholesky factor of JᵀJ is at least ``_FINISH_SCREEN`` are
    regular (full rank).  The others get the pivoted-QR diagonal and, where that shows a gap or a small ratio,
    the exact singular values (rank by the singular-value gap, σ_min/σ_max against ``singular_tol``).
    A pose whose last Newton step was the normal-equation one with an estimate ≥ ``_FINISH_SCREEN`` is regular
    without a new factorisation: that step was taken a converging Newton step (≲ 1e-6 relative) before the
    final iterate, which moves σ_min/σ_max by far less than the screen's margin of 10³ over the suspect bound."""
    n_free = system.free.size
    sig = np.full(q.shape[0], np.nan)
    with np.errstate(invalid="ignore"):
        regular = chol & (rcond >= _FINISH_SCREEN)
    ok = np.flatnonzero((status == "converged") & ~regular)
    status = status.copy()
    if ok.size:
        r, J = system.evaluate(q[ok], None if target is None else target[ok], reduced=True, omega=True)
        _, rk, rc, qr = lstsq_step(J, r, screen=_FINISH_SCREEN, sweeps=4, pattern=system.sparsity)
        rank[ok] = rk
        rcond[ok] = rc
        sus = np.flatnonzero(qr & ((rk < n_free) | ~(rc > _SUSPECT_RCOND)))
        if sus.size:
            s = singular_values(np.ascontiguousarray(J[sus]))
            idx = ok[sus]
            rank[idx] = gap_rank(s)
            sig[idx] = s[:, -1] / s[:, 0]
            bad = (rank[idx] < n_free) | (sig[idx] < singular_tol)
            status[idx[bad]] = "singular"
    return Solution(system.mech, q, status, iters, resid, rank, n_free, rcond, sig)


def _as_targets(values: ArrayLike, width: int, what: str, unit: str) -> Array:
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ArgumentError(f"{what}: expected numbers of shape ({width},) or (N, {width}) [{unit}], "
                                  f"found {values!r}") from None
    if arr.ndim == 1:
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ArgumentError(f"{what}: expected shape ({width},) or (N, {width}) [{unit}], found shape "
                                  f"{np.shape(values)}")
    if not np.isfinite(arr).all():
        raise ArgumentError(f"{what}: expected finite values [{unit}], found NaN/inf")
    return arr


def _continuation(system: System, target: Array, start_q: Array, start_target: Array, steps: int, tol: float,
                  max_iter: int, max_refine: int, max_backtrack: int = 30) -> tuple:
    """Equal steps from (start_q, start_target) to target; failing poses are redone with 2×, 4×, … steps."""
    N = target.shape[0]
    L, d = start_q.shape[-2:]
    q_out = np.empty((N, L, d))
    status = np.full(N, "no_solution", dtype=object)
    iters = np.zeros(N, dtype=int)
    resid = np.full(N, np.nan)
    rank = np.zeros(N, dtype=int)
    rcond = np.full(N, np.nan)
    chol = np.zeros(N, dtype=bool)
    todo = np.arange(N)
    n = max(1, int(steps))
    for _ in range(max_refine + 1):
        q = np.broadcast_to(start_q, (N, L, d))[todo].copy()
        t0 = np.broadcast_to(start_target, target.shape)[todo]
        t1 = target[todo]
        alive = np.ones(todo.size, dtype=bool)
        final_miss = np.zeros(todo.size, dtype=bool)
        st = np.full(todo.size, "converged", dtype=object)
        for s in range(1, n + 1):
            idx = np.flatnonzero(alive)
            if idx.size == 0:
                break
            tg = t0[idx] + (s / n) * (t1[idx] - t0[idx])
            last = s == n
            qs, sts, its, res, rk, rc, ch = newton(system, q[idx], tg, tol if last else _PATH_TOL * tol, max_iter,
                                                   max_backtrack)
            q[idx] = qs
            iters[todo[idx]] += its
            fail = sts != "converged"
            st[idx[fail]] = sts[fail]
            alive[idx[fail]] = False
            if last:
                resid[todo[idx]], rank[todo[idx]], rcond[todo[idx]], chol[todo[idx]] = res, rk, rc, ch
                final_miss[idx[fail & (sts == "no_solution")]] = True
        # a target missed only at the last step after a converged path is unreachable: no smaller steps needed
        good = alive | final_miss
        q_out[todo] = q
        status[todo] = st
        todo = todo[~good]
        if todo.size == 0:
            break
        n *= 2
    return q_out, status.astype(str), iters, resid, rank, rcond, chol


def path_steps(delta: Array, angular: Array, length_scale: float, steps: int) -> Array:
    """Continuation steps per pose (N,) for target changes ``delta`` (N, k) whose columns are angles where
    ``angular`` (k,) is True [rad], else lengths [m]: at least ``steps``, and enough that no step exceeds
    :data:`MAX_ANGLE_STEP` / :data:`MAX_LENGTH_STEP` × length scale; rounded up to ``steps``·2^i so that
    poses share few step counts (one vectorised continuation per count)."""
    lim = np.where(angular, MAX_ANGLE_STEP, MAX_LENGTH_STEP * length_scale)
    need = np.ceil(np.nanmax(np.abs(delta) / lim, axis=1, initial=0.0) / max(1, int(steps)))
    return max(1, int(steps)) * 2 ** np.ceil(np.log2(np.maximum(need, 1.0))).astype(int)


def _grouped(system: System, target: Array, start_q: Array, start_target: Array, n: Array, tol: float,
             max_iter: int, max_refine: int, max_backtrack: int) -> tuple:
    """:func:`_continuation` for poses with different step counts ``n`` (N,): one call per distinct count."""
    N = target.shape[0]
    if np.all(n == n[0]):
        return _continuation(system, target, start_q, start_target, int(n[0]), tol, max_iter, max_refine,
                             max_backtrack)
    L, d = start_q.shape[-2:]
    q0 = np.broadcast_to(start_q, (N, L, d))
    t0 = np.broadcast_to(start_target, target.shape)
    outs = None
    for v in np.unique(n):
        idx = np.flatnonzero(n == v)
        res = _continuation(system, target[idx], q0[idx], t0[idx], int(v), tol, max_iter, max_refine, max_backtrack)
        if outs is None:
            outs = [np.empty((N,) + a.shape[1:], dtype=a.dtype if a.dtype.kind != "U" else object) for a in res]
        for o, a in zip(outs, res):
            o[idx] = a
    return tuple(o.astype(str) if o.dtype == object else o for o in outs)


def home(mech: Mechanism, n: int = 1) -> Array:
    """Home configuration: every link frame = world frame (patent claim 4), shape (n, L, d)."""
    return np.zeros((n, len(mech.links), mech.dof_per_link))


def forward(mech: Mechanism, drives: ArrayLike, start: Solution | Array | None = None, steps: int = 1,
            tol: float | None = None, max_iter: int = 30, max_refine: int = 4,
            singular_tol: float = 1e-7, max_backtrack: int = 30, output_check: bool = True) -> Solution:
    """Forward kinematics: configurations for drive values (N, n_drives) [m or rad] (patent claim 12).

    Starts at home (drive values = offsets) or at ``start`` (a Solution or q (N, L, d)) and continues in
    equal steps: ``steps``, or more where a drive changes by more than :data:`MAX_ANGLE_STEP` (revolute) or
    :data:`MAX_LENGTH_STEP` × length scale (linear) per step (:func:`path_steps`), so that the configuration
    is the one connected to the start; ``tol`` defaults to 1e-13·length scale.  Never raises for unreachable targets:
    see ``Solution.status``: ``singular`` also where the controlled outputs are singular (``output_check``:
    κ of ∂x_c/∂s, ``Solution.output_kappa``, above 1/``singular_tol`` — a wrist singularity, where the forward
    kinematics themselves stay regular).  ``max_backtrack`` bounds the step halvings per Newton step (fewer: unreachable
    targets are given up sooner, as a section raster needs).  A mechanism of length legs (6-UPS, 6X, Hexaglide, 6-RUS:
    :func:`pkmstiff.mechanisms.reduced.leg_plan`, decided once per mechanism) is solved on the output link's 6
    coordinates with the legs in closed form (:func:`_forward_reduced`; ``PKMSTIFF_FULL_FK=1`` forces the full
    path).
    """
    nd = len(mech.drives)
    if nd == 0:
        raise ArgumentError(f"mechanism '{mech.name}' has no driven joint: forward kinematics undefined")
    tg = _as_targets(drives, nd, "drives", ", ".join(mech.drive_units))
    system = fk_system(mech)
    tol = 1e-13 * mech.length_scale if tol is None else tol
    if start is None:
        q0 = home(mech)
        t0 = np.array([[j.drive.offset for j in mech.drives]])
    else:
        q0 = start.q if isinstance(start, Solution) else np.asarray(start, dtype=float)
        t0 = joint_values(mech, q0, [i for i, j in enumerate(mech.joints) if j.drive is not None])
    n = path_steps(tg - t0, np.array([u == "rad" for u in mech.drive_units]), mech.length_scale, steps)
    lp = reduced.leg_plan(mech) if reduced.enabled() else None
    if lp is not None:
        return _forward_reduced(lp, system, tg, q0, t0, n, tol, max_iter, max_refine, max_backtrack, singular_tol,
                                output_check)
    return _forward_full(system, tg, q0, t0, n, tol, max_iter, max_refine, max_backtrack, singular_tol,
                         output_check)


def _forward_full(system: System, tg: Array, q0: Array, t0: Array, n: Array, tol: float, max_iter: int,
                  max_refine: int, max_backtrack: int, singular_tol: float, output_check: bool) -> Solution:
    """:func:`forward` on the whole link-and-joint system: continuation, rank check, output check."""
    out = _grouped(system, tg, q0, t0, n, tol, max_iter, max_refine, max_backtrack)
    sol = _finish(system, *out, tg, singular_tol)
    if output_check:
        _flag_outputs(sol, tg, singular_tol)
    return sol


def _forward_reduced(lp: reduced.LegPlan, system: System, tg: Array, q0: Array, t0: Array, n: Array, tol: float,
                     max_iter: int, max_refine: int, max_backtrack: int, singular_tol: float,
                     output_check: bool) -> Solution:
    """:func:`forward` of a mechanism of length legs (:mod:`pkmstiff.mechanisms.reduced`): Newton on the output
    frame, legs in closed form; the poses it does not certify regular go through :func:`_forward_full`.

    ``rcond`` of a certified pose is a lower bound of σ_min/σ_max of the reduced 6 × 6 Jacobian diag(D)⁻¹ J (≥
    ``reduced.REGULAR_SCREEN``), its rank the full one, ``residual`` max |F| of the drive equations (the legs'
    equations hold to rounding)."""
    mech = system.mech
    N = tg.shape[0]
    q, code, iters, resid, rcond, kappa, lock = reduced.solve(mech, lp, q0, t0, tg, n, tol, _PATH_TOL * tol,
                                                              max_iter, max_backtrack, _ARMIJO)
    with np.errstate(invalid="ignore"):
        good = (code == reduced.CONVERGED) & (rcond >= reduced.REGULAR_SCREEN) & ~lock
        if output_check:
            good &= kappa * singular_tol <= 1.0
    sol = Solution(mech, q, np.full(N, "converged", dtype=f"<U{max(map(len, STATUS))}"), iters, resid,
                   np.full(N, system.free.size, dtype=int), system.free.size, rcond, np.full(N, np.nan),
                   np.where(good, kappa, np.nan) if output_check else None)
    bad = np.flatnonzero(~good)
    if bad.size:
        full = _forward_full(system, tg[bad], q0[np.minimum(bad, q0.shape[0] - 1)],
                             t0[np.minimum(bad, t0.shape[0] - 1)], n[bad], tol, max_iter, max_refine, max_backtrack,
                             singular_tol, output_check)
        for f in ("q", "status", "iterations", "residual", "rank", "rcond", "sigma_ratio"):
            getattr(sol, f)[bad] = getattr(full, f)
        if output_check:
            sol.output_kappa[bad] = full.output_kappa
    return sol


def _flag_outputs(sol: Solution, drives: Array, singular_tol: float) -> None:
    """``sol.output_kappa``: κ of ∂x_c/∂s at every pose with a configuration (drive values ``drives`` (N, n_d)),
    and the status ``singular`` where κ > 1/``singular_tol`` (an output singularity: the hybrid's wrist)."""
    sol.output_kappa = np.full(drives.shape[0], np.nan)
    if sol.mech.output is None:
        return
    ok = np.flatnonzero(sol.ok)
    kap = output_condition(sol.mech, sol.q[ok], drives[ok])
    sol.output_kappa[ok] = kap
    with np.errstate(invalid="ignore"):
        sol.status[ok[kap * singular_tol > 1.0]] = "singular"


def inverse(mech: Mechanism, poses: ArrayLike, start: Solution | Array | None = None, steps: int = 1,
            tol: float | None = None, max_iter: int = 30, max_refine: int = 4,
            singular_tol: float = 1e-7, max_backtrack: int = 30, output_check: bool = True) -> Solution:
    """Inverse kinematics: configurations (and drive values) for output poses (N, 6) x, y, z [m], a, b, c [rad]
    (planar (N, 3) x, y [m], φ [rad]) (patent claim 11).  Continuation from home or ``start`` as in
    :func:`forward` (changes of the controlled point coordinates against :data:`MAX_LENGTH_STEP`, the turn of the
    controlled orientation against :data:`MAX_ANGLE_STEP`).  ``output_check``: ``Solution.output_kappa`` (κ of
    ∂x_c/∂s at the drive values found) and ``singular`` above 1/``singular_tol``, as in :func:`forward`; near an
    output singularity a residual at rounding level leaves the ill-determined drive uncertain by ~ε·κ/|x_c| (the
    hybrid's V1 to ~1e-16/tilt rad; the Newton steps there: :func:`_newton_loop`)."""
    if mech.output is None:
        raise ArgumentError(f"mechanism '{mech.name}' has no [output]: inverse kinematics undefined")
    units = "m, m, m, rad, rad, rad" if mech.dim == 3 else "m, m, rad"
    tg = _as_targets(poses, mech.pose_size, "poses", units)
    system = ik_system(mech)
    tol = 1e-13 * mech.length_scale if tol is None else tol
    if start is None:
        q0, t0 = home(mech), mech.home_output_pose[None]
    else:
        q0 = start.q if isinstance(start, Solution) else np.asarray(start, dtype=float)
        t0 = output_pose(mech, q0)
    n = path_steps(_controlled_change(mech, t0, tg), np.array([False, True]), mech.length_scale, steps)
    out = _grouped(system, tg, q0, t0, n, tol, max_iter, max_refine, max_backtrack)
    sol = _finish(system, *out, tg, singular_tol)
    if output_check:
        _flag_outputs(sol, sol.drives, singular_tol)
    return sol


def _controlled_change(mech: Mechanism, p0: Array, p1: Array) -> Array:
    """(N, 2): the largest change of a controlled point coordinate [m] and the turn of the controlled orientation
    [rad] between output poses p0 and p1 — the rotation angle |log(R₁R₀ᵀ)| (full), the angle between the axes
    (axis), nothing (none) — the quantities the default continuation bounds per step."""
    o = mech.output
    D = mech.dim
    N = np.broadcast_shapes(p0.shape, p1.shape)[0]
    out = np.zeros((N, 2))
    out[:, 0] = np.abs((p1 - p0)[:, list(o.coordinates)]).max(axis=1)
    if o.orientation == "none":
        return out
    if D == 2:
        out[:, 1] = np.abs(wrap(p1[:, 2] - p0[:, 2]))
        return out
    R0 = cardan_pose_rotation(np.broadcast_to(p0, (N, p0.shape[1]))[:, 3:6])
    R1 = cardan_pose_rotation(np.broadcast_to(p1, (N, p1.shape[1]))[:, 3:6])
    if o.orientation == "full":
        out[:, 1] = np.linalg.norm(rotation_log(R1 @ np.swapaxes(R0, -1, -2)), axis=-1)
    else:
        c = np.einsum("na,na->n", R0 @ o.axis, R1 @ o.axis)
        out[:, 1] = np.arccos(np.clip(c, -1.0, 1.0))
    return out
