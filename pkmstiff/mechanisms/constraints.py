"""Residuals and analytic Jacobians of the elementary constraints, vectorised over poses (DE 10 2004 026 707 A1).

Unknowns ``q`` have shape (N, L, d): per link the frame position t and the angles φ (d = 6 in space with
R = Rz(φz) Ry(φy) Rx(φx), eq. 2; d = 3 in the plane, eq. 9).  A :class:`System` is a mechanism's model equations
(eq. 3–7, fixed coordinates eq. 15–16) plus control equations: drive equations (eq. 8, its projection on the axis;
relative angles for revolute drives) for forward kinematics, or output equations (link coordinates set,
patent [0017]) for inverse kinematics.  Every constraint kind is evaluated for all its instances and all poses
at once; Jacobian blocks are scattered into a dense (N, m, L·d) matrix.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pkmstiff.mechanisms import kernel
from pkmstiff.mechanisms.kernel import make_plan
from pkmstiff.mechanisms.model import ROWS, Joint, Mechanism
from pkmstiff.mechanisms.model import JOINT_TYPES_2D, JOINT_TYPES_3D

Array = NDArray[np.float64]


# ----------------------------------------------------------------------------------------------------------
# link rotations (eq. 2, eq. 9) and their derivatives
# ----------------------------------------------------------------------------------------------------------


def link_rotations(phi: Array, dim: int) -> tuple[Array, Array]:
    """R (…, D, D) and ∂R/∂φ_c (…, nr, D, D) of link angles ``phi`` (…, nr): eq. 2 (R = Rz Ry Rx) or eq. 9."""
    if dim == 2:
        c, s = np.cos(phi[..., 0]), np.sin(phi[..., 0])
        R = np.empty(phi.shape[:-1] + (2, 2))
        R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1] = c, -s, s, c
        dR = np.empty(phi.shape[:-1] + (1, 2, 2))
        dR[..., 0, 0, 0], dR[..., 0, 0, 1], dR[..., 0, 1, 0], dR[..., 0, 1, 1] = -s, -c, c, -s
        return R, dR
    sh = phi.shape[:-1]
    cx, sx = np.cos(phi[..., 0]), np.sin(phi[..., 0])
    cy, sy = np.cos(phi[..., 1]), np.sin(phi[..., 1])
    cz, sz = np.cos(phi[..., 2]), np.sin(phi[..., 2])
    z0, o1 = np.zeros(sh), np.ones(sh)

    def m(*e):
        return np.stack(e, axis=-1).reshape(sh + (3, 3))

    Rx, dRx = m(o1, z0, z0, z0, cx, -sx, z0, sx, cx), m(z0, z0, z0, z0, -sx, -cx, z0, cx, -sx)
    Ry, dRy = m(cy, z0, sy, z0, o1, z0, -sy, z0, cy), m(-sy, z0, cy, z0, z0, z0, -cy, z0, -sy)
    Rz, dRz = m(cz, -sz, z0, sz, cz, z0, z0, z0, o1), m(-sz, -cz, z0, cz, -sz, z0, z0, z0, z0)
    RzRy = Rz @ Ry
    R = RzRy @ Rx
    dR = np.stack([RzRy @ dRx, Rz @ dRy @ Rx, dRz @ Ry @ Rx], axis=-3)
    return R, dR


def link_angles(R: Array) -> Array:
    """Angles (φx, φy, φz) of R = Rz Ry Rx (…, 3, 3), |φy| ≤ 90° (inverse of eq. 2).

    φz and φy come from the first column; φx from Rx = Ry(φy)ᵀ Rz(φz)ᵀ R, so that R(φ) reproduces R to rounding
    also at and near φy = ±90°, where φx and φz are not determined separately (there φz may take any value)."""
    out = np.empty(R.shape[:-2] + (3,))
    c1 = np.hypot(R[..., 0, 0], R[..., 1, 0])
    out[..., 1] = np.arctan2(-R[..., 2, 0], c1)
    out[..., 2] = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    cz, sz = np.cos(out[..., 2]), np.sin(out[..., 2])
    # rows 1 and 2 of Rz(φz)ᵀ R: (−sz, cz, 0)·R and R's third row; then Ry(φy)ᵀ leaves row 1 as cos φx, sin φx
    r1 = -sz[..., None] * R[..., 0, :] + cz[..., None] * R[..., 1, :]  # = (0, cos φx, −sin φx) of Rx
    out[..., 0] = np.arctan2(-r1[..., 2], r1[..., 1])
    return out


def rotation_log(M: Array) -> Array:
    """Rotation vectors r (…, 3) of rotation matrices M (…, 3, 3), |r| ∈ [0, π] (the compiled ``_logm``)."""
    v = 0.5 * np.stack([M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]], -1)
    sn = np.linalg.norm(v, axis=-1)
    cs = 0.5 * (np.trace(M, axis1=-2, axis2=-1) - 1.0)
    th = np.arctan2(sn, cs)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(sn < 1e-8, 1.0 + sn * sn / 6.0, th / sn)
    r = f[..., None] * v
    far = cs <= -0.99
    if far.any():  # near half a turn: axis from the symmetric part, sign from v
        Mf, vf, csf, thf = M[far], v[far], cs[far], th[far]
        i = np.argmax(np.diagonal(Mf, axis1=-2, axis2=-1), axis=-1)
        n = np.arange(i.size)
        u = 0.5 * (Mf[n, :, i] + Mf[n, i, :])
        u[n, i] = Mf[n, i, i] - csf
        sg = np.where(np.einsum("na,na->n", u, vf) >= 0.0, 1.0, -1.0)
        r[far] = (sg * thf / np.linalg.norm(u, axis=-1))[:, None] * u
    return r


def left_jacobian_inverse(r: Array) -> Array:
    """J_l⁻¹(r) (…, 3, 3) = I − ½[r]× + (1/θ² − (1 + cos θ)/(2θ sin θ))[r]×², d log(exp(δ) M)/dδ at r = log M."""
    th2 = np.einsum("...a,...a->...", r, r)
    th = np.sqrt(th2)
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.where(th < 1e-4, 1.0 / 12.0 + th2 / 720.0, 1.0 / th2 - (1.0 + np.cos(th)) / (2.0 * th * np.sin(th)))
    K = np.zeros(r.shape + (3,))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -r[..., 2], r[..., 1], -r[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = r[..., 2], -r[..., 1], r[..., 0]
    return np.eye(3) - 0.5 * K + g[..., None, None] * (K @ K)


def wrap(a: Array) -> Array:
    """Angles wrapped to (−π, π]."""
    return np.pi - np.mod(np.pi - a, 2.0 * np.pi)


def cardan_pose_rotation(angles: Array) -> Array:
    """Rotation of pose angles a, b, c (N, 3) in pkmstiff's Cardan convention R = R_a R_b R_c (models.md §1.1)."""
    from pkmstiff.kinematics.rotation import cardan_matrix

    return cardan_matrix(angles[:, 0], angles[:, 1], angles[:, 2])


