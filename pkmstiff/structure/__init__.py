"""PKM structure model: spindle, platform and six drives connected by the bindings W, V, U (spec models.md §4).

:func:`build_structure` turns a machine and N poses into a pose-vectorised :class:`~pkmstiff.multibody.SDEModel`:

* bodies (spec §4.2, DOF order of the spec): ``spindle`` (rigid, 6 DOF; only if the machine gives a
  ``platform_spindle`` stiffness), ``platform`` (rigid, 6), ``drive1`` … ``drive6`` (point masses, 3 each, at the
  drive-side joint points q_i; absent where the drive is rigidly suspended in the frame);
* ``W1`` … ``W6`` drive–frame (spec §4.4): glide ``K_W = R_i diag(k_A, k_y, k_z) R_iᵀ`` from the axial drive
  stiffness and the guide carriages (eq. 3.6; R_i: x' = guide direction, z' = machine vertical); pod: the
  ``drive_suspension`` 3×3 stiffness in the MKS (absent = rigid, the drive DOFs are removed, spec §4.6);
* ``V1`` … ``V6`` drive–platform (eq. 4.48–4.50): ``k_V d̂ d̂ᵀ`` at the platform joint p_i with
  ``1/k_V = 1/k_drive-joint + 1/k_strut + 1/k_platform-joint`` (pod: the telescopic ``drive`` is the strut term);
  joint stiffness at the joint angles of the pose in the joint type's convention (spec §2);
* ``U`` platform–spindle (eq. 4.51–4.52): the 6×6 ``platform_spindle`` stiffness at the coupling point r_U,
  given in platform axes (``H K_U Hᵀ``).  Without it platform and spindle are one body (24 DOF for a glide).

Components that are not given are rigid (``None`` in :func:`pkmstiff.machine.roles.machine_components`): a
rigid direction becomes an exact rigid binding (null-space elimination of the SDE layer), a fully rigid drive
suspension removes the drive body and attaches V to the frame.

Poses whose inverse kinematics has no solution or that are singular (κ(J_C⁻¹) above the machine's threshold,
spec §1.6) are not modelled: the structure keeps them with a reason code and every analysis returns NaN for them
(never an exception inside a batch).  The same holds for poses where a component cannot be evaluated (range
error, NaN or non-positive stiffness) and, in the batch evaluation, for poses whose stiffness matrix is not
positive definite.

Assumptions (not in the spec, configurable in :class:`StructureOptions`): strut masses are lumped half at the
drive joint and half at the platform joint (Hexaglide machine file); joint masses of the joint types go to the
drive resp. the platform; the platform–spindle coupling point is O' (spec §4.4 Assumption); the spindle's
reference point is O'; a massless spindle (Hexaglide: all of M_P on the platform) is condensed statically.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Iterator, Literal, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

import pkmstiff.multibody as sde
from pkmstiff.admissibility.checks import Reason
from pkmstiff.kinematics.joint_angles import joint_angles
from pkmstiff.kinematics import IK, as_poses, inverse_jacobian, inverse_kinematics, kinematic_jacobian, singular_mask
from pkmstiff.machine.roles import MachineComponents, machine_components
from pkmstiff.machine.model import Machine
from pkmstiff.units import InputError

Array = NDArray[np.float64]

#: default number of poses per chunk of the batch evaluation (memory ≈ 3·chunk·30²·8 bytes of work arrays)
DEFAULT_CHUNK = 2048

#: extra status bits of the structure model (beside :class:`pkmstiff.admissibility.checks.Reason`)
COMPONENT_FAILED = 1  # a component could not be evaluated (range error, NaN or non-positive stiffness)
NOT_POSITIVE_DEFINITE = 2  # the assembled stiffness matrix is not positive definite
STATUS_TEXT = {
    COMPONENT_FAILED: "a component stiffness could not be evaluated at this pose (out of range, NaN or <= 0)",
    NOT_POSITIVE_DEFINITE: "stiffness matrix not positive definite (structurally singular pose)",
}


class StructureModelError(InputError):
    """The machine's data do not define a structure model (names machine, key, expectation and finding)."""


