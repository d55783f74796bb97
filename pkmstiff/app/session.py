"""The logic of ``pkmstiff app`` without a browser: what the user chose → the request → the result shown.

A :class:`Session` turns a :class:`MachineChoice` (a bundled machine or file, and a variant option) and a
:class:`SectionChoice` (plane, position, raster step, quantity, tool orientation) into a :class:`SectionView`: the
public API's :meth:`pkmstiff.api.StudyMachine.section` (the map ``pkmstiff section`` computes for the same inputs)
drawn as ``pkmstiff section`` draws it (:func:`pkmstiff.plots.section_maps.section_figure`), with the map axes'
pixel box so that a click on the picture finds its raster point. A picked point gives a :class:`PointView`
(:meth:`~pkmstiff.api.StudyMachine.point`: stiffness, weak points, modes). :func:`export` writes what is shown and
the commands that reproduce it. Units: SI inside; mm and degrees in the choices and on screen (the command line's).
"""

from __future__ import annotations

import io
import math
import shlex
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pkmstiff.errors import ArgumentError
from pkmstiff.machine.loader import bundled_machines, machine_options  # noqa: F401 (the app's choices)

if TYPE_CHECKING:
    from pkmstiff.api import PointResults, SectionMap, StudyMachine
    from pkmstiff.app.mechanisms import MechanismPointView, MechanismSectionView
    from pkmstiff.mechanisms.model import Mechanism

MM = 1e3
#: the section planes offered (those of ``pkmstiff section --plane``)
PLANES = ("yz", "xz", "xy")
#: raster steps (mm) the app accepts: a map is recomputed on every change, so the raster is bounded to keep a
#: change interactive (the Hexaglide's YZ plane at 25 mm: 1551 points, about 4 s on one core; the time grows with
#: 1/step²)
STEP_LIMITS_MM = (5.0, 200.0)
#: largest tool angle (deg) the app accepts for a, b, c (the orientation sliders' range)
ANGLE_LIMIT_DEG = 60.0
#: natural frequencies and mode shapes of a point analysis
N_MODES = 6


@dataclass(frozen=True)
class MachineChoice:
    """A bundled machine name or machine file, and an ``[options.NAME]`` variant of it ("" for none)."""

    machine: str = "hexaglide"
    option: str = ""

    @property
    def spec(self) -> str:
        """The machine as the command line names it: ``hexaglide`` or ``hexaglide:printed_values``."""
        return f"{self.machine}:{self.option}" if self.option else self.machine


def check_spatial(machine: str) -> None:
    """An :class:`~pkmstiff.errors.ArgumentError` (one line) for a mechanism or a planar example: the spatial
    machines' path of the app (a mechanism with an ``[elastic]`` table takes :meth:`Session.mechanism_section`)."""
    from pkmstiff.analysis.planar import bundled_planar
    from pkmstiff.mechanisms.loader import is_mechanism

    if machine in bundled_machines():
        return
    kind = ("a planar example" if machine in bundled_planar() else
            "a mechanism" if is_mechanism(machine) else "")
    if kind:
        raise ArgumentError(option="machine", expected=(
            f"a spatial machine or a mechanism; a planar example's map is that of its mechanism file "
            f"{machine}_generic (the same model)" if kind == "a planar example" else
            "a spatial machine (a mechanism takes the app's mechanism path: pkmstiff section / pkmstiff point with "
            "its name)"), found=f"{machine} ({kind})")


def is_mechanism_target(machine: str) -> bool:
    """Whether ``machine`` names a mechanism (bundled name or mechanism file), as the command line resolves it
    (a bundled spatial machine's name first)."""
    from pkmstiff.mechanisms.loader import is_mechanism

    return machine not in bundled_machines() and is_mechanism(machine)


