"""The app's logic for a mechanism with an ``[elastic]`` table (docs/user-guide/mechanisms.md "Elastic model"),
spatial or planar (``five_bar``): the section map and the point analysis of ``pkmstiff section MECHANISM`` and
``pkmstiff point MECHANISM`` computed by the functions those commands call
(:func:`pkmstiff.mechanisms.section.fit_window`, :func:`~pkmstiff.mechanisms.section.evaluate_section`,
:func:`pkmstiff.mechanisms.stiffness.evaluate_mechanism`), drawn as they draw them
(:func:`pkmstiff.plots.mechanism_section.mechanism_quantity_figure`) and written as they write them
(:func:`pkmstiff.report.mechanism_section.write_mechanism_section`). Units: SI inside; mm and degrees on screen.
"""

from __future__ import annotations

import io
import math
import shlex
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pkmstiff.errors import ArgumentError

if TYPE_CHECKING:
    from pkmstiff.app.session import ModelSettings, SectionChoice
    from pkmstiff.mechanisms.model import Mechanism
    from pkmstiff.mechanisms.section import MechanismSection
    from pkmstiff.mechanisms.solver import Solution
    from pkmstiff.mechanisms.stiffness import MechanismStiffness

MM = 1e3
#: the mechanism PNG's resolution (that of ``pkmstiff section MECHANISM``'s maps)
DPI = 110


def elastic_mechanism(mech: Mechanism) -> Mechanism:
    """``mech`` if it has an ``[elastic]`` table, else one line saying why the app cannot show it."""
    if mech.elastic is None:
        raise ArgumentError(option="machine", expected="a mechanism with an [elastic] table (a stiffness model; see "
                            "docs/user-guide/mechanisms.md, elastic model)", found=f"{mech.name} (none)")
    return mech


def bundled_elastic_mechanisms() -> list[str]:
    """Names of the bundled mechanisms with an ``[elastic]`` table (the app's choices besides the machines)."""
    import tomllib

    from pkmstiff.mechanisms.loader import bundled_mechanism_dir, bundled_mechanisms

    return [n for n in bundled_mechanisms()
            if "elastic" in tomllib.loads((bundled_mechanism_dir() / f"{n}.toml").read_text(encoding="utf-8"))]


def _check_settings(mech: Mechanism, settings: ModelSettings) -> None:
    """The machine-only settings refused for a mechanism, as ``pkmstiff section``/``point`` refuse them."""
    for name, given in (("frame", settings.frame != "machine"), ("neglect spindle", settings.neglect_spindle),
                        ("skip checks", bool(settings.skip_checks))):
        if given:
            raise ArgumentError(option=name, expected=f"the default for a mechanism ('{mech.name}')", found="set")


def _tip(mech: Mechanism, settings: ModelSettings) -> np.ndarray | None:
    from pkmstiff.mechanisms.stiffness import tool_point

    return tool_point(mech, settings.tool_length_mm)


