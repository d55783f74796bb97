"""Joint models (eq. 3.30, spline interpolation of Cobet 3.2.5, swivel-tilt tables) and the CSV joint tables."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from components import ComponentState
from components.joint_tables import JointTableNotFound, parse_joint_table
from components.joints import (
    AnalyticJoint330,
    ConstantJoint,
    ProductJoint,
    SwivelTiltTableJoint,
    TiltTableJoint,
    bundled_tables,
    joint_from_table,
    load_joint_table,
    write_joint_table,
)
from components.protocol import ComponentRangeError
from components.spline import clamped_spline, spline_weights
from pkmstiff.errors import InputError
from pkmstiff.units import si, to_unit

DEG = np.deg2rad
ANGLES = np.arange(0, 91, 15)
M3 = [262, 136, 71, 49, 37, 31, 30]  # component-data.md §1, drive-side 3-DOF joint, N/um
M2 = [269, 232, 196, 161, 148, 152, 154]  # platform-side 2-DOF joint
FE2 = [337.8, 214.6, 134.0, 101.0, 86.1, 80.5, 81.3]  # Table 3.3
AN = [214.29, 201.54, 180.35, 163.20, 151.60, 144.99, 142.86]  # component-data.md §5


def tilt_state(deg):
    return ComponentState(tilt=DEG(np.asarray(deg, dtype=float)))


# ------------------------------------------------------------------ analytic model, eq. 3.30
def test_analytic_3_30_matches_reference_values_and_drops_33_percent():
    joint = AnalyticJoint330(name="a", k_AaL=600e6, k_BrL=500e6, k_CrL=500e6, k_CaL=600e6)
    k = to_unit(joint.stiffness(tilt_state(ANGLES)), "N/um")
    np.testing.assert_allclose(k, AN, atol=0.01)  # the spec prints two decimals
    assert 1 - k[-1] / k[0] == pytest.approx(1 / 3, abs=0.005)  # "drops by 33 %"
    # closed form at the ends: 600000/2800 and 600000/4200 N/um
    assert k[0] == pytest.approx(600000 / 2800, rel=1e-12)
    assert k[-1] == pytest.approx(600000 / 4200, rel=1e-12)


def test_analytic_reference_table_agrees_with_the_model():
    table = load_joint_table("analytic_3_30_reference")
    joint = AnalyticJoint330(name="a", k_AaL=600e6, k_BrL=500e6, k_CrL=500e6, k_CaL=600e6)
    np.testing.assert_allclose(joint.stiffness(ComponentState(tilt=table.tilt)), table.stiffness, atol=si(0.01, "N/um"))


# ------------------------------------------------------------------ spline (Cobet 3.2.5)
@pytest.mark.parametrize("name, values", [("hexaglide_3dof_improved_measured", M3),
                                          ("hexaglide_2dof_improved_measured", M2),
                                          ("hexaglide_2dof_improved_fe", FE2)])
def test_bundled_tables_hold_the_spec_values(name, values):
    t = load_joint_table(name)
    np.testing.assert_allclose(t.tilt, DEG(ANGLES), rtol=1e-15)
    np.testing.assert_allclose(to_unit(t.stiffness, "N/um"), values, rtol=1e-12)
    assert t.angle_convention == "axis" and t.method in ("measured", "FE")
    assert "Cobet" in t.metadata["source"]


def test_fe_table_is_5kN_over_the_printed_deformations():
    deformation_um = np.array([14.8, 23.3, 37.3, 49.5, 58.1, 62.1, 61.5])
    k = to_unit(load_joint_table("hexaglide_2dof_improved_fe").stiffness, "N/um")
    np.testing.assert_allclose(k, 5000 / deformation_um, atol=0.05)  # Table 3.3 rounds to 0.1 N/um


@pytest.mark.parametrize("values, s0, sn", [(M3, -8.4, -0.0667), (M2, -2.4667, 0.1333)])
def test_table_spline_passes_through_nodes_and_uses_end_slope_rule(values, s0, sn):
    joint = TiltTableJoint(name="j", tilt_nodes=DEG(ANGLES), k_nodes=si(np.array(values, float), "N/um"))
    np.testing.assert_allclose(to_unit(joint.stiffness(tilt_state(ANGLES)), "N/um"), values, rtol=1e-12)
    per_deg = si(1.0, "N/um") * 180 / np.pi  # N/um per degree -> N/m per rad
    d = joint.derivative(tilt_state([0.0, 90.0])) / per_deg
    np.testing.assert_allclose(d, [s0, sn], atol=5e-5)  # the spec prints the slopes with 4 decimals
    # independent check by one-sided finite differences of the stiffness itself (O(h) truncation ~1e-6 rel)
    h = 1e-6
    k = joint.stiffness(ComponentState(tilt=np.array([0.0, h, np.pi / 2 - h, np.pi / 2])))
    fd = np.array([(k[1] - k[0]) / h, (k[3] - k[2]) / h]) / per_deg
    np.testing.assert_allclose(fd, [(values[1] - values[0]) / 15, (values[-1] - values[-2]) / 15], rtol=1e-4, atol=1e-6)


def test_spline_is_twice_continuously_differentiable_at_inner_nodes():
    spline = clamped_spline(DEG(ANGLES), np.array(M3, float))
    eps = 1e-9
    for t in DEG(ANGLES[1:-1]):
        left, right = spline(t - eps, 2), spline(t + eps, 2)
        assert left == pytest.approx(right, rel=1e-5, abs=1e-6)  # C2: a cubic spline, not a Hermite patchwork


@given(st.lists(st.floats(1.0, 500.0), min_size=2, max_size=9), st.floats(0.0, 1.0))
@settings(max_examples=50, deadline=None)
def test_spline_reproduces_nodes_and_linear_data(values, frac):
    x = np.linspace(0.0, np.pi / 2, len(values))
    joint = TiltTableJoint(name="j", tilt_nodes=x, k_nodes=np.array(values))
    np.testing.assert_allclose(joint.stiffness(ComponentState(tilt=x)), values, rtol=1e-10)
    # linear data are reproduced exactly (the secant end slopes are the true slopes)
    lin = TiltTableJoint(name="j", tilt_nodes=x, k_nodes=100.0 + 50.0 * x)
    t = frac * np.pi / 2
    assert lin.stiffness(ComponentState(tilt=[t]))[0] == pytest.approx(100.0 + 50.0 * t, rel=1e-10)


def test_extrapolation_policies_clamp_and_error():
    clamp = joint_from_table(load_joint_table("hexaglide_3dof_improved_measured"))
    k = to_unit(clamp.stiffness(tilt_state([-5.0, 0.0, 90.0, 100.0])), "N/um")
    np.testing.assert_allclose(k, [262.0, 262.0, 30.0, 30.0], rtol=1e-12)
    assert "extrapolation" in clamp.assumptions
    strict = joint_from_table(load_joint_table("hexaglide_3dof_improved_measured"), extrapolation="error")
    with pytest.raises(ComponentRangeError, match=r"tilt = 100 deg \(pose 1\).*\[0, 90\] deg"):
        strict.stiffness(tilt_state([45.0, 100.0]))
    # exactly at the table end (round-off of an arccos) is not an error
    assert strict.stiffness(ComponentState(tilt=[np.pi / 2 + 1e-15]))[0] == pytest.approx(30e6)
    with pytest.raises(ValueError, match="extrapolation"):
        TiltTableJoint(name="j", tilt_nodes=[0, 1], k_nodes=[1, 2], extrapolation="linear")


def test_nan_tilt_propagates_only_to_its_pose():
    for policy in ("clamp", "error"):
        joint = joint_from_table(load_joint_table("hexaglide_2dof_improved_measured"), extrapolation=policy)
        k = joint.stiffness(tilt_state([0.0, np.nan, 90.0]))
        assert np.isnan(k[1]) and np.all(np.isfinite(k[[0, 2]]))
    k = AnalyticJoint330(name="a", k_AaL=6e8, k_BrL=5e8, k_CrL=5e8, k_CaL=6e8).stiffness(tilt_state([np.nan, 0.0]))
    assert np.isnan(k[0]) and np.isfinite(k[1])


def test_constant_joint_and_limits():
    joint = ConstantJoint(name="c", k=1e8, limits={"tilt_min": DEG(5.0)})
    state = tilt_state([3.0, 5.0, 60.0])
    assert np.all(joint.stiffness(state) == 1e8)
    np.testing.assert_array_equal(joint.within_limits(state), [False, True, True])
    nan_swivel = ComponentState(tilt=DEG([10.0]), swivel=[np.nan])
    assert ConstantJoint(name="c", k=1e8, limits={"swivel_max": 0.1}).within_limits(nan_swivel)[0]


# ------------------------------------------------------------------ swivel-tilt tables
SW = DEG(np.array([0.0, 45.0, 90.0]))
TI = DEG(np.array([-30.0, 0.0, 30.0, 60.0]))


def test_bicubic_grid_passes_through_nodes_and_reproduces_bilinear_data():
    phi, th = np.meshgrid(SW, TI, indexing="ij")
    grid = 1e8 * (2.0 + 0.3 * phi - 0.2 * th + 0.1 * phi * th)
    joint = SwivelTiltTableJoint(name="g", swivel_nodes=SW, tilt_nodes=TI, k_grid=grid)
    k = joint.stiffness(ComponentState(swivel=phi.ravel(), tilt=th.ravel()))
    np.testing.assert_allclose(k, grid.ravel(), rtol=1e-12)
    rng = np.random.default_rng(3)
    p, t = rng.uniform(SW[0], SW[-1], 50), rng.uniform(TI[0], TI[-1], 50)
    np.testing.assert_allclose(joint.stiffness(ComponentState(swivel=p, tilt=t)),
                               1e8 * (2.0 + 0.3 * p - 0.2 * t + 0.1 * p * t), rtol=1e-10)


def test_bicubic_of_separable_data_equals_product_of_1d_splines():
    a = np.array([1.0, 0.6, 0.9])  # along swivel: low in the middle (INA, component-data.md §4)
    b = np.array([0.7, 0.8, 1.0, 0.75])
    joint = SwivelTiltTableJoint(name="g", swivel_nodes=SW, tilt_nodes=TI, k_grid=2e8 * np.outer(a, b))
    product = ProductJoint(name="p", k_ref=2e8, swivel_nodes=SW, g_swivel=a, tilt_nodes=TI, g_tilt=b)
    rng = np.random.default_rng(4)
    state = ComponentState(swivel=rng.uniform(0, np.pi / 2, 40), tilt=rng.uniform(-0.5, 1.0, 40))
    np.testing.assert_allclose(joint.stiffness(state), product.stiffness(state), rtol=1e-10)
    # the product form is k_ref at the maxima of both curves
    assert product.stiffness(ComponentState(swivel=[0.0], tilt=[DEG(30.0)]))[0] == pytest.approx(2e8, rel=1e-12)


def test_swivel_tilt_undefined_swivel_and_range_policy():
    grid = 1e8 * (1.0 + np.arange(12.0).reshape(3, 4))
    nan_policy = SwivelTiltTableJoint(name="g", swivel_nodes=SW, tilt_nodes=TI, k_grid=grid)
    fixed = SwivelTiltTableJoint(name="g", swivel_nodes=SW, tilt_nodes=TI, k_grid=grid, undefined_swivel=float(SW[1]))
    state = ComponentState(swivel=[np.nan, SW[1]], tilt=[TI[1], TI[1]])
    k = nan_policy.stiffness(state)
    assert np.isnan(k[0]) and k[1] == pytest.approx(grid[1, 1], rel=1e-12)
    np.testing.assert_allclose(fixed.stiffness(state), [grid[1, 1], grid[1, 1]], rtol=1e-12)
    strict = SwivelTiltTableJoint(name="g", swivel_nodes=SW, tilt_nodes=TI, k_grid=grid, extrapolation="error")
    with pytest.raises(ComponentRangeError, match="swivel = 100 deg"):
        strict.stiffness(ComponentState(swivel=DEG([100.0]), tilt=[0.0]))
    clamped = nan_policy.stiffness(ComponentState(swivel=DEG([100.0]), tilt=DEG([-40.0])))
    assert clamped[0] == pytest.approx(grid[2, 0], rel=1e-12)


def test_spline_weights_rows_sum_to_one():
    w = spline_weights(TI, np.linspace(TI[0], TI[-1], 17))
    np.testing.assert_allclose(w.sum(axis=1), 1.0, rtol=1e-12)  # constants are reproduced


# ------------------------------------------------------------------ CSV tables: writer, loader, validation
META = {"name": "test_joint", "source": "unit test", "method": "measured", "quantity": "axial stiffness",
        "angle_convention": "normal", "load": "1 kN"}


def test_write_and_load_round_trip_1d_and_2d(tmp_path):
    p1 = write_joint_table(tmp_path / "one.csv", [0.0, 15.0, 30.0], si(np.array([100.0, 90.5, 80.25]), "N/um"), META)
    t1 = load_joint_table(p1)
    np.testing.assert_array_equal(to_unit(t1.stiffness, "N/um"), [100.0, 90.5, 80.25])
    np.testing.assert_allclose(t1.tilt, DEG([0.0, 15.0, 30.0]), rtol=1e-15)
    assert t1.metadata == META and t1.angle_convention == "normal"
    grid = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.5]])
    p2 = write_joint_table(tmp_path / "two.csv", [-10.0, 0.0, 10.0], grid, META, swivel_deg=[0.0, 45.0], k_unit="N/um")
    t2 = load_joint_table(str(p2))
    np.testing.assert_array_equal(to_unit(t2.stiffness, "N/um"), grid)
    np.testing.assert_allclose(t2.swivel, DEG([0.0, 45.0]), rtol=1e-15)
    assert isinstance(joint_from_table(t2), SwivelTiltTableJoint)


def test_writer_validates_before_writing(tmp_path):
    with pytest.raises(InputError, match="method"):
        write_joint_table(tmp_path / "bad.csv", [0.0, 10.0], [1e8, 2e8], {**META, "method": "guessed"})
    fe = {**META, "method": "FE"}
    with pytest.raises(InputError, match="mesh_size"):
        write_joint_table(tmp_path / "bad.csv", [0.0, 10.0], [1e8, 2e8], fe)
    with pytest.raises(InputError, match="positive"):
        write_joint_table(tmp_path / "bad.csv", [0.0, 10.0], [1e8, -2e8], META)
    assert not (tmp_path / "bad.csv").exists()
    full_fe = {**fe, "parameters": "E=210 GPa", "mesh_size": "2 mm", "element_type": "tet10", "date": "2024-01-01",
               "version": "pkmstiff 0.1"}
    assert load_joint_table(write_joint_table(tmp_path / "fe.csv", [0.0, 10.0], [1e8, 2e8], full_fe)).method == "FE"


HEAD = "# name: t\n# source: s\n# method: measured\n# quantity: q\n# angle_convention: axis\n"


@pytest.mark.parametrize("text, pattern", [
    (HEAD + "tilt_deg,k_N_per_um\n0,100\n15,-5\n", r"bad\.csv: key 'line 8, column k_N_per_um'.*positive"),
    (HEAD + "tilt_deg,k_N_per_um\n0,100\n30,90\n15,80\n", r"line 9, column tilt_deg.*strictly increasing"),
    (HEAD + "tilt_deg,k_N_per_um\n0,100\n15,abc\n", r"line 8, column k_N_per_um.*a number"),
    (HEAD + "tilt,k\n0,100\n15,90\n", r"line 6 \(header\)"),
    (HEAD.replace("measured", "simulated") + "tilt_deg,k_N_per_um\n0,1\n9,2\n", r"metadata 'method'.*simulated"),
    (HEAD.replace("# source: s\n", "") + "tilt_deg,k_N_per_um\n0,1\n9,2\n", r"metadata 'source'.*missing"),
    (HEAD.replace("axis", "radial") + "tilt_deg,k_N_per_um\n0,1\n9,2\n", r"angle_convention"),
    (HEAD + "tilt_deg,k_N_per_um\n0,100\n", r"at least 2 support points"),
    (HEAD + "tilt_deg,k_N_per_um\n0,100,3\n15,90\n", r"line 7.*2 comma-separated"),
    (HEAD + "swivel_deg,tilt_deg,k_N_per_um\n0,0,1\n0,10,2\n45,0,3\n45,20,4\n", r"lines 9-10, column tilt_deg.*same tilt"),
    (HEAD + "swivel_deg,tilt_deg,k_N_per_um\n0,0,1\n0,10,2\n45,0,3\n45,10,4\n0,0,5\n0,10,6\n", r"column swivel_deg"),
])
def test_invalid_tables_give_clear_errors(tmp_path, text, pattern):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=pattern):
        load_joint_table(path)


def test_missing_table_names_the_path(tmp_path):
    with pytest.raises(JointTableNotFound, match=r"no file at .*nowhere\.csv"):
        load_joint_table("nowhere.csv", base_dir=tmp_path)
    with pytest.raises(JointTableNotFound, match="hexaglide_3dof_improved_measured"):  # lists the bundled names
        load_joint_table("no_such_table")
    assert {"hexaglide_3dof_improved_measured", "hexaglide_2dof_improved_measured", "hexaglide_2dof_improved_fe",
            "analytic_3_30_reference"} <= set(bundled_tables())


def test_parse_accepts_case_insensitive_method_and_extra_metadata():
    t = parse_joint_table(HEAD.replace("measured", "fe").replace("# quantity", "# parameters: p\n# mesh_size: 1 mm\n"
                                                                   "# element_type: hex\n# date: d\n# version: v\n"
                                                                   "# quantity") + "tilt_deg,k_N_per_um\n0,1\n9,2\n",
                          source="mem")
    assert t.method == "FE" and Path(t.path).name == "mem"
