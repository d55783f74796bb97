"""Component stiffness per pose and chain: evaluation of the component models at the joint angles and drive
positions of each pose, chain series stiffness k_V (docs/theory/structure.md, Cobet eq. 4.48-4.50).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pkmstiff.kinematics import IK
from pkmstiff.structure.layout import StructureLayout
from pkmstiff.structure.masses import effective_mass
from pkmstiff.structure.options import Array


def _state_kwargs(role: str, cols: list[int], arrays: dict[str, Array]) -> dict[str, Array]:
    """ComponentState fields (chain-major, flattened) for the chains ``cols`` of one role."""
    keys = {"drive": ("drive_position", "strut_length", "effective_mass"), "strut": ("strut_length",),
            "guide": ("drive_position",), "drive_suspension": ("drive_position", "strut_length"),
            "drive_joint": ("tilt", "swivel"), "platform_joint": ("tilt", "swivel")}[role]
    out = {}
    for k in keys:
        src = arrays.get(f"{role}.{k}", arrays.get(k))
        if src is not None:
            out[k] = np.ascontiguousarray(src[:, cols].T).ravel()
    return out


def evaluate_component(component: Any, kwargs: dict[str, Array], n_values: int) -> tuple[Array, Array]:
    """Stiffness of ``component`` for ``n_values`` states and a per-value ok mask (bisection on range errors)."""
    from components.protocol import ComponentRangeError, ComponentState

    def run(idx: Array) -> tuple[Array, Array]:
        sub = {k: v[idx] for k, v in kwargs.items()}
        state = ComponentState(**sub) if sub else ComponentState(n_poses=max(len(idx), 1))
        try:
            val = np.asarray(component.stiffness(state), dtype=float)
            if not sub and len(idx) == 0:
                val = val[:0]
            return val, np.ones(len(idx), bool)
        except ComponentRangeError:
            if len(idx) == 1:
                return np.full((1,) + _core_shape(component), np.nan), np.zeros(1, bool)
            half = len(idx) // 2
            va, oa = run(idx[:half])
            vb, ob = run(idx[half:])
            return np.concatenate([va, vb]), np.concatenate([oa, ob])

    if n_values == 0:
        return np.zeros((0,) + _core_shape(component)), np.zeros(0, bool)
    values, ok = run(np.arange(n_values))
    core = values.reshape(n_values, -1)
    with np.errstate(invalid="ignore"):
        ok &= np.all(np.isfinite(core) | np.isposinf(core), axis=1)
        if values.ndim == 1:
            ok &= values > 0
    return values, ok


def _core_shape(component: Any) -> tuple[int, ...]:
    return {"matrix3": (3, 3), "matrix6": (6, 6)}.get(getattr(component, "kind", "axial"), ())


def _role_stiffness(instances: Sequence[Any], role: str, arrays: dict[str, Array], n_poses: int,
                    rigid: Any) -> tuple[Array, Array]:
    """Per-chain stiffness of a role (N, n[, 3, 3]) and an ok mask (N,); ``None`` components give ``rigid``.

    Chains sharing one component instance are evaluated in a single call (states stacked chain-major).
    """
    n = len(instances)
    core = np.shape(rigid)
    out = np.empty((n_poses, n) + core)
    out[:] = rigid
    ok = np.ones(n_poses, bool)
    groups: dict[int, list[int]] = {}
    for i, c in enumerate(instances):
        if c is not None:
            groups.setdefault(id(c), []).append(i)
    for cols in groups.values():
        comp = instances[cols[0]]
        vals, good = evaluate_component(comp, _state_kwargs(role, cols, arrays), n_poses * len(cols))
        vals = vals.reshape((len(cols), n_poses) + vals.shape[1:])
        out[:, cols] = np.moveaxis(vals, 0, 1)
        ok &= good.reshape(len(cols), n_poses).all(axis=0)
    return out, ok


@dataclass
class ChainStiffness:
    """Component stiffnesses per pose and chain (N/m; ``inf`` = rigid, i.e. component not given).

    ``drive_joint``, ``strut``, ``platform_joint``, ``drive`` (pod: the telescopic drive, part of the chain;
    glide: axial drive stiffness k_A, part of W) are (N, n); ``chain`` = k_V (N, n); ``w_local`` glide
    K'_W = diag(k_A, k_y, k_z) (N, n, 3, 3) in drive coordinates, pod: suspension in the MKS; None if rigid.
    """

    drive_joint: Array
    strut: Array
    platform_joint: Array
    drive: Array
    chain: Array
    w_local: Array | None

    def take(self, idx: Array) -> ChainStiffness:
        """The same stiffnesses at the poses ``idx`` (index array or boolean mask)."""
        return ChainStiffness(self.drive_joint[idx], self.strut[idx], self.platform_joint[idx], self.drive[idx],
                              self.chain[idx], None if self.w_local is None else self.w_local[idx])


def _chain_arrays(ik: IK, angles: Mapping[str, Array] | Any, idx: Array) -> dict[str, Array]:
    def angle(side: str, qty: str) -> Array:
        a = angles[f"{side}_{qty}"] if isinstance(angles, Mapping) else getattr(getattr(angles, side), qty)
        return a[idx]

    return {
        "drive_position": ik.drive[idx], "strut_length": ik.length[idx],
        **{f"{side}_joint.{qty}": angle(side, qty) for side in ("drive", "platform") for qty in ("tilt", "swivel")},
    }


def _pole_placement(layout: StructureLayout) -> bool:
    return any(getattr(d, "axial_stiffness", None) == "pole_placement" for d in layout.components.drive)


def chain_stiffness(layout: StructureLayout, ik: IK, angles: Mapping[str, Array] | Any, idx: Array
                    ) -> tuple[ChainStiffness, Array]:
    """Component stiffnesses at the poses ``idx`` of ``ik`` and an ok mask (len(idx),) (docs/theory/components.md, eq. 4.48).

    ``angles``: the joint angles of the pose pipeline (:attr:`pkmstiff.admissibility.pipeline.PoseEvaluation.angles`,
    keys ``drive_tilt``, ``drive_swivel``, ``platform_tilt``, ``platform_swivel``), or a
    :class:`~pkmstiff.kinematics.joint_angles.JointAngles`."""
    mc, n, m = layout.components, layout.n, len(idx)
    arrays = _chain_arrays(ik, angles, idx)
    if _pole_placement(layout):
        arrays["drive.effective_mass"] = effective_mass(layout, ik, idx, layout.machine)
    k_dj, ok1 = _role_stiffness(mc.drive_joint, "drive_joint", arrays, m, np.inf)
    k_pj, ok2 = _role_stiffness(mc.platform_joint, "platform_joint", arrays, m, np.inf)
    k_st, ok3 = _role_stiffness(mc.strut, "strut", arrays, m, np.inf)
    k_dr, ok4 = _role_stiffness(mc.drive, "drive", arrays, m, np.inf)
    ok = ok1 & ok2 & ok3 & ok4
    with np.errstate(divide="ignore", invalid="ignore"):
        comp = 1.0 / k_dj + 1.0 / k_st + 1.0 / k_pj
        if layout.machine.kind == "pod":
            comp = comp + 1.0 / k_dr  # the telescopic drive is the strut term of eq. 4.48
        k_v = 1.0 / comp
    w_local = None
    if layout.machine.kind == "glide":
        guide, ok5 = _role_stiffness(mc.guide, "guide", arrays, m, np.diag([0.0, np.inf, np.inf]))
        w_local = np.array(guide, copy=True)
        w_local[..., 0, 0] = k_dr
        ok &= ok5
    elif any(s is not None for s in mc.drive_suspension):
        w_local, ok5 = _role_stiffness(mc.drive_suspension, "drive_suspension", arrays, m,
                                       np.diag([np.inf, np.inf, np.inf]))
        ok &= ok5
    return ChainStiffness(k_dj, k_st, k_pj, k_dr, k_v, w_local), ok
