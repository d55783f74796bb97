"""Forward kinematics on the output body's six coordinates where every leg reduces to a distance constraint
(issue 27 item 6: speed of the generic solver; an internal fast path of :func:`pkmstiff.mechanisms.solver.forward`).

Three kinds of leg reduce (:class:`LegPlan`, found by :func:`leg_plan` from the constraint structure, once per
mechanism):

- *telescopic*: joined to the ground by a cardan joint (point b) and to the output link by a driven
  ``point_on_axis`` joint (point P, axis a ∥ P − b at home): the drive equation (eq. 8 on the axis u = R_leg a)
  reads s = σ|p − b| + c with p = t + R P, σ = sign((P − b)·a), c = offset − (P − b)·a (6-UPS, 6X);
- *guided rod*: joined to the ground by a driven ``point_on_axis`` joint (carriage point C on a guide along g) and
  to the output link by a cardan joint (point P): |p − C − (s − offset) g| = |P − C| (Hexaglide);
- *crank and rod* (two links): a crank on a driven revolute joint on the ground (point b, axis g), a rod joined to
  it by a cardan joint (point K) and to the output link by a spherical joint (point P):
  |p − b − Rot(g, s − offset)(K − b)| = |P − K| (6-RUS).

A mechanism whose links are the ground, the output link and six such legs, with no other joint, is solved by a
Newton iteration on the output frame (t, R) alone — residual rᵢ = σᵢ|p − Aᵢ(sᵢ)| + cᵢ − μᵢsᵢ, Jacobian rows
σᵢ[nᵢᵀ, ((R Pᵢ) × nᵢ)ᵀ] for the step (δt, δω), R ← exp([δω]×) R, one 6 × 6 solve per step, compiled per pose — and
every leg's frame follows in closed form (:func:`_legs`): the cardan R_rel = Rot(e₁, α) Rot(e₂, β) relative to its
reference link turns the leg's home direction onto the current one, t_leg from the cardan point; of the two β the
one nearest to the start's leg rotation (the configuration connected to the start, as the full path's
continuation); a crank's frame is Rot(g, s − offset) about b.  Any other structure (a serial wrist, planar
linkages) keeps the full path.

The controlled-output condition comes from the same 6 × 6 Jacobian: ∂x_c/∂s = G J⁻¹ diag(D) with
G = [[I, −[R o]×], [0, I]] for the output point o and ω and Dᵢ = −∂rᵢ/∂sᵢ, so κ(∂x_c/∂s) = κ(diag(D)⁻¹ J G⁻¹)
(one 6 × 6 Jacobi SVD per pose, :func:`_svd6`).

Poses for which the reduced solve does not certify a regular configuration — not converged, a lower bound of
σ_min/σ_max of diag(D)⁻¹ J below :data:`REGULAR_SCREEN`, a cardan near its lock, κ above 1/``singular_tol`` — are
solved again by the full link-and-joint path from their original start, so statuses, ranks and singular-value
ratios there are the full path's by construction.  ``PKMSTIFF_FULL_FK=1`` switches the fast path off.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from pkmstiff.mechanisms.kernel import _angles, _exp_left
from pkmstiff.mechanisms.model import Mechanism

Array = NDArray[np.float64]

#: lower bound of σ_min/σ_max of the reduced 6 × 6 Jacobian diag(D)⁻¹ J from which a converged pose is
#: regular without the full path's rank check: over the bundled 6-UPS/6X/Hexaglide workspaces the full system's
#: exact σ_min/σ_max is at least 0.01 of the bound (0.3 seen for the 6-UPS, 0.02 for the Hexaglide;
#: tests/test_mechanism_reduced.py checks 0.01), so a certified pose has ≥ 1e-5 there, 100 × the full path's
#: ``singular_tol`` (1e-7) and far above its gap floor (1e-8): it would be ``converged`` there too
REGULAR_SCREEN = 1e-3
#: a cardan whose leg direction v has |v·e₁| within this of its bound √(a₁² + a₃²) is near its lock: full path
_LOCK_MARGIN = 1e-6
#: codes of :func:`solve`
CONVERGED, FAILED = 0, 1
_CHUNK = 64
_PARALLEL_MIN = 2048


@dataclass(frozen=True)
class LegPlan:
    """The legs of a reducible mechanism (SI, world coordinates at home), in drive order.  Leg i imposes
    rᵢ = σᵢ|p − Aᵢ| + cᵢ − μᵢ sᵢ = 0 on the output point p = t + R Pᵢ with the anchor Aᵢ = bᵢ + (sᵢ − g0ᵢ) gᵢ:
    a telescopic leg (cardan on the ground at b, driven ``point_on_axis`` on the output link: σ|p − b| + c = s)
    a guided rod (driven ``point_on_axis`` on a ground guide through b along g, cardan on the output link:
    |p − A(s)| = L) or a crank and rod (the anchor is the crank tip).  Its cardan joins it to the reference link
    (``ref`` 0: ground, 1: output, 2: the crank) at K."""

    out_link: int
    leg_links: np.ndarray  #: (6,) leg link per drive
    P: np.ndarray  #: (6, 3) leg points on the output link (home)
    b: np.ndarray  #: (6, 3) anchor points on the ground (home)
    g: np.ndarray  #: (6, 3) guide directions (unit; 0 for a telescopic leg)
    g0: np.ndarray  #: (6,) drive value at which the anchor is at b [m]
    sign: np.ndarray  #: (6,) σ
    c: np.ndarray  #: (6,) c [m]
    mu: np.ndarray  #: (6,) μ (1 telescopic, 0 guided)
    K: np.ndarray  #: (6, 3) cardan points (home)
    ref: np.ndarray  #: (6,) int64 cardan reference link: 0 ground, 1 output, 2 the leg's crank
    crank: np.ndarray  #: (6,) int64 crank link of a crank leg (anchor b + Rot(g, s − g0)(K − b)), −1 otherwise
    e1: np.ndarray  #: (6, 3) cardan axes on the reference link (its frame)
    e2: np.ndarray  #: (6, 3) cardan axes on the leg (home)
    ac: np.ndarray  #: (6, 3) the leg direction a = (Q − K)/|Q − K| at home in the basis e₁, e₂, e₁ × e₂
    rho: np.ndarray  #: (6,) √(a₁² + a₃²): |v·e₁| ≤ ρ (beyond: the cardan cannot reach v)
    gam: np.ndarray  #: (6,) atan2(a₃, a₁)
    o: np.ndarray  #: (3,) the output point (home)


def leg_plan(mech: Mechanism) -> LegPlan | None:
    """The :class:`LegPlan` of a mechanism whose every non-ground link but the output belongs to one of six legs
    (telescopic, guided rod, crank and rod), else None (see the module docstring); cached on the mechanism."""
    cached = mech.__dict__.get("_leg_plan", False)
    if cached is not False:
        return cached
    plan = _find_legs(mech)
    mech.__dict__["_leg_plan"] = plan
    return plan


def _crank_leg(mech: Mechanism, ci: int, g: int, out: int) -> tuple | None:
    """The row of a crank leg (driven revolute on the ground at b about g, cardan at K to a rod, spherical at P on
    the output link: |p − b − Rot(g, s − offset)(K − b)| = |P − K|), or None."""
    js = [jt for jt in mech.joints if ci in jt.links]
    rev = [jt for jt in js if jt.type == "revolute" and jt.links == (g, ci) and jt.drive is not None]
    card = [jt for jt in js if jt.type == "cardan" and jt.links[0] == ci]
    if len(js) != 2 or len(rev) != 1 or len(card) != 1:
        return None
    rj, cj = rev[0], card[0]
    ri = cj.links[1]
    rjs = [jt for jt in mech.joints if ri in jt.links]
    sph = [jt for jt in rjs if jt.type == "spherical" and jt.links == (ri, out)]
    if len(rjs) != 2 or len(sph) != 1:
        return None
    L = float(np.linalg.norm(sph[0].point - cj.point))
    if L < 1e-9 * mech.length_scale:
        return None
    return (mech.drives.index(rj), ri, sph[0].point, rj.point, rj.axis, rj.drive.offset, 1.0, -L, 0.0, cj.point, 2,
            cj.axis, cj.axis2, sph[0].point, ci)


def _leg(mech: Mechanism, li: int, g: int, out: int) -> tuple | None:
    """One leg's row of the :class:`LegPlan` (drive index first), or None if link ``li`` is no such leg."""
    js = [jt for jt in mech.joints if li in jt.links]
    if len(js) != 2:
        return None
    card = [jt for jt in js if jt.type == "cardan" and jt.links[1] == li and jt.links[0] in (g, out)]
    poa = [jt for jt in js if jt.type == "point_on_axis" and jt.drive is not None]
    if len(card) != 1 or len(poa) != 1:
        return None
    cj, pj = card[0], poa[0]
    tol = 1e-12 * mech.length_scale
    if cj.links[0] == g and pj.links == (li, out):  # telescopic: P on the leg's axis through the cardan point
        d = pj.point - cj.point
        if np.linalg.norm(d) < 1e-9 * mech.length_scale or np.linalg.norm(np.cross(d, pj.axis)) > tol:
            return None
        da = float(d @ pj.axis)
        return (mech.drives.index(pj), li, pj.point, cj.point, np.zeros(3), 0.0, np.sign(da), pj.drive.offset - da,
                1.0, cj.point, 0, cj.axis, cj.axis2, pj.point, -1)
    if cj.links[0] == out and pj.links == (g, li):  # guided rod: carriage point on a ground guide
        L = float(np.linalg.norm(cj.point - pj.point))
        if L < 1e-9 * mech.length_scale:
            return None
        return (mech.drives.index(pj), li, cj.point, pj.point, pj.axis, pj.drive.offset, 1.0, -L, 0.0, cj.point, 1,
                cj.axis, cj.axis2, pj.point, -1)
    return None


