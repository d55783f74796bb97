"""Kinetostatics of a mechanism with elastic (mass) data: the machines' quantities (docs/theory/kinetostatics.md,
Cobet 4.3) from the controlled-output Jacobian J = ∂x_c/∂s (:func:`~pkmstiff.mechanisms.outputs.output_jacobian`,
implicit differentiation, no finite differences) and the masses of the elastic model.

* Drive rates per output rate J⁻¹ (n×n, the controlled outputs of the file: as many as drives); a direction e is a
  translation of the output point along x, y or z with the other controlled outputs (orientation, tool axis) held.
* Transmission quality ``U = (σ_min/σ_max)^½`` of ``W_x J W_s⁻¹`` (eq. 4.75, 4.77; the machines' default form
  ``inverse_sqrt_kappa``, :func:`pkmstiff.kinematics.transmission_quality`) with W_x = 1 on the point rows and w
  on the orientation rows, W_s = 1 for linear drives and w for rotary drives; w [m/rad] = ``[elastic]
  transmission_weight``, default the mechanism's length scale (so that rotary and linear drives compare in one unit).
* v_max (eq. 4.79) with the drive components' ``max_speed`` (rotary: ``max_angular_speed``); a_max from standstill (eq. 4.80–4.93) with
  ``μ = M_s J⁻¹ e``, ``M_s = M_A + Σ_b J_bᵀ M_b J_b`` the mass matrix of every body of the elastic model in drive
  coordinates (J_b: the body's twist per drive rate) plus the diagonal drive-coordinate masses M_A of telescopic
  drives (the drive component's mass: a ball screw's moved + apparent spindle mass, Cobet eq. 3.4) and rotary
  drives' rotor ``inertia`` (:attr:`~pkmstiff.mechanisms.structure.Plan.drive_inertias`) — for a pod/glide machine
  ``M_A + J_Cᵀ M_P J_C`` (eq. 4.86; a glide's M_A is its carriage nodes, which move with the drive coordinate).
* Static drive loads τ_g = Σ_b J_{b,v}ᵀ (−m_b g) (eq. 4.90): the forces (N) or torques (N m) that hold every body
  against gravity, g = −9.81 m/s² · ``[elastic] vertical`` (M_A carries no weight, as in the machines); plus
  ``[elastic] drive_load_strut_mass`` × the strut masses at the CoG of the output link's body (+ tool body), in τ_g
  only — the machines' eq. 4.90 reading
  (``limits.drive_load_strut_mass``, :func:`pkmstiff.machine.roles.drive_load_data`), so that a generated mechanism
  file gives its machine's static drive loads and a_max.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pkmstiff.analysis.kinetostatics import acceleration_bounds, max_velocity, twist_directions
from pkmstiff.errors import InputError
from pkmstiff.mechanisms.constraints import Frames
from pkmstiff.mechanisms.model import Mechanism
from pkmstiff.mechanisms.outputs import configuration_rates, controlled_output_names, output_jacobian
from pkmstiff.mechanisms.solver import Solution

Array = np.ndarray
#: standard gravity [m/s²] (the machines' default ``gravity``)
G = 9.81
VELOCITY_DIRECTIONS = ("x", "y", "z")
ACCELERATION_DIRECTIONS = ("x", "-x", "y", "-y", "z", "-z")


def link_twist_matrix(mech: Mechanism, q: Array, link: int, point: Array) -> Array:
    """(N, 6, L·d): velocity (3) of the point ``point`` (home world coordinates on ``link``) and angular velocity
    (3) of the link per rate of the link coordinates q (N, L, d); planar mechanisms embedded in z = 0."""
    D = mech.dim
    N, L, d = q.shape
    F = Frames(q, D)
    li = np.array([link])
    _, Dw = F.point(li, np.asarray(point, float)[None, :D])  # (N, 1, D, nr)
    out = np.zeros((N, 6, L, d))
    for c in range(D):
        out[:, c, link, c] = 1.0
        out[:, c, link, D:] = Dw[:, 0, c]
    if D == 3:
        out[:, 3:, link, 3:] = F.rates(li)[:, 0]
    else:
        out[:, 5, link, 2] = 1.0
    return out.reshape(N, 6, L * d)


@dataclass
class MechanismKinetostatics:
    """Kinetostatics at N configurations (SI; NaN where the configuration is missing or J singular).

    ``jinv`` (N, n, n_c) drive rates per controlled-output rate; ``directions`` labels of v_max (x, y, z among the
    controlled coordinates) and a_max (±); ``drive_loads`` (N, n) N or N m (``rotary`` drives)."""

    outputs: tuple[str, ...]
    jinv: Array
    weight: float
    transmission_quality: Array
    velocity_labels: list[str]
    v_max: Array
    v_limiting: Array
    acceleration_labels: list[str]
    a_max: Array
    a_limiting: Array
    a_infeasible: Array
    drive_loads: Array
    mass_matrix: Array
    rotary: Array
    notes: list[str]


def _bodies(mech: Mechanism):
    """(link, home cog (3,), mass, inertia about the cog in link axes (3, 3)) of every mass of the elastic model:
    rigid links, flexible links' tool parts (kinematically rigid), strut-end nodes (point masses)."""
    from pkmstiff.mechanisms.structure import _home3, plan

    pl = plan(mech, dynamics=True)
    out = [(li, b.cog, b.mass, b.inertia) for li, b in list(pl.bodies.items()) + list(pl.tools.items())]
    out += [(mech.joints[ji].links[1], _home3(mech, mech.joints[ji].point), nd.mass, np.zeros((3, 3)))
            for ji, nd in pl.nodes.items()]
    return [b for b in out if b[2] > 0]


