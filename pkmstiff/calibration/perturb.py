"""Applying an error vector: the perturbed machine, the perturbed set-up and the machine file that ``extends`` the
nominal one (docs/theory/calibration.md; Szatmári §4.2.4: the "real" machine of a simulated measurement).

A perturbed machine is an ordinary :class:`~pkmstiff.machine.Machine` whose chain geometry (and per-chain
``drive_offset``) carries the errors, so every toolkit function (IK, FK, admissibility) works on it unchanged, and
:func:`machine_file_text` writes the same machine as a machine file that ``extends`` the nominal one.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from pkmstiff.calibration.instruments import Setup, SetupState
from pkmstiff.calibration.parameters import ParameterSet
from pkmstiff.errors import ArgumentError
from pkmstiff.machine import Machine, bundled_machine_dir

#: machine-file key of each chain parameter block
CHAIN_KEYS = {"base_joint": "drive_joint", "platform_joint": "platform_joint", "strut_offset": "drive_offset",
              "guide_start": "guide_start", "guide_direction": "guide_direction", "drive_joint": "drive_joint",
              "strut_length": "strut_length", "drive_zero": "drive_offset"}


def chain_geometry(machine: Machine, params: ParameterSet, delta: np.ndarray) -> dict[str, np.ndarray]:
    """The perturbed chain arrays (machine-file keys -> (n, 3) or (n,) SI) for the error vector ``delta``."""
    delta = params.check_vector(delta)
    ch = machine.chains
    n = ch.n
    out: dict[str, np.ndarray] = {}
    if ch.kind == "pod":
        out["drive_joint"] = ch.drive_joint + params.block_vectors(delta, "base_joint", n)
        out["drive_offset"] = ch.drive_offset + params.block_scalars(delta, "strut_offset", n)
    else:
        out["guide_start"] = ch.guide_start + params.block_vectors(delta, "guide_start", n)
        r = ch.guide_direction + params.block_vectors(delta, "guide_direction", n)
        out["guide_direction"] = r / np.linalg.norm(r, axis=1, keepdims=True)
        out["drive_joint"] = ch.drive_joint + params.block_vectors(delta, "drive_joint", n)
        out["strut_length"] = ch.strut_length + params.block_scalars(delta, "strut_length", n)
        out["drive_offset"] = ch.drive_offset + params.block_scalars(delta, "drive_zero", n)
    out["platform_joint"] = ch.platform_joint + params.block_vectors(delta, "platform_joint", n)
    return out


def perturbed_machine(machine: Machine, params: ParameterSet, delta: np.ndarray) -> Machine:
    """The machine with the errors ``delta`` applied to its geometry (a new :class:`Machine`)."""
    geo = chain_geometry(machine, params, delta)
    if machine.kind == "glide" and np.any(geo["strut_length"] <= 0):
        raise ArgumentError(f"machine '{machine.name}': the errors make a strut length non-positive")
    return dataclasses.replace(machine, chains=dataclasses.replace(machine.chains, **geo),
                               title=machine.title + " (perturbed)")


def perturbed_state(setup: Setup, params: ParameterSet, delta: np.ndarray) -> SetupState:
    """The actual instrument set-up: nominal + set-up errors of ``delta``."""
    delta = params.check_vector(delta)
    st = setup.state()
    tgt = st.target + params.block_vectors(delta, "ball_offset", 1)[0] + params.block_vectors(delta, "target_offset",
                                                                                                1)[0]
    fixed = None if st.fixed_ball is None else st.fixed_ball + params.block_vectors(delta, "fixed_ball", 1)[0]
    bar = float(params.block_scalars(delta, "bar_offset", 1)[0])
    m = params.mask("instrument_frame")
    trans, rot = np.zeros(3), np.zeros(3)
    for k in np.flatnonzero(m):
        (rot if params.components[k].startswith("r") else trans)[:] += delta[k] * params.axis[k]
    return SetupState(target=tgt, fixed_ball=fixed, bar_offset=bar, frame_translation=trans,
                      frame_rotation=Rotation.from_rotvec(rot).as_matrix())


def _toml_value(v: np.ndarray | float) -> str:
    if np.ndim(v) == 0:
        return repr(float(v))
    return "[" + ", ".join(repr(float(x)) for x in np.asarray(v)) + "]"


def _extends_target(machine: Machine) -> str:
    if ":" in machine.name:
        raise ArgumentError(f"machine '{machine.name}' was loaded with options: a file that 'extends' it cannot "
                               "select them; write the options into a machine file first")
    path = Path(machine.path)
    if path.parent.resolve() == bundled_machine_dir().resolve():
        return path.stem
    return str(path.resolve())


def machine_file_text(machine: Machine, params: ParameterSet, delta: np.ndarray, name: str | None = None,
                      title: str | None = None) -> str:
    """TOML text of a machine file that ``extends`` the nominal machine and sets the perturbed chain geometry
    (only the keys whose values change; bare numbers are SI). Loading it gives :func:`perturbed_machine`."""
    geo = chain_geometry(machine, params, delta)
    ch = machine.chains
    lines = ["# Machine with geometric errors applied (pkmstiff.calibration); values in SI (m, dimensionless).",
             "format_version = 1", "", "[machine]",
             f'name = "{name or machine.name + "_perturbed"}"',
             f'title = "{title or machine.title + " (perturbed)"}"',
             f'extends = "{_extends_target(machine)}"', ""]
    nominal = {k: getattr(ch, k) for k in geo}
    for i in range(ch.n):
        lines.append("[[chains]]")
        for key, arr in geo.items():
            if not np.array_equal(arr[i], nominal[key][i]):
                lines.append(f"{key} = {_toml_value(arr[i])}")
        lines.append("")
    return "\n".join(lines)
