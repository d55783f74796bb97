"""Planar two-DOF examples: biglide and bipod (docs/theory/kinematics.md; docs/user-guide/machines.md; Cobet App. C.5).

A :class:`PlanarMachine` is loaded from a small TOML file (bundled: ``"biglide"``, ``"bipod"`` in
``pkmstiff/machine/bundled/planar/``; schema below).  Coordinates (x, y) with y vertical; SI units inside.

Models:

* inverse kinematics: biglide ``q_i = s_i + λ_i r_i`` on the line–sphere (here line–circle) intersection with the
  strut length (smaller root by default, docs/theory/kinematics.md), bipod ``l_i = |p − q_i|``;
* inverse Jacobian (eq. A.24/A.25 in the general form of §1.4): glide row ``d_iᵀ/(d_i·r_i)``, pod ``d̂_iᵀ``;
* structure model on the generic SDE layer, embedded in 3-D (z out of plane, held by exact rigid bindings):
  platform point mass; biglide drives = point masses with ``K_A = R diag(k_drive, k_guide) Rᵀ`` (eq. 4.33) and
  rigid struts (exact rigid bindings, not the dissertation's simplified eq. 4.53–4.56, see docs/theory/structure.md); bipod:
  SDE ``k n nᵀ`` from the platform to the fixed drive points (eq. 4.42), ``K = Σ k n nᵀ`` (eq. 4.57);
* transmission quality ``1/κ(J⁻¹)`` (no weighting), ``v_max`` (eq. 4.79), ``a_max`` with
  ``M_q = M_A J⁻¹ + Jᵀ M_P`` (eq. 4.91–4.94; bipod M_A = 0) in the sign-aware form of §6.3.

TOML schema (``format_version = 1``)::

    [machine]  name, title, type = "glide" | "pod", source, gravity = [gx, gy]
    [platform] mass
    [chain_defaults] any chain key
    [[chains]] (two)  glide: guide_start [x, y], guide_direction [x, y], guide_length, strut_length, root
                      pod:   drive_point [x, y], length_min, length_max
                      both:  drive_stiffness (glide: along the guide; pod: telescopic drive in series with the
                             strut), guide_stiffness (glide, transverse), strut_stiffness, drive_mass, max_force,
                             force_reserve, coulomb_friction, viscous_friction, max_speed
    [assumptions] key = "one-line reason"

Stiffness values accept ``"rigid"``; a missing stiffness is rigid (pod: ``drive_stiffness``; glide:
``strut_stiffness``) or an error (glide ``drive_stiffness``/``guide_stiffness``, pod ``strut_stiffness``:
at least one term of a chain must be elastic).
"""

from __future__ import annotations

import importlib.resources
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

import pkmstiff.multibody as sde
from pkmstiff.admissibility.checks import Reason
from pkmstiff.errors import InputError
from pkmstiff.io import check_keys, read_toml, require
from pkmstiff.units import parse_quantity

Array = NDArray[np.float64]

SINGULARITY_THRESHOLD = 1e8  # κ(J⁻¹) above which a pose is singular (docs/theory/kinematics.md)




@dataclass(frozen=True)
class PlanarMachine:
    """A biglide or bipod (two chains) in SI units; ``inf`` stiffness = rigid."""

    name: str
    title: str
    kind: str  # "glide" | "pod"
    gravity: np.ndarray  # (2,) m/s²
    platform_mass: float  # kg
    guide_start: np.ndarray  # (2, 2) glide
    guide_direction: np.ndarray  # (2, 2) glide, unit
    guide_length: np.ndarray  # (2,) glide
    strut_length: np.ndarray  # (2,) glide
    larger_root: np.ndarray  # (2,) bool, glide
    drive_point: np.ndarray  # (2, 2) pod
    length_min: np.ndarray  # (2,) pod
    length_max: np.ndarray  # (2,) pod
    drive_stiffness: np.ndarray  # (2,) N/m
    guide_stiffness: np.ndarray  # (2,) N/m
    strut_stiffness: np.ndarray  # (2,) N/m
    drive_mass: np.ndarray  # (2,) kg
    max_force: np.ndarray  # (2,) N
    force_reserve: np.ndarray  # (2,) N
    coulomb_friction: np.ndarray  # (2,) N
    viscous_friction: np.ndarray  # (2,) N s/m
    max_speed: np.ndarray  # (2,) m/s
    source: str = ""
    path: str = ""
    assumptions: dict[str, str] = field(default_factory=dict)

    @property
    def chain_stiffness(self) -> np.ndarray:
        """k_i (2,) along the strut: series of the strut and (pod) the telescopic drive [N/m]; inf = rigid."""
        terms = [self.strut_stiffness] + ([self.drive_stiffness] if self.kind == "pod" else [])
        with np.errstate(divide="ignore"):
            return 1.0 / sum(1.0 / k for k in terms)