@dataclass(frozen=True)
class StructureOptions:
    """Settings of the structure model; every field not prescribed by the spec is an Assumption.

    ``strut_mass_to_drive``: fraction of each strut's mass lumped at the drive joint (rest at the platform joint);
    ``joint_masses``: add the joint types' masses (drive joint → drive, platform joint → platform);
    ``coupling_point``: r_U in the PKS [m] (spec §4.4 Assumption: O'); ``k_u_axes``: axes in which the
    ``platform_spindle`` matrix is given (``"platform"`` → ``H K_U Hᵀ``, or ``"machine"``);
    ``damping_beta``: stiffness-proportional SDE damping ``C_e = β K_e`` [s] (no damping data given: 0);
    ``free_frame``: replace the fixed frame by a free rigid body ``base`` of ``frame_mass`` [kg] and
    ``frame_inertia`` [kg m²] (test of the six rigid-body modes; not a machine model);
    ``check``: ``"kinematic"`` (default) models every reachable, non-singular pose; ``"full"`` also excludes poses
    failing any admissibility check of :func:`pkmstiff.admissibility.pipeline.evaluate_poses` (collisions, joint limits, ...).
    """

    strut_mass_to_drive: float = 0.5
    joint_masses: bool = True
    coupling_point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    k_u_axes: Literal["platform", "machine"] = "platform"
    damping_beta: float = 0.0
    free_frame: bool = False
    frame_mass: float = 1.0e3
    frame_inertia: float = 1.0e3
    check: Literal["kinematic", "full"] = "kinematic"

    def __post_init__(self) -> None:
        if not 0.0 <= self.strut_mass_to_drive <= 1.0:
            raise StructureModelError("StructureOptions", "strut_mass_to_drive", "a fraction in [0, 1]",
                                      self.strut_mass_to_drive)
        if self.k_u_axes not in ("platform", "machine"):
            raise StructureModelError("StructureOptions", "k_u_axes", "'platform' or 'machine'", self.k_u_axes)
        if self.check not in ("kinematic", "full"):
            raise StructureModelError("StructureOptions", "check", "'kinematic' or 'full'", self.check)
        if not (np.isfinite(self.damping_beta) and self.damping_beta >= 0):
            raise StructureModelError("StructureOptions", "damping_beta", "a time >= 0 s", self.damping_beta)
        if np.shape(self.coupling_point) != (3,):
            raise StructureModelError("StructureOptions", "coupling_point", "a point (3,) in m (PKS)",
                                      self.coupling_point)


# ----------------------------------------------------------------------------------------------------- layout


@dataclass(frozen=True)
class PKSBody:
    """A rigid body fixed to the platform, in the PKS: mass [kg], CoG (3,) [m] (relative to O') and inertia
    about the CoG in platform axes (3, 3) [kg m²]."""

    mass: float
    cog: np.ndarray
    inertia: np.ndarray

    @staticmethod
    def empty() -> "PKSBody":
        return PKSBody(0.0, np.zeros(3), np.zeros((3, 3)))

    def plus_point(self, mass: float, point: np.ndarray) -> "PKSBody":
        return combine_bodies([self, PKSBody(float(mass), np.asarray(point, float), np.zeros((3, 3)))])


def combine_bodies(bodies: Sequence[PKSBody]) -> PKSBody:
    """Total mass, common CoG and inertia about it (parallel-axis theorem) of rigidly joined bodies (PKS)."""
    total = sum(b.mass for b in bodies)
    if total <= 0:
        return PKSBody(0.0, np.zeros(3) if not bodies else bodies[0].cog,
                       sum((b.inertia for b in bodies), np.zeros((3, 3))))
    cog = sum(b.mass * b.cog for b in bodies) / total
    inertia = np.zeros((3, 3))
    for b in bodies:
        r = b.cog - cog
        inertia += b.inertia + b.mass * (r @ r * np.eye(3) - np.outer(r, r))
    return PKSBody(total, cog, inertia)


def component_body(component: Any) -> PKSBody:
    """A rigid-body component (``mass``, ``cog``, ``inertia``) as a :class:`PKSBody`; ``None`` → massless."""
    if component is None:
        return PKSBody.empty()
    return PKSBody(float(component.mass), np.asarray(component.cog, float), np.asarray(component.inertia, float))