def mass_and_gravity(mech: Mechanism, q: Array, q_s: Array) -> tuple[Array, Array]:
    """M_s (N, n, n) [kg, kg m, kg m² by drive units] and τ_g (N, n) at configurations q (N, L, d) with
    configuration rates q_s (N, L·d, n)."""
    from pkmstiff.mechanisms.structure import plan

    N = q.shape[0]
    n = q_s.shape[2]
    F = Frames(q, mech.dim, derivatives=False)
    g = -G * mech.elastic.vertical
    M = np.zeros((N, n, n))
    tau = np.zeros((N, n))
    for li, cog, mass, inertia in _bodies(mech):
        Jb = link_twist_matrix(mech, q, li, cog) @ q_s  # (N, 6, n)
        Jv, Jw = Jb[:, :3], Jb[:, 3:]
        M += mass * np.swapaxes(Jv, 1, 2) @ Jv
        if np.any(inertia):
            R = F.R[:, li]
            if mech.dim == 2:
                R3 = np.zeros((N, 3, 3))
                R3[:, :2, :2], R3[:, 2, 2] = R, 1.0
                R = R3
            Iw = R @ inertia @ np.swapaxes(R, 1, 2)
            M += np.swapaxes(Jw, 1, 2) @ Iw @ Jw
        tau += np.einsum("nji,j->ni", Jv, -mass * g)
    # drive-coordinate masses/inertias M_A (telescopic drives, rotary drives' rotors): M_A s̈, no weight (4.86, 4.90)
    col = {ji: c for c, ji in enumerate(i for i, j in enumerate(mech.joints) if j.drive is not None)}
    for ji, m_a in plan(mech, dynamics=True).drive_inertias.items():
        M[:, col[ji], col[ji]] += m_a
    extra = _drive_load_strut_mass(mech)
    if extra is not None:
        li, cog, mass = extra
        Jv = (link_twist_matrix(mech, q, li, cog) @ q_s)[:, :3]
        tau += np.einsum("nji,j->ni", Jv, -mass * g)
    return M, tau


def _drive_load_strut_mass(mech: Mechanism) -> tuple[int, Array, float] | None:
    """(output link, home CoG (3,), mass [kg]) of the strut share of the static drive loads (eq. 4.90 as the machines
    read it, :func:`pkmstiff.machine.roles.drive_load_data`): ``[elastic] drive_load_strut_mass`` × the strut
    components' masses at the combined CoG of the output link's body and tool body; None if there is none."""
    from pkmstiff.mechanisms.structure import _mass

    el = mech.elastic
    mass = el.drive_load_strut_mass * sum(_mass(el.link(i).component) for i in range(len(mech.links))
                                          if el.link(i).strut)
    if not mass > 0:
        return None
    li = mech.output.link if mech.output is not None else -1
    le = el.link(li)
    carried = [b for b in (le.body, le.tool) if b.mass > 0]
    if li < 0 or le.strut or not carried:
        raise InputError(mech.path or mech.name, "elastic.drive_load_strut_mass", "an output link with a body "
                         "(the strut share is added at its CoG)", mech.links[li] if li >= 0 else "no [output]")
    cog = sum(b.mass * b.cog for b in carried) / sum(b.mass for b in carried)
    return li, cog, mass