# ----------------------------------------------------------------------------------------------------------
# compiled constraint blocks
# ----------------------------------------------------------------------------------------------------------


@dataclass
class Block:
    """All instances of one constraint kind: links j, k (k = −1: the world), points, axes, rows."""

    kind: str
    joint: np.ndarray  #: (nc,) index of the joint each instance comes from (−1: output/control)
    j: np.ndarray  #: (nc,) link index
    k: np.ndarray  #: (nc,) link index or −1
    p: np.ndarray  #: (nc, D)
    a: np.ndarray  #: (nc, D) axis (1C, 1D on link j, 1E, 1F normal, drives)
    b: np.ndarray  #: (nc, D) second axis (1D on link k; revolute drive reference vector ⊥ a)
    nrows: int  #: rows per instance
    row0: int = 0  #: first row of the block in the system
    coord: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))  #: fixed / output coordinates
    value: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: fixed values / drive offsets

    @property
    def n(self) -> int:
        return int(self.j.size)

    @property
    def rows(self) -> int:
        return self.n * self.nrows


def _perp(a: np.ndarray) -> np.ndarray:
    """A unit vector ⊥ a (the coordinate axis least aligned with a, orthogonalised)."""
    e = np.zeros(3)
    e[int(np.argmin(np.abs(a)))] = 1.0
    u = np.cross(a, e)
    return u / np.linalg.norm(u)


