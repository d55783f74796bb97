"""The instrument registry: kind name (file header ``instrument_type``, ``[plan] instrument``, ``--instrument``)
-> :class:`~.base.Instrument`. The only place where kind names are compared; adding an instrument is one module
and one :func:`register` line here (docs/development.md, "Add an instrument")."""

from __future__ import annotations

from pkmstiff.calibration.instruments.ball_bar import BALL_BAR
from pkmstiff.calibration.instruments.base import Instrument
from pkmstiff.calibration.instruments.pose import POSE
from pkmstiff.calibration.instruments.tracker import TRACKER
from pkmstiff.errors import CalibrationInputError

_REGISTRY: dict[str, Instrument] = {}

#: the instrument of a measurement file without the header key ``instrument_type`` (files written before it)
FILE_DEFAULT: Instrument = BALL_BAR


def register(inst: Instrument) -> Instrument:
    """Make ``inst`` known under ``inst.kind``."""
    _REGISTRY[inst.kind] = inst
    return inst


def unregister(inst: Instrument) -> None:
    """Forget ``inst`` (tests that register an instrument of their own)."""
    _REGISTRY.pop(inst.kind, None)


def kinds() -> tuple[str, ...]:
    """Kind names, in registration order (CLI choices, messages)."""
    return tuple(_REGISTRY)


def instruments() -> tuple[Instrument, ...]:
    return tuple(_REGISTRY.values())


def find(kind: str) -> Instrument | None:
    """The instrument named ``kind``, or None."""
    return _REGISTRY.get(kind)


def instrument(kind: str | Instrument, source: str = "--instrument", key: str = "instrument") -> Instrument:
    """The instrument named ``kind`` (an :class:`Instrument` passes through); unknown -> one-line error naming
    ``source`` and ``key``."""
    if isinstance(kind, Instrument):
        return kind
    if not isinstance(kind, str) or kind not in _REGISTRY:
        raise CalibrationInputError(source, key, f"one of {', '.join(_REGISTRY)}", kind)
    return _REGISTRY[kind]


register(BALL_BAR)
register(TRACKER)
register(POSE)
