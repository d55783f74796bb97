"""The public study API (pkmstiff.api): results equal the library functions it calls, conversions carry units, and
README examples and studies use nothing but the API."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import pkmstiff
from pkmstiff.api import points as api_points
from pkmstiff.errors import InputError
from pkmstiff.evaluation.sections import axis_plane, evaluate_section
from pkmstiff.machine.frames import neglect_spindle, spindle_neglected

ROOT = Path(__file__).resolve().parents[1]
POSES = np.array([[0.0, 0.0, -1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -0.9, 0.0, 0.0, 0.0], [0.05, 0.3, -0.95, 0.02, 0, 0]])


@pytest.fixture(scope="module")
def m():
    return pkmstiff.load_machine("hexaglide")


def test_load_machine_is_a_machine_with_the_study_methods(m):
    from pkmstiff.admissibility import evaluate_poses
    from pkmstiff.machine import Machine, load_machine

    assert isinstance(m, Machine) and isinstance(m, pkmstiff.StudyMachine)
    plain = load_machine("hexaglide")
    assert not isinstance(plain, pkmstiff.StudyMachine)
    assert pkmstiff.StudyMachine.of(plain).name == plain.name
    ev_api, ev_plain = evaluate_poses(m, POSES), evaluate_poses(plain, POSES)  # the library takes it as a machine
    np.testing.assert_array_equal(ev_api.ok, ev_plain.ok)
    np.testing.assert_array_equal(ev_api.drive, ev_plain.drive)


def test_section_to_xarray_carries_units_and_equals_the_section(m):
    s = m.section("yz", at=0.0, step=0.05, quantities=["kx", "f1"], u_range=(-0.2, 0.6), v_range=(-1.2, -0.6))
    direct = evaluate_section(m, axis_plane("yz", 0.0, (-0.2, 0.6), (-1.2, -0.6), 0.05), ["kx", "f1"],
                              progress=False)
    ds = s.to_xarray()
    assert ds["y"].attrs["units"] == "mm" and ds["z"].attrs["units"] == "mm" and ds["x"].attrs["units"] == "mm"
    assert "machine frame" in ds["y"].attrs["long_name"] and ds.attrs["frame"] == "machine"
    assert ds["kx"].dims == ("z", "y") and ds["kx"].attrs["units"] == "N/um" and ds["f1"].attrs["units"] == "Hz"
    np.testing.assert_array_equal(ds["y"].values, direct.plane.u_values * 1e3)
    np.testing.assert_array_equal(ds["admissible"].values, direct.ok)
    np.testing.assert_array_equal(ds["kx"].values, direct.display("kx"))  # the same function, the same chunks
    assert 0 < direct.ok.sum() < direct.ok.size
    si = s.to_xarray(si=True)
    assert si["kx"].attrs["units"] == "N/m" and si["y"].attrs["units"] == "m"
    np.testing.assert_allclose(si["kx"].values, ds["kx"].values * 1e6, rtol=1e-12)  # N/um -> N/m
    assert s.statistics() == direct.statistics()
    assert set(ds["reasons"].attrs["flag_meanings"].split()) >= {"SINGULAR"} or ds["reasons"].attrs["flag_masks"]


def test_section_window_fitted_when_omitted_and_report_frame(m):
    from pkmstiff.workspace.windows import window_for

    s = m.section("yz", at=0.0, step=0.05, quantities=["kx"], frame="report")
    plane = window_for(m, "yz", 0.0, 0.05, frame="report")
    np.testing.assert_array_equal(s.plane.u_values, plane.u_values)
    assert s.frame == "report" and s.to_xarray()["y"].attrs["long_name"].endswith("(report frame)")


def test_point_equals_the_cli_point_report(m):
    from pkmstiff.cli.point import point_report

    rep = point_report("hexaglide", "0,0,-1000,0,0,0", tool_length_mm=150.0)
    p = m.point(POSES[0], tool_length=0.15)
    assert len(p) == 1 and bool(p.admissible[0]) == rep["admissible"]
    # same functions on the same single pose: equal up to rounding of the 1/C_jj inversion
    np.testing.assert_allclose(p.stiffness[0, :3] / 1e6, [rep["k_N_per_um"][a] for a in "xyz"], rtol=1e-12)
    np.testing.assert_allclose(p.frequencies_hz[0], rep["frequencies_Hz"], rtol=1e-10)
    assert p.mode_descriptions[0] == rep["mode_descriptions"]
    for d in "xyz":
        np.testing.assert_allclose([100 * p.weak_points[d][k][0] for k in rep["weak_points_percent"][d]],
                                   list(rep["weak_points_percent"][d].values()), rtol=1e-10)
    np.testing.assert_allclose(p.drive_loads[0], rep["static_drive_loads_N"], rtol=1e-12)
    np.testing.assert_allclose(p.v_max[0], list(rep["v_max_m_per_s"].values()), rtol=1e-12)


def test_point_batches_are_chunked_without_changing_results(m, monkeypatch):
    whole = m.point(POSES, tool_length=0.1)
    monkeypatch.setattr(api_points, "CHUNK", 1)
    chunked = m.point(POSES, tool_length=0.1)
    # one pose per model vs three in one model: the same arithmetic per pose, BLAS blocking may differ in the last bits
    np.testing.assert_allclose(chunked.stiffness, whole.stiffness, rtol=1e-9)
    np.testing.assert_allclose(chunked.frequencies_hz, whole.frequencies_hz, rtol=1e-9)
    assert chunked.reasons == whole.reasons and whole.reasons[1] and not whole.reasons[0]


def test_point_frames_differ_by_the_report_origin(m):
    report = m.point(POSES[0], frame="report")
    machine = m.point(POSES[0] + np.r_[m.report_origin, 0, 0, 0], frame="machine")
    np.testing.assert_allclose(report.stiffness, machine.stiffness, rtol=1e-12)
    np.testing.assert_array_equal(report.poses, POSES[:1])  # kept in the frame they were given in
    assert report.frame["frame"] == "report" and report.to_pandas().attrs["frame"] == "report"


def test_point_mode_axes_are_the_platforms_screw_axes(m):
    """Chasles: the platform's modal displacement at a point r is u + θ × (r − r0); on the screw axis it is parallel
    to the axis (the translation along it, pitch · θ). The axis points are given in the result's frame."""
    from pkmstiff.analysis import modal_analysis
    from pkmstiff.structure import build_structure

    report = m.point(POSES[0], frame="report", n_modes=4, weak_point_directions=(), kinetostatics=False)
    machine = m.point(POSES[0] + np.r_[m.report_origin, 0, 0, 0], n_modes=4, weak_point_directions=(),
                      kinetostatics=False)
    assert report.mode_axis_point.shape == (1, 4, 3) and report.mode_axis_pitch.shape == (1, 4)
    # positions of about 1 m shifted by the report origin: equal to round-off of the additions
    np.testing.assert_allclose(report.mode_axis_point + m.report_origin, machine.mode_axis_point, atol=1e-9)
    st = build_structure(m, machine.poses)
    ma = modal_analysis(st, 4)
    b = st.model.body("platform")
    v = ma.shapes[0][:, st.model.dof_index("platform")]  # (modes, 6): u at the reference point, θ
    u, th = v[:, :3], v[:, 3:]
    on_axis = u + np.cross(th, machine.mode_axis_point[0] - np.asarray(b.position).reshape(-1, 3)[0])
    d = machine.mode_axis_direction[0]
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, rtol=1e-12)
    # the motion on the axis has no component across it (relative to the motion's size |u|)
    across = np.linalg.norm(np.cross(on_axis, d), axis=1)
    assert np.all(across <= 1e-9 * np.linalg.norm(u, axis=1))
    np.testing.assert_allclose(np.einsum("ij,ij->i", on_axis, d) / np.linalg.norm(th, axis=1),
                               machine.mode_axis_pitch[0], atol=1e-9)  # m/rad: round-off of O(1) m products