def _elementaries(mech: Mechanism, jt: Joint) -> tuple[str, ...]:
    return (JOINT_TYPES_3D if mech.dim == 3 else JOINT_TYPES_2D)[jt.type]


def model_blocks(mech: Mechanism, joints: list[int] | None = None, ground: bool = True) -> list[Block]:
    """Blocks of the model equations: every joint's elementary constraints and the ground's fixed coordinates."""
    D = mech.dim
    nr = 3 if D == 3 else 1
    acc: dict[str, list] = {}
    zero = np.zeros(D)

    def add(kind, ji, j, k, p=zero, a=zero, b=zero, coord=-1, value=0.0):
        acc.setdefault(kind, []).append((ji, j, k, p, a, b, coord, value))

    for ji in range(len(mech.joints)) if joints is None else joints:
        jt = mech.joints[ji]
        j, k = jt.links
        for e in _elementaries(mech, jt):
            if e == "fixed":
                for c, v in zip(jt.coordinates, jt.values):
                    add("fixed", ji, j, -1, coord=c, value=v)
            elif e == "1D":
                add("1D", ji, j, k, jt.point, jt.axis, jt.axis2)
            elif e == "1F" or (e == "1C" and jt.type == "planar"):
                add(e, ji, j, k, jt.point, jt.axis)
            else:
                add(e, ji, j, k, jt.point, jt.axis if jt.axis is not None else zero)
    if ground:
        for g in mech.ground:
            for c in range(D + nr):
                add("fixed", -1, g, -1, coord=c, value=0.0)
    order = ("fixed", "1A", "1B", "1C", "1D", "1E", "1F")
    return [_block(kind, acc[kind], ROWS[D][kind]) for kind in order if kind in acc]


def _block(kind: str, items: list, nrows: int) -> Block:
    ji, j, k, p, a, b, coord, value = zip(*items)
    return Block(kind, np.array(ji), np.array(j), np.array(k), np.array(p, dtype=float), np.array(a, dtype=float),
                 np.array(b, dtype=float), nrows, coord=np.array(coord, dtype=int), value=np.array(value, dtype=float))


def drive_blocks(mech: Mechanism) -> list[Block]:
    """Drive equations of the active joints, in file order (eq. 8 projected on the axis; relative angles)."""
    out = []
    for i, ji in enumerate(ji for ji, jt in enumerate(mech.joints) if jt.drive is not None):
        jt = mech.joints[ji]
        j, k = jt.links
        if jt.variable == "linear":
            out.append(Block("drive_lin", np.array([ji]), np.array([j]), np.array([k]), jt.point[None],
                             jt.axis[None], np.zeros((1, mech.dim)), 1, coord=np.array([i]),
                             value=np.array([jt.drive.offset])))
        else:
            b = _perp(jt.axis) if mech.dim == 3 else np.zeros(2)
            out.append(Block("drive_rot", np.array([ji]), np.array([j]), np.array([k]), jt.point[None],
                             (jt.axis if mech.dim == 3 else np.zeros(2))[None], b[None], 1,
                             coord=np.array([i]), value=np.array([jt.drive.offset])))
    return _merge(out)


def _merge(blocks: list[Block]) -> list[Block]:
    by: dict[str, list[Block]] = {}
    for b in blocks:
        by.setdefault(b.kind, []).append(b)
    out = []
    for kind, bs in by.items():
        out.append(Block(kind, np.concatenate([b.joint for b in bs]), np.concatenate([b.j for b in bs]),
                         np.concatenate([b.k for b in bs]), np.concatenate([b.p for b in bs]),
                         np.concatenate([b.a for b in bs]), np.concatenate([b.b for b in bs]), bs[0].nrows,
                         coord=np.concatenate([b.coord for b in bs]), value=np.concatenate([b.value for b in bs])))
    return out


