"""Typed instruments (issue 21 item 2): kind names are compared only in the registry, and a new instrument is one
module plus one registry line — followed here for a dummy "z probe" (docs/development.md, "Add an instrument")."""

from __future__ import annotations

import ast
import json
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pkmstiff.calibration import default_plan, error_model, identifiability, identification_jacobian
from pkmstiff.calibration.compensation import measurement_plan
from pkmstiff.calibration.identification import identify
from pkmstiff.calibration.instruments import Instrument, Setup, SetupState, instrument, kinds, register, unregister
from pkmstiff.calibration.instruments.file_format import fmt, scalars
from pkmstiff.calibration.measurement import simulate_readings
from pkmstiff.calibration.measurement_file import read_measurement, write_measurement
from pkmstiff.calibration.simulation import SimulationOptions, simulate, to_measurement
from pkmstiff.errors import CalibrationInputError, MeasurementFileError
from pkmstiff.machine import load_machine

PACKAGE = Path(__file__).resolve().parents[1] / "pkmstiff"
REGISTRY = PACKAGE / "calibration" / "instruments" / "registry.py"


def kind_comparisons(root: Path, names: tuple[str, ...]) -> list[str]:
    """``file:line`` of every comparison (==, !=, in, not in) of an expression with one of the kind ``names`` (a
    string literal, or a tuple/list/set of them), and of every ``getattr(x, "kind", ...)``, in the Python files
    under ``root`` except the registry."""
    def literal(node: ast.AST) -> bool:
        if isinstance(node, ast.Constant):
            return node.value in names
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            return any(literal(e) for e in node.elts)
        return False

    hits = []
    for path in sorted(root.rglob("*.py")):
        if path.name == REGISTRY.name and path.parent.name == REGISTRY.parent.name:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Compare) and any(literal(x) for x in [node.left, *node.comparators]):
                hits.append(f"{path.relative_to(root.parent)}:{node.lineno}")
            elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "getattr"
                  and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant) and node.args[1].value == "kind"
                  and len(node.args) == 3 and literal(node.args[2])):
                hits.append(f"{path.relative_to(root.parent)}:{node.lineno}")
    return hits


def test_no_instrument_kind_comparisons_outside_the_registry():
    hits = kind_comparisons(PACKAGE, kinds())
    assert hits == [], "compare instruments as objects (or give Instrument a method); kind names only in " \
                       f"{REGISTRY.relative_to(PACKAGE.parent)}: {hits}"


def test_the_check_finds_comparisons(tmp_path):
    """The grep test can fail: it finds each form of kind test it forbids."""
    (tmp_path / "m.py").write_text('a = x == "ballbar"\nb = y in ("tracker", "pose")\n'
                                   'c = getattr(m, "kind", "ballbar")\nd = {"pose": 1}["pose"]\n')
    assert kind_comparisons(tmp_path, kinds()) == ["m.py:1".replace("m.py", f"{tmp_path.name}/m.py"),
                                                    f"{tmp_path.name}/m.py:2", f"{tmp_path.name}/m.py:3"]


def test_registry_round_trip_and_unknown_kind():
    for k in kinds():
        assert instrument(k).kind == k and str(instrument(k)) == k and instrument(instrument(k)) is instrument(k)
    with pytest.raises(CalibrationInputError, match="one of ballbar, tracker, pose"):
        instrument("laser")


# ------------------------------------------------------------------------------------ a dummy instrument
# Everything a new instrument needs lives in this block (in the package: one module under
# pkmstiff/calibration/instruments/ and one register() line in registry.py).


@dataclass(frozen=True)
class ZProbeDevice:
    """A touch probe measuring the z coordinate of the target: ``resolution`` and ``accuracy`` [m], ``travel``
    [m] (readings beyond ±travel are out of range), ``sample_rate`` [Hz]."""

    name: str = "z probe (test)"
    sample_rate: float = 10.0
    resolution: float = 0.1e-6
    accuracy: float = 1e-6
    travel: float = 2.0

    def sigma(self, noise: str | float, feed: np.ndarray | float) -> np.ndarray:
        f = np.asarray(feed, dtype=float)
        return np.full_like(f, 0.0 if noise == "none" else self.accuracy / 2 if noise == "instrument" else noise)


