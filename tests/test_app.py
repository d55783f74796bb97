"""The logic of ``pkmstiff app`` without a browser (pkmstiff.app.session, pkmstiff.app.scene): the map equals
``pkmstiff section``'s, a click finds its raster point, the point analysis is ``pkmstiff point``'s, exports never
overwrite, bad choices fail with one line before any work. The browser itself: tests/test_app_browser.py."""

from __future__ import annotations

import io
import json
import shlex

import numpy as np
import pytest

from pkmstiff.app.session import MachineChoice, ModelSettings, SectionChoice, Session, export
from pkmstiff.errors import ArgumentError, InputError

HEXAGLIDE = MachineChoice("hexaglide")
COARSE = SectionChoice(plane="yz", step_mm=50.0, quantity="kx")


@pytest.fixture(scope="module")
def session():
    return Session()


@pytest.fixture(scope="module")
def view(session):
    return session.section(HEXAGLIDE, COARSE)


def _cli(capsys, *args: str) -> str:
    from pkmstiff.cli import main

    capsys.readouterr()
    assert main(list(args)) == 0
    return capsys.readouterr().out


def test_exported_map_and_its_command_equal_the_cli_section(view, tmp_path, capsys):
    folder = export(tmp_path, HEXAGLIDE, view, None)
    section_cmd = (folder / "commands.txt").read_text().splitlines()[0]
    assert section_cmd == COARSE.command(HEXAGLIDE, str(folder / "cli"))
    _cli(capsys, *shlex.split(section_cmd)[1:], "--quiet")
    # one evaluation function (evaluate_section) with the same window, raster and checks in one program: the
    # 10-digit CSV texts are equal, not merely close
    assert (folder / "hexaglide_yz.csv").read_text() == (folder / "cli" / "hexaglide_yz.csv").read_text()
    assert (folder / "hexaglide_yz_kx.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_click_finds_its_raster_point_and_the_picture_shows_it_there(view):
    from PIL import Image

    nv, nu = view.map.ok.shape
    for row in range(nv):
        for col in range(nu):
            assert view.node_at_pixel(*view.pixel_of(row, col)) == (row, col)
    left, top, right, bottom = view.axes_px
    assert view.node_at_pixel(left - 2, top + 5) is None and view.node_at_pixel(right + 2, bottom - 5) is None
    img = np.asarray(Image.open(io.BytesIO(view.png)).convert("RGB")).astype(int)
    assert img.shape[1::-1] == view.size_px
    # an admissible point away from the boundary line is coloured, an inadmissible one far from it is white
    ok = view.map.ok
    inner = ok & np.roll(ok, 1, 0) & np.roll(ok, -1, 0) & np.roll(ok, 1, 1) & np.roll(ok, -1, 1)
    outer = ~ok & ~np.roll(ok, 1, 0) & ~np.roll(ok, -1, 0) & ~np.roll(ok, 1, 1) & ~np.roll(ok, -1, 1)
    inside = np.zeros_like(ok)
    inside[1:-1, 1:-1] = True  # the first and last rows and columns lie on the axes' frame (black)
    inner, outer = inner & inside, outer & inside
    assert inner.sum() > 10 and outer.sum() > 10
    for mask, white in ((inner, False), (outer, True)):
        for row, col in zip(*np.nonzero(mask)):
            x, y = view.pixel_of(row, col)
            assert bool((img[int(round(y)), int(round(x))] >= 250).all()) is white, (row, col)


def test_point_view_is_the_cli_point_analysis(session, view, capsys):
    node = view.central_node()
    pose = view.pose_at(*node)
    pv = session.point(HEXAGLIDE, pose)
    ref = json.loads(_cli(capsys, *shlex.split(pv.command)[1:], "--json"))
    k = pv.stiffness()
    # same structure model at the same pose (the command's 10-digit pose): round-off only
    for ax in "xyz":
        assert k[f"k{ax}"] == pytest.approx(ref["k_N_per_um"][ax], rel=1e-9)
        assert k[f"kr{ax}"] == pytest.approx(ref["rotational_stiffness_Nm_per_urad"][ax], rel=1e-9)
    assert [f for f, _ in pv.modes()] == pytest.approx(ref["frequencies_Hz"], rel=1e-9)
    assert [d for _, d in pv.modes()] == ref["mode_descriptions"]
    for comp, shares in pv.weak_points().items():
        for d, share in shares.items():
            assert share == pytest.approx(ref["weak_points_percent"][d][comp], abs=1e-9)
    # the map's value at the point is the point analysis' (the section's chunked evaluation vs one pose)
    assert view.value_at(*node) == pytest.approx(k["kx"], rel=1e-9)


def test_exports_go_to_new_folders(view, session, tmp_path):
    pv = session.point(HEXAGLIDE, view.pose_at(*view.central_node()))
    first = export(tmp_path, HEXAGLIDE, view, pv, scene_png=b"\x89PNG\r\n\x1a\n")
    second = export(tmp_path, HEXAGLIDE, None, pv)
    assert (first.name, second.name) == ("export-001", "export-002")
    assert (first / "commands.txt").read_text().splitlines()[1] == pv.command
    assert (second / "commands.txt").read_text() == pv.command + "\n"
    import pandas

    row = pandas.read_csv(second / "point.csv")
    assert row["kx_N_per_um"][0] == pytest.approx(pv.stiffness()["kx"], rel=1e-12)
    assert (first / "view_3d.png").is_file() and not (second / "hexaglide_yz.csv").exists()


@pytest.mark.parametrize("choice, field", [
    (SectionChoice(plane="ab"), "plane"), (SectionChoice(step_mm=0.5), "step"), (SectionChoice(step_mm=float("nan")), "step"),
    (SectionChoice(at_mm=float("inf")), "at"), (SectionChoice(orientation_deg=(0.0, 90.0, 0.0)), "orientation"),
    (SectionChoice(quantity="kq"), "kq"), (SectionChoice(quantity="drive_9"), "drive_9")])
def test_bad_choices_fail_in_one_line_before_any_work(session, choice, field):
    with pytest.raises(ArgumentError, match=field) as info:
        session.section(HEXAGLIDE, choice)
    assert "\n" not in str(info.value)


def test_variant_options_and_bad_machines(session):
    from pkmstiff.machine.loader import machine_options

    assert "printed_values" in machine_options("hexaglide")
    m = session.machine(MachineChoice("hexaglide", "printed_values"))
    assert m.name == "hexaglide:printed_values"
    with pytest.raises(InputError, match="options"):
        session.machine(MachineChoice("hexaglide", "no_such_option"))


def test_command_lines_quote_and_keep_negative_values():
    cmd = SectionChoice(plane="xz", at_mm=-100.0, orientation_deg=(-10.0, 0.0, 5.0)).command(
        MachineChoice("my machine.toml"), "out dir")
    assert shlex.split(cmd) == ["pkmstiff", "section", "my machine.toml", "--plane", "xz", "--at", "-100", "--step",
                                "25", "--orientation=-10,0,5", "--quantities", "kx", "--out", "out dir", "--formats",
                                "png,csv"]


def test_scene_animates_the_mode_shape_about_the_pose(session, view):
    from pkmstiff.app.scene import MODE_FRAMES, Scene

    m = session.machine(HEXAGLIDE)
    pose = view.pose_at(*view.central_node())
    scene = Scene(window_size=(400, 300))
    scene.set_machine(m, pose)
    scene.set_section(view)
    scene.set_mode(m, pose, 1)
    assert len(scene.mode_frames) == MODE_FRAMES and "mode 1" in scene.mode_text
    # sin(2πk/N): frame 0 is the undeformed machine, frames k and k + N/2 are mirror images about it
    p0, pk, pm = (scene.mode_frames[k]["platform_joints"].points for k in (0, 4, 4 + MODE_FRAMES // 2))
    assert np.abs(pk - p0).max() > 1.0  # mm: the frame moves visibly
    # the glyph points are float32: at ~1000 mm one unit in the last place is 6e-5 mm
    np.testing.assert_allclose(pk - p0, -(pm - p0), atol=1e-3)
    assert scene.png()[:8] == b"\x89PNG\r\n\x1a\n"
    scene.clear_mode(m, pose)
    assert not scene.mode_frames and not any(a.startswith("mode_") for a in scene.plotter.actors)


def test_a_machine_file_works_like_its_bundled_name(session, view, tmp_path):
    from pkmstiff.machine.loader import bundled_machine_dir

    path = tmp_path / "my hexaglide.toml"
    path.write_text((bundled_machine_dir() / "hexaglide.toml").read_text(encoding="utf-8"), encoding="utf-8")
    from_file = session.section(MachineChoice(str(path)), COARSE)
    np.testing.assert_array_equal(from_file.map.display("kx"), view.map.display("kx"))  # the same machine data
    assert shlex.split(COARSE.command(MachineChoice(str(path))))[2] == str(path)


SETTINGS = ModelSettings(tool_length_mm=150.0, skip_checks=("platform_collision", "drive_load"), neglect_spindle=True,
                         frame="report")


def test_model_settings_reach_the_map_the_point_and_their_commands(session, tmp_path, capsys):
    choice = SectionChoice(plane="xz", at_mm=100.0, step_mm=100.0, quantity="kz", settings=SETTINGS)
    view = session.section(HEXAGLIDE, choice)
    cmd = shlex.split(choice.command(HEXAGLIDE, str(tmp_path / "cli")))
    for opt in (["--tool-length", "150"], ["--skip-check", "platform_collision"], ["--skip-check", "drive_load"],
                ["--neglect-spindle"], ["--frame", "report"]):
        assert any(cmd[i:i + len(opt)] == opt for i in range(len(cmd))), opt
    folder = export(tmp_path, HEXAGLIDE, view, None)
    _cli(capsys, *cmd[1:], "--quiet")
    # the same evaluation on the same inputs: the 10-digit CSV texts are equal
    assert (folder / "hexaglide_xz.csv").read_text() == (tmp_path / "cli" / "hexaglide_xz.csv").read_text()
    plain = session.section(HEXAGLIDE, SectionChoice(plane="xz", at_mm=100.0, step_mm=100.0, quantity="kz"))
    # every setting changes the map: the report frame shifts the window, K_U and the tool change k_z
    assert not np.array_equal(view.map.plane.u_values, plain.map.plane.u_values) or not np.allclose(
        view.map.display("kz"), plain.map.display("kz"), equal_nan=True)
    # the raster point's pose is in the machine frame: the report frame's origin added
    node = view.central_node()
    origin = session.machine(HEXAGLIDE).to_machine_frame(np.zeros(3), "report")
    nu = view.map.plane.shape[1]
    np.testing.assert_allclose(view.pose_at(*node)[:3], view.map.plane.points()[node[0] * nu + node[1]] + origin)
    pv = session.point(HEXAGLIDE, view.pose_at(*node), SETTINGS)
    ref = json.loads(_cli(capsys, *shlex.split(pv.command)[1:], "--json"))
    assert all(o in pv.command for o in ("--tool-length 150", "--neglect-spindle", "--frame report"))
    # the map's value is the point analysis' and the CLI's (same model, same pose: round-off; 10-digit pose)
    assert view.value_at(*node) == pytest.approx(pv.stiffness()["kz"], rel=1e-9)
    assert pv.stiffness()["kz"] == pytest.approx(ref["k_N_per_um"]["z"], rel=1e-9)
    without = session.point(HEXAGLIDE, view.pose_at(*node))
    assert without.stiffness()["kz"] != pytest.approx(pv.stiffness()["kz"], rel=1e-6)  # the settings act


@pytest.mark.parametrize("settings, field", [
    (ModelSettings(tool_length_mm=-1.0), "tool length"), (ModelSettings(skip_checks=("nope",)), "skip checks"),
    (ModelSettings(frame="world"), "frame")])
def test_bad_settings_fail_in_one_line(session, settings, field):
    with pytest.raises(ArgumentError, match=field):
        session.section(HEXAGLIDE, SectionChoice(settings=settings))
    with pytest.raises(ArgumentError, match=field):
        session.point(HEXAGLIDE, np.array([0, 0, -1.0, 0, 0, 0]), settings)


@pytest.mark.parametrize("name, kind", [("slider_crank", "a mechanism"), ("five_bar", "a planar example")])
def test_mechanisms_and_planar_examples_get_one_line(session, name, kind):
    from pkmstiff.analysis.planar import bundled_planar

    if kind == "a planar example" and name not in bundled_planar():
        name = bundled_planar()[0]
    with pytest.raises(ArgumentError, match=kind) as info:
        session.machine(MachineChoice(name))
    hint = f"{name}_generic" if kind == "a planar example" else "pkmstiff section"  # where its map is
    assert hint in str(info.value) and "\n" not in str(info.value)


#: one planar and one spatial mechanism with an [elastic] table, each on a coarse raster (the map is computed twice)
MECHANISM_MAPS = [("five_bar", SectionChoice(plane="xy", step_mm=50.0, quantity="kx")),
                  ("hexa_6rus", SectionChoice(plane="xy", at_mm=-400.0, step_mm=100.0, quantity="kz"))]


@pytest.fixture(scope="module", params=MECHANISM_MAPS, ids=[n for n, _ in MECHANISM_MAPS])
def mechanism_view(request, session):
    name, choice = request.param
    return name, session.mechanism_section(name, choice)


def test_mechanism_map_equals_the_cli_section(mechanism_view, tmp_path, capsys):
    name, mv = mechanism_view
    folder = export(tmp_path, MachineChoice(name), mv, None)
    cmd = (folder / "commands.txt").read_text().splitlines()[0]
    assert cmd == mv.choice.command(MachineChoice(name), str(folder / "cli"))
    _cli(capsys, *shlex.split(cmd)[1:])
    # the same functions (fit_window, evaluate_section, the section writer) in one program: equal texts
    stem = f"{name}_{mv.choice.plane}"
    assert (folder / f"{stem}.csv").read_text() == (folder / "cli" / f"{stem}.csv").read_text()
    assert (folder / f"{stem}.json").read_text() == (folder / "cli" / f"{stem}.json").read_text()
    assert (folder / f"{stem}_{mv.choice.quantity}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert mv.png[:8] == b"\x89PNG\r\n\x1a\n" and mv.map.ok.sum() > 3


def test_mechanism_point_equals_the_cli_point(mechanism_view, session, capsys):
    name, mv = mechanism_view
    rows, cols = np.nonzero(mv.map.ok)
    node = int(rows[len(rows) // 2]), int(cols[len(rows) // 2])
    pv = session.mechanism_point(name, mv.pose_at(*node))
    ref = json.loads(_cli(capsys, *shlex.split(pv.command)[1:], "--json"))
    assert pv.admissible and ref["admissible"]
    k = pv.stiffness()
    # one elastic model at the same pose (the command's 10-digit pose): round-off only
    for ax, v in ref["k_N_per_um"].items():
        assert k[f"k{ax}"] == pytest.approx(v, rel=1e-9)
    for ax, v in ref.get("rotational_stiffness_Nm_per_urad", {}).items():
        assert k[f"kr{ax}"] == pytest.approx(v, rel=1e-9)
    assert set(k) == {f"k{a}" for a in ref["k_N_per_um"]} | {
        f"kr{a}" for a in ref.get("rotational_stiffness_Nm_per_urad", {})}
    assert [f for f, _ in pv.modes()] == pytest.approx(ref["frequencies_Hz"], rel=1e-9)
    assert [d for _, d in pv.modes()][:len(ref["mode_descriptions"])] == ref["mode_descriptions"]
    for comp, shares in pv.weak_points().items():
        for d, share in shares.items():
            assert share == pytest.approx(ref["weak_points_percent"][d][comp], abs=1e-9)
    # the map's value at the point is the point analysis' (the raster's continuation vs one solve: the same
    # configuration to the solver's tolerance)
    q = mv.choice.quantity
    assert mv.value_at(*node) == pytest.approx(k[q], rel=1e-6)


def test_mechanism_without_elastic_data_gets_one_line(session):
    with pytest.raises(ArgumentError, match=r"\[elastic\]") as info:
        session.mechanism_section("slider_crank", SectionChoice(plane="xy", quantity="kappa"))
    assert "\n" not in str(info.value)


def test_a_click_on_a_mechanism_map_finds_its_raster_point(mechanism_view):
    name, mv = mechanism_view
    left, top, right, bottom = mv.axes_px
    assert mv.node_at_pixel(left - 2, top + 5) is None
    u0, u1, v0, v1 = mv.limits_mm
    nv, nu = mv.map.ok.shape
    for row, col in ((0, 0), (nv - 1, nu - 1), (nv // 2, nu // 3)):
        u, v = mv.map.u_values[col] * 1e3, mv.map.v_values[row] * 1e3
        x = left + (u - u0) / (u1 - u0) * (right - left)
        y = top + (v1 - v) / (v1 - v0) * (bottom - top)
        assert mv.node_at_pixel(x, y) == (row, col)
    assert mv.picked_text(0, 0).endswith(f"{mv.choice.quantity} = inadmissible") or "N/um" in mv.picked_text(0, 0)


def _centres(mesh, n: int) -> np.ndarray:
    """Centres (n, 3) of the n equal spheres of a glyph mesh (points in order of the glyphs)."""
    return np.asarray(mesh.points, float).reshape(n, -1, 3).mean(axis=1)


@pytest.mark.parametrize("name, pose", [("hexa_6rus", [0.02, -0.03, -0.42, 0.05, -0.03, 0.08]),
                                        ("five_bar", [0.09, 0.31, 0.0])])
def test_scene_draws_a_mechanism_at_its_pose(session, name, pose):
    """The 3-D view of a mechanism: the output sphere at the output pose, the joint spheres at the joints'
    world points of the configuration (IK of that pose), driven joints separately; a new pose moves them (the
    configuration continued from the one shown). Glyph points are float32: 1e-3 mm at ~500 mm."""
    from pkmstiff.app.mechanisms import app_pose, mechanism_at_pose, mechanism_pose
    from pkmstiff.app.scene import Scene
    from pkmstiff.mechanisms.constraints import Frames

    mech = session.mechanism(name)
    pose = np.asarray(pose, float)
    np.testing.assert_array_equal(mechanism_pose(mech, app_pose(mech, pose)), pose)
    at = mechanism_at_pose(mech, pose)
    assert at.ok
    scene = Scene(window_size=(400, 300))
    scene.set_machine(at, pose)
    out = scene.plotter.actors["machine_output"].mapper.dataset
    xyz = np.concatenate([pose[:mech.dim], np.zeros(3 - mech.dim)])
    np.testing.assert_allclose(_centres(out, 1)[0], xyz * 1e3, atol=1e-3)
    F = Frames(at.solution.q, mech.dim, derivatives=False)
    driven = [j for j in mech.joints if j.drive is not None]
    want = np.array([np.concatenate([F.t[0, j.links[1]] + F.R[0, j.links[1]] @ j.point, np.zeros(3 - mech.dim)])
                     for j in driven]) * 1e3
    got = _centres(scene.plotter.actors["machine_drive_joints"].mapper.dataset, len(driven))
    np.testing.assert_allclose(got, want, atol=1e-3)
    assert name in at.title() and "no configuration" not in at.title()
    moved = pose.copy()
    moved[1] += 0.01
    scene.set_pose(mechanism_at_pose(mech, moved, at), moved)
    out2 = scene.plotter.actors["machine_output"].mapper.dataset
    np.testing.assert_allclose(_centres(out2, 1)[0] - _centres(out, 1)[0], [0.0, 10.0, 0.0], atol=1e-3)
    far = mechanism_at_pose(mech, pose + np.r_[10.0, np.zeros(len(pose) - 1)], at)  # out of reach: the last drawn
    scene.set_pose(far, far.pose)
    assert not far.ok and "no configuration" in far.title()
    np.testing.assert_allclose(_centres(scene.plotter.actors["machine_output"].mapper.dataset, 1), _centres(out2, 1))
    assert scene.png()[:8] == b"\x89PNG\r\n\x1a\n"


def test_scene_shows_a_mechanism_section_and_animates_its_mode(session, mechanism_view):
    """The section plane of a mechanism's map in its place (z = at for xy; a planar mechanism's under its links), and a
    mode shape animated about the configuration: the frequency of ``pkmstiff point``'s analysis, frames k and
    k + N/2 mirror images about the undeformed links."""
    from pkmstiff.app.mechanisms import mechanism_at_pose
    from pkmstiff.app.scene import MODE_FRAMES, PLANAR_OFFSET_MM, Scene

    name, mv = mechanism_view
    mech = session.mechanism(name)
    pose = mv.pose_at(*mv.central_node())
    at = mechanism_at_pose(mech, pose)
    scene = Scene(window_size=(400, 300))
    scene.set_machine(at, pose)
    scene.set_section(mv)
    grid = scene.plotter.actors["section"].mapper.dataset
    z = mv.choice.at_mm if mech.dim == 3 else -PLANAR_OFFSET_MM  # drawn just below a planar mechanism's links
    np.testing.assert_allclose(np.asarray(grid.points)[:, 2], z, atol=1e-6)
    nv, nu = mv.map.ok.shape
    assert grid.n_points == nv * nu
    scene.set_mode(at, pose, 1)
    pv = session.mechanism_point(name, pose)
    assert len(scene.mode_frames) == MODE_FRAMES and f"{pv.modes()[0][0]:.2f} Hz" in scene.mode_text
    # the joint and output spheres translate with their points (the link tubes also turn)
    p0, pk, pm = (np.vstack([scene.mode_frames[k][b].points for b in ("joints", "output")])
                  for k in (0, 4, 4 + MODE_FRAMES // 2))
    assert np.abs(pk - p0).max() > 1.0
    np.testing.assert_allclose(pk - p0, -(pm - p0), atol=1e-3)
    scene.clear_mode(at, pose)
    assert not scene.mode_frames and not any(a.startswith("mode_") for a in scene.plotter.actors)


def test_scene_aims_the_camera_again_when_the_section_plane_changes(session):
    """The camera and the mm axes follow a new section plane (before: they stayed aimed at the machine alone, so a
    plane elsewhere could lie outside the view); a new quantity on the same plane keeps the user's view."""
    from pkmstiff.app.mechanisms import mechanism_at_pose
    from pkmstiff.app.scene import Scene

    name = "hexa_6rus"
    mech = session.mechanism(name)
    xy = session.mechanism_section(name, SectionChoice(plane="xy", at_mm=-400.0, step_mm=100.0, quantity="kz"))
    xz = session.mechanism_section(name, SectionChoice(plane="xz", at_mm=150.0, step_mm=100.0, quantity="kz"))
    pose = xy.pose_at(*xy.central_node())
    scene = Scene(window_size=(400, 300))
    scene.set_machine(mechanism_at_pose(mech, pose), pose)
    machine_focus = np.array(scene.plotter.camera.focal_point)
    counts = []

    def box_centre(view) -> np.ndarray:  # centre of the machine's box joined with the plane's
        pts = view.machine_points() * 1e3
        lo = np.minimum(scene._machine_box[:, 0], pts.min(axis=0))
        hi = np.maximum(scene._machine_box[:, 1], pts.max(axis=0))
        return 0.5 * (lo + hi)

    for view in (xy, xz):
        scene.set_section(view)
        # the camera looks at the centre of the joined box (frame_camera; vtk's reset_camera keeps the focus up to
        # rounding of the padded bounds: 1e-6 mm)
        np.testing.assert_allclose(scene.plotter.camera.focal_point, box_centre(view), atol=1e-6)
        counts.append(len(scene.plotter.actors))
    assert not np.allclose(scene.plotter.camera.focal_point, machine_focus)
    assert counts[0] == counts[1]  # the axes and the section replaced, not added
    scene.plotter.camera.azimuth = 30.0  # the user turns the view …
    turned = scene.plotter.camera_position
    kx = session.mechanism_section(name, SectionChoice(plane="xz", at_mm=150.0, step_mm=100.0, quantity="kx"))
    scene.set_section(kx)  # … and changes the quantity only: the view stays
    assert scene.plotter.camera_position == turned
