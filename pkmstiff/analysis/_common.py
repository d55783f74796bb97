"""Helpers shared by the structure analyses: directions, the TCP load point, component energy split."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

import pkmstiff.multibody as sde
from pkmstiff.structure import PKMStructure, StructureModelError

Array = NDArray[np.float64]

#: named directions: translations along and rotations about the machine axes
AXIS_NAMES = {"x": (0, False), "y": (1, False), "z": (2, False), "rx": (0, True), "ry": (1, True), "rz": (2, True)}

#: component labels of the energy split, in output order (only those present in a machine are reported)
COMPONENT_LABELS = ("drive", "guide", "drive_suspension", "drive_joint", "strut", "platform_joint",
                    "platform_spindle")


def parse_direction(direction: Any, what: str = "direction") -> tuple[np.ndarray, bool]:
    """``"x"``, ``"-y"``, ``"rz"`` or a vector (3,) → (unit vector, rotational?)."""
    if isinstance(direction, str):
        text = direction.strip().lower()
        sign = -1.0 if text.startswith("-") else 1.0
        key = text.lstrip("+-")
        if key not in AXIS_NAMES:
            raise StructureModelError("analysis", what, f"one of {sorted(AXIS_NAMES)} (optionally signed) or a "
                                      "vector (3,)", direction)
        axis, rot = AXIS_NAMES[key]
        e = np.zeros(3)
        e[axis] = sign
        return e, rot
    e = np.asarray(direction, dtype=float)
    if e.shape != (3,) or not np.all(np.isfinite(e)) or not np.linalg.norm(e) > 0:
        raise StructureModelError("analysis", what, "a non-zero finite vector (3,) or an axis name", direction)
    return e / np.linalg.norm(e), False


def by_parts(st: PKMStructure, analyse: Callable[[PKMStructure], Any], per_pose: Sequence[str] = ()) -> Any:
    """``analyse(st)`` computed part by part (:meth:`PKMStructure.parts`: work space bounded by one part) and joined
    along the pose axis: an array result, or a dataclass whose fields ``per_pose`` are (N, ...) arrays (the other
    fields, e.g. labels, come from the first part with modelled poses). Each part's result is written into the
    output as soon as it is computed. Parts without modelled poses stay NaN (their arrays may lack the trailing
    axes of element or body labels)."""
    parts = st.parts()
    if len(parts) == 1:
        return analyse(st)
    out = None
    first = None
    for sl, part in parts:
        res = analyse(part)
        first = res if first is None else first
        if part.empty:
            continue
        if out is None:  # the first part with modelled poses sets the shapes and the labels
            arrays = {f: res if f is None else getattr(res, f) for f in (per_pose or (None,))}
            out = {f: np.full((st.n_poses,) + v.shape[1:], np.nan, v.dtype) for f, v in arrays.items()
                   if v is not None}
            ref = res
        for f, dst in out.items():
            dst[sl] = res if f is None else getattr(res, f)
    if out is None:  # no modelled pose at all: every part's result is NaN, the joined one too
        ref = first
        out = {f: np.full((st.n_poses,) + v.shape[1:], np.nan, v.dtype) for f in (per_pose or (None,))
               if (v := (first if f is None else getattr(first, f))) is not None}
    if None in out:
        return out[None]
    return dataclasses.replace(ref, **out)


def load_body(st: PKMStructure) -> str:
    """Body carrying the TCP load: the tool's body (the platform where the machine leaves K_U out), or the platform
    with K_U rigid where the structure's options say ``load_platform`` (docs/theory/structure.md)."""
    return "platform" if st.options.load_platform else st.tcp_body


def component_energies(st: PKMStructure, q: Array) -> tuple[list[str], Array]:
    """Strain energy (J) of every component kind for displacements ``q`` (M, [k,] n) of ``st.model``.

    W_i (glide): ``½ k_A l'_x²`` (drive) and the rest of ``½ l'ᵀ K'_W l'`` (guide), ``l' = R_iᵀ l``; pod:
    ``½ lᵀ K_W l`` (drive suspension).  V_i: ``½ k_V (d̂·l)²`` split among the series terms in proportion to their
    compliances ``k_V / k_term`` (same force in all terms).  U: ``½ lᵀ K_U l`` (platform_spindle).
    Returns the labels present and energies (M, [k,] C) summing to the total strain energy.
    """
    ks = st.stiffness
    defs = sde.sde_deformations(st.model, q)
    extra = np.asarray(q).ndim - 2

    def ex(a: Array) -> Array:  # per-pose (M, ...) → broadcast over a mode axis
        return a.reshape(a.shape[:1] + (1,) * extra + a.shape[1:])

    shape = np.asarray(q).shape[:-1]
    out = {k: np.zeros(shape) for k in COMPONENT_LABELS}
    glide = st.machine.kind == "glide"
    for i, body in enumerate(st.drive_bodies):
        name = f"W{i + 1}"
        if not body or name not in defs:
            continue
        kl = np.where(np.isposinf(ks.w_local[:, i]), 0.0, ks.w_local[:, i])  # (M, 3, 3)
        if glide:
            lp = np.einsum("ji,...j->...i", st.layout.drive_frames[i], defs[name])  # l' = Rᵀ l
            total = 0.5 * np.einsum("...i,...ij,...j->...", lp, ex(kl), lp)
            drive = 0.5 * ex(kl[:, 0, 0]) * lp[..., 0] ** 2
            out["drive"] += drive
            out["guide"] += total - drive
        else:
            out["drive_suspension"] += 0.5 * np.einsum("...i,...ij,...j->...", defs[name], ex(kl), defs[name])
    terms = [("drive_joint", ks.drive_joint), ("strut", ks.strut), ("platform_joint", ks.platform_joint)]
    if not glide:
        terms.append(("drive", ks.drive))
    for i in range(st.layout.n):
        name = f"V{i + 1}"
        if name not in defs:
            continue
        kv = ks.chain[:, i]
        energy = 0.5 * ex(kv) * np.einsum("...i,...i->...", defs[name], ex(st.u[:, i])) ** 2
        for label, k in terms:
            with np.errstate(divide="ignore"):
                out[label] += energy * ex(kv / k[:, i])  # k = inf (rigid term): share 0
    if "U" in defs:
        u_set = next(s for s in st.model.sets if s.names == ("U",))
        ku = u_set.stiffness.full()[:, 0]  # (M|1, 6, 6)
        out["platform_spindle"] += 0.5 * np.einsum("...i,...ij,...j->...", defs["U"], ex(ku), defs["U"])
    present = present_components(st)
    return present, np.stack([out[k] for k in present], axis=-1)


def present_components(st: PKMStructure) -> list[str]:
    mc = st.layout.components
    has = {
        "drive": any(d is not None for d in mc.drive),
        "guide": st.machine.kind == "glide" and any(g is not None for g in mc.guide),
        "drive_suspension": st.machine.kind == "pod" and any(s is not None for s in mc.drive_suspension),
        "drive_joint": any(j is not None for j in mc.drive_joint),
        "strut": any(s is not None for s in mc.strut),
        "platform_joint": any(j is not None for j in mc.platform_joint),
        "platform_spindle": st.layout.separate_spindle,
    }
    return [k for k in COMPONENT_LABELS if has[k]]


def shares(energy: Array) -> Array:
    """Normalise energies along the last axis to shares summing to 1 (all-zero rows stay 0)."""
    total = energy.sum(axis=-1, keepdims=True)
    return energy / np.where(total > 0, total, 1.0)