# ------------------------------------------------------------------------------------------------ file loading

_TOP = {"format_version", "machine", "platform", "chain_defaults", "chains", "assumptions"}
_MACHINE = {"name", "title", "type", "source", "gravity"}
_COMMON = {"drive_stiffness", "guide_stiffness", "strut_stiffness", "drive_mass", "max_force", "force_reserve",
           "coulomb_friction", "viscous_friction", "max_speed"}
_GLIDE = {"guide_start", "guide_direction", "guide_length", "strut_length", "root"}
_POD = {"drive_point", "length_min", "length_max"}


def planar_machine_dir() -> Path:
    return Path(str(importlib.resources.files("pkmstiff") / "machine" / "bundled" / "planar"))


def bundled_planar() -> list[str]:
    """Names of the bundled planar examples."""
    return sorted(p.stem for p in planar_machine_dir().glob("*.toml"))


def _stiffness(value: Any, src: str, key: str) -> float:
    if isinstance(value, str) and value.strip().lower() == "rigid":
        return np.inf
    return float(parse_quantity(value, "N/m", source=src, key=key, positive=True))


def load_planar(name_or_path: str | Path) -> PlanarMachine:
    """Load and validate a planar machine by bundled name (``"biglide"``, ``"bipod"``) or path."""
    p = Path(name_or_path)
    if p.suffix != ".toml" and not p.exists():
        p = planar_machine_dir() / f"{name_or_path}.toml"
        if not p.is_file():
            raise InputError(str(name_or_path), "(file)", f"a bundled planar machine {bundled_planar()} or "
                                  "a path to a .toml file", "no such machine")
    src = str(p)
    raw = read_toml(p, "planar machine file")
    try:
        return _build(raw, src)
    except InputError as exc:  # from the unit parser: name the planar machine file
        raise exc.in_file(src) from None


