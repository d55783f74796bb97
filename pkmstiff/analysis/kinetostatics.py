"""Kinetostatics (docs/theory/kinetostatics.md, Cobet 4.3): transmission quality, maximum tool velocity and acceleration,
static drive loads.

* Transmission quality ``U = σ_min(W J_C)/σ_max(W J_C)``, ``W = diag(1, 1, 1, w, w, w)`` (eq. 4.75, 4.77), w from
  the machine file (Hexaglide eq. 5.1, 6X eq. 4.78); 0 at singular poses.
* Maximum velocity (eq. 4.79) in a twist direction e: ``v_max = min_i q̇_max,i / |(J_C⁻¹ e)_i|`` (m/s; rad/s for
  rotations) and the limiting drive.
* Maximum acceleration from standstill (eq. 4.80–4.93, sign-aware form of docs/theory/kinetostatics.md):
  ``μ = M_q e``, ``M_q = M_A J_C⁻¹ + J_Cᵀ M_P`` (eq. 4.86), Coulomb friction ``c_i = C_i sign((J_C⁻¹ e)_i)``,
  gravity ``τ_g = J_Cᵀ g_P`` (eq. 4.90), available force ``T_i = τ_max − τ_min``:
  ``a_max = min_{μ_i ≠ 0} (T_i − sign(μ_i)(τ_g,i + c_i)) / |μ_i|``; a negative bound (or a drive with μ_i = 0
  that cannot hold ``|τ_g,i + c_i| ≤ T_i``) means the pose cannot accelerate in e: 0 and ``infeasible``.
* Static drive loads ``τ_g`` (eq. 4.90) via :func:`pkmstiff.admissibility.checks.static_drive_loads` (the same function
  as the B.13 admissibility check).

M_A = drive masses (drive + guide + drive-joint mass), M_P = platform (+ spindle) about O' (docs/theory/structure.md).  Extensions
of docs/theory/kinetostatics.md (Assumptions, off by default): half of each strut's mass to the drive and half to the platform
(``strut_mass_split``); drive weight along non-horizontal guides (``drive_gravity``, glide only).
Unreachable and singular poses give NaN with their reason code.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.admissibility.checks import Reason, static_drive_loads
from pkmstiff.admissibility.pipeline import PoseEvaluation
from pkmstiff.analysis._common import AXIS_NAMES, Array
from pkmstiff.errors import InputError
from pkmstiff.kinematics import as_poses, inverse_jacobian, inverse_kinematics, jacobian_and_condition
from pkmstiff.kinematics import transmission_quality as _tq
from pkmstiff.machine.model import Machine
from pkmstiff.machine.roles import DriveLoadData, machine_components
from pkmstiff.structure import PKSBody, dynamics_masses, mass_matrix_about_origin, vertical_direction

DEFAULT_VELOCITY_DIRECTIONS = ("x", "y", "z")
DEFAULT_ACCELERATION_DIRECTIONS = ("x", "-x", "y", "-y", "z", "-z")


@dataclass(frozen=True)
class KinetostaticsOptions:
    """``strut_mass_split`` / ``drive_gravity``: docs/theory/kinetostatics.md extensions (Assumptions, off by default);
    ``include_coulomb``: Coulomb friction opposes the starting motion (eq. 4.89); ``weight``: transmission-quality
    weight w [m/rad] (None = machine file)."""

    strut_mass_split: bool = False
    drive_gravity: bool = False
    include_coulomb: bool = True
    weight: float | None = None


@dataclass(frozen=True)
class DriveData:
    """Per-drive data (n,) in SI, NaN where the machine gives no value, and the moved body (PKS)."""

    mass: np.ndarray  # M_A diagonal, kg
    max_force: np.ndarray  # tau_q,max, N
    force_reserve: np.ndarray  # tau_q,min, N (0 where not given)
    coulomb: np.ndarray  # C_i, N (0 where not given)
    viscous: np.ndarray  # V_i, N s/m (0 where not given)
    max_speed: np.ndarray  # m/s
    body: PKSBody  # platform (+ spindle, + strut shares) carried by the drives

    @property
    def available_force(self) -> np.ndarray:
        """T = τ_max − τ_min (n,) in N (docs/theory/kinetostatics.md)."""
        return self.max_force - self.force_reserve


def drive_data(machine: Machine, options: KinetostaticsOptions | None = None) -> DriveData:
    """Masses (:func:`pkmstiff.structure.dynamics_masses`), force/speed limits and friction of the drives."""
    options = options or KinetostaticsOptions()
    mc = machine_components(machine)

    def lim(key: str, default: float) -> np.ndarray:
        return np.array([default if d is None else float(d.limits.get(key, default)) for d in mc.drive])

    m_a, body = dynamics_masses(machine, options.strut_mass_split, mc)
    return DriveData(m_a, lim("max_force", np.nan), lim("force_reserve", 0.0), lim("coulomb_friction", 0.0),
                     lim("viscous_friction", 0.0), lim("max_speed", np.nan), body)


def twist_directions(directions: Sequence[Any]) -> tuple[np.ndarray, list[str]]:
    """Unit twist directions (k, 6) and labels from names (``"x"``, ``"-z"``, ``"rx"``), vectors (3,)
    (translations) or 6-vectors (v, ω) (normalised)."""
    out, labels = [], []
    for d in directions:
        if isinstance(d, str):
            key = d.strip().lower()
            sign = -1.0 if key.startswith("-") else 1.0
            if key.lstrip("+-") not in AXIS_NAMES:
                raise InputError("kinetostatics", "direction", f"one of {sorted(AXIS_NAMES)} "
                                          "(optionally signed), a vector (3,) or a twist (6,)", d)
            axis, rot = AXIS_NAMES[key.lstrip("+-")]
            e = np.zeros(6)
            e[axis + 3 * rot] = sign
            labels.append(key if key.startswith("-") else key.lstrip("+"))
        else:
            v = np.asarray(d, dtype=float)
            if v.shape == (3,):
                v = np.concatenate([v, np.zeros(3)])
            if v.shape != (6,) or not np.all(np.isfinite(v)) or not np.linalg.norm(v) > 0:
                raise InputError("kinetostatics", "direction", "a non-zero vector (3,) or twist (6,)", d)
            e = v / np.linalg.norm(v)
            labels.append(np.array2string(e, precision=3, separator=","))
        out.append(e)
    return np.array(out).reshape(-1, 6), labels


def max_velocity(jinv: Array, directions: Array, max_speed: Array) -> tuple[Array, Array]:
    """``v_max(e) = min_i q̇_max,i / |(J_C⁻¹ e)_i|`` (N, k) and the limiting drive (N, k) (eq. 4.79).

    ``jinv`` (N, n, 6), ``directions`` (k, 6) unit twists, ``max_speed`` (n,) [m/s].  A direction that moves no
    drive gives ``inf``; NaN rows of ``jinv`` give NaN.
    """
    rate = np.abs(np.einsum("nij,kj->nki", jinv, directions))  # |q̇_i| per unit tool speed (N, k, n)
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = np.where(rate > 0, max_speed / rate, np.inf)
    bound = np.where(np.isnan(rate), np.nan, bound)
    limiting = np.argmin(np.where(np.isnan(bound), np.inf, bound), axis=-1)
    vmax = np.min(bound, axis=-1)
    limiting = np.where(np.isfinite(vmax), limiting, -1)
    return vmax, limiting


def max_acceleration(jinv: Array, jc: Array, directions: Array, m_a: Array, m_p: Array, tau_g: Array,
                     available: Array, coulomb: Array) -> tuple[Array, Array, Array]:
    """Maximum acceleration from standstill (docs/theory/kinetostatics.md, sign-aware eq. 4.88/4.92–4.93).

    ``jinv``, ``jc`` (N, n, 6)/(N, 6, n); ``directions`` (k, 6); ``m_a`` (n,) kg; ``m_p`` (N, 6, 6) about O';
    ``tau_g`` (N, n) N; ``available`` T (n,) N; ``coulomb`` C (n,) N.  Returns a_max (N, k) [m/s² or rad/s²],
    limiting drive (N, k) (−1 if none) and ``infeasible`` (N, k) (a_max reported as 0).
    """
    qdd = np.einsum("nij,kj->nki", jinv, directions)  # J_C⁻¹ e (N, k, n)
    mu = m_a * qdd + np.einsum("nji,njl,kl->nki", jc, m_p, directions)  # M_q e = M_A J⁻¹e + J_Cᵀ M_P e
    return acceleration_bounds(qdd, mu, tau_g, available, coulomb)


def acceleration_bounds(qdd: Array, mu: Array, tau_g: Array, available: Array, coulomb: Array
                        ) -> tuple[Array, Array, Array]:
    """a_max (N, k), limiting drive (N, k) and ``infeasible`` (N, k) from the drive accelerations per unit tool
    acceleration ``qdd`` = J⁻¹ e (N, k, n) and the drive forces per unit tool acceleration ``mu`` = M_q e (N, k, n)
    (the sign-aware bound of :func:`max_acceleration`)."""
    c = coulomb * np.sign(qdd)
    load = tau_g[:, None, :] + c  # gravity + friction to be overcome (N, k, n)
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = np.where(mu != 0, (available - np.sign(mu) * load) / np.abs(mu), np.inf)
    static_bad = (mu == 0) & (np.abs(load) > available)
    bound = np.where(np.isnan(mu) | np.isnan(load), np.nan, bound)
    pick = np.where(np.isnan(bound), np.inf, bound)
    limiting = np.argmin(pick, axis=-1) if pick.shape[-1] else np.zeros(pick.shape[:-1], int)
    amin = np.min(bound, axis=-1) if bound.shape[-1] else np.full(bound.shape[:-1], np.nan)
    infeasible = (amin < 0) | static_bad.any(axis=-1)
    amax = np.where(infeasible, 0.0, amin)
    limiting = np.where(np.isfinite(amin), limiting, -1)
    return amax, limiting, infeasible & np.isfinite(amin)


@dataclass
class Kinetostatics:
    """Kinetostatic results at N poses (SI); NaN where ``reasons`` != 0 (unreachable / singular).

    ``transmission_quality`` (N,) with weight ``weight`` [m/rad]; ``v_max`` (N, k_v) m/s (rad/s for rotations)
    with ``v_limiting`` drive indices (0-based, −1 none); ``a_max`` (N, k_a) m/s² (rad/s²), ``a_limiting``,
    ``a_infeasible``; ``drive_loads`` (N, n) static drive loads τ_g in N; ``available_force`` T (n,) N.
    """

    poses: Array
    reasons: Array
    weight: float
    transmission_quality: Array
    velocity_labels: list[str]
    velocity_directions: Array
    v_max: Array
    v_limiting: Array
    acceleration_labels: list[str]
    acceleration_directions: Array
    a_max: Array
    a_limiting: Array
    a_infeasible: Array
    drive_loads: Array
    available_force: Array
    notes: list[str]


def kinetostatics(machine: Machine, poses: ArrayLike | PoseEvaluation,
                  velocity_directions: Sequence[Any] = DEFAULT_VELOCITY_DIRECTIONS,
                  acceleration_directions: Sequence[Any] = DEFAULT_ACCELERATION_DIRECTIONS,
                  options: KinetostaticsOptions | None = None) -> Kinetostatics:
    """Transmission quality, v_max, a_max (with limiting drive) and static drive loads at poses (N, 6) or at the
    poses of a :class:`~pkmstiff.admissibility.pipeline.PoseEvaluation` (its inverse kinematics, J_C^-1, J_C and
    κ are reused)."""
    options = options or KinetostaticsOptions()
    with np.errstate(invalid="ignore", divide="ignore"):
        if isinstance(poses, PoseEvaluation):
            x, ik, jinv, jc, kappa = poses.poses, poses.ik, poses.jinv, poses.jc, poses.kappa
        else:
            x = as_poses(poses)
            ik = inverse_kinematics(machine, x)
            jinv = inverse_jacobian(machine, ik)
            jc, kappa = jacobian_and_condition(jinv)
        w = machine.transmission_weight if options.weight is None else float(options.weight)
        tq = _tq(machine, jinv, w)
    reasons = np.zeros(len(x), np.uint32)
    reach = ik.all_reachable
    reasons[~reach] = int(Reason.UNREACHABLE)
    singular = reach & ~(kappa <= machine.limits.singularity_threshold)
    reasons[singular] |= np.uint32(int(Reason.SINGULAR))
    ok = reasons == 0
    tq = np.where(reach, tq, np.nan)

    data = drive_data(machine, options)
    notes = []
    ev, v_labels = twist_directions(velocity_directions)
    ea, a_labels = twist_directions(acceleration_directions)
    jinv_ok = np.where(ok[:, None, None], jinv, np.nan)
    jc_ok = np.where(ok[:, None, None], jc, np.nan)
    if np.any(np.isnan(data.max_speed)):
        notes.append("maximum drive speed not given for every drive: v_max is NaN")
    vmax, vlim = max_velocity(jinv_ok, ev, data.max_speed)

    R = np.asarray(ik.R)
    up = vertical_direction(machine)
    g = float(np.linalg.norm(machine.gravity))
    if data.body.mass > 0:
        load_data = DriveLoadData(data.body.mass, data.body.cog, data.max_force, data.force_reserve, data.coulomb)
        if not options.strut_mass_split and machine.limits.drive_load_strut_mass > 0:
            # the admissibility check's moved mass (B.13, eq. 4.90: platform + the machine's strut share)
            from pkmstiff.machine.roles import drive_load_data

            dl = drive_load_data(machine)
            if dl is not None:
                load_data = DriveLoadData(dl.moved_mass, dl.cog_offset, data.max_force, data.force_reserve,
                                          data.coulomb)
        with np.errstate(invalid="ignore"):
            tau_g = static_drive_loads(machine, jc_ok, R, load_data)
    else:
        notes.append("no platform mass given: static drive loads are zero, M_P = 0")
        tau_g = np.where(ok[:, None], 0.0, np.nan) * np.ones((1, machine.n_chains))
    if options.drive_gravity and machine.kind == "glide":
        tau_g = tau_g + data.mass * g * (machine.chains.guide_direction @ up)
    if np.any(np.isnan(data.max_force)):
        notes.append("maximum drive force not given for every drive: a_max is NaN")
    coulomb = data.coulomb if options.include_coulomb else np.zeros_like(data.coulomb)
    m_p = mass_matrix_about_origin(data.body, R)
    amax, alim, ainf = max_acceleration(jinv_ok, jc_ok, ea, data.mass, m_p, tau_g, data.available_force, coulomb)
    return Kinetostatics(x, reasons, w, tq, v_labels, ev, vmax, vlim, a_labels, ea, amax, alim, ainf, tau_g,
                         data.available_force, notes)
