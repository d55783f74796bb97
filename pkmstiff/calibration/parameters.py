"""Geometric error models as named parameter vectors (Szatmári §4.2.2, Fig. 4.4; docs/theory/calibration.md).

A :class:`ParameterSet` lists every error parameter of a machine (and optionally of the measurement set-up) with a
name such as ``chain3.platform_joint.y``, its unit, nominal value, scale and the direction it acts along. Error
vectors are *deviations* Δp from the nominal values (SI: m, rad).

Per chain (chain numbers 1-based, as ``chains[i]`` in machine files):

* pod: ``base_joint`` (3, machine-file key ``drive_joint``), ``platform_joint`` (3, PKS), ``strut_offset`` (1,
  key ``drive_offset``: a commanded strut length u gives the length u + Δl) = 7, i.e. 42 for a hexapod;
* glide: ``guide_start`` (3), ``guide_direction`` (2 tilt angles t1, t2 about axes normal to the guide),
  ``drive_joint`` (3, offset of the drive-side joint from the guide point), ``strut_length`` (1),
  ``platform_joint`` (3), ``drive_zero`` (1, key ``drive_offset``) = 13.

Set-up parameters (selected by the tokens of :func:`setup_tokens`): ball-bar ``ball_offset`` Δv (PKS, 3),
``fixed_ball`` position (MKS, 3), ``bar_offset`` Δr (1); tracker/pose ``target_offset`` (PKS, 3) and
``instrument_frame`` (translation x, y, z and rotation rx, ry, rz of the instrument's frame in the MKS, 6).
Machine parameters outside the geometry (token ``backlash``, :data:`MACHINE_TOKENS`): per-drive reversal backlash
``chain<i>.backlash`` (1 per chain, m; :mod:`pkmstiff.calibration.backlash`).

Parameter frames (Szatmári §4.4.2.3): ``cartesian`` (x, y, z of the machine or platform frame) or ``cylindrical``
(r radial, t tangential, z with respect to the joint circle: the z axis through the centroid of the points of a
block). The frame only rotates the three components of a point; it changes O and the condition number, not the rank.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from pkmstiff.errors import InputError
from pkmstiff.machine.model import Machine

if TYPE_CHECKING:
    from pkmstiff.calibration.instruments import Instrument

Frame = Literal["cartesian", "cylindrical"]
FRAMES = ("cartesian", "cylindrical")

#: typical size of a length error (m): the scale of the Jacobian columns. Szatmári Tab. 5.2: parameter errors
#: up to 1.75 mm, mean 0.7 mm -> 1 mm
DEFAULT_LENGTH_SCALE = 1e-3
#: typical size of an angular error (rad): 1 mrad = 1 mm over 1 m of guide
DEFAULT_ANGLE_SCALE = 1e-3


#: blocks whose parameters are points fixed to the base (MKS)
BASE_POINTS = ("base_joint", "guide_start", "fixed_ball")

_E = np.eye(3)


@dataclass(frozen=True)
class ParameterSet:
    """Named error parameters of a machine and its measurement set-up (docs/theory/calibration.md).

    Arrays have one entry per parameter: ``nominal`` and ``scale`` in SI (m or rad), ``chain`` the 0-based chain
    index (-1 for set-up parameters), ``axis`` the unit direction a parameter moves its point (or, for a guide
    tilt, the direction the guide's unit vector turns to; for ``instrument_frame`` the translation or rotation
    axis); zero for scalars.
    """

    machine: str
    kind: str
    frame: str
    names: tuple[str, ...]
    units: tuple[str, ...]
    blocks: tuple[str, ...]
    components: tuple[str, ...]
    chain: np.ndarray
    axis: np.ndarray
    nominal: np.ndarray
    scale: np.ndarray

    def __len__(self) -> int:
        return len(self.names)

    @property
    def n(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Position of a parameter; unknown names raise a one-line error with the closest names."""
        try:
            return self.names.index(name)
        except ValueError:
            close = difflib.get_close_matches(name, self.names, n=3)
            hint = f" (did you mean {', '.join(close)}?)" if close else ""
            raise InputError(self.machine, name, f"a parameter name of this error model{hint}",
                                        "unknown parameter") from None

    def indices(self, names: Iterable[str]) -> np.ndarray:
        return np.array([self.index(nm) for nm in names], dtype=int)

    def mask(self, block: str) -> np.ndarray:
        return np.array([b == block for b in self.blocks])

    def vector(self, values: Mapping[str, float]) -> np.ndarray:
        """Error vector Δp (SI) from a mapping name -> value; names not given are 0."""
        out = np.zeros(self.n)
        for name, v in values.items():
            out[self.index(name)] = float(v)
        return out

    def as_dict(self, delta: np.ndarray) -> dict[str, float]:
        delta = self.check_vector(delta)
        return {nm: float(v) for nm, v in zip(self.names, delta)}

    def check_vector(self, delta: np.ndarray, what: str = "error vector") -> np.ndarray:
        d = np.asarray(delta, dtype=float)
        if d.shape != (self.n,) or not np.all(np.isfinite(d)):
            raise InputError(self.machine, what, f"{self.n} finite values (one per parameter, SI)",
                                        f"shape {d.shape}")
        return d

    def block_vectors(self, delta: np.ndarray, block: str, rows: int) -> np.ndarray:
        """Cartesian deviation (rows, 3) of a vector block from Δp: Σ Δp_k axis_k per chain (or row 0 for set-up)."""
        out = np.zeros((rows, 3))
        m = self.mask(block)
        if m.any():
            r = np.where(self.chain[m] >= 0, self.chain[m], 0)
            np.add.at(out, r, delta[m, None] * self.axis[m])
        return out

    def block_scalars(self, delta: np.ndarray, block: str, rows: int) -> np.ndarray:
        out = np.zeros(rows)
        m = self.mask(block)
        if m.any():
            r = np.where(self.chain[m] >= 0, self.chain[m], 0)
            np.add.at(out, r, delta[m])
        return out

    def scaled(self, scale: np.ndarray) -> ParameterSet:
        """The same parameters with other scales (SI, one per parameter, positive)."""
        s = np.asarray(scale, dtype=float)
        if s.shape != (self.n,) or not np.all(s > 0):
            raise InputError(self.machine, "scale", f"{self.n} positive scales", f"shape {s.shape}")
        return ParameterSet(**{**self.__dict__, "scale": s})