def _build(raw: dict, src: str) -> PlanarMachine:
    check_keys(raw, _TOP, src, "")
    if raw.get("format_version", 1) != 1:
        raise InputError(src, "format_version", "1", raw.get("format_version"))
    mt = check_keys(require(raw, "machine", src, "", "a [machine] table"), _MACHINE, src,
                    "machine.")
    kind = require(mt, "type", src, "machine.", "'glide' or 'pod'")
    if kind not in ("glide", "pod"):
        raise InputError(src, "machine.type", "'glide' or 'pod'", kind)
    name = str(require(mt, "name", src, "machine.", "the machine's short name"))
    gravity = parse_quantity(mt.get("gravity", [0.0, -9.81]), "m/s^2", source=src, key="machine.gravity",
                             shape=(2,))
    plat = check_keys(require(raw, "platform", src, "", "a [platform] table with the mass"),
                      {"mass"}, src, "platform.")
    mass = require(plat, "mass", src, "platform.", "the platform mass")
    m_p = float(parse_quantity(mass, "kg", source=src,
                               key="platform.mass", positive=True))
    allowed = _COMMON | (_GLIDE if kind == "glide" else _POD)
    defaults = check_keys(raw.get("chain_defaults", {}), allowed, src, "chain_defaults.")
    chains = require(raw, "chains", src, "", "two [[chains]] tables")
    if not isinstance(chains, list) or len(chains) != 2:
        raise InputError(src, "chains", "exactly two [[chains]] tables", chains)
    cols: dict[str, list] = {}
    for i, ch in enumerate(chains):
        pre = f"chains[{i + 1}]."
        t = {**defaults, **check_keys(ch, allowed, src, pre)}

        def q(key: str, unit: str, what: str, *, shape: Any = None, positive: bool = False, default: Any = None,
              min_value: float | None = None) -> Any:
            value = t.get(key, default)
            if value is None:
                raise InputError(src, pre + key, what + " (the key is required)", "missing key")
            return parse_quantity(value, unit, source=src, key=pre + key, shape=shape, positive=positive,
                                  min_value=min_value)

        def k(key: str, required: bool) -> float:
            if key not in t:
                if required:
                    raise InputError(src, pre + key, "a stiffness in N/m (or 'rigid')", "missing key")
                return np.inf
            return _stiffness(t[key], src, pre + key)

        row = {}
        if kind == "glide":
            row["guide_start"] = q("guide_start", "m", "the guide start point [x, y]", shape=(2,))
            d = q("guide_direction", "dimensionless", "the guide direction [x, y]", shape=(2,))
            if not np.linalg.norm(d) > 1e-9:
                raise InputError(src, pre + "guide_direction", "a non-zero direction", list(d))
            row["guide_direction"] = d / np.linalg.norm(d)
            row["guide_length"] = q("guide_length", "m", "the usable guide length", positive=True)
            row["strut_length"] = q("strut_length", "m", "the strut length", positive=True)
            root = t.get("root", "smaller")
            if root not in ("smaller", "larger"):
                raise InputError(src, pre + "root", "'smaller' or 'larger'", root)
            row["larger_root"] = root == "larger"
            row["drive_stiffness"] = k("drive_stiffness", True)
            row["guide_stiffness"] = k("guide_stiffness", True)
            row["strut_stiffness"] = k("strut_stiffness", False)
            row["drive_mass"] = q("drive_mass", "kg", "the drive mass", min_value=0.0)
        else:
            row["drive_point"] = q("drive_point", "m", "the fixed drive point [x, y]", shape=(2,))
            row["length_min"] = q("length_min", "m", "the minimum strut length", positive=True)
            row["length_max"] = q("length_max", "m", "the maximum strut length", positive=True)
            if row["length_max"] <= row["length_min"]:
                raise InputError(src, pre + "length_max", f"a length > length_min = {row['length_min']} m",
                                      t["length_max"])
            row["strut_stiffness"] = k("strut_stiffness", True)
            row["drive_stiffness"] = k("drive_stiffness", False)
            row["guide_stiffness"] = np.inf
            row["drive_mass"] = q("drive_mass", "kg", "the drive mass", default=0.0, min_value=0.0)
        for key, unit, default in (("max_force", "N", np.nan), ("force_reserve", "N", 0.0),
                                   ("coulomb_friction", "N", 0.0), ("viscous_friction", "N*s/m", 0.0),
                                   ("max_speed", "m/s", np.nan)):
            row[key] = default if key not in t else q(key, unit, key, min_value=0.0)
        for key, value in row.items():
            cols.setdefault(key, []).append(value)
    if kind == "pod" and np.any(np.isinf(np.array(cols["strut_stiffness"])) &
                                np.isinf(np.array(cols["drive_stiffness"]))):
        raise InputError(src, "chains[*].strut_stiffness", "an elastic strut or drive per bipod chain",
                              "both rigid")
    assumptions = raw.get("assumptions", {})
    if not isinstance(assumptions, dict) or not all(isinstance(v, str) for v in assumptions.values()):
        raise InputError(src, "assumptions", "a table key = one-line reason", assumptions)
    nan2, nan22 = np.full(2, np.nan), np.full((2, 2), np.nan)

    def col(key: str, fallback: np.ndarray) -> np.ndarray:
        return np.array(cols[key], dtype=float) if key in cols else fallback.copy()

    return PlanarMachine(
        name=name, title=str(mt.get("title", name)), kind=kind, gravity=np.asarray(gravity, float), platform_mass=m_p,
        guide_start=col("guide_start", nan22), guide_direction=col("guide_direction", nan22),
        guide_length=col("guide_length", nan2), strut_length=col("strut_length", nan2),
        larger_root=np.array(cols.get("larger_root", [False, False]), bool),
        drive_point=col("drive_point", nan22), length_min=col("length_min", nan2),
        length_max=col("length_max", nan2), drive_stiffness=col("drive_stiffness", nan2),
        guide_stiffness=col("guide_stiffness", nan2), strut_stiffness=col("strut_stiffness", nan2),
        drive_mass=col("drive_mass", nan2), max_force=col("max_force", nan2),
        force_reserve=col("force_reserve", nan2), coulomb_friction=col("coulomb_friction", nan2),
        viscous_friction=col("viscous_friction", nan2), max_speed=col("max_speed", nan2),
        source=str(mt.get("source", "")), path=src, assumptions=dict(assumptions))


