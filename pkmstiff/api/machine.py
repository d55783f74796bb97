"""The machine of the public API: the frozen machine model plus the few methods a design study scripts.

:class:`StudyMachine` *is* a :class:`pkmstiff.machine.Machine` (a subclass that adds methods, no data), so every
library function that takes a machine takes it; ``pkmstiff.load_machine`` returns one. Its methods call the library's
high-level functions (:func:`~pkmstiff.evaluation.sections.evaluate_section`, :func:`~pkmstiff.structure.build_structure`,
:class:`~pkmstiff.workspace.requests.WorkspaceRequest`, ...) and wrap their results in the objects of
:mod:`pkmstiff.api.results`, which convert to xarray and pandas. SI units in and out (m, rad, N/m); every result states
its frame (``"machine"``: the machine file's coordinate system, ``"report"``: shifted to the machine's report origin,
the frame the dissertation quotes positions in).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.machine import Machine
from pkmstiff.machine import load_machine as _load_model
from pkmstiff.machine.frames import check_frame
from pkmstiff.machine.frames import neglect_spindle as _neglect_spindle

if TYPE_CHECKING:
    from pkmstiff.api.points import PointResults
    from pkmstiff.api.results import RotationMap, SectionMap, Workspace
    from pkmstiff.machine.roles import MachineComponents

#: the quantities a section evaluates when none are named
DEFAULT_SECTION_QUANTITIES = ("kx", "ky", "kz", "f1")


def _checks(skip_checks: Sequence[str]) -> tuple[str, ...]:
    """The admissibility checks to apply: :data:`pkmstiff.admissibility.checks.ALL_CHECKS` without ``skip_checks``
    (an unknown name is an :class:`~pkmstiff.errors.InputError` naming the known ones)."""
    from pkmstiff.admissibility.checks import checks_without

    return checks_without(skip_checks, "pkmstiff.api", "skip_checks")


#: fields that :func:`~pkmstiff.machine.frames.neglect_spindle` sets (``with_`` handles them itself)
_SPINDLE_FIELDS = frozenset({"machine_components", "spindle_neglected"})
#: fields whose values are tied to the component instances built on load: a change made to them outside ``with_``
#: cannot be carried onto a rebuilt variant (its instances would not match)
_BUILT_FIELDS = frozenset({"components", "chain_components"})


def _same(a: Any, b: Any) -> bool:
    """Value equality of machine fields (dataclasses, dicts, sequences, numpy arrays; NaN equals NaN)."""
    if a is b:
        return True
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        return type(a) is type(b) and all(_same(getattr(a, f.name), getattr(b, f.name))
                                          for f in dataclasses.fields(a) if f.compare)
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.shape(a) == np.shape(b) and bool(np.array_equal(a, b, equal_nan=True))
    if isinstance(a, (list, tuple)):
        return isinstance(b, (list, tuple)) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return bool(a == b)


def _changed_fields(machine: Machine, reference: Machine) -> list[str]:
    """Names of the compared fields of ``machine`` whose values differ from ``reference``'s."""
    return [f.name for f in dataclasses.fields(Machine)
            if f.compare and f.name not in _SPINDLE_FIELDS and not _same(getattr(machine, f.name),
                                                                         getattr(reference, f.name))]