def _cyl_axes(points: np.ndarray, frame: str) -> np.ndarray:
    """Per point the three unit axes (n, 3, 3) of its components: x, y, z or radial, tangential, z about the
    vertical axis through the centroid of the points (Szatmári §4.4.2.3)."""
    n = points.shape[0]
    if frame == "cartesian":
        return np.broadcast_to(_E, (n, 3, 3)).copy()
    rel = points[:, :2] - points[:, :2].mean(axis=0)
    rad = np.linalg.norm(rel, axis=1)
    er = np.zeros((n, 3))
    ok = rad > 1e-9
    er[ok, :2] = rel[ok] / rad[ok, None]
    er[~ok, 0] = 1.0  # a point on the axis: radial = x (the cylindrical frame is undefined there)
    ez = np.broadcast_to(_E[2], (n, 3))
    et = np.cross(ez, er)
    return np.stack([er, et, ez], axis=1)


def guide_tilt_axes(direction: np.ndarray) -> np.ndarray:
    """Two unit vectors (n, 2, 3) normal to each guide direction r: e1 = unit(r × z) (horizontal; r × x for a
    vertical guide), e2 = r × e1. The tilt parameters t1, t2 turn r by δr = t1 e1 + t2 e2."""
    r = direction / np.linalg.norm(direction, axis=1, keepdims=True)
    e1 = np.cross(r, _E[2])
    vert = np.linalg.norm(e1, axis=1) < 0.1
    e1[vert] = np.cross(r[vert], _E[0])
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(r, e1)
    return np.stack([e1, e2], axis=1)