def _find_legs(mech: Mechanism) -> LegPlan | None:
    o = mech.output
    if (mech.dim != 3 or o is None or o.orientation != "full" or tuple(o.coordinates) != (0, 1, 2)
            or len(mech.drives) != 6 or len(mech.ground) != 1):
        return None
    g, out = mech.ground[0], o.link
    legs = [li for li in range(len(mech.links)) if li not in (g, out)]
    if len(legs) == 6 and len(mech.joints) == 12:
        rows = [_leg(mech, li, g, out) for li in legs]
    elif len(legs) == 12 and len(mech.joints) == 18:
        cranks = [jt.links[1] for jt in mech.drives if jt.type == "revolute" and jt.links[0] == g]
        rows = [_crank_leg(mech, ci, g, out) for ci in cranks] if len(cranks) == 6 else [None]
        if any(r is None for r in rows) or len({r[1] for r in rows} | set(cranks)) != 12:
            return None
    else:
        return None
    if any(r is None for r in rows):
        return None
    rows.sort(key=lambda r: r[0])
    f = np.ascontiguousarray
    _, li, P, b, gd, g0, sg, c, mu, K, ref, e1, e2, Q, crank = (f(np.array(v)) for v in zip(*rows))
    a = (Q - K) / np.linalg.norm(Q - K, axis=1, keepdims=True)
    ac = f(np.stack([np.einsum("ia,ia->i", a, e) for e in (e1, e2, np.cross(e1, e2))], axis=1))
    return LegPlan(out, li.astype(np.int64), P, b, gd.astype(float), g0.astype(float), sg.astype(float),
                   c.astype(float), mu.astype(float), K, ref.astype(np.int64), crank.astype(np.int64), e1, e2, ac,
                   np.hypot(ac[:, 0], ac[:, 2]), np.arctan2(ac[:, 2], ac[:, 0]), np.asarray(o.point, dtype=float))