@dataclass
class MechanismSectionView:
    """A computed mechanism section as the app shows it: the map, its PNG and the map axes' pixel box."""

    choice: SectionChoice
    mechanism: Mechanism
    map: MechanismSection
    png: bytes
    size_px: tuple[int, int]
    axes_px: tuple[float, float, float, float]  # left, top, right, bottom, pixels from the top left
    seconds: float

    @property
    def limits_mm(self) -> tuple[float, float, float, float]:
        m = self.map
        return (m.u_values[0] * MM, m.u_values[-1] * MM, m.v_values[0] * MM, m.v_values[-1] * MM)

    @property
    def unit(self) -> str:
        return self.map.units[self.choice.quantity]

    def node_at(self, u_mm: float, v_mm: float) -> tuple[int, int]:
        """(row, column) of the raster point nearest the in-plane position (u, v) [mm]."""
        return (int(np.argmin(np.abs(self.map.v_values * MM - v_mm))),
                int(np.argmin(np.abs(self.map.u_values * MM - u_mm))))

    def value_at(self, row: int, col: int) -> float:
        """The map's value at raster point (row, column) in its display unit (NaN where inadmissible)."""
        return float(self.map.display(self.choice.quantity)[row, col])

    def node_at_pixel(self, x_px: float, y_px: float) -> tuple[int, int] | None:
        """(row, column) of the raster point nearest the PNG pixel (x right, y down), None outside the map axes."""
        from pkmstiff.app.session import node_at_pixel

        return node_at_pixel(self, x_px, y_px)

    def picked_text(self, row: int, col: int) -> str:
        """One line for the picked raster point: its in-plane position [mm] and the map's value there."""
        from pkmstiff.app.session import value_text

        m, (u, v) = self.map, self.choice.plane
        return (f"{u} = {m.u_values[col] * MM:.1f} mm, {v} = {m.v_values[row] * MM:.1f} mm: "
                + value_text(self.choice.quantity, self.value_at(row, col), self.unit))

    def machine_points(self) -> np.ndarray:
        """(nv·nu, 3) raster points [m] in world coordinates (a planar mechanism's plane is z = 0)."""
        m = self.map
        P = plane_points(self.mechanism, m.plane, m.at, m.u_values, m.v_values)
        return np.column_stack([P, np.zeros((len(P), 3 - P.shape[1]))])

    def central_node(self) -> tuple[int, int] | None:
        from pkmstiff.app.session import central_node

        return central_node(self.map.ok)

    def pose_at(self, row: int, col: int) -> np.ndarray:
        """The mechanism's output pose (SI: x, y, z, a, b, c or planar x, y, φ) of raster point (row, column)."""
        from pkmstiff.mechanisms.section import plane_poses

        m = self.map
        return plane_poses(self.mechanism, m.plane, m.at, m.u_values[col:col + 1], m.v_values[row:row + 1],
                           m.orientation)[0]

    def summary(self) -> str:
        ok = self.map.ok
        st = self.map.statistics()[self.choice.quantity]
        rng = f", {self.choice.quantity} {st['min']:.4g} … {st['max']:.4g} {self.unit}" if st["count"] else ""
        return (f"{int(ok.sum())} of {ok.size} points admissible ({float(ok.sum()) * self.map.cell_area:.4g} m²)"
                f"{rng}; computed in {self.seconds:.2f} s")

    def where(self) -> dict:
        from pkmstiff.report.mechanism_section import section_where

        c = self.choice
        return section_where(self.mechanism, c.plane, c.at_mm, self.map.orientation,
                             c.settings.tool_length_mm)

    def write(self, folder: Path) -> list[Path]:
        """The PNG and CSV files ``pkmstiff section MECHANISM --formats png,csv`` writes, into ``folder``."""
        from pkmstiff.io.atomic import safe_stem
        from pkmstiff.report.mechanism_section import write_mechanism_section

        return write_mechanism_section(self.map, folder, f"{safe_stem(self.mechanism.name)}_{self.choice.plane}",
                                       ["png", "csv"], self.where())


def plane_points(mech: Mechanism, plane: str, at: float, u_values: np.ndarray, v_values: np.ndarray) -> np.ndarray:
    """World positions (nv·nu, dim) [m] of the raster points of a section (row-major over v, then u)."""
    from pkmstiff.mechanisms.section import plane_poses

    return plane_poses(mech, plane, at, u_values, v_values, np.zeros(3))[:, :mech.dim]


def app_pose(mech: Mechanism, pose: np.ndarray) -> np.ndarray:
    """The app's six pose values (x, y, z [m], a, b, c [rad]) of a mechanism's output pose: planar (x, y, φ) as
    x, y and a (the map's tool angle a is a planar mechanism's φ, as in ``pkmstiff section``)."""
    if mech.dim == 3:
        return np.asarray(pose, float)
    return np.array([pose[0], pose[1], 0.0, pose[2], 0.0, 0.0])


def mechanism_pose(mech: Mechanism, values: np.ndarray) -> np.ndarray:
    """A mechanism's output pose from the app's six pose values (inverse of :func:`app_pose`)."""
    v = np.asarray(values, float)
    return v.copy() if mech.dim == 3 else np.array([v[0], v[1], v[3]])


def pose_limits(mech: Mechanism) -> tuple[np.ndarray, np.ndarray]:
    """Slider limits of the app's six pose values (mm, deg) for a mechanism: home ± its length scale, ± 60°."""
    home = app_pose(mech, mech.home_output_pose)
    reach = np.array([mech.length_scale * MM] * 3 + [60.0] * 3)
    centre = np.concatenate([home[:3] * MM, np.degrees(home[3:])])
    return centre - reach, centre + reach


