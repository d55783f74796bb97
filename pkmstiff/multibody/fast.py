"""Compiled fast path of the batch analysis: stiffness, compliance of one body and the mass-normalised
eigenproblem matrix of a chunk of poses with the kernels of :mod:`pkmstiff.multibody.kernels`.

Same quantities as :func:`pkmstiff.multibody.assembly.stiffness_matrix`,
:meth:`pkmstiff.multibody.solver.StaticSystem.body_compliance` and
:func:`pkmstiff.multibody.modal.dynamic_system` (``.a``), equal to round-off.  Applies to models without rigid
bindings; the eigenproblem matrix additionally needs every DOF to carry mass (no static condensation), else
:func:`compiled_chunk` returns None for it and the caller uses the numpy path.  Used for chunks of at least
:data:`MIN_POSES` poses (importing numba and loading the compiled kernels costs ~1 s once per process, so small
calls, e.g. one pose through the API, stay on the numpy path; the choice depends on the chunk size only, so results
are reproducible bit for bit across processes); ``PKMSTIFF_JIT=0`` disables it,
``PKMSTIFF_JIT=1`` forces it.
"""

from __future__ import annotations

import os

import numpy as np

from pkmstiff.errors import InputError, NumericalError
from pkmstiff.multibody.bodies import FRAME, RigidBody
from pkmstiff.multibody.solver import UNDER_RESTRAINED, cholesky_checked, elimination_plan
from pkmstiff.multibody.system import SDEModel

#: chunks with at least this many poses use the compiled kernels (as pkmstiff.kinematics.dispatch.COMPILE_AFTER)
MIN_POSES = 200

#: poses per kernel/LAPACK block (K and A of a 24-DOF model: 2 × 128 × 4.6 kB, in L2/L3; 32…256 measured, 128 best)
BLOCK = 128


def use_compiled(model: SDEModel) -> bool:
    """Whether :func:`compiled_chunk` applies to ``model`` and pays off for its number of poses."""
    mode = os.environ.get("PKMSTIFF_JIT", "")
    if mode == "0" or model.bindings:
        return False
    # by the chunk size alone (not by whether numba is already loaded), so that a pose gives the same bits in every
    # process (sweeps compare serial, process-pool and dask results bit for bit)
    return mode == "1" or model.n_poses >= MIN_POSES