# ------------------------------------------------------------------------------------------------- kinematics


def _positions(positions: ArrayLike) -> Array:
    x = np.asarray(positions, dtype=float)
    if x.ndim == 1:
        x = x[None]
    if x.ndim != 2 or x.shape[1] != 2 or not np.all(np.isfinite(x)):
        raise InputError("planar", "positions", "finite platform positions of shape (2,) or (N, 2) [x, y in m]",
                         f"shape {np.shape(positions)}")
    return x


@dataclass(frozen=True)
class PlanarIK:
    """Inverse kinematics of N platform positions: ``p`` (N, 2), ``q`` (N, 2, 2) drive points, ``d`` (N, 2, 2)
    strut vectors p − q_i, ``length`` (N, 2), ``drive`` (N, 2) drive coordinates (glide λ_i, pod l_i) in m,
    ``reachable`` (N, 2), ``in_range`` (N, 2) (B.1/B.2)."""

    p: Array
    q: Array
    d: Array
    length: Array
    drive: Array
    reachable: Array
    in_range: Array


def planar_inverse_kinematics(pm: PlanarMachine, positions: ArrayLike) -> PlanarIK:
    """Drive coordinates and joint points for platform positions (N, 2) (docs/theory/kinematics.md in 2-D, §1.7)."""
    p = _positions(positions)
    if pm.kind == "glide":
        c = pm.guide_start[None] - p[:, None, :]  # (N, 2, 2)
        rc = np.einsum("ij,nij->ni", pm.guide_direction, c)
        disc = rc ** 2 - (np.einsum("nij,nij->ni", c, c) - pm.strut_length ** 2)
        reach = disc >= 0
        with np.errstate(invalid="ignore"):
            lam = -rc + np.where(pm.larger_root, 1.0, -1.0) * np.sqrt(disc)
        q = pm.guide_start[None] + lam[..., None] * pm.guide_direction[None]
        in_range = reach & (lam >= 0) & (lam <= pm.guide_length)
        d = p[:, None, :] - q
        length = np.where(reach, pm.strut_length, np.nan)
        drive = lam
    else:
        q = np.broadcast_to(pm.drive_point, (p.shape[0], 2, 2)).copy()
        d = p[:, None, :] - q
        length = np.linalg.norm(d, axis=-1)
        drive = length
        reach = np.ones_like(length, bool)
        in_range = (length >= pm.length_min) & (length <= pm.length_max)
    return PlanarIK(p, q, d, length, drive, reach, in_range)