@dataclass(frozen=True)
class MechanismAtPose:
    """A mechanism at an output pose (SI) with its configuration (``solution`` of one pose; not ``ok`` where none
    was found): what the app's 3-D view draws."""

    mechanism: Mechanism
    pose: np.ndarray
    solution: Solution

    @property
    def ok(self) -> bool:
        return bool(self.solution.ok[0])

    def pose_values(self) -> np.ndarray:
        """The app's six pose values of the pose (:func:`app_pose`)."""
        return app_pose(self.mechanism, self.pose)

    def world(self) -> dict[int, np.ndarray]:
        """World points [m] of the links (:func:`pkmstiff.plots.sketch.mechanism_world`)."""
        from pkmstiff.plots.sketch import mechanism_world

        return mechanism_world(self.mechanism, self.solution.q[0])

    def title(self) -> str:
        """One line for the view: name, output pose (mm, deg) and, where there is none, that no configuration was
        found."""
        m, p = self.mechanism, self.pose
        n = m.dim
        text = (f"{m.name}: {', '.join('xyz'[:n])} = {', '.join(f'{v * MM:.0f}' for v in p[:n])} mm; "
                + (f"a, b, c = {', '.join(f'{np.degrees(v):.1f}' for v in p[3:6])}°" if n == 3 else
                   f"phi = {np.degrees(p[2]):.1f}°"))
        return text if self.ok else text + " — no configuration here (the last one found is drawn)"


def mechanism_at_pose(mech: Mechanism, pose: np.ndarray, previous: MechanismAtPose | None = None
                      ) -> MechanismAtPose:
    """The configuration at the output ``pose`` (SI) in home's working mode: by continuation from ``previous`` (the
    pose shown before) where that keeps the mode, else as ``point`` and a section find it
    (:func:`pkmstiff.mechanisms.section.solve_in_mode`)."""
    from pkmstiff.mechanisms import inverse
    from pkmstiff.mechanisms.section import mode_filter, solve_in_mode

    x = np.asarray(pose, float)[None]
    sol = None
    if previous is not None and previous.ok:
        sol = mode_filter(mech, inverse(mech, x, start=previous.solution))
    if sol is None or not sol.ok[0]:
        sol = solve_in_mode(mech, x)
    return MechanismAtPose(mech, x[0], sol)


def mechanism_section(mech: Mechanism, choice: SectionChoice) -> MechanismSectionView:
    """The map of ``choice`` on ``mech`` as ``pkmstiff section MECHANISM`` computes it (window fitted to the
    workspace, the same raster, quantities and admissibility)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from pkmstiff.mechanisms.section import check_quantities, evaluate_section, fit_window
    from pkmstiff.plots.mechanism_section import mechanism_quantity_figure

    elastic_mechanism(mech)
    choice.checked_raster()
    _check_settings(mech, choice.settings.checked())
    if mech.dim == 2 and choice.plane != "xy":
        raise ArgumentError(option="plane", expected=f"xy (mechanism '{mech.name}' is planar)", found=choice.plane)
    check_quantities(mech, [choice.quantity])
    tip = _tip(mech, choice.settings)
    ori = np.radians(choice.orientation_deg)
    step, at = choice.step_mm / MM, choice.at_mm / MM
    t0 = time.perf_counter()
    (u0, u1), (v0, v1) = fit_window(mech, choice.plane, at, ori, step)
    sec = evaluate_section(mech, choice.plane, at, (u0, u1), (v0, v1), step, ori, [choice.quantity], tip)
    if tip is not None:
        sec.settings["tool_length_mm"] = float(choice.settings.tool_length_mm)
    seconds = time.perf_counter() - t0
    fig, ax = mechanism_quantity_figure(sec, choice.quantity)
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    width, height = (int(round(v)) for v in fig.get_size_inches() * DPI)
    box = ax.get_window_extent()  # after savefig: the layout as drawn; origin bottom left
    return MechanismSectionView(choice, mech, sec, buf.getvalue(), (width, height),
                                (float(box.x0), height - float(box.y1), float(box.x1), height - float(box.y0)),
                                seconds)


@dataclass
class MechanismPointView:
    """The point analysis of a mechanism at one output pose (the numbers ``pkmstiff point MECHANISM`` prints)."""

    pose: np.ndarray  # SI output pose
    result: MechanismStiffness
    reasons: list[str]
    descriptions: list[str]
    axes: str  # the directions of the stiffness and weak points: "xyz", planar "xy"
    rotational: bool  # the load body is a rigid body (rotational stiffness reported)
    dim: int
    command: str

    @property
    def admissible(self) -> bool:
        return not self.reasons

    def stiffness(self) -> dict[str, float]:
        """k_x, k_y (, k_z) [N/µm] and the rotational k_r… [N·m/µrad] that ``pkmstiff point`` reports."""
        k = self.result.stiffness[0] / 1e6
        out = {f"k{ax}": float(k[i]) for i, ax in enumerate(self.axes)}
        if self.rotational:
            out |= {f"kr{ax}": float(k[3 + i]) for i, ax in enumerate("xyz") if self.dim == 3 or ax == "z"}
        return out

    def weak_points(self) -> dict[str, dict[str, float]]:
        """Component -> direction -> share of the output point's compliance [%]."""
        from pkmstiff.mechanisms.structure import LABELS

        return {lab: {d: float(100.0 * self.result.shares[d][0, j]) for d in self.axes}
                for j, lab in enumerate(LABELS)}

    def modes(self) -> list[tuple[float, str]]:
        """(frequency [Hz], description; "" where the model has none) of each computed mode, lowest first."""
        f = self.result.frequencies_hz[0]
        return [(float(v), self.descriptions[i] if i < len(self.descriptions) else "") for i, v in enumerate(f)]