#: the rotary drives' limit of each linear-drive limit (components.limits.ROTARY_DRIVE_LIMITS)
_ROTARY_KEY = {"max_speed": "max_angular_speed", "max_force": "max_torque", "force_reserve": "torque_reserve",
               "coulomb_friction": "coulomb_torque"}


def _drive_limits(mech: Mechanism, key: str, default: float) -> Array:
    """The drive components' limit ``key`` (linear drives; a rotary drive's torque/angular-speed counterpart) per
    drive, SI (``default`` where not given)."""
    out = []
    for ji, jt in enumerate(mech.joints):
        if jt.drive is None:
            continue
        c = mech.elastic.joint(ji).drive
        k = _ROTARY_KEY[key] if jt.variable == "angle" else key
        out.append(float((getattr(c, "limits", None) or {}).get(k, default)))
    return np.array(out)


def mechanism_kinetostatics(mech: Mechanism, sol: Solution) -> MechanismKinetostatics:
    """Transmission quality, v_max, a_max (limiting drive) and static drive loads at the configurations of ``sol``
    (units of :class:`MechanismKinetostatics`); the mechanism needs elastic data (masses, drive limits)."""
    outputs = controlled_output_names(mech)
    n = len(mech.drives)
    N = sol.q.shape[0]
    rotary = np.array([u != "m" for u in mech.drive_units])
    notes: list[str] = []
    ok = np.asarray(sol.ok, bool).copy()
    q = np.where(ok[:, None, None], sol.q, np.nan)
    drv = np.where(ok[:, None], sol.drives, 0.0)
    jinv = np.full((N, n, len(outputs)), np.nan)
    M = np.full((N, n, n), np.nan)
    tau = np.full((N, n), np.nan)
    w = float(mech.length_scale if mech.elastic.transmission_weight is None else mech.elastic.transmission_weight)
    tq = np.full(N, np.nan)
    if len(outputs) != n:
        notes.append(f"{len(outputs)} controlled outputs ({', '.join(outputs)}) for {n} drives: no drive Jacobian "
                     "inverse, no kinetostatics")
        ok[:] = False
    if ok.any():
        J = output_jacobian(mech, q[ok], drv[ok])
        wx = np.array([1.0 if o in "xyz" else w for o in outputs])
        ws = np.where(rotary, w, 1.0)
        s = np.linalg.svd(wx[None, :, None] * J / ws[None, None, :], compute_uv=False)
        tq[ok] = np.sqrt(s[:, -1] / s[:, 0])  # the machines' default form (inverse_sqrt_kappa, eq. 4.75 note)
        good = s[:, -1] > 1e-12 * s[:, 0]
        with np.errstate(all="ignore"):
            inv = np.linalg.inv(np.where(good[:, None, None], J, np.eye(n)))
        jinv[ok] = np.where(good[:, None, None], inv, np.nan)
        qs = configuration_rates(mech, q[ok], drv[ok])
        M[ok], tau[ok] = mass_and_gravity(mech, q[ok], qs)
    coords = [o for o in outputs if o in "xyz"]

    def directions(names) -> tuple[Array, list[str]]:
        names = [d for d in names if d.lstrip("-") in coords]
        e6, labels = twist_directions(names) if names else (np.zeros((0, 6)), [])
        e = np.zeros((len(labels), len(outputs)))
        for r, o in enumerate(outputs):
            if o in "xyz":
                e[:, r] = e6[:, "xyz".index(o)]
        return e, labels

    ev, v_labels = directions(VELOCITY_DIRECTIONS)
    ea, a_labels = directions(ACCELERATION_DIRECTIONS)
    max_speed = _drive_limits(mech, "max_speed", np.nan)
    if np.isnan(max_speed).any():
        notes.append("maximum drive speed not given for every drive: v_max is NaN")
    vmax, vlim = max_velocity(jinv, ev, max_speed)
    max_force = _drive_limits(mech, "max_force", np.nan)
    if np.isnan(max_force).any():
        notes.append("maximum drive force not given for every drive: a_max is NaN")
    available = max_force - _drive_limits(mech, "force_reserve", 0.0)
    qdd = np.einsum("nij,kj->nki", jinv, ea)
    mu = np.einsum("nij,nkj->nki", M, qdd)
    amax, alim, ainf = acceleration_bounds(qdd, mu, tau, available, _drive_limits(mech, "coulomb_friction", 0.0))
    return MechanismKinetostatics(outputs, jinv, w, tq, v_labels, vmax, vlim, a_labels, amax, alim, ainf, tau, M,
                                  rotary, notes)
