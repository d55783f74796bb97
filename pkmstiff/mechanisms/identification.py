"""Geometric parameters of a mechanism and its identification Jacobian, for calibration (issue 14, item 5).

Self-contained interface (Denkena §1.3: implicit identification equations F(x, ψ, y, p) = 0, Jacobian by the
implicit function theorem): :func:`parameters` names every geometric parameter with its unit and nominal value
(joint points ``<joint>.point.x`` [m], axes ``<joint>.axis.x`` / ``<joint>.axis2.x`` [1, components as entered,
not renormalised], drive offsets ``<joint>.offset`` [m or rad], output point ``output.point.x`` [m]);
:func:`identification_jacobian` returns ∂(output pose)/∂p at the configurations reached for given drive values,
∂q/∂p = −F_q⁺ F_p (pseudo-inverse by SVD with rank from the singular-value gap; the rows are redundant).
F_q is analytic; F_p and the pose derivatives are central differences of the analytic residual / pose (O(h²)).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pkmstiff.errors import ArgumentError
from pkmstiff.mechanisms.constraints import fk_system
from pkmstiff.mechanisms.linalg import gap_rank
from pkmstiff.mechanisms.model import Drive, Mechanism
from pkmstiff.mechanisms.solver import Solution, forward, output_pose

Array = NDArray[np.float64]


def parameters(mech: Mechanism) -> tuple[list[str], list[str], Array]:
    """Names, units and nominal values (SI) of the mechanism's geometric parameters."""
    names, units, vals = [], [], []
    ax = "xyz"[: mech.dim]
    for jt in mech.joints:
        if jt.type == "fixed":
            continue
        if jt.type not in ("equal_orientation", "common_axis", "perpendicular_axes"):
            for c, v in zip(ax, jt.point):
                names.append(f"{jt.name}.point.{c}"); units.append("m"); vals.append(v)  # noqa: E702
        for key, vec in (("axis", jt.axis), ("axis2", jt.axis2)):
            if vec is not None:
                for c, v in zip(ax, vec):
                    names.append(f"{jt.name}.{key}.{c}"); units.append("1"); vals.append(v)  # noqa: E702
        if jt.drive is not None:
            names.append(f"{jt.name}.offset"); units.append("m" if jt.variable == "linear" else "rad")  # noqa: E702
            vals.append(jt.drive.offset)
    if mech.output is not None:
        for c, v in zip(ax, mech.output.point):
            names.append(f"output.point.{c}"); units.append("m"); vals.append(v)  # noqa: E702
    return names, units, np.array(vals, dtype=float)


def with_parameters(mech: Mechanism, values: ArrayLike) -> Mechanism:
    """The mechanism with its geometric parameters (order of :func:`parameters`) replaced by ``values``."""
    names, _, nominal = parameters(mech)
    values = np.asarray(values, dtype=float)
    if values.shape != nominal.shape:
        raise ArgumentError(f"values: expected {nominal.size} parameters (see parameters()), "
                                  f"found shape {values.shape}")
    it = iter(values)
    D = mech.dim
    joints = []
    for jt in mech.joints:
        if jt.type == "fixed":
            joints.append(jt)
            continue
        kw = {}
        if jt.type not in ("equal_orientation", "common_axis", "perpendicular_axes"):
            kw["point"] = np.array([next(it) for _ in range(D)])
        for key in ("axis", "axis2"):
            if getattr(jt, key) is not None:
                kw[key] = np.array([next(it) for _ in range(D)])
        if jt.drive is not None:
            kw["drive"] = Drive(jt.drive.name, float(next(it)))
        joints.append(dataclasses.replace(jt, **kw))
    out = mech.output
    if out is not None:
        out = dataclasses.replace(out, point=np.array([next(it) for _ in range(D)]))
    return dataclasses.replace(mech, joints=tuple(joints), output=out)


def identification_jacobian(mech: Mechanism, drives: ArrayLike, start: Solution | None = None,
                            names: list[str] | None = None, steps: int = 1, h: float = 1e-6
                            ) -> tuple[Solution, Array, list[str]]:
    """∂(output pose)/∂p (N, pose_size, n_params) at the forward-kinematics configurations of ``drives``.

    Returns the solution, the Jacobian (pose rows x, y, z [m], a, b, c [rad]; columns per parameter in the
    parameter's unit) and the parameter names (all, or ``names``).  Poses without a configuration give NaN rows.
    """
    all_names, _, p0 = parameters(mech)
    sel = list(range(len(all_names))) if names is None else [all_names.index(n) if n in all_names else
                                                             _bad(n, all_names) for n in names]
    sol = forward(mech, drives, start=start, steps=steps)
    system = fk_system(mech)
    rows, free = system.solve_rows, system.free
    N, L, d = sol.q.shape
    tg = np.asarray(drives, dtype=float).reshape(N, -1)
    # configuration changes in the Newton coordinates (incremental rotation vectors of the links, System.step):
    # regular at every link orientation, also where a link's Euler angle φy = ±90°
    _, Fq = system.evaluate(sol.q, tg, reduced=True, omega=True)
    hp = h * max(1.0, mech.length_scale)
    Fp = np.empty((N, rows.size, len(sel)))
    Pp = np.empty((N, mech.pose_size, len(sel)))
    for c, k in enumerate(sel):
        rs, ps = [], []
        for sg in (1.0, -1.0):
            p = p0.copy()
            p[k] += sg * hp
            m2 = with_parameters(mech, p)
            rs.append(fk_system(m2).evaluate(sol.q, tg, jac=False)[0][:, rows])
            ps.append(output_pose(m2, sol.q) if mech.output is not None else np.zeros((N, mech.pose_size)))
        Fp[:, :, c] = (rs[0] - rs[1]) / (2 * hp)
        Pp[:, :, c] = (ps[0] - ps[1]) / (2 * hp)
    U, s, Vt = np.linalg.svd(Fq, full_matrices=False)
    rk = gap_rank(s)
    inv_s = np.where(np.arange(s.shape[1])[None] < rk[:, None], 1.0 / np.where(s > 0, s, 1.0), 0.0)
    dq = -np.einsum("nji,nj,nkj,nkp->nip", Vt, inv_s, U, Fp)  # (N, n_free, n_params)
    Pq = np.empty((N, mech.pose_size, free.size))
    hq = 1e-7
    qf = sol.q.reshape(N, -1)
    for c in range(free.size):
        e = np.zeros((N, free.size))
        e[:, c] = hq
        qp, qm = system.step(qf, e), system.step(qf, -e)
        Pq[:, :, c] = (output_pose(mech, qp.reshape(N, L, d)) - output_pose(mech, qm.reshape(N, L, d))) / (2 * hq)
    Jid = np.einsum("npf,nfk->npk", Pq, dq) + Pp
    Jid[~sol.ok] = np.nan
    return sol, Jid, [all_names[k] for k in sel]


def _bad(n: str, names: list[str]) -> int:
    raise ArgumentError(f"parameter {n!r}: expected one of the names of parameters(), e.g. {names[:3]}")