def test_point_to_pandas_names_units(m):
    p = m.point(POSES, tool_length=0.15)
    df = p.to_pandas()
    assert len(df) == 3 and {"x_mm", "a_deg", "kx_N_per_um", "krz_Nm_per_urad", "f1_Hz", "transmission_quality",
                             "share_x_drive_joint_percent", "vmax_y_m_per_min", "drive_load_6_N"} <= set(df.columns)
    np.testing.assert_allclose(df["z_mm"], POSES[:, 2] * 1e3)
    np.testing.assert_allclose(df["kx_N_per_um"], p.stiffness[:, 0] / 1e6)
    shares = df[[c for c in df.columns if c.startswith("share_x_")]].sum(axis=1)
    np.testing.assert_allclose(shares[p.modelled], 100.0, rtol=1e-9)  # compliance shares add up (energy balance)
    st = p.statistics()["kx_N_per_um"]
    ok = p.stiffness[p.admissible, 0] / 1e6
    assert st["count"] == ok.size and st["min"] == pytest.approx(ok.min()) and st["max"] == pytest.approx(ok.max())


def test_with_builds_variants(m):
    stiff = m.with_(components={f"linear_motor_{i}": {"k_axial": "50 N/um"} for i in range(1, 7)})
    assert isinstance(stiff, pkmstiff.StudyMachine)
    k0, k1 = m.point(POSES[0]).stiffness[0], stiff.point(POSES[0]).stiffness[0]
    assert np.all(k1[:3] > k0[:3])  # stiffer drives, stiffer TCP (springs in series)
    assert m.with_() is m
    rigid = m.with_(neglect_spindle=True)
    assert rigid.spindle_neglected and spindle_neglected(neglect_spindle(m)) and not m.spindle_neglected
    back = rigid.with_(neglect_spindle=False)
    assert not back.spindle_neglected and back.machine_components == m.machine_components
    opt = m.with_(options=["old_joints_fe"])
    assert opt.name == "hexaglide:old_joints_fe" and opt.with_(neglect_spindle=True).name == opt.name


