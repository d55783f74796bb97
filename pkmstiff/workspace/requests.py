"""Workspace evaluation requests (SI units), the workspace layer's part of the request model of
:mod:`pkmstiff.evaluation.requests`."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from pkmstiff.admissibility.checks import checks_without
from pkmstiff.evaluation.cost import STRUCTURE_GROUPS, Cost, octree_pilot_halvings, workspace_cost
from pkmstiff.machine.frames import check_frame, frame_metadata, neglect_spindle, to_machine_frame
from pkmstiff.machine.model import Machine
from pkmstiff.workspace.requirements import parse_requirements
from pkmstiff.workspace.rotation import RotationMapResult, rotation_angle_map
from pkmstiff.workspace.translational import WorkspaceResult, constant_orientation_workspace


@dataclass(frozen=True)
class WorkspaceRequest:
    """Constant-orientation workspace by the modified octree (docs/theory/workspace.md, Cobet §7.3).

    ``box`` = (lo, hi) in m or None (the chains' reach box); ``requirements`` as in ``pkmstiff workspace
    --require``; ``methods`` volume methods of :data:`pkmstiff.workspace.volume.METHODS`.
    """

    resolution: float  # m
    box: tuple[Any, Any] | None = None  # (lo (3,), hi (3,)) m
    requirements: tuple[str, ...] = ()
    orientation: tuple[float, float, float] = (0.0, 0.0, 0.0)  # rad
    methods: tuple[str, ...] = ("surface_nets",)
    frame: str = "machine"  # frame of ``box``; the result's summary gives positions in it too
    neglect_spindle: bool = False  # leave K_U out (stiffness requirements)
    skip_checks: tuple[str, ...] = ()  # admissibility checks left out (names of ALL_CHECKS)

    def evaluate(self, machine: Machine, **options: Any) -> WorkspaceResult:
        """``options`` are passed to :func:`constant_orientation_workspace` (progress, refine_steps, ...)."""
        check_frame(self.frame)
        checks = checks_without(self.skip_checks, "WorkspaceRequest")
        machine = neglect_spindle(machine, self.neglect_spindle)
        box = None if self.box is None else (to_machine_frame(machine, self.box[0], self.frame),
                                             to_machine_frame(machine, self.box[1], self.frame))
        res = constant_orientation_workspace(machine, self.resolution, self.orientation,
                                             requirements=self.requirements, box=box, methods=self.methods,
                                             checks=checks, **options)
        res.frame = frame_metadata(machine, self.frame)
        res.settings["neglect_spindle"] = self.neglect_spindle
        return res

    def cost(self, machine: Machine, orientations: int = 1, **options: Any) -> Cost:
        """The :class:`~pkmstiff.evaluation.cost.Cost` of :meth:`evaluate` by the octree's growth law: evaluations
        ×4 per halving of eps (the boundary area over eps²). Large runs are extrapolated from a pilot run at
        ``eps·2^k`` of about :data:`~pkmstiff.evaluation.cost.OCTREE_PILOT_EVALUATIONS` evaluations (≤ 1/16 of the
        run), which measures the machine's own boundary area; small ones use the reach box's surface.
        ``orientations``: orientations checked per point (a range); ``options`` as for :meth:`evaluate`."""
        from pkmstiff.evaluation.quantities import get_quantity
        from pkmstiff.workspace.translational import reach_box

        lo, hi = self.box if self.box is not None else reach_box(neglect_spindle(machine, self.neglect_spindle))
        extent = np.asarray(hi, float) - np.asarray(lo, float)
        structure = any(get_quantity(r.quantity).group in STRUCTURE_GROUPS
                        for r in parse_requirements(self.requirements))
        k = octree_pilot_halvings(extent, self.resolution, orientations)
        pilot = None
        if k:
            eps_p = self.resolution * 2.0 ** k
            options = {key: v for key, v in options.items() if key != "progress"}
            res = replace(self, resolution=eps_p, methods=("surface_nets",)).evaluate(machine, **options)
            pilot = (eps_p, res.octree.evaluations)
        return workspace_cost(extent, self.resolution, orientations, structure, pilot)


@dataclass(frozen=True)
class RotationMapRequest:
    """Maximum admissible rotation angles on a section raster origin + u·u_axis + v·v_axis (m; Cobet §7.4)."""

    origin: tuple[float, float, float]  # m
    u_axis: tuple[float, float, float]
    v_axis: tuple[float, float, float]
    u_values: tuple[float, ...]  # m
    v_values: tuple[float, ...]  # m
    directions: tuple[str, ...] = ("+a",)
    base_orientation: tuple[float, float, float] = (0.0, 0.0, 0.0)  # rad
    increment: float = math.radians(1.0)  # rad
    max_angle: float = math.radians(90.0)  # rad
    requirements: tuple[str, ...] = ()
    method: str = "predictor_corrector"
    frame: str = "machine"  # frame of ``origin`` (the raster's u, v values are offsets along the axes)
    neglect_spindle: bool = False  # leave K_U out (stiffness requirements)
    skip_checks: tuple[str, ...] = ()  # admissibility checks left out (names of ALL_CHECKS)

    def evaluate(self, machine: Machine, **options: Any) -> RotationMapResult:
        check_frame(self.frame)
        checks = checks_without(self.skip_checks, "RotationMapRequest")
        machine = neglect_spindle(machine, self.neglect_spindle)
        origin = to_machine_frame(machine, self.origin, self.frame)
        res = rotation_angle_map(machine, origin, self.u_axis, self.v_axis, self.u_values, self.v_values,
                                 self.base_orientation, list(self.directions), self.increment, self.max_angle,
                                 requirements=self.requirements, method=self.method, checks=checks,
                                 **options)
        res.settings.update(frame_metadata(machine, self.frame))
        res.settings["neglect_spindle"] = self.neglect_spindle
        return res