class _Builder:
    def __init__(self) -> None:
        self.rows: list[tuple] = []

    def point(self, prefix: str, block: str, chain: int, value: np.ndarray, axes: np.ndarray, labels: Sequence[str],
              scale: float) -> None:
        for k in range(3):
            self.rows.append((f"{prefix}{block}.{labels[k]}", "m", block, labels[k], chain, axes[k],
                              float(value @ axes[k]), scale))

    def scalar(self, name: str, block: str, chain: int, unit: str, value: float, scale: float) -> None:
        self.rows.append((name, unit, block, "", chain, np.zeros(3), float(value), scale))

    def build(self, machine: str, kind: str, frame: str) -> ParameterSet:
        names, units, blocks, comps, chain, axis, nominal, scale = zip(*self.rows) if self.rows else ([],) * 8
        return ParameterSet(machine=machine, kind=kind, frame=frame, names=tuple(names), units=tuple(units),
                            blocks=tuple(blocks), components=tuple(comps), chain=np.array(chain, dtype=int),
                            axis=np.array(axis, dtype=float).reshape(-1, 3), nominal=np.array(nominal, dtype=float),
                            scale=np.array(scale, dtype=float))


#: ``--with`` tokens of machine parameters outside the geometric error model -> block: per-drive reversal backlash
#: (:mod:`pkmstiff.calibration.backlash`, issue 26 item 6)
MACHINE_TOKENS = {"backlash": "backlash"}


def setup_tokens() -> dict[str, str]:
    """Every set-up parameter token (command line ``--with``) -> its block, over all instruments
    (:attr:`pkmstiff.calibration.instruments.Instrument.setup_tokens`)."""
    from pkmstiff.calibration.instruments import instruments

    return {t: b for inst in instruments() for t, b in inst.setup_tokens.items()}


def parse_with(tokens: str | Iterable[str] | None, instrument: Instrument | str,
               source: str = "--with") -> tuple[str, ...]:
    """Set-up tokens (``"ball-offset,bar-offset"``) -> block names; checked against the instrument."""
    from pkmstiff.calibration.instruments import instrument as lookup, instruments

    if tokens is None:
        return ()
    inst = lookup(instrument)
    known = setup_tokens()
    items = [t.strip() for t in (tokens.split(",") if isinstance(tokens, str) else tokens) if t.strip()]
    out = []
    for t in items:
        if t in MACHINE_TOKENS:  # machine parameters any instrument can see
            if MACHINE_TOKENS[t] not in out:
                out.append(MACHINE_TOKENS[t])
            continue
        if t not in known:
            raise InputError(source, t, f"one of {', '.join([*known, *MACHINE_TOKENS])}", "unknown set-up parameter")
        block = known[t]
        if t not in inst.setup_tokens:
            owners = "/".join(str(i) for i in instruments() if t in i.setup_tokens)
            raise InputError(source, t, f"a set-up parameter of the {inst} "
                                        f"({', '.join(inst.setup_tokens)})", f"a {owners} parameter")
        if block not in out:
            out.append(block)
    return tuple(out)


