"""Several instrument set-ups in one identification (issue 26 item 3): fixed-ball positions, bar lengths, ball
offsets or tracker stations measured on one machine and identified together (Szatmári §5.4 measures in several
regions for this reason).

* :class:`PlanSet` — the plans of several set-ups (one :class:`~pkmstiff.calibration.plans.Plan` each, one
  instrument), read where a plan is read: its readings and Jacobian rows are those of its parts, stacked in order.
* :func:`setups_error_model` — the machine's error parameters once, the set-up parameters (``--with``) once **per
  set-up**: ``setup<k>.fixed_ball.x`` … (chain index −k, so ``chain < 0`` still marks a set-up parameter);
  :func:`part_parameters` maps set-up k back to a one-set-up :class:`ParameterSet` (the names without the prefix),
  so every one-set-up function works on a part unchanged.
* **Fixed ball placed by the machine** (:attr:`Setup.placing_pose`): the centre mount, held in the tool cup, is
  driven to a commanded pose and locked there. Its actual position is then where the machine with its errors put
  it, s(Δp) = s_nominal + m_c(Δp) − m_c(0) (+ Δs with ``--with fixed-ball``), m_c the ball centre o + R (v + Δv)
  reached for the nominal drive values of the placing pose; a reading r = |m − s| has the Jacobian row
  u · (∂m/∂p − ∂m_c/∂p) (:func:`placed_ball_jacobian`). Such a ball moves with the machine's own frame, so it
  removes none of the base-frame gauge freedoms (docs/user-guide/calibration-identifiability.md, "Several set-ups").
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pkmstiff.calibration.instruments import Instrument, Setup, SetupState
from pkmstiff.calibration.parameters import ParameterSet, error_model
from pkmstiff.calibration.perturb import perturbed_state
from pkmstiff.calibration.plans import Plan, Segment
from pkmstiff.errors import InputError
from pkmstiff.machine import Machine


@dataclass(frozen=True)
class PlanSet:
    """Plans of several set-ups of one instrument, measured on one machine and identified together (rows in the
    order of ``parts``)."""

    name: str
    parts: tuple[Plan, ...]

    def __post_init__(self) -> None:
        if not self.parts:
            raise InputError(self.name, "setups", "at least one set-up", "none")
        kinds = {p.instrument.kind for p in self.parts}
        if len(kinds) > 1:
            raise InputError(self.name, "setups", "set-ups of one instrument", ", ".join(sorted(kinds)))

    @property
    def instrument(self) -> Instrument:
        return self.parts[0].instrument

    @property
    def setup(self) -> Setup:
        """The first set-up (it names the gauge freedoms' rotation centres)."""
        return self.parts[0].setup

    @property
    def setups(self) -> tuple[Setup, ...]:
        return tuple(p.setup for p in self.parts)

    @property
    def n_setups(self) -> int:
        return len(self.parts)

    @property
    def n_poses(self) -> int:
        return sum(p.n_poses for p in self.parts)

    @property
    def n_readings(self) -> int:
        return sum(p.n_readings for p in self.parts)

    @property
    def poses(self) -> np.ndarray:
        return np.vstack([p.poses for p in self.parts])

    @property
    def offsets(self) -> np.ndarray:
        """First pose of each part and the total (n_setups + 1,)."""
        return np.concatenate([[0], np.cumsum([p.n_poses for p in self.parts])]).astype(int)

    @property
    def segments(self) -> tuple[Segment, ...]:
        out = []
        for k, (p, off) in enumerate(zip(self.parts, self.offsets)):
            out += [Segment(f"set-up {k + 1}: {s.label}", s.start + off, s.stop + off, s.kind) for s in p.segments]
        return tuple(out)


def setups_of(plan: Plan | PlanSet) -> tuple[Setup, ...]:
    return plan.setups if isinstance(plan, PlanSet) else (plan.setup,)


def setup_prefix(k: int) -> str:
    """Name prefix of the set-up parameters of set-up ``k`` (0-based) in a several-set-up error model."""
    return f"setup{k + 1}."


def setups_error_model(machine: Machine, plan: Plan | PlanSet, frame: str = "cartesian",
                       setup_blocks: Sequence[str] = ()) -> ParameterSet:
    """The error model of ``machine`` with the set-up ``blocks`` of every set-up of ``plan`` (module docstring);
    a one-set-up plan gives :func:`~pkmstiff.calibration.parameters.error_model` unchanged."""
    if not isinstance(plan, PlanSet) or plan.n_setups == 1:
        return error_model(machine, frame=frame, setup=plan.setup, setup_blocks=tuple(setup_blocks))
    base = error_model(machine, frame=frame)
    fields = {f.name: [getattr(base, f.name)] for f in dataclasses.fields(ParameterSet)
              if f.name not in ("machine", "kind", "frame")}
    for k, st in enumerate(plan.setups):
        ps = error_model(machine, frame=frame, setup=st, setup_blocks=tuple(setup_blocks))
        idx = np.flatnonzero(ps.chain < 0)
        sub = _subset(ps, idx)
        fields["names"].append(tuple(setup_prefix(k) + nm for nm in sub.names))
        fields["chain"].append(np.full(idx.size, -(k + 1)))
        for key in ("units", "blocks", "components", "axis", "nominal", "scale"):
            fields[key].append(getattr(sub, key))
    out = {key: (sum(v, ()) if isinstance(v[0], tuple) else np.concatenate(v)) for key, v in fields.items()}
    return ParameterSet(machine=base.machine, kind=base.kind, frame=base.frame, **out)


def _subset(params: ParameterSet, idx: np.ndarray, names: tuple[str, ...] | None = None,
            chain: np.ndarray | None = None) -> ParameterSet:
    return dataclasses.replace(
        params, names=names if names is not None else tuple(params.names[i] for i in idx),
        units=tuple(params.units[i] for i in idx), blocks=tuple(params.blocks[i] for i in idx),
        components=tuple(params.components[i] for i in idx), chain=params.chain[idx] if chain is None else chain,
        axis=params.axis[idx], nominal=params.nominal[idx], scale=params.scale[idx])


def part_parameters(params: ParameterSet, k: int) -> tuple[ParameterSet, np.ndarray]:
    """The one-set-up error model of set-up ``k`` (0-based): the machine's parameters and set-up k's (names
    without the ``setup<k>.`` prefix, chain −1), and their indices in ``params``."""
    own = (params.chain >= 0) | (params.chain == -(k + 1))
    if not np.any(params.chain < -1):  # a one-set-up model: every set-up parameter is the set-up's
        own = np.ones(params.n, dtype=bool)
    idx = np.flatnonzero(own)
    pre = setup_prefix(k)
    names = tuple(params.names[i][len(pre):] if params.chain[i] < 0 and params.names[i].startswith(pre)
                  else params.names[i] for i in idx)
    return _subset(params, idx, names, np.where(params.chain[idx] < 0, -1, params.chain[idx])), idx


def parts(plan: Plan | PlanSet, params: ParameterSet):
    """(plan, its one-set-up parameters, their indices in ``params``, row slice of its poses) per set-up."""
    plans = plan.parts if isinstance(plan, PlanSet) else (plan,)
    off = np.concatenate([[0], np.cumsum([p.n_poses for p in plans])])
    for k, p in enumerate(plans):
        sub, idx = part_parameters(params, k)
        yield p, sub, idx, slice(int(off[k]), int(off[k + 1]))


# --------------------------------------------------------------------------------- fixed ball placed by the machine


def placed_ball(machine: Machine, params: ParameterSet, delta: np.ndarray, setup: Setup) -> np.ndarray:
    """Centre (3,) m of the ball the machine with errors ``delta`` puts at ``setup.placing_pose``: o + R (v + Δv)
    at the pose reached for the pose's nominal drive values."""
    from pkmstiff.calibration.measurement import reached_poses
    from pkmstiff.kinematics.rotation import cardan_matrix

    x = setup.placing_pose[None, :]
    reached = x if not np.any(delta[params.chain >= 0]) else reached_poses(machine, params, delta, x)
    st = perturbed_state(setup, params, delta)
    R = cardan_matrix(reached[:, 3], reached[:, 4], reached[:, 5])[0]
    return reached[0, :3] + R @ st.target


def actual_state(machine: Machine, params: ParameterSet, delta: np.ndarray, setup: Setup) -> SetupState:
    """The actual set-up (:func:`~pkmstiff.calibration.perturb.perturbed_state`) with a machine-placed fixed ball
    moved to where the machine with errors ``delta`` put it (module docstring)."""
    st = perturbed_state(setup, params, delta)
    if setup.placing_pose is None:
        return st
    shift = placed_ball(machine, params, delta, setup) - placed_ball(machine, params, np.zeros(params.n), setup)
    return dataclasses.replace(st, fixed_ball=st.fixed_ball + shift)


def placed_ball_jacobian(machine: Machine, params: ParameterSet, setup: Setup) -> np.ndarray:
    """∂s/∂p (3, n), SI: how the machine-placed fixed ball moves with the machine's parameters (the target-point
    rows of the identification Jacobian at the placing pose) and with the ball offset Δv (R_c e); 0 for the
    other set-up parameters (the fixed-ball parameter Δs has its own column)."""
    from pkmstiff.calibration.instruments import TRACKER
    from pkmstiff.calibration.jacobian import identification_jacobian
    from pkmstiff.kinematics.rotation import cardan_matrix

    mach = np.flatnonzero(params.chain >= 0)
    sub = _subset(params, mach)
    probe = Plan("placing pose", Setup(TRACKER, target=setup.target), setup.placing_pose[None, :])
    out = np.zeros((3, params.n))
    out[:, mach] = identification_jacobian(machine, sub, probe).J  # tracker readings: the target point, (3, n)
    Rc = cardan_matrix(*setup.placing_pose[3:])
    for i in np.flatnonzero(np.asarray(params.blocks) == "ball_offset"):
        out[:, i] = Rc @ params.axis[i]
    return out


__all__ = ["PlanSet", "actual_state", "moved_plan", "part_parameters", "parts", "placed_ball", "placed_ball_jacobian",
           "setup_prefix", "setups_error_model", "setups_of"]


def moved_plan(plan: Plan, fixed_ball: np.ndarray, placed_by_machine: bool = False) -> Plan:
    """``plan`` (one set-up with a fixed ball) moved rigidly so that its fixed ball lies at ``fixed_ball`` (m):
    the same path and orientations about the new ball (``calibrate identifiability --fixed-ball``).
    ``placed_by_machine``: the machine places that ball, with the plan's target point at it and zero
    orientation (:attr:`~pkmstiff.calibration.instruments.Setup.placing_pose`)."""
    from pkmstiff.calibration.plans import poses_for_target

    st = plan.setup
    if st.fixed_ball is None:
        raise InputError(plan.name, "fixed_ball", "a ball-bar plan (a fixed ball to move)", st.instrument.kind)
    c = np.asarray(fixed_ball, dtype=float).reshape(3)
    place = poses_for_target(c[None, :], np.eye(3)[None], st.target)[0] if placed_by_machine else None
    shift = np.r_[c - st.fixed_ball, np.zeros(3)]
    name = f"{plan.name} about ({', '.join(f'{v * 1e3:g}' for v in c)}) mm"
    return Plan(name, dataclasses.replace(st, fixed_ball=c, placing_pose=place), plan.poses + shift,
                plan.segments)
