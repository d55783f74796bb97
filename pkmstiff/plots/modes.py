"""Mode-shape figures (Cobet Figs. 4.31, 5.32): undeformed and scaled deformed machine, and an animated GIF."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pkmstiff.analysis.modal import ModalAnalysis, modal_analysis
from pkmstiff.io.atomic import atomic_path
from pkmstiff.kinematics import inverse_kinematics
from pkmstiff.machine.model import Machine
from pkmstiff.plots import offscreen
from pkmstiff.plots.sketch import add_sketch, sketch_from_points
from pkmstiff.structure import build_structure


@dataclass
class ModeShape:
    """Undeformed points and their modal displacements (m) for one mode at one pose."""

    frequency_hz: float
    description: str
    q: np.ndarray  # (n, 3) drive-side joint points
    p: np.ndarray  # (n, 3) platform-side joint points
    hull: np.ndarray | None  # (m, 3) hull vertices
    dq: np.ndarray
    dp: np.ndarray
    dhull: np.ndarray | None

    def scale_for(self, amplitude: float) -> float:
        """Factor that makes the largest point displacement equal ``amplitude`` (m)."""
        parts = [self.dq, self.dp] + ([self.dhull] if self.dhull is not None else [])
        peak = max(float(np.nanmax(np.linalg.norm(d, axis=1))) for d in parts if len(d))
        return amplitude / peak if peak > 0 else 0.0


def mode_shape(machine: Machine, pose, mode: int = 1, n_modes: int | None = None,
               modal: ModalAnalysis | None = None) -> ModeShape:
    """Point displacements of mode ``mode`` (1 = lowest) at ``pose`` from the structure model (docs/theory/structure.md)."""
    pose = np.asarray(pose, float)
    st = build_structure(machine, pose[None])
    modal = modal or modal_analysis(st, n_modes or max(mode, 6), shapes=True)
    if not np.isfinite(modal.frequencies_hz[0, mode - 1]):
        raise ValueError(f"mode shape: the pose {pose.tolist()} is not admissible for the structure model")
    v = modal.shapes[0, mode - 1]
    labels = modal.dof_labels
    ik = inverse_kinematics(machine, pose[None])
    R, w = ik.R[0], ik.poses[0, :3]

    def body(name: str) -> np.ndarray | None:
        idx = [labels.index(f"{name}.{c}") for c in ("ux", "uy", "uz", "rx", "ry", "rz") if f"{name}.{c}" in labels]
        return v[idx] if idx else None

    plat = body("platform")
    centre = np.asarray(st.model.body("platform").position, float).reshape(-1, 3)[0]

    def rigid(points: np.ndarray) -> np.ndarray:
        if plat is None:
            return np.zeros_like(points)
        return plat[:3] + np.cross(plat[3:6], points - centre)

    p = ik.p[0]
    q = np.array(ik.q[0])
    dq = np.zeros_like(q)
    for i in range(machine.n_chains):
        d = body(f"drive{i + 1}")
        if d is not None:
            dq[i] = d[:3]
    hull = None if machine.hull.empty else machine.hull.vertices @ R.T + w
    return ModeShape(float(modal.frequencies_hz[0, mode - 1]), modal.description(0, mode - 1), q, p, hull, dq,
                     rigid(p), None if hull is None else rigid(hull))


def deformed_sketch(machine: Machine, ms: ModeShape, factor: float):
    """The machine sketch with the mode's displacements times ``factor`` added to its points."""
    return sketch_from_points(machine, ms.q + factor * ms.dq, ms.p + factor * ms.dp,
                              None if ms.hull is None else ms.hull + factor * ms.dhull)


def _camera(p, ms: ModeShape, zoom: float = 1.0) -> None:
    pts = np.concatenate([ms.q, ms.p]) * 1e3
    focus = np.nanmean(pts, axis=0)
    size = float(np.nanmax(np.ptp(pts, axis=0)))
    direction = np.array([1.0, -1.4, 0.8]) / np.linalg.norm([1.0, -1.4, 0.8])
    p.camera_position = [tuple(focus + 2.6 * size * direction), tuple(focus), (0.0, 0.0, 1.0)]
    if zoom != 1.0:  # fit everything drawn (guides, triad) along the same view direction, then fill the canvas
        p.reset_camera()
        p.camera.zoom(zoom)
        pos, foc, up = (np.asarray(v, float) for v in p.camera_position)
        shift = -0.06 * size * up  # the title takes the top rows: move the drawing down into the empty bottom
        p.camera_position = [tuple(pos - shift), tuple(foc - shift), tuple(up)]