def test_with_composes_variants_and_replaced_fields(m):
    """A variant of a variant keeps the first variant's changes (the same machine as both changes at once); a field
    changed by dataclasses.replace survives with_ unless with_ changes it too, which is refused in one line."""
    import dataclasses

    motors = {f"linear_motor_{i}": {"k_axial": "50 N/um"} for i in range(1, 7)}
    both = m.with_(components=motors, overrides={"tool.length": "150 mm"})
    stepwise = m.with_(overrides={"tool.length": "150 mm"}).with_(neglect_spindle=True).with_(components=motors)
    assert stepwise.tool.length == pytest.approx(0.15) and stepwise.spindle_neglected
    # the same machine file values, built the same way: bit-identical stiffness
    np.testing.assert_array_equal(stepwise.point(POSES[0]).stiffness,
                                  both.with_(neglect_spindle=True).point(POSES[0]).stiffness)
    replaced = dataclasses.replace(m, transmission_weight=0.5)
    variant = replaced.with_(components=motors)
    assert variant.transmission_weight == 0.5
    assert variant.file_changes == {f"components.linear_motor_{i}.k_axial": "50 N/um" for i in range(1, 7)}
    assert variant.components["linear_motor_1"] == both.components["linear_motor_1"]
    moved = dataclasses.replace(m, tool=dataclasses.replace(m.tool, length=0.2))
    with pytest.raises(InputError, match=r"key 'tool'.*dataclasses.replace") as err:
        moved.with_(overrides={"tool.length": "150 mm"})
    assert "\n" not in str(err.value)
    edited = dataclasses.replace(m, components={**m.components})  # component data: never carried over
    edited.components["linear_motor_1"] = {**m.components["linear_motor_1"], "k_axial": 1.0}
    with pytest.raises(InputError, match="components"):
        edited.with_(overrides={"tool.length": "150 mm"})


def test_workspace_wrapper_equals_the_request(m):
    from pkmstiff.workspace.requests import WorkspaceRequest

    box = (np.array([-0.2, 0.0, -1.1]), np.array([0.2, 0.6, -0.7]))
    w = m.workspace(0.05, box=box)
    direct = WorkspaceRequest(0.05, box=box).evaluate(m)
    assert w.volume == pytest.approx(direct.volume, rel=1e-12) and w.volume > 0
    df = w.to_pandas()
    assert list(df.columns) == ["x_mm", "y_mm", "z_mm"] and len(df) == len(direct.boundary_points)
    assert w.statistics()["volume_m3"] == pytest.approx(w.volume)