def enabled() -> bool:
    """The fast path is used unless ``PKMSTIFF_FULL_FK`` is set to 1 (tests compare both paths)."""
    return os.environ.get("PKMSTIFF_FULL_FK", "0") != "1"


# ----------------------------------------------------------------------------------------------------------
# compiled Newton on (t, R) of the output link
# ----------------------------------------------------------------------------------------------------------


def _turn(e, ang, x, y, z):  # pragma: no cover - compiled
    """Rot(e, ang) (x, y, z) for a unit axis e (Rodrigues)."""
    c, s_ = math.cos(ang), math.sin(ang)
    k = (e[0] * x + e[1] * y + e[2] * z) * (1.0 - c)
    return (x * c + (e[1] * z - e[2] * y) * s_ + e[0] * k, y * c + (e[2] * x - e[0] * z) * s_ + e[1] * k,
            z * c + (e[0] * y - e[1] * x) * s_ + e[2] * k)


def _eval(t, R, P, b, g, g0, sign, c, mu, K, crank, s, r, J, D):  # pragma: no cover - compiled
    """Residual r (6,) and Jacobian J (6, 6) (columns δt, δω) of the legs at (t, R): rᵢ = σᵢ|p − Aᵢ| + cᵢ − μᵢ sᵢ
    with the anchor Aᵢ = bᵢ + (sᵢ − g0ᵢ) gᵢ (or the crank tip bᵢ + Rot(gᵢ, sᵢ − g0ᵢ)(Kᵢ − bᵢ)); with J also
    D (6,) = −∂rᵢ/∂sᵢ = nᵢ·∂Aᵢ/∂sᵢ + μᵢ."""
    for i in range(6):
        rp0 = R[0, 0] * P[i, 0] + R[0, 1] * P[i, 1] + R[0, 2] * P[i, 2]
        rp1 = R[1, 0] * P[i, 0] + R[1, 1] * P[i, 1] + R[1, 2] * P[i, 2]
        rp2 = R[2, 0] * P[i, 0] + R[2, 1] * P[i, 1] + R[2, 2] * P[i, 2]
        h = s[i] - g0[i]
        if crank[i] < 0:  # anchor b + h g, ∂A/∂s = g
            a0, a1, a2 = h * g[i, 0], h * g[i, 1], h * g[i, 2]
            m0, m1, m2 = g[i, 0], g[i, 1], g[i, 2]
        else:  # crank tip b + Rot(g, h)(K − b), ∂A/∂s = g × (A − b)
            a0, a1, a2 = _turn(g[i], h, K[i, 0] - b[i, 0], K[i, 1] - b[i, 1], K[i, 2] - b[i, 2])
            m0, m1, m2 = g[i, 1] * a2 - g[i, 2] * a1, g[i, 2] * a0 - g[i, 0] * a2, g[i, 0] * a1 - g[i, 1] * a0
        d0 = t[0] + rp0 - b[i, 0] - a0
        d1 = t[1] + rp1 - b[i, 1] - a1
        d2 = t[2] + rp2 - b[i, 2] - a2
        ln = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        r[i] = sign[i] * ln + c[i] - mu[i] * s[i]
        if J.shape[0] == 6:
            n0, n1, n2 = sign[i] * d0 / ln, sign[i] * d1 / ln, sign[i] * d2 / ln
            J[i, 0], J[i, 1], J[i, 2] = n0, n1, n2
            J[i, 3], J[i, 4], J[i, 5] = rp1 * n2 - rp2 * n1, rp2 * n0 - rp0 * n2, rp0 * n1 - rp1 * n0
            D[i] = n0 * m0 + n1 * m1 + n2 * m2 + mu[i]