@dataclass(frozen=True)
class StudyMachine(Machine):
    """A loaded machine with the design-study methods :meth:`point`, :meth:`section`, :meth:`workspace`,
    :meth:`rotation_map` and :meth:`with_` (all SI: m, rad).

    ``file_changes``: the machine-file changes (dotted key -> value) that :meth:`with_` applied to the machine file
    to make this variant (empty for a machine as loaded); the next :meth:`with_` starts from them.
    """

    file_changes: Mapping[str, Any] = dataclasses.field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def of(cls, machine: Machine, file_changes: Mapping[str, Any] | None = None) -> "StudyMachine":
        """The same machine (same field values, shared component instances) with the study methods."""
        if isinstance(machine, cls) and (file_changes is None or _same(dict(file_changes), machine.file_changes)):
            return machine
        return cls(**{f.name: getattr(machine, f.name) for f in dataclasses.fields(Machine)},
                   file_changes=dict(file_changes or {}))

    def components_by_role(self) -> "MachineComponents":
        """The component instances by role (``.drive[i]``, ``.strut[i]``, ``.drive_joint[i]``, ``.platform``, ...;
        None where a role is rigid or absent); each has the methods of :mod:`components` (``stiffness(state)``,
        ...)."""
        from pkmstiff.machine.roles import machine_components

        return machine_components(self)

    def with_(self, components: Mapping[str, Mapping[str, Any]] | None = None, options: Sequence[str] = (),
              overrides: Mapping[str, Any] | None = None, neglect_spindle: bool | None = None) -> "StudyMachine":
        """A variant of this machine, validated like a machine file.

        ``components``: component instance name -> {parameter: value} (values as in the machine file, e.g.
        ``{"drive": {"stiffness": "300 N/um"}}``); ``options``: ``[options.NAME]`` tables of the machine file to
        apply; ``overrides``: any other dotted machine-file key -> value (``{"tool.length": "150 mm"}``);
        ``neglect_spindle``: leave out (True) or keep (False) the platform-spindle stiffness K_U (Cobet 4.2.4).

        Changes compose: the variant is rebuilt from the machine file with this machine's options and
        :attr:`file_changes` plus the new ones (a later value of a key wins). A field changed outside ``with_``
        (``dataclasses.replace``) is carried onto the variant when the new changes leave it as the file gives it;
        where they change it too, or where it holds component data, this is an
        :class:`~pkmstiff.errors.InputError` (one line) instead of a variant that silently loses the change.
        """
        from pkmstiff.errors import InputError
        from pkmstiff.machine.variants import machine_with

        changes = dict(overrides or {})
        for name, params in (components or {}).items():
            changes.update({f"components.{name}.{key}": value for key, value in params.items()})
        neglect = self.spindle_neglected if neglect_spindle is None else neglect_spindle
        if not (changes or options or (self.spindle_neglected and not neglect)):
            return StudyMachine.of(_neglect_spindle(self, neglect), self.file_changes)
        loaded = self.name.split(":", 1)[1].split(",") if ":" in self.name else []
        source = self.path or self.name
        as_made = _neglect_spindle(machine_with(source, self.file_changes, loaded), self.spindle_neglected)
        edited = _changed_fields(self, as_made)  # changed outside with_ (dataclasses.replace)
        merged = {**self.file_changes, **changes}
        model = machine_with(source, merged, [*loaded, *options])
        if edited:
            clash = [f for f in edited if f in _BUILT_FIELDS or not _same(getattr(model, f), getattr(as_made, f))]
            if clash:
                raise InputError(f"{self.name} (StudyMachine.with_)", ", ".join(clash),
                                 "a field changed either by with_ or by dataclasses.replace, not both (make every "
                                 "change with with_)", "changed by dataclasses.replace and by this with_ call")
            model = dataclasses.replace(model, **{f: getattr(self, f) for f in edited})
        return StudyMachine.of(_neglect_spindle(model, neglect), merged)

    def point(self, poses: ArrayLike, frame: str = "machine", tool_length: float | None = None, n_modes: int = 6,
              weak_point_directions: Sequence[str] = ("x", "y", "z"), quantities: Sequence[str] = (),
              neglect_spindle: bool | None = None, structure: Mapping[str, Any] | None = None,
              kinetostatics: bool = True, skip_checks: Sequence[str] = ()) -> "PointResults":
        """Stiffness at the TCP, natural frequencies with their energy shares, weak points, kinetostatics and
        admissibility at one pose (6,) or many poses (N, 6): x, y, z [m] of O' in ``frame``, a, b, c [rad].

        ``tool_length`` [m] (None: the machine's); ``quantities``: further registered quantities
        (:func:`pkmstiff.evaluation.quantities.available_quantities`, e.g. ``"tilt_drive_1"``) at the admissible
        poses; ``neglect_spindle``: True/False evaluates the machine with K_U left out/kept (as
        ``with_(neglect_spindle=...)``; None: as the machine says);
        ``structure``: modelling choices of the structure model (fields of
        :class:`pkmstiff.structure.StructureOptions`, e.g. ``{"strut_mass_to_drive": 0.5}``). Evaluated in chunks
        of bounded memory. ``skip_checks`` as in :meth:`section`. ``n_modes=0``, ``weak_point_directions=()`` and ``kinetostatics=False`` leave those analyses
        out (for fast stiffness-only batches).
        """
        from pkmstiff.api.points import evaluate_points

        machine = self if neglect_spindle is None else self.with_(neglect_spindle=neglect_spindle)
        return evaluate_points(machine, poses, frame=check_frame(frame), tool_length=tool_length, n_modes=n_modes,
                               weak_point_directions=tuple(weak_point_directions), quantities=tuple(quantities),
                               structure=dict(structure or {}), with_kinetostatics=kinetostatics,
                               checks=_checks(skip_checks))

    def frame_description(self, frame: str) -> str:
        """One line naming ``frame`` and its origin, e.g. ``report frame (origin 0, 400, 0 mm in the machine frame:
        middle guide)``."""
        from pkmstiff.machine.frames import frame_text

        return frame_text(self, check_frame(frame))

    def to_machine_frame(self, positions: ArrayLike, frame: str) -> np.ndarray:
        """Positions (..., 3) or poses (..., 6) given in ``frame`` → the same in the machine frame [m]."""
        from pkmstiff.machine.frames import to_machine_frame

        return to_machine_frame(self, positions, check_frame(frame))

    def admissibility(self, poses: ArrayLike, frame: str = "machine", skip_checks: Sequence[str] = ()
                      ) -> tuple[np.ndarray, list[list[str]]]:
        """Admissibility only (no structure model): (N,) bool and, per pose, the failing checks, for poses (6,) or
        (N, 6) in ``frame``; ``skip_checks`` as in :meth:`section`."""
        from pkmstiff.admissibility import evaluate_poses

        x = self.to_machine_frame(np.atleast_2d(np.asarray(poses, float)), frame)
        adm = evaluate_poses(self, x, checks=_checks(skip_checks)).admissibility
        return np.asarray(adm.ok, bool), [adm.failing(i) for i in range(len(x))]

    def orientation_map(self, point: ArrayLike, direction: str = "+a",
                        u_values: ArrayLike = np.radians(np.arange(-30.0, 30.1, 2.0)),
                        v_values: ArrayLike = np.radians(np.arange(-60.0, 60.1, 4.0)), frame: str = "machine",
                        increment: float = np.radians(1.0), max_angle: float = np.radians(90.0)) -> Any:
        """The rotational workspace at ``point`` (x, y, z [m] in ``frame``; Cobet §7.4): the largest admissible
        angle [rad] in ``direction`` (``"+a"``: over u = b, v = c; ``"+b"``: over u = a, v = c; raster values in
        rad). Returns :class:`pkmstiff.workspace.rotation.RotationMapResult` (``.angles[direction]`` (nv, nu) rad,
        NaN where the base orientation is inadmissible; ``.summary()`` with units)."""
        from pkmstiff.workspace.rotation import rotational_workspace_map

        return rotational_workspace_map(self, self.to_machine_frame(point, frame), direction, u_values=u_values,
                                        v_values=v_values, increment=increment, max_angle=max_angle)

    def plot_mode_shape(self, pose: ArrayLike, path: str | Path, mode: int = 1, frame: str = "machine",
                        amplitude: float = 0.08, animate: bool = False, frames: int = 16) -> Path:
        """PNG (or with ``animate`` an animated GIF of ``frames`` frames) of mode ``mode`` at ``pose`` (6,) in
        ``frame`` over the undeformed machine, displacements scaled to ``amplitude`` [m] peak."""
        from pkmstiff.plots.modes import animate_mode_shape, plot_mode_shape

        x = self.to_machine_frame(pose, frame)
        if animate:
            return animate_mode_shape(self, x, path, mode=mode, amplitude=amplitude, frames=frames)
        return plot_mode_shape(self, x, path, mode=mode, amplitude=amplitude)

    def section(self, plane: str = "yz", at: float = 0.0, step: float = 0.01,
                quantities: Sequence[str] = DEFAULT_SECTION_QUANTITIES, *, u_range: tuple[float, float] | None = None,
                v_range: tuple[float, float] | None = None, orientation: Iterable[float] = (0.0, 0.0, 0.0),
                tool_length: float | None = None, frame: str = "machine", skip_checks: Sequence[str] = (),
                n_jobs: int = 1, progress: bool | None = False) -> "SectionMap":
        """Quantities (:func:`pkmstiff.evaluation.quantities.available_quantities`) on the axis plane ``plane``
        (``"yz"``, ``"xz"``, ``"xy"``) at ``at`` [m] along its normal, raster ``step`` [m], masked by admissibility.

        ``u_range``/``v_range`` [m] bound the window along the plane's two axes (in ``frame``); omitted, the window
        is fitted to the workspace on the plane (as ``pkmstiff section`` does). ``orientation`` (a, b, c) [rad]
        is fixed over the plane; ``tool_length`` [m] (None: the machine's); ``skip_checks``: names of admissibility
        checks left out (of :data:`pkmstiff.ALL_CHECKS`; the result's settings say so).
        """
        from pkmstiff.api.results import SectionMap
        from pkmstiff.evaluation.sections import evaluate_section

        ori = tuple(float(v) for v in orientation)
        checks = _checks(skip_checks)
        res = evaluate_section(self, self._plane(plane, at, step, u_range, v_range, ori, frame, checks),
                               list(quantities), orientation=ori, tool_length=tool_length, n_jobs=n_jobs,
                               progress=progress, frame=check_frame(frame), checks=checks)
        return SectionMap(res)

    def _plane(self, plane: str, at: float, step: float, u_range: tuple[float, float] | None,
               v_range: tuple[float, float] | None, orientation: Iterable[float], frame: str,
               checks: Sequence[str] | None = None) -> Any:
        """The axis plane of a section or rotation map; a range not given is fitted to the region where
        ``checks`` (None: all) pass on the plane (:func:`pkmstiff.workspace.windows.window_ranges`, as
        ``pkmstiff section`` does, also with ``--skip-check``)."""
        from pkmstiff.evaluation.sections import axis_plane

        kind = plane.lower()
        if u_range is None or v_range is None:
            from pkmstiff.workspace.windows import window_ranges

            fitted = window_ranges(self, kind, at, step, tuple(orientation), check_frame(frame),
                                   *(() if checks is None else (checks,)))
            u_range = fitted.u_range if u_range is None else u_range
            v_range = fitted.v_range if v_range is None else v_range
        return axis_plane(kind, at, u_range, v_range, step)

    def workspace(self, resolution: float = 0.025, orientation: Iterable[float] = (0.0, 0.0, 0.0), *,
                  box: tuple[ArrayLike, ArrayLike] | None = None, requirements: Sequence[str] = (),
                  skip_checks: Sequence[str] = (), methods: Sequence[str] | None = None,
                  frame: str = "machine", fit_box: bool = False, progress: bool = False) -> "Workspace":
        """The constant-orientation workspace by the modified octree (Cobet §7.3): boundary within ``resolution``
        [m], volumes [m³]. ``box`` = (lo, hi) [m] in ``frame`` (None: the chains' reach box); ``requirements`` as
        ``pkmstiff workspace --require`` (e.g. ``"kx >= 5 N/um"``); ``skip_checks`` as in :meth:`section`; ``methods``:
        volume methods (None: all of :data:`pkmstiff.workspace.volume.DEFAULT_METHODS`); ``fit_box``: grow ``box``
        about its centre to extents resolution·2^k, so that halving reaches exactly ``resolution`` and boxes of
        successive resolutions are nested (the reach box is always fitted)."""
        from pkmstiff.api.results import Workspace
        from pkmstiff.workspace.requests import WorkspaceRequest
        from pkmstiff.workspace.translational import fit_box as fitted
        from pkmstiff.workspace.volume import DEFAULT_METHODS

        if box is not None and fit_box:
            box = fitted(box[0], box[1], resolution)
        req = WorkspaceRequest(resolution=resolution, box=box, requirements=tuple(requirements),
                               orientation=tuple(float(v) for v in orientation),
                               methods=DEFAULT_METHODS if methods is None else tuple(methods), frame=check_frame(frame),
                               skip_checks=tuple(skip_checks))
        return Workspace(req.evaluate(self, progress=progress), self)

    def rotation_map(self, plane: str = "yz", at: float = 0.0, step: float = 0.025, *,
                     u_range: tuple[float, float] | None = None, v_range: tuple[float, float] | None = None,
                     directions: Sequence[str] = ("+a",), base_orientation: Iterable[float] = (0.0, 0.0, 0.0),
                     increment: float = np.radians(1.0), max_angle: float = np.radians(90.0),
                     requirements: Sequence[str] = (), frame: str = "machine") -> "RotationMap":
        """Largest admissible rotation angle [rad] per direction (``"+a"``, ``"-b"``, ...) on an axis-plane raster
        (Cobet §7.4), searched in steps of ``increment`` up to ``max_angle``; window as in :meth:`section`."""
        from pkmstiff.api.results import RotationMap
        from pkmstiff.workspace.requests import RotationMapRequest

        pl = self._plane(plane, at, step, u_range, v_range, base_orientation, frame)
        req = RotationMapRequest(origin=tuple(pl.origin), u_axis=tuple(pl.u_axis), v_axis=tuple(pl.v_axis),
                                 u_values=tuple(pl.u_values), v_values=tuple(pl.v_values),
                                 directions=tuple(directions), base_orientation=tuple(base_orientation),
                                 increment=increment, max_angle=max_angle, requirements=tuple(requirements),
                                 frame=check_frame(frame))
        return RotationMap(req.evaluate(self), pl)


def load_machine(name_or_path: str | Path, options: Iterable[str] = ()) -> StudyMachine:
    """Load a machine by bundled name (``"hexaglide"``, ``"linapod:printed_values"``) or path, with the study methods
    (:class:`StudyMachine`); see :func:`pkmstiff.machine.load_machine`."""
    return StudyMachine.of(_load_model(name_or_path, options))

