"""Compiled (numba) kernels of the octree's bookkeeping: a hash table of lattice keys, the closure's ring look-ups and
the mesh's triangle volumes (docs/theory/workspace.md; the serial parts of a parallel workspace run, issue 25).

Conventions as in :mod:`pkmstiff.kinematics.kernels` (no ``fastmath``: IEEE rounding kept, ``cache=True``); kept in a
file of their own so that editing them does not invalidate the cache of the pose kernels. A workspace always evaluates
thousands of points, so there is no interpreted twin.

The hash table: open addressing with linear probing over a power-of-two number of slots, int64 keys >= 0 (the keys of
lattice points, :class:`pkmstiff.workspace.octree.Lattice`; queries may be any int64), -1 = empty slot; the value of a key is an int64 (a leaf number).
Key and value of a slot lie side by side (``slots[2 h]``, ``slots[2 h + 1]``): a look-up that finds its key reads
one cache line, not two.
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
def table_insert(slots, shift, keys, vals):
    """Insert ``keys`` (distinct from each other and from the table's) with ``vals``."""
    mask = slots.size // 2 - 1
    for i in range(keys.size):
        k = keys[i]
        h = _slot(k, shift)
        while slots[2 * h] != -1:
            h = (h + 1) & mask
        slots[2 * h] = k
        slots[2 * h + 1] = vals[i]


@_jit
def _find(slots, shift, k):
    mask = slots.size // 2 - 1
    h = _slot(k, shift)
    while True:
        s = slots[2 * h]
        if s == -1:  # first: a query may be -1 (a voxel beyond the lattice's padding), never in the table
            return -1
        if s == k:
            return slots[2 * h + 1]
        h = (h + 1) & mask


@_jit
def table_lookup(slots, shift, keys):
    """Value of every key of ``keys`` (flat), -1 where absent."""
    out = np.empty(keys.size, np.int64)
    for i in range(keys.size):
        out[i] = _find(slots, shift, keys[i])
    return out


@_jit
def ring_misses(slots, shift, keys, corners, corner_off, edges, ring_off):
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
                    if _find(slots, shift, rk) < 0:
                        if n == out.size:
                            grown = np.empty(2 * n, np.int64)
                            grown[:n] = out
                            out = grown
                        out[n] = rk
                        n += 1
    return out[:n]


@_jit
def known_corners(slots, shift, leaf_corners, keys, corner_off):
    """For corner keys ``keys``: whether a voxel of the table has it as a corner (known) and its flag there."""
    known = np.zeros(keys.size, np.bool_)
    flag = np.zeros(keys.size, np.bool_)
    for i in range(keys.size):
        for c in range(8):
            v = _find(slots, shift, keys[i] - corner_off[c])
            if v >= 0:
                known[i] = True
                flag[i] = leaf_corners[v, c]
                break
    return known, flag


@_jit
def six_volumes(vertices, triangles, origin):
    """(T,) p1 . (p2 x p3) of every triangle, p = vertex - ``origin`` (3,): ``np.cross``'s products and differences,
    then the dot product summed as numpy's ``einsum("ij,ij->i", ...)`` sums three terms on x86-64 (first and third,
    then the second), so the volumes are those of the numpy formulation it replaced, bit for bit, without the shifted
    copy of the vertices (tests/test_workspace_octree.py)."""
    out = np.empty(triangles.shape[0])
    o0, o1, o2 = origin[0], origin[1], origin[2]
    for t in range(triangles.shape[0]):
        a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        a0, a1, a2 = vertices[a, 0] - o0, vertices[a, 1] - o1, vertices[a, 2] - o2
        b0, b1, b2 = vertices[b, 0] - o0, vertices[b, 1] - o1, vertices[b, 2] - o2
        c0, c1, c2 = vertices[c, 0] - o0, vertices[c, 1] - o1, vertices[c, 2] - o2
        x0 = b1 * c2 - b2 * c1
        x1 = b2 * c0 - b0 * c2
        x2 = b0 * c1 - b1 * c0
        out[t] = (a0 * x0 + a2 * x2) + a1 * x1
    return out


@_jit
def distances(points, z):
    """(N,) Euclidean distance of each point (N, 3) from ``z`` (3,): the square root of ((dx² + dy²) + dz²), the order
    in which ``np.linalg.norm(points - z, axis=1)`` sums, so the same numbers bit for bit without its two (N, 3)
    temporaries (tests/test_workspace_octree.py)."""
    out = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        d0, d1, d2 = points[i, 0] - z[0], points[i, 1] - z[1], points[i, 2] - z[2]
        out[i] = np.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
    return out


@_jit
def crossing_vertices(vid, start, axis, t, n, lo, h, n_vox):
    """(n_vox, 3) vertices of the crossing mesh: per voxel, lo + (mean of the crossing points of the edges ``vid``
    (E, 4) around it, lattice units) * h. The crossing point of edge e is ``start`` (E, 3) + t_e along ``axis``, where
    t_e is ``t`` (E,) between two lattice points (0 <= index <= ``n``), 1 where the lower end lies outside and 0
    where the upper end does (the box face is the cut). Sums in edge order, then the quotient and the product as
    numpy's ``lo + acc / cnt * h``: the numbers of the numpy formulation, bit for bit."""
    acc = np.zeros((n_vox, 3))
    cnt = np.zeros(n_vox)
    p = np.empty(3)
    for e in range(vid.shape[0]):
        a = axis[e]
        lower_in = True
        upper_in = True
        for k in range(3):
            i = start[e, k]
            if i < 0 or i > n[k]:
                lower_in = False
            j = i + 1 if k == a else i
            if j < 0 or j > n[k]:
                upper_in = False
            p[k] = np.float64(i)
        p[a] += 1.0 if not lower_in else (0.0 if not upper_in else t[e])
        for r in range(4):
            v = vid[e, r]
            acc[v, 0] += p[0]
            acc[v, 1] += p[1]
            acc[v, 2] += p[2]
            cnt[v] += 1.0
    out = np.empty((n_vox, 3))
    for v in range(n_vox):
        for k in range(3):
            out[v, k] = lo[k] + acc[v, k] / cnt[v] * h[k]
    return out


@_jit
def ring_triangles(vid, flip, out, a, b):
    """Into ``out`` (2E, 3): the triangles of the quads through the four voxels ``vid`` (E, 4) of edges a..b-1, the
    ring reversed where ``flip``: first the triangles (0, 1, 2) of every quad (rows e), then the triangles (0, 2, 3)
    (rows E + e); parts of the edges on threads of their own write into one array."""
    n = vid.shape[0]
    for e in range(a, b):
        if flip[e]:
            q0, q1, q2, q3 = vid[e, 3], vid[e, 2], vid[e, 1], vid[e, 0]
        else:
            q0, q1, q2, q3 = vid[e, 0], vid[e, 1], vid[e, 2], vid[e, 3]
        out[e, 0], out[e, 1], out[e, 2] = q0, q1, q2
        out[n + e, 0], out[n + e, 1], out[n + e, 2] = q0, q2, q3


@_jit
def _key(idx, i, dims):
    return (idx[i, 0] + 1) + dims[0] * ((idx[i, 1] + 1) + dims[1] * (idx[i, 2] + 1))


@_jit
def lattice_keys(idx, dims):
    """(N,) keys (i0 + 1) + dims0 ((i1 + 1) + dims1 (i2 + 1)) of the lattice indices ``idx`` (N, 3)
    (:meth:`pkmstiff.workspace.octree.Lattice.key`)."""
    out = np.empty(idx.shape[0], np.int64)
    for i in range(idx.shape[0]):
        out[i] = _key(idx, i, dims)
    return out


@_jit
def owned_edge_counts(corners, a, b):
    """(3,) sign-change edges at the lower corner of voxels a..b-1 per axis (:func:`owned_edges_into`)."""
    out = np.zeros(3, np.int64)
    for ax in range(3):
        for m in range(a, b):
            if corners[m, 0] != corners[m, 1 << ax]:
                out[ax] += 1
    return out


@_jit
def owned_edges_into(vox, corners, a, b, at, start, axis, low):
    """Into ``start`` (E, 3), ``axis`` (E,), ``low`` (E,): the sign-change edges at the lower corner of voxels a..b-1
    (``vox`` (M, 3), ``corners`` (M, 8)), those along axis k from row ``at[k]`` on in voxel order: lower end, axis,
    lower end admissible. With the rows of each part of the voxels after those of the parts before it, per axis, the
    edges of all voxels are listed first along x in voxel order, then y, then z (parts on threads of their own write
    into one array)."""
    for ax in range(3):
        e = at[ax]
        for m in range(a, b):
            if corners[m, 0] != corners[m, 1 << ax]:
                start[e, 0], start[e, 1], start[e, 2] = vox[m, 0], vox[m, 1], vox[m, 2]
                axis[e] = ax
                low[e] = corners[m, 0]
                e += 1


@_jit
def ring_lookup(slots, shift, start, axis, dims, ring_off, out, a, b):
    """Into ``out[a:b]`` (E, 4): the values (leaf numbers, -1 where absent) of the lattice keys of the four voxels
    around edges a..b-1: lower end ``start`` (E, 3) lattice indices, ``axis`` (E,), keys as :func:`lattice_keys`,
    the voxels' key offsets ``ring_off`` (3, 4) (parts of the edges on threads of their own write into one array)."""
    for e in range(a, b):
        base = _key(start, e, dims)
        for r in range(4):
            out[e, r] = _find(slots, shift, base + ring_off[axis[e], r])


@_jit
def corner_centroids(index, corners, lo, h):
    """(M, 3) lo + (index + mean offset of the admissible corners) * h of every voxel (eq. 4.1), with numpy's
    operations on the counts (float quotient, then the sum and the product), so the same numbers bit for bit."""
    out = np.empty((index.shape[0], 3))
    for m in range(index.shape[0]):
        n = 0
        a0 = 0
        a1 = 0
        a2 = 0
        for c in range(8):
            if corners[m, c]:
                n += 1
                a0 += c & 1
                a1 += (c >> 1) & 1
                a2 += (c >> 2) & 1
        out[m, 0] = lo[0] + (index[m, 0] + np.float64(a0) / np.float64(n)) * h[0]
        out[m, 1] = lo[1] + (index[m, 1] + np.float64(a1) / np.float64(n)) * h[1]
        out[m, 2] = lo[2] + (index[m, 2] + np.float64(a2) / np.float64(n)) * h[2]
    return out


@_jit
def on_other_slice(idx, size, cells, dims, slots, shift, me):
    """(N,) whether each lattice point ``idx`` (N, 3) (inside the lattice) lies in a coarse voxel (closed) of a slice
    other than ``me``: one of the up to eight coarse voxels of edge ``size`` (3,) cells touching it (two along an axis
    where it lies on a coarse face, one otherwise), looked up in the table of the coarse voxels' lower-corner keys
    (:func:`lattice_keys` with ``dims``) -> slice; ``cells`` (3,) coarse voxels per axis."""
    out = np.zeros(idx.shape[0], np.bool_)
    for i in range(idx.shape[0]):
        q0, q1, q2 = idx[i, 0] // size[0], idx[i, 1] // size[1], idx[i, 2] // size[2]
        f0 = idx[i, 0] - q0 * size[0] == 0
        f1 = idx[i, 1] - q1 * size[1] == 0
        f2 = idx[i, 2] - q2 * size[2] == 0
        if not (f0 or f1 or f2):
            continue
        for c in range(8):
            o0, o1, o2 = c & 1, (c >> 1) & 1, (c >> 2) & 1
            if (o0 and not f0) or (o1 and not f1) or (o2 and not f2):
                continue
            a0, a1, a2 = q0 - o0, q1 - o1, q2 - o2
            if a0 < 0 or a1 < 0 or a2 < 0 or a0 >= cells[0] or a1 >= cells[1] or a2 >= cells[2]:
                continue
            key = (a0 * size[0] + 1) + dims[0] * ((a1 * size[1] + 1) + dims[1] * (a2 * size[2] + 1))
            s = _find(slots, shift, key)
            if s >= 0 and s != me:
                out[i] = True
                break
    return out


@_jit
def touches_box(vox, corners, n):
    """Whether an admissible corner of the voxels ``vox`` (M, 3) lower-corner lattice indices, ``corners`` (M, 8)
    in corner order c = (c & 1, c >> 1 & 1, c >> 2 & 1), lies on a face of the lattice box 0..n (3,) and inside it."""
    for m in range(vox.shape[0]):
        for c in range(8):
            if not corners[m, c]:
                continue
            face = False
            inside = True
            for k in range(3):
                i = vox[m, k] + ((c >> k) & 1)
                if i < 0 or i > n[k]:
                    inside = False
                elif i == 0 or i == n[k]:
                    face = True
            if face and inside:
                return True
    return False


@_jit
def extent(points):
    """(3,) min and (3,) max of the points (N >= 1, 3) per axis (no NaN), in one pass."""
    lo = points[0].copy()
    hi = points[0].copy()
    for i in range(1, points.shape[0]):
        for k in range(3):
            v = points[i, k]
            if v < lo[k]:
                lo[k] = v
            elif v > hi[k]:
                hi[k] = v
    return lo, hi


@_jit
def extent_centre(points):
    """(3,) 0.5 (min + max) of the points (N >= 1, 3) per axis (no NaN)."""
    lo, hi = extent(points)
    return 0.5 * (lo + hi)


class KeyTable:
    """Lattice keys -> int64 values (leaf numbers), growing as keys are added."""

    def __init__(self, keys: np.ndarray, capacity: int = 0):
        self.size = 0
        self._alloc(max(2 * (keys.size + capacity), 1024))
        self.add(keys)

    def _alloc(self, n: int) -> None:
        bits = max(10, int(n - 1).bit_length())
        self.shift = 64 - bits
        self.slots = np.full(2 << bits, -1, np.int64)  # (key, value) pairs

    def add(self, keys: np.ndarray, values: np.ndarray | None = None) -> None:
        """Add distinct new keys with ``values`` (int64 >= 0), by default the next numbers (the order of addition)."""
        keys = np.ascontiguousarray(keys, np.int64).ravel()
        if 4 * (self.size + keys.size) > self.slots.size:  # keep the load below 1/2
            pairs = self.slots.reshape(-1, 2)
            old = pairs[pairs[:, 0] != -1]
            self._alloc(4 * (self.size + keys.size))
            table_insert(self.slots, self.shift, np.ascontiguousarray(old[:, 0]), np.ascontiguousarray(old[:, 1]))
        table_insert(self.slots, self.shift, keys, np.arange(self.size, self.size + keys.size) if values is None
                     else np.ascontiguousarray(values, np.int64).ravel())
        self.size += keys.size

    def find(self, keys: np.ndarray) -> np.ndarray:
        """Value of each key (shape of ``keys``), -1 where absent."""
        q = np.ascontiguousarray(keys, np.int64)
        return table_lookup(self.slots, self.shift, q.ravel()).reshape(q.shape)


@_jit
def corrector_poses(active, up, cur, D, K, lookahead, budget, pts, dvec, inc):
    """The poses of one batch of the rotation map's corrector (:func:`pkmstiff.workspace.rotation._steps`): the active
    (point, direction) searches (``active``, ``up``, ``cur``: (P, D) flattened row-major) in that order, each walking
    from ``cur`` upwards (``up``, to K) or downwards (to 1) by up to L = max(1, min(``lookahead``, ``budget`` //
    searches)) increments. Returns the searches' flat indices, the increments each evaluates (n), L and the poses
    (pts[p] + (cur ± j) inc dvec[d], j = 1 … n, search by search)."""
    at = np.flatnonzero(active)
    count = at.size
    L = max(1, min(lookahead, budget // max(count, 1)))
    n = np.empty(count, np.int64)
    total = 0
    for a in range(count):
        c = cur[at[a]]
        n[a] = min(K - c if up[at[a]] else c - 1, L)
        total += n[a]
    poses = np.empty((total, 6))
    row = 0
    for a in range(count):
        p, d = at[a] // D, at[a] % D
        c = cur[at[a]]
        sign = 1 if up[at[a]] else -1
        for j in range(1, n[a] + 1):
            t = (c + sign * j) * inc
            for q in range(6):
                poses[row, q] = pts[p, q] + t * dvec[d, q]
            row += 1
    return at, n, L, poses


@_jit
def corrector_update(at, n, L, ok, D, K, up, cur, result, active, evals):
    """The searches of :func:`corrector_poses` after their poses' admissibility ``ok``: each stops at its first
    increment whose admissibility differs from its direction of walk (inadmissible upwards, admissible downwards) and
    counts the increments the one-at-a-time search evaluates (up to the stop); ``cur``, ``result`` (upwards: the last
    admissible increment so far; downwards: set when the search ends, 0 = the base orientation), ``active`` (all
    (P, D) flattened) and ``evals`` (D,) in place."""
    row = 0
    for a in range(at.size):
        i = at[a]
        u = up[i]
        c = cur[i]
        stop = L + 1
        for j in range(1, n[a] + 1):
            if ok[row + j - 1] != u:
                stop = j
                break
        row += n[a]
        stopped = stop <= n[a]
        walked = stop if stopped else n[a]
        evals[i % D] += walked
        new = c + walked if u else c - walked
        if u:
            res = new - 1 if stopped else new
            done = stopped or new >= K
        else:
            res = new if stopped else 0
            done = stopped or new <= 1
        if u or done:
            result[i] = res
        cur[i] = new
        if done:
            active[i] = False
