"""Building components from machine-file tables: every model, unit parsing, error messages, user models."""

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from components import Component, ComponentState, registry
from components.joints import write_joint_table
from components.registry import available_models, build_component, build_components, register_model
from pkmstiff.errors import InputError
from pkmstiff.units import si, to_unit

SRC = "machines/hexaglide.toml"

HEXAGLIDE = {
    "drive": {"model": "linear_direct_drive", "k_axial": "25 N/um", "mass": "102.17 kg", "max_force": "2500 N",
              "force_reserve": "300 N", "max_speed": "1 m/s", "coulomb_friction": "75.7 N",
              "viscous_friction": "753.6 N*s/m"},
    "guide": {"model": "guide_carriages", "k_horizontal": "1130 N/um", "k_vertical": "1700 N/um", "count": 4},
    "strut_12": {"model": "strut", "k": "326 N/um", "mass": "12.13 kg", "length": "1.0 m"},
    "drive_joint": {"model": "joint_table", "table": "hexaglide_3dof_improved_measured", "tilt_min": "5 deg"},
    "platform_joint": {"model": "joint_table", "table": "hexaglide_2dof_improved_measured"},
    "platform": {"model": "body_stiffness", "diagonal": [1603, 1567, 588, 4348, 5115, 2564]},
    "platform_body": {"model": "rigid_body", "mass": "117.24 kg", "inertia": [7.42, 7.74, 2.87]},
}


def test_required_models_are_registered():
    required = {"constant_axial", "ballscrew_fixed_fixed", "ballscrew_fixed_floating", "ballscrew_floating_fixed",
                "telescopic_ballscrew_6x", "linear_direct_drive", "guide_carriages", "strut", "strut_sections",
                "joint_constant", "joint_analytic_3_30", "joint_table", "joint_table_swivel_tilt",
                "tapered_roller_bearing", "rigid_body", "body_stiffness"}
    models = available_models()
    assert required <= set(models)
    assert all(isinstance(d, str) and d and "\n" not in d for d in models.values())


def test_hexaglide_component_set():
    comps = build_components(HEXAGLIDE, source=SRC)
    state = ComponentState(drive_position=np.zeros(2), tilt=np.deg2rad([45.0, 90.0]))
    assert to_unit(comps["drive"].stiffness(state), "N/um").tolist() == [25.0, 25.0]
    assert comps["drive"].limits["viscous_friction"] == pytest.approx(753.6)
    K = comps["guide"].local_stiffness(comps["drive"].stiffness(state))
    np.testing.assert_allclose(to_unit(K[0].diagonal(), "N/um"), [25.0, 4520.0, 6800.0], rtol=1e-12)
    np.testing.assert_allclose(to_unit(comps["drive_joint"].stiffness(state), "N/um"), [49.0, 30.0], rtol=1e-12)
    assert comps["drive_joint"].limits["tilt_min"] == pytest.approx(np.deg2rad(5.0))
    assert comps["drive_joint"].angle_convention == "axis"
    assert comps["strut_12"].mass == 12.13
    assert comps["platform"].matrix[3, 3] == pytest.approx(4.348e9)  # default rotational unit N*m/urad
    assert "rotational_unit" in comps["platform"].assumptions
    assert comps["platform_body"].mass_matrix()[5, 5] == pytest.approx(2.87)