def _norms6(r):  # pragma: no cover - compiled
    """(max |rᵢ|, Σ rᵢ²) of a residual (6,); a NaN entry shows in the sum of squares."""
    rn = 0.0
    r2 = 0.0
    for i in range(6):
        r2 += r[i] * r[i]
        if not abs(r[i]) <= rn:
            rn = abs(r[i])
    return rn, r2


def _solve6(A, x):  # pragma: no cover - compiled
    """x ← A⁻¹ x by Gaussian elimination with partial pivoting (A (6, 6) is overwritten); False if singular."""
    for k in range(6):
        p = k
        for i in range(k + 1, 6):
            if abs(A[i, k]) > abs(A[p, k]):
                p = i
        if not abs(A[p, k]) > 0.0:
            return False
        if p != k:
            for j in range(6):
                A[k, j], A[p, j] = A[p, j], A[k, j]
            x[k], x[p] = x[p], x[k]
        for i in range(k + 1, 6):
            f = A[i, k] / A[k, k]
            for j in range(k, 6):
                A[i, j] -= f * A[k, j]
            x[i] -= f * x[k]
    for k in range(5, -1, -1):
        v = x[k]
        for j in range(k + 1, 6):
            v -= A[k, j] * x[j]
        x[k] = v / A[k, k]
    return True


