"""Component instances of a machine, by role (docs/theory/components.md).

Roles per chain (``[[chains]] components``): ``drive`` (glide: axial drive stiffness along the guide; pod: the
length-dependent telescopic drive, i.e. the strut term of eq. 4.48), ``guide`` (glide: guide carriages, transverse
stiffness), ``strut`` (eq. 3.7), ``drive_suspension`` (pod: 3x3 drive-frame stiffness; absent = rigid).
Joint stiffness comes from the joint types (``[joint_types.NAME] stiffness``). Machine roles
(``[machine_components]``): ``platform`` and ``spindle`` (rigid bodies) and ``platform_spindle`` (6x6 K_U;
absent = platform and spindle merged into one body).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from pkmstiff.machine.model import Machine, memo

CHAIN_ROLES = ("drive", "guide", "strut", "drive_suspension")
MACHINE_ROLES = ("platform", "spindle", "platform_spindle")


def component(machine: Machine, name: str) -> Any:
    """The component instance ``name`` of the machine (built on load; built once per machine object if the machine
    was modified: kept with the object by :func:`~pkmstiff.machine.model.memo`, never written into the frozen
    machine's ``built_components``, which ``dataclasses.replace`` shares between copies)."""
    raw = machine.components[name]
    cached = machine.built_components.get(name)
    if cached is not None and cached[0] is raw:
        return cached[1]

    def build() -> tuple[dict, Any]:
        from pathlib import Path

        from components.registry import build_component

        return raw, build_component(name, raw, source=machine.path, base_dir=str(Path(machine.path).parent))

    hit = memo(machine, f"_built_component:{name}", build)
    if hit[0] is not raw:  # the components dict was changed in place since: build afresh
        hit = build()
    return hit[1]



@dataclass(frozen=True)
class DriveLoadData:
    """Mass and force data for the static drive-load check (eq. 4.90, B.13), SI units."""

    moved_mass: float  # kg carried by the platform (platform + spindle (+ strut shares))
    cog_offset: np.ndarray  # (3,) CoG offset from O' in the PKS, m
    max_force: np.ndarray  # (n,) tau_q,max, N
    force_reserve: np.ndarray  # (n,) tau_q,min, N
    coulomb: np.ndarray  # (n,) C_i, N

@dataclass(frozen=True)
class MachineComponents:
    """Component instances by role; ``None`` where the role is not given (rigid / massless / merged)."""

    drive: tuple[Any, ...]
    guide: tuple[Any, ...]
    strut: tuple[Any, ...]
    drive_suspension: tuple[Any, ...]
    drive_joint: tuple[Any, ...]
    platform_joint: tuple[Any, ...]
    platform: Any
    spindle: Any
    platform_spindle: Any

    @property
    def has_masses(self) -> bool:
        return self.platform is not None


def machine_components(machine: Machine) -> MachineComponents:
    """Resolve every role of every chain and of the machine to its component instance."""
    def role(i: int, r: str) -> Any:
        name = machine.chain_components[i].get(r)
        return None if name is None else component(machine, name)

    def joint(side: str, i: int) -> Any:
        types = machine.chains.drive_joint_type if side == "drive" else machine.chains.platform_joint_type
        name = machine.joint_types[types[i]].stiffness
        return None if name is None else component(machine, name)

    n = machine.n_chains
    mc = {r: (None if machine.machine_components.get(r) is None else component(machine, machine.machine_components[r]))
          for r in MACHINE_ROLES}
    return MachineComponents(
        **{r: tuple(role(i, r) for i in range(n)) for r in CHAIN_ROLES},
        drive_joint=tuple(joint("drive", i) for i in range(n)),
        platform_joint=tuple(joint("platform", i) for i in range(n)), **mc)


def drive_load_data(machine: Machine) -> DriveLoadData | None:
    """Mass and drive-force data for the static drive-load check (eq. 4.90, B.13), or None if not given.

    Moved mass = platform (+ spindle) mass, plus ``limits.drive_load_strut_mass`` × the strut masses (eq. 4.90:
    the sum of the moved masses carried by the platform; docs/user-guide/validation-hexaglide.md, reading: static drive load — for the Hexaglide all six
    struts); CoG = the combined CoG of platform and spindle in the PKS (the strut share is added at that CoG:
    eq. 4.90 sums the masses, their CoG is not given). Needs a platform body and a maximum force on every drive;
    missing force reserve / Coulomb friction count as 0. Computed once per machine object (it depends on the
    machine's data only; ~10 % of a one-pose evaluation).
    """
    return memo(machine, "_drive_load_data", lambda: _drive_load_data(machine))




def _drive_load_data(machine: Machine) -> DriveLoadData | None:
    try:
        mc = machine_components(machine)
    except ImportError:
        return None
    if mc.platform is None or any(d is None or "max_force" not in d.limits for d in mc.drive):
        return None
    bodies = [b for b in (mc.platform, mc.spindle) if b is not None]
    mass = sum(float(b.mass) for b in bodies)
    cog = sum(float(b.mass) * np.asarray(b.cog, float) for b in bodies) / mass
    frac = machine.limits.drive_load_strut_mass
    if frac > 0:
        mass += frac * sum(float(getattr(s, "mass", 0.0) or 0.0) for s in mc.strut if s is not None)
    lim = [d.limits for d in mc.drive]
    return DriveLoadData(
        moved_mass=mass, cog_offset=cog,
        max_force=np.array([x["max_force"] for x in lim], float),
        force_reserve=np.array([x.get("force_reserve", 0.0) for x in lim], float),
        coulomb=np.array([x.get("coulomb_friction", 0.0) for x in lim], float),
    )
