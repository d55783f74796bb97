"""Static stiffness, natural frequencies, weak points and FRF of a mechanism's elastic model (issue 27, item 1):
the analyses of :mod:`pkmstiff.multibody` on :func:`~pkmstiff.mechanisms.structure.mechanism_structure`, chunked
over the configurations (bounded memory).  Same quantities and units as the structure model of pod/glide machines
(docs/theory/structure.md): compliance at the output point (m/N, rad/(N m)), k = 1/C_jj (N/m, N m/rad), frequencies
in Hz, strain-energy shares of the components (a unit force at the output point, Cobet eq. 4.70–4.72).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

import pkmstiff.multibody as sde
from pkmstiff.errors import ArgumentError, NumericalError
from pkmstiff.mechanisms.model import Mechanism
from pkmstiff.mechanisms.solver import Solution
from pkmstiff.mechanisms.structure import LABELS, STATUS_BITS, MechanismStructure, mechanism_structure

Array = np.ndarray

#: configurations per chunk (the SDE work arrays of the largest bundled model, ~30 DOF, as the structure model's)
CHUNK = 2048


def take(sol: Solution, idx: Array) -> Solution:
    """The configurations ``idx`` of a solution (index array or mask)."""
    fields = {f.name: getattr(sol, f.name) for f in dataclasses.fields(Solution)}
    for k, v in fields.items():
        if isinstance(v, np.ndarray) and v.ndim and v.shape[0] == sol.q.shape[0]:
            fields[k] = v[idx]
    return Solution(**fields)


@dataclass
class MechanismStiffness:
    """Results at N configurations, NaN where not modelled (``status`` bits of
    :data:`~pkmstiff.mechanisms.structure.STATUS_BITS`).

    ``compliance`` (N, 6, 6) at the output point ((u, θ); a point-mass output: the 3×3 translational block, the
    rest NaN); ``stiffness`` (N, 6) k_x, k_y, k_z [N/m], k_rx, k_ry, k_rz [N m/rad]; ``frequencies_hz`` (N, n);
    ``shares`` {direction: (N, len(LABELS))} component shares of the compliance along x, y, z (sum 1)."""

    compliance: Array
    stiffness: Array
    frequencies_hz: Array
    shares: dict[str, Array]
    status: Array

    @property
    def ok(self) -> Array:
        return self.status == 0


def component_energies(ms: MechanismStructure, q: Array) -> Array:
    """Strain energy (M, [k,] len(LABELS)) of every component label for displacements q of ``ms.model``: each
    element's ``½ lᵀ K l`` split by its parts (drive along/about its axis, the rest guide or bearing; a strut's
    energy by the compliance fractions ``k_V / k_term`` of its series terms, as
    :func:`pkmstiff.analysis._common.component_energies`)."""
    model = ms.model
    defs = sde.sde_deformations(model, q)
    q = np.asarray(q)
    extra = q.ndim - 2

    def ex(a: Array) -> Array:
        return a.reshape(a.shape[:1] + (1,) * extra + a.shape[1:])

    out = np.zeros(q.shape[:-1] + (len(LABELS),))
    for s in model.sets:
        mat = s.stiffness.full()  # (M|1, E, d, d)
        for e, name in enumerate(s.names):
            lv = defs[name]
            total = 0.5 * np.einsum("...i,...ij,...j->...", lv, ex(mat[:, e]), lv)
            rest, rest_label = total, None
            for label, spec in ms.energy_split.get(name, []):
                if spec is None:
                    rest_label = label
                    continue
                kind = spec[0]
                if kind == "share":
                    part = total * ex(spec[1])
                else:
                    direction, k = spec[1], spec[2]
                    block = lv[..., 3:] if kind == "rot" else lv[..., :3]
                    part = 0.5 * ex(k) * np.einsum("...i,...i->...", block, ex(direction)) ** 2
                out[..., LABELS.index(label)] += part
                rest = rest - part
            if rest_label is not None:
                out[..., LABELS.index(rest_label)] += rest
    return out


def _chunk(ms: MechanismStructure, n_modes: int, directions: tuple[str, ...]) -> tuple[Array, Array, dict]:
    model, body, point = ms.model, ms.load_body, ms.load_point
    ev = sde.evaluate_point(model, body, point, n_modes)
    c = ev.compliance
    if c.shape[-1] == 3:
        full = np.full((c.shape[0], 6, 6), np.nan)
        full[:, :3, :3] = c
        c = full
    shares = {}
    for d in directions:
        e = np.eye(3)["xyz".index(d)]
        qd = sde.solve_static(model, sde.point_load(model, body, point, force=e))
        energy = component_energies(ms, qd)
        total = energy.sum(axis=-1, keepdims=True)
        shares[d] = energy / np.where(total > 0, total, 1.0)
    return c, ev.frequencies_hz, shares


def evaluate_mechanism(mech: Mechanism, solution: Solution, n_modes: int = 6, directions: tuple[str, ...] = (),
                       chunk_size: int = CHUNK, point: ArrayLike | None = None) -> MechanismStiffness:
    """Compliance and stiffness at the output point (or at ``point``, home coordinates on the output link, e.g. a
    tool tip), the ``n_modes`` lowest natural frequencies and the component shares along ``directions`` (subset of
    x, y, z) at the configurations of ``solution`` (chunks of ``chunk_size``).  A configuration whose stiffness matrix is not positive definite (a structurally singular
    pose) gets NaN and the status bit NOT_POSITIVE_DEFINITE; a chunk never raises because of single poses."""
    n = solution.q.shape[0]
    comp = np.full((n, 6, 6), np.nan)
    freq = np.full((n, n_modes), np.nan)
    shares = {d: np.full((n, len(LABELS)), np.nan) for d in directions}
    status = np.zeros(n, np.uint8)
    for s0 in range(0, n, chunk_size):
        rows = np.arange(s0, min(s0 + chunk_size, n))
        for _ in range(3):  # the not positive definite poses are found at the first failure, once more is a safety
            ms = mechanism_structure(mech, solution=take(solution, rows), point=point)
            status[rows] |= ms.status
            rows = rows[ms.index]
            if not rows.size:
                break
            try:
                c, f, sh = _chunk(ms, n_modes, directions)
                break
            except NumericalError:
                bad = _not_pd(ms)
                status[rows[bad]] |= STATUS_BITS["NOT_POSITIVE_DEFINITE"]
                rows = rows[~bad]
        else:
            raise NumericalError("stiffness matrix still singular after removing the non-positive-definite poses")
        if rows.size:
            comp[rows], freq[rows] = c, f
            for d in directions:
                shares[d][rows] = sh[d]
    with np.errstate(divide="ignore", invalid="ignore"):
        stiff = 1.0 / np.diagonal(comp, axis1=1, axis2=2)
    return MechanismStiffness(comp, stiff, freq, shares, status)


def _not_pd(ms: MechanismStructure) -> Array:
    """(M,) True where the reduced stiffness matrix is not positive definite."""
    from pkmstiff.multibody.assembly import stiffness_matrix

    k = stiffness_matrix(ms.model)
    z = sde.null_space_basis(ms.model)
    if z is not None:
        k = np.swapaxes(z, 1, 2) @ k @ z
    eig = np.linalg.eigvalsh(k)
    return ~(eig[:, 0] > 1e-13 * np.abs(eig[:, -1]))


def frf(ms: MechanismStructure, freq_hz: Any, direction: str = "x", zeta: Any = 0.02) -> Array:
    """Complex receptance (M, F) [m/N] at the output point along ``direction`` for a force there along the same
    direction (:func:`pkmstiff.multibody.receptance`, modal damping ratio ``zeta``)."""
    pd = sde.PointDirection(ms.load_body, np.eye(3)["xyz".index(direction)], ms.load_point)
    return sde.receptance(ms.model, freq_hz, pd, pd, zeta=zeta)


def tool_point(mech, tool_length_mm: float | None) -> Array | None:
    """Home coordinates [m] of the tool tip ``--tool-length`` mm from the output point along the tool axis: the
    file's ``[output] axis`` (orientation "axis", or the optional tool axis of "full"), else −z as the machines'
    default tool axis; None without ``--tool-length``. A planar mechanism or an output without orientation has no
    tool axis: one line, exit 2."""
    if tool_length_mm is None:
        return None
    o = mech.output
    if mech.dim != 3 or o.orientation == "none":
        raise ArgumentError(f"--tool-length: not available for mechanism '{mech.name}': its output has no "
                            f"orientation ({'planar' if mech.dim != 3 else 'orientation = none'}), so no tool axis")
    axis = o.axis if o.axis is not None else np.array([0.0, 0.0, -1.0])
    return np.asarray(o.point, float) + tool_length_mm * 1e-3 * axis