def _svd6(A, sv):  # pragma: no cover - compiled
    """Singular values sv (6,) of A (6, 6) (overwritten) by one-sided Jacobi rotations (accurate to rounding
    relative to each σ, unlike the eigenvalues of AᵀA), descending."""
    for _sweep in range(30):
        off = 0.0
        for p in range(5):
            for q in range(p + 1, 6):
                al = be = ga = 0.0
                for i in range(6):
                    al += A[i, p] * A[i, p]
                    be += A[i, q] * A[i, q]
                    ga += A[i, p] * A[i, q]
                if ga == 0.0 or abs(ga) <= 1e-17 * math.sqrt(al * be):
                    continue
                off = max(off, abs(ga) / math.sqrt(al * be))
                z = (be - al) / (2.0 * ga)
                tt = (1.0 if z >= 0.0 else -1.0) / (abs(z) + math.sqrt(1.0 + z * z))
                cs = 1.0 / math.sqrt(1.0 + tt * tt)
                sn = cs * tt
                for i in range(6):
                    x, y = A[i, p], A[i, q]
                    A[i, p], A[i, q] = cs * x - sn * y, sn * x + cs * y
        if off <= 6e-16:  # n·ε
            break
    for j in range(6):
        v = 0.0
        for i in range(6):
            v += A[i, j] * A[i, j]
        sv[j] = math.sqrt(v)
    sv.sort()
    sv[:] = sv[::-1].copy()


def _rot_angles(x, y, z, out):  # pragma: no cover - compiled
    """out ← Rz(z) Ry(y) Rx(x) (eq. 2)."""
    cx, sx, cy, sy, cz, sz = math.cos(x), math.sin(x), math.cos(y), math.sin(y), math.cos(z), math.sin(z)
    out[0, 0], out[0, 1], out[0, 2] = cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx
    out[1, 0], out[1, 1], out[1, 2] = sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx
    out[2, 0], out[2, 1], out[2, 2] = -sy, cy * sx, cy * cx


def _rot_axis(e, ang, out):  # pragma: no cover - compiled
    """out ← rotation about the unit axis e by ang (Rodrigues)."""
    _exp_left(ang * e[0], ang * e[1], ang * e[2], _EYE, out)


