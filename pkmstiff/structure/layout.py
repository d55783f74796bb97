"""Bodies and layout of the PKM structure model: which bodies exist, their masses, the component roles
(docs/theory/structure.md, Cobet §4.2).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from pkmstiff.machine.model import Machine
from pkmstiff.machine.roles import MachineComponents, machine_components
from pkmstiff.structure.options import StructureModelError, StructureOptions


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


def strut_mass_shares(machine: Machine, options: StructureOptions | None = None) -> tuple[float, float]:
    """(drive, platform) fractions of each strut's mass lumped at its joints: the machine file's
    ``strut_mass_shares`` unless ``options.strut_mass_to_drive`` overrides them (that fraction at the drive, the rest
    at the platform)."""
    share = None if options is None else options.strut_mass_to_drive
    if share is None:
        return machine.strut_mass_shares
    return share, 1.0 - share


def strut_mass_text(machine: Machine, options: StructureOptions | None = None) -> str:
    """One line for outputs: how the structure model places the strut masses."""
    d, p = strut_mass_shares(machine, options)
    if d == 0.0 and p == 0.0:
        return "no extra strut mass (the drive and platform masses hold the struts)"
    return f"each strut's mass lumped {100 * d:g} % at its drive joint, {100 * p:g} % at its platform joint"


def structure_layout(machine: Machine, options: StructureOptions | None = None) -> StructureLayout:
    """Masses and bodies of the structure model of ``machine`` (docs/theory/structure.md); raises on missing data."""
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
    share, platform_share = strut_mass_shares(machine, options)
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
        platform = platform.plus_point(platform_share * strut_mass[i] + jm_p[i], machine.chains.platform_joint[i])

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
