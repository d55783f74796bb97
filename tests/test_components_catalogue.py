"""The catalogue, the `pkmstiff components` listing and the machine-file reader come from one declaration."""

import re
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from components import Component, ComponentState, catalogue, registry
from components.params import ModelSpec, Param
from components.registry import build_component, model_info, models
from pkmstiff.cli import main
from pkmstiff.errors import ArgumentError, ComponentModelError, InputError, PkmstiffError


def _sections(text: str) -> dict[str, str]:
    parts = re.split(r"^## `([a-z0-9_]+)`$", text, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2]))


def test_catalogue_has_every_model_and_every_declared_parameter():
    sections = _sections(catalogue.markdown())
    assert set(sections) == {spec.name for spec in models()}
    for spec in models():
        rows = re.findall(r"^\| `([^`]+)` \| ([^|]+) \|", sections[spec.name], flags=re.M)
        keys = [key for key, _ in rows if key in {d.key for d in spec.parameters}]
        assert keys == [d.key for d in spec.parameters], spec.name  # every declared parameter, in order
        assert spec.equation in sections[spec.name] and spec.description in sections[spec.name]


def test_catalogue_lists_the_bundled_tables_with_provenance():
    section = _sections(catalogue.markdown())["joint_table"]
    for table in catalogue.bundled_table_provenance("tilt"):
        row = next(line for line in section.splitlines() if line.startswith(f"| `{table.name}` |"))
        assert table.method in row and table.angle_convention in row
        assert table.metadata["source"].replace("|", "\\|") in row


@pytest.mark.parametrize("name", [spec.name for spec in models()])
def test_listing_shows_every_declared_parameter(name, capsys):
    assert main(["components", name]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"{name}: {model_info(name).description}")
    listed = [line.split()[0] for line in lines[1:]]
    assert listed == [d.key for d in model_info(name).parameters]


def test_reader_parses_by_the_declaration():
    # the declaration's unit, default and range are what the machine-file reader applies
    spec = model_info("guide_carriages")
    assert spec.parameter("count").default == 1 and spec.parameter("k_vertical").unit == "N/m"
    g = build_component("g", {"model": "guide_carriages", "k_horizontal": "1130 N/um", "k_vertical": "1.7 kN/um"})
    assert g.count == 1 and g.k_vertical == pytest.approx(1.7e9, rel=1e-15)  # one unit conversion, round-off only
    with pytest.raises(InputError, match="an integer >= 1"):
        build_component("g", {"model": "guide_carriages", "k_horizontal": 1e9, "k_vertical": 1e9, "count": 0})


@dataclass(frozen=True, kw_only=True, eq=False)
class _Spring(Component):
    kind: ClassVar[str] = "axial"
    k: float

    def stiffness(self, state: ComponentState) -> np.ndarray:
        return np.full(state.n, self.k)


def test_user_model_declared_once_is_read_listed_and_catalogued(monkeypatch):
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))  # keep the global registry clean
    registry.register(ModelSpec("spring", "a plain spring", "k = const",
                                (Param("k", "N/m", None, "stiffness", required=True, positive=True),),
                                lambda p: _Spring(name=p.name, k=p["k"])))
    s = build_component("s", {"model": "spring", "k": "2 N/um"})
    assert s.stiffness(ComponentState(n_poses=2)).tolist() == [2e6, 2e6]  # "2 N/um" is exactly 2e6 N/m in binary
    assert "| `k` | N/m | required | stiffness; > 0 |" in _sections(catalogue.markdown())["spring"]
    with pytest.raises(InputError, match="positive"):
        build_component("s", {"model": "spring", "k": "-2 N/um"})


def test_reading_an_undeclared_parameter_is_a_model_error(monkeypatch):
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    registry.register(ModelSpec("sloppy", "reads a key it does not declare", "", (),
                                lambda p: _Spring(name=p.name, k=p["k"])))
    with pytest.raises(ComponentModelError, match="reads parameter 'k' without declaring it"):
        build_component("s", {"model": "sloppy", "k": 1.0})


def test_component_errors_derive_from_the_root():
    from components.joint_tables import JointTableNotFound
    from components.protocol import ComponentRangeError

    assert issubclass(ComponentRangeError, PkmstiffError) and issubclass(ComponentRangeError, ValueError)
    assert issubclass(ComponentModelError, PkmstiffError) and issubclass(JointTableNotFound, InputError)
    with pytest.raises(ArgumentError):
        ComponentState(tilt=[0.0]).require("swivel", "j")