@dataclass
class ZProbeMeasurement:
    instrument: Instrument
    t: np.ndarray
    z: np.ndarray
    poses: np.ndarray | None = None
    drives: np.ndarray | None = None
    drive_units: tuple[str, ...] = ()
    feed: np.ndarray | None = None
    direction: np.ndarray | None = None
    temperature: np.ndarray | None = None
    target: np.ndarray = field(default_factory=lambda: np.zeros(3))
    machine: str = ""
    device: str = ZProbeDevice.name
    travel: float = ZProbeDevice.travel
    notes: list[str] = field(default_factory=list)
    lines: np.ndarray | None = None

    @property
    def n_samples(self) -> int:
        return int(self.t.size)


class ZProbe(Instrument):
    """Reading: the z coordinate of the target o + R v in the machine frame (m), one per pose."""

    kind = "zprobe"
    title = "z probe"
    reading_names = ("z",)
    reading_units = ("m",)
    setup_tokens = {"probe-offset": "target_offset"}
    file_columns = ("z_probe_mm",)
    header_keys = ("probe_target_mm", "travel_mm")

    def readings(self, setup: Setup, state: SetupState, o: np.ndarray, R: np.ndarray,
                 R_cmd: np.ndarray) -> np.ndarray:
        return (o + np.einsum("nij,j->ni", R, state.target))[:, 2:3]

    def reading_twist(self, setup: Setup, m: np.ndarray, Rv: np.ndarray, source: str) -> np.ndarray:
        ez = np.array([0.0, 0.0, 1.0])  # δz = e_z · (δo + δω × Rv) = e_z · δo + δω · (Rv × e_z)
        return np.concatenate([np.tile(ez, (len(m), 1)), np.cross(Rv, ez)], axis=1)[:, None, :]

    def setup_column(self, block: str, component: str, axis: np.ndarray, setup: Setup, R: np.ndarray,
                     m: np.ndarray) -> np.ndarray:
        if block == "target_offset":
            return (R @ axis)[:, 2:3]
        return super().setup_column(block, component, axis, setup, R, m)

    def default_plans(self, machine: Any, centre: np.ndarray, setup: Setup) -> Iterator[Any]:
        from pkmstiff.calibration.plans import grid_plan

        for hw in (0.1, 0.05):
            yield grid_plan(setup, centre, hw, tilt=np.radians(10), torsion=np.radians(10), name=f"z grid {hw}")

    def default_device(self) -> ZProbeDevice:
        return ZProbeDevice()

    def device(self, setup: Setup, **figures: float | None) -> ZProbeDevice:
        return ZProbeDevice(**{k: v for k, v in figures.items() if v is not None and k in ("resolution", "accuracy")})

    def finish_readings(self, device, setup, options, clean, noisy, rng):
        out = np.round(noisy / device.resolution) * device.resolution if options.quantise else noisy
        return out, np.flatnonzero(np.abs(out[:, 0]) > device.travel), None

    def range_error(self, plan, res, device) -> str:
        return f"plan '{plan.name}': {res.violations.size} readings beyond the probe's travel"

    def simulation_summary(self, plan, res) -> dict:
        return {"z_max_mm": float(np.abs(res.readings).max() * 1e3)}

    def to_measurement(self, machine, plan, res, device, saturate, notes) -> ZProbeMeasurement:
        return ZProbeMeasurement(self, t=res.samples.t, z=res.readings[:, 0], poses=res.samples.poses,
                                 target=plan.setup.target.copy(), machine=machine.name, device=device.name,
                                 travel=device.travel, notes=notes)

    def measured(self, meas: ZProbeMeasurement) -> tuple[Setup, np.ndarray]:
        return Setup(self, target=meas.target), meas.z[:, None]

    def range_violations(self, meas: ZProbeMeasurement) -> np.ndarray:
        return np.flatnonzero(np.abs(meas.z) > meas.travel)

    def range_message(self, meas: ZProbeMeasurement, bad: np.ndarray) -> str:
        return f"{bad.size} reading(s) beyond the travel"

    def parse_header(self, src: str, header: dict[str, tuple[int, str]]) -> dict:
        meta: dict = {}
        if (h := header.get("probe_target_mm")) is not None:
            meta["target"] = np.array([float(v) for v in h[1].split(",")]) * 1e-3
        scalars(src, header, (("travel_mm", "travel", 1e-3, False),), meta)
        return meta

    def header_lines(self, meas: ZProbeMeasurement) -> list[str]:
        return [f"# probe_target_mm: {', '.join(fmt(v * 1e3) for v in meas.target)}",
                f"# travel_mm: {fmt(meas.travel * 1e3)}"]

    def reading_columns(self, meas: ZProbeMeasurement) -> list[tuple[str, np.ndarray]]:
        return [("z_probe_mm", meas.z / 1e-3)]

    def from_columns(self, src: str, column: Callable[[str], np.ndarray], common: dict, check_range: bool,
                     locate: Callable[[int, str], tuple[int, int, str]]) -> ZProbeMeasurement:
        meas = ZProbeMeasurement(self, z=column("z_probe_mm") * 1e-3, **common)
        bad = self.range_violations(meas)
        if check_range and bad.size:
            line, col, name = locate(int(bad[0]), "z_probe_mm")
            raise MeasurementFileError(src, line, "z beyond the travel", col, name)
        return meas