def add_axis_triad(p, ms: ModeShape) -> None:
    """Machine-frame axes x, y, z (red, green, blue arrows with labels) at the lower corner of the machine's
    bounding box, a tenth of its size long (pyvista's orientation widget needs an interactor, so the triad is
    drawn as geometry)."""
    pv = offscreen()
    pts = np.concatenate([ms.q, ms.p]) * 1e3
    lo = np.nanmin(pts, axis=0)
    size = float(np.nanmax(np.ptp(pts, axis=0)))
    length = 0.15 * size
    origin = lo - 0.05 * size
    tips = []
    for k, colour in enumerate(("red", "green", "blue")):
        d = np.zeros(3)
        d[k] = 1.0
        p.add_mesh(pv.Arrow(start=origin, direction=d, scale=length, tip_length=0.25, tip_radius=0.08,
                            shaft_radius=0.03), color=colour)
        tips.append(origin + 1.15 * length * d)
    p.add_point_labels(np.array(tips), ["x", "y", "z"], font_size=20, text_color="black", shape=None,
                       show_points=False, always_visible=True)


def plot_mode_shape(machine: Machine, pose, path: str | Path, mode: int = 1, amplitude: float = 0.12,
                    window_size=(1000, 720)) -> Path:
    """PNG of the undeformed machine (grey, transparent) and mode ``mode`` scaled to ``amplitude`` (m) peak
    (orange), with axes in mm (the scale), the x, y, z triad and a legend that states the amplitude; the frequency
    and the description are computed at ``pose`` by the structure model."""
    pv = offscreen()
    ms = mode_shape(machine, pose, mode)
    factor = ms.scale_for(amplitude)
    p = pv.Plotter(off_screen=True, window_size=window_size)
    add_sketch(p, machine, pose, opacity=0.3, colour="gray")
    deformed = deformed_sketch(machine, ms, factor)
    if "guides" in deformed.keys():
        deformed.pop("guides")  # the guides do not move; drawn once, grey
    add_sketch(p, machine, pose, sketch=deformed, colour="darkorange")
    add_axis_triad(p, ms)
    pts = np.concatenate([ms.q, ms.p]) * 1e3
    direction = np.array([1.0, -1.4, 0.8]) / np.linalg.norm([1.0, -1.4, 0.8])
    from pkmstiff.plots.axes3d import add_mm_axes

    add_mm_axes(p, np.column_stack([np.nanmin(pts, axis=0), np.nanmax(pts, axis=0)]).ravel(), direction,
                font_size=16)
    ori = ", ".join(f"{np.degrees(v):g}°" for v in np.asarray(pose)[3:6])
    p.add_text(f"{machine.name}: mode {mode}, {ms.frequency_hz:.2f} Hz, {ms.description}\n"
               f"pose x, y, z = {', '.join(f'{v * 1e3:g}' for v in np.asarray(pose)[:3])} mm, a, b, c = {ori} "
               f"(machine frame)", position="upper_left", font_size=12, color="black")
    p.add_text(f"grey: undeformed; orange: mode {mode} scaled to {amplitude * 1e3:g} mm peak displacement "
               f"(x{factor:.3g})", position="lower_left", font_size=12, color="black")
    p.set_background("white")
    _camera(p, ms, zoom=1.3)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        p.screenshot(str(tmp))
    p.close()
    return path


def animate_mode_shape(machine: Machine, pose, path: str | Path, mode: int = 1, amplitude: float = 0.08,
                       frames: int = 20, window_size=(640, 520), fps: int = 12) -> Path:
    """Animated GIF of mode ``mode`` (one period, ``frames`` frames), written with Pillow."""
    from PIL import Image

    pv = offscreen()
    ms = mode_shape(machine, pose, mode)
    factor = ms.scale_for(amplitude)
    images = []
    for k in range(frames):
        p = pv.Plotter(off_screen=True, window_size=window_size)
        add_sketch(p, machine, pose, opacity=0.2, colour="gray")
        add_sketch(p, machine, pose, sketch=deformed_sketch(machine, ms, factor * np.sin(2 * np.pi * k / frames)))
        p.add_text(f"mode {mode}: {ms.frequency_hz:.2f} Hz, {ms.description}", position="upper_left",
                   font_size=10, color="black")
        p.set_background("white")
        _camera(p, ms)
        images.append(Image.fromarray(p.screenshot(return_img=True)))
        p.close()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        images[0].save(tmp, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
    return path