def vertical_direction(machine: Machine) -> np.ndarray:
    """Unit upward direction of the machine (−gravity); +z if no gravity is given."""
    g = np.asarray(machine.gravity, float)
    n = float(np.linalg.norm(g))
    return -g / n if n > 0 else np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class StructureLayout:
    """Pose-independent part of the structure model of a machine (bodies, masses, which bindings exist)."""

    machine: Machine
    components: MachineComponents
    options: StructureOptions
    separate_spindle: bool  # True: spindle body + U binding; False: platform and spindle merged
    platform: PKSBody  # platform (+ merged spindle, strut shares, platform joints) in the PKS
    spindle: PKSBody  # spindle body in the PKS (massless: mass 0)
    drive_mass: np.ndarray  # (n,) kg, point mass at each drive joint
    drive_frames: np.ndarray  # (n, 3, 3) columns x', y', z' (glide: guide direction first)

    @property
    def n(self) -> int:
        return self.machine.n_chains

    @property
    def tcp_body(self) -> str:
        return "spindle" if self.separate_spindle else "platform"


def structure_layout(machine: Machine, options: StructureOptions | None = None) -> StructureLayout:
    """Masses and bodies of the structure model of ``machine`` (spec §4.2, §4.6); raises on missing data."""
    options = options or StructureOptions()
    try:
        mc = machine_components(machine)
    except ImportError as exc:  # pragma: no cover - the component library is part of the package
        raise StructureModelError(machine.path, "components", "the component library 'components'", exc) from exc
    n = machine.n_chains
    glide = machine.kind == "glide"
    if glide and all(d is None for d in mc.drive) and all(g is None for g in mc.guide) \
            and all(s is None for s in mc.strut):
        raise StructureModelError(machine.path, "chains[*].components",
                                  "drive/guide/strut components (a structure model needs stiffness data)",
                                  "no component roles for any chain")
    if not glide and all(d is None for d in mc.drive) and all(s is None for s in mc.strut):
        raise StructureModelError(machine.path, "chains[*].components.drive",
                                  "a telescopic drive or strut stiffness per chain", "none given")
    jt_d = [machine.joint_types[t] for t in machine.chains.drive_joint_type]
    jt_p = [machine.joint_types[t] for t in machine.chains.platform_joint_type]
    share = options.strut_mass_to_drive
    strut_mass = np.array([0.0 if s is None else float(s.mass) for s in mc.strut])
    jm_d = np.array([j.mass if options.joint_masses else 0.0 for j in jt_d])
    jm_p = np.array([j.mass if options.joint_masses else 0.0 for j in jt_p])

    platform = component_body(mc.platform)
    spindle = component_body(mc.spindle)
    separate = mc.platform_spindle is not None
    if not separate:
        platform = combine_bodies([platform, spindle])
        spindle = PKSBody.empty()
    for i in range(n):
        platform = platform.plus_point((1.0 - share) * strut_mass[i] + jm_p[i], machine.chains.platform_joint[i])

    def mass_of(c: Any) -> float:
        return 0.0 if c is None else float(c.mass)

    drive_mass = np.array([mass_of(mc.drive[i]) + mass_of(mc.guide[i]) + mass_of(mc.drive_suspension[i])
                           + share * strut_mass[i] + jm_d[i] for i in range(n)])
    if glide:
        from components.guides import drive_frame

        frames = drive_frame(machine.chains.guide_direction, vertical=vertical_direction(machine))
    else:
        frames = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    return StructureLayout(machine, mc, options, separate, platform, spindle, drive_mass, frames)


# ------------------------------------------------------------------------------------ component evaluation


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


def _evaluate(component: Any, kwargs: dict[str, Array], n_values: int) -> tuple[Array, Array]:
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
        vals, good = _evaluate(comp, _state_kwargs(role, cols, arrays), n_poses * len(cols))
        vals = vals.reshape((len(cols), n_poses) + vals.shape[1:])
        out[:, cols] = np.moveaxis(vals, 0, 1)
        ok &= good.reshape(len(cols), n_poses).all(axis=0)
    return out, ok


