"""The trame user interface of ``pkmstiff app`` (thin: every number comes from :mod:`pkmstiff.app.session`, every
picture from :mod:`pkmstiff.app.scene`).

State flows one way: a control changes a state variable → a handler builds a :class:`~pkmstiff.app.session.
MachineChoice`/:class:`~pkmstiff.app.session.SectionChoice` → the session computes in a worker thread (the page stays
live; a newer request supersedes an older one) → the handler puts the result into state. VTK is touched only in the
server's event-loop thread. Served on 127.0.0.1 only; trame serves its own JavaScript, styles and fonts (no network).
"""

from __future__ import annotations

import asyncio
import base64
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from pkmstiff.admissibility.checks import ALL_CHECKS
from pkmstiff.app.scene import Scene
from pkmstiff.app.session import (
    PLANES,
    MachineChoice,
    ModelSettings,
    PointView,
    SectionChoice,
    SectionView,
    Session,
    as_float,
    bundled_machines,
    is_mechanism_target,
    describe_error,
    export,
    machine_options,
    pose_text,
)
from pkmstiff.machine.frames import FRAMES

MM = 1e3
#: the host the app binds to: this computer only
HOST = "127.0.0.1"
#: seconds between the frames of an animated mode shape
FRAME_SECONDS = 0.1
#: seconds a section request waits for further changes (typing "50" asks for one map, not for "5" and "50")
SETTLE_SECONDS = 0.6
POSE_KEYS = ("pose_x", "pose_y", "pose_z", "pose_a", "pose_b", "pose_c")
NO_OPTION = "(none)"
#: what a number field holds while a number is being typed (no error for these)
INCOMPLETE = ("", "-", "+", ".", "-.", "+.")


def _quantity_names() -> list[str]:
    from pkmstiff.evaluation.quantities import available_quantities

    return list(available_quantities())


