"""The 3-D view of ``pkmstiff app``: an off-screen pyvista plotter with the machine (or a mechanism's links and
joints) at the chosen pose, the section plane coloured by its quantity, and a mode shape animated over the ghosted
machine (coordinates in mm, as in every figure of the toolkit). No browser needed: the trame view streams this
plotter's render window, and the tests render it to PNG."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from pkmstiff.plots import offscreen
from pkmstiff.plots.sketch import add_sketch, machine_sketch, mechanism_sketch

if TYPE_CHECKING:
    from pkmstiff.app.mechanisms import MechanismAtPose, MechanismSectionView
    from pkmstiff.app.session import SectionView
    from pkmstiff.machine import Machine

    #: what the view draws: a pod/glide machine (at the pose given with it) or a mechanism at its pose
    Drawn = Machine | MechanismAtPose

MM = 1e3
#: the view direction of the toolkit's 3-D figures (front right, from above; plots.section_maps, plots.modes)
VIEW_DIRECTION = np.array([1.0, -1.4, 0.8]) / np.linalg.norm([1.0, -1.4, 0.8])
#: a planar mechanism's: mostly from above its plane of motion z = 0
PLANAR_VIEW_DIRECTION = np.array([0.2, -0.5, 1.0]) / np.linalg.norm([0.2, -0.5, 1.0])
#: frames per period of the animated mode shape, and its peak displacement [m] on screen
MODE_FRAMES = 16
#: how far below a planar mechanism's links its section plane is drawn [mm]
PLANAR_OFFSET_MM = 5.0
MODE_AMPLITUDE = 0.08


class Scene:
    """The plotter and what it shows; every method changes named actors only, so a change redraws no more than
    itself."""

    def __init__(self, window_size: tuple[int, int] = (900, 700)):
        pv = offscreen()
        self.plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
        self.plotter.set_background("white")
        self.mode_frames: list = []
        self.mode_text = ""
        self._mechanism: MechanismAtPose | None = None  # the mechanism's last configuration found
        self._machine_box: np.ndarray | None = None  # (3, 2) mm: the machine as first drawn
        self._section_key: tuple | None = None  # the plane the camera was last aimed at

    @property
    def _planar(self) -> bool:
        return self._mechanism is not None and self._mechanism.mechanism.dim == 2

    def set_machine(self, machine: Drawn, pose: np.ndarray) -> None:
        """A new machine: clear the view, draw the machine at ``pose`` with mm axes around it and aim the camera at
        it (the view stays while the pose changes; the user turns and zooms it with the mouse)."""
        self.plotter.clear_actors()
        self.mode_frames = []
        self._mechanism = None
        self._section_key = None
        self.set_pose(machine, pose)
        self._machine_box = np.array(self.plotter.bounds).reshape(3, 2)
        self._aim(self._machine_box)

    def _aim(self, box: np.ndarray) -> None:
        """mm axes around ``box`` (3, 2) [mm] (replacing the last ones) and the camera aimed at it."""
        from pkmstiff.plots.axes3d import add_mm_axes, frame_camera

        direction = PLANAR_VIEW_DIRECTION if self._planar else VIEW_DIRECTION
        add_mm_axes(self.plotter, box.ravel(), direction, font_size=12, name="axes")
        frame_camera(self.plotter, direction, box, zoom=1.1)

    def set_pose(self, machine: Drawn, pose: np.ndarray) -> None:
        """The machine at ``pose`` (x, y, z [m], a, b, c [rad], machine frame), or a mechanism at its pose (its last
        configuration found where the pose has none); ghosted while a mode is shown."""
        from pkmstiff.app.mechanisms import MechanismAtPose

        if isinstance(machine, MechanismAtPose):
            if machine.ok:
                self._mechanism = machine
            shown = self._mechanism or machine
            sketch = mechanism_sketch(shown.mechanism, shown.world()) if shown.ok else None
            title = machine.title()
        else:
            sketch = machine_sketch(machine, pose)
            title = (f"{machine.name}: x, y, z = {', '.join(f'{v * MM:.0f}' for v in pose[:3])} mm; "
                     f"a, b, c = {', '.join(f'{np.degrees(v):.1f}' for v in pose[3:6])}°")
        if sketch is not None:
            add_sketch(self.plotter, None, None, sketch=sketch, opacity=0.25 if self.mode_frames else 1.0,
                       colour="gray" if self.mode_frames else None, name="machine")
        self.plotter.add_text(title + (f"\n{self.mode_text}" if self.mode_frames else ""),
                              position="upper_left", font_size=10, color="black", name="title")

    def set_section(self, view: SectionView | MechanismSectionView) -> None:
        """The section plane in its place, coloured by the map's quantity on the map's colour scale.  When the plane
        or its window changes (not the quantity), the axes and the camera are aimed again at the machine and the
        plane together, so a plane moved away from the machine (another --at, another plane) stays in view."""
        from pkmstiff.plots.section_maps import pretty_unit, robust_clim

        pv = offscreen()
        values = view.map.display(view.choice.quantity)
        nv, nu = values.shape
        grid = pv.StructuredGrid()
        points = view.machine_points() * MM
        if self._planar:  # below the links, which lie in the same plane z = 0
            points[:, 2] -= PLANAR_OFFSET_MM
        grid.points = points
        grid.dimensions = (nu, nv, 1)
        grid.point_data[view.choice.quantity] = values.ravel()
        scale = robust_clim(values)
        title = f"{view.choice.quantity} [{pretty_unit(view.unit)}]"
        self.plotter.remove_scalar_bar() if self.plotter.scalar_bars else None
        self.plotter.add_mesh(grid, scalars=view.choice.quantity, cmap="viridis", clim=(scale.lo, scale.hi),
                              log_scale=scale.log, nan_opacity=0.0, name="section", opacity=0.85,
                              scalar_bar_args={"title": title, "vertical": True, "position_x": 0.03,
                                               "position_y": 0.4, "width": 0.06, "height": 0.45, "color": "black",
                                               "title_font_size": 14, "label_font_size": 12, "fmt": "%.3g"})
        key = (view.choice.plane, view.choice.at_mm, *view.limits_mm)
        if key != self._section_key and self._machine_box is not None:
            lo, hi = points.min(axis=0), points.max(axis=0)
            self._aim(np.column_stack([np.minimum(self._machine_box[:, 0], lo),
                                       np.maximum(self._machine_box[:, 1], hi)]))
        self._section_key = key

    def set_mode(self, machine: Drawn, pose: np.ndarray, mode: int) -> None:
        """Mode ``mode`` (1 = lowest) at ``pose``: the machine ghosted grey and :data:`MODE_FRAMES` frames of one
        period of the deformed machine (orange), peak displacement :data:`MODE_AMPLITUDE` on screen."""
        from pkmstiff.app.mechanisms import MechanismAtPose
        from pkmstiff.plots.modes import deformed_sketch, mode_shape

        if isinstance(machine, MechanismAtPose):
            ms = _mechanism_mode(machine, mode)

            def deformed(f: float):
                return mechanism_sketch(machine.mechanism, {li: w + f * ms.displacement[li]
                                                            for li, w in ms.world.items()})
        else:
            ms = mode_shape(machine, pose, mode)

            def deformed(f: float):
                return deformed_sketch(machine, ms, f)
        factor = ms.scale_for(MODE_AMPLITUDE)
        frames = []
        for k in range(MODE_FRAMES):
            sk = deformed(factor * np.sin(2 * np.pi * k / MODE_FRAMES))
            if "guides" in sk.keys():
                sk.pop("guides")  # the guides do not move: drawn once, with the ghosted machine
            frames.append(sk)
        self.mode_frames = frames
        self.mode_text = (f"mode {mode}: {ms.frequency_hz:.2f} Hz{', ' if ms.description else ''}{ms.description} "
                          "(orange, "
                          f"{MODE_AMPLITUDE * MM:g} mm peak displacement on screen, x{factor:.3g})")
        self.set_pose(machine, pose)
        self.show_mode_frame(machine, pose, 0)

    def show_mode_frame(self, machine: Drawn, pose: np.ndarray, k: int) -> None:
        """Frame ``k`` (modulo :data:`MODE_FRAMES`) of the animated mode shape."""
        if self.mode_frames:
            add_sketch(self.plotter, None, None, sketch=self.mode_frames[k % len(self.mode_frames)],
                       colour="darkorange", name="mode")

    def clear_mode(self, machine: Drawn, pose: np.ndarray) -> None:
        """No mode shape: the machine drawn solid again."""
        for name in [a for a in self.plotter.actors if a.startswith("mode_")]:
            self.plotter.remove_actor(name, render=False)
        self.mode_frames = []
        self.set_pose(machine, pose)

    def png(self) -> bytes:
        """The view as PNG bytes."""
        import io

        from PIL import Image

        buf = io.BytesIO()
        Image.fromarray(self.plotter.screenshot(return_img=True)).save(buf, format="PNG")
        return buf.getvalue()


def _mechanism_mode(at: MechanismAtPose, mode: int):
    """Mode ``mode`` (1 = lowest) of a mechanism's elastic model at its configuration
    (:func:`pkmstiff.mechanisms.modeshape.mode_shapes`); one line where the pose has no configuration."""
    from pkmstiff.errors import ArgumentError
    from pkmstiff.mechanisms.modeshape import mode_shapes

    if not at.ok:
        raise ArgumentError(option="mode", expected="a pose with a configuration", found="none at this pose")
    shapes = mode_shapes(at.mechanism, at.solution, mode)
    if len(shapes) < mode:
        raise ArgumentError(option="mode", expected=f"at most {len(shapes)} (the model's modes)", found=mode)
    return shapes[mode - 1]