def output_blocks(mech: Mechanism) -> list[Block]:
    """Output equations for inverse kinematics: point coordinates, then orientation (full angles or axis)."""
    o = mech.output
    D = mech.dim
    one = lambda v: np.asarray(v, dtype=float)[None]  # noqa: E731
    z = np.zeros((1, D))
    blocks = [Block("out_point", np.array([-1]), np.array([o.link]), np.array([-1]), one(o.point), z, z,
                    len(o.coordinates), coord=np.array(o.coordinates))]
    if o.orientation == "full":
        blocks.append(Block("out_full", np.array([-1]), np.array([o.link]), np.array([-1]), z, z, z, 3 if D == 3 else 1))
    elif o.orientation == "axis":
        blocks.append(Block("out_axis", np.array([-1]), np.array([o.link]), np.array([-1]), z, one(o.axis), z, 3))
    return blocks


# ----------------------------------------------------------------------------------------------------------
# evaluation
# ----------------------------------------------------------------------------------------------------------


class Frames:
    """Link frames of N configurations: t (N, L, D), R (N, L, D, D), dR (N, L, nr, D, D)."""

    def __init__(self, q: Array, dim: int, derivatives: bool = True, omega: np.ndarray | None = None):
        self.q, self.dim = q, dim
        self.t = q[..., :dim]
        self.R, self.dR = link_rotations(q[..., dim:], dim)
        if omega is not None and omega.any():  # incremental rotation vectors: ∂R/∂ω_c = [e_c]× R
            E = np.zeros((3, 3, 3))
            for c in range(3):
                E[c, (c + 2) % 3, (c + 1) % 3], E[c, (c + 1) % 3, (c + 2) % 3] = 1.0, -1.0
            self.dR[:, omega] = np.einsum("cab,nlbd->nlcad", E, self.R[:, omega])
        if not derivatives:
            self.dR = None

    def rates(self, li: np.ndarray) -> Array:
        """w (N, nc, 3, nr): angular velocity vee(∂R/∂q_c Rᵀ) of links li per unit rate of rotation coordinate c."""
        W = np.einsum("nkcab,nkdb->nkcad", self.dR[:, li], self.R[:, li])
        return np.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], axis=-1).swapaxes(-1, -2)

    def point(self, li: np.ndarray, p: Array) -> tuple[Array, Array | None]:
        """World points w = t + R p (N, nc, D) and ∂w/∂φ (N, nc, D, nr) of local points p (nc, D) on links li
        (None if the frames were built without derivatives)."""
        w = self.t[:, li] + np.einsum("nkab,kb->nka", self.R[:, li], p)
        return w, None if self.dR is None else np.einsum("nkcab,kb->nkac", self.dR[:, li], p)

    def vector(self, li: np.ndarray, a: Array) -> tuple[Array, Array | None]:
        """World vectors U = R a (N, nc, D) and ∂U/∂φ (N, nc, D, nr) (None without derivatives)."""
        U = np.einsum("nkab,kb->nka", self.R[:, li], a)
        return U, None if self.dR is None else np.einsum("nkcab,kb->nkac", self.dR[:, li], a)


def _skew_cols(u: Array) -> Array:
    """Matrix M (…, 3, 3) with M e_c = e_c × u."""
    M = np.zeros(u.shape + (3,))
    M[..., 0, 1], M[..., 0, 2] = u[..., 2], -u[..., 1]
    M[..., 1, 0], M[..., 1, 2] = -u[..., 2], u[..., 0]
    M[..., 2, 0], M[..., 2, 1] = u[..., 1], -u[..., 0]
    return M