def _legs(t, R, s, q0, q, leg_links, P, b, g, g0, K, ref, crank, e1, e2, ac, rho, gam,
          W):  # pragma: no cover - compiled
    """Leg frames into q (see :class:`LegPlan`); returns True where a cardan is near its lock.

    The cardan joins the leg to its reference link (ground: R_ref = I, or the output link: R_ref = R) at K; the
    leg's home direction a = (Q − K)/|Q − K| turns onto v = (Q' − K')/|Q' − K'| (Q' the output point t + R P or
    the anchor b + (s − g0) g).  R_rel = Rot(e₁, α) Rot(e₂, β) with R_rel a = R_refᵀ v: of the two β that solve
    (R_refᵀ v)·e₁ = a₁ cos β + a₃ sin β (a in the basis e₁, e₂, e₃) the one whose R_leg = R_ref R_rel is nearest
    (Frobenius) to the start's leg rotation; t_leg = K' − R_leg K."""
    R0, Ra, Rb, Rl, Rbest, Rr = W[0], W[1], W[2], W[3], W[4], W[5]
    kp = np.empty(3)
    qp = np.empty(3)
    w = np.empty(3)
    lock = False
    for i in range(6):
        h = s[i] - g0[i]
        if ref[i] == 0:
            Rr[:] = _EYE
        elif ref[i] == 1:
            Rr[:] = R
        else:  # the crank: Rot(g, h) about b
            _rot_axis(g[i], h, Rr)
            ci = 6 * crank[i]
            for a in range(3):
                q[ci + a] = b[i, a] - (Rr[a, 0] * b[i, 0] + Rr[a, 1] * b[i, 1] + Rr[a, 2] * b[i, 2])
            _angles(Rr[0, 0], Rr[1, 0], Rr[2, 0], Rr[0, 1], Rr[1, 1], Rr[0, 2], Rr[1, 2], q[ci + 3:ci + 6])
        for a in range(3):
            pa = t[a] + R[a, 0] * P[i, 0] + R[a, 1] * P[i, 1] + R[a, 2] * P[i, 2]
            if ref[i] == 1:  # guided rod: cardan on the output link, other end on the guide
                kp[a] = t[a] + R[a, 0] * K[i, 0] + R[a, 1] * K[i, 1] + R[a, 2] * K[i, 2]
                qp[a] = b[i, a] + h * g[i, a]
            else:  # cardan on the ground / the crank (its tip), other end at the output point
                kp[a] = b[i, a] + (Rr[a, 0] * (K[i, 0] - b[i, 0]) + Rr[a, 1] * (K[i, 1] - b[i, 1])
                                   + Rr[a, 2] * (K[i, 2] - b[i, 2]))
                qp[a] = pa
        f = 1.0 / math.sqrt((qp[0] - kp[0]) ** 2 + (qp[1] - kp[1]) ** 2 + (qp[2] - kp[2]) ** 2)
        for a in range(3):  # R_refᵀ v
            w[a] = f * (Rr[0, a] * (qp[0] - kp[0]) + Rr[1, a] * (qp[1] - kp[1]) + Rr[2, a] * (qp[2] - kp[2]))
        e3 = (e1[i, 1] * e2[i, 2] - e1[i, 2] * e2[i, 1], e1[i, 2] * e2[i, 0] - e1[i, 0] * e2[i, 2],
              e1[i, 0] * e2[i, 1] - e1[i, 1] * e2[i, 0])
        v1 = w[0] * e1[i, 0] + w[1] * e1[i, 1] + w[2] * e1[i, 2]
        v2 = w[0] * e2[i, 0] + w[1] * e2[i, 1] + w[2] * e2[i, 2]
        v3 = w[0] * e3[0] + w[1] * e3[1] + w[2] * e3[2]
        x = v1 / rho[i]
        if abs(x) > 1.0 - _LOCK_MARGIN:
            lock = True
        dl = math.acos(min(1.0, max(-1.0, x)))
        o = 6 * leg_links[i]
        _rot_angles(q0[o + 3], q0[o + 4], q0[o + 5], R0)
        best = np.inf
        for br in (1.0, -1.0):
            beta = gam[i] + br * dl
            p3 = ac[i, 2] * math.cos(beta) - ac[i, 0] * math.sin(beta)
            alpha = math.atan2(v3, v2) - math.atan2(p3, ac[i, 1])
            _rot_axis(e1[i], alpha, Ra)
            _rot_axis(e2[i], beta, Rb)
            for r_ in range(3):
                for c_ in range(3):
                    Rl[r_, c_] = Ra[r_, 0] * Rb[0, c_] + Ra[r_, 1] * Rb[1, c_] + Ra[r_, 2] * Rb[2, c_]
            if ref[i] != 0:  # R_leg = R_ref R_rel
                for c_ in range(3):
                    x0, x1, x2 = Rl[0, c_], Rl[1, c_], Rl[2, c_]
                    for r_ in range(3):
                        Rl[r_, c_] = Rr[r_, 0] * x0 + Rr[r_, 1] * x1 + Rr[r_, 2] * x2
            dist = 0.0
            for r_ in range(3):
                for c_ in range(3):
                    dist += (Rl[r_, c_] - R0[r_, c_]) ** 2
            if dist < best:
                best = dist
                Rbest[:] = Rl
        for a in range(3):
            q[o + a] = kp[a] - (Rbest[a, 0] * K[i, 0] + Rbest[a, 1] * K[i, 1] + Rbest[a, 2] * K[i, 2])
        _angles(Rbest[0, 0], Rbest[1, 0], Rbest[2, 0], Rbest[0, 1], Rbest[1, 1], Rbest[0, 2], Rbest[1, 2],
                q[o + 3:o + 6])
    return lock


