"""Combined per-pose evaluation for large pose batches: compliance at a point + lowest natural frequencies.

One stiffness assembly per chunk is shared by the static condensation and the eigenvalue solve; memory is bounded
by ``chunk_size`` (about 3 × chunk × n² × 8 bytes of work arrays), so millions of poses run in a fixed footprint.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from pkmstiff.multibody.assembly import stiffness_matrix
from pkmstiff.multibody.modal import modal_chunk
from pkmstiff.multibody.solver import StaticSystem
from pkmstiff.multibody.static import DEFAULT_CHUNK, _n_total, chunk_point, point_transform
from pkmstiff.multibody.system import SDEModel


@dataclass
class PointEvaluation:
    """``compliance`` (N, 6, 6) (or (N, 3, 3)) at the point, see :func:`pkmstiff.multibody.static.point_compliance`;
    ``frequencies_hz`` (N, n_modes) lowest natural frequencies in Hz."""

    compliance: np.ndarray
    frequencies_hz: np.ndarray


def evaluate_point(model: SDEModel, body: str, point: Any | None = None, n_modes: int = 6,
                   chunk_size: int = DEFAULT_CHUNK) -> PointEvaluation:
    """Compliance at ``point`` of ``body`` (e.g. the TCP on the spindle) and the ``n_modes`` lowest frequencies."""
    n_p = _n_total(model, point, body)
    d = model.body(body).n_dof
    comp = np.zeros((n_p, d, d))
    freq = np.zeros((n_p, n_modes))
    for sl, sub in model.chunks(chunk_size, n_p):
        k = stiffness_matrix(sub)
        comp[sl] = StaticSystem(sub, k).body_compliance(body, point_transform(sub, body, chunk_point(point, sl)))
        if n_modes:
            freq[sl] = modal_chunk(sub, n_modes, False, k).frequencies_hz
    return PointEvaluation(comp, freq)
