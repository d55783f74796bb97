"""Point evaluations of the public API: everything ``pkmstiff point`` reports, for one pose or a batch of poses.

Per chunk of at most :data:`CHUNK` poses: one pose evaluation (:func:`~pkmstiff.admissibility.evaluate_poses`:
inverse kinematics, Jacobians, joint angles, admissibility) serving one structure model
(:func:`~pkmstiff.structure.build_structure`: the TCP compliance (docs/theory/structure.md), the weak points and the
modal analysis) and the kinetostatics (docs/theory/kinetostatics.md). SI units in the arrays;
:meth:`PointResults.to_pandas` converts to display units named in the column names.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.kinematics import as_poses
from pkmstiff.machine.frames import frame_metadata, from_machine_frame, to_machine_frame

if TYPE_CHECKING:
    import pandas

    from pkmstiff.api.machine import StudyMachine

#: poses per structure model: bounds the working set (measured on the Hexaglide with modes, weak points and
#: kinetostatics: about 230 MB peak for one chunk of 2048 poses)
CHUNK = 2048


@dataclass
class PointResults:
    """Results at N poses (SI units; NaN where a pose could not be modelled).

    ``stiffness`` (N, 6): k_x, k_y, k_z [N/m], k_rx, k_ry, k_rz [N·m/rad] (1/C_jj of the TCP compliance);
    ``weak_points[direction][component]`` (N,): share of the TCP compliance for a unit force along ``direction``
    (fraction, sums to 1 over the components); ``mode_descriptions`` (per pose and mode, made on first use);
    ``mode_kinetic[body]`` and ``mode_strain[component]`` (N, n_modes):
    each mode's kinetic and strain energy shares (fractions); ``quantities[name]`` (N,): the requested registered
    quantities in SI (display unit in ``units``); ``v_max`` [m/s] and ``a_max`` [m/s²] (N, directions) with their
    labels; ``drive_loads`` (N, chains) static drive loads [N]. ``poses`` are in ``frame`` (as given).
    ``mode_axis_direction`` (N, n_modes, 3), ``mode_axis_point`` (N, n_modes, 3) [m, in ``frame``] and
    ``mode_axis_pitch`` (N, n_modes) [m/rad]: the platform's instantaneous screw axis in each mode (a rotation about
    the axis through ``point`` along ``direction`` plus ``pitch`` times it along the axis; ``point`` is the axis
    point nearest the platform's reference point; NaN for a pure translation; :func:`pkmstiff.multibody.mode_axes`).
    """

    machine: str
    frame: dict[str, Any]
    poses: np.ndarray  # (N, 6) m, rad, in ``frame``
    tool_length: float  # m
    admissible: np.ndarray  # (N,) bool
    reason_bits: np.ndarray  # (N,) failing admissibility checks as Reason bits (pkmstiff.admissibility.checks.Reason)
    modelled: np.ndarray  # (N,) bool
    compliance: np.ndarray  # (N, 6, 6) SI
    stiffness: np.ndarray  # (N, 6) N/m, N m/rad
    frequencies_hz: np.ndarray  # (N, n_modes) Hz
    mode_kinetic: dict[str, np.ndarray]  # body -> (N, n_modes) share of the mode's kinetic energy (fraction)
    mode_strain: dict[str, np.ndarray]  # component -> (N, n_modes) share of the mode's strain energy (fraction)
    weak_points: dict[str, dict[str, np.ndarray]]
    transmission_quality: np.ndarray  # (N,)
    velocity_labels: list[str]
    v_max: np.ndarray  # (N, len(velocity_labels)) m/s
    acceleration_labels: list[str]
    a_max: np.ndarray  # (N, len(acceleration_labels)) m/s^2
    drive_loads: np.ndarray  # (N, n_chains) N
    mode_axis_direction: np.ndarray  # (N, n_modes, 3) unit vector
    mode_axis_point: np.ndarray  # (N, n_modes, 3) m, in ``frame``
    mode_axis_pitch: np.ndarray  # (N, n_modes) m/rad
    quantities: dict[str, np.ndarray] = field(default_factory=dict)  # name -> (N,) SI, NaN where inadmissible
    units: dict[str, str] = field(default_factory=dict)  # name -> display unit of ``quantities``
    notes: list[str] = field(default_factory=list)
    _admissibility: list[Any] = field(default_factory=list, repr=False)  # per chunk, for the texts of ``reasons``
    _modal: list[tuple[int, Any]] = field(default_factory=list, repr=False)  # per chunk: (poses, ModalAnalysis|None)

    def __len__(self) -> int:
        return len(self.poses)

    @cached_property
    def reasons(self) -> list[list[str]]:
        """Per pose: the failing admissibility checks as text, naming the chains involved (empty if admissible)."""
        return [adm.failing(i) for adm in self._admissibility for i in range(len(adm.ok))]

    @cached_property
    def mode_descriptions(self) -> list[list[str]]:
        """Per pose and mode: the platform motion, e.g. ``'translation along y (58 %)'`` (``'n/a'`` if not modelled)."""
        k = self.frequencies_hz.shape[1]
        return [[ma.description(i, j) for j in range(k)] if ma is not None else ["n/a"] * k
                for n, ma in self._modal for i in range(n)]

    def to_pandas(self) -> "pandas.DataFrame":
        """One row per pose; column names carry their unit (``x_mm``, ``kx_N_per_um``, ``f1_Hz``,
        ``share_x_drive_joint_percent``, ``vmax_x_m_per_min``, ``drive_load_1_N``); ``admissible`` and
        ``reasons`` (``"; "``-joined) state the admissibility. The frame is in ``DataFrame.attrs``."""
        import pandas

        cols: dict[str, Any] = {}
        for i, ax in enumerate("xyz"):
            cols[f"{ax}_mm"] = self.poses[:, i] * 1e3
        for i, ax in enumerate("abc"):
            cols[f"{ax}_deg"] = np.degrees(self.poses[:, 3 + i])
        cols["admissible"] = self.admissible
        cols["reasons"] = ["; ".join(r) for r in self.reasons] if (~self.admissible).any() else [""] * len(self)
        for i, ax in enumerate("xyz"):
            cols[f"k{ax}_N_per_um"] = self.stiffness[:, i] / 1e6
        for i, ax in enumerate("xyz"):
            cols[f"kr{ax}_Nm_per_urad"] = self.stiffness[:, 3 + i] / 1e6
        for j in range(self.frequencies_hz.shape[1]):
            cols[f"f{j + 1}_Hz"] = self.frequencies_hz[:, j]
        for d, shares in self.weak_points.items():
            for label, share in shares.items():
                cols[f"share_{d}_{label}_percent"] = 100.0 * share
        if self.velocity_labels:  # kinetostatics evaluated
            cols["transmission_quality"] = self.transmission_quality
        for j, lab in enumerate(self.velocity_labels):
            cols[f"vmax_{lab}_m_per_min"] = 60.0 * self.v_max[:, j]
        for j, lab in enumerate(self.acceleration_labels):
            cols[f"amax_{lab}_m_per_s2"] = self.a_max[:, j]
        for j in range(self.drive_loads.shape[1]):
            cols[f"drive_load_{j + 1}_N"] = self.drive_loads[:, j]
        from pkmstiff.evaluation.quantities import get_quantity

        for name, vals in self.quantities.items():
            unit = self.units[name].replace("/", "_per_")
            cols[name if unit == "1" else f"{name}_{unit}"] = get_quantity(name).to_display(vals)
        df = pandas.DataFrame(cols)
        df.attrs.update({"machine": self.machine, **self.frame, "tool_length_mm": self.tool_length * 1e3})
        return df

    def statistics(self) -> dict[str, dict[str, float]]:
        """Per numeric column of :meth:`to_pandas` (display units, named in the column): min, mean, max and count
        over the admissible poses."""
        df = self.to_pandas()
        ok = df[df["admissible"]].drop(columns=["admissible", "reasons"])
        return {c: {"min": float(ok[c].min()), "mean": float(ok[c].mean()), "max": float(ok[c].max()),
                    "count": int(ok[c].count())} for c in ok.columns}

    def plot(self, column: str = "kx_N_per_um", against: str | None = None, path: str | None = None):
        """A line plot of one :meth:`to_pandas` column over the pose index or over another column (``against``,
        e.g. ``"z_mm"``); inadmissible poses are left out. Returns the matplotlib ``Figure``; ``path`` also writes a
        PNG."""
        from matplotlib.figure import Figure

        df = self.to_pandas()
        if column not in df.columns or (against is not None and against not in df.columns):
            raise KeyError(f"expected a column of to_pandas() {list(df.columns)}, found {column!r} / {against!r}")
        ok = df[df["admissible"]]
        fig = Figure(figsize=(6.4, 4.0), layout="constrained")
        ax = fig.add_subplot()
        ax.plot(ok.index if against is None else ok[against], ok[column], marker="o", ms=3)
        ax.set_xlabel("pose" if against is None else against)
        ax.set_ylabel(column)
        ax.set_title(f"{self.machine} ({self.frame['frame']} frame)")
        ax.grid(alpha=0.3)
        if path is not None:
            fig.savefig(path, dpi=110)
        return fig


def _quantities(machine: "StudyMachine", ev: Any, names: tuple[str, ...], tool_length: float | None
                ) -> dict[str, np.ndarray]:
    """Registered quantities (SI) at the admissible poses of ``ev``, NaN elsewhere (as on a section)."""
    from pkmstiff.evaluation.quantities import EvalContext, evaluate_quantities

    out = {n: np.full(len(ev.poses), np.nan) for n in names}
    if names and ev.ok.any():
        sub = ev if ev.ok.all() else ev.subset(ev.ok)
        vals = evaluate_quantities(EvalContext(machine, sub, tool_length, {}), list(names))
        for n in names:
            out[n][ev.ok] = np.asarray(vals[n], float)
    return out


def evaluate_points(machine: "StudyMachine", poses: ArrayLike, frame: str = "machine",
                    tool_length: float | None = None, n_modes: int = 6,
                    weak_point_directions: tuple[str, ...] = ("x", "y", "z"), quantities: tuple[str, ...] = (),
                    structure: dict[str, Any] | None = None,
                    with_kinetostatics: bool = True, checks: tuple[str, ...] | None = None) -> PointResults:
    """:class:`PointResults` at ``poses`` ((6,) or (N, 6): x, y, z [m] of O' in ``frame``, a, b, c [rad]), chunked
    by :data:`CHUNK` poses. ``tool_length`` [m] (None: the machine's; K_U as the machine's ``spindle_neglected``
    says); ``structure``: fields of
    :class:`~pkmstiff.structure.StructureOptions`; ``with_kinetostatics=False`` leaves the kinetostatics out (NaN,
    no direction labels); ``checks``: the admissibility checks (None: all)."""
    from pkmstiff.admissibility import evaluate_poses
    from pkmstiff.analysis import kinetostatics, modal_analysis, tcp_compliance, weak_points
    from pkmstiff.evaluation.quantities import get_quantity
    from pkmstiff.multibody import dynamic_dofs
    from pkmstiff.structure import StructureOptions, build_structure

    units = {n: get_quantity(n).unit for n in quantities}  # unknown names fail before any work
    options = StructureOptions(**structure) if structure else None
    given = as_poses(np.atleast_2d(np.asarray(poses, float)))
    x = to_machine_frame(machine, given, frame)
    parts: list[dict[str, Any]] = []
    for s in range(0, len(x), CHUNK):
        chunk = x[s:s + CHUNK]
        ev = evaluate_poses(machine, chunk) if checks is None else evaluate_poses(machine, chunk, checks=checks)
        adm = ev.admissibility
        st = build_structure(machine, ev, options)  # the chunk's one evaluation: no second inverse kinematics
        comp = tcp_compliance(st, tool_length)
        wp = {d: weak_points(st, d, tool_length) for d in weak_point_directions}
        k = 0 if st.empty else min(n_modes, dynamic_dofs(st.model))
        ma = modal_analysis(st, k, shapes=False) if k else None
        parts.append({
            "ok": adm.ok, "adm": adm, "modelled": st.ok,
            "comp": comp, "ma": ma, "wp": wp, "ks": kinetostatics(machine, ev) if with_kinetostatics else None,
            "q": _quantities(machine, ev, quantities, tool_length)})
    ks0 = parts[0]["ks"]

    def kin(key: str, *width: int) -> np.ndarray:
        """A kinetostatics array over all chunks; NaN of shape (N, *width) where it was not evaluated."""
        if ks0 is None:
            return np.full((len(x), *width), np.nan)
        return np.concatenate([getattr(p["ks"], key) for p in parts])

    comp = np.concatenate([p["comp"] for p in parts])
    with np.errstate(divide="ignore", invalid="ignore"):
        stiffness = 1.0 / np.diagonal(comp, axis1=1, axis2=2)
    n_f = max((0 if p["ma"] is None else p["ma"].frequencies_hz.shape[1]) for p in parts)

    def modal(key: str, *width: int) -> np.ndarray:
        """A per-mode array of the modal analyses over all chunks, (N, n_modes, *width); NaN where not evaluated."""
        return np.concatenate([np.full((len(p["ok"]), n_f, *width), np.nan) if p["ma"] is None
                               else getattr(p["ma"], key) for p in parts])

    freqs = modal("frequencies_hz")

    def energy(labels: str, values: str) -> dict[str, np.ndarray]:
        """Per body (kinetic) or component (strain): the share of each mode's energy over all chunks, (N, n_modes)."""
        first = next((p["ma"] for p in parts if p["ma"] is not None), None)
        if first is None:
            return {}
        return {lab: np.concatenate([np.full((len(p["ok"]), n_f), np.nan) if p["ma"] is None
                                     else getattr(p["ma"], values)[:, :, j] for p in parts])
                for j, lab in enumerate(getattr(first, labels))}

    shares = {d: {lab: np.concatenate([p["wp"][d].component_shares[:, j] for p in parts])
                  for j, lab in enumerate(parts[0]["wp"][d].component_labels)} for d in weak_point_directions}
    return PointResults(
        machine=machine.name, frame=frame_metadata(machine, frame), poses=given,
        tool_length=machine.tool.length if tool_length is None else float(tool_length),
        admissible=np.concatenate([p["ok"] for p in parts]),
        reason_bits=np.concatenate([p["adm"].reasons for p in parts]),
        modelled=np.concatenate([p["modelled"] for p in parts]), compliance=comp, stiffness=stiffness,
        frequencies_hz=freqs, weak_points=shares,
        mode_kinetic=energy("body_labels", "kinetic"), mode_strain=energy("component_labels", "component_strain"),
        transmission_quality=kin("transmission_quality"),
        velocity_labels=[] if ks0 is None else list(ks0.velocity_labels), v_max=kin("v_max", 0),
        acceleration_labels=[] if ks0 is None else list(ks0.acceleration_labels), a_max=kin("a_max", 0),
        drive_loads=kin("drive_loads", machine.n_chains), mode_axis_direction=modal("axis_direction", 3),
        mode_axis_point=from_machine_frame(machine, modal("axis_point", 3), frame), mode_axis_pitch=modal("axis_pitch"),
        quantities={n: np.concatenate([p["q"][n] for p in parts]) for n in quantities}, units=units,
        notes=[] if ks0 is None else list(ks0.notes), _admissibility=[p["adm"] for p in parts],
        _modal=[(len(p["ok"]), p["ma"]) for p in parts])
