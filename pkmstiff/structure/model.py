"""The PKM structure model at N poses: the pose-vectorised SDE model with its bodies, elements and bindings.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

import pkmstiff.multibody as sde
from pkmstiff.admissibility.checks import Reason
from pkmstiff.machine.model import Machine
from pkmstiff.structure.assembly import drive_names, rigid_chains, sde_model
from pkmstiff.structure.layout import StructureLayout
from pkmstiff.structure.options import NOT_POSITIVE_DEFINITE, STATUS_TEXT, Array, StructureModelError, StructureOptions
from pkmstiff.structure.stiffness import ChainStiffness


@dataclass
class PKMStructure:
    """Structure model of a machine at N poses (SDE model over the ``index`` poses that could be modelled).

    ``reasons`` (N,) :class:`~pkmstiff.admissibility.checks.Reason` bits of poses not modelled (0 = modelled unless
    ``status`` is set); ``status`` (N,) extra bits :data:`COMPONENT_FAILED`, :data:`NOT_POSITIVE_DEFINITE`.
    Geometry arrays (``w``, ``R``, ``p``, ``q``, ``u``) and ``stiffness`` hold the modelled poses only.
    """

    layout: StructureLayout
    poses: Array  # (N, 6)
    reasons: Array  # (N,) uint32
    status: Array  # (N,) uint8
    index: Array  # (M,) modelled poses
    w: Array  # (M, 3) O' in the MKS
    R: Array  # (M, 3, 3)
    p: Array  # (M, n, 3) platform joint points
    q: Array  # (M, n, 3) drive joint points
    u: Array  # (M, n, 3) unit strut directions d̂
    stiffness: ChainStiffness
    _model: sde.SDEModel | None = dataclasses.field(default=None, repr=False)
    _dynamic: sde.SDEModel | None = dataclasses.field(default=None, repr=False)
    _parts: dict[int, list[tuple[slice, PKMStructure]]] = dataclasses.field(default_factory=dict, repr=False)

    @property
    def model(self) -> sde.SDEModel | None:
        """The SDE model of the modelled poses (built on first use); None when no pose could be modelled."""
        if self._model is None and len(self.index):
            self._model = sde_model(self.layout, self.w, self.R, self.p, self.q, self.u, self.stiffness)
        return self._model

    @property
    def drive_bodies(self) -> tuple[str, ...]:
        """Names of the drive bodies, ``''`` where the drive is rigidly suspended (no drive DOFs)."""
        return drive_names(self.layout, self.stiffness)

    @property
    def rigid_chain(self) -> np.ndarray:
        """(n,) True where the chain (V) is rigid (exact rigid binding instead of an SDE)."""
        return rigid_chains(self.stiffness)

    @property
    def machine(self) -> Machine:
        return self.layout.machine

    @property
    def options(self) -> StructureOptions:
        return self.layout.options

    @property
    def n_poses(self) -> int:
        return int(self.poses.shape[0])

    @property
    def ok(self) -> Array:
        """(N,) True where the pose is modelled (results finite)."""
        mask = np.zeros(self.n_poses, bool)
        mask[self.index] = True
        return mask

    @property
    def tcp_body(self) -> str:
        return self.layout.tcp_body

    @property
    def empty(self) -> bool:
        """True when no pose could be modelled (``model`` is None; every analysis returns NaN)."""
        return not len(self.index)

    def tcp(self, tool_length: float | ArrayLike | None = None) -> Array:
        """TCP in the MKS (M, 3): ``O' + R (tool.offset + L · tool.axis)`` (docs/theory/structure.md).

        ``tool_length``: L in m (None: machine file), or a tool vector (3,) in the PKS [m] from O' to the tool tip
        that replaces ``tool.offset + L · tool.axis`` (any tool orientation).
        """
        tool = self.machine.tool
        if tool_length is not None and np.ndim(tool_length) == 1:
            tip = np.asarray(tool_length, dtype=float)
            if tip.shape != (3,) or not np.all(np.isfinite(tip)):
                raise StructureModelError("tcp", "tool_length", "a length >= 0 m or a tool vector (3,) in m (PKS)",
                                          tool_length)
        else:
            if tool_length is not None and not (np.isfinite(tool_length) and tool_length >= 0):
                raise StructureModelError("tcp", "tool_length", "a length >= 0 m or a tool vector (3,) in m (PKS)",
                                          tool_length)
            tip = tool.tip(tool_length)
        return self.w + self.R @ tip

    def scatter(self, values: ArrayLike, fill: Any = np.nan) -> np.ndarray:
        """Expand per-modelled-pose values (M, ...) to all poses (N, ...), ``fill`` elsewhere."""
        v = np.asarray(values)
        out = np.full((self.n_poses,) + v.shape[1:], fill, dtype=np.result_type(v.dtype, np.asarray(fill).dtype))
        out[self.index] = v
        return out

    @property
    def massless_spindle(self) -> bool:
        """True for a separate spindle body without mass (e.g. the Hexaglide: all of M_P on the platform)."""
        sp = self.layout.spindle
        return self.layout.separate_spindle and sp.mass == 0 and not np.any(sp.inertia)

    @property
    def dynamic_model(self) -> sde.SDEModel:
        """Model for the eigenvalue problem: :attr:`model`, or without a massless spindle.

        A massless spindle coupled to the platform only through U adds nothing to the dynamic stiffness: its static
        condensation gives ``K_PP − N_Pᵀ K_U N_P``, i.e. exactly the platform block without U (docs/theory/structure.md Guyan).
        Leaving it out saves the condensation (frequencies identical; mode shapes then lack the spindle DOFs).
        """
        if not self.massless_spindle or not len(self.index):
            return self.model
        if self._dynamic is None:
            self._dynamic = sde_model(self.layout, self.w, self.R, self.p, self.q, self.u, self.stiffness,
                                       with_spindle=False)
        return self._dynamic

    def failing(self, i: int) -> list[str]:
        """Why pose ``i`` is not modelled (empty list if it is)."""
        from pkmstiff.admissibility.checks import REASON_TEXT

        out = [REASON_TEXT[r] for r in Reason if int(self.reasons[i]) & int(r)]
        out += [text for bit, text in STATUS_TEXT.items() if int(self.status[i]) & bit]
        return out

    def without(self, local_bad: Array, status_bit: int = NOT_POSITIVE_DEFINITE) -> PKMStructure:
        """Copy without the modelled poses flagged in ``local_bad`` (M,) (they get ``status_bit``)."""
        keep = ~np.asarray(local_bad, bool)
        status = self.status.copy()
        status[self.index[~keep]] |= np.uint8(status_bit)
        return dataclasses.replace(self, status=status, index=self.index[keep], w=self.w[keep], R=self.R[keep],
                                   p=self.p[keep], q=self.q[keep], u=self.u[keep],
                                   stiffness=self.stiffness.take(keep), _model=None, _dynamic=None, _parts={})

    def part(self, poses: slice) -> PKMStructure:
        """The structure of a range of its poses (``slice`` over the N poses); the SDE model is built anew."""
        lo, hi, _ = poses.indices(self.n_poses)
        k = (self.index >= lo) & (self.index < hi)
        return PKMStructure(self.layout, self.poses[lo:hi], self.reasons[lo:hi], self.status[lo:hi], self.index[k] - lo,
                            self.w[k], self.R[k], self.p[k], self.q[k], self.u[k], self.stiffness.take(k))

    def parts(self, chunk_size: int | None = None) -> list[tuple[slice, PKMStructure]]:
        """``(slice, structure)`` for consecutive ranges of at most ``chunk_size`` poses (default
        :data:`~pkmstiff.structure.DEFAULT_CHUNK`): the analyses of :mod:`pkmstiff.analysis` work part by part, so
        that their memory is bounded by one part whatever N is. A structure that fits is its own single part.

        The parts (and the SDE models they build) of a structure of at most :data:`KEEP_PARTS` parts are kept, so
        that several analyses of one chunk (stiffness, weak points, deflection: the section quantities) assemble
        each model once; a larger structure is split afresh by every analysis (memory stays bounded).
        """
        from pkmstiff.structure import options as _options

        size = int(chunk_size or _options.DEFAULT_CHUNK)
        if size < 1:
            raise StructureModelError("PKMStructure.parts", "chunk_size", "an integer >= 1", chunk_size)
        if self.n_poses <= size:
            return [(slice(0, self.n_poses), self)]
        if size in self._parts:
            return self._parts[size]
        out = [(sl, self.part(sl)) for sl in (slice(s, min(s + size, self.n_poses))
                                              for s in range(0, self.n_poses, size))]
        if len(out) <= KEEP_PARTS:
            self._parts[size] = out
        return out

    @staticmethod
    def concatenate(parts: list[PKMStructure]) -> PKMStructure:
        """One structure of the poses of ``parts`` (same layout) in their order (SDE model built anew)."""
        first = parts[0]
        offsets = np.cumsum([0] + [p.n_poses for p in parts[:-1]])
        ks = [p.stiffness for p in parts]
        w_local = None if ks[0].w_local is None else np.concatenate([k.w_local for k in ks])
        stiffness = ChainStiffness(*(np.concatenate([getattr(k, f) for k in ks]) for f in
                                     ("drive_joint", "strut", "platform_joint", "drive", "chain")), w_local)
        return PKMStructure(first.layout, *(np.concatenate([getattr(p, f) for p in parts]) for f in
                                            ("poses", "reasons", "status")),
                            np.concatenate([p.index + o for p, o in zip(parts, offsets)]),
                            *(np.concatenate([getattr(p, f) for p in parts]) for f in ("w", "R", "p", "q", "u")),
                            stiffness)


#: largest number of parts of a structure that :meth:`PKMStructure.parts` keeps (a section chunk of the default
#: 4096 poses has two parts of 2048; one million poses would keep every part's SDE model alive)
KEEP_PARTS = 4