def _cross(a: Array, b: Array) -> Array:
    """a × b over the last axis (length 3), broadcasting; cheaper than numpy's cross for small arrays."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _cross_cols(A: Array, u: Array) -> Array:
    """Columns A[..., :, c] × u for A (…, 3, nc) and u (…, 3)."""
    return _cross(np.swapaxes(A, -1, -2), u[..., None, :]).swapaxes(-1, -2)


def _cross2(a: Array, b: Array) -> Array:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def block_eval(bl: Block, F: Frames, target: Array | None) -> tuple[Array, Array | None, Array | None]:
    """Residual (N, nc, rows) and Jacobian blocks wrt link j and link k (N, nc, rows, d) of one block."""
    D = F.dim
    N = F.q.shape[0]
    nr = 3 if D == 3 else 1
    d = D + nr
    nc, rows = bl.n, bl.nrows
    Jj = np.zeros((N, nc, rows, d))
    Jk = np.zeros((N, nc, rows, d)) if (bl.k >= 0).any() else None
    I = np.eye(D)
    kind = bl.kind
    if kind == "fixed":
        r = (F.q[:, bl.j, bl.coord] - bl.value)[..., None]
        Jj[:, np.arange(nc), 0, bl.coord] = 1.0
        return r, Jj, None
    if kind in ("1A", "1E", "1F", "drive_lin"):
        wj, Dwj = F.point(bl.j, bl.p)
        wk, Dwk = F.point(bl.k, bl.p)
        delta = wj - wk
    if kind == "1A":
        Jj[..., :D], Jj[..., D:] = I, Dwj
        Jk[..., :D], Jk[..., D:] = -I, -Dwk
        return delta, Jj, Jk
    if kind == "1B":
        if D == 2:
            Jj[..., D:], Jk[..., D:] = 1.0, -1.0
            return F.q[:, bl.j, D:] - F.q[:, bl.k, D:], Jj, Jk
        # log(R_j R_kᵀ) = 0: the only root is equal orientation (angle differences φ_j − φ_k would tie the
        # equation to the Euler angles and their singularity at φy = ±90°)
        M = F.R[:, bl.j] @ np.swapaxes(F.R[:, bl.k], -1, -2)
        r = rotation_log(M)
        Ji = left_jacobian_inverse(r)
        Jj[..., D:] = Ji @ F.rates(bl.j)
        Jk[..., D:] = -Ji @ M @ F.rates(bl.k)
        return r, Jj, Jk
    if kind == "1C":
        Uj, DUj = F.vector(bl.j, bl.a)
        Uk, DUk = F.vector(bl.k, bl.a)
        Jj[..., D:], Jk[..., D:] = DUj, -DUk
        return Uj - Uk, Jj, Jk
    if kind == "1D":
        Uj, DUj = F.vector(bl.j, bl.a)
        Uk, DUk = F.vector(bl.k, bl.b)
        Jj[..., 0, D:] = np.einsum("nkac,nka->nkc", DUj, Uk)
        Jk[..., 0, D:] = np.einsum("nkac,nka->nkc", DUk, Uj)
        return np.einsum("nka,nka->nk", Uj, Uk)[..., None], Jj, Jk
    if kind == "1E":
        u, Du = F.vector(bl.j, bl.a)
        if D == 3:
            M = _skew_cols(u)  # e_c × u
            Jj[..., :D], Jk[..., :D] = M, -M
            Jj[..., D:] = _cross_cols(Dwj, u) + _cross(delta[..., None, :], np.swapaxes(Du, -1, -2)).swapaxes(-1, -2)
            Jk[..., D:] = -_cross_cols(Dwk, u)
            return _cross(delta, u), Jj, Jk
        g = np.stack([u[..., 1], -u[..., 0]], axis=-1)  # ∂(Δ×u)/∂Δ
        Jj[..., 0, :D], Jk[..., 0, :D] = g, -g
        Jj[..., 0, D] = _cross2(Dwj[..., 0], u) + _cross2(delta, Du[..., 0])
        Jk[..., 0, D] = -_cross2(Dwk[..., 0], u)
        return _cross2(delta, u)[..., None], Jj, Jk
    if kind in ("1F", "drive_lin"):
        u, Du = F.vector(bl.j, bl.a)
        sgn = 1.0 if kind == "1F" else -1.0  # 1F: u·(w_j − w_k); drive: u·(w_k − w_j) + offset − s
        Jj[..., 0, :D], Jk[..., 0, :D] = sgn * u, -sgn * u
        Jj[..., 0, D:] = sgn * (np.einsum("nkac,nka->nkc", Dwj, u) + np.einsum("nka,nkac->nkc", delta, Du))
        Jk[..., 0, D:] = -sgn * np.einsum("nkac,nka->nkc", Dwk, u)
        r = sgn * np.einsum("nka,nka->nk", delta, u)
        if kind == "drive_lin":
            r = r + bl.value - target[:, bl.coord]
        return r[..., None], Jj, Jk
    if kind == "drive_rot":
        th = target[:, bl.coord] - bl.value
        if D == 2:
            Jj[..., 0, D], Jk[..., 0, D] = -1.0, 1.0
            return (F.q[:, bl.k, D] - F.q[:, bl.j, D] - th)[..., None], Jj, Jk
        A, DA = F.vector(bl.j, bl.a)
        U, DU = F.vector(bl.j, bl.b)
        V, DV = F.vector(bl.k, bl.b)
        S = np.einsum("nka,nka->nk", A, _cross(U, V))
        C = np.einsum("nka,nka->nk", U, V)
        dS_j = np.einsum("nkac,nka->nkc", DA, _cross(U, V)) + np.einsum("nkac,nka->nkc", DU, _cross(V, A))
        dS_k = np.einsum("nkac,nka->nkc", DV, _cross(A, U))
        dC_j = np.einsum("nkac,nka->nkc", DU, V)
        dC_k = np.einsum("nkac,nka->nkc", DV, U)
        # wrapped angle difference atan2(sin(θ − θ*), cos(θ − θ*)) with θ = atan2(S, C): its only root is θ = θ*
        # (mod 2π) — sin(θ − θ*) also vanishes at θ* + π; ∂r = (C ∂S − S ∂C)/(S² + C²), independent of θ*
        c0, s0 = np.cos(th), np.sin(th)
        n2 = (S * S + C * C)[..., None]
        Jj[..., 0, D:] = (C[..., None] * dS_j - S[..., None] * dC_j) / n2
        Jk[..., 0, D:] = (C[..., None] * dS_k - S[..., None] * dC_k) / n2
        return np.arctan2(c0 * S - s0 * C, c0 * C + s0 * S)[..., None], Jj, Jk
    if kind == "out_point":
        w, Dw = F.point(bl.j, bl.p)
        c = bl.coord
        Jj[..., :D] = I[c]
        Jj[..., D:] = Dw[:, :, c]
        return w[:, :, c] - target[:, None, c], Jj, None
    if kind == "out_full":
        if D == 2:
            Jj[..., D:] = 1.0
            return wrap(F.q[:, bl.j, D:] - target[:, None, 2:3]), Jj, None
        M = F.R[:, bl.j] @ np.swapaxes(cardan_pose_rotation(target[:, 3:6]), -1, -2)[:, None]
        r = rotation_log(M)
        Jj[..., D:] = left_jacobian_inverse(r) @ F.rates(bl.j)
        return r, Jj, None
    if kind == "out_axis":
        U, DU = F.vector(bl.j, bl.a)
        Rt = cardan_pose_rotation(target[:, 3:6])
        Jj[..., D:] = DU
        return U - np.einsum("nab,kb->nka", Rt, bl.a), Jj, None
    raise ValueError(f"unknown constraint kind {kind!r}")


@dataclass
class System:
    """Model equations (+ control equations) of a mechanism over the unknowns q (L, d)."""

    mech: Mechanism
    blocks: list[Block]

    def __post_init__(self):
        row = 0
        for b in self.blocks:
            b.row0 = row
            row += b.rows
        self.m = row
        L, d = len(self.mech.links), self.mech.dof_per_link
        self.n = L * d
        fixed_cols, fixed_rows = [], []
        for b in self.blocks:
            if b.kind == "fixed":
                fixed_cols += list(b.j * d + b.coord)
                fixed_rows += list(b.row0 + np.arange(b.n))
        self.fixed_cols = np.array(sorted(set(fixed_cols)), dtype=int)
        self.free = np.setdiff1d(np.arange(self.n), self.fixed_cols)
        self.solve_rows = np.setdiff1d(np.arange(self.m), np.array(fixed_rows, dtype=int))
        self.n_fixed_rows = len(fixed_rows)
        if fixed_rows and max(fixed_rows) != len(fixed_rows) - 1:
            raise ValueError("System: the fixed-coordinate block must come first")
        # index maps built once per system (the Newton loop evaluates many times)
        self._cmap_full = np.arange(self.n, dtype=np.int64)
        self._cmap_reduced = np.full(self.n, -1, dtype=np.int64)
        self._cmap_reduced[self.free] = np.arange(self.free.size)
        self._has_rt = any(b.kind in ("out_full", "out_axis") for b in self.blocks)
        # links whose rotation the Newton solver updates by incremental rotation vectors (spatial links without a
        # fixed angle coordinate); their rotation columns in ``evaluate(omega=True)`` are ∂/∂ω
        fixed_rot = np.zeros(L, dtype=bool)
        fc = self.fixed_cols
        fixed_rot[fc[fc % d >= self.mech.dim] // d] = True
        self.omega_links = ~fixed_rot if self.mech.dim == 3 else np.zeros(L, dtype=bool)
        self._om = self.omega_links.astype(np.int64)
        self._om0 = np.zeros(L, dtype=np.int64)
        self.rot_cols = np.array([[self._cmap_reduced[li * d + self.mech.dim + c] for c in range(3)]
                                  for li in np.flatnonzero(self.omega_links)], dtype=np.int64).reshape(-1, 3)
        self.plan = make_plan(self.blocks) if self.mech.dim == 3 else None
        self._sparsity = None

    @property
    def sparsity(self) -> tuple[np.ndarray, np.ndarray]:
        """Nonzero columns per row of the reduced Jacobian (every coordinate of the links a row's constraint joins)
        as (cols, cnt) for :func:`pkmstiff.mechanisms.linalg.lstsq_step`; built once."""
        if self._sparsity is None:
            from pkmstiff.mechanisms.linalg import sparsity

            d = self.mech.dof_per_link
            pat = np.zeros((self.m, self.n), dtype=bool)
            for b in self.blocks:
                rows = (b.row0 + np.arange(b.rows)).reshape(b.n, b.nrows)
                for links in (b.j, b.k):
                    for i, li in enumerate(links):
                        if li >= 0:
                            pat[rows[i][:, None], li * d + np.arange(d)] = True
            self._sparsity = sparsity(pat[self.n_fixed_rows:][:, self.free])
        return self._sparsity

    def step(self, q: Array, dx: Array) -> Array:
        """q (N, L·d) after the Newton step dx (N, n_free) in the coordinates of ``evaluate(omega=True)``:
        positions (and the angles of the other links) add; the rotation of an :attr:`omega_links` link becomes
        exp([δω]×) R(φ) (Rodrigues), stored again as angles φ (:func:`link_angles`, exact at φy = ±90°)."""
        out = q.copy()
        out[:, self.free] += dx
        if self.rot_cols.size:
            d, D = self.mech.dof_per_link, self.mech.dim
            links = np.flatnonzero(self.omega_links)
            cols = links[:, None] * d + D + np.arange(3)  # (nl, 3) angle columns in q
            out[:, cols] = kernel.rotate(q[:, cols], dx[:, self.rot_cols])
        return out

    def row_joint(self) -> np.ndarray:
        """(m,) index of the joint behind each row (−1: ground / control)."""
        out = np.empty(self.m, dtype=int)
        for b in self.blocks:
            out[b.row0:b.row0 + b.rows] = np.repeat(b.joint, b.nrows)
        return out

    def evaluate(self, q: Array, target: Array | None = None, jac: bool = True,
                 reduced: bool = False, omega: bool = False) -> tuple[Array, Array | None]:
        """Residual F (N, m) and Jacobian F_q (N, m, L·d) at configurations q (N, L, d).

        ``reduced=True``: only the rows and columns the solver uses — without the fixed-coordinate rows and the
        fixed coordinates — F (N, m_s) and F_q (N, m_s, n_free).  Spatial systems run the compiled loop of
        :mod:`pkmstiff.mechanisms.kernel` (one call for all constraints and poses), planar ones
        :meth:`evaluate_reference`.  ``omega=True``: the rotation columns of :attr:`omega_links` are
        derivatives with respect to an incremental world-frame rotation vector (R → exp([δω]×) R), regular at every
        orientation (the Newton solver's coordinates, see :meth:`step`); else with respect to the angles φ.
        """
        if self.plan is None:
            return self.evaluate_reference(q, target, jac, reduced, omega)
        Rt = cardan_pose_rotation(np.asarray(target, dtype=float)[:, 3:6]) if self._has_rt else None
        roff = self.n_fixed_rows if reduced else 0
        cmap = self._cmap_reduced if reduced else self._cmap_full
        r, J = kernel.evaluate(self.plan, q, target, self._om if omega else self._om0, Rt, self.m, roff, cmap,
                               self.free.size if reduced else self.n, jac)
        return (r[:, roff:] if reduced else r), J

    def evaluate_reference(self, q: Array, target: Array | None = None, jac: bool = True,
                           reduced: bool = False, omega: bool = False) -> tuple[Array, Array | None]:
        """:meth:`evaluate` by one vectorised numpy call per constraint kind (:func:`block_eval`): the reference
        the compiled loop is tested against, and the planar path."""
        N = q.shape[0]
        d = self.mech.dof_per_link
        F = Frames(q, self.mech.dim, omega=self.omega_links if omega else None)
        r = np.empty((N, self.m))
        if reduced:
            cmap = np.full(self.n, self.free.size)  # fixed columns go to a scratch column that is cut off
            cmap[self.free] = np.arange(self.free.size)
            roff = self.n_fixed_rows
            J = np.zeros((N, self.m - roff, self.free.size + 1)) if jac else None
        else:
            cmap, roff = np.arange(self.n), 0
            J = np.zeros((N, self.m, self.n)) if jac else None
        for b in self.blocks:
            rb, Jj, Jk = block_eval(b, F, target)
            r[:, b.row0:b.row0 + b.rows] = rb.reshape(N, -1)
            if jac and not (reduced and b.kind == "fixed"):
                rows = (b.row0 - roff + np.arange(b.rows)).reshape(b.n, b.nrows)
                cj = cmap[b.j[:, None] * d + np.arange(d)]
                J[:, rows[:, :, None], cj[:, None, :]] = Jj
                if Jk is not None:
                    has = b.k >= 0
                    ck = cmap[b.k[has, None] * d + np.arange(d)]
                    J[:, rows[has][:, :, None], ck[:, None, :]] = Jk[:, has]
        if reduced:
            return r[:, roff:], (J[:, :, :-1] if jac else None)
        return r, J


def _cached(mech: Mechanism, key: str, build) -> System:
    """The system ``key`` of ``mech``, built once per mechanism (kept in the frozen dataclass's __dict__, like
    functools.cached_property does): solving one pose at a time must not rebuild blocks and index maps."""
    sysm = mech.__dict__.get(key)
    if sysm is None:
        sysm = build()
        mech.__dict__[key] = sysm
    return sysm


def model_system(mech: Mechanism) -> System:
    return _cached(mech, "_model_system", lambda: System(mech, model_blocks(mech)))


def fk_system(mech: Mechanism) -> System:
    return _cached(mech, "_fk_system", lambda: System(mech, model_blocks(mech) + drive_blocks(mech)))


def ik_system(mech: Mechanism) -> System:
    return _cached(mech, "_ik_system", lambda: System(mech, model_blocks(mech) + output_blocks(mech)))
