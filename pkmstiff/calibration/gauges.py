"""Candidate gauge freedoms: parameter directions that may leave every reading unchanged, each with a name
(Szatmári §4.2.3, eq. 4.1–4.2, the invariance lemma; docs/theory/calibration.md: compute, never hard-code, and name the
lost directions as rigid motions where they are).

A candidate is a group of parameter directions (columns in SI parameter units) that represents one named motion:

* ``base frame translation`` / ``base frame rotation about <point>``: every base-fixed point (base joints, guide
  starts, fixed ball) moved, every base-fixed vector (glide drive-joint offsets, guide directions) turned, the
  instrument frame moved with them — first-order rigid motions δP = t + ω × (P − c);
* ``platform frame translation`` / ``platform frame rotation about the target``: the platform joints (and the
  moving ball / target, when it is a parameter) moved in the PKS by a rigid motion — the body is the same, only its
  frame is relabelled;
* per glide chain: ``guide start vs drive-joint offset`` (only s_i + q_off,i acts) and ``guide start along the
  guide vs drive zero`` (s_i + ε r_i with Δλ_i − ε);
* each single parameter (a parameter without effect on the readings).

Which candidates (or which of their sub-directions) lie in the null space is decided by
:mod:`pkmstiff.calibration.identifiability` from the Jacobian.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pkmstiff.calibration.instruments import Setup
from pkmstiff.calibration.parameters import BASE_POINTS, ParameterSet
from pkmstiff.machine import Machine

_E = np.eye(3)


@dataclass(frozen=True)
class GaugeCandidate:
    """A named group of parameter directions G (n, g) in SI parameter units; ``axes`` names its columns."""

    name: str
    G: np.ndarray
    axes: tuple[str, ...]
    kind: str  # "rigid", "combination" or "parameter"


def _setups(setup: Setup | Sequence[Setup] | None) -> tuple[Setup, ...]:
    return () if setup is None else (setup,) if isinstance(setup, Setup) else tuple(setup)


def _row(params: ParameterSet, k: int) -> int:
    """Row of parameter k's point: its chain, or for a set-up parameter its set-up (chain −1, −2, …)."""
    c = int(params.chain[k])
    return c if c >= 0 else -c - 1


def _nominal_points(machine: Machine, params: ParameterSet, setup: Setup | Sequence[Setup] | None
                    ) -> dict[str, np.ndarray]:
    ch = machine.chains
    pts = {"base_joint": ch.drive_joint, "guide_start": ch.guide_start, "platform_joint": ch.platform_joint,
           "drive_joint": ch.drive_joint}
    sts = _setups(setup)
    if sts:
        pts["ball_offset"] = pts["target_offset"] = np.array([st.target for st in sts])
        if sts[0].fixed_ball is not None:
            pts["fixed_ball"] = np.array([st.fixed_ball for st in sts])
    return pts


def _base_motion(machine: Machine, params: ParameterSet, setup: Setup | Sequence[Setup] | None, t: np.ndarray,
                 w: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Parameter deviation of a first-order rigid motion (t, ω about c) of everything fixed to the base."""
    pts = _nominal_points(machine, params, setup)
    out = np.zeros(params.n)
    for k in range(params.n):
        blk, i, a = params.blocks[k], _row(params, k), params.axis[k]
        if blk in BASE_POINTS:
            out[k] = a @ (t + np.cross(w, pts[blk][i] - c))
        elif blk == "drive_joint":  # glide drive-joint offset: a vector fixed to the base
            out[k] = a @ np.cross(w, pts[blk][i])
        elif blk == "guide_direction":
            out[k] = a @ np.cross(w, machine.chains.guide_direction[i])
        elif blk == "instrument_frame":
            comp = params.components[k]
            out[k] = a @ (w if comp.startswith("r") else t - np.cross(w, c))
    return out


def _platform_motion(machine: Machine, params: ParameterSet, setup: Setup | Sequence[Setup] | None, t: np.ndarray,
                     w: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Parameter deviation of a first-order rigid motion (t, ω about c, PKS) of everything fixed to the platform."""
    pts = _nominal_points(machine, params, setup)
    out = np.zeros(params.n)
    for k in range(params.n):
        blk, i, a = params.blocks[k], _row(params, k), params.axis[k]
        if blk in ("platform_joint", "ball_offset", "target_offset"):
            out[k] = a @ (t + np.cross(w, pts[blk][i] - c))
    return out


def gauge_candidates(machine: Machine, params: ParameterSet, setup: Setup | Sequence[Setup] | None
                     ) -> list[GaugeCandidate]:
    """The named candidate gauge groups for ``params`` (see the module docstring), most physical first; with
    several set-ups (:mod:`.setups`) the rigid motions move every set-up's points and name the first set-up's
    centres."""
    cands: list[GaugeCandidate] = []
    setups = setup
    setup = _setups(setups)[0] if _setups(setups) else None
    xyz = ("x", "y", "z")
    if setup is not None and setup.fixed_ball is not None:
        c_base = setup.fixed_ball
        where = "the fixed-ball centre" if len(_setups(setups)) == 1 else "the fixed-ball centre of set-up 1"
    else:
        c_base, where = np.zeros(3), "the MKS origin"
    target = setup.target if setup is not None else np.zeros(3)
    zero = np.zeros(3)
    cands.append(GaugeCandidate("base frame translation", np.stack(
        [_base_motion(machine, params, setups, _E[j], zero, c_base) for j in range(3)], 1), xyz, "rigid"))
    cands.append(GaugeCandidate(f"base frame rotation about {where}", np.stack(
        [_base_motion(machine, params, setups, zero, _E[j], c_base) for j in range(3)], 1), xyz, "rigid"))
    tgt_name = setup.instrument.target_name if setup is not None else "target point"
    cands.append(GaugeCandidate("platform frame translation", np.stack(
        [_platform_motion(machine, params, setups, _E[j], zero, target) for j in range(3)], 1), xyz, "rigid"))
    cands.append(GaugeCandidate(f"platform frame rotation about the {tgt_name}", np.stack(
        [_platform_motion(machine, params, setups, zero, _E[j], target) for j in range(3)], 1), xyz, "rigid"))
    if machine.kind == "glide":
        r = machine.chains.guide_direction
        n_ch = machine.n_chains
        G = np.zeros((params.n, 3 * n_ch))
        g = np.zeros((params.n, n_ch))
        for k in range(params.n):
            i, blk = params.chain[k], params.blocks[k]
            if blk in ("guide_start", "drive_joint"):
                G[k, 3 * i:3 * i + 3] = params.axis[k] * (1.0 if blk == "guide_start" else -1.0)
            if blk == "guide_start":
                g[k, i] = params.axis[k] @ r[i]
            elif blk == "drive_zero":
                g[k, i] = -1.0
        cands.append(GaugeCandidate("guide start vs drive-joint offset per chain (only their sum acts)", G,
                                    tuple(f"{i + 1}.{c}" for i in range(n_ch) for c in xyz), "combination"))
        cands.append(GaugeCandidate("guide start along the guide vs drive zero per chain", g,
                                    tuple(str(i + 1) for i in range(n_ch)), "combination"))
    for k, name in enumerate(params.names):
        e = np.zeros((params.n, 1))
        e[k] = 1.0
        cands.append(GaugeCandidate(f"{name} (no effect)", e, ("",), "parameter"))
    return [c for c in cands if np.any(c.G)]