class App:
    """One app: a trame server, its session and its 3-D scene."""

    def __init__(self, machine: str = "hexaglide", out: str | Path = "pkmstiff-app", server: Any = None,
                 step_mm: float = 25.0):
        from trame.app import get_server

        self.server = server or get_server("pkmstiff", client_type="vue3")
        self.state = self.server.state
        self.session = Session()
        self.scene = Scene()
        self.out = Path(out)
        self.view: SectionView | None = None
        self.point: PointView | None = None
        self._token = 0
        self._animating = False
        self._scene_machine = ""  # the machine the 3-D view was set up for (spec)
        self.mechanism = False  # the chosen machine is a mechanism (drawn as links and joints)
        self.at_pose = None  # the mechanism at the pose of the sliders (MechanismAtPose), None for a machine
        self._init_state(machine, step_mm)
        self._build()
        self.server.controller.on_server_ready.add(lambda **_: self._machine_changed())

    # ---- state -------------------------------------------------------------------------------------------------

    def _init_state(self, machine: str, step_mm: float) -> None:
        s = self.state
        s.trame__title = "pkmstiff app"
        from pkmstiff.app.mechanisms import bundled_elastic_mechanisms

        s.machines = bundled_machines() + bundled_elastic_mechanisms()
        s.machine, s.option, s.options = machine, NO_OPTION, [NO_OPTION]
        s.plane, s.planes = "yz", list(PLANES)
        s.at_mm, s.step_mm, s.quantity, s.quantities = 0.0, step_mm, "kx", _quantity_names()
        s.ori_a, s.ori_b, s.ori_c = 0.0, 0.0, 0.0
        s.tool_length_mm, s.skip_checks, s.checks, s.neglect_spindle = "", [], list(ALL_CHECKS), False
        s.frame, s.frames = "machine", list(FRAMES)
        for k in POSE_KEYS:
            s[k] = 0.0
        s.pose_lo, s.pose_hi = [-1000.0] * 3 + [-60.0] * 3, [1000.0] * 3 + [60.0] * 3
        s.map_src, s.map_summary, s.map_geometry, s.map_version = "", "", "{}", 0
        s.picked, s.point_rows, s.weak_rows, s.weak_dirs, s.mode_items = "click the map", [], [], [], []
        s.point_admissible, s.mode, s.animate, s.mode_shown = "", None, False, ""
        s.section_command, s.point_command, s.export_folder = "", "", ""
        s.status, s.error, s.pose_shown, s.scene_note = "starting", "", "", ""

    def machine_choice(self) -> MachineChoice:
        option = self.state.option
        return MachineChoice(str(self.state.machine).strip(), "" if option in (None, NO_OPTION) else str(option))

    def settings(self) -> ModelSettings:
        s = self.state
        tool = None if str(s.tool_length_mm).strip() == "" else as_float(s.tool_length_mm, "tool length")
        return ModelSettings(tool, tuple(s.skip_checks or ()), bool(s.neglect_spindle), str(s.frame))

    def section_choice(self) -> SectionChoice:
        s = self.state
        return SectionChoice(str(s.plane), as_float(s.at_mm, "at"), as_float(s.step_mm, "step"), str(s.quantity),
                             (as_float(s.ori_a, "a"), as_float(s.ori_b, "b"), as_float(s.ori_c, "c")),
                             self.settings())

    def analysed_machine(self):
        """The machine as the point analysis and the mode shapes see it (K_U left out if asked)."""
        return self.session.machine(self.machine_choice(), bool(self.state.neglect_spindle))

    def pose(self) -> np.ndarray:
        """The pose of the sliders/fields: x, y, z [m], a, b, c [rad]; a mechanism's output pose (planar: x, y and
        a as φ)."""
        v = [as_float(self.state[k], k.removeprefix("pose_")) for k in POSE_KEYS]
        pose = np.array([*(x / MM for x in v[:3]), *(math.radians(a) for a in v[3:])])
        if self.mechanism:
            from pkmstiff.app.mechanisms import mechanism_pose

            return mechanism_pose(self.session.mechanism(self.machine_choice().machine), pose)
        return pose

    def drawn(self, pose: np.ndarray):
        """What the 3-D view draws at ``pose``: the machine as analysed, or the mechanism's configuration there
        (continued from the one shown before)."""
        if not self.mechanism:
            return self.analysed_machine()
        from pkmstiff.app.mechanisms import mechanism_at_pose

        mech = self.session.mechanism(self.machine_choice().machine)
        prev = self.at_pose if self.at_pose is not None and self.at_pose.mechanism is mech else None
        if prev is None or not np.array_equal(prev.pose, pose):
            self.at_pose = mechanism_at_pose(mech, pose, prev)
        return self.at_pose

    def _fail(self, exc: BaseException) -> None:
        self.state.error = describe_error(exc)
        self.state.status = "error"

    # ---- handlers ----------------------------------------------------------------------------------------------

    def _new_machine(self, **_: Any) -> None:
        """Another machine: its options replace the old machine's (the option goes back to none)."""
        if self.state.option != NO_OPTION:
            self.state.option = NO_OPTION  # the option handler then loads the machine
        else:
            self._machine_changed()

    def _machine_changed(self, **_: Any) -> None:
        """A machine or option chosen: load it, offer its options, set the pose limits, recompute the map."""
        s = self.state
        try:
            mc = self.machine_choice()
            self.mechanism = is_mechanism_target(mc.machine)
            if self.mechanism:
                from pkmstiff.app.mechanisms import elastic_mechanism, pose_limits
                from pkmstiff.mechanisms.section import quantity_names

                mech = elastic_mechanism(self.session.mechanism(mc.machine))  # none: one line says why
                s.options, s.quantities = [NO_OPTION], list(quantity_names(mech))
                s.scene_note = ("planar mechanism: pose x, y and a = phi (z, b, c unused)" if mech.dim == 2 else "")
                lo, hi = pose_limits(mech)
                s.pose_lo, s.pose_hi = lo.tolist(), hi.tolist()
                if mech.dim == 2:
                    s.plane = "xy"
            else:
                self.session.machine(mc)  # a planar example: one line says why it is not shown
                s.options, s.quantities, s.scene_note = [NO_OPTION, *machine_options(mc.machine)], _quantity_names(), ""
                lo, hi = self.session.pose_limits(mc)
                s.pose_lo, s.pose_hi = lo.tolist(), hi.tolist()
        except Exception as exc:  # the message bar says what is wrong; the app stays up
            self._fail(exc)
            return
        s.error = ""
        self._request_section()

    def _section_changed(self, **_: Any) -> None:
        self._request_section()

    def _request_section(self) -> None:
        from trame.app import asynchronous

        self._token += 1
        asynchronous.create_task(self._compute_section(self._token))

    async def _compute_section(self, token: int) -> None:
        s = self.state
        await asyncio.sleep(SETTLE_SECONDS)
        if token != self._token:  # superseded while settling
            return
        try:
            mc, sc = self.machine_choice(), self.section_choice()
        except Exception as exc:
            with s:
                self._fail(exc)
            return
        with s:
            s.status, s.error = "computing the section map…", ""
        try:
            compute = self.session.mechanism_section if self.mechanism else self.session.section
            view = await asyncio.get_running_loop().run_in_executor(
                None, compute, mc.machine if self.mechanism else mc, sc)
        except Exception as exc:
            if token == self._token:
                with s:
                    self._fail(exc)
            return
        if token != self._token:  # a newer request is on its way
            return
        with s:
            self.view = view
            s.map_src = "data:image/png;base64," + base64.b64encode(view.png).decode()
            s.map_summary = view.summary()
            s.map_version += 1
            s.map_geometry = json.dumps({"version": s.map_version, "size_px": view.size_px, "axes_px": view.axes_px,
                                         "limits_mm": view.limits_mm, "quantity": sc.quantity, "unit": view.unit})
            s.section_command = sc.command(mc)
            node = view.central_node()
            if self._scene_machine != mc.spec:  # a new machine: start at the middle of the admissible region
                if node is not None:
                    self._set_pose(view.pose_at(*node))
                self.at_pose = None
                pose = self.pose()
                self.scene.set_machine(self.drawn(pose), pose)  # and aim the camera at it
                self._scene_machine = mc.spec
            self.scene.set_section(view)
            self._update_view()
            s.status = "ready"

    def _set_pose(self, pose: np.ndarray) -> None:
        """Move the sliders to ``pose`` (a machine's or a mechanism's output pose; the pose handler then redraws)."""
        if self.mechanism:
            from pkmstiff.app.mechanisms import app_pose

            pose = app_pose(self.session.mechanism(self.machine_choice().machine), pose)
        values = [*(pose[:3] * MM), *np.degrees(pose[3:6])]
        self.state.update({k: round(float(v), 6) for k, v in zip(POSE_KEYS, values)})

    def _pose_changed(self, **_: Any) -> None:
        if any(str(self.state[k]).strip() in INCOMPLETE for k in POSE_KEYS):
            return  # still typing
        try:
            pose = self.pose()
            m = self.drawn(pose)
        except Exception as exc:
            self._fail(exc)
            return
        self.state.animate, self.state.error, self.state.status = False, "", "ready"
        self.state.pose_shown = pose_text(m.pose_values() if self.mechanism else pose)
        if self.scene.mode_frames:
            self.scene.clear_mode(m, pose)
            self.state.mode, self.state.mode_shown = None, ""
        else:
            self.scene.set_pose(m, pose)
        self._update_view()

    def on_map_click(self, x: float, y: float, width: float, height: float) -> None:
        """A click on the map picture (pixels of the shown picture): the nearest raster point's pose and its point
        analysis."""
        if self.view is None or not width or not height:
            return
        w, h = self.view.size_px
        node = self.view.node_at_pixel(x * w / width, y * h / height)
        if node is None:
            return
        pose = self.view.pose_at(*node)
        self.state.picked = self.view.picked_text(*node)
        self._set_pose(pose)
        self._start_analysis(pose)

    def analyse_pose(self) -> None:
        """The button: the point analysis at the pose of the sliders and fields."""
        try:
            pose = self.pose()
        except Exception as exc:
            self._fail(exc)
            return
        self.state.picked = f"pose {pose_text(pose)}"
        self._start_analysis(pose)

    def _start_analysis(self, pose: np.ndarray) -> None:
        from trame.app import asynchronous

        try:
            settings = self.settings()
        except Exception as exc:
            self._fail(exc)
            return
        asynchronous.create_task(self._analyse(self.machine_choice(), pose, settings))

    async def _analyse(self, mc: MachineChoice, pose: np.ndarray, settings: ModelSettings) -> None:
        s = self.state
        with s:
            s.status = "analysing the point…"
        try:
            analyse = self.session.mechanism_point if self.mechanism else self.session.point
            pv = await asyncio.get_running_loop().run_in_executor(
                None, analyse, mc.machine if self.mechanism else mc, pose, settings)
        except Exception as exc:
            with s:
                self._fail(exc)
            return
        with s:
            self.point = pv
            k = pv.stiffness()
            s.point_admissible = "admissible" if pv.admissible else "NOT admissible: " + "; ".join(pv.reasons)
            s.point_rows = [{"id": f"k-{n}", "name": f"k_{n[1:]}", "value": f"{v:.3f}",
                             "unit": "N·m/µrad" if n.startswith("kr") else "N/µm"} for n, v in k.items()]
            wp = pv.weak_points()
            s.weak_dirs = list(next(iter(wp.values()))) if wp else []
            s.weak_rows = [{"component": c, "shares": [f"{v:.1f}" for v in d.values()]} for c, d in wp.items()]
            s.mode_items = [{"title": f"{i + 1}: {f:.2f} Hz" + (f", {d}" if d else ""), "value": i + 1,
                             "hz": f"{f:.2f}"} for i, (f, d) in enumerate(pv.modes())]
            s.mode, s.animate = None, False
            s.point_command = pv.command
            s.status = "ready"

    def _mode_changed(self, mode: int | None = None, **_: Any) -> None:
        try:
            pose = self.pose()
            m = self.drawn(pose)
            if mode:
                self.scene.set_mode(m, pose, int(mode))
            else:
                self.state.animate = False
                self.scene.clear_mode(m, pose)
            self.state.mode_shown = self.scene.mode_text if self.scene.mode_frames else ""
        except Exception as exc:
            self._fail(exc)
        self._update_view()

    def _animate_changed(self, animate: bool = False, **_: Any) -> None:
        from trame.app import asynchronous

        if animate and not self._animating and self.scene.mode_frames:
            asynchronous.create_task(self._animation())

    async def _animation(self) -> None:
        self._animating = True
        pose = self.pose()
        m, k = self.drawn(pose), 0
        try:
            while self.state.animate and self.scene.mode_frames:
                k += 1
                self.scene.show_mode_frame(m, pose, k)
                self._update_view()
                await asyncio.sleep(FRAME_SECONDS)
        finally:
            self._animating = False

    def export_shown(self) -> None:
        """PNG, CSV and the commands of what is shown, into a new folder under the export directory."""
        try:
            folder = export(self.out, self.machine_choice(), self.view, self.point, self.scene.png())
        except Exception as exc:
            self._fail(exc)
            return
        self.state.export_folder = str(folder.resolve())

    def _update_view(self) -> None:
        update = self.server.controller.view_update
        if update.exists():
            update()

    # ---- layout ------------------------------------------------------------------------------------------------

    def _build(self) -> None:
        from trame.ui.vuetify3 import VAppLayout
        from trame.widgets import html
        from trame.widgets import vtk as vtk_widgets
        from trame.widgets import vuetify3 as v3
        from vtkmodules.vtkRenderingCore import vtkRenderWindowInteractor

        s, ctrl = self.state, self.server.controller
        s.change("machine")(self._new_machine)
        s.change("option")(self._machine_changed)
        s.change("plane", "at_mm", "step_mm", "quantity", "ori_a", "ori_b", "ori_c", "tool_length_mm", "skip_checks",
                 "neglect_spindle", "frame")(self._section_changed)
        s.change(*POSE_KEYS)(self._pose_changed)
        s.change("mode")(self._mode_changed)
        s.change("animate")(self._animate_changed)
        ren_win = self.scene.plotter.ren_win
        interactor = vtkRenderWindowInteractor()  # mouse rotation and zoom in the remote view
        interactor.SetRenderWindow(ren_win)
        interactor.GetInteractorStyle().SetCurrentStyleToTrackballCamera()
        field = {"density": "compact", "hide_details": True, "variant": "outlined", "classes": "mb-2"}
        with VAppLayout(self.server, fill_height=True) as layout:
            with v3.VNavigationDrawer(permanent=True, width=360, classes="pa-3"):
                html.Div("pkmstiff app", classes="text-h6 mb-2")
                v3.VCombobox(label="machine (bundled name or file)", v_model=("machine",), items=("machines",),
                             id="machine", **field)
                v3.VSelect(label="variant option", v_model=("option",), items=("options",), id="option", **field)
                html.Div("section map", classes="text-subtitle-2 mt-2")
                v3.VSelect(label="plane", v_model=("plane",), items=("planes",), id="plane", **field)
                with v3.VRow(dense=True):
                    with v3.VCol():
                        v3.VTextField(label="at [mm]", v_model=("at_mm",), id="at", **field)
                    with v3.VCol():
                        v3.VTextField(label="step [mm]", v_model=("step_mm",), id="step", **field)
                v3.VCombobox(label="quantity", v_model=("quantity",), items=("quantities",), id="quantity", **field)
                with v3.VRow(dense=True):
                    for key, name in (("ori_a", "a"), ("ori_b", "b"), ("ori_c", "c")):
                        with v3.VCol():
                            v3.VTextField(label=f"tool {name} [deg]", v_model=(key,), id=f"ori-{name}", **field)
                with v3.VRow(dense=True):
                    with v3.VCol():
                        v3.VTextField(label="tool length [mm]", v_model=("tool_length_mm",), id="tool-length",
                                      placeholder="machine file", persistent_placeholder=True, **field)
                    with v3.VCol():
                        v3.VSelect(label="frame", v_model=("frame",), items=("frames",), id="frame", **field)
                v3.VSelect(label="checks left out", v_model=("skip_checks",), items=("checks",), id="skip-checks",
                           multiple=True, chips=True, closable_chips=True, **field)
                v3.VCheckbox(label="neglect the spindle stiffness K_U", v_model=("neglect_spindle",),
                             id="neglect-spindle", density="compact", hide_details=True)
                html.Div("pose (machine frame; drag or type)", classes="text-subtitle-2 mt-2")
                for i, key in enumerate(POSE_KEYS):
                    name = key.removeprefix("pose_")
                    unit = "mm" if i < 3 else "deg"
                    with v3.VRow(dense=True, align="center"):
                        with v3.VCol(cols=8):
                            v3.VSlider(v_model=(key,), min=(f"pose_lo[{i}]",), max=(f"pose_hi[{i}]",),
                                       step=1 if i < 3 else 0.5, hide_details=True, density="compact",
                                       label=name)
                        with v3.VCol(cols=4):
                            v3.VTextField(v_model=(key,), suffix=unit, id=f"pose-{name}", **field)
                v3.VBtn("analyse this pose", click=self.analyse_pose, block=True, classes="mb-2", id="analyse")
                v3.VBtn("export PNG, CSV, commands", click=self.export_shown, block=True, color="primary",
                        id="export")
                html.Div("{{ export_folder }}", id="export-folder", classes="text-caption mt-1",
                         style="word-break: break-all")
            with v3.VMain():
                with v3.VContainer(fluid=True, classes="pa-2"):
                    html.Div("{{ status }}", id="status", classes="text-caption")
                    v3.VAlert(text=("error",), v_show="error", type="error", density="compact", id="error",
                              classes="mb-2")
                    with v3.VRow(dense=True):
                        with v3.VCol(cols=12, lg=6):
                            html.Img(src=("map_src",), id="section-map", style="width: 100%; cursor: crosshair",
                                     click=(self.on_map_click, ("[$event.offsetX, $event.offsetY, "
                                                                "$event.target.clientWidth, $event.target.clientHeight]")))
                            html.Div("{{ map_summary }}", id="map-summary", classes="text-caption")
                            html.Div("{{ map_geometry }}", id="map-geometry", style="display: none")
                        with v3.VCol(cols=12, lg=6):
                            html.Div("machine at {{ pose_shown }}", id="pose-shown", classes="text-caption")
                            html.Div("{{ scene_note }}", id="scene-note", classes="text-caption")
                            with html.Div(id="view-3d", style="height: 520px; border: 1px solid #ddd"):
                                view = vtk_widgets.VtkRemoteView(ren_win, ref="view3d", interactive_ratio=1)
                                ctrl.view_update = view.update
                    with v3.VRow(dense=True):
                        with v3.VCol(cols=12, md=4):
                            html.Div("point: {{ picked }}", id="picked", classes="text-subtitle-2")
                            html.Div("{{ point_admissible }}", id="point-admissible", classes="text-caption")
                            with v3.VTable(density="compact"):
                                with html.Tbody():
                                    with html.Tr(v_for="row in point_rows", key="row.id"):
                                        html.Td("{{ row.name }}")
                                        html.Td("{{ row.value }}", raw_attrs=[':id="row.id"'])
                                        html.Td("{{ row.unit }}")
                        with v3.VCol(cols=12, md=4):
                            html.Div("weak points: share of the TCP compliance [%]", classes="text-subtitle-2")
                            with v3.VTable(density="compact", id="weak-points"):
                                with html.Thead():
                                    with html.Tr():
                                        html.Th("component")
                                        html.Th("{{ d }}", v_for="d in weak_dirs", key="d")
                                with html.Tbody():
                                    with html.Tr(v_for="row in weak_rows", key="row.component"):
                                        html.Td("{{ row.component }}")
                                        html.Td("{{ v }}", v_for="(v, j) in row.shares", key="j")
                        with v3.VCol(cols=12, md=4):
                            html.Div("modes (choose one to see its shape)", classes="text-subtitle-2")
                            v3.VSelect(v_model=("mode",), items=("mode_items",), id="mode", clearable=True,
                                       label="mode", **field)
                            html.Div("{{ mode_shown }}", id="mode-shown", classes="text-caption")
                            v3.VSwitch(v_model=("animate",), label="animate the mode shape", id="animate",
                                       hide_details=True, density="compact", color="primary")
                            with html.Ol(id="modes", classes="text-caption ml-4"):
                                html.Li("{{ m.title.split(': ')[1] }}", v_for="m in mode_items", key="m.value")
                    html.Div("commands that reproduce what is shown", classes="text-subtitle-2 mt-2")
                    html.Pre("{{ section_command }}\n{{ point_command }}", id="commands",
                             style="white-space: pre-wrap; font-size: 12px")
        self.layout = layout

    def start(self, port: int = 0, open_browser: bool = True) -> None:
        """Serve on 127.0.0.1:``port`` (0: a free port) until interrupted; the URL is printed."""
        import os
        import sys

        # trame reads its own options (--host among them) from sys.argv and TRAME_ARGS: give it none, so that the
        # app binds to HOST whatever the command line or the environment say
        argv, sys.argv = sys.argv, sys.argv[:1]
        trame_args = os.environ.pop("TRAME_ARGS", None)
        try:
            self.server.start(port=port, host=HOST, open_browser=open_browser, timeout=0)
        finally:
            sys.argv = argv
            if trame_args is not None:
                os.environ["TRAME_ARGS"] = trame_args