def _newton_chunk(Q0, S0, S1, n_steps, out_link, leg_links, P, b, g, g0, sign, c, mu, K, ref, crank, e1, e2, ac, rho, gam, o,
                  tol, path_tol, max_iter, max_backtrack, armijo, Q, code, iters, resid, rcond, kappa, lock, n0,
                  n1):  # pragma: no cover - compiled
    r = np.empty(6)
    rt = np.empty(6)
    D = np.empty(6)
    J = np.empty((6, 6))
    Jt = np.empty((6, 6))
    Jd = np.empty((1, 1))
    A = np.empty((6, 6))
    dx = np.empty(6)
    sv = np.empty(6)
    s = np.empty(6)
    t = np.empty(3)
    tt = np.empty(3)
    R = np.empty((3, 3))
    Rt = np.empty((3, 3))
    W = np.empty((6, 3, 3))
    a2 = (1.0 - armijo) ** 2
    ol = 6 * out_link
    for p in range(n0, n1):
        q0 = Q0[min(p, Q0.shape[0] - 1)]
        s0 = S0[min(p, S0.shape[0] - 1)]
        t[:] = q0[ol:ol + 3]
        _rot_angles(q0[ol + 3], q0[ol + 4], q0[ol + 5], R)
        ns = n_steps[p]
        st = CONVERGED
        acc = 0
        rn = np.inf
        for k in range(1, ns + 1):
            for i in range(6):
                s[i] = s0[i] + (k / ns) * (S1[p, i] - s0[i])
            tk = tol if k == ns else path_tol
            _eval(t, R, P, b, g, g0, sign, c, mu, K, crank, s, r, J, D)
            st = FAILED
            for it_ in range(max_iter + 1):
                rn, r2 = _norms6(r)
                if rn <= tk:
                    st = CONVERGED
                    break
                if it_ == max_iter:
                    break
                A[:] = J
                for i in range(6):
                    dx[i] = -r[i]
                if not _solve6(A, dx):
                    break
                alpha = 1.0
                ok = False
                for _ in range(max_backtrack + 1):
                    for i in range(3):
                        tt[i] = t[i] + alpha * dx[i]
                    _exp_left(alpha * dx[3], alpha * dx[4], alpha * dx[5], R, Rt)
                    _eval(tt, Rt, P, b, g, g0, sign, c, mu, K, crank, s, rt, Jt if alpha == 1.0 else Jd, D)
                    tmax, t2 = _norms6(rt)
                    if math.isfinite(t2) and (t2 <= (1.0 - armijo * alpha) ** 2 * r2
                                              or (alpha == 1.0 and (t2 <= a2 * r2 or tmax <= tk))):
                        ok = True
                        break
                    alpha *= 0.5
                if not ok:
                    st = CONVERGED if rn <= 10.0 * tk else FAILED
                    break
                t[:] = tt
                R[:] = Rt
                acc += 1
                if alpha == 1.0:
                    r, rt = rt, r
                    J, Jt = Jt, J
                else:
                    _eval(t, R, P, b, g, g0, sign, c, mu, K, crank, s, r, J, D)
            if st != CONVERGED:
                break
        code[p] = st
        iters[p] = acc
        resid[p] = rn
        if st != CONVERGED:
            continue
        qp = Q[p]
        qp[:] = 0.0
        qp[ol:ol + 3] = t
        _angles(R[0, 0], R[1, 0], R[2, 0], R[0, 1], R[1, 1], R[0, 2], R[1, 2], qp[ol + 3:ol + 6])
        lock[p] = _legs(t, R, s, q0, qp, leg_links, P, b, g, g0, K, ref, crank, e1, e2, ac, rho, gam, W)
        # ∂x_c/∂s = G J⁻¹ diag(D): κ = κ(diag(D)⁻¹ J G⁻¹), G⁻¹ = [[I, [R o]×], [0, I]] (δω columns gain J_t [R o]×)
        _eval(t, R, P, b, g, g0, sign, c, mu, K, crank, s, r, J, D)
        ro0 = R[0, 0] * o[0] + R[0, 1] * o[1] + R[0, 2] * o[2]
        ro1 = R[1, 0] * o[0] + R[1, 1] * o[1] + R[1, 2] * o[2]
        ro2 = R[2, 0] * o[0] + R[2, 1] * o[1] + R[2, 2] * o[2]
        for i in range(6):
            A[i, 0], A[i, 1], A[i, 2] = J[i, 0], J[i, 1], J[i, 2]
            A[i, 3] = J[i, 3] + J[i, 1] * ro2 - J[i, 2] * ro1
            A[i, 4] = J[i, 4] + J[i, 2] * ro0 - J[i, 0] * ro2
            A[i, 5] = J[i, 5] + J[i, 0] * ro1 - J[i, 1] * ro0
            for j in range(6):
                A[i, j] /= D[i]
        _svd6(A, sv)
        kappa[p] = sv[0] / sv[5] if sv[5] > 1e-14 * sv[0] else np.inf
        # D⁻¹J = (D⁻¹J G⁻¹) G: its σ_min/σ_max ≥ 1/(κ(D⁻¹J G⁻¹) κ(G)), κ(G) = ((|Ro| + √(|Ro|² + 4))/2)²
        x = math.sqrt(ro0 * ro0 + ro1 * ro1 + ro2 * ro2)
        rcond[p] = 1.0 / (kappa[p] * (0.5 * (x + math.sqrt(x * x + 4.0))) ** 2)


