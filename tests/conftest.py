"""Shared test helpers and fixtures.

* bundled machines loaded once per test module (``hexaglide``, ``hexapod``);
* kinematics helpers: a hand-built Hexaglide and workspace-centre poses of every bundled machine;
* study helpers: load a script from ``studies/`` (not a package) and run it once in --fast mode.

VTK's EGL window is chosen for the whole session when there is no display (as the command line does).
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from pkmstiff import load_machine
from pkmstiff.machine.model import Chains, Hull, JointType, Limits, Machine, Tool

if not os.environ.get("DISPLAY"):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


@pytest.fixture(scope="module")
def hexaglide():
    return load_machine("hexaglide")


@pytest.fixture(scope="module")
def hexapod():
    return load_machine("hexapod_6x")


@pytest.fixture(scope="module")
def felix():
    return load_machine("felix")


# ------------------------------------------------------------------------------------------------------ kinematics
BUNDLED = ("hexaglide", "hexaglide_v1", "hexaglide_v2", "hexapod_6x", "linapod", "paralix")

#: workspace-centre poses (x, y, z [m], a, b, c [rad]) chosen by scanning each machine: every drive within
#: its range and κ(J⁻¹) < 200 in a box of ±0.1 m and ±5° around them (input data, not results)
CENTRE = {
    "hexaglide": (0.0, 0.3, -0.9, 0.0, 0.0, 0.0),
    "hexaglide_v1": (0.0, 0.45, -0.9, 0.0, 0.0, 0.0),
    "hexaglide_v2": (0.0, 0.7, -0.9, 0.0, 0.0, 0.0),
    "hexapod_6x": (0.0, 0.0, 1.3, 0.0, 0.0, 0.0),
    "linapod": (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    "paralix": (-2.0, 0.0, 0.0, 0.0, 0.0, 0.0),
}


def hexaglide_by_hand() -> Machine:
    """Hexaglide, original configuration, Table C.1 values exactly as printed (axes not normalised)."""
    s = [(1.35, 0.80, 0.0), (-1.35, 0.80, 0.0), (1.35, 0.40, 0.0), (-1.35, 0.40, 0.0), (1.35, 0.0, 0.0),
         (-1.35, 0.0, 0.0)]
    r = [(-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)] * 3
    b = [(-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)] * 3
    p = [(0.20, 0.19, 0.15), (-0.20, 0.19, 0.15), (0.30, -0.13, 0.15), (-0.30, -0.13, 0.15), (0.08, -0.18, 0.15),
         (-0.08, -0.18, 0.15)]
    m = [(0.7071, 0.7071, 0.0), (-0.7071, 0.7071, 0.0), (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.7071, -0.7071, 0.0),
         (-0.7071, -0.7071, 0.0)]
    n6 = np.ones(6)
    chains = Chains(
        kind="glide",
        guide_start=np.array(s),
        guide_direction=np.array(r),
        guide_length=2.7 * n6,
        strut_length=np.array([1.0, 1.0, 0.95, 0.95, 0.95, 0.95]),
        larger_root=np.zeros(6, dtype=bool),
        length_min=np.full(6, np.nan),
        length_max=np.full(6, np.nan),
        drive_joint=np.tile([0.0, 0.0, -0.15], (6, 1)),
        drive_axis=np.tile([-1.0, 0.0, 0.0], (6, 1)),
        drive_reference=np.array(b),
        platform_joint=np.array(p),
        platform_axis=np.array(m),
        platform_reference=np.tile([0.0, 0.0, 1.0], (6, 1)),
        strut_radius=0.025 * n6,
        drive_joint_type=("iwf_3dof",) * 6,
        platform_joint_type=("iwf_2dof",) * 6,
        guide=("y800", "y800", "y400", "y400", "y000", "y000"),
    )
    return Machine(
        name="hexaglide_by_hand",
        title="Hexaglide (hand-built test fixture)",
        chains=chains,
        joint_types={
            "iwf_3dof": JointType("iwf_3dof", "axis", "outward", tilt_min=np.deg2rad(5.0)),
            "iwf_2dof": JointType("iwf_2dof", "axis", "outward"),
        },
        guides={},
        hull=Hull(np.zeros((0, 3)), np.zeros((0, 3), dtype=int)),
        tool=Tool(),
        gravity=np.array([0.0, 0.0, -9.81]),
        limits=Limits(),
        transmission_weight=0.5 / (np.pi / 9),
        components={},
        chain_components=tuple({} for _ in range(6)),
        machine_components={},
        assumptions={},
    )


def with_chains(machine: Machine, **changes) -> Machine:
    """Copy of ``machine`` with some ``Chains`` fields replaced."""
    return dataclasses.replace(machine, chains=dataclasses.replace(machine.chains, **changes))


def random_poses(name: str, n: int, rng: np.random.Generator, dpos: float = 0.1, dang_deg: float = 5.0) -> np.ndarray:
    """n poses uniformly in a box of ±dpos [m] and ±dang_deg around the workspace centre of ``name``."""
    poses = np.tile(np.array(CENTRE[name]), (n, 1))
    poses[:, :3] += rng.uniform(-dpos, dpos, (n, 3))
    poses[:, 3:] += rng.uniform(-1.0, 1.0, (n, 3)) * np.deg2rad(dang_deg)
    return poses


# --------------------------------------------------------------------------------------------------------- studies
STUDIES = Path(__file__).resolve().parents[1] / "studies"


def load(name: str):
    """Import ``studies/<name>`` as a module."""
    path = STUDIES / name
    spec = importlib.util.spec_from_file_location(f"study_{path.stem}", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def run_fast(scripts: dict[str, str], tmp_path_factory) -> dict:
    """Each study run once in --fast mode: letter -> (module, output dir, results.json)."""
    out = {}
    for letter, script in scripts.items():
        mod = load(script)
        d = tmp_path_factory.mktemp(f"study_{letter}")
        assert mod.main(["--fast", "--out", str(d)]) == 0
        out[letter] = (mod, d, json.loads((d / "results.json").read_text(encoding="utf-8")))
    return out
