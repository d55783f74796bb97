"""Frequency response at the tool centre point: receptance, accelerance and peaks (extension of docs/theory/structure.md).

Damping: SDE damping matrices (``StructureOptions.damping_beta``: ``C_e = β K_e`` per SDE) and/or a modal damping
ratio ``zeta``; the spec itself neglects damping (§4.1), no damping data are given for any machine, so both are
user settings (Assumption).  Excitation = unit force (or moment) at the TCP along a direction, response =
displacement (or rotation) of the TCP along a direction: receptance in m/N (rad/N, m/(N m), rad/(N m)),
accelerance ``−ω² H`` in (m/s²)/N.  NaN rows for poses that are not modelled.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

import pkmstiff.multibody as sde
from pkmstiff.analysis._common import Array, load_body, parse_direction
from pkmstiff.structure import PKMStructure


@dataclass
class FRFResult:
    """``freq_hz`` (F,); ``values`` (N, F) complex (``kind`` receptance or accelerance); ``peak_hz``,
    ``peak_magnitude`` (N, max_peaks), NaN-padded, ascending in frequency."""

    kind: str
    freq_hz: Array
    values: Array
    peak_hz: Array
    peak_magnitude: Array


def tcp_frf(st: PKMStructure, freq_hz: Any, response: Any = "x", excitation: Any = "x", *,
            tool_length: float | ArrayLike | None = None, zeta: Any = None, sde_damping: bool = True,
            kind: Literal["receptance", "accelerance"] = "receptance", method: Literal["modal", "direct"] = "modal",
            max_peaks: int = 6) -> FRFResult:
    """FRF between two directions at the TCP (``"x"``, ``"-y"``, ``"rz"`` or vectors) over ``freq_hz`` (Hz)."""
    if kind not in ("receptance", "accelerance"):
        from pkmstiff.structure import StructureModelError

        raise StructureModelError("tcp_frf", "kind", "'receptance' or 'accelerance'", kind)
    f = np.asarray(freq_hz, dtype=float).ravel()
    if st.empty:
        nan = st.scatter(np.zeros((0, f.size), complex))
        pk = st.scatter(np.zeros((0, max_peaks)))
        return FRFResult(kind, f, nan, pk, pk.copy())
    body = load_body(st)
    tcp = st.tcp(tool_length)
    dirs = []
    for d, what in ((response, "response"), (excitation, "excitation")):
        e, rot = parse_direction(d, what)
        dirs.append(sde.PointDirection(body, e, tcp, rotation=rot))
    fn = sde.accelerance if kind == "accelerance" else sde.receptance
    h = fn(st.model, f, dirs[0], dirs[1], zeta=zeta, sde_damping=sde_damping, method=method)
    pf, pm = sde.find_peaks(f, h, max_peaks) if f.size >= 3 else (np.full((h.shape[0], max_peaks), np.nan),) * 2
    return FRFResult(kind, f, st.scatter(h), st.scatter(pf), st.scatter(pm))