def _newton_impl(Q0, S0, S1, n_steps, out_link, leg_links, P, b, g, g0, sign, c, mu, K, ref, crank, e1, e2, ac, rho, gam, o,
                 tol, path_tol, max_iter, max_backtrack, armijo, Q, code, iters, resid, rcond, kappa,
                 lock):  # pragma: no cover - compiled
    N = S1.shape[0]
    for ch in numba.prange((N + _CHUNK - 1) // _CHUNK):
        _newton_chunk(Q0, S0, S1, n_steps, out_link, leg_links, P, b, g, g0, sign, c, mu, K, ref, crank, e1, e2, ac, rho, gam,
                      o, tol, path_tol, max_iter, max_backtrack, armijo, Q, code, iters, resid, rcond, kappa, lock,
                      ch * _CHUNK, min(N, (ch + 1) * _CHUNK))


_EYE = np.eye(3)
_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}
_turn = numba.njit(**_OPTS)(_turn)
_eval = numba.njit(**_OPTS)(_eval)
_norms6 = numba.njit(inline="always", **_OPTS)(_norms6)
_solve6 = numba.njit(**_OPTS)(_solve6)
_svd6 = numba.njit(**_OPTS)(_svd6)
_rot_angles = numba.njit(**_OPTS)(_rot_angles)
_rot_axis = numba.njit(**_OPTS)(_rot_axis)
_legs = numba.njit(**_OPTS)(_legs)
_newton_chunk = numba.njit(**_OPTS)(_newton_chunk)
_newton_parallel = numba.njit(parallel=True, **_OPTS)(_newton_impl)


@numba.njit(**_OPTS)
def _newton_serial(Q0, S0, S1, n_steps, out_link, leg_links, P, b, g, g0, sign, c, mu, K, ref, crank, e1, e2, ac, rho, gam, o,
                   tol, path_tol, max_iter, max_backtrack, armijo, Q, code, iters, resid, rcond, kappa,
                   lock):  # pragma: no cover - compiled
    _newton_chunk(Q0, S0, S1, n_steps, out_link, leg_links, P, b, g, g0, sign, c, mu, K, ref, crank, e1, e2, ac, rho, gam, o,
                  tol, path_tol, max_iter, max_backtrack, armijo, Q, code, iters, resid, rcond, kappa, lock, 0,
                  S1.shape[0])


def solve(mech: Mechanism, lp: LegPlan, q0: Array, s0: Array, s1: Array, n_steps: Array, tol: float,
          path_tol: float, max_iter: int, max_backtrack: int, armijo: float) -> tuple:
    """Continuation in ``n_steps`` (N,) equal drive steps from the start (q0 (1 or N, L, 6), drive values s0
    (1 or N, 6)) to s1 (N, 6) [m], each a damped Newton on the output frame to ``path_tol`` (intermediate) /
    ``tol`` (last) on max |r|; then the legs in closed form.  Returns q (N, L, 6), code (N,), accepted steps,
    max |r|, a lower bound of σ_min/σ_max of diag(D)⁻¹ J, κ(∂x_c/∂s) and the cardan-lock flag (NaN/False
    where failed)."""
    N, L = s1.shape[0], len(mech.links)
    Q = np.full((N, L * 6), np.nan)
    code = np.empty(N, dtype=np.int64)
    iters = np.zeros(N, dtype=np.int64)
    resid = np.full(N, np.inf)
    rcond = np.full(N, np.nan)
    kappa = np.full(N, np.nan)
    lock = np.zeros(N, dtype=np.bool_)
    kern = _newton_parallel if N >= _PARALLEL_MIN else _newton_serial
    f = np.ascontiguousarray
    kern(f(q0.reshape(q0.shape[0], -1), dtype=float), f(s0, dtype=float), f(s1, dtype=float),
         f(n_steps, dtype=np.int64), lp.out_link, lp.leg_links, lp.P, lp.b, lp.g, lp.g0, lp.sign, lp.c, lp.mu, lp.K,
         lp.ref, lp.crank, lp.e1, lp.e2, lp.ac, lp.rho, lp.gam, lp.o, float(tol), float(path_tol), int(max_iter),
         int(max_backtrack), float(armijo), Q, code, iters, resid, rcond, kappa, lock)
    return Q.reshape(N, L, 6), code, iters, resid, rcond, kappa, lock