def point_command(mech: Mechanism, pose: np.ndarray, settings: ModelSettings) -> str:
    """The ``pkmstiff point`` command of the analysis at the output ``pose`` (SI), in mm and degrees to 10
    significant digits."""
    n_len = 3 if mech.dim == 3 else 2
    text = ",".join(f"{v * MM if i < n_len else math.degrees(v):.10g}" for i, v in enumerate(pose))
    return shlex.join(["pkmstiff", "point", mech.name, f"--pose={text}", *settings.args()])


def mechanism_point(mech: Mechanism, pose: np.ndarray, settings: ModelSettings, n_modes: int) -> MechanismPointView:
    """Stiffness, weak points and modes at the output ``pose`` (SI) as ``pkmstiff point MECHANISM`` computes them
    (modes limited to the model's dynamic degrees of freedom; descriptions of a rigid output body)."""
    import pkmstiff.multibody as sde
    from pkmstiff.mechanisms import evaluate, reason_names
    from pkmstiff.mechanisms.section import solve_in_mode
    from pkmstiff.mechanisms.stiffness import evaluate_mechanism
    from pkmstiff.mechanisms.structure import mechanism_structure

    elastic_mechanism(mech)
    _check_settings(mech, settings.checked())
    tip = _tip(mech, settings)
    x = np.asarray(pose, float)
    ev = evaluate(mech, x[None], solution=solve_in_mode(mech, x[None]))  # as point: in home's working mode
    ms = mechanism_structure(mech, solution=ev.solution, point=tip) if ev.solution.ok[0] else None
    if ms is not None and ms.model is not None:
        n_modes = min(n_modes, sde.dynamic_dofs(ms.model))
    axes = "xyz"[:mech.dim]
    res = evaluate_mechanism(mech, ev.solution, n_modes, tuple(axes), point=tip)
    rot = ms is not None and ms.model is not None and isinstance(ms.model.body(ms.load_body), sde.RigidBody)
    descriptions = []
    if n_modes and rot and res.ok[0]:
        mr = sde.modes(ms.model, n_modes, shapes=True)
        idx, share = sde.describe_modes(ms.model, mr.shapes, ms.output_body)
        descriptions = [sde.mode_label(idx[0, k], share[0, k]) for k in range(n_modes)]
    reasons = [r.lower().replace("_", " ") for r in reason_names(int(ev.reasons[0]))]
    return MechanismPointView(x, res, reasons, descriptions, axes, rot, mech.dim,
                              point_command(mech, x, settings))