# --------------------------------------------------------------------------------------------- the model


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

    def take(self, idx: Array) -> "ChainStiffness":
        """The same stiffnesses at the poses ``idx`` (index array or boolean mask)."""
        return ChainStiffness(self.drive_joint[idx], self.strut[idx], self.platform_joint[idx], self.drive[idx],
                              self.chain[idx], None if self.w_local is None else self.w_local[idx])


@dataclass
class PKMStructure:
    """Structure model of a machine at N poses (SDE model over the ``index`` poses that could be modelled).

    ``reasons`` (N,) :class:`~pkmstiff.admissibility.checks.Reason` bits of poses not modelled (0 = modelled unless
    ``status`` is set); ``status`` (N,) extra bits :data:`COMPONENT_FAILED`, :data:`NOT_POSITIVE_DEFINITE`.
    Geometry arrays (``w``, ``R``, ``p``, ``q``, ``u``) and ``stiffness`` hold the modelled poses only.
    """

    layout: StructureLayout
    poses: Array  # (N, 6)
    reasons: Array  # (N,) uint32
    status: Array  # (N,) uint8
    index: Array  # (M,) modelled poses
    w: Array  # (M, 3) O' in the MKS
    R: Array  # (M, 3, 3)
    p: Array  # (M, n, 3) platform joint points
    q: Array  # (M, n, 3) drive joint points
    u: Array  # (M, n, 3) unit strut directions d̂
    stiffness: ChainStiffness
    _model: sde.SDEModel | None = dataclasses.field(default=None, repr=False)
    _dynamic: sde.SDEModel | None = dataclasses.field(default=None, repr=False)

    @property
    def model(self) -> sde.SDEModel | None:
        """The SDE model of the modelled poses (built on first use); None when no pose could be modelled."""
        if self._model is None and len(self.index):
            self._model = _sde_model(self.layout, self.w, self.R, self.p, self.q, self.u, self.stiffness)
        return self._model

    @property
    def drive_bodies(self) -> tuple[str, ...]:
        """Names of the drive bodies, ``''`` where the drive is rigidly suspended (no drive DOFs)."""
        return _drive_names(self.layout, self.stiffness)

    @property
    def rigid_chain(self) -> np.ndarray:
        """(n,) True where the chain (V) is rigid (exact rigid binding instead of an SDE)."""
        return _rigid_chains(self.stiffness)

    @property
    def machine(self) -> Machine:
        return self.layout.machine

    @property
    def options(self) -> StructureOptions:
        return self.layout.options

    @property
    def n_poses(self) -> int:
        return int(self.poses.shape[0])

    @property
    def ok(self) -> Array:
        """(N,) True where the pose is modelled (results finite)."""
        mask = np.zeros(self.n_poses, bool)
        mask[self.index] = True
        return mask

    @property
    def tcp_body(self) -> str:
        return self.layout.tcp_body

    @property
    def empty(self) -> bool:
        """True when no pose could be modelled (``model`` is None; every analysis returns NaN)."""
        return not len(self.index)

    def tcp(self, tool_length: float | ArrayLike | None = None) -> Array:
        """TCP in the MKS (M, 3): ``O' + R (tool.offset + L · tool.axis)`` (spec §5.1).

        ``tool_length``: L in m (None: machine file), or a tool vector (3,) in the PKS [m] from O' to the tool tip
        that replaces ``tool.offset + L · tool.axis`` (any tool orientation).
        """
        tool = self.machine.tool
        if tool_length is not None and np.ndim(tool_length) == 1:
            tip = np.asarray(tool_length, dtype=float)
            if tip.shape != (3,) or not np.all(np.isfinite(tip)):
                raise StructureModelError("tcp", "tool_length", "a length >= 0 m or a tool vector (3,) in m (PKS)",
                                          tool_length)
        else:
            if tool_length is not None and not (np.isfinite(tool_length) and tool_length >= 0):
                raise StructureModelError("tcp", "tool_length", "a length >= 0 m or a tool vector (3,) in m (PKS)",
                                          tool_length)
            tip = tool.tip(tool_length)
        return self.w + self.R @ tip

    def scatter(self, values: ArrayLike, fill: Any = np.nan) -> np.ndarray:
        """Expand per-modelled-pose values (M, ...) to all poses (N, ...), ``fill`` elsewhere."""
        v = np.asarray(values)
        out = np.full((self.n_poses,) + v.shape[1:], fill, dtype=np.result_type(v.dtype, np.asarray(fill).dtype))
        out[self.index] = v
        return out

    @property
    def massless_spindle(self) -> bool:
        """True for a separate spindle body without mass (e.g. the Hexaglide: all of M_P on the platform)."""
        sp = self.layout.spindle
        return self.layout.separate_spindle and sp.mass == 0 and not np.any(sp.inertia)

    @property
    def dynamic_model(self) -> sde.SDEModel:
        """Model for the eigenvalue problem: :attr:`model`, or without a massless spindle.

        A massless spindle coupled to the platform only through U adds nothing to the dynamic stiffness: its static
        condensation gives ``K_PP − N_Pᵀ K_U N_P``, i.e. exactly the platform block without U (spec §4.6 Guyan).
        Leaving it out saves the condensation (frequencies identical; mode shapes then lack the spindle DOFs).
        """
        if not self.massless_spindle or not len(self.index):
            return self.model
        if self._dynamic is None:
            self._dynamic = _sde_model(self.layout, self.w, self.R, self.p, self.q, self.u, self.stiffness,
                                       with_spindle=False)
        return self._dynamic

    def failing(self, i: int) -> list[str]:
        """Why pose ``i`` is not modelled (empty list if it is)."""
        from pkmstiff.admissibility.checks import REASON_TEXT

        out = [REASON_TEXT[r] for r in Reason if int(self.reasons[i]) & int(r)]
        out += [text for bit, text in STATUS_TEXT.items() if int(self.status[i]) & bit]
        return out

    def without(self, local_bad: Array, status_bit: int = NOT_POSITIVE_DEFINITE) -> "PKMStructure":
        """Copy without the modelled poses flagged in ``local_bad`` (M,) (they get ``status_bit``)."""
        keep = ~np.asarray(local_bad, bool)
        status = self.status.copy()
        status[self.index[~keep]] |= np.uint8(status_bit)
        return dataclasses.replace(self, status=status, index=self.index[keep], w=self.w[keep], R=self.R[keep],
                                   p=self.p[keep], q=self.q[keep], u=self.u[keep],
                                   stiffness=self.stiffness.take(keep), _model=None, _dynamic=None)


