"""Rigid bodies (mass, inertia, centre of gravity) and 6×6 body stiffness (docs/theory/components.md).

Mass matrix of a body about its CoG in MKS axes: M = diag(m I₃, R I'_cg Rᵀ) (I'_cg in body axes).
Referred to another point O with ρ = CoG − O: M_O = N(ρ)ᵀ M_cg N(ρ) (parallel-axis theorem) with the
reference matrix N(Δ) = [[I₃, −[Δ]×], [0, I₃]] of Cobet eq. 4.45. DOF order (u_x, u_y, u_z, θ_x, θ_y, θ_z).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from components.params import ModelSpec, Param
from components.protocol import Component, ComponentState, _full
from pkmstiff.errors import ArgumentError, InputError
from pkmstiff.units import parse_quantity, si

if TYPE_CHECKING:
    from components.reader import Params

_SYM_TOL = 1e-9  # relative asymmetry tolerated in input matrices (round-off of printed/converted data)


def skew(v: Any) -> np.ndarray:
    """[v]× (..., 3, 3) with [v]× u = v × u."""
    v = np.asarray(v, dtype=float)
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def reference_matrix(delta: Any) -> np.ndarray:
    """N(Δ) (..., 6, 6) of Cobet eq. 4.45: maps body twist/displacement at the reference to the point at offset Δ."""
    delta = np.asarray(delta, dtype=float)
    N = np.broadcast_to(np.eye(6), delta.shape[:-1] + (6, 6)).copy()
    N[..., :3, 3:] = -skew(delta)
    return N


def shift_mass_matrix(M_cg: Any, rho: Any) -> np.ndarray:
    """M_O = N(ρ)ᵀ M_cg N(ρ) (..., 6, 6), ρ = CoG − O in MKS components (docs/theory/structure.md)."""
    N = reference_matrix(rho)
    return np.swapaxes(N, -1, -2) @ np.asarray(M_cg, dtype=float) @ N


def _check_symmetric(K: np.ndarray, what: str) -> None:
    scale = max(float(np.max(np.abs(K))), np.finfo(float).tiny)
    if np.max(np.abs(K - K.T)) > _SYM_TOL * scale:
        raise ArgumentError(f"{what}: the matrix must be symmetric, found max |K - K^T| = "
                                 f"{np.max(np.abs(K - K.T)):.3g} (max |K| = {scale:.3g})")


def _check_positive_definite(K: np.ndarray, what: str, semi: bool = False) -> None:
    eig = np.linalg.eigvalsh(0.5 * (K + K.T))
    bad = eig.min() < 0 if semi else eig.min() <= 0
    if bad:
        kind = "positive semi-definite" if semi else "positive definite"
        raise ArgumentError(f"{what}: the matrix must be {kind}, found smallest eigenvalue {eig.min():.6g}")


@dataclass(frozen=True, kw_only=True, eq=False)
class RigidBody(Component):
    """Rigid body: ``mass`` [kg], ``inertia`` I'_cg (3, 3) about the CoG in body axes [kg·m²], ``cog`` (3,)
    position of the CoG relative to the body's reference point in body axes [m].

    A rigid body has no compliance: :meth:`stiffness` returns ``np.inf`` per pose (rigid, usable in ``series``).
    """

    kind: ClassVar[str] = "body"
    inertia: np.ndarray = None  # type: ignore[assignment]
    cog: np.ndarray = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        inertia = np.zeros((3, 3)) if self.inertia is None else np.asarray(self.inertia, dtype=float)
        if inertia.shape == (3,):
            inertia = np.diag(inertia)
        cog = np.zeros(3) if self.cog is None else np.asarray(self.cog, dtype=float)
        if inertia.shape != (3, 3) or cog.shape != (3,):
            raise ArgumentError(f"body '{self.name}': inertia must be (3, 3) or (3,), cog (3,); found "
                                     f"{inertia.shape}, {cog.shape}")
        if not self.mass >= 0:
            raise ArgumentError(f"body '{self.name}': mass must be >= 0, found {self.mass!r}")
        _check_symmetric(inertia, f"body '{self.name}' inertia")
        _check_positive_definite(inertia, f"body '{self.name}' inertia", semi=True)
        object.__setattr__(self, "inertia", 0.5 * (inertia + inertia.T))
        object.__setattr__(self, "cog", cog)

    def stiffness(self, state: ComponentState) -> np.ndarray:
        return _full(state, np.inf)

    def mass_matrix(self, R: Any = None) -> np.ndarray:
        """M_cg = diag(m I₃, R I'_cg Rᵀ) (6, 6) or (N, 6, 6) about the CoG in MKS axes; ``R`` body → MKS."""
        Rm = np.eye(3) if R is None else np.asarray(R, dtype=float)
        M = np.zeros(Rm.shape[:-2] + (6, 6))
        M[..., :3, :3] = self.mass * np.eye(3)
        M[..., 3:, 3:] = Rm @ self.inertia @ np.swapaxes(Rm, -1, -2)
        return M

    def mass_matrix_about(self, point: Any, origin: Any = (0.0, 0.0, 0.0), R: Any = None) -> np.ndarray:
        """Mass matrix about ``point`` (MKS) for a body whose reference point is at ``origin`` (MKS), orientation R.

        CoG in the MKS = origin + R cog; ρ = CoG − point (parallel-axis theorem, docs/theory/structure.md).
        """
        Rm = np.eye(3) if R is None else np.asarray(R, dtype=float)
        cog_mks = np.asarray(origin, dtype=float) + (Rm @ self.cog)
        return shift_mass_matrix(self.mass_matrix(Rm), cog_mks - np.asarray(point, dtype=float))


@dataclass(frozen=True, kw_only=True, eq=False)
class BodyStiffness(Component):
    """Constant 6×6 body stiffness (e.g. the platform stiffness K_P used as K_U, docs/user-guide/machines.md).

    ``matrix`` (6, 6) in SI (blocks N/m, N/rad, N·m/rad), symmetric positive definite, in the axes it was
    determined in (platform axes: use :meth:`in_mks`).
    """

    kind: ClassVar[str] = "matrix6"
    what: ClassVar[str] = "body stiffness"
    semi_definite: ClassVar[bool] = False
    matrix: np.ndarray

    def __post_init__(self) -> None:
        K = np.asarray(self.matrix, dtype=float)
        if K.shape != (6, 6) or not np.all(np.isfinite(K)):
            raise ArgumentError(f"{self.what} '{self.name}': expected a finite (6, 6) matrix, found shape "
                                     f"{K.shape}")
        _check_symmetric(K, f"{self.what} '{self.name}'")
        _check_positive_definite(K, f"{self.what} '{self.name}'", semi=self.semi_definite)
        object.__setattr__(self, "matrix", 0.5 * (K + K.T))

    @classmethod
    def from_diagonal(cls, translational: Any, rotational: Any, **kwargs: Any) -> "BodyStiffness":
        """diag(k_x, k_y, k_z [N/m]; k_a, k_b, k_c [N·m/rad])."""
        return cls(matrix=np.diag(np.concatenate([np.asarray(translational, float), np.asarray(rotational, float)])),
                   **kwargs)

    @classmethod
    def from_units(cls, values: Any, *, translational_unit: str = "N/um", rotational_unit: str = "N*m/urad",
                   coupling_unit: str = "N/urad", **kwargs: Any) -> "BodyStiffness":
        """From 6 diagonal values or a 6×6 matrix given in the dissertation's units.

        Default rotational unit N·m/µrad: the interpretation of the unprinted Hexaglide K_P units
        (docs/user-guide/machines.md note 3) — configurable.
        """
        v = np.asarray(values, dtype=float)
        K = np.diag(v) if v.shape == (6,) else v.copy()
        if K.shape != (6, 6):
            raise ArgumentError(f"body stiffness: expected 6 diagonal values or a (6, 6) matrix, found shape "
                                     f"{v.shape}")
        K[:3, :3] = si(K[:3, :3], translational_unit)
        K[3:, 3:] = si(K[3:, 3:], rotational_unit)
        K[:3, 3:] = si(K[:3, 3:], coupling_unit)
        K[3:, :3] = si(K[3:, :3], coupling_unit)
        return cls(matrix=K, **kwargs)

    def stiffness(self, state: ComponentState) -> np.ndarray:
        return np.broadcast_to(self.matrix, (state.n, 6, 6)).copy()

    def in_mks(self, R: Any) -> np.ndarray:
        """H K Hᵀ with H = diag(R, R) (..., 6, 6) for a matrix given in body axes (docs/theory/structure.md)."""
        Rm = np.asarray(R, dtype=float)
        H = np.zeros(Rm.shape[:-2] + (6, 6))
        H[..., :3, :3] = Rm
        H[..., 3:, 3:] = Rm
        return H @ self.matrix @ np.swapaxes(H, -1, -2)


@dataclass(frozen=True, kw_only=True, eq=False)
class JointStiffness(BodyStiffness):
    """Constant 6×6 stiffness of a joint or bearing between two links (mechanism files): symmetric positive
    semi-definite, 0 in the directions the joint leaves free (e.g. the rotation of a revolute joint)."""

    what: ClassVar[str] = "joint stiffness"
    semi_definite: ClassVar[bool] = True


# --------------------------------------------------------------------------------------------- machine files
def _rigid_body(p: "Params") -> Component:
    inertia_raw = p.raw("inertia", None)
    inertia = None
    if inertia_raw is not None:
        is_matrix = isinstance(inertia_raw, (list, tuple)) and inertia_raw and isinstance(inertia_raw[0], (list, tuple))
        if isinstance(inertia_raw, dict):
            is_matrix = np.ndim(inertia_raw.get("value")) == 2
        inertia = p.get("inertia", shape=(3, 3) if is_matrix else (3,))
    return RigidBody(name=p.name, mass=p["mass"], inertia=inertia, cog=p["cog"])


_UNIT_PARAMS = (("translational_unit", "N/m"), ("rotational_unit", "N*m/rad"), ("coupling_unit", "N/rad"))


def _body_stiffness(p: "Params", cls: type = BodyStiffness) -> Component:
    t_unit, r_unit, c_unit = (p[key] for key, _ in _UNIT_PARAMS)
    for (key, dim), unit in zip(_UNIT_PARAMS, (t_unit, r_unit, c_unit)):
        try:
            parse_quantity(f"1 {unit}", dim, source=p.source, key=p.key(key))
        except InputError as exc:
            raise p.error(key, f"a unit of {dim}", unit) from exc
    notes = {}
    if not p.has("rotational_unit"):
        notes["rotational_unit"] = ("bare rotational entries read as N*m/urad (interpretation of the unprinted "
                                    "Hexaglide K_P units, docs/user-guide/machines.md note 3)")
    if p.exactly_one(("diagonal",), ("matrix",)) == 0:
        trans = p.quantity_in("diagonal", "N/m", t_unit, shape=(6,))
        rot = p.quantity_in("diagonal", "N*m/rad", r_unit, shape=(6,))
        K = np.diag(np.concatenate([trans[:3], rot[3:]]))
    else:
        K = np.empty((6, 6))
        blocks = p.quantity_in("matrix", "N/m", t_unit, shape=(6, 6))
        K[:3, :3] = blocks[:3, :3]
        K[3:, 3:] = p.quantity_in("matrix", "N*m/rad", r_unit, shape=(6, 6))[3:, 3:]
        coupling = p.quantity_in("matrix", "N/rad", c_unit, shape=(6, 6))
        K[:3, 3:], K[3:, :3] = coupling[:3, 3:], coupling[3:, :3]
    return cls(name=p.name, matrix=K, assumptions=notes)


MODELS: tuple[ModelSpec, ...] = (
    ModelSpec("rigid_body", "rigid body: mass, inertia about the CoG (body axes), CoG", "docs/theory/structure.md",
              (Param("mass", "kg", None, "mass", required=True, min_value=0.0),
               Param("inertia", "kg*m^2", None, "3 principal values or a 3x3 tensor about the CoG (body axes)",
                     shape=(3,), default_text="0"),
               Param("cog", "m", None, "CoG relative to the body reference point, body axes", shape=(3,),
                     default_text="(0, 0, 0)")),
              _rigid_body),
    ModelSpec("body_stiffness", "constant 6x6 body stiffness (e.g. platform K_P / K_U)", "docs/theory/components.md",
              (Param("diagonal", "N/m, N*m/rad", None, "6 diagonal values (instead of matrix)",
                     required="unless matrix", kind="raw", shape=(6,)),
               Param("matrix", "N/m, N/rad, N*m/rad", None, "6x6 matrix (instead of diagonal)",
                     required="unless diagonal", kind="raw", shape=(6, 6)),
               Param("translational_unit", "-", "N/um", "unit of bare translational entries", kind="string"),
               Param("rotational_unit", "-", "N*m/urad", "unit of bare rotational entries (Assumption)",
                     kind="string"),
               Param("coupling_unit", "-", "N/urad", "unit of bare coupling entries", kind="string")),
              _body_stiffness),
    ModelSpec("joint_stiffness", "constant 6x6 joint/bearing stiffness, 0 in the joint's free directions "
              "(mechanism files)", "docs/user-guide/mechanisms.md",
              (Param("diagonal", "N/m, N*m/rad", None, "6 diagonal values (instead of matrix)",
                     required="unless matrix", kind="raw", shape=(6,)),
               Param("matrix", "N/m, N/rad, N*m/rad", None, "6x6 matrix (instead of diagonal)",
                     required="unless diagonal", kind="raw", shape=(6, 6)),
               Param("translational_unit", "-", "N/um", "unit of bare translational entries", kind="string"),
               Param("rotational_unit", "-", "N*m/urad", "unit of bare rotational entries", kind="string"),
               Param("coupling_unit", "-", "N/urad", "unit of bare coupling entries", kind="string")),
              lambda p: _body_stiffness(p, JointStiffness)),
)