# ------------------------------------------------------------------------------- only the public API in examples
#: scripts in studies/ that demonstrate a library layer rather than a design study: they import that layer
LAYER_EXAMPLES = {"example_spring_mass.py": "pkmstiff.multibody"}
#: besides the standard library: the API, numpy, matplotlib and the studies' shared helpers
ALLOWED_TOP_LEVEL = {"pkmstiff", "numpy", "matplotlib", "_study_common", "__future__"}
EXTRA_ALLOWED: dict[str, set[str]] = {}


def _pkmstiff_submodule_imports(code: str) -> list[str]:
    """``pkmstiff.<submodule>`` imports of ``code`` (also inside functions), as ``line: module``."""
    bad = []
    for node in ast.walk(ast.parse(code)):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            names = [node.module or ""]
            if node.module == "pkmstiff":  # "from pkmstiff import evaluation" names a submodule
                import importlib.util

                names += [f"pkmstiff.{a.name}" for a in node.names
                          if importlib.util.find_spec(f"pkmstiff.{a.name}") is not None]
        bad += [f"{node.lineno}: {n}" for n in names
                if (n.startswith("pkmstiff.") or n == "components" or n.startswith("components."))]
    return bad


def test_the_import_check_finds_submodules():
    assert _pkmstiff_submodule_imports("import pkmstiff\nimport numpy as np\n") == []
    assert _pkmstiff_submodule_imports("def f():\n    from pkmstiff.structure import build_structure\n") == [
        "2: pkmstiff.structure"]
    assert _pkmstiff_submodule_imports("from pkmstiff import evaluation\nimport pkmstiff.admissibility.checks as a\n"
                                       ) == ["1: pkmstiff.evaluation", "2: pkmstiff.admissibility.checks"]


def test_readme_examples_use_only_the_public_api():
    from tests.test_docs import fenced_blocks

    bad = [f"README.md:{line}+{imp}" for lang, line, code, _ in fenced_blocks(ROOT / "README.md") if lang == "python"
           for imp in _pkmstiff_submodule_imports(code)]
    assert not bad, bad


@pytest.mark.parametrize("script", sorted(p.name for p in (ROOT / "studies").glob("*.py")))
def test_studies_use_only_the_public_api(script):
    bad = _pkmstiff_submodule_imports((ROOT / "studies" / script).read_text(encoding="utf-8"))
    if script in LAYER_EXAMPLES:  # the generic spring-mass example of the multibody layer, no machine involved
        bad = [b for b in bad if not b.endswith(LAYER_EXAMPLES[script])]
    assert not bad, f"studies/{script} imports internals: {bad}"
    import sys

    allowed = ALLOWED_TOP_LEVEL | set(sys.stdlib_module_names) | EXTRA_ALLOWED.get(script, set())
    tree = ast.parse((ROOT / "studies" / script).read_text(encoding="utf-8"))
    tops = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    tops |= {n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module and not n.level}
    assert tops <= allowed, f"studies/{script} imports {sorted(tops - allowed)}"


def test_point_options_leave_analyses_out_and_add_quantities(m):
    from pkmstiff.admissibility import evaluate_poses

    full = m.point(POSES, quantities=["tilt_drive_1", "kappa"])
    lean = m.point(POSES, n_modes=0, weak_point_directions=(), kinetostatics=False)
    np.testing.assert_array_equal(lean.stiffness, full.stiffness)  # the same model and solve
    assert lean.frequencies_hz.shape == (3, 0) and not lean.weak_points and not lean.velocity_labels
    assert np.isnan(lean.transmission_quality).all() and "transmission_quality" not in lean.to_pandas()
    ev = evaluate_poses(m, POSES)
    ok = ev.ok
    np.testing.assert_allclose(full.quantities["tilt_drive_1"][ok], ev.angles["drive_tilt"][ok, 0], rtol=1e-12)
    assert np.isnan(full.quantities["kappa"][~ok]).all()  # quantities only where admissible, as on a section
    df = full.to_pandas()
    np.testing.assert_allclose(df["tilt_drive_1_deg"][ok], np.degrees(ev.angles["drive_tilt"][ok, 0]), rtol=1e-12)
    assert full.reason_bits[1] and full.reasons[1] == ev.admissibility.failing(1)
    # strut mass at the drive joint instead of the platform joint: stiffness unchanged, frequencies change
    moved = m.point(POSES[0], structure={"strut_mass_to_drive": 1.0})
    np.testing.assert_allclose(moved.stiffness, full.stiffness[:1], rtol=1e-12)
    assert not np.allclose(moved.frequencies_hz, full.frequencies_hz[:1])
    for k in range(full.frequencies_hz.shape[1]):  # energy shares of each mode add up to one
        assert sum(v[0, k] for v in full.mode_kinetic.values()) == pytest.approx(1.0, abs=1e-9)
        assert sum(v[0, k] for v in full.mode_strain.values()) == pytest.approx(1.0, abs=1e-9)