@pytest.fixture
def zprobe():
    inst = register(ZProbe())  # the one registry line
    yield inst
    unregister(inst)


@pytest.fixture(scope="module")
def felix():
    return load_machine("felix")


def test_dummy_instrument_jacobian_rows_match_finite_differences(zprobe, felix):
    plan = default_plan(felix, "zprobe")
    assert plan.instrument is zprobe and plan.setup.n_readings == 1
    params = error_model(felix, setup=plan.setup, setup_blocks=("target_offset",))
    J = identification_jacobian(felix, params, plan).J
    h = 1e-7  # central differences: truncation ~h² · (second derivative ~1/m) ~1e-14, round-off ~1e-16/h ~1e-9
    fd = np.empty_like(J)
    for k in range(params.n):
        e = np.zeros(params.n)
        e[k] = h
        fd[:, k] = (simulate_readings(felix, params, e, plan) - simulate_readings(felix, params, -e, plan))[:, 0] / (2 * h)
    assert np.max(np.abs(J - fd)) < 1e-6  # |J| ~ 1; the bound leaves room for the 1e-13 m forward-kinematics tolerance
    ident = identifiability(felix, params, plan)
    assert 0 < ident.rank < params.n  # one z reading per pose cannot see x/y motions of the platform


def test_dummy_instrument_end_to_end(zprobe, felix, tmp_path):
    """Simulate -> write -> read -> identify: the file carries the dummy instrument and the identification fits
    the noise-free readings."""
    plan = default_plan(felix, "zprobe")
    params = error_model(felix, setup=plan.setup)
    delta = params.vector({"chain1.strut_offset": 30e-6, "chain3.base_joint.z": -20e-6})
    res = simulate(felix, params, delta, plan, options=SimulationOptions(noise="none", quantise=False))
    path = write_measurement(tmp_path / "z.csv", to_measurement(felix, plan, res, zprobe.default_device()))
    header = json.loads(path.with_suffix(".json").read_text())  # the header sits beside the plain CSV
    assert header["instrument_type"] == "zprobe" and "z_probe_mm" in path.read_text().splitlines()[0]
    meas = read_measurement(path)
    assert meas.instrument is zprobe and meas.n_samples == plan.n_poses
    mplan, y = measurement_plan(meas, "felix", str(path))
    np.testing.assert_allclose(y, res.readings, atol=1e-12)  # 15 significant digits in mm in the file
    fit = identify(felix, params, mplan, y)
    assert np.sqrt(np.mean(fit.residual_after ** 2)) < 1e-9  # noise-free: the model fits to the FK tolerance


def test_dummy_instrument_keys_belong_to_its_files(zprobe, tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("# instrument_type: tracker\n# travel_mm: 5\nt_s,x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,px_mm,py_mm,"
                 "pz_mm\n0,0,0,0,0,0,0,0,0,0\n")
    with pytest.raises(MeasurementFileError, match="line 2: header key 'travel_mm' does not belong to a tracker"):
        read_measurement(p)


def test_dummy_instrument_reading_lengths_are_checked_on_writing(zprobe, tmp_path):
    meas = ZProbeMeasurement(zprobe, t=np.arange(3.0), z=np.zeros(2), poses=np.zeros((3, 6)))
    with pytest.raises(MeasurementFileError, match="column 'z_probe_mm' has 2 samples, expected 3"):
        write_measurement(tmp_path / "z.csv", meas)
    assert not (tmp_path / "z.csv").exists()
