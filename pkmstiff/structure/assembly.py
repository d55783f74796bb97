"""Assembly of the SDE model from layout, geometry and chain stiffness: bindings W, V, U
(docs/theory/structure.md, Cobet eq. 3.6, 4.48-4.52).
"""

from __future__ import annotations

import numpy as np

import pkmstiff.multibody as sde
from pkmstiff.structure.layout import StructureLayout
from pkmstiff.structure.options import Array
from pkmstiff.structure.stiffness import ChainStiffness


def _frame_name(layout: StructureLayout) -> str:
    return "base" if layout.options.free_frame else sde.FRAME


def _w_matrices(layout: StructureLayout, w_local: Array) -> tuple[Array, Array]:
    """K_W in the MKS with rigid (inf) local directions zeroed (M, n, 3, 3), and the rigid-direction mask (n, 3)."""
    if w_local.shape[0] > 1 and np.array_equal(w_local, np.broadcast_to(w_local[:1], w_local.shape)):
        w_local = w_local[:1]  # pose-independent (e.g. constant drive and guide stiffness): assemble once
    diag = np.diagonal(w_local, axis1=-2, axis2=-1)  # (M|1, n, 3)
    rigid = np.all(np.isposinf(diag), axis=0)
    kl = np.where(np.isposinf(w_local), 0.0, w_local)
    if layout.machine.kind == "glide":
        fr = layout.drive_frames  # (n, 3, 3)
        kw = fr @ kl @ np.swapaxes(fr, -1, -2)
    else:
        kw = kl
    return kw, rigid


def drive_names(layout: StructureLayout, ks: ChainStiffness) -> tuple[str, ...]:
    if ks.w_local is None:
        return ("",) * layout.n
    fixed = _w_matrices(layout, ks.w_local)[1].all(axis=1)
    return tuple("" if fixed[i] else f"drive{i + 1}" for i in range(layout.n))


def rigid_chains(ks: ChainStiffness) -> np.ndarray:
    kv = ks.chain
    return np.all(np.isposinf(kv), axis=0) if kv.shape[0] else np.zeros(kv.shape[1], bool)


def sde_model(layout: StructureLayout, w: Array, R: Array, p: Array, q: Array, u: Array,
               ks: ChainStiffness, with_spindle: bool = True) -> sde.SDEModel:
    """Bodies and bindings (docs/theory/structure.md) for the modelled poses (leading axis M).

    ``with_spindle=False`` leaves out a separate spindle body and U (see :attr:`PKMStructure.dynamic_model`).
    """
    opts, n, m_p = layout.options, layout.n, w.shape[0]
    with_spindle = with_spindle and layout.separate_spindle
    frame = _frame_name(layout)
    model = sde.SDEModel()
    beta = opts.damping_beta
    r_u = w + R @ np.asarray(opts.coupling_point, float)
    if with_spindle:
        sp = layout.spindle
        pos = r_u if sp.mass == 0 else w + R @ sp.cog
        model.add_rigid_body("spindle", sp.mass, pos, sp.inertia, rotation=R)
    pl = layout.platform
    model.add_rigid_body("platform", pl.mass, w + R @ pl.cog, pl.inertia, rotation=R)

    # drive bodies exist where the drive-frame binding is not rigid in all three directions
    if ks.w_local is not None:
        kw, rigid_dir = _w_matrices(layout, ks.w_local)
    else:
        kw, rigid_dir = None, np.ones((n, 3), bool)
    fixed = rigid_dir.all(axis=1)
    drives = tuple("" if fixed[i] else f"drive{i + 1}" for i in range(n))
    for i in range(n):
        if drives[i]:
            model.add_point_mass(drives[i], layout.drive_mass[i], q[:, i])
    if opts.free_frame:
        model.add_rigid_body("base", opts.frame_mass, np.zeros(3), np.full(3, opts.frame_inertia))

    live = [i for i in range(n) if drives[i]]
    if kw is not None and live:
        kk = kw[:, live]
        model.add_sde_set([f"W{i + 1}" for i in live], [drives[i] for i in live], frame, q[:, live],
                          stiffness=kk, damping=beta * kk if beta else None, groups="W", check_psd=False)
        for i in live:
            for j in np.flatnonzero(rigid_dir[i]):
                axis = layout.drive_frames[i][:, j] if layout.machine.kind == "glide" else np.eye(3)[j]
                model.add_rigid_binding(f"W{i + 1}_rigid_{'xyz'[j]}", drives[i], frame, q[:, i], kind="axial",
                                        axis=axis)

    kv = ks.chain
    rigid_chain = rigid_chains(ks)
    elastic = [i for i in range(n) if not rigid_chain[i]]
    for side_fixed in (False, True):
        sel = [i for i in elastic if bool(fixed[i]) == side_fixed]
        if not sel:
            continue
        side_a = frame if side_fixed else [drives[i] for i in sel]
        k = kv[:, sel]
        model.add_sde_set([f"V{i + 1}" for i in sel], side_a, "platform", p[:, sel], k=k, axis=u[:, sel],
                          c=beta * k if beta else None, groups="V")
    for i in np.flatnonzero(rigid_chain):
        model.add_rigid_binding(f"V{i + 1}_rigid", drives[i] or frame, "platform", p[:, i], kind="axial",
                                axis=u[:, i])

    if with_spindle:
        ku = platform_spindle_matrix(layout)
        if opts.k_u_axes == "platform":
            h = np.zeros((m_p, 6, 6))
            h[:, :3, :3] = R
            h[:, 3:, 3:] = R
            ku = h @ ku @ np.swapaxes(h, 1, 2)
        model.add_sde("U", "platform", "spindle", r_u, stiffness=ku, damping=beta * ku if beta else None,
                      group="U", check_psd=False)
    return model


def platform_spindle_matrix(layout: StructureLayout) -> Array:
    """The constant 6×6 K_U of the ``platform_spindle`` component (N/m, N/rad, N m/rad blocks)."""
    from components.protocol import ComponentState

    comp = layout.components.platform_spindle
    return np.asarray(comp.stiffness(ComponentState(n_poses=1)), float).reshape(6, 6)
