"""Modified octree for the boundary of a 3-D admissible set (docs/theory/workspace.md, Cobet 4.1.4, eq. 4.1).

The algorithm works on any admissibility predicate ``admissible(points (N, 3)) -> bool (N,)`` over a box: the
translational workspace at constant orientation (points = positions of O'), the workspace with one variable
orientation range, or the rotational workspace at a point (points = Cardan angles).

Implementation (the text's intended behaviour, docs/theory/workspace.md Note, evaluated level by level instead of depth first):

* All corners live on the finest lattice: axis k of the box is halved ``L_k`` times, the smallest number with
  ``extent_k / 2**L_k <= eps``; corners are integer triples hashed to one int64 key.
* Level ``l`` holds the voxels that are still on the boundary. A boundary voxel is split at its mid-point along
  the axes whose edge is still longer than eps (``l < L_k``; the *modification*), others keep their extent.
* The new corners of a whole level (the 3x3x3 sub-lattice of every boundary voxel minus its eight known corners,
  deduplicated across neighbours) are evaluated in ONE batch; corners shared by voxels are evaluated once.
* A voxel with 0 or 8 admissible corners is discarded (outside / inside, the volume of the inside ones is
  accumulated); a voxel with 1..7 on the finest level is a leaf, whose boundary point is the centroid of its
  admissible corners (eq. 4.1).
* Depth-first (the printed algorithm) and level-by-level (here) visit the same voxels and evaluate the same
  corners; only the order differs.

Extension (Assumption, on by default, ``closure=True``): a feature thinner than a coarse voxel can leave a
sign change on a finest-lattice edge whose neighbouring voxels were discarded on a coarser level. The closure
step adds every finest voxel that shares such an edge with a leaf (evaluating its unknown corners) until the
set is closed; this makes the boundary surface (:mod:`pkmstiff.workspace.surface`) watertight. Corners outside
the initial box count as inadmissible (virtual, not evaluated); ``touches_box`` reports an admissible corner on
the box boundary, i.e. an initial box that does not contain the whole set.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from itertools import pairwise
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from pkmstiff.errors import ArgumentError
from pkmstiff.workspace import kernels
from pkmstiff.workspace.kernels import (
    KeyTable,
    corner_centroids,
    known_corners,
    ring_lookup,
    ring_misses,
    ring_triangles,
)

Predicate = Callable[[np.ndarray], np.ndarray]
Progress = Callable[[int, int, int], None]  # (level, max level, evaluations so far)
#: a predicate that also counts per point: ``points (N, 3) -> (bool (N,), int (N, C))`` (C counters of the caller's,
#: e.g. the poses each point cost), so that points evaluated by two subtrees can be counted once
CountedPredicate = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]

# corner c of a voxel = lower corner + (c & 1, (c >> 1) & 1, (c >> 2) & 1) cells (e2 - e1 along x, ...)
CORNER_OFFSETS = np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)], dtype=np.int64)
# the eight corner flags of a voxel read as one uint64 (one byte per corner): 0 = no admissible corner, ALL = all eight
ALL_CORNERS = np.uint64(0x0101010101010101)


def corner_code(corners: np.ndarray) -> np.ndarray:
    """(M,) uint64: the (M, 8) bool corner flags of each voxel as one number (a view, no copy where contiguous), so
    that "none" / "all admissible" are one comparison instead of a sum over eight columns."""
    return np.ascontiguousarray(corners, dtype=bool).view(np.uint64).reshape(-1)




@dataclass
class OctreeResult:
    """Boundary of an admissible set found by the modified octree (all lengths in the units of the box)."""

    lo: np.ndarray  # (3,) lower box corner
    hi: np.ndarray  # (3,) upper box corner
    eps: float  # requested resolution
    levels: np.ndarray  # (3,) int, halvings per axis
    spacing: np.ndarray  # (3,) effective resolution dx, dy, dz (<= eps)
    leaf_index: np.ndarray  # (M, 3) int64 lower-corner lattice indices of the boundary (leaf) voxels
    leaf_corners: np.ndarray  # (M, 8) bool admissibility of their corners (CORNER_OFFSETS order)
    inside_volume: float  # total volume of the voxels discarded with 8 admissible corners
    evaluations: int  # admissibility evaluations (each lattice point at most once)
    evaluations_per_level: list[tuple[int, int]]  # (level, new evaluations); level -1 = closure step
    closure_voxels: int  # leaves added by the closure step
    touches_box: bool  # an admissible corner lies on the box boundary
    time_total: float  # s, wall clock
    time_evaluation: float  # s spent inside the predicate
    edges: tuple[np.ndarray, np.ndarray, np.ndarray] | None = field(repr=False, default=None)
    leaf_table: KeyTable | None = field(repr=False, default=None)  # leaf lower-corner key -> leaf number
    #: threads the mesh's look-ups and volumes may use (:func:`pkmstiff.workspace.volume.workspace_volume`): 1, or
    #: 2 in a parallel run, whose workers are idle by then
    threads: int = field(repr=False, default=1)

    @cached_property
    def known_keys(self) -> np.ndarray:
        """Sorted keys of the evaluated corners of the leaves: the octree's leaves' corners and those the closure
        evaluated (each a corner of a closure voxel)."""
        return unique_sorted(self._corner_keys())

    @cached_property
    def admissible_keys(self) -> np.ndarray:
        """The admissible ones of :attr:`known_keys`."""
        return unique_sorted(self._corner_keys()[self.leaf_corners])

    def _corner_keys(self) -> np.ndarray:
        return self.lattice.key(self.leaf_index)[:, None] + CORNER_OFFSETS @ self.lattice.strides

    @property
    def n_cells(self) -> np.ndarray:
        return (1 << self.levels.astype(np.int64)).astype(np.int64)

    @property
    def voxel_volume(self) -> float:
        return float(np.prod(self.spacing))

    @cached_property
    def boundary_points(self) -> np.ndarray:
        """(M, 3) centroids of the admissible corners of the leaf voxels (eq. 4.1)."""
        return corner_centroids(np.ascontiguousarray(self.leaf_index, np.int64), np.ascontiguousarray(self.leaf_corners),
                                np.asarray(self.lo, float), np.asarray(self.spacing, float))

    @cached_property
    def extent(self) -> tuple[np.ndarray, np.ndarray]:
        """(3,) min and (3,) max of the boundary points per axis (NaN without any), computed once: the bounding box
        and the cloud centre of the volume methods."""
        p = self.boundary_points
        if p.shape[0] == 0:
            return np.full(3, np.nan), np.full(3, np.nan)
        return kernels.extent(np.ascontiguousarray(p, float))

    @cached_property
    def lattice(self) -> "Lattice":
        return Lattice(self.lo, self.hi, self.levels)

    def sign_change_edges(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Finest-lattice edges of the leaves with a change of admissibility: (lower end (E, 3), axis, lower end ok)."""
        if self.edges is None:
            self.edges = sign_change_edges(self.leaf_index, self.leaf_corners)
        return self.edges

    @cached_property
    def edge_rings(self) -> np.ndarray:
        """(E, 4) leaf numbers of the four voxels around each sign-change edge (see :meth:`Lattice.ring_offsets`);
        -1 where a voxel is not a leaf (only without the closure step). Looked up on :attr:`threads` threads (the
        compiled look-up releases the GIL), each a contiguous part of the edges."""
        start, axis, _ = self.sign_change_edges()
        lat = self.lattice
        if self.leaf_table is None:
            self.leaf_table = KeyTable(lat.key(self.leaf_index))
        start, axis = np.ascontiguousarray(start, np.int64), np.ascontiguousarray(axis, np.int64)
        table, dims, off = self.leaf_table, lat.dims, lat.ring_offsets()
        out = np.empty((start.shape[0], 4), np.int64)
        in_threads(lambda a, b: ring_lookup(table.slots, table.shift, start, axis, dims, off, out, a, b),
                   start.shape[0], self.threads)
        return out

    @cached_property
    def ring_triangles(self) -> np.ndarray:
        """(2E, 3) leaf numbers of the triangles of the boundary mesh (:mod:`pkmstiff.workspace.surface`): the quad
        of each sign-change edge's ring, whose normal is +axis in ring order, turned to point outwards (from the
        admissible to the inadmissible end) and split in two; the same for every vertex placement. Made on
        :attr:`threads` threads, each a contiguous part of the edges."""
        _, _, low_adm = self.sign_change_edges()
        rings, flip = np.ascontiguousarray(self.edge_rings), np.ascontiguousarray(~low_adm)
        out = np.empty((2 * rings.shape[0], 3), np.int64)
        in_threads(lambda a, b: ring_triangles(rings, flip, out, a, b), rings.shape[0], self.threads)
        return out

    def point(self, idx: np.ndarray) -> np.ndarray:
        """Coordinates of lattice indices ``idx`` (..., 3)."""
        return self.lo + np.asarray(idx) * self.spacing

    def admissible_points(self) -> np.ndarray:
        """(K, 3) coordinates of the evaluated admissible corners of the finest level."""
        return self.lattice.point(self.lattice.unkey(self.admissible_keys))


