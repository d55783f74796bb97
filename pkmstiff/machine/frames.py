"""Position frames and the spindle-coupling switch (docs/user-guide/validation-hexaglide.md items 2 and 4).

Two frames for positions of O', both with the axes of the machine coordinate system (MKS):

* ``"machine"`` — the MKS in which the machine file's geometry is given;
* ``"report"`` — the MKS shifted to the machine's ``report_origin`` (``[machine] report_origin`` in the machine
  file, a point in the MKS; zero if the file gives none). The source's quoted positions are measured from it
  (Hexaglide: the middle guide, docs/user-guide/validation-hexaglide.md (reading 2)): ``position_machine = position_report + report_origin``.

Orientations (a, b, c) are the same in both frames. :func:`neglect_spindle` returns the machine with the
platform-spindle stiffness K_U left out (platform and spindle one rigid body), as the dissertation's stiffness maps
at tool length 0 do (Cobet 4.2.4, Fig. 4.25; docs/user-guide/validation-hexaglide.md (reading 4)).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.errors import InputError
from pkmstiff.machine.model import NEGLECT_SPINDLE_NOTE, Machine  # noqa: F401 (re-exported)

FRAMES = ("machine", "report")


def check_frame(frame: str, source: str = "frame") -> str:
    """``frame`` if it is one of :data:`FRAMES`, else an :class:`InputError` naming the choices."""
    if frame not in FRAMES:
        raise InputError(source, "frame", f"one of {list(FRAMES)}", frame)
    return frame


def frame_origin(machine: Machine, frame: str) -> np.ndarray:
    """Origin (3,) [m] of ``frame`` in the MKS: zero for ``"machine"``, ``machine.report_origin`` for ``"report"``."""
    check_frame(frame)
    return np.zeros(3) if frame == "machine" else np.asarray(machine.report_origin, float).copy()


def to_machine_frame(machine: Machine, positions: ArrayLike, frame: str) -> np.ndarray:
    """Positions (..., 3) or poses (..., 6) given in ``frame`` → the same in the machine frame (a copy)."""
    out = np.array(positions, dtype=float)
    out[..., :3] += frame_origin(machine, frame)
    return out


def from_machine_frame(machine: Machine, positions: ArrayLike, frame: str) -> np.ndarray:
    """Positions (..., 3) or poses (..., 6) in the machine frame → the same in ``frame`` (a copy)."""
    out = np.array(positions, dtype=float)
    out[..., :3] -= frame_origin(machine, frame)
    return out


def frame_metadata(machine: Machine, frame: str) -> dict[str, Any]:
    """JSON-ready statement of a frame: name, origin in the MKS [mm] and what the origin is."""
    o = frame_origin(machine, frame)
    note = ("machine coordinate system of the machine file" if frame == "machine" else
            (machine.report_origin_note or "report origin of the machine file"))
    return {"frame": frame, "frame_origin_mm": (o * 1e3).tolist(), "frame_note": note}


def frame_text(machine: Machine, frame: str) -> str:
    """One line for printed outputs, e.g. ``report frame (origin 0, 400, 0 mm in the machine frame: middle guide)``."""
    if frame == "machine":
        return "machine frame"
    o = frame_origin(machine, frame) * 1e3
    md = frame_metadata(machine, frame)
    return f"report frame (origin {o[0]:g}, {o[1]:g}, {o[2]:g} mm in the machine frame: {md['frame_note']})"


def neglect_spindle(machine: Machine, enabled: bool = True) -> Machine:
    """The machine with the platform-spindle stiffness K_U left out (``enabled``; else the machine unchanged).

    Without the ``platform_spindle`` role platform and spindle form one rigid body (roles.py); this equals loading
    the platform at the TCP with K_U rigid (the structure option ``load_platform`` of
    :class:`pkmstiff.structure.StructureOptions`).
    The machine's field ``spindle_neglected`` records it (every analysis of the machine honours it; the displayed
    title :attr:`~pkmstiff.machine.model.Machine.display_title` says so).
    """
    if not enabled or "platform_spindle" not in machine.machine_components:
        return machine
    mc = {k: v for k, v in machine.machine_components.items() if k != "platform_spindle"}
    return dataclasses.replace(machine, machine_components=mc, spindle_neglected=True)


def spindle_neglected(machine: Machine) -> bool:
    """True if K_U was left out by :func:`neglect_spindle` (the machine's ``spindle_neglected`` field)."""
    return machine.spindle_neglected