@dataclass(frozen=True)
class ModelSettings:
    """What the map and the point analysis share, as ``pkmstiff section`` and ``pkmstiff point`` take it:
    ``--tool-length`` [mm] (None: the machine file's), ``--skip-check`` (admissibility checks left out),
    ``--neglect-spindle`` (K_U left out, Cobet 4.2.4) and ``--frame`` (positions given and shown in the machine or
    the report frame)."""

    tool_length_mm: float | None = None
    skip_checks: tuple[str, ...] = ()
    neglect_spindle: bool = False
    frame: str = "machine"

    def checked(self) -> ModelSettings:
        """These settings, or an :class:`~pkmstiff.errors.ArgumentError` (one line) before any work."""
        from pkmstiff.admissibility.checks import ALL_CHECKS
        from pkmstiff.machine.frames import FRAMES

        t = self.tool_length_mm
        if t is not None and not (math.isfinite(t) and t >= 0.0):
            raise ArgumentError(option="tool length", expected="a length >= 0 mm (empty: the machine file's)",
                                found=t)
        bad = [c for c in self.skip_checks if c not in ALL_CHECKS]
        if bad:
            raise ArgumentError(option="skip checks", expected=f"names of {', '.join(ALL_CHECKS)}",
                                found=", ".join(bad))
        if self.frame not in FRAMES:
            raise ArgumentError(option="frame", expected=f"one of {', '.join(FRAMES)}", found=self.frame)
        return self

    @property
    def tool_length(self) -> float | None:
        """The tool length [m] (None: the machine file's)."""
        return None if self.tool_length_mm is None else self.tool_length_mm / MM

    def args(self) -> list[str]:
        """The command-line options of these settings (none for the defaults)."""
        out = [] if self.tool_length_mm is None else ["--tool-length", f"{self.tool_length_mm:g}"]
        out += [a for c in self.skip_checks for a in ("--skip-check", c)]
        out += ["--neglect-spindle"] if self.neglect_spindle else []
        return out + ([] if self.frame == "machine" else ["--frame", self.frame])


@dataclass(frozen=True)
class SectionChoice:
    """A section map as ``pkmstiff section`` takes it: ``--plane``, ``--at`` [mm], ``--step`` [mm],
    ``--quantities`` (one), ``--orientation`` a, b, c [deg] and the :class:`ModelSettings`; the window is fitted to
    the workspace."""

    plane: str = "yz"
    at_mm: float = 0.0
    step_mm: float = 25.0
    quantity: str = "kx"
    orientation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    settings: ModelSettings = ModelSettings()

    def checked(self, n_chains: int) -> SectionChoice:
        """This choice, or an :class:`~pkmstiff.errors.ArgumentError` (one line naming the field, what was
        expected and what was found) before any work."""
        from pkmstiff.evaluation.quantities import check_quantity

        self.checked_raster()
        check_quantity(self.quantity, n_chains)
        self.settings.checked()
        return self

    def checked_raster(self) -> SectionChoice:
        """This choice's plane, step, position and orientation checked (one line, before any work)."""
        if self.plane not in PLANES:
            raise ArgumentError(option="plane", expected=f"one of {', '.join(PLANES)}", found=self.plane)
        lo, hi = STEP_LIMITS_MM
        if not (math.isfinite(self.step_mm) and lo <= self.step_mm <= hi):
            raise ArgumentError(option="step", expected=f"a raster step {lo:g}..{hi:g} mm", found=self.step_mm)
        if not math.isfinite(self.at_mm):
            raise ArgumentError(option="at", expected="a finite position in mm", found=self.at_mm)
        if len(self.orientation_deg) != 3 or not all(math.isfinite(a) and abs(a) <= ANGLE_LIMIT_DEG
                                                     for a in self.orientation_deg):
            raise ArgumentError(option="orientation", expected=f"a, b, c within ±{ANGLE_LIMIT_DEG:g} deg",
                                found=tuple(self.orientation_deg))
        return self

    def command(self, machine: MachineChoice, out: str = "OUT") -> str:
        """The ``pkmstiff section`` command that computes and writes (PNG, CSV into ``out``) this map."""
        ori = ",".join(f"{a:g}" for a in self.orientation_deg)
        return shlex.join(["pkmstiff", "section", machine.spec, "--plane", self.plane, "--at", f"{self.at_mm:g}",
                           "--step", f"{self.step_mm:g}", f"--orientation={ori}", "--quantities", self.quantity,
                           *self.settings.args(), "--out", out, "--formats", "png,csv"])