def _chain_arrays(ik: IK, angles: Any, idx: Array) -> dict[str, Array]:
    return {
        "drive_position": ik.drive[idx], "strut_length": ik.length[idx],
        "drive_joint.tilt": angles.drive.tilt[idx], "drive_joint.swivel": angles.drive.swivel[idx],
        "platform_joint.tilt": angles.platform.tilt[idx], "platform_joint.swivel": angles.platform.swivel[idx],
    }


def _pole_placement(layout: StructureLayout) -> bool:
    return any(getattr(d, "axial_stiffness", None) == "pole_placement" for d in layout.components.drive)


def platform_mass_matrix(layout: StructureLayout, R: Array) -> Array:
    """M_P (N, 6, 6) of platform + spindle referred to O' in MKS axes (spec §4.6, parallel-axis theorem)."""
    body = combine_bodies([layout.platform, layout.spindle]) if layout.separate_spindle else layout.platform
    return mass_matrix_about_origin(body, R)


def mass_matrix_about_origin(body: PKSBody, R: Array) -> Array:
    """``N(ρ)ᵀ diag(m I, R I' Rᵀ) N(ρ)`` (N, 6, 6) about O' in MKS axes, ρ = R cog (spec §4.6)."""
    rho = R @ body.cog
    m = np.zeros((R.shape[0], 6, 6))
    m[:, [0, 1, 2], [0, 1, 2]] = body.mass
    icg = R @ body.inertia @ np.swapaxes(R, 1, 2)
    s = sde.linalg.skew(rho)
    m[:, :3, 3:] = -body.mass * s
    m[:, 3:, :3] = body.mass * s
    m[:, 3:, 3:] = icg - body.mass * s @ s
    return m


