"""Static analyses at the tool centre point (docs/theory/structure.md, Cobet eq. 4.70–4.72).

TCP = ``O' + R (tool.offset + L_tool · tool.axis)`` on the spindle body (or on the platform with
the structure option ``load_platform``, i.e. K_U rigid).  Stiffness in a direction e: ``k_e = |F| / (e·u_TCP) = 1/(eᵀ C e)`` for
a unit force along e at the TCP; rotational stiffness: unit moment, rotation about the same axis.  Every function
returns values for all N poses of the structure, NaN where a pose is not modelled (``structure.failing(i)``).
Units: N/m, N m/rad, m/N, rad/(N m); forces N, moments N m, displacements m, rotations rad.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

import pkmstiff.multibody as sde
from pkmstiff.analysis._common import (
    Array,
    by_parts,
    component_energies,
    load_body,
    parse_direction,
    present_components,
    shares,
)
from pkmstiff.structure import PKMStructure


def tcp_compliance(st: PKMStructure, tool_length: float | ArrayLike | None = None) -> Array:
    """Compliance at the TCP (N, 6, 6): column j = (u, θ) of the TCP for a unit force (j < 3) / moment (j ≥ 3).

    Symmetric (Maxwell–Betti).  ``tool_length`` [m] overrides the machine's tool length; a vector (3,) [m, PKS] is
    the whole tool vector from O' to the tip (any tool orientation).
    """
    def one(st: PKMStructure) -> Array:
        if st.empty:
            return st.scatter(np.zeros((0, 6, 6)))
        return st.scatter(sde.point_compliance(st.model, load_body(st), st.tcp(tool_length)))

    return by_parts(st, one)


def tcp_stiffness_matrix(st: PKMStructure, tool_length: float | ArrayLike | None = None) -> Array:
    """6×6 stiffness at the TCP (N, 6, 6) (statically condensed, no inversion; blocks N/m, N/rad, N m/rad)."""
    def one(st: PKMStructure) -> Array:
        if st.empty:
            return st.scatter(np.zeros((0, 6, 6)))
        return st.scatter(sde.point_stiffness(st.model, load_body(st), st.tcp(tool_length)))

    return by_parts(st, one)


def directional_stiffness(compliance: Array, direction: Any, rotational: bool = False) -> Array:
    """``k_e = 1/(eᵀ C e)`` (N,) in N/m (or N m/rad with ``rotational``) for a unit direction e (3,)."""
    return sde.directional_stiffness(compliance, direction, rotational=rotational)


def axis_stiffness(compliance: Array) -> Array:
    """(N, 6): k_x, k_y, k_z [N/m] and k_rx, k_ry, k_rz [N m/rad] at the TCP from its compliance (docs/theory/structure.md)."""
    return sde.axis_stiffness(compliance)


@dataclass
class Deformation:
    """Static response to a load at the TCP (all arrays (N, ...), NaN where a pose is not modelled).

    ``tcp`` (N, 6): translation [m] and rotation [rad] of the TCP; ``bodies``: displacement of every body
    (name → (N, 3|6)); ``sdes``: deformation ``l`` of every SDE (name → (N, 3|6), m/rad); ``forces``: SDE force
    ``K l`` (N, N m); ``component_energy``: strain energy per component kind (labels, (N, C)) in J.
    """

    tcp: Array
    bodies: dict[str, Array]
    sdes: dict[str, Array]
    forces: dict[str, Array]
    component_labels: list[str]
    component_energy: Array


def static_deformation(st: PKMStructure, force: Any = (0.0, 0.0, 0.0), moment: Any = (0.0, 0.0, 0.0),
                       tool_length: float | ArrayLike | None = None) -> Deformation:
    """Deformation of every body and SDE for a force [N] and moment [N m] at the TCP (eq. 4.70–4.72)."""
    if st.empty:
        labels = present_components(st)
        return Deformation(st.scatter(np.zeros((0, 6))), {}, {}, {}, labels, st.scatter(np.zeros((0, len(labels)))))
    body = load_body(st)
    tcp = st.tcp(tool_length)
    f = sde.point_load(st.model, body, tcp, force=force, moment=moment)
    q = sde.solve_static(st.model, f)
    labels, energy = component_energies(st, q)
    return Deformation(
        tcp=st.scatter(sde.point_motion(st.model, q, body, tcp)),
        bodies={k: st.scatter(v) for k, v in sde.body_displacements(st.model, q).items()},
        sdes={k: st.scatter(v) for k, v in sde.sde_deformations(st.model, q).items()},
        forces={k: st.scatter(v) for k, v in sde.sde_forces(st.model, q).items()},
        component_labels=labels, component_energy=st.scatter(energy))


@dataclass
class WeakPoints:
    """Shares of the TCP compliance in one load direction (docs/theory/structure.md "weak points"), each row summing to 1.

    ``element_labels``/``element_shares`` (N, E): per SDE (W1…W6, V1…V6, U); ``component_labels``/
    ``component_shares`` (N, C): per component kind (drive, guide, drive_joint, strut, platform_joint,
    platform_spindle, …); ``compliance`` (N,): ``e·u`` for the unit load [m/N or rad/(N m)].
    """

    direction: np.ndarray
    rotational: bool
    element_labels: list[str]
    element_shares: Array
    component_labels: list[str]
    component_shares: Array
    compliance: Array


def weak_points(st: PKMStructure, direction: Any, tool_length: float | ArrayLike | None = None) -> WeakPoints:
    """Each SDE's and each component's share of the TCP compliance for a unit load along ``direction``.

    ``direction``: ``"x"``, ``"-z"``, a vector (3,) (force) or ``"rx"``/``"ry"``/``"rz"`` (moment).  The strain
    energy of a unit load equals half the compliance in its direction, so energy shares are compliance shares.
    """
    e, rot = parse_direction(direction)
    return by_parts(st, lambda part: _weak_points(part, e, rot, tool_length),
                    ("element_shares", "component_shares", "compliance"))


def _weak_points(st: PKMStructure, e: np.ndarray, rot: bool, tool_length: float | ArrayLike | None) -> WeakPoints:
    if st.empty:
        labels = present_components(st)
        return WeakPoints(e, rot, [], st.scatter(np.zeros((0, 0))), labels, st.scatter(np.zeros((0, len(labels)))),
                          st.scatter(np.zeros(0)))
    body = load_body(st)
    tcp = st.tcp(tool_length)
    kw = {"moment": e} if rot else {"force": e}
    f = sde.point_load(st.model, body, tcp, **kw)
    q = sde.solve_static(st.model, f)
    el_labels, el_shares = sde.energy_shares(st.model, q)
    labels, energy = component_energies(st, q)
    motion = sde.point_motion(st.model, q, body, tcp)
    comp = motion[:, 3:] @ e if rot else motion[:, :3] @ e
    return WeakPoints(e, rot, el_labels, st.scatter(el_shares), labels, st.scatter(shares(energy)),
                      st.scatter(comp))