def point_command(machine: MachineChoice, pose: Sequence[float], settings: ModelSettings = ModelSettings(),
                  origin_m: Sequence[float] = (0.0, 0.0, 0.0)) -> str:
    """The ``pkmstiff point`` command of the point analysis at ``pose`` (x, y, z [m], a, b, c [rad], machine
    frame) with ``settings``, the position in the settings' frame (origin ``origin_m`` in the machine frame),
    printed in mm and degrees to 10 significant digits (a raster point's position exactly as shown)."""
    mm_deg = [*((v - o) * MM for v, o in zip(pose[:3], origin_m)), *(math.degrees(v) for v in pose[3:6])]
    return shlex.join(["pkmstiff", "point", machine.spec, f"--pose={','.join(f'{v:.10g}' for v in mm_deg)}",
                       *settings.args()])


def node_at_pixel(view: SectionView | MechanismSectionView, x_px: float, y_px: float) -> tuple[int, int] | None:
    """(row, column) of the raster point of ``view`` nearest the PNG pixel (x right, y down), None outside its map
    axes (``view.axes_px``; the axes span ``view.limits_mm``)."""
    left, top, right, bottom = view.axes_px
    if not (left <= x_px <= right and top <= y_px <= bottom):
        return None
    u0, u1, v0, v1 = view.limits_mm
    u = u0 + (x_px - left) / (right - left) * (u1 - u0)
    v = v1 - (y_px - top) / (bottom - top) * (v1 - v0)
    return view.node_at(u, v)


def value_text(quantity: str, value: float, unit: str) -> str:
    """``kx = 1.23 N/um`` or ``kx = inadmissible`` (NaN)."""
    return f"{quantity} = " + ("inadmissible" if math.isnan(value) else f"{value:.6g} {unit}")


