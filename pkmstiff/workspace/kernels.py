"""Compiled (numba) kernels of the octree's bookkeeping: a hash table of lattice keys, the closure's ring look-ups and
the mesh's triangle volumes (docs/theory/workspace.md; the serial parts of a parallel workspace run, issue 25).

Conventions as in :mod:`pkmstiff.kinematics.kernels` (no ``fastmath``: IEEE rounding kept, ``cache=True``); kept in a
file of their own so that editing them does not invalidate the cache of the pose kernels. A workspace always evaluates
thousands of points, so there is no interpreted twin.

The hash table: open addressing with linear probing over a power-of-two number of slots, int64 keys >= 0 (the keys of
lattice points, :class:`pkmstiff.workspace.octree.Lattice`; queries may be any int64), -1 = empty slot; the value of a key is an int64 (a leaf number).
"""

from __future__ import annotations

import numba
import numpy as np

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)  # Fibonacci hashing: the top bits of key * 2**64 / phi


@_jit
def _slot(key, shift):
    return np.int64((np.uint64(key) * _GOLDEN) >> np.uint64(shift))


@_jit
def table_insert(slots, values, shift, keys, vals):
    """Insert ``keys`` (distinct from each other and from the table's) with ``vals``."""
    mask = slots.size - 1
    for i in range(keys.size):
        k = keys[i]
        h = _slot(k, shift)
        while slots[h] != -1:
            h = (h + 1) & mask
        slots[h] = k
        values[h] = vals[i]


@_jit
def _find(slots, values, shift, k):
    mask = slots.size - 1
    h = _slot(k, shift)
    while True:
        s = slots[h]
        if s == -1:  # first: a query may be -1 (a voxel beyond the lattice's padding), never in the table
            return -1
        if s == k:
            return values[h]
        h = (h + 1) & mask


@_jit
def table_lookup(slots, values, shift, keys):
    """Value of every key of ``keys`` (flat), -1 where absent."""
    out = np.empty(keys.size, np.int64)
    for i in range(keys.size):
        out[i] = _find(slots, values, shift, keys[i])
    return out


@_jit
def ring_misses(slots, values, shift, keys, corners, corner_off, edges, ring_off):
    """Lower-corner keys of the voxels around the sign-change edges of the voxels ``keys`` (with their (M, 8) corner
    flags) that are not in the table (the closure's missing voxels; repeats possible)."""
    n = 0
    out = np.empty(1024, np.int64)
    for m in range(keys.size):
        for e in range(edges.shape[0]):
            if corners[m, edges[e, 1]] != corners[m, edges[e, 2]]:
                low = keys[m] + corner_off[edges[e, 1]]
                a = edges[e, 0]
                for r in range(4):
                    rk = low + ring_off[a, r]
                    if rk == keys[m]:  # the voxel itself
                        continue
                    if _find(slots, values, shift, rk) < 0:
                        if n == out.size:
                            grown = np.empty(2 * n, np.int64)
                            grown[:n] = out
                            out = grown
                        out[n] = rk
                        n += 1
    return out[:n]


@_jit
def known_corners(slots, values, shift, leaf_corners, keys, corner_off):
    """For corner keys ``keys``: whether a voxel of the table has it as a corner (known) and its flag there."""
    known = np.zeros(keys.size, np.bool_)
    flag = np.zeros(keys.size, np.bool_)
    for i in range(keys.size):
        for c in range(8):
            v = _find(slots, values, shift, keys[i] - corner_off[c])
            if v >= 0:
                known[i] = True
                flag[i] = leaf_corners[v, c]
                break
    return known, flag


@_jit
def six_volumes(vertices, triangles):
    """(T,) p1 . (p2 x p3) of every triangle: ``np.cross``'s products and differences, then the dot product summed as
    numpy's ``einsum("ij,ij->i", ...)`` sums three terms on x86-64 (first and third, then the second), so the volumes
    are those of the numpy formulation it replaced, bit for bit (tests/test_workspace_octree.py)."""
    out = np.empty(triangles.shape[0])
    for t in range(triangles.shape[0]):
        a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        x0 = vertices[b, 1] * vertices[c, 2] - vertices[b, 2] * vertices[c, 1]
        x1 = vertices[b, 2] * vertices[c, 0] - vertices[b, 0] * vertices[c, 2]
        x2 = vertices[b, 0] * vertices[c, 1] - vertices[b, 1] * vertices[c, 0]
        out[t] = (vertices[a, 0] * x0 + vertices[a, 2] * x2) + vertices[a, 1] * x1
    return out


@_jit
def ring_sums(vid, points, n):
    """(n, 3) sums and (n,) counts of ``points`` (E, 3) over the four voxels ``vid`` (E, 4) of each edge, added in
    edge order (as ``np.bincount`` adds)."""
    acc = np.zeros((n, 3))
    cnt = np.zeros(n)
    for e in range(vid.shape[0]):
        for r in range(4):
            v = vid[e, r]
            acc[v, 0] += points[e, 0]
            acc[v, 1] += points[e, 1]
            acc[v, 2] += points[e, 2]
            cnt[v] += 1.0
    return acc, cnt


@_jit
def ring_triangles(vid, flip):
    """(2E, 3) triangles of the quads through the four voxels ``vid`` (E, 4) of each edge, the ring reversed where
    ``flip``: first the triangles (0, 1, 2) of every quad, then the triangles (0, 2, 3)."""
    n = vid.shape[0]
    out = np.empty((2 * n, 3), np.int64)
    for e in range(n):
        if flip[e]:
            q0, q1, q2, q3 = vid[e, 3], vid[e, 2], vid[e, 1], vid[e, 0]
        else:
            q0, q1, q2, q3 = vid[e, 0], vid[e, 1], vid[e, 2], vid[e, 3]
        out[e, 0], out[e, 1], out[e, 2] = q0, q1, q2
        out[n + e, 0], out[n + e, 1], out[n + e, 2] = q0, q2, q3
    return out


class KeyTable:
    """Lattice keys -> int64 values (leaf numbers), growing as keys are added."""

    def __init__(self, keys: np.ndarray, capacity: int = 0):
        self.size = 0
        self._alloc(max(2 * (keys.size + capacity), 1024))
        self.add(keys)

    def _alloc(self, n: int) -> None:
        bits = max(10, int(n - 1).bit_length())
        self.shift = 64 - bits
        self.slots = np.full(1 << bits, -1, np.int64)
        self.values = np.empty(1 << bits, np.int64)

    def add(self, keys: np.ndarray) -> None:
        """Add distinct new keys; their values are the next numbers (the order of addition)."""
        keys = np.ascontiguousarray(keys, np.int64).ravel()
        if 2 * (self.size + keys.size) > self.slots.size:  # keep the load below 1/2
            old = self.slots != -1
            ok, ov = self.slots[old], self.values[old]
            self._alloc(4 * (self.size + keys.size))
            table_insert(self.slots, self.values, self.shift, ok, ov)
        table_insert(self.slots, self.values, self.shift, keys, np.arange(self.size, self.size + keys.size))
        self.size += keys.size

    def find(self, keys: np.ndarray) -> np.ndarray:
        """Value of each key (shape of ``keys``), -1 where absent."""
        q = np.ascontiguousarray(keys, np.int64)
        return table_lookup(self.slots, self.values, self.shift, q.ravel()).reshape(q.shape)