def dynamics_masses(machine: Machine, strut_mass_split: bool = False,
                    components: MachineComponents | None = None) -> tuple[np.ndarray, PKSBody]:
    """M_A (n,) [kg] and the body moved by the drives (PKS) for the rigid-body dynamics of spec §3.2 / §6.3.

    M_A = drive + guide carriages + drive-joint mass; moved body = platform + spindle.  ``strut_mass_split``
    (spec §6.3 extension, Assumption, off by default) adds half of each strut to the drive and half, at the platform
    joint, to the moved body.  (The structure model's own mass distribution is set by :class:`StructureOptions`.)
    """
    mc = components or machine_components(machine)
    jt = [machine.joint_types[t] for t in machine.chains.drive_joint_type]
    share = 0.5 if strut_mass_split else 0.0

    def mass(c: Any) -> float:
        return 0.0 if c is None else float(c.mass)

    m_a = np.array([mass(mc.drive[i]) + mass(mc.guide[i]) + jt[i].mass + share * mass(mc.strut[i])
                    for i in range(machine.n_chains)])
    body = combine_bodies([component_body(mc.platform), component_body(mc.spindle)])
    for i in range(machine.n_chains):
        body = body.plus_point(share * mass(mc.strut[i]), machine.chains.platform_joint[i])
    return m_a, body


def _effective_mass(layout: StructureLayout, ik: IK, idx: Array, machine: Machine) -> Array:
    """Diagonal of M_q = M_A + J_Cᵀ M_P J_C (eq. 3.10–3.12) for pole-placement drives (N, n) [kg].

    M_A and M_P as in :func:`dynamics_masses` (platform + spindle about O', no strut shares: spec §3.2).
    """
    from components.direct_drive import joint_space_mass_diagonal

    jsub = IK(**{f.name: (getattr(ik, f.name)[idx] if isinstance(getattr(ik, f.name), np.ndarray)
                          else getattr(ik, f.name)) for f in dataclasses.fields(IK)})
    jc = kinematic_jacobian(inverse_jacobian(machine, jsub))
    m_a, body = dynamics_masses(machine, components=layout.components)
    with np.errstate(invalid="ignore"):
        return joint_space_mass_diagonal(jc, m_a, mass_matrix_about_origin(body, jsub.R))


def chain_stiffness(layout: StructureLayout, ik: IK, angles: Any, idx: Array) -> tuple[ChainStiffness, Array]:
    """Component stiffnesses at the poses ``idx`` of ``ik`` and an ok mask (len(idx),) (spec §3, eq. 4.48)."""
    mc, n, m = layout.components, layout.n, len(idx)
    arrays = _chain_arrays(ik, angles, idx)
    if _pole_placement(layout):
        arrays["drive.effective_mass"] = _effective_mass(layout, ik, idx, layout.machine)
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


def _drive_names(layout: StructureLayout, ks: ChainStiffness) -> tuple[str, ...]:
    if ks.w_local is None:
        return ("",) * layout.n
    fixed = _w_matrices(layout, ks.w_local)[1].all(axis=1)
    return tuple("" if fixed[i] else f"drive{i + 1}" for i in range(layout.n))


def _rigid_chains(ks: ChainStiffness) -> np.ndarray:
    kv = ks.chain
    return np.all(np.isposinf(kv), axis=0) if kv.shape[0] else np.zeros(kv.shape[1], bool)