def planar_inverse_jacobian(pm: PlanarMachine, ik: PlanarIK) -> Array:
    """J⁻¹ (N, 2, 2), q̇ = J⁻¹ ṗ: glide row ``d_iᵀ/(d_i·r_i)``, pod ``d̂_iᵀ`` (eq. A.24, A.25, docs/theory/kinematics.md/§1.7)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        if pm.kind == "glide":
            return ik.d / np.einsum("nij,ij->ni", ik.d, pm.guide_direction)[..., None]
        return ik.d / ik.length[..., None]


def _condition(a: Array) -> Array:
    out = np.full(a.shape[0], np.inf)
    good = np.all(np.isfinite(a), axis=(1, 2))
    if good.any():
        s = np.linalg.svd(a[good], compute_uv=False)
        with np.errstate(divide="ignore"):
            out[good] = s[:, 0] / s[:, -1]
    return out


def planar_reasons(pm: PlanarMachine, ik: PlanarIK, jinv: Array) -> tuple[Array, Array]:
    """Reason bits (N,) (UNREACHABLE, DRIVE_RANGE, SINGULAR) and κ(J⁻¹) (N,)."""
    kappa = _condition(jinv)
    reasons = np.zeros(ik.p.shape[0], np.uint32)
    reach = ik.reachable.all(axis=1)
    reasons[~reach] = int(Reason.UNREACHABLE)
    reasons[reach & ~ik.in_range.all(axis=1)] |= np.uint32(int(Reason.DRIVE_RANGE))
    reasons[reach & ~(kappa <= SINGULARITY_THRESHOLD)] |= np.uint32(int(Reason.SINGULAR))
    return reasons, kappa


# ------------------------------------------------------------------------------------------------- structure

_EZ = np.array([0.0, 0.0, 1.0])


def _xyz(v: Array) -> Array:
    """(…, 2) → (…, 3) with z = 0."""
    return np.concatenate([v, np.zeros(v.shape[:-1] + (1,))], axis=-1)


@dataclass
class PlanarStructure:
    """SDE model of the modelled positions (``index``; unreachable or singular ones are left out)."""

    machine: PlanarMachine
    positions: Array
    reasons: Array
    index: Array
    model: sde.SDEModel | None

    def scatter(self, values: ArrayLike) -> np.ndarray:
        v = np.asarray(values)
        out = np.full((self.positions.shape[0],) + v.shape[1:], np.nan, dtype=np.result_type(v.dtype, float))
        out[self.index] = v
        return out


def planar_structure(pm: PlanarMachine, positions: ArrayLike) -> PlanarStructure:
    """Structure model (docs/theory/structure.md) embedded in 3-D; the out-of-plane DOFs are removed by rigid bindings."""
    ik = planar_inverse_kinematics(pm, positions)
    jinv = planar_inverse_jacobian(pm, ik)
    reasons, _ = planar_reasons(pm, ik, jinv)
    idx = np.flatnonzero((reasons & int(Reason.UNREACHABLE | Reason.SINGULAR)) == 0)
    if idx.size == 0:
        return PlanarStructure(pm, ik.p, reasons, idx, None)
    p3, q3 = _xyz(ik.p[idx]), _xyz(ik.q[idx])
    n3 = _xyz(ik.d[idx] / ik.length[idx][..., None])
    m = sde.SDEModel()
    m.add_point_mass("platform", pm.platform_mass, p3)
    m.add_rigid_binding("platform_z", "platform", sde.FRAME, p3, kind="axial", axis=_EZ)
    k = pm.chain_stiffness
    drives = []
    if pm.kind == "glide":
        for i in range(2):
            name = f"drive{i + 1}"
            drives.append(name)
            m.add_point_mass(name, pm.drive_mass[i], q3[:, i])
            m.add_rigid_binding(f"{name}_z", name, sde.FRAME, q3[:, i], kind="axial", axis=_EZ)
            r = _xyz(pm.guide_direction[i])
            t = np.cross(_EZ, r)  # in-plane transverse direction
            for axis, kk, label in ((r, pm.drive_stiffness[i], "drive"), (t, pm.guide_stiffness[i], "guide")):
                if np.isinf(kk):
                    m.add_rigid_binding(f"W{i + 1}_{label}", name, sde.FRAME, q3[:, i], kind="axial", axis=axis)
                else:
                    m.add_sde(f"W{i + 1}_{label}", name, sde.FRAME, q3[:, i], k=kk, axis=axis, group=label)
    for i in range(2):
        side = drives[i] if drives else sde.FRAME
        if np.isinf(k[i]):
            m.add_rigid_binding(f"V{i + 1}", side, "platform", p3, kind="axial", axis=n3[:, i])
        else:
            m.add_sde(f"V{i + 1}", side, "platform", p3, k=k[i], axis=n3[:, i], group="strut")
    return PlanarStructure(pm, ik.p, reasons, idx, m)


def planar_compliance(ps: PlanarStructure) -> Array:
    """In-plane compliance of the platform point (N, 2, 2) in m/N."""
    if ps.model is None:
        return ps.scatter(np.zeros((0, 2, 2)))
    return ps.scatter(sde.point_compliance(ps.model, "platform")[:, :2, :2])


def planar_stiffness(ps: PlanarStructure) -> Array:
    """In-plane stiffness of the platform point (N, 2, 2) in N/m (inverse of :func:`planar_compliance`)."""
    c = planar_compliance(ps)
    out = np.full_like(c, np.nan)
    good = np.all(np.isfinite(c), axis=(1, 2))
    out[good] = np.linalg.inv(c[good])
    return out


def planar_modes(ps: PlanarStructure, n_modes: int | None = None) -> sde.ModalResult:
    """Natural frequencies (N, k) in Hz and mass-normalised shapes (N, k, n) (biglide 4, bipod 2 modes)."""
    if ps.model is None:
        k = n_modes or 1
        nan = ps.scatter(np.zeros((0, k)))
        return sde.ModalResult(nan, nan.copy(), None)
    n_dyn = ps.model.n_dof - ps.model.n_constraints
    res = sde.modes(ps.model, n_modes or n_dyn, shapes=True)
    return sde.ModalResult(ps.scatter(res.eigenvalues), ps.scatter(res.frequencies_hz), ps.scatter(res.shapes))


# --------------------------------------------------------------------------------------------- kinetostatics


@dataclass
class PlanarKinetostatics:
    """``transmission_quality`` (N,) = 1/κ(J⁻¹); ``v_max`` (N, k) m/s; ``a_max`` (N, k) m/s² with limiting drive
    (−1 none) and ``a_infeasible``; ``drive_loads`` (N, 2) static drive loads in N; NaN where unreachable/singular."""

    reasons: Array
    transmission_quality: Array
    directions: Array
    v_max: Array
    v_limiting: Array
    a_max: Array
    a_limiting: Array
    a_infeasible: Array
    drive_loads: Array


def planar_kinetostatics(pm: PlanarMachine, positions: ArrayLike, directions: ArrayLike = ((1, 0), (0, 1)),
                         include_gravity: bool = True, include_coulomb: bool = True) -> PlanarKinetostatics:
    """Transmission quality, v_max, a_max (eq. 4.91–4.94, sign-aware §6.3) and static drive loads (N, 2)."""
    from pkmstiff.analysis.kinetostatics import max_acceleration, max_velocity

    ik = planar_inverse_kinematics(pm, positions)
    jinv = planar_inverse_jacobian(pm, ik)
    reasons, kappa = planar_reasons(pm, ik, jinv)
    bad = (reasons & int(Reason.UNREACHABLE | Reason.SINGULAR)) != 0
    jinv = np.where(bad[:, None, None], np.nan, jinv)
    jc = np.full_like(jinv, np.nan)
    jc[~bad] = np.linalg.inv(jinv[~bad])
    e = np.atleast_2d(np.asarray(directions, dtype=float))
    e = e / np.linalg.norm(e, axis=1, keepdims=True)
    vmax, vlim = max_velocity(jinv, e, pm.max_speed)
    m_a = pm.drive_mass if pm.kind == "glide" else np.zeros(2)  # bipod: drives fixed, M_A = 0 (eq. 4.94)
    m_p = np.broadcast_to(pm.platform_mass * np.eye(2), jinv.shape)
    g = pm.gravity if include_gravity else np.zeros(2)
    tau_g = np.einsum("nji,j->ni", jc, -pm.platform_mass * g)  # J^T g_P, g_P = holding force (eq. 4.90)
    coulomb = pm.coulomb_friction if include_coulomb else np.zeros(2)
    amax, alim, ainf = max_acceleration(jinv, jc, e, m_a, m_p, tau_g, pm.max_force - pm.force_reserve, coulomb)
    tq = np.where(ik.reachable.all(axis=1), 1.0 / kappa, np.nan)
    return PlanarKinetostatics(reasons, tq, e, vmax, vlim, amax, alim, ainf, tau_g)


__all__ = [
    "PlanarMachine", "PlanarIK", "PlanarStructure", "PlanarKinetostatics", "load_planar",
    "bundled_planar", "planar_inverse_kinematics", "planar_inverse_jacobian", "planar_reasons", "planar_structure",
    "planar_compliance", "planar_stiffness", "planar_modes", "planar_kinetostatics",
]