#: fewest items per thread worth a thread of its own (:func:`in_threads`): below, starting it costs a noticeable share
THREAD_LEAST_ITEMS = 100_000


def thread_parts(items: int, threads: int) -> np.ndarray:
    """(n + 1,) bounds of the contiguous parts :func:`in_threads` runs: up to ``threads`` parts of at least
    :data:`THREAD_LEAST_ITEMS` items (one at least)."""
    n = max(1, min(threads, items // THREAD_LEAST_ITEMS))
    return np.linspace(0, items, n + 1).round().astype(np.int64)


def in_threads(fn: Callable[[int, int], Any], items: int, threads: int) -> list[Any]:
    """``[fn(a, b) for contiguous (a, b) covering 0..items]``: up to ``threads`` parts of at least
    :data:`THREAD_LEAST_ITEMS` items, run on as many threads (``fn`` must release the GIL to gain: a compiled kernel)."""
    bounds = thread_parts(items, threads)
    n = bounds.size - 1
    if n == 1:
        return [fn(0, items)]
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(n - 1) as ex:
        rest = [ex.submit(fn, int(a), int(b)) for a, b in pairwise(bounds[1:])]
        first = fn(0, int(bounds[1]))
        return [first] + [f.result() for f in rest]


def unique_sorted(keys: np.ndarray) -> np.ndarray:
    """Sorted unique int64 keys (a plain sort; faster here than numpy's hash-based ``np.unique``).

    The sorts here are ``kind="stable"``: lattice keys come in long ascending runs (voxel by voxel, corner by
    corner), which numpy's stable sort merges 3-4 times faster than its default introsort (measured on the 3.125 mm
    Hexaglide workspace); the sorted values are the same whatever the algorithm.
    """
    k = np.sort(np.asarray(keys, np.int64).ravel(), kind="stable")
    if k.size:
        k = k[np.concatenate([[True], k[1:] != k[:-1]])]
    return k


def unique_inverse(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(keys, return_inverse=True)`` for int64 keys by a stable argsort (see :func:`unique_sorted`)."""
    order = np.argsort(keys, kind="stable")
    k = keys[order]
    first = np.empty(k.size, bool)
    first[:1] = True
    np.not_equal(k[1:], k[:-1], out=first[1:])
    inv = np.empty(k.size, np.int64)
    inv[order] = np.cumsum(first) - 1
    return k[first], inv


def _in_sorted(arr: np.ndarray, q: np.ndarray) -> np.ndarray:
    if arr.size == 0:
        return np.zeros(q.shape, bool)
    pos = np.minimum(np.searchsorted(arr, q), arr.size - 1)
    return arr[pos] == q


class Lattice:
    """Integer lattice of the finest level with one layer of padding for virtual (outside) points."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, levels: np.ndarray):
        self.lo, self.hi, self.levels = lo, hi, levels
        self.n = (1 << levels.astype(np.int64)).astype(np.int64)
        self.h = (hi - lo) / self.n
        self.dims = self.n + 3  # indices -1 .. n + 1
        self.strides = np.array([1, self.dims[0], self.dims[0] * self.dims[1]], dtype=np.int64)  # key of +1 step

    def ring_offsets(self) -> np.ndarray:
        """(3, 4) key offsets from an edge's lower end to the lower corners of the four finest voxels around it.

        For an edge along axis a the ring runs counter-clockwise in the right-handed (a+1, a+2) plane with voxel
        offsets (0, 0), (-1, 0), (-1, -1), (0, -1), so a quad through the four voxel vertices has its normal
        along +a.
        """
        out = np.zeros((3, 4), np.int64)
        for a in range(3):
            su, sv = self.strides[(a + 1) % 3], self.strides[(a + 2) % 3]
            out[a] = [0, -su, -su - sv, -sv]
        return out

    def key(self, idx: np.ndarray) -> np.ndarray:
        """Keys of lattice indices ``idx`` (..., 3) (:func:`pkmstiff.workspace.kernels.lattice_keys`)."""
        idx = np.asarray(idx)
        flat = np.ascontiguousarray(idx, np.int64).reshape(-1, 3)
        return kernels.lattice_keys(flat, self.dims).reshape(idx.shape[:-1])

    def unkey(self, key: np.ndarray) -> np.ndarray:
        k = np.asarray(key, np.int64)
        i0 = k % self.dims[0]
        r = k // self.dims[0]
        return np.stack([i0, r % self.dims[1], r // self.dims[1]], axis=-1) - 1

    def inside(self, idx: np.ndarray) -> np.ndarray:
        return np.all((idx >= 0) & (idx <= self.n), axis=-1)

    def point(self, idx: np.ndarray) -> np.ndarray:
        return self.lo + idx * self.h


def levels_for(lo: np.ndarray, hi: np.ndarray, eps: float) -> np.ndarray:
    """Halvings per axis: the smallest L_k with (hi_k - lo_k) / 2**L_k <= eps."""
    ratio = (hi - lo) / eps
    return np.array([max(0, math.ceil(math.log2(r) - 1e-9)) if r > 1 else 0 for r in ratio], dtype=np.int64)


def _check_box(lo: ArrayLike, hi: ArrayLike, eps: float) -> tuple[np.ndarray, np.ndarray, float]:
    lo_a, hi_a = np.asarray(lo, float), np.asarray(hi, float)
    if lo_a.shape != (3,) or hi_a.shape != (3,) or not (np.isfinite(lo_a).all() and np.isfinite(hi_a).all()):
        raise ArgumentError(f"octree box: expected lo and hi of shape (3,) with finite values, found {lo!r}, {hi!r}")
    if np.any(hi_a <= lo_a):
        raise ArgumentError(f"octree box: expected hi > lo on every axis, found lo={lo_a.tolist()}, "
                               f"hi={hi_a.tolist()}")
    if not (math.isfinite(eps) and eps > 0):
        raise ArgumentError(option="octree resolution eps", expected="a positive number", found=eps)
    if np.max((hi_a - lo_a) / eps) > 2.0 ** 20:
        raise ArgumentError(f"octree resolution eps={eps!r}: more than 2**20 cells along an axis of the box "
                               f"{(hi_a - lo_a).tolist()}; choose a coarser resolution")
    return lo_a, hi_a, float(eps)


class _Evaluator:
    """Calls the predicate on lattice points (inside the box) and keeps count and time."""

    def __init__(self, fn: Predicate, lat: Lattice):
        self.fn, self.lat = fn, lat
        self.count = 0
        self.time = 0.0
        self.level = 0  # the octree level whose new corners are being evaluated (set by _refine)

    def __call__(self, idx: np.ndarray) -> np.ndarray:
        out = np.zeros(idx.shape[0], bool)
        ins = self.lat.inside(idx)
        if ins.any():
            t0 = time.perf_counter()
            val = self._values(idx[ins])
            self.time += time.perf_counter() - t0
            if val.shape != (int(ins.sum()),):
                raise ArgumentError(f"admissibility predicate: expected a bool array of shape ({int(ins.sum())},), "
                                       f"found shape {val.shape}")
            out[ins] = val
            self.count += int(val.shape[0])
        return out

    def _values(self, idx: np.ndarray) -> np.ndarray:
        return np.asarray(self.fn(self.lat.point(idx)), bool)


def octree_boundary(
    admissible: Predicate,
    lo: ArrayLike,
    hi: ArrayLike,
    eps: float,
    *,
    min_level: int = 3,
    closure: bool = True,
    progress: Progress | None = None,
    subtrees: SubtreeRunner | None = None,
    threads: int = 1,
) -> OctreeResult:
    """Boundary voxels and points of the set ``{x : admissible(x)}`` inside the box [lo, hi] (docs/theory/workspace.md).

    ``eps`` is the resolution (every leaf edge <= eps). ``min_level`` (Assumption, default 3): the octree starts
    on the uniform grid of level ``min_level`` (8 voxels per axis) instead of level 1, so that sets much smaller
    than the box are not missed; ``1`` reproduces the spec's start, where the initial box is split without
    classifying it (``0`` is treated as ``1``).

    ``subtrees`` (parallel runs): once it says so (:meth:`SubtreeRunner.split_here`), the boundary voxels of that level
    are cut into contiguous slices whose subtrees are refined to the finest level apart (in workers,
    :func:`refine_subtree`); the leaves, volumes and counts are the same as without (points on the faces between
    slices, evaluated by both, are counted once).

    ``threads``: threads the bookkeeping after the closure (edges, box test) and the result's mesh look-ups and volumes
    may use (:attr:`OctreeResult.threads`): the same result for any number.
    """
    lo_a, hi_a, eps = _check_box(lo, hi, eps)
    t_start = time.perf_counter()
    levels = levels_for(lo_a, hi_a, eps)
    lat = Lattice(lo_a, hi_a, levels)
    ev = _Evaluator(admissible, lat)
    lmax = int(levels.max())
    l0 = int(min(max(min_level, 1), lmax))
    per_level: list[tuple[int, int]] = []

    # start grid: all voxels of level l0
    cells = 1 << np.minimum(l0, levels)  # voxels per axis
    size = 1 << (levels - np.minimum(l0, levels))  # lattice cells per voxel edge
    grid = np.stack(np.meshgrid(*[np.arange(c + 1) for c in cells], indexing="ij"), axis=-1).reshape(-1, 3)
    vals = ev(grid * size).reshape(tuple(cells + 1))
    vox = np.stack(np.meshgrid(*[np.arange(c) for c in cells], indexing="ij"), axis=-1).reshape(-1, 3)
    corners = np.stack([vals[vox[:, 0] + o[0], vox[:, 1] + o[1], vox[:, 2] + o[2]] for o in CORNER_OFFSETS], axis=1)
    vox = vox * size
    per_level.append((l0, ev.count))
    if progress:
        progress(l0, lmax, ev.count)

    n_slices = [0]

    def stop(level: int, n: int) -> bool:
        n_slices[0] = 0 if subtrees is None or level >= lmax - 1 else \
            subtrees.slices(level, n, _evaluations_after(per_level[-1][1], level, levels))
        return n_slices[0] >= 2

    vox, corners, inside, level = _refine(vox, corners, l0, levels, lat, ev, per_level, progress, stop)
    candidates, ahead = None, None  # the closure's first pass and points it will evaluate, done by the subtrees
    if level < lmax and vox.shape[0]:  # stopped: the subtrees of this level's boundary voxels, refined apart
        t_sub = time.perf_counter()
        vox, corners, candidates, ahead = _refine_apart(vox, corners, level, lat, subtrees,  # type: ignore[arg-type]
                                                        n_slices[0], inside, per_level, closure)
        ev.count = sum(n for _, n in per_level)
        ev.time += time.perf_counter() - t_sub
        if progress:
            progress(lmax, lmax, ev.count)
    inside_volume = 0.0
    for level, count in enumerate(inside[l0:], l0):  # level by level, as the voxels were discarded
        size = 1 << (levels - np.minimum(level, levels))
        inside_volume += float(count) * float(np.prod(size * lat.h))

    closure_added, edges, table = 0, None, None
    if closure and vox.shape[0]:
        before = ev.count
        if ahead is None:
            vox, corners, edges, closure_added, table = _close(vox, corners, lat, ev, candidates, threads)
        else:
            vox, corners, edges, closure_added, table = _close_ahead(vox, corners, lat, ev, candidates, ahead,
                                                                     subtrees, threads)  # type: ignore[arg-type]
        per_level.append((-1, ev.count - before))

    touches = _touches_box(vox, corners, lat, threads)
    return OctreeResult(
        lo=lo_a, hi=hi_a, eps=eps, levels=levels, spacing=lat.h, leaf_index=vox, leaf_corners=corners,
        inside_volume=inside_volume, evaluations=ev.count, evaluations_per_level=per_level,
        closure_voxels=closure_added, touches_box=touches, time_total=time.perf_counter() - t_start,
        time_evaluation=ev.time, edges=edges, leaf_table=table, threads=threads,
    )


def _refine(vox: np.ndarray, corners: np.ndarray, level: int, levels: np.ndarray, lat: Lattice, ev: _Evaluator,
            per_level: list[tuple[int, int]], progress: Progress | None = None,
            stop: Callable[[int, int], bool] | None = None) -> tuple[np.ndarray, np.ndarray, list[int], int]:
    """Refine the voxels of ``level`` (with their corner values) to the finest level: the finest boundary voxels,
    their corners, the number of voxels discarded as inside on each level (index = level; levels below
    ``level`` hold 0) and the level of the returned voxels. Appends (level, new evaluations) to ``per_level`` for
    every split. ``stop(level, boundary voxels)`` true: return that level's boundary voxels unsplit (to hand their
    subtrees to workers).

    The children of a voxel follow each other and keep their parents' order, so the leaves come in depth-first order:
    refining contiguous slices of ``vox`` separately and joining the results in slice order gives the same leaves
    (``test_refining_slices_separately_gives_the_same_leaves``), which lets subtrees be refined apart.
    """
    lmax = int(levels.max())
    inside = [0] * (lmax + 1)
    while True:
        code = corner_code(corners)
        inside[level] = int(np.count_nonzero(code == ALL_CORNERS))
        bnd = (code != 0) & (code != ALL_CORNERS)
        vox, corners = vox[bnd], corners[bnd]
        if level >= lmax or vox.shape[0] == 0 or (stop is not None and stop(level, vox.shape[0])):
            return vox, corners, inside, level
        before = ev.count
        ev.level = level + 1
        vox, corners = _split(vox, corners, level, levels, lat, ev)
        level += 1
        per_level.append((level, ev.count - before))
        if progress:
            progress(level, lmax, ev.count)


# ------------------------------------------------------------------------------------------------- subtrees apart
@dataclass
class SubtreeTask:
    """One contiguous slice of a level's boundary voxels, to be refined to the finest level apart (compact arrays).

    ``coarse_keys`` (sorted lattice keys of the lower corners of ALL slices' voxels) and ``coarse_slice`` (the slice
    of each) tell which evaluated points lie on a face shared with another slice: only those can be evaluated twice.
    """

    lo: np.ndarray
    hi: np.ndarray
    levels: np.ndarray
    level: int
    vox: np.ndarray  # (n, 3) lattice indices of the voxels' lower corners
    corners: np.ndarray  # (n, 8) bool
    coarse_keys: np.ndarray
    coarse_slice: np.ndarray
    slice: int
    closure: bool = False  # also close the slice's leaves within the region no other slice holds (see Subtree)
    _regions: KeyTable | None = field(default=None, repr=False)  # coarse voxel key -> number in _region_of
    _region_of: np.ndarray | None = field(default=None, repr=False)  # the slice whose region each is, -1 none
    _slices: KeyTable | None = field(default=None, repr=False)  # :meth:`slice_table`

    @cached_property
    def coarse_size(self) -> np.ndarray:
        """(3,) edge of the slices' voxels in lattice cells."""
        return (1 << (self.levels - np.minimum(self.level, self.levels))).astype(np.int64)

    def others(self, lat: Lattice, idx: np.ndarray) -> np.ndarray:
        """Whether the lattice cells ``idx`` (n, 3) lie in the region of another slice: a voxel of another slice, or a
        voxel of no slice whose neighbours (26) hold voxels of slices, the lowest of them another one (so that two
        slices' own closures rarely evaluate the same points, :func:`refine_subtree`)."""
        q = idx // self.coarse_size
        cells = lat.n // self.coarse_size
        ck = lat.key(q * self.coarse_size)
        if self._regions is None:
            self._regions, self._region_of = KeyTable(np.empty(0, np.int64)), np.empty(0, np.int64)
        pos = self._regions.find(ck)
        new = np.flatnonzero(pos < 0)
        if new.size:  # the voxels' region, once per voxel
            nk, first = np.unique(ck[new], return_index=True)
            nq = q[new[first]]
            owner = self.owner(lat, nq, cells)
            free = np.flatnonzero(owner < 0)
            if free.size:
                near = np.full(free.size, np.iinfo(np.int64).max)
                for o in NEIGHBOURS:
                    s = self.owner(lat, nq[free] + o, cells)
                    near = np.where(s >= 0, np.minimum(near, s), near)
                owner[free] = np.where(near == np.iinfo(np.int64).max, -1, near)
            self._regions.add(nk)
            self._region_of = np.concatenate([self._region_of, owner])
            pos = self._regions.find(ck)
        owner = self._region_of[pos]
        return (owner >= 0) & (owner != self.slice)

    def slice_table(self) -> KeyTable:
        """The lower-corner keys of all slices' voxels -> their slice (built once)."""
        if self._slices is None:
            self._slices = KeyTable(np.empty(0, np.int64), capacity=self.coarse_keys.size)
            self._slices.add(self.coarse_keys, self.coarse_slice)
        return self._slices

    def owner(self, lat: Lattice, q: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """The slice of the slices' voxels ``q`` (n, 3) (coarse indices), -1 where none."""
        valid = np.all((q >= 0) & (q < cells), axis=1)
        ck = lat.key(q * self.coarse_size)
        pos = np.minimum(np.searchsorted(self.coarse_keys, ck), self.coarse_keys.size - 1)
        return np.where(valid & (self.coarse_keys[pos] == ck), self.coarse_slice[pos], -1)


# the 26 neighbours of a voxel (index offsets)
NEIGHBOURS = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1) if (i, j, k) != (0, 0, 0)],
                      dtype=np.int64)


@dataclass
class EvaluatedPoints:
    """Points evaluated ahead of need: sorted keys, admissibility and the counters of each (:data:`CountedPredicate`)."""

    keys: np.ndarray  # (K,) int64, sorted, distinct
    ok: np.ndarray  # (K,) bool
    counts: np.ndarray  # (K, C) int64

    @classmethod
    def empty(cls) -> EvaluatedPoints:
        return cls(np.empty(0, np.int64), np.empty(0, bool), np.empty((0, 0), np.int64))

    @classmethod
    def join(cls, parts: list[EvaluatedPoints]) -> tuple[EvaluatedPoints, np.ndarray]:
        """The points of all ``parts`` (each point once, the first part's) and the summed counters (C,) of the
        repeats left out."""
        parts = [p for p in parts if p.keys.size]
        if not parts:
            return cls.empty(), np.zeros(0, np.int64)
        keys = np.concatenate([p.keys for p in parts])
        counts = np.concatenate([p.counts for p in parts])
        ukeys, first = np.unique(keys, return_index=True)
        again = np.ones(keys.size, bool)
        again[first] = False
        return cls(ukeys, np.concatenate([p.ok for p in parts])[first], counts[first]), counts[again].sum(axis=0)


@dataclass
class Subtree:
    """The finest boundary voxels of one :class:`SubtreeTask` and what its counts need to be merged exactly."""

    vox: np.ndarray
    corners: np.ndarray
    inside: list[int]  # voxels discarded as inside per level
    per_level: list[tuple[int, int]]  # (level, new evaluations of this slice)
    shared_keys: np.ndarray  # (K,) keys of the evaluated points on faces shared with another slice
    shared_level: np.ndarray  # (K,) their levels
    shared_counts: np.ndarray  # (K, C) their counters (:data:`CountedPredicate`)
    ring_misses: np.ndarray | None = None  # sorted keys of voxels around the leaves' sign-change edges not among them
    #: the points the slice's own closure evaluated (:attr:`SubtreeTask.closure`): the closure of all leaves then
    #: finds most of its points evaluated (:func:`_close_ahead`)
    closed: EvaluatedPoints | None = None
    info: Any = None  # what the runner adds (the evaluation statistics of the task)


class SubtreeRunner(Protocol):
    """Where the subtrees run (:func:`octree_boundary`'s ``subtrees``)."""

    def slices(self, level: int, voxels: int, evaluations: float) -> int:
        """Number of slices to cut ``voxels`` boundary voxels of ``level`` into now (< 2: not at this level);
        ``evaluations``: about as many points are left to evaluate below this level."""

    def bounds(self, voxels: int, n_slices: int) -> np.ndarray:
        """(n_slices + 1,) bounds of the contiguous slices of the ``voxels`` boundary voxels (any sizes: the leaves
        are the same, :func:`_refine`)."""

    def run(self, tasks: list[SubtreeTask]) -> list[Subtree]:
        """:func:`refine_subtree` of every task, in task order."""

    def uncount(self, points: int, counts: np.ndarray) -> None:
        """Take ``points`` points with the summed counters ``counts`` (C,) out of the statistics: they were
        evaluated by a second slice."""


class _CountingEvaluator(_Evaluator):
    """Evaluator of a subtree: also keeps key, level and counters of the points on faces shared with another slice."""

    def __init__(self, fn: CountedPredicate, lat: Lattice, task: SubtreeTask):
        super().__init__(fn, lat)  # type: ignore[arg-type]
        self.task = task
        self.shared: list[tuple[np.ndarray, int, np.ndarray]] = []

    def _values(self, idx: np.ndarray) -> np.ndarray:
        val, counts = self.fn(self.lat.point(idx))
        val = np.asarray(val, bool)
        sh = self._on_shared_face(idx)
        if sh.any():
            self.shared.append((self.lat.key(idx[sh]), self.level, np.asarray(counts)[sh]))
        return val

    def _on_shared_face(self, idx: np.ndarray) -> np.ndarray:
        """Points that lie in a voxel (closed) of another slice: one of the up to eight coarse voxels touching them
        (:func:`kernels.on_other_slice`)."""
        t, lat = self.task, self.lat
        table = t.slice_table()
        return kernels.on_other_slice(np.ascontiguousarray(idx, np.int64), t.coarse_size, lat.n // t.coarse_size,
                                      lat.dims, table.slots, table.shift, t.slice)


#: a subtree's own closure stops before a pass of fewer new points than this: each pass costs ~1 ms of fixed costs
#: (two small evaluation calls), and the closure of all leaves evaluates such tails of all slices in one pass each
AHEAD_LEAST_POINTS = 256


class _RecordingEvaluator(_Evaluator):
    """Evaluator of a subtree's own closure: keeps key, value and counters of every point it evaluates."""

    def __init__(self, fn: CountedPredicate, lat: Lattice):
        super().__init__(fn, lat)  # type: ignore[arg-type]
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def _values(self, idx: np.ndarray) -> np.ndarray:
        val, counts = self.fn(self.lat.point(idx))
        val = np.asarray(val, bool)
        self.parts.append((self.lat.key(idx), val, np.asarray(counts)))
        return val

    def points(self) -> EvaluatedPoints:
        """What it evaluated, sorted by key (each point once: a closure evaluates a point once)."""
        if not self.parts:
            return EvaluatedPoints.empty()
        keys = np.concatenate([k for k, _, _ in self.parts])
        order = np.argsort(keys, kind="stable")
        return EvaluatedPoints(keys[order], np.concatenate([v for _, v, _ in self.parts])[order],
                               np.concatenate([c for _, _, c in self.parts])[order])


def refine_subtree(task: SubtreeTask, counted: CountedPredicate) -> Subtree:
    """Refine one slice (a worker's task): its finest boundary voxels in depth-first order, the per-level counts and
    the points it shares with other slices (see :func:`octree_boundary`); with ``task.closure`` also the points the
    closure of its leaves evaluates within the region that no other slice holds."""
    lat = Lattice(task.lo, task.hi, task.levels)
    ev = _CountingEvaluator(counted, lat, task)
    per_level: list[tuple[int, int]] = []
    vox, corners, inside, _ = _refine(task.vox, task.corners, task.level, task.levels, lat, ev, per_level)
    if ev.shared:
        keys = np.concatenate([k for k, _, _ in ev.shared])
        lvl = np.concatenate([np.full(k.size, level, np.int64) for k, level, _ in ev.shared])
        counts = np.concatenate([c for _, _, c in ev.shared])
    else:
        keys, lvl, counts = np.empty(0, np.int64), np.empty(0, np.int64), np.empty((0, 0), np.int64)
    leaf_keys = lat.key(vox)
    table = KeyTable(leaf_keys, capacity=leaf_keys.size // 4)  # the closure's below adds its voxels to it
    misses = _ring_misses(table, leaf_keys, corners, lat)
    closed = None
    if task.closure and vox.shape[0]:
        rec = _RecordingEvaluator(counted, lat)
        _closure_passes(vox, corners, lat, rec, misses, keep=lambda k: ~task.others(lat, lat.unkey(k)),
                        least=AHEAD_LEAST_POINTS, table=table, keys=leaf_keys)
        closed = rec.points()
    return Subtree(vox, corners, inside, per_level, keys, lvl, counts, misses, closed)


def _ring_misses(table: KeyTable, keys: np.ndarray, corners: np.ndarray, lat: Lattice) -> np.ndarray:
    """Sorted keys of the voxels around the sign-change edges of the leaves (``keys``, all in ``table``) that are not
    among them: the closure's first pass over these leaves alone (a superset of its first pass over all leaves, see
    :func:`_close`)."""
    return unique_sorted(ring_misses(table.slots, table.shift, keys, np.ascontiguousarray(corners),
                                     CORNER_OFFSETS @ lat.strides, EDGES, lat.ring_offsets()))


def _evaluations_after(last: int, level: int, levels: np.ndarray) -> float:
    """Evaluations the levels below ``level`` will take, from the ``last`` level's: a boundary surface cut by
    halving s axes has 2**(s - 1) times as many voxels (×4 while all three axes are halved, ×1 when one is)."""
    total, e = 0.0, float(last)
    for lv in range(level + 1, int(levels.max()) + 1):
        e *= 2.0 ** (int(np.count_nonzero(levels >= lv)) - 1)
        total += e
    return total


def _refine_apart(vox: np.ndarray, corners: np.ndarray, level: int, lat: Lattice, runner: SubtreeRunner,
                  n_slices: int, inside: list[int], per_level: list[tuple[int, int]], closure: bool
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, EvaluatedPoints]:
    """Cut the boundary voxels of ``level`` into ``n_slices`` contiguous slices, refine them apart (``runner``) and
    join the leaves in slice order (the serial order, :func:`_refine`); the inside counts and the evaluations per level
    are added to ``inside`` and ``per_level``, a point evaluated by k slices counted once (``runner.uncount``). Also
    returns the slices' ring misses (candidates for the closure's first pass, :func:`_close`) and, with ``closure``,
    the points their own closures evaluated (each once; :func:`_close_ahead`)."""
    bounds = runner.bounds(vox.shape[0], n_slices)
    keys = lat.key(vox)
    order = np.argsort(keys, kind="stable")
    owner = np.repeat(np.arange(n_slices), np.diff(bounds))
    tasks = [SubtreeTask(lat.lo, lat.hi, lat.levels, level, vox[a:b], corners[a:b], keys[order], owner[order], k,
                         closure) for k, (a, b) in enumerate(pairwise(bounds))]
    parts = runner.run(tasks)
    new: dict[int, int] = {}
    for part in parts:
        for lv, n in enumerate(part.inside):
            inside[lv] += n
        for lv, n in part.per_level:
            new[lv] = new.get(lv, 0) + n
    shared = [p for p in parts if p.shared_keys.size]
    if shared:
        skeys = np.concatenate([p.shared_keys for p in shared])
        again = np.ones(skeys.size, bool)  # the second and later evaluations of a point
        again[np.unique(skeys, return_index=True)[1]] = False
        for lv, n in zip(*np.unique(np.concatenate([p.shared_level for p in shared])[again], return_counts=True)):
            new[int(lv)] -= int(n)
        runner.uncount(int(again.sum()), np.concatenate([p.shared_counts for p in shared])[again].sum(axis=0))
    per_level.extend(sorted(new.items()))
    closed = [p.closed for p in parts if p.closed is not None]
    ahead, repeats = EvaluatedPoints.join(closed)
    if sum(c.keys.size for c in closed) > ahead.keys.size:
        runner.uncount(sum(c.keys.size for c in closed) - ahead.keys.size, repeats)
    return (np.concatenate([p.vox for p in parts]), np.concatenate([p.corners for p in parts]),
            np.concatenate([p.ring_misses for p in parts]), ahead)


def _touches_box(vox: np.ndarray, corners: np.ndarray, lat: Lattice, threads: int = 1) -> bool:
    """An admissible corner of a finest voxel lies on the box boundary (:func:`kernels.touches_box`; contiguous parts
    of the voxels on up to ``threads`` threads)."""
    vox, corners = np.ascontiguousarray(vox, np.int64), np.ascontiguousarray(corners, bool)
    n = np.ascontiguousarray(lat.n, np.int64)
    return any(in_threads(lambda a, b: bool(kernels.touches_box(vox[a:b], corners[a:b], n)), vox.shape[0], threads))


def _split(vox: np.ndarray, corners: np.ndarray, level: int, levels: np.ndarray, lat: Lattice,
           ev: _Evaluator) -> tuple[np.ndarray, np.ndarray]:
    """Children of the boundary voxels of ``level`` with their corner values (new corners in one batch)."""
    split = level < levels  # axes whose edge is still longer than eps
    child = 1 << (levels - np.minimum(level + 1, levels))  # child edge in lattice cells
    m = np.where(split, 3, 2)  # sub-lattice points per axis: {0, child, 2 child} or {0, parent edge}
    step = child  # lattice step of the sub-lattice (on a non-split axis the child edge equals the parent edge)
    sub = np.stack(np.meshgrid(*[np.arange(k) for k in m], indexing="ij"), axis=-1).reshape(-1, 3)  # (S, 3)
    is_corner = np.all((sub == 0) | (sub == m - 1), axis=1)
    new_sub = sub[~is_corner]
    # values on the sub-lattice: (M, m0, m1, m2)
    M = vox.shape[0]
    val = np.zeros((M,) + tuple(m), bool)
    for c, o in enumerate(CORNER_OFFSETS):
        val[:, o[0] * (m[0] - 1), o[1] * (m[1] - 1), o[2] * (m[2] - 1)] = corners[:, c]
    keys = (lat.key(vox)[:, None] + (new_sub * step) @ lat.strides).ravel()  # (M * S') keys of the new points
    ukeys, inv = unique_inverse(keys)
    uval = ev(lat.unkey(ukeys))
    nv = uval[inv].reshape(M, -1)
    val[:, new_sub[:, 0], new_sub[:, 1], new_sub[:, 2]] = nv
    # children: lower sub-index c in {0 .. m-2} per axis, corners c + offset
    lower = np.stack(np.meshgrid(*[np.arange(k - 1) for k in m], indexing="ij"), axis=-1).reshape(-1, 3)  # (C, 3)
    cidx = lower[:, None, :] + CORNER_OFFSETS[None]  # (C, 8, 3)
    ccorn = val[:, cidx[..., 0], cidx[..., 1], cidx[..., 2]]  # (M, C, 8)
    cvox = vox[:, None, :] + lower[None] * step  # (M, C, 3)
    return cvox.reshape(-1, 3), ccorn.reshape(-1, 8)


# the 12 edges of a voxel: (axis, corner at the lower end, corner at the upper end)
EDGES = np.array([(a, c, c | (1 << a)) for a in range(3) for c in range(8) if not c & (1 << a)], dtype=np.int64)


def sign_change_edges(vox: np.ndarray, corners: np.ndarray, dedupe: bool = True
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Finest-lattice edges of the voxels whose end points differ in admissibility.

    Returns ``(lower end lattice index (E, 3), axis (E,), lower end admissible (E,))``; with ``dedupe`` an edge
    shared by several voxels is listed once.
    """
    lo_ok = corners[:, EDGES[:, 1]]
    hi_ok = corners[:, EDGES[:, 2]]
    vi, ei = np.nonzero(lo_ok != hi_ok)
    start = vox[vi] + CORNER_OFFSETS[EDGES[ei, 1]]
    axis = EDGES[ei, 0]
    low_adm = lo_ok[vi, ei]
    if start.shape[0] == 0 or not dedupe:
        return start, axis, low_adm
    span = int(start.max()) + 3
    key = ((start[:, 0] + 1) + span * ((start[:, 1] + 1) + span * (start[:, 2] + 1))) * 3 + axis
    _, first = np.unique(key, return_index=True)
    return start[first], axis[first], low_adm[first]


def owned_edges(vox: np.ndarray, corners: np.ndarray, threads: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sign-change edges listed once, by their owner: the voxel whose lower corner is the edge's lower end; first those
    along x in voxel order, then y, then z: (lower end (E, 3), axis (E,), lower end admissible (E,)).

    Complete only for a closed leaf set (every voxel around a sign-change edge is a leaf), which the closure step
    guarantees; no sorting needed. Counted, then listed, on up to ``threads`` threads (contiguous parts of the
    voxels; the same arrays for any number).
    """
    vox, corners = np.ascontiguousarray(vox, np.int64), np.ascontiguousarray(corners, bool)
    m = vox.shape[0]
    counts = np.array(in_threads(lambda a, b: kernels.owned_edge_counts(corners, a, b), m, threads),
                      np.int64).reshape(-1, 3)  # (parts, 3)
    per_axis = counts.sum(axis=0)
    # first row of each part's edges along each axis: the edges of the axes before, then those of the parts before
    at = np.concatenate([[0], np.cumsum(per_axis)[:-1]])[None] + np.cumsum(counts, axis=0) - counts
    part = {int(a): k for k, a in enumerate(thread_parts(m, threads)[:-1])}
    n = int(per_axis.sum())
    start, axis, low = np.empty((n, 3), np.int64), np.empty(n, np.int64), np.empty(n, bool)
    in_threads(lambda a, b: kernels.owned_edges_into(vox, corners, a, b, at[part[a]], start, axis, low), m, threads)
    return start, axis, low


def _close(vox: np.ndarray, corners: np.ndarray, lat: Lattice, ev: _Evaluator, candidates: np.ndarray | None = None,
           threads: int = 1) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray], int, KeyTable]:
    """Add finest voxels around sign-change edges until every such edge has all four voxels (see module doc).

    Returns the leaves, their corners, the sign-change edges of all leaves (each once), the number of added voxels and
    the leaves' key table (key -> leaf number); the passes are :func:`_closure_passes`'.
    """
    vox, corners, added, table = _closure_passes(vox, corners, lat, ev, candidates)
    return vox, corners, owned_edges(vox, corners, threads), added, table


class _AheadEvaluator(_Evaluator):
    """The closure's evaluator where the subtrees evaluated points ahead: their values are read back (and marked
    used), the others evaluated by ``ev``'s predicate."""

    def __init__(self, ev: _Evaluator, ahead: EvaluatedPoints):
        super().__init__(ev.fn, ev.lat)
        self.ahead = ahead
        self.used = np.zeros(ahead.keys.size, bool)

    def _values(self, idx: np.ndarray) -> np.ndarray:
        keys, known = self.lat.key(idx), self.ahead.keys
        pos = np.minimum(np.searchsorted(known, keys), max(known.size - 1, 0))
        hit = known[pos] == keys if known.size else np.zeros(keys.size, bool)
        out = np.empty(keys.size, bool)
        out[hit] = self.ahead.ok[pos[hit]]
        self.used[pos[hit]] = True
        if not hit.all():
            out[~hit] = super()._values(idx[~hit])
        return out


def _close_ahead(vox: np.ndarray, corners: np.ndarray, lat: Lattice, ev: _Evaluator, candidates: np.ndarray,
                 ahead: EvaluatedPoints, runner: SubtreeRunner, threads: int = 1
                 ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray], int, KeyTable]:
    """:func:`_close` where the subtrees' own closures evaluated points ahead (:func:`refine_subtree`): the same
    passes, leaves and counts (a point read back counts as evaluated here, as in the serial run); the points evaluated
    ahead that the closure does not need are taken out of the statistics (``runner.uncount``).

    Every voxel a subtree's closure adds is one the closure of all leaves adds too (it lies outside the other slices,
    which hold all their leaves, and is reached from leaves through voxels of the closure), so most of the points
    the closure needs are read back; the rest (voxels first reached through another slice's region) are evaluated
    here."""
    aev = _AheadEvaluator(ev, ahead)
    out = _close(vox, corners, lat, aev, candidates, threads)
    ev.count += aev.count
    ev.time += aev.time
    if not aev.used.all():
        runner.uncount(int((~aev.used).sum()), ahead.counts[~aev.used].sum(axis=0))
    return out


def _closure_passes(vox: np.ndarray, corners: np.ndarray, lat: Lattice, ev: _Evaluator,
                    candidates: np.ndarray | None = None, keep: Callable[[np.ndarray], np.ndarray] | None = None,
                    least: int = 0, table: KeyTable | None = None, keys: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray, int, KeyTable]:
    """The closure's passes: the leaves with the added voxels, their corners, the number added and the key table.

    Only the voxels added in the previous pass can ask for new neighbours, so each pass looks at that frontier; the
    voxels of a pass are added in the order of their keys. A corner is known (not evaluated again) when a leaf has it:
    the corners of the octree's leaves and those evaluated in earlier passes.

    ``candidates`` (subtrees refined apart): the ring misses of each subtree's leaves alone (computed in the workers).
    A voxel missing among all leaves is missing among a subtree's; a candidate of one subtree may be a leaf of
    another: the first pass keeps the candidates not in the table, which are the misses of a pass over all leaves.

    ``keep`` (a subtree's own closure, :func:`refine_subtree`): keys of missing voxels -> which of them to add; the
    others are left out (the closure is then that of the leaves within the region ``keep`` allows). ``least``: stop
    before a pass that would evaluate fewer points (the rest is left to the closure of all leaves). ``table``,
    ``keys``: the leaves' key table and lattice keys where the caller has them (``candidates`` are then the misses of
    these very leaves, none in the table).
    """
    corner_off = CORNER_OFFSETS @ lat.strides
    ring_off = lat.ring_offsets()
    f_keys, f_corn = lat.key(vox) if keys is None else keys, np.ascontiguousarray(corners)
    known = table is not None
    if table is None:
        table = KeyTable(f_keys, capacity=f_keys.size // 4)
    parts_v = [vox]
    all_corn = np.empty((f_keys.size + max(f_keys.size // 4, 1024), 8), bool)  # corners by leaf number, grown
    all_corn[:f_keys.size] = f_corn
    added = 0
    while f_keys.shape[0]:
        if candidates is not None:
            missing = candidates if known else unique_sorted(candidates[table.find(candidates) < 0])
            candidates = None
        else:
            missing = unique_sorted(ring_misses(table.slots, table.shift, f_keys, f_corn, corner_off,
                                                EDGES, ring_off))
        if keep is not None:
            missing = missing[keep(missing)]
        if missing.size == 0:
            break
        ck = (missing[:, None] + corner_off[None]).ravel()
        uck, at = unique_inverse(ck)  # neighbouring missing voxels share corners: each looked up once
        kn, uval = known_corners(table.slots, table.shift, all_corn, uck, corner_off)
        unk = uck[~kn]
        if unk.size < least:
            break
        if unk.size:
            uval[~kn] = ev(lat.unkey(unk))
        table.add(missing)
        f_keys, f_corn = missing, uval[at].reshape(-1, 8)
        if table.size > all_corn.shape[0]:
            all_corn = np.concatenate([all_corn, np.empty((max(all_corn.shape[0], f_keys.size), 8), bool)])
        all_corn[table.size - f_keys.size:table.size] = f_corn
        parts_v.append(lat.unkey(missing))
        added += missing.size
    return np.concatenate(parts_v), all_corn[:table.size], added, table