def _side(model: SDEModel, names: tuple[str, ...], point: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First global DOF (E,), kind (E,) and Δ = point − body reference point (1|P, E, 3) of one side of a set."""
    n_el = len(names)
    if names[0] == FRAME:
        return np.full(n_el, -1, np.int64), np.zeros(n_el, np.int64), np.zeros((1, n_el, 3))
    start = np.array([model.dof_index(n).start for n in names], np.int64)
    if not isinstance(model.body(names[0]), RigidBody):
        return start, np.ones(n_el, np.int64), np.zeros((1, n_el, 3))
    pos = [model.body(n).position for n in names]
    n_p = max(p.shape[0] for p in pos)
    ref = np.stack([np.broadcast_to(p, (n_p, 3)) for p in pos], axis=1)
    return start, np.full(n_el, 2, np.int64), np.ascontiguousarray(point - ref)


def _set_arrays(model: SDEModel) -> list[tuple]:
    """Kernel arguments of every SDE set (stiffness only; see :func:`pkmstiff.multibody.kernels.assemble_set`)."""
    dummy2, dummy3, dummy4 = np.zeros((1, 1)), np.zeros((1, 1, 3)), np.zeros((1, 1, 3, 3))
    out = []
    for s in model.sets:
        sa, ka, da = _side(model, s.body_a, s.point)
        sb, kb, db = _side(model, s.body_b, s.point)
        spec = s.stiffness
        if spec.matrix is None:
            out.append((sa, ka, sb, kb, da, db, np.ascontiguousarray(spec.k), np.ascontiguousarray(spec.axis),
                        dummy4, True))
        else:
            out.append((sa, ka, sb, kb, da, db, dummy2, dummy3, np.ascontiguousarray(spec.matrix), False))
    return out


def _block(arr: np.ndarray, sl: slice) -> np.ndarray:
    """Poses ``sl`` of an array with a leading pose axis of length 1 (broadcast) or P."""
    return arr if arr.shape[0] == 1 else arr[sl]


def _mass_layout(model: SDEModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scale (1|P, n), rotation-block starts (B,) and L⁻¹ (1|P, B, 3, 3) of the mass normalisation
    (as :func:`pkmstiff.multibody.modal.dynamic_system` without massless DOFs)."""
    n = model.n_dof
    n_pm = max([b.mass.shape[0] for b in model.bodies])
    scale = np.ones((n_pm, n))
    starts, linvs = [], []
    for body in model.bodies:
        s = model.dof_index(body.name)
        if np.all(body.mass > 0):
            scale[:, s.start:s.start + 3] = (1.0 / np.sqrt(body.mass))[:, None]
        if isinstance(body, RigidBody) and not np.all(body.inertia == 0):
            lower = cholesky_checked(body.inertia, f"inertia of rigid body '{body.name}'",
                                     "all principal moments must be > 0 (or all 0 for a massless body)")
            starts.append(s.start + 3)  # L⁻¹ as cholesky_inverse_factor (same calls, one Cholesky fewer)
            linvs.append(np.linalg.solve(lower, np.broadcast_to(np.eye(3), lower.shape)))
    if not linvs:
        return scale, np.zeros(0, np.int64), np.zeros((1, 0, 3, 3))
    n_pl = max(x.shape[0] for x in linvs)
    linv = np.stack([np.broadcast_to(x, (n_pl, 3, 3)) for x in linvs], axis=1)
    return scale, np.array(starts, np.int64), np.ascontiguousarray(linv)


def compiled_chunk(model: SDEModel, body: str, transform: np.ndarray, n_modes: int
                   ) -> tuple[np.ndarray, np.ndarray | None]:
    """``T (K⁻¹)_bb Tᵀ`` (P, d, d) of ``body`` for the point transform ``transform`` (1|P, d, d), and the
    ``n_modes`` lowest eigenvalues λ (P, n_modes) of ``K v = λ M v`` in rad²/s² (None if ``n_modes`` is 0 or a
    DOF has no mass: the caller then uses :func:`pkmstiff.multibody.modal.modal_chunk`).

    Works through blocks of :data:`BLOCK` poses so that K and the eigenproblem matrices stay in cache between the
    kernels and LAPACK (``eigvalsh``, the same call as :func:`~pkmstiff.multibody.modal.modal_chunk`).
    Raises :class:`NumericalError` naming the poses where K is not positive definite (as the numpy path).
    """
    from pkmstiff.multibody import kernels

    n_p, n = model.n_poses, model.n_dof
    plan = elimination_plan(model, (body,))
    sl = plan.slices
    elim = [d for members, _ in plan.steps for i in members for d in range(sl[i].start, sl[i].stop)]
    kept = [d for i in plan.kept for d in range(sl[i].start, sl[i].stop)]
    order = np.array(elim + kept, np.int64)
    right = np.ascontiguousarray(np.swapaxes(transform, -1, -2))
    star = None  # one elimination step whose bodies couple only to the kept body (PKM drives): dense kernel
    if len(plan.steps) == 0 or (len(plan.steps) == 1 and plan.steps[0][1] == plan.kept):
        members = plan.steps[0][0] if plan.steps else ()
        d = sl[members[0]].stop - sl[members[0]].start if members else 3
        star = (np.array([sl[i].start for i in members], np.int64), d, np.array(kept, np.int64))
    sets = _set_arrays(model)
    dynamic = n_modes > 0 and model.massless_dofs.size == 0
    if dynamic:
        if not 1 <= n_modes <= n:
            raise InputError("modes", "n_modes", f"1..{n} (dynamic DOFs of the model)", n_modes)
        scale, starts, linv = _mass_layout(model)
        lam = np.empty((n_p, n_modes))
    comp = np.empty((n_p, right.shape[2], right.shape[2]))
    ok = np.empty(n_p, np.bool_)
    k_buf = np.empty((min(BLOCK, n_p), n, n))
    a_buf = np.empty_like(k_buf)
    for s0 in range(0, n_p, BLOCK):
        bl = slice(s0, min(s0 + BLOCK, n_p))
        m = bl.stop - bl.start
        k = k_buf[:m]
        k[...] = 0.0
        for sa, ka, sb, kb, da, db, kk, ax, mat, rank_one in sets:
            kernels.assemble_set(k, sa, ka, sb, kb, _block(da, bl), _block(db, bl), _block(kk, bl),
                                 _block(ax, bl), _block(mat, bl), rank_one)
        if star is None:
            kernels.condensed_compliance(k, order, len(elim), _block(right, bl), comp[bl], ok[bl])
        else:
            kernels.condensed_star(k, star[0], star[1], star[2], _block(right, bl), comp[bl], ok[bl])
        if dynamic:
            a = a_buf[:m]
            kernels.mass_normalised(k, _block(scale, bl), starts, _block(linv, bl), a)
            lam[bl] = np.linalg.eigvalsh(a)[:, :n_modes]
    if not ok.all():
        bad = np.flatnonzero(~ok)
        raise NumericalError(f"matrix not positive definite (block elimination) at poses {bad[:10].tolist()}"
                                 f"{' ...' if bad.size > 10 else ''}: {UNDER_RESTRAINED}")
    return comp, (lam if dynamic else None)
