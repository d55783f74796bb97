"""Modal analysis of the structure model (docs/theory/structure.md, Cobet eq. 4.73).

``K v = λ M v`` (generalized symmetric eigenproblem; massless DOFs condensed statically, docs/theory/structure.md),
``f = √λ / (2π)`` in Hz, lowest first.  Each mode is described by the dominant motion of the platform (the
largest share of its kinetic energy among translations along and rotations about x, y, z), with kinetic-energy
shares per body and strain-energy shares per SDE and per component kind.  The rigid-body model is meaningful
below about 250 Hz (docs/theory/structure.md).  NaN for poses that are not modelled.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import pkmstiff.multibody as sde
from pkmstiff.analysis._common import Array, by_parts, component_energies, present_components, shares
from pkmstiff.structure import PKMStructure


def natural_frequencies(st: PKMStructure, n_modes: int = 6) -> Array:
    """Lowest ``n_modes`` natural frequencies (N, n_modes) in Hz (eigenvalues only: fast path)."""
    def one(st: PKMStructure) -> Array:
        if st.empty:
            return st.scatter(np.zeros((0, n_modes)))
        return st.scatter(sde.natural_frequencies(st.dynamic_model, n_modes))

    return by_parts(st, one)


@dataclass
class ModalAnalysis:
    """Lowest modes at N poses.

    ``frequencies_hz``, ``eigenvalues`` (rad²/s²) (N, k); ``shapes`` (N, k, n) mass-normalised (vᵀMv = 1) in the
    DOF order of ``dof_labels``; ``dominant`` (N, k) index into :data:`pkmstiff.multibody.MOTION_LABELS` of the
    platform's dominant motion and ``dominant_share`` its kinetic-energy share; ``kinetic`` (N, k, bodies)
    kinetic-energy shares per body (``body_labels``); ``strain`` (N, k, E) strain-energy shares per SDE
    (``element_labels``); ``component_strain`` (N, k, C) per component kind (``component_labels``);
    ``axis_direction`` (N, k, 3), ``axis_point`` (N, k, 3) [m, machine frame] and ``axis_pitch`` (N, k) [m/rad]:
    the platform's instantaneous screw axis in each mode (Chasles; :func:`pkmstiff.multibody.mode_axes`).
    """

    frequencies_hz: Array
    eigenvalues: Array
    shapes: Array | None
    dof_labels: list[str]
    dominant: Array
    dominant_share: Array
    body_labels: list[str]
    kinetic: Array
    element_labels: list[str]
    strain: Array
    component_labels: list[str]
    component_strain: Array
    axis_direction: Array
    axis_point: Array
    axis_pitch: Array

    def description(self, pose: int, mode: int) -> str:
        """E.g. ``'rotation about x (83 %)'`` (platform motion); ``'n/a'`` for a pose that is not modelled."""
        d = self.dominant[pose, mode]
        if not np.isfinite(d):
            return "n/a"
        return sde.mode_label(int(d), float(self.dominant_share[pose, mode]))


def modal_analysis(st: PKMStructure, n_modes: int = 6, shapes: bool = True) -> ModalAnalysis:
    """Lowest ``n_modes`` modes with descriptions and energy shares (``shapes=False`` skips the shapes array)."""
    return by_parts(st, lambda part: _modal_analysis(part, n_modes, shapes),
                    ("frequencies_hz", "eigenvalues", "shapes", "dominant", "dominant_share", "kinetic", "strain",
                     "component_strain", "axis_direction", "axis_point", "axis_pitch"))


def _modal_analysis(st: PKMStructure, n_modes: int, shapes: bool) -> ModalAnalysis:
    labels_c = present_components(st)
    if st.empty:
        nan = st.scatter(np.zeros((0, n_modes)))
        empty = st.scatter(np.zeros((0, n_modes, 0)))
        axis = st.scatter(np.zeros((0, n_modes, 3)))
        return ModalAnalysis(nan, nan.copy(), None, [], nan.copy(), nan.copy(), [], empty, [], empty.copy(), labels_c,
                             st.scatter(np.zeros((0, n_modes, len(labels_c)))), axis, axis.copy(), nan.copy())
    m = st.model
    res = sde.modes(m, n_modes, shapes=True)
    idx, share = sde.describe_modes(m, res.shapes, "platform")
    el_labels, strain = sde.strain_energy_shares(m, res.shapes)
    _, comp = component_energies(st, res.shapes)
    axes = sde.mode_axes(m, res.shapes, "platform")
    return ModalAnalysis(
        frequencies_hz=st.scatter(res.frequencies_hz), eigenvalues=st.scatter(res.eigenvalues),
        shapes=st.scatter(res.shapes) if shapes else None, dof_labels=m.dof_labels,
        dominant=st.scatter(idx.astype(float)), dominant_share=st.scatter(share), body_labels=m.body_names,
        kinetic=st.scatter(sde.kinetic_energy_shares(m, res.shapes)), element_labels=el_labels,
        strain=st.scatter(strain), component_labels=labels_c, component_strain=st.scatter(shares(comp)),
        axis_direction=st.scatter(axes.direction), axis_point=st.scatter(axes.point), axis_pitch=st.scatter(axes.pitch))