@dataclass
class SectionView:
    """A computed section map as the app shows it: the map, its PNG and where the map axes lie in the PNG."""

    choice: SectionChoice
    map: SectionMap
    png: bytes
    size_px: tuple[int, int]  # (width, height) of the PNG
    axes_px: tuple[float, float, float, float]  # left, top, right, bottom of the map axes, pixels from the top left
    seconds: float
    origin_m: np.ndarray = field(default_factory=lambda: np.zeros(3))  # the map frame's origin in the machine frame

    def machine_points(self) -> np.ndarray:
        """(nv·nu, 3) raster points [m] in the machine frame (the map's plane is in the settings' frame)."""
        return self.map.plane.points() + self.origin_m

    @property
    def limits_mm(self) -> tuple[float, float, float, float]:
        """u_min, u_max, v_min, v_max [mm] of the map axes (the raster's first and last values)."""
        pl = self.map.plane
        return (pl.u_values[0] * MM, pl.u_values[-1] * MM, pl.v_values[0] * MM, pl.v_values[-1] * MM)

    def node_at_pixel(self, x_px: float, y_px: float) -> tuple[int, int] | None:
        """(row, column) of the raster point nearest the PNG pixel (x right, y down), None outside the map axes."""
        return node_at_pixel(self, x_px, y_px)

    def picked_text(self, row: int, col: int) -> str:
        """One line for the picked raster point: its in-plane position [mm] and the map's value there."""
        pl = self.map.plane
        frame = self.choice.settings.frame
        return ((f"{frame} frame: " if frame != "machine" else "")
                + f"{pl.u_name} = {pl.u_values[col] * MM:.1f} mm, {pl.v_name} = {pl.v_values[row] * MM:.1f} mm: "
                + value_text(self.choice.quantity, self.value_at(row, col), self.unit))

    def node_at(self, u_mm: float, v_mm: float) -> tuple[int, int]:
        """(row, column) of the raster point nearest the in-plane position (u, v) [mm]."""
        pl = self.map.plane
        return (int(np.argmin(np.abs(pl.v_values * MM - v_mm))), int(np.argmin(np.abs(pl.u_values * MM - u_mm))))

    def pixel_of(self, row: int, col: int) -> tuple[float, float]:
        """The PNG pixel (x right, y down) of raster point (row, column): the inverse of :meth:`node_at_pixel`."""
        left, top, right, bottom = self.axes_px
        u0, u1, v0, v1 = self.limits_mm
        pl = self.map.plane
        u, v = pl.u_values[col] * MM, pl.v_values[row] * MM
        return (left + (u - u0) / (u1 - u0) * (right - left), top + (v1 - v) / (v1 - v0) * (bottom - top))

    def pose_at(self, row: int, col: int) -> np.ndarray:
        """(6,) pose of raster point (row, column): x, y, z [m] (machine frame) and the map's a, b, c [rad]."""
        nu = self.map.plane.shape[1]
        return np.concatenate([self.machine_points()[row * nu + col], np.radians(self.choice.orientation_deg)])

    def value_at(self, row: int, col: int) -> float:
        """The map's value at raster point (row, column) in its display unit (NaN where inadmissible)."""
        return float(self.map.display(self.choice.quantity)[row, col])

    @property
    def unit(self) -> str:
        return self.map.units[self.choice.quantity]

    def central_node(self) -> tuple[int, int] | None:
        return central_node(self.map.ok)

    def summary(self) -> str:
        """One line: admissible points and area, the quantity's range and the time taken."""
        ok = self.map.ok
        st = self.map.statistics().get(self.choice.quantity, {})
        rng = (f", {self.choice.quantity} {st['min']:.4g} … {st['max']:.4g} {self.unit}"
               if st.get("count") else "")
        return (f"{int(ok.sum())} of {ok.size} points admissible "
                f"({float(ok.sum()) * self.map.plane.cell_area:.4g} m²){rng}; computed in {self.seconds:.2f} s")


@dataclass
class PointView:
    """The point analysis at one pose as the app shows it (the numbers ``pkmstiff point`` prints)."""

    pose: np.ndarray  # (6,) m, rad, machine frame
    result: PointResults
    command: str

    @property
    def admissible(self) -> bool:
        return bool(self.result.admissible[0])

    @property
    def reasons(self) -> list[str]:
        return self.result.reasons[0]

    def stiffness(self) -> dict[str, float]:
        """k_x, k_y, k_z [N/µm] and k_rx, k_ry, k_rz [N·m/µrad] (1/C_jj of the TCP compliance)."""
        k = self.result.stiffness[0] / 1e6
        return {f"k{ax}": float(k[i]) for i, ax in enumerate("xyz")} | {
            f"kr{ax}": float(k[3 + i]) for i, ax in enumerate("xyz")}

    def weak_points(self) -> dict[str, dict[str, float]]:
        """Component -> direction -> share of the TCP compliance [%] (columns of ``pkmstiff point``)."""
        wp = self.result.weak_points
        components = list(next(iter(wp.values()))) if wp else []
        return {c: {d: float(100.0 * wp[d][c][0]) for d in wp} for c in components}

    def modes(self) -> list[tuple[float, str]]:
        """(frequency [Hz], description) of each computed mode, lowest first."""
        return [(float(f), d) for f, d in zip(self.result.frequencies_hz[0], self.result.mode_descriptions[0])]


