"""Modal analysis of the SDE model (docs/theory/structure.md, Cobet eq. 4.73).

``K v = λ M v`` is solved after (1) eliminating rigid bindings with the null-space basis Z, (2) condensing massless
DOFs statically (Guyan, docs/theory/structure.md) and (3) mass-normalising with the block factors of M (``m^{-1/2}`` for
translations, ``L⁻¹`` with ``I_cg = L Lᵀ`` for rotations), which turns the generalized problem into a standard
symmetric one ``A y = λ y`` solved by LAPACK (``eigvalsh`` when only frequencies are needed, ``eigh`` for shapes).
``f = √λ / (2π)`` in Hz (λ < 0 from round-off on free rigid-body modes is clipped to 0).  Mode shapes are
mass-normalised (``vᵀ M v = 1``) full DOF vectors (condensed DOFs recovered, ``q = Z q_r`` with bindings).
Validity: the rigid-body model is meaningful below about 250 Hz (docs/theory/structure.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from pkmstiff.errors import InputError
from pkmstiff.multibody.assembly import element_energies, mass_blocks, mass_matrix, stiffness_matrix
from pkmstiff.multibody.bodies import RigidBody
from pkmstiff.multibody.constraints import null_space_basis
from pkmstiff.multibody.linalg import cholesky_inverse_factor
from pkmstiff.multibody.solver import check_positive_definite
from pkmstiff.multibody.static import DEFAULT_CHUNK, Groups, group_matrix
from pkmstiff.multibody.system import SDEModel

MOTION_LABELS = ("translation along x", "translation along y", "translation along z",
                 "rotation about x", "rotation about y", "rotation about z")


@dataclass
class DynamicSystem:
    """Mass-normalised standard eigenproblem of one chunk: ``a`` (N, r, r); ``shapes(y)`` maps eigenvectors
    (N, r, k) back to mass-normalised full DOF vectors (N, k, n); ``n_massless`` = number of condensed DOFs."""

    a: np.ndarray
    to_full: Callable[[np.ndarray], np.ndarray]
    n_massless: int


def _guyan(k: np.ndarray, keep: np.ndarray, drop: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Condensed stiffness and the map q_drop = X q_keep (X = −K_dd⁻¹ K_dk) for massless DOFs."""
    if drop.size == 0:
        return k, None
    kdd = k[:, drop][:, :, drop]
    check_positive_definite(kdd, "massless DOFs (a massless body needs stiffness to all its directions)")
    kdk = k[:, drop][:, :, keep]
    x = -np.linalg.solve(kdd, kdk)
    kc = k[:, keep][:, :, keep] + np.swapaxes(kdk, 1, 2) @ x
    return 0.5 * (kc + np.swapaxes(kc, 1, 2)), x


def dynamic_system(model: SDEModel, k: np.ndarray | None = None) -> DynamicSystem:
    """Prepare ``A = L⁻¹ K_c L⁻ᵀ`` for one chunk of poses (see module docstring)."""
    k = stiffness_matrix(model) if k is None else k
    n_p, n = k.shape[0], model.n_dof
    z = null_space_basis(model)
    if z is None:
        drop = model.massless_dofs
        keep = np.setdiff1d(np.arange(n), drop)
        kc, x = _guyan(k, keep, drop)
        pos = {d: i for i, d in enumerate(keep)}
        n_pm = max([b.mass.shape[0] for b in model.bodies])
        scale = np.ones((n_pm, keep.size))
        rot_blocks = []  # (slice in keep-space, L⁻¹ (N, 3, 3)) with I_cg = L Lᵀ
        for body in model.bodies:
            s = model.dof_index(body.name)
            if np.all(body.mass > 0):
                idx = [pos[s.start + i] for i in range(3)]
                scale[:, idx] = (1.0 / np.sqrt(body.mass))[:, None]
            if isinstance(body, RigidBody) and not np.all(body.inertia == 0):
                check_positive_definite(body.inertia, f"inertia of rigid body '{body.name}'",
                                        "all principal moments must be > 0 (or all 0 for a massless body)")
                start = pos[s.start + 3]
                rot_blocks.append((slice(start, start + 3), cholesky_inverse_factor(body.inertia)))
        a = kc * (scale[:, :, None] * scale[:, None, :])
        for idx, linv in rot_blocks:
            a[:, idx, :] = linv @ a[:, idx, :]
            a[:, :, idx] = a[:, :, idx] @ np.swapaxes(linv, 1, 2)

        def to_full(y: np.ndarray) -> np.ndarray:
            v = y * scale[:, :, None]  # (N, r, k)
            for idx, linv in rot_blocks:
                v[:, idx, :] = np.swapaxes(linv, 1, 2) @ v[:, idx, :]
            full = np.zeros((n_p, n, y.shape[-1]))
            full[:, keep] = v
            if x is not None:
                full[:, drop] = x @ v
            return np.swapaxes(full, 1, 2)

        return DynamicSystem(a, to_full, int(drop.size))  # eigh/eigvalsh read the lower triangle only

    zt = np.swapaxes(z, 1, 2)
    kr = zt @ k @ z
    mr = zt @ mass_matrix(model) @ z
    mu, u = np.linalg.eigh(mr)
    tol = 1e-12 * mu[:, -1:]
    n0 = (mu <= tol).sum(axis=1)
    if np.any(n0 != n0[0]):
        raise InputError("SDEModel", "mass", "the same number of massless directions at all poses",
                            f"between {n0.min()} and {n0.max()}")
    n0 = int(n0[0])
    ky = np.swapaxes(u, 1, 2) @ kr @ u
    r = ky.shape[1]
    keep, drop = np.arange(n0, r), np.arange(n0)
    kc, x = _guyan(ky, keep, drop)
    s = 1.0 / np.sqrt(mu[:, n0:])
    a = kc * s[:, :, None] * s[:, None, :]

    def to_full_c(y: np.ndarray) -> np.ndarray:
        av = y * s[:, :, None]
        yv = np.zeros((n_p, r, y.shape[-1]))
        yv[:, keep] = av
        if x is not None:
            yv[:, drop] = x @ av
        return np.swapaxes(z @ (u @ yv), 1, 2)

    return DynamicSystem(0.5 * (a + np.swapaxes(a, 1, 2)), to_full_c, n0)