@pytest.mark.parametrize("params", [
    {"model": "constant_axial", "k": "250 N/um"},
    {"model": "ballscrew_fixed_fixed", "k_aL": "650 N/um", "k_M": "210 N/um", "k_TM": "1000 N/um",
     "d_Sp": "40 mm", "E": "210 GPa", "spindle_length": "1.2 m"},
    {"model": "ballscrew_fixed_floating", "k_aL": "650 N/um", "k_M": "210 N/um", "spindle_EA": "211 N*m/um",
     "lead": "20 mm", "spindle_inertia": "20 kg*cm^2", "motor_torque": "10 N*m", "efficiency": 0.9},
    {"model": "ballscrew_floating_fixed", "k_aL": "650 N/um", "k_M": "210 N/um", "spindle_EA": "211 N*m/um",
     "spindle_length": "1.5 m"},
    {"model": "telescopic_ballscrew", "k_aL": "650 N/um", "k_M": "410 N/um", "spindle_EA": "211 N*m/um",
     "drive_model": "exact_3_3", "l_eff_min": "0.12 m", "l_eff_max": "1.41 m", "length_at_l_eff_min": "1.28 m"},
    {"model": "linear_direct_drive", "axial_stiffness": "pole_placement", "pole_distance": "500 rad/s"},
    {"model": "strut_sections", "E": ["210 GPa", "70 GPa"], "area": ["10 cm^2", "20 cm^2"], "length": [0.5, 0.5],
     "density": [7850, 2700]},
    {"model": "joint_constant", "k": "rigid"},
    {"model": "joint_analytic_3_30", "k_AaL": "600 N/um", "k_BrL": "500 N/um", "k_CrL": "500 N/um",
     "k_CaL": "600 N/um", "angle_convention": "normal"},
    {"model": "joint_table", "tilt": {"value": [0, 45, 90], "unit": "deg"}, "stiffness": ["100 N/um", "80 N/um",
                                                                                          "70 N/um"],
     "angle_convention": "normal", "extrapolation": "error"},
    {"model": "joint_table_swivel_tilt", "swivel": ["0 deg", "45 deg", "90 deg"], "tilt": ["0 deg", "30 deg"],
     "stiffness": {"value": [[100, 90], [60, 50], [95, 85]], "unit": "N/um"}, "undefined_swivel": "0 deg"},
    {"model": "joint_product_swivel_tilt", "k_ref": "150 N/um", "swivel": ["0 deg", "45 deg", "90 deg"],
     "g_swivel": [1.0, 0.7, 0.95], "tilt": ["-30 deg", "15 deg", "45 deg"], "g_tilt": [0.8, 0.7, 1.0],
     "undefined_swivel": "45 deg"},
    {"model": "tapered_roller_bearing", "n_rollers": 21, "k_roller": "22.5 N/um", "contact_angle": "30.1 deg",
     "pitch_radius": "25 mm"},
    {"model": "rigid_body", "mass": 10.0, "inertia": [[1, 0, 0], [0, 2, 0], [0, 0, 3]], "cog": ["0 mm", "0 mm", "50 mm"]},
    {"model": "body_stiffness", "matrix": np.diag([1.0, 1, 1, 2, 2, 2]).tolist(), "rotational_unit": "N*m/rad",
     "translational_unit": "N/m"},
])
def test_every_model_builds_and_evaluates(params):
    comp = build_component("c", params, source=SRC)
    assert isinstance(comp, Component) and comp.name == "c"
    state = ComponentState(drive_position=[0.2, 0.4], strut_length=[1.5, 2.0], tilt=[0.1, 0.3],
                           swivel=[np.nan, 0.2], effective_mass=[100.0, 120.0])
    k = comp.stiffness(state)
    expected_shape = {"axial": (2,), "matrix3": (2, 3, 3), "matrix6": (2, 6, 6), "body": (2,)}[comp.kind]
    assert k.shape == expected_shape
    assert np.all(np.isfinite(k) | np.isposinf(k))


def test_units_are_parsed():
    d = build_component("d", {"model": "ballscrew_fixed_floating", "k_aL": 6.5e8, "k_M": "0.21 kN/um",
                              "spindle_EA": "211 N*m/um", "nut_offset": "50 mm", "lead": "20 mm",
                              "spindle_inertia": "20 kg*cm^2", "motor_torque": "10 N*m", "efficiency": 0.9},
                        source=SRC)
    assert d.k_al == 6.5e8 and d.k_m == pytest.approx(2.1e8) and d.nut_offset == pytest.approx(0.05)
    assert d.mass == pytest.approx((2 * np.pi / 0.02) ** 2 * 20e-4, rel=1e-12)  # eq. 3.4
    assert d.limits["max_force"] == pytest.approx(2 * np.pi * 10 * 0.9 / 0.02, rel=1e-12)  # eq. 3.24


@pytest.mark.parametrize("params, key, pattern", [
    ({"model": "warp_drive"}, "components.c.model", "one of"),
    ({"k": "25 N/um"}, "components.c.model", "missing"),
    ({"model": "constant_axial"}, "components.c.k", "parameter missing"),
    ({"model": "constant_axial", "k": "25 N/um", "colour": "red"}, "components.c.colour", "unknown parameter"),
    ({"model": "constant_axial", "k": "25 mm"}, "components.c.k", "dimension of N/m"),
    ({"model": "constant_axial", "k": "-25 N/um"}, "components.c.k", "positive"),
    ({"model": "joint_table", "table": "hexaglide_3dof_improved_measured", "extrapolation": "linear"},
     "components.c.extrapolation", "'clamp', 'error'"),
    ({"model": "joint_table", "table": "hexaglide_3dof_improved_measured", "angle_convention": "normal"},
     "components.c.angle_convention", "convention 'axis'"),
    ({"model": "joint_table_swivel_tilt", "table": "hexaglide_3dof_improved_measured"}, "components.c.table",
     "swivel-tilt table"),
    ({"model": "joint_table", "table": "hexaglide_3dof_improved_measured", "tilt": [0, 1], "stiffness": [1, 2]},
     "components.c", "exactly one of table or tilt\\+stiffness"),
    ({"model": "joint_table", "tilt": [0, 1], "stiffness": [1e8, 2e8, 3e8]}, "components.c.stiffness", "shape"),
    ({"model": "joint_constant", "k": 1e8, "tilt_min": "30 deg", "tilt_max": "10 deg"}, "components.c.tilt_max",
     ">= tilt_min"),
    ({"model": "linear_direct_drive", "k_axial": "25 N/um", "pole_distance": 300}, "components.c.pole_distance",
     "constant"),
    ({"model": "strut", "k": "300 N/um", "EA": "3e8 N"}, "components.c", "exactly one of"),
    ({"model": "telescopic_ballscrew_6x", "max_force": "4 kN", "efficiency": 0.9}, "components.c.efficiency",
     "only together with motor_torque"),
    ({"model": "tapered_roller_bearing", "n_rollers": 2.5, "k_roller": "1 N/um", "contact_angle": "30 deg"},
     "components.c.n_rollers", "integer"),
    ({"model": "body_stiffness", "diagonal": [1, 2, 3], "rotational_unit": "N*m/urad"}, "components.c.diagonal",
     "shape"),
    ({"model": "body_stiffness", "diagonal": [1, 2, 3, 4, 5, 6], "rotational_unit": "N/um"},
     "components.c.rotational_unit", "N\\*m/rad"),
])
def test_invalid_parameters_raise_input_error_naming_source_and_key(params, key, pattern):
    with pytest.raises(InputError, match=pattern) as info:
        build_component("c", params, source=SRC)
    assert info.value.file == SRC
    assert info.value.key.startswith(key)