@dataclass
class Session:
    """Machines loaded once per variant, and the app's requests on them."""

    _machines: dict[str, StudyMachine] = field(default_factory=dict)
    _mechanisms: dict[str, Mechanism] = field(default_factory=dict)

    def machine(self, choice: MachineChoice, neglect_spindle: bool = False) -> StudyMachine:
        """The machine of ``choice`` (loaded on first use; a bad name, file or option is one clear error), with
        the platform-spindle stiffness K_U left out if ``neglect_spindle`` (as ``--neglect-spindle``)."""
        from pkmstiff.api import load_machine

        if choice.spec not in self._machines:
            check_spatial(choice.machine)
            self._machines[choice.spec] = load_machine(choice.spec)
        m = self._machines[choice.spec]
        return m.with_(neglect_spindle=True) if neglect_spindle else m

    def section(self, machine: MachineChoice, choice: SectionChoice) -> SectionView:
        """The map of ``choice`` (as ``pkmstiff section`` computes it: the same window, raster and masking)."""
        import time

        from matplotlib.backends.backend_agg import FigureCanvasAgg

        from pkmstiff.plots.section_maps import section_figure

        st = choice.settings
        m = self.machine(machine, st.neglect_spindle)
        choice.checked(m.n_chains)
        t0 = time.perf_counter()
        smap = m.section(choice.plane, at=choice.at_mm / MM, step=choice.step_mm / MM, quantities=[choice.quantity],
                         orientation=np.radians(choice.orientation_deg), tool_length=st.tool_length,
                         frame=st.frame, skip_checks=st.skip_checks)
        seconds = time.perf_counter() - t0
        fig, ax = section_figure(smap.result, choice.quantity)
        FigureCanvasAgg(fig)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=100, facecolor="white")  # as pkmstiff section saves its PNG
        width, height = (int(round(v)) for v in fig.get_size_inches() * 100)
        box = ax.get_window_extent()  # after savefig: the constrained layout as drawn; origin bottom left
        return SectionView(choice, smap, buf.getvalue(), (width, height),
                           (float(box.x0), height - float(box.y1), float(box.x1), height - float(box.y0)), seconds,
                           m.to_machine_frame(np.zeros(3), st.frame))

    def point(self, machine: MachineChoice, pose: Sequence[float],
              settings: ModelSettings = ModelSettings()) -> PointView:
        """The point analysis at ``pose`` (x, y, z [m], a, b, c [rad], machine frame) with ``settings``: stiffness,
        weak points and :data:`N_MODES` modes, as ``pkmstiff point`` computes them (the kinetostatics are left
        out)."""
        x = np.asarray(pose, float)
        m = self.machine(machine, settings.checked().neglect_spindle)
        res = m.point(x, tool_length=settings.tool_length, n_modes=N_MODES, kinetostatics=False,
                      skip_checks=settings.skip_checks)
        return PointView(x, res, point_command(machine, x, settings, m.to_machine_frame(np.zeros(3), settings.frame)))

    def mechanism(self, name: str) -> Mechanism:
        """The mechanism ``name`` (bundled or file; loaded on first use)."""
        from pkmstiff.mechanisms import load_mechanism

        if name not in self._mechanisms:
            self._mechanisms[name] = load_mechanism(name)
        return self._mechanisms[name]

    def mechanism_section(self, name: str, choice: SectionChoice) -> MechanismSectionView:
        """The section map of ``choice`` on the mechanism ``name`` (as ``pkmstiff section NAME``)."""
        from pkmstiff.app.mechanisms import mechanism_section

        return mechanism_section(self.mechanism(name), choice)

    def mechanism_point(self, name: str, pose: Sequence[float],
                        settings: ModelSettings = ModelSettings()) -> MechanismPointView:
        """The point analysis of the mechanism ``name`` at the output ``pose`` (SI; as ``pkmstiff point NAME``)."""
        from pkmstiff.app.mechanisms import mechanism_point

        return mechanism_point(self.mechanism(name), np.asarray(pose, float), settings, N_MODES)

    def pose_limits(self, machine: MachineChoice) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) (6,) slider limits of the pose in mm and degrees: the chains' reach box and ±:data:`ANGLE_LIMIT_DEG`."""
        from pkmstiff.workspace.translational import reach_box

        lo, hi = reach_box(self.machine(machine))
        a = np.full(3, ANGLE_LIMIT_DEG)
        return np.concatenate([np.floor(lo * MM), -a]), np.concatenate([np.ceil(hi * MM), a])