@dataclass
class ModalResult:
    """Lowest modes: ``eigenvalues`` λ (N, k) in rad²/s², ``frequencies_hz`` (N, k), ``shapes`` (N, k, n)
    mass-normalised full DOF vectors (m/√kg, rad/√(kg m²) units) or None."""

    eigenvalues: np.ndarray
    frequencies_hz: np.ndarray
    shapes: np.ndarray | None


def dynamic_dofs(model: SDEModel) -> int:
    """Number of modes the model has: the size of its condensed eigenproblem — the DOFs left by the rigid bindings
    (null space of the constraint matrix) less the massless directions among them (Guyan).  A DOF that is both
    massless and bound is counted once (not ``n_dof − n_constraints − len(massless_dofs)``, which counts it twice)."""
    return int(dynamic_system(model.poses(slice(0, 1)) if model.n_poses > 1 else model).a.shape[1])


def modal_chunk(model: SDEModel, n_modes: int, shapes: bool, k: np.ndarray | None = None) -> ModalResult:
    """Lowest ``n_modes`` modes of one chunk (all poses of ``model``)."""
    dyn = dynamic_system(model, k)
    r = dyn.a.shape[1]
    if not 1 <= n_modes <= r:
        raise InputError("modes", "n_modes", f"1..{r} (dynamic DOFs of the model)", n_modes)
    if shapes:
        lam, y = np.linalg.eigh(dyn.a)
        lam, y = lam[:, :n_modes], y[:, :, :n_modes]
        vec = dyn.to_full(y)
    else:
        lam = np.linalg.eigvalsh(dyn.a)[:, :n_modes]
        vec = None
    return ModalResult(lam, np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi), vec)


def modes(model: SDEModel, n_modes: int = 6, shapes: bool = False, chunk_size: int = DEFAULT_CHUNK) -> ModalResult:
    """Lowest ``n_modes`` eigenvalues, frequencies (Hz) and optionally mass-normalised mode shapes, all poses."""
    n_p = model.n_poses
    lam = np.zeros((n_p, n_modes))
    vec = np.zeros((n_p, n_modes, model.n_dof)) if shapes else None
    for sl, sub in model.chunks(chunk_size):
        res = modal_chunk(sub, n_modes, shapes)
        lam[sl] = res.eigenvalues
        if shapes:
            vec[sl] = res.shapes
    return ModalResult(lam, np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi), vec)


def natural_frequencies(model: SDEModel, n_modes: int = 6, chunk_size: int = DEFAULT_CHUNK) -> np.ndarray:
    """Lowest ``n_modes`` natural frequencies (N, n_modes) in Hz, ascending."""
    return modes(model, n_modes, False, chunk_size).frequencies_hz


def kinetic_energy_shares(model: SDEModel, shapes: np.ndarray) -> np.ndarray:
    """Share of every body in the kinetic energy of each mode (N, k, n_bodies), bodies in ``model.body_names``
    order; ``v_bᵀ M_b v_b / vᵀ M v`` (sums to 1)."""
    parts = []
    for s, blk in mass_blocks(model):
        vb = shapes[..., s]
        parts.append(np.einsum("nki,nij,nkj->nk", vb, np.broadcast_to(blk, (shapes.shape[0],) + blk.shape[1:]), vb))
    energy = np.stack(parts, axis=-1)
    return energy / energy.sum(axis=-1, keepdims=True)


