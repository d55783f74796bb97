"""Drive ranges by pseudo-arclength continuation to the singular ends (issue 14, item 3; calibration.md §3).

For drive i, the model equations plus every other drive held at its start value leave a one-parameter solution
curve through the start configuration.  It is followed both ways with a predictor along the tangent (null vector of
the Jacobian, by SVD) and a Newton corrector on the hyperplane through the predictor normal to the tangent, with
step control (halving on failure, doubling after easy steps).  The drive value along the curve has an extremum
where the full forward-kinematics Jacobian (with drive i) loses rank, i.e. where its smallest singular value
vanishes (a dead centre); it is located by bisection on the sign of ds_i/dα and reported with its configuration.
Curves that keep going (a crank turning round) stop at the joint limits or after ``max_travel``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pkmstiff.errors import MechanismInputError
from pkmstiff.mechanisms.constraints import System, drive_blocks, model_blocks
from pkmstiff.mechanisms.linalg import gap_rank
from pkmstiff.mechanisms.model import Mechanism
from pkmstiff.mechanisms.solver import home, joint_values

Array = NDArray[np.float64]


@dataclass
class RangeEnd:
    """One end of a drive interval: value (m or rad), kind ("singular", "limit", "travel", "unlimited", "failed"),
    configuration q (L, d) and σ_min/σ_max of the forward-kinematics Jacobian there."""

    value: float
    kind: str
    q: Array
    sigma_ratio: float


@dataclass
class DriveRange:
    name: str
    unit: str
    min: RangeEnd
    max: RangeEnd


class _Curve:
    def __init__(self, mech: Mechanism, drive: int):
        self.mech = mech
        blocks = drive_blocks(mech)
        self.others = System(mech, model_blocks(mech) + [b for b in _split(blocks) if b.coord[0] != drive])
        self.full = System(mech, model_blocks(mech) + _split(blocks))
        self.ji = [i for i, j in enumerate(mech.joints) if j.drive is not None][drive]
        self.drive = drive
        self.free = self.others.free
        self.rows = self.others.solve_rows
        self.shape = (len(mech.links), mech.dof_per_link)

    def fun(self, x: Array, target: Array) -> tuple[Array, Array]:
        q = np.zeros(int(np.prod(self.shape)))
        q[self.free] = x
        r, J = self.others.evaluate(q.reshape(1, *self.shape), target[None])
        return r[0, self.rows], J[0][np.ix_(self.rows, self.free)]

    def value(self, x: Array) -> float:
        q = np.zeros(int(np.prod(self.shape)))
        q[self.free] = x
        return float(joint_values(self.mech, q.reshape(1, *self.shape), [self.ji])[0, 0])

    def grad(self, x: Array) -> Array:
        """∂s_i/∂x: the drive row of the full Jacobian with the target set to the current value."""
        q = np.zeros(int(np.prod(self.shape)))
        q[self.free] = x
        nd = len(self.mech.drives)
        tg = np.zeros((1, nd))
        tg[0, self.drive] = self.value(x)
        b = next(b for b in self.full.blocks if b.kind.startswith("drive") and b.coord[0] == self.drive)
        _, J = self.full.evaluate(q.reshape(1, *self.shape), tg)
        return J[0, b.row0, self.free]

    def tangent(self, x: Array, target: Array, prev: Array | None) -> Array:
        _, J = self.fun(x, target)
        t = np.linalg.svd(J)[2][-1]
        if prev is not None and t @ prev < 0:
            t = -t
        return t

    def correct(self, x: Array, t: Array, target: Array, tol: float, max_iter: int = 12) -> Array | None:
        xp = x.copy()
        for _ in range(max_iter):
            r, J = self.fun(x, target)
            r = np.append(r, t @ (x - xp))
            if np.abs(r).max() <= tol:
                return x
            A = np.vstack([J, t])
            x = x + np.linalg.lstsq(A, -r, rcond=None)[0]
        r, _ = self.fun(x, target)
        return x if max(np.abs(r).max(), abs(t @ (x - xp))) <= tol else None

    def sigma_ratio(self, x: Array, target: Array) -> float:
        q = np.zeros(int(np.prod(self.shape)))
        q[self.free] = x
        tfull = target.copy()
        tfull[self.drive] = self.value(x)
        r, J = self.full.evaluate(q.reshape(1, *self.shape), tfull[None])
        s = np.linalg.svd(J[0][np.ix_(self.full.solve_rows, self.full.free)], compute_uv=False)
        return float(s[-1] / s[0])


def _split(blocks):
    """One block per drive (so that a drive can be left out)."""
    from pkmstiff.mechanisms.constraints import Block

    out = []
    for b in blocks:
        for i in range(b.n):
            out.append(Block(b.kind, b.joint[i:i + 1], b.j[i:i + 1], b.k[i:i + 1], b.p[i:i + 1], b.a[i:i + 1],
                             b.b[i:i + 1], b.nrows, coord=b.coord[i:i + 1], value=b.value[i:i + 1]))
    return out


def _trace(c: _Curve, x0: Array, target: Array, sign: float, h0: float, lo: float, hi: float, max_travel: float,
           max_steps: int, tol: float) -> RangeEnd:
    """One end of the range: follow the curve in direction ``sign`` of the drive value.  Angles are unwrapped
    along the curve (a step changes them by far less than π), so a drive that turns round passes ±180° and, after
    a full turn without a turning point or limit, is reported ``unlimited`` (value ±∞)."""
    x = x0.copy()
    angular = c.mech.drive_units[c.drive] == "rad"
    s0 = c.value(x)
    s_prev = s0

    def unwrapped(xx):
        v = c.value(xx)
        return s_prev + ((v - s_prev + np.pi) % (2.0 * np.pi) - np.pi) if angular else v
    t = c.tangent(x, target, None)
    if c.grad(x) @ t * sign < 0:
        t = -t
    h = h0
    for _ in range(max_steps):
        xn = c.correct(x + h * t, t, target, tol)
        if xn is None:
            h *= 0.5
            if h < 1e-12 * h0:
                return RangeEnd(unwrapped(x), "failed", x, c.sigma_ratio(x, target))
            continue
        tn = c.tangent(xn, target, t)
        sn = unwrapped(xn)
        if (sign > 0 and sn > hi) or (sign < 0 and sn < lo):
            return RangeEnd(hi if sign > 0 else lo, "limit", xn, c.sigma_ratio(xn, target))
        if angular and abs(sn - s0) >= 2.0 * np.pi:
            return RangeEnd(sign * np.inf, "unlimited", xn, c.sigma_ratio(xn, target))
        if abs(sn - s0) > max_travel:
            return RangeEnd(sn, "travel", xn, c.sigma_ratio(xn, target))
        if sign * (c.grad(xn) @ tn) <= 0:  # ds/dα changed sign: a turning point between x and xn
            a, b = 0.0, h
            xa, ta = x, t
            for _ in range(60):
                mid = 0.5 * (a + b)
                xm = c.correct(xa + (mid - a) * ta, ta, target, tol)
                if xm is None:
                    break
                tm = c.tangent(xm, target, ta)
                if sign * (c.grad(xm) @ tm) > 0:
                    a, xa, ta = mid, xm, tm
                else:
                    b = mid
                if b - a < 1e-13 * h0:
                    break
            xe = c.correct(xa + 0.5 * (b - a) * ta, ta, target, tol)
            xe = xa if xe is None else xe
            return RangeEnd(unwrapped(xe), "singular", xe, c.sigma_ratio(xe, target))
        x, t, s_prev = xn, tn, sn
        h = min(2.0 * h, 8.0 * h0) if h < 8.0 * h0 else h
    return RangeEnd(unwrapped(x), "travel", x, c.sigma_ratio(x, target))


def drive_ranges(mech: Mechanism, drives: list[str] | None = None, start: Array | None = None,
                 step: float | None = None, max_travel: float | None = None, max_steps: int = 2000,
                 tol: float | None = None) -> dict[str, DriveRange]:
    """Interval of each drive over which a configuration exists, the other drives held at their start values.

    ``start``: a configuration q (L, d) (default home); ``step``: initial arclength step in the free link
    coordinates (default 2 % of the length scale); ``max_travel``: stop after this change of the drive value
    (default 10 length scales for linear drives); an angle that turns a full round without a turning point is
    ``unlimited`` (±∞); joint limits of the driven joint stop the continuation too ("limit").
    """
    names = list(mech.drive_names)
    if not names:
        raise MechanismInputError(f"mechanism '{mech.name}' has no driven joint: no drive range")
    sel = names if drives is None else drives
    for d in sel:
        if d not in names:
            raise MechanismInputError(f"drive {d!r}: expected one of {names}")
    q0 = home(mech)[0] if start is None else np.asarray(start, dtype=float)
    tol = 1e-13 * mech.length_scale if tol is None else tol
    h0 = 0.02 * mech.length_scale if step is None else step
    units = mech.drive_units
    out = {}
    for name in sel:
        i = names.index(name)
        c = _Curve(mech, i)
        target = joint_values(mech, q0[None], [k for k, j in enumerate(mech.joints) if j.drive is not None])[0]
        x0 = q0.reshape(-1)[c.free]
        rk = gap_rank(np.linalg.svd(c.fun(x0, target)[1], compute_uv=False))
        if c.free.size - rk != 1:
            raise MechanismInputError(f"drive {name!r}: the mechanism with the other drives held has "
                                      f"{c.free.size - rk} degrees of freedom at the start (need 1)")
        jt = mech.joints[c.ji]
        travel = (10.0 * mech.length_scale if units[i] == "m" else np.inf) if max_travel is None else max_travel
        ends = [_trace(c, x0, target, sg, h0, jt.limits[0], jt.limits[1], travel, max_steps, tol) for sg in (-1, 1)]
        out[name] = DriveRange(name, units[i], ends[0], ends[1])
    return out