def test_component_level_validation_is_reported_with_source():
    # a fit polynomial that becomes negative inside the stroke is caught by the component and reported
    with pytest.raises(InputError, match="not positive") as info:
        build_component("c", {"model": "telescopic_ballscrew_6x", "fit_coefficients": ["1 N/um", "-10 N/um", "1 N/um"]},
                        source=SRC)
    assert info.value.file == SRC and info.value.key == "components.c"


def test_joint_table_path_relative_to_machine_file(tmp_path):
    (tmp_path / "data").mkdir()
    write_joint_table(tmp_path / "data" / "my_joint.csv", [0.0, 45.0, 90.0], [1e8, 8e7, 7e7],
                      {"name": "my_joint", "source": "own measurement", "method": "measured",
                       "quantity": "axial stiffness", "angle_convention": "normal"})
    j = build_component("drive_joint", {"model": "joint_table", "table": "data/my_joint.csv"},
                        source=str(tmp_path / "m.toml"), base_dir=tmp_path)
    assert j.angle_convention == "normal" and "own measurement" in j.provenance
    with pytest.raises(InputError, match=r"no file at .*missing\.csv") as info:
        build_component("drive_joint", {"model": "joint_table", "table": "data/missing.csv"},
                        source=str(tmp_path / "m.toml"), base_dir=tmp_path)
    assert info.value.key == "components.drive_joint.table"
    assert info.value.file == str(tmp_path / "m.toml")
    (tmp_path / "data" / "broken.csv").write_text((tmp_path / "data" / "my_joint.csv").read_text().replace("90.0,", "30.0,"))
    with pytest.raises(InputError, match=r"broken\.csv \(table of components\.drive_joint\.table in .*m\.toml\).*"
                                         r"line \d+, column tilt_deg.*strictly increasing"):
        build_component("drive_joint", {"model": "joint_table", "table": "data/broken.csv"},
                        source=str(tmp_path / "m.toml"), base_dir=tmp_path)


def test_assumptions_and_provenance_are_merged():
    c = build_component("c", {"model": "joint_constant", "k": "100 N/um",
                              "assumptions": {"k": "no data: constant value as in the dissertation's comparison"},
                              "provenance": "guess"}, source=SRC)
    assert c.assumptions["k"].startswith("no data") and c.provenance == "guess"
    with pytest.raises(InputError, match="table of strings"):
        build_component("c", {"model": "joint_constant", "k": 1e8, "assumptions": ["x"]}, source=SRC)


# ------------------------------------------------------------------ user models (README worked example)
@dataclass(frozen=True, kw_only=True, eq=False)
class ElastomerMount(Component):
    """Axial stiffness that grows linearly with the preload: k = k0 + c F."""

    kind: ClassVar[str] = "axial"
    k0: float
    c: float
    preload: float

    def stiffness(self, state: ComponentState) -> np.ndarray:
        return np.full(state.n, self.k0 + self.c * self.preload)


def _elastomer_mount(p: registry.Params) -> Component:
    return ElastomerMount(name=p.name, k0=p.quantity("k0", "N/m", positive=True),
                          c=p.quantity("c", "1/m", min_value=0.0), preload=p.quantity("preload", "N", 0.0),
                          mass=p.quantity("mass", "kg", 0.0, min_value=0.0))


def test_register_and_build_a_user_model(monkeypatch):
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))  # keep the global registry clean
    register_model("elastomer_mount", _elastomer_mount, "elastomer mount, k = k0 + c F",
                   parameters=[("k0", "N/m", "required", "stiffness without preload"),
                               ("c", "1/m", "required", "stiffening per newton of preload"),
                               ("preload", "N", "0", "preload force")])
    assert "elastomer_mount" in available_models()
    m = build_component("mount", {"model": "elastomer_mount", "k0": "10 N/um", "c": "2000 1/m", "preload": "1 kN"},
                        source=SRC)
    assert m.stiffness(ComponentState(n_poses=3)) == pytest.approx(np.full(3, si(10, "N/um") + 2000 * 1000))
    with pytest.raises(InputError, match="unknown parameter 'stiffness'"):
        build_component("mount", {"model": "elastomer_mount", "k0": 1e7, "c": 0, "stiffness": 1}, source=SRC)
    with pytest.raises(ValueError, match="already registered"):
        register_model("elastomer_mount", _elastomer_mount, "again")