def central_node(ok: np.ndarray) -> tuple[int, int] | None:
    """The admissible raster point (row, column) nearest the centroid of the admissible region ``ok`` (nv, nu)
    (None if there is none)."""
    rows, cols = np.nonzero(ok)
    if not rows.size:
        return None
    k = int(np.argmin((rows - rows.mean()) ** 2 + (cols - cols.mean()) ** 2))
    return int(rows[k]), int(cols[k])


def pose_text(pose: Sequence[float]) -> str:
    """x, y, z [mm] and a, b, c [deg] of a pose (m, rad) for the screen."""
    return (", ".join(f"{v * MM:.1f}" for v in pose[:3]) + " mm; "
            + ", ".join(f"{math.degrees(v):.1f}" for v in pose[3:6]) + " deg")


def export(out_dir: str | Path, machine: MachineChoice, view: SectionView | MechanismSectionView | None,
           point: PointView | MechanismPointView | None, scene_png: bytes | None = None) -> Path:
    """Write what is shown into a new folder ``out_dir/export-NNN`` (nothing existing is overwritten): the map as
    ``pkmstiff section --out`` writes it (PNG, CSV with its JSON metadata, statistics; same file names), the point
    analysis as a one-row CSV (``point.csv``, the columns of :meth:`PointResults.to_pandas`), the 3-D view
    (``view_3d.png``) and ``commands.txt``: the commands that reproduce the map and the point analysis. A mechanism's
    map is written as ``pkmstiff section MECHANISM --out`` writes it (no ``point.csv``)."""
    from pkmstiff.app.mechanisms import MechanismSectionView
    from pkmstiff.io.atomic import atomic_path, atomic_write_text, safe_stem
    from pkmstiff.report.outputs import write_section_outputs

    base = Path(out_dir)
    base.mkdir(parents=True, exist_ok=True)
    k = 1 + max((int(p.name[7:]) for p in base.glob("export-[0-9][0-9][0-9]") if p.name[7:].isdigit()), default=0)
    folder = base / f"export-{k:03d}"
    folder.mkdir()
    commands = []
    if isinstance(view, MechanismSectionView):
        view.write(folder)
        commands.append(view.choice.command(machine, str(folder / "cli")))
    elif view is not None:
        stem = f"{safe_stem(view.map.result.machine)}_{view.choice.plane}"
        write_section_outputs(view.map.result, folder, ["png", "csv"], stem, progress=False)
        commands.append(view.choice.command(machine, str(folder / "cli")))
    if isinstance(point, PointView):
        with atomic_path(folder / "point.csv") as tmp:
            point.result.to_pandas().to_csv(tmp, index=False)
    if point is not None:
        commands.append(point.command)
    if scene_png is not None:
        with atomic_path(folder / "view_3d.png") as tmp:
            Path(tmp).write_bytes(scene_png)
    atomic_write_text(folder / "commands.txt", "".join(c + "\n" for c in commands))
    return folder


def describe_error(exc: BaseException) -> str:
    """One line for the app's message bar (the command line's wording for the toolkit's errors)."""
    from pkmstiff.errors import PkmstiffError

    text = " ".join(str(exc).split())
    return text if isinstance(exc, PkmstiffError) else f"internal error {type(exc).__name__}: {text}"


def as_float(value: Any, name: str) -> float:
    """A number typed into a field, or an :class:`~pkmstiff.errors.ArgumentError` naming the field."""
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ArgumentError(option=name, expected="a number", found=value) from None
    if not math.isfinite(out):
        raise ArgumentError(option=name, expected="a finite number", found=value)
    return out