def error_model(machine: Machine, frame: str = "cartesian", setup: object | None = None,
                setup_blocks: Iterable[str] = (), length_scale: float = DEFAULT_LENGTH_SCALE,
                angle_scale: float = DEFAULT_ANGLE_SCALE) -> ParameterSet:
    """The error parameters of ``machine`` (docs/theory/calibration.md, Szatmári §4.2.2) plus the set-up blocks asked for.

    ``setup`` (a :class:`pkmstiff.calibration.instruments.Setup`) gives the nominal values of set-up parameters;
    ``setup_blocks`` are block names (``ball_offset``, ``fixed_ball``, ``bar_offset``, ``target_offset``,
    ``instrument_frame``), e.g. from :func:`parse_with`.
    """
    if frame not in FRAMES:
        raise InputError(machine.path or machine.name, "frame", "'cartesian' or 'cylindrical'", frame)
    ch = machine.chains
    b = _Builder()
    labels = ("x", "y", "z") if frame == "cartesian" else ("r", "t", "z")
    L, A = float(length_scale), float(angle_scale)
    if ch.kind == "pod":
        base_ax, plat_ax = _cyl_axes(ch.drive_joint, frame), _cyl_axes(ch.platform_joint, frame)
        for i in range(ch.n):
            pre = f"chain{i + 1}."
            b.point(pre, "base_joint", i, ch.drive_joint[i], base_ax[i], labels, L)
            b.point(pre, "platform_joint", i, ch.platform_joint[i], plat_ax[i], labels, L)
            b.scalar(pre + "strut_offset", "strut_offset", i, "m", ch.drive_offset[i], L)
    else:
        start_ax, plat_ax = _cyl_axes(ch.guide_start, frame), _cyl_axes(ch.platform_joint, frame)
        tilt = guide_tilt_axes(ch.guide_direction)
        for i in range(ch.n):
            pre = f"chain{i + 1}."
            b.point(pre, "guide_start", i, ch.guide_start[i], start_ax[i], labels, L)
            for k in range(2):
                b.rows.append((f"{pre}guide_direction.t{k + 1}", "rad", "guide_direction", f"t{k + 1}", i,
                               tilt[i, k], 0.0, A))
            b.point(pre, "drive_joint", i, ch.drive_joint[i], _E, ("x", "y", "z"), L)
            b.scalar(pre + "strut_length", "strut_length", i, "m", ch.strut_length[i], L)
            b.point(pre, "platform_joint", i, ch.platform_joint[i], plat_ax[i], labels, L)
            b.scalar(pre + "drive_zero", "drive_zero", i, "m", ch.drive_offset[i], L)
    blocks = tuple(setup_blocks)
    if "backlash" in blocks:  # a machine parameter: one per drive, m (:mod:`pkmstiff.calibration.backlash`)
        for i in range(ch.n):
            b.scalar(f"chain{i + 1}.backlash", "backlash", i, "m", 0.0, L)
        blocks = tuple(blk for blk in blocks if blk != "backlash")
    if blocks and setup is None:
        raise InputError(machine.path or machine.name, "setup", "an instrument set-up for set-up "
                                    "parameters", None)
    for blk in blocks:
        if blk in ("ball_offset", "target_offset"):
            b.point("", blk, -1, setup.target, _E, ("x", "y", "z"), L)
        elif blk == "fixed_ball":
            b.point("", blk, -1, setup.fixed_ball, _E, ("x", "y", "z"), L)
        elif blk == "bar_offset":
            b.scalar("bar_offset", blk, -1, "m", 0.0, L)
        elif blk == "instrument_frame":
            for k, c in enumerate("xyz"):
                b.rows.append((f"instrument_frame.{c}", "m", blk, c, -1, _E[k], 0.0, L))
            for k, c in enumerate("xyz"):
                b.rows.append((f"instrument_frame.r{c}", "rad", blk, f"r{c}", -1, _E[k], 0.0, A))
        else:
            raise InputError(machine.path or machine.name, "setup_blocks",
                                        f"set-up blocks {sorted(setup_tokens().values())}", blk)
    return b.build(machine.name, ch.kind, frame)


def parse_errors(table: Mapping[str, object], params: ParameterSet, source: str = "errors") -> np.ndarray:
    """Error vector Δp (SI) from a table name -> quantity (``"0.5 mm"``, ``"0.2 mrad"``, bare numbers SI), e.g. the
    ``[errors]`` table of an error file; unknown names and wrong dimensions raise one-line errors."""
    from pkmstiff.units import parse_quantity

    if not isinstance(table, Mapping):
        raise InputError(source, "errors", "a table parameter name = value", table)
    out = np.zeros(params.n)
    for name, value in table.items():
        k = params.index(str(name))
        try:
            out[k] = parse_quantity(value, params.units[k], source=source, key=str(name))
        except InputError:
            raise
        except ValueError as exc:  # another ValueError (a component or numpy): name the parameter
            raise InputError(getattr(exc, "file", source), getattr(exc, "key", str(name)),
                                        getattr(exc, "expected", f"a value in {params.units[k]}"),
                                        getattr(exc, "found", value)) from None
    return out