def test_admissibility_and_section_checks(m):
    ok, reasons = m.admissibility(POSES)
    assert ok.tolist() == m.point(POSES).admissible.tolist() and reasons[1] and not reasons[0]
    without = ["platform_collision"]
    assert m.admissibility(POSES[1], skip_checks=without)[0][0]  # pose 1 fails the strut-platform check only
    s = m.section("yz", 0.0, 0.05, [], u_range=(-0.2, 0.6), v_range=(-1.2, -0.6))
    s2 = m.section("yz", 0.0, 0.05, [], u_range=(-0.2, 0.6), v_range=(-1.2, -0.6), skip_checks=without)
    from pkmstiff.admissibility.checks import Reason

    lenient = m.point(POSES, skip_checks=without, n_modes=0)
    assert lenient.admissible.all() and (lenient.reason_bits & int(Reason.PLATFORM_COLLISION) == 0).all()
    with pytest.raises(pkmstiff.InputError):
        m.section("yz", 0.0, 0.05, [], u_range=(-0.2, 0.6), v_range=(-1.2, -0.6), skip_checks=["no_such_check"])
    only_platform = s.result.reasons == int(Reason.PLATFORM_COLLISION)
    assert only_platform.any() and (s2.ok == (s.ok | only_platform)).all()
    assert not (s.fails("platform_collision") & s.ok).any() and s.fails("PLATFORM_COLLISION")[only_platform].all()
    code, names = s.failing_check_codes()
    assert names[0] == "admissible" and ((code == 0) == s.ok).all()


def test_rotation_map_equals_the_library_and_converts(m, tmp_path):
    from pkmstiff.workspace.rotation import rotation_angle_map

    r = m.rotation_map("yz", at=0.0, step=0.1, u_range=(-0.1, 0.5), v_range=(-1.1, -0.7), increment=np.radians(5))
    direct = rotation_angle_map(m, [0, 0, 0], [0, 1, 0], [0, 0, 1], r.u_values, r.v_values,
                                increment=np.radians(5))
    np.testing.assert_array_equal(r.angle("+a"), direct.angles["+a"])
    ds = r.to_xarray()
    assert ds["angle_+a"].attrs["units"] == "deg" and ds["y"].attrs["units"] == "mm"
    np.testing.assert_allclose(ds["angle_+a"].values, np.degrees(direct.angles["+a"]))
    assert r.statistics()["+a"]["max_deg"] == pytest.approx(np.nanmax(np.degrees(direct.angles["+a"])))
    assert r.plot("+a", tmp_path / "a.png").stat().st_size > 1000


def test_plots_write_pngs(m, tmp_path):
    s = m.section("yz", at=0.0, step=0.05, quantities=["kx"], u_range=(-0.2, 0.6), v_range=(-1.2, -0.6))
    assert s.plot("kx", tmp_path / "kx.png").stat().st_size > 1000
    p = m.point(POSES)
    fig = p.plot("kx_N_per_um", against="z_mm", path=tmp_path / "p.png")
    assert fig.axes[0].get_xlabel() == "z_mm" and (tmp_path / "p.png").stat().st_size > 1000
    with pytest.raises(KeyError):
        p.plot("no_such_column")


def test_general_plane_has_no_axis_coordinate():
    from pkmstiff.api import SectionMap
    from pkmstiff.evaluation.sections import general_plane

    m = pkmstiff.load_machine("hexaglide")
    pl = general_plane([0.0, 0.3, -0.9], [1, 0, 0], [0, 1, 1], (-0.1, 0.1), (-0.1, 0.1), 0.05)
    ds = SectionMap(evaluate_section(m, pl, ["kx"], progress=False)).to_xarray()
    assert set(ds.coords) == {"u", "v"} and ds["u"].attrs["units"] == "mm" and ds["kx"].dims == ("v", "u")
