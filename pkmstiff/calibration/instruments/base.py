"""The :class:`Instrument` protocol and the instrument set-up (Szatmári §4.3; Denkena §1.3).

Two words, two things: an **instrument** is a kind of measurement (ball bar, laser tracker, 6-D pose — one
:class:`Instrument` subclass each, one instance each in :mod:`.registry`); a **device** is a concrete instrument
model with its figures (a QC10 ball bar, an AT960-class tracker): sample rate, range, resolution and accuracy, i.e.
the noise model of the simulation and the header of a measurement file.

A :class:`Setup` holds the nominal set-up; a :class:`SetupState` the actual one (nominal + set-up errors). Readings
are computed from the platform frame (origin o, rotation R) the machine reaches (docs/theory/calibration.md):

* ball bar: r = |o + R (v + Δv) − s_7| + Δr (m);
* tracker: the target position in the instrument frame, Qᵀ (o + R (v + Δv) − τ) (m, 3 per pose);
* pose: the same position (3, m) and the orientation error φ = log(Qᵀ R R_cᵀ) as a rotation vector (3, rad) with
  R_c the commanded orientation.

v is the moving ball / target / reference point in the platform frame (PKS), s_7 the fixed ball (MKS), (τ, Q) the
pose of the instrument frame in the MKS (nominal: identity).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from pkmstiff.errors import InputError


class Instrument:
    """One kind of instrument: its reading model, Jacobian rows, set-up parameters, measurement-file columns,
    default plan and device (noise) model. Subclasses are stateless; :mod:`.registry` holds one instance of each,
    and ``kind`` is used only to name the instrument in files and on the command line (``str(instrument)``).

    Class attributes: ``kind`` (file header ``instrument_type`` / CLI choice), ``title`` (prose), ``reading_names``
    and ``reading_units`` (per pose, SI), ``setup_tokens`` (``--with`` token -> set-up parameter block),
    ``target_name`` (what the target point is called), ``file_columns`` (reading columns of the measurement CSV),
    ``header_keys`` (header keys of its measurement files besides the common ones), ``path_plans`` (its default
    plan is a continuous path whose orientation nodes ``calibrate plan`` optimises, not a pose set), ``saturates``
    (a reading out of range is clipped at the range limit, as a transducer does, rather than lost)."""

    kind: ClassVar[str]
    title: ClassVar[str]
    reading_names: ClassVar[tuple[str, ...]]
    reading_units: ClassVar[tuple[str, ...]]
    setup_tokens: ClassVar[dict[str, str]] = {}
    target_name: ClassVar[str] = "target point"
    file_columns: ClassVar[tuple[str, ...]]
    header_keys: ClassVar[tuple[str, ...]] = ()
    path_plans: ClassVar[bool] = False
    saturates: ClassVar[bool] = False

    def __eq__(self, other: object) -> bool:
        return type(self) is type(other)

    def __hash__(self) -> int:
        return hash(type(self))

    def __str__(self) -> str:
        return self.kind

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    @property
    def n_readings(self) -> int:
        return len(self.reading_names)

    # ---------------------------------------------------------------------------------------------- set-up
    def check_setup(self, setup: Setup) -> None:
        """Raise :class:`InputError` if ``setup`` lacks what this instrument needs."""

    def default_setup(self, machine: Any, centre: np.ndarray, bar_length: float) -> Setup:
        """The set-up a user starts with (target at the TCP)."""
        return Setup(self, target=machine.tool.tip())

    def setup_from_toml(self, table: dict, quantity: Callable[..., Any], target: np.ndarray) -> Setup:
        """The ``[setup]`` table of a plan file; ``quantity(table, key, unit, prefix, default, shape, positive)``
        parses one value (see :func:`pkmstiff.calibration.plans.read_plan`)."""
        return Setup(self, target=target)

    def setup_toml(self, setup: Setup, quantity: Callable[[float, str, float], str]) -> list[str]:
        """Lines of the ``[setup]`` table after ``target`` (``quantity(value_SI, unit, scale)`` formats one)."""
        return []

    # ---------------------------------------------------------------------------------------------- readings
    def readings(self, setup: Setup, state: SetupState, o: np.ndarray, R: np.ndarray,
                 R_cmd: np.ndarray) -> np.ndarray:
        """Readings (N, k) for platform frames (o (N, 3), R (N, 3, 3)); ``R_cmd`` the commanded orientations."""
        raise NotImplementedError

    def reading_twist(self, setup: Setup, m: np.ndarray, Rv: np.ndarray, source: str) -> np.ndarray:
        """H (N, k, 6): derivative of the readings with respect to the platform twist (δo, δω) (MKS) at the target
        points ``m`` = o + R v (``Rv`` = R v)."""
        raise NotImplementedError

    def setup_jacobian(self, J: np.ndarray, params: Any, setup: Setup, R: np.ndarray, m: np.ndarray) -> None:
        """Fill the columns (N, k) of the set-up parameters (``params.chain < 0``) of J (N, k, n) in place."""
        for k in np.flatnonzero(params.chain < 0):
            J[:, :, k] = self.setup_column(params.blocks[k], params.components[k], params.axis[k], setup, R, m)

    def setup_column(self, block: str, component: str, axis: np.ndarray, setup: Setup, R: np.ndarray,
                     m: np.ndarray) -> np.ndarray:
        """∂readings/∂(one set-up parameter), (N, k)."""
        raise InputError("setup", block, f"a set-up parameter of the {self}", block)

    def check_nominal(self, machine: Any, plan: Any, poses: np.ndarray) -> None:
        """Raise a one-line :class:`~pkmstiff.errors.InadmissibleError` if a nominal reading of the plan leaves the
        instrument's range (or its mount); nothing to check by default."""

    def project_path(self, setup: Setup, P: np.ndarray, Pq: np.ndarray, k: np.ndarray,
                     w: np.ndarray) -> np.ndarray:
        """Target points ``Pq`` interpolated linearly between path nodes ``P`` (node ``k``, weight ``w``), put back
        on the surface the instrument keeps them on (identity by default)."""
        return Pq

    # ---------------------------------------------------------------------------------------------- plans
    def default_plans(self, machine: Any, centre: np.ndarray, setup: Setup) -> Iterator[Any]:
        """Candidate default plans, most ambitious first; :func:`~pkmstiff.calibration.plans.default_plan` takes
        the first admissible one."""
        raise NotImplementedError

    # ---------------------------------------------------------------------------------------------- devices
    def default_device(self) -> Any:
        """The default device (noise model) of this instrument."""
        raise NotImplementedError

    def device(self, setup: Setup, **figures: float | None) -> Any:
        """The default device with the figures given (SI; None keeps the default): ``sample_rate``, ``range``,
        ``resolution``, ``accuracy``, ``angle_accuracy``."""
        raise NotImplementedError

    def accepts(self, device: Any) -> bool:
        """Whether ``device`` is a device of this instrument."""
        return isinstance(device, type(self.default_device()))

    # ---------------------------------------------------------------------------------------------- simulation
    def finish_readings(self, device: Any, setup: Setup, options: Any, clean: np.ndarray, noisy: np.ndarray,
                        rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Simulated readings after the device (extra noise, quantisation): (readings, indices of samples out of
        range, ball-bar deviation from the bar length or None)."""
        raise NotImplementedError

    def range_error(self, plan: Any, res: Any, device: Any) -> str:
        """One line on the simulated readings out of range (``res.violations`` not empty)."""
        raise NotImplementedError

    def simulation_summary(self, plan: Any, res: Any) -> dict:
        """JSON-ready figures of a simulated run (keys name their units)."""
        raise NotImplementedError

    def to_measurement(self, machine: Any, plan: Any, res: Any, device: Any, saturate: bool, notes: list[str]) -> Any:
        """The simulated run as a measurement of this instrument."""
        raise NotImplementedError

    # ---------------------------------------------------------------------------------------------- measurements
    def measured(self, meas: Any) -> tuple[Setup, np.ndarray]:
        """Nominal set-up and readings (N, k) (SI, :attr:`reading_names` order) of a measurement."""
        raise NotImplementedError

    def reading_sigma(self, meas: Any) -> np.ndarray:
        """The noise σ (k,) (SI) the device of ``meas`` states for each reading: its accuracy read as a 2σ bound
        (k = 2), as the simulation's ``instrument`` noise model (model-fit diagnostics,
        :mod:`pkmstiff.calibration.diagnostics`)."""
        raise NotImplementedError

    def range_violations(self, meas: Any) -> np.ndarray:
        """Indices of the samples whose reading lies outside the device's range."""
        raise NotImplementedError

    def range_message(self, meas: Any, bad: np.ndarray) -> str:
        """One line on the samples ``bad`` (indices, not empty) out of range, for a writer."""
        raise NotImplementedError

    def check_measurement(self, src: str, meas: Any) -> None:
        """Raise :class:`~pkmstiff.errors.InputError` if ``meas`` cannot be written as this instrument's
        file (nothing to check by default)."""

    def parse_header(self, src: str, header: dict[str, tuple[int, str]]) -> dict:
        """Measurement attributes (SI) from the header keys of a file: {key: (line, text)}."""
        raise NotImplementedError

    def header_lines(self, meas: Any) -> list[str]:
        """Header lines (with ``# ``) of a measurement file after the common ones, before ``units``/``note``."""
        raise NotImplementedError

    def reading_columns(self, meas: Any) -> list[tuple[str, np.ndarray]]:
        """(column name, values in file units) of the readings, in :attr:`file_columns` order."""
        raise NotImplementedError

    def from_columns(self, src: str, column: Callable[[str], np.ndarray], common: dict, check_range: bool,
                     locate: Callable[[int, str], tuple[int, int, str]]) -> Any:
        """A measurement from the file's common fields and its reading columns (``column(name)`` in file units);
        with ``check_range`` readings out of range are an error at ``locate(sample, column)`` (line, column no.,
        name)."""
        raise NotImplementedError