def strain_energy_shares(model: SDEModel, shapes: np.ndarray, groups: Groups = None) -> tuple[list[str], np.ndarray]:
    """Share of every SDE (or group, see :func:`pkmstiff.multibody.static.group_matrix`) in the strain energy of each
    mode: (N, k, n_items); the element energies ``½ lᵀ K l`` sum to ``½ λ`` for mass-normalised shapes."""
    energy = element_energies(model, shapes)
    labels, mat = group_matrix(model, groups)
    grouped = energy @ mat
    return labels, grouped / grouped.sum(axis=-1, keepdims=True)


def motion_shares(model: SDEModel, shapes: np.ndarray, body: str) -> np.ndarray:
    """Kinetic-energy split of a body's motion in each mode over (tx, ty, tz, rx, ry, rz): (N, k, 6|3), sums to 1.

    Translation i: ``m u_i²``; rotation: the rotational energy ``θᵀ I θ`` split in proportion to ``I_ii θ_i²``
    (global axes).  For a massless body unit weights are used.
    """
    b = model.body(body)
    vb = shapes[..., model.dof_index(body)]
    n_p = shapes.shape[0]
    m = np.broadcast_to(b.mass, (n_p,))
    m = np.where(m > 0, m, 1.0)[:, None, None]
    trans = m * vb[..., :3] ** 2
    if not isinstance(b, RigidBody):
        parts = trans
    else:
        inertia = np.broadcast_to(b.inertia, (n_p, 3, 3))
        if np.all(inertia == 0):
            inertia = np.broadcast_to(np.eye(3), (n_p, 3, 3))
        th = vb[..., 3:]
        rot_total = np.einsum("nki,nij,nkj->nk", th, inertia, th)
        diag = np.diagonal(inertia, axis1=1, axis2=2)[:, None, :] * th ** 2
        dsum = diag.sum(axis=-1, keepdims=True)
        parts = np.concatenate([trans, rot_total[..., None] * diag / np.where(dsum > 0, dsum, 1.0)], axis=-1)
    total = parts.sum(axis=-1, keepdims=True)
    return parts / np.where(total > 0, total, 1.0)


def describe_modes(model: SDEModel, shapes: np.ndarray, body: str) -> tuple[np.ndarray, np.ndarray]:
    """Dominant motion of ``body`` in each mode: index into :data:`MOTION_LABELS` (N, k) and its share (N, k)."""
    shares = motion_shares(model, shapes, body)
    idx = np.argmax(shares, axis=-1)
    return idx, np.take_along_axis(shares, idx[..., None], axis=-1)[..., 0]


@dataclass
class ModeAxes:
    """Instantaneous screw axis of a rigid body's motion in each mode (N, k): ``direction`` (N, k, 3) unit vector
    along the rotation θ, ``point`` (N, k, 3) [m] the point of the axis nearest the body's reference point (CoG),
    ``pitch`` (N, k) [m/rad] translation along the axis per rotation, and ``lever`` (N, k) [m] = |u|/|θ| at the
    reference point (large: the motion is nearly a translation; then ``point`` lies far away)."""

    direction: np.ndarray
    point: np.ndarray
    pitch: np.ndarray
    lever: np.ndarray


def mode_axes(model: SDEModel, shapes: np.ndarray, body: str) -> ModeAxes:
    """Instantaneous screw axis of ``body`` (a rigid body) in each mode shape (Chasles' theorem).

    A small rigid-body motion (u at the reference point r₀, rotation θ) is a rotation about the axis
    ``p + t θ/|θ|`` with ``p = r₀ + (θ × u)/|θ|²`` plus the translation ``h θ`` along it, ``h = θ·u/|θ|²``
    (the velocity of a point r is ``u + θ × (r − r₀)``; on the axis it is parallel to θ).  NaN where θ = 0.
    """
    b = model.body(body)
    if not isinstance(b, RigidBody):
        raise InputError(body, "body", "a rigid body (6 DOF)", type(b).__name__)
    v = shapes[..., model.dof_index(body)]
    u, th = v[..., :3], v[..., 3:]
    t2 = np.einsum("...i,...i->...", th, th)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(t2 > 0, 1.0 / t2, np.nan)
        r0 = np.broadcast_to(b.position, (shapes.shape[0], 3))[:, None, :]
        point = r0 + np.cross(th, u) * inv[..., None]
        direction = th * np.sqrt(inv)[..., None]
        pitch = np.einsum("...i,...i->...", th, u) * inv
        lever = np.linalg.norm(u, axis=-1) * np.sqrt(inv)
    return ModeAxes(direction, point, pitch, lever)


def mode_label(index: int, share: float) -> str:
    """Text such as ``'rotation about x (83 %)'``."""
    return f"{MOTION_LABELS[int(index)]} ({100.0 * float(share):.0f} %)"
