"""Batch evaluation of many poses: TCP compliance and lowest natural frequencies, chunked (bounded memory).

Per chunk: inverse kinematics, singularity check, joint angles and component stiffnesses, one assembly of the
structure model, the TCP compliance by block elimination (docs/theory/structure.md) and the lowest frequencies (eigenvalues
only, docs/theory/structure.md).  A massless spindle hanging on U alone is left out of both solves (24-DOF model, see
:attr:`pkmstiff.structure.PKMStructure.dynamic_model`): its TCP compliance is the platform compliance at the
coupling point plus ``K_U⁻¹`` in series, transferred to the TCP — algebraically identical to the 30-DOF solve.
Poses that cannot be modelled give NaN and their reason code; a chunk never raises because of single poses (poses
with a stiffness matrix that is not positive definite are identified, flagged and removed, and the chunk is
evaluated again).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

import pkmstiff.multibody as sde
from pkmstiff.admissibility.pipeline import PoseEvaluation
from pkmstiff.analysis._common import Array, load_body
from pkmstiff.errors import NumericalError
from pkmstiff.kinematics import as_poses
from pkmstiff.machine.model import Machine
from pkmstiff.multibody.assembly import stiffness_matrix
from pkmstiff.multibody.fast import compiled_chunk, use_compiled
from pkmstiff.multibody.modal import modal_chunk
from pkmstiff.multibody.solver import StaticSystem
from pkmstiff.multibody.static import point_transform
from pkmstiff.structure import (
    DEFAULT_CHUNK,
    NOT_POSITIVE_DEFINITE,
    STATUS_TEXT,
    PKMStructure,
    StructureOptions,
    iter_structures,
    platform_spindle_matrix,
)


@dataclass
class StructureBatch:
    """Results of :func:`evaluate_structure` for N poses (NaN where not modelled).

    ``compliance`` (N, 6, 6) at the TCP (m/N, rad/(N m), mixed 1/N) or None; ``stiffness`` (N, 6): k_x, k_y, k_z
    [N/m] and k_rx, k_ry, k_rz [N m/rad] (``1/C_jj``); ``frequencies_hz`` (N, n_modes); ``reasons`` (N,)
    :class:`~pkmstiff.admissibility.checks.Reason` bits; ``status`` (N,) structure bits (:data:`~pkmstiff.structure.
    STATUS_TEXT`).
    """

    poses: Array
    ok: Array
    reasons: Array
    status: Array
    compliance: Array | None
    stiffness: Array
    frequencies_hz: Array
    tool_tip: np.ndarray  # (3,) tool vector O' → TCP in the PKS, m

    def failing(self, i: int) -> list[str]:
        """Why pose ``i`` has no result (empty if it has one)."""
        from pkmstiff.admissibility.checks import REASON_TEXT, Reason

        out = [REASON_TEXT[r] for r in Reason if int(self.reasons[i]) & int(r)]
        return out + [t for bit, t in STATUS_TEXT.items() if int(self.status[i]) & bit]


def _not_pd(k: np.ndarray) -> np.ndarray:
    """(M,) True where a stiffness matrix (M, n, n) is not positive definite (smallest eigenvalue ≤ 1e-13 λ_max)."""
    eig = np.linalg.eigvalsh(k)
    return ~(eig[:, 0] > 1e-13 * np.abs(eig[:, -1]))


def _evaluate_chunk(st: PKMStructure, tool_length: float | ArrayLike | None, n_modes: int
                    ) -> tuple[PKMStructure, Array, Array]:
    """Compliance (M, 6, 6) and frequencies (M, n_modes) of the modelled poses of one chunk."""
    for _ in range(3):
        if st.empty:
            return st, np.zeros((0, 6, 6)), np.zeros((0, n_modes))
        try:
            return (st, *_chunk_results(st, tool_length, n_modes))
        except NumericalError:
            model = st.dynamic_model if st.massless_spindle else st.model
            st = st.without(_not_pd(np.ascontiguousarray(stiffness_matrix(model))), NOT_POSITIVE_DEFINITE)
    raise NumericalError("stiffness matrix still singular after removing the non-positive-definite poses")


def _chunk_results(st: PKMStructure, tool_length: float | ArrayLike | None, n_modes: int) -> tuple[Array, Array]:
    tcp = st.tcp(tool_length)
    if st.massless_spindle:
        # the spindle hangs on U alone: C_TCP = N(Δ) [C_P(r_U) + (H K_U Hᵀ)⁻¹] N(Δ)ᵀ, Δ = TCP − r_U (series
        # connection, exact); the 24-DOF model without the spindle serves the static and the modal solve
        model = st.dynamic_model
        r_u = _coupling_point(st)
        comp, lam = _compliance(model, "platform", r_u, n_modes)
        if not st.options.load_platform:
            comp = comp + _u_compliance(st)
        n = sde.linalg.reference_matrix(tcp - r_u)
        comp = n @ comp @ np.swapaxes(n, 1, 2)
    else:
        model = st.model
        comp, lam = _compliance(model, load_body(st), tcp, n_modes)
    freq = np.zeros((comp.shape[0], n_modes))
    if n_modes:
        freq = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)  # as modal_chunk
    return comp, freq


def _compliance(model: sde.SDEModel, body: str, point: Array, n_modes: int) -> tuple[Array, Array | None]:
    """Compliance of ``body`` at ``point`` and the ``n_modes`` lowest eigenvalues (None if 0) of one chunk:
    compiled kernels for large chunks (:mod:`pkmstiff.multibody.fast`), the numpy solver otherwise (identical to
    round-off, eigenvalues bit for bit)."""
    transform = point_transform(model, body, point)
    lam = None
    if use_compiled(model):
        comp, lam = compiled_chunk(model, body, transform, n_modes)
        if lam is not None or not n_modes:
            return comp, lam
        k = stiffness_matrix(model)
    else:
        k = stiffness_matrix(model)
        comp = StaticSystem(model, k).body_compliance(body, transform)
    return comp, (modal_chunk(model, n_modes, False, k).eigenvalues if n_modes else None)


def _coupling_point(st: PKMStructure) -> Array:
    """r_U (M, 3) in the MKS."""
    return st.w + st.R @ np.asarray(st.options.coupling_point, float)


def _u_compliance(st: PKMStructure) -> Array:
    """(H K_U Hᵀ)⁻¹ = H K_U⁻¹ Hᵀ (M, 6, 6) in MKS axes (K_U in platform axes, or already in MKS)."""
    cu = np.linalg.inv(platform_spindle_matrix(st.layout))
    if st.options.k_u_axes == "machine":
        return np.broadcast_to(cu, (len(st.index), 6, 6))
    h = np.zeros((len(st.index), 6, 6))
    h[:, :3, :3] = st.R
    h[:, 3:, 3:] = st.R
    return h @ cu @ np.swapaxes(h, 1, 2)


def evaluate_structure(machine: Machine, poses: ArrayLike | PoseEvaluation | PKMStructure,
                       tool_length: float | ArrayLike | None = None, n_modes: int = 6,
                       options: StructureOptions | None = None,
                       chunk_size: int = DEFAULT_CHUNK, store_compliance: bool = True) -> StructureBatch:
    """TCP compliance/stiffness and the ``n_modes`` lowest frequencies at N poses: poses (N, 6) (x, y, z [m],
    a, b, c [rad]), their :class:`~pkmstiff.admissibility.pipeline.PoseEvaluation`, or a structure built from
    them (:func:`pkmstiff.structure.build_structure`: then nothing is built again, ``options`` does not apply).

    Memory: results (N × (36 + 6 + n_modes) × 8 bytes with ``store_compliance``) plus a fixed work space per
    chunk (≈ 40 MB at the default 2048 poses).  ``tool_length`` in m (None: machine file) or a tool vector (3,) in
    the PKS [m].
    """
    x = poses.poses if isinstance(poses, (PoseEvaluation, PKMStructure)) else as_poses(poses)
    n = x.shape[0]
    comp_out = np.full((n, 6, 6), np.nan) if store_compliance else None
    stiff = np.full((n, 6), np.nan)
    freq = np.full((n, n_modes), np.nan)
    reasons = np.zeros(n, np.uint32)
    status = np.zeros(n, np.uint8)
    for sl, st in iter_structures(machine, poses, options, chunk_size):
        st, comp, fr = _evaluate_chunk(st, tool_length, n_modes)
        idx = st.index + sl.start
        reasons[sl], status[sl] = st.reasons, st.status
        if comp_out is not None:
            comp_out[idx] = comp
        stiff[idx] = 1.0 / np.diagonal(comp, axis1=1, axis2=2)
        freq[idx] = fr
    tl = machine.tool.tip() if tool_length is None else (
        np.asarray(tool_length, float) if np.ndim(tool_length) else machine.tool.tip(float(tool_length)))
    return StructureBatch(x, (reasons == 0) & (status == 0), reasons, status, comp_out, stiff, freq, tl)