@dataclass(frozen=True)
class Setup:
    """Nominal instrument set-up: the ``instrument`` (an :class:`Instrument`, or its kind name), ``target`` v in
    the PKS (m); ball bar: ``fixed_ball`` s_7 in the MKS (m) and the nominal ``bar_length`` (m);
    ``measuring_range`` (m) about it (default: the device's, QC10 ±1 mm); ``max_mount_angle`` (rad, optional) the largest angle between
    the bar (moving ball → fixed ball) and the tool axis that the magnetic cup permits (Szatmári §4.4.3, collision
    check; no value given there, so unchecked unless set); ``placing_pose`` (6,) (m, rad, optional) the commanded pose
    at which the machine itself placed the fixed ball (centre mount in the tool cup, driven there and locked): its
    actual position then follows the machine's errors (:mod:`pkmstiff.calibration.setups`)."""

    instrument: Instrument
    target: np.ndarray = field(default_factory=lambda: np.zeros(3))
    fixed_ball: np.ndarray | None = None
    bar_length: float | None = None
    measuring_range: float | None = None
    max_mount_angle: float | None = None
    placing_pose: np.ndarray | None = None

    def __post_init__(self) -> None:
        from pkmstiff.calibration.instruments.registry import instrument

        object.__setattr__(self, "instrument", instrument(self.instrument, "setup"))
        object.__setattr__(self, "target", np.asarray(self.target, dtype=float).reshape(3))
        if self.placing_pose is not None:
            object.__setattr__(self, "placing_pose", np.asarray(self.placing_pose, dtype=float).reshape(6))
            if self.fixed_ball is None:
                raise InputError("setup", "placing_pose", "a set-up with a fixed ball (ball bar)", "no fixed ball")
        self.instrument.check_setup(self)

    @property
    def n_readings(self) -> int:
        return self.instrument.n_readings

    def state(self) -> SetupState:
        return SetupState(target=self.target.copy(),
                          fixed_ball=None if self.fixed_ball is None else self.fixed_ball.copy())


@dataclass(frozen=True)
class SetupState:
    """Actual set-up: target v + Δv (PKS), fixed ball (MKS), bar-length offset Δr, instrument frame (τ, Q)."""

    target: np.ndarray
    fixed_ball: np.ndarray | None = None
    bar_offset: float = 0.0
    frame_translation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    frame_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))


def target_points(state: SetupState, o: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Moving ball / target in the MKS, o + R v, shape (N, 3)."""
    return o + np.einsum("nij,j->ni", R, state.target)


def readings(setup: Setup, state: SetupState, o: np.ndarray, R: np.ndarray, R_cmd: np.ndarray) -> np.ndarray:
    """Readings (N, k) of the set-up's instrument for platform frames (o (N, 3), R (N, 3, 3)); ``R_cmd`` the
    commanded orientations (pose instrument). Units: m, rad (:attr:`Instrument.reading_units`)."""
    return setup.instrument.readings(setup, state, o, R, R_cmd)