def _sde_model(layout: StructureLayout, w: Array, R: Array, p: Array, q: Array, u: Array,
               ks: ChainStiffness, with_spindle: bool = True) -> sde.SDEModel:
    """Bodies and bindings (spec §4.2–4.4) for the modelled poses (leading axis M).

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
    rigid_chain = _rigid_chains(ks)
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


def _kinematic_reasons(machine: Machine, ik: IK, options: StructureOptions) -> Array:
    """Reason bits (N,) of poses that cannot be modelled: unreachable, singular (or any check with 'full')."""
    if options.check == "full":
        from pkmstiff.admissibility.pipeline import evaluate_poses

        return evaluate_poses(machine, ik.poses).admissibility.reasons.astype(np.uint32)
    reasons = np.zeros(ik.n_poses, np.uint32)
    reach = ik.all_reachable
    reasons[~reach] = int(Reason.UNREACHABLE)
    if reach.any():
        idx = np.flatnonzero(reach)
        sub = IK(**{f.name: (getattr(ik, f.name)[idx] if isinstance(getattr(ik, f.name), np.ndarray)
                             else getattr(ik, f.name)) for f in dataclasses.fields(IK)})
        with np.errstate(invalid="ignore", divide="ignore"):
            sing = singular_mask(machine, inverse_jacobian(machine, sub))
        reasons[idx[sing]] |= np.uint32(int(Reason.SINGULAR))
    return reasons


def structure_from_ik(machine: Machine, ik: IK, options: StructureOptions | None = None,
                      layout: StructureLayout | None = None) -> PKMStructure:
    """Structure model for the poses of an inverse-kinematics result (see :func:`build_structure`)."""
    layout = layout or structure_layout(machine, options)
    reasons = _kinematic_reasons(machine, ik, layout.options)
    status = np.zeros(ik.n_poses, np.uint8)
    idx = np.flatnonzero(reasons == 0)
    angles = joint_angles(machine, ik, signed=False)
    ks, good = chain_stiffness(layout, ik, angles, idx)
    status[idx[~good]] |= np.uint8(COMPONENT_FAILED)
    idx, ks = idx[good], ks.take(good)
    w = np.ascontiguousarray(ik.poses[idx, :3])
    R = np.ascontiguousarray(ik.R[idx])
    p, q = np.ascontiguousarray(ik.p[idx]), np.ascontiguousarray(ik.q[idx])
    u = np.ascontiguousarray(ik.unit_d[idx])
    return PKMStructure(layout, np.asarray(ik.poses), reasons, status, idx, w, R, p, q, u, ks)


def build_structure(machine: Machine, poses: ArrayLike, options: StructureOptions | None = None,
                    layout: StructureLayout | None = None) -> PKMStructure:
    """Structure model (spec §4) of ``machine`` at poses ``(N, 6)`` = (x, y, z [m], a, b, c [rad]).

    All poses are held in one SDE model; for large batches use :func:`iter_structures` (chunks) or the batch
    evaluation :func:`pkmstiff.analysis.evaluate_structure`.
    """
    return structure_from_ik(machine, inverse_kinematics(machine, as_poses(poses)), options, layout)


def iter_structures(machine: Machine, poses: ArrayLike, options: StructureOptions | None = None,
                    chunk_size: int = DEFAULT_CHUNK) -> Iterator[tuple[slice, PKMStructure]]:
    """``(slice, structure)`` for consecutive chunks of at most ``chunk_size`` poses (bounded memory)."""
    x = as_poses(poses)
    if chunk_size < 1:
        raise StructureModelError("iter_structures", "chunk_size", "an integer >= 1", chunk_size)
    layout = structure_layout(machine, options)
    for start in range(0, x.shape[0], chunk_size):
        sl = slice(start, min(start + chunk_size, x.shape[0]))
        yield sl, build_structure(machine, x[sl], layout=layout)


def structure_summary(structure: PKMStructure) -> dict[str, Any]:
    """Bodies, DOF and bindings of the model (for reports and the README figure)."""
    m = structure.model
    return {
        "bodies": m.body_names, "dof": m.n_dof, "elements": m.element_names,
        "rigid_bindings": [b.name for b in m.bindings], "tcp_body": structure.tcp_body,
        "separate_spindle": structure.layout.separate_spindle,
        "massless_dofs": len(m.massless_dofs),
    }


__all__ = [
    "StructureOptions", "StructureLayout", "StructureModelError", "PKMStructure", "ChainStiffness",
    "structure_layout", "build_structure", "structure_from_ik", "iter_structures", "chain_stiffness",
    "platform_mass_matrix", "mass_matrix_about_origin", "PKSBody", "combine_bodies", "component_body",
    "vertical_direction", "platform_spindle_matrix", "dynamics_masses", "structure_summary", "DEFAULT_CHUNK",
    "COMPONENT_FAILED",
    "NOT_POSITIVE_DEFINITE", "STATUS_TEXT",
]
