"""Modified octree, closed boundary surface and volume methods on analytic bodies (spec models.md §7.3, §7.5)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pkmstiff.errors import ArgumentError
from pkmstiff.workspace.octree import CORNER_OFFSETS, levels_for, octree_boundary
from pkmstiff.workspace.surface import boundary_surface
from pkmstiff.workspace.volume import pyramid_volume, tetrahedron_volume, workspace_volume

# body centre off the lattice planes of the box [-0.8, 0.8]^3 (an aligned face would sit exactly on corners)
CENTRE = np.array([0.0123, 0.0271, 0.0389])
BOX = (np.full(3, -0.8), np.full(3, 0.8))  # 1.6 m = 6.25 mm * 2**8: eps is reached by repeated halving


def sphere(p, c=CENTRE, r=0.5):
    return np.linalg.norm(p - c, axis=1) <= r


def cube(p, c=CENTRE, a=0.5):
    return np.all(np.abs(p - c) <= a, axis=1)


@pytest.fixture(scope="module")
def bodies_6mm():
    out = {}
    # "cube, h not dividing": box +-0.61 m gives h = 1.22 m / 256 = 4.77 mm, so the cube edge is 209.8 h and the
    # mid-point errors of opposite faces do not cancel (with h = 6.25 mm the edge is exactly 160 h)
    for name, fn, exact, box in (("sphere", sphere, np.pi / 6, BOX), ("cube", cube, 1.0, BOX),
                                 ("cube, h not dividing", cube, 1.0, (np.full(3, -0.61), np.full(3, 0.61)))):
        res = octree_boundary(fn, *box, 0.00625)
        rep = workspace_volume(res, ("surface_nets", "tetrahedron", "divergence", "pyramid"),
                               refine_steps=3, admissible=fn)
        out[name] = (res, rep, exact)
    return out


@pytest.mark.parametrize("body", ["sphere", "cube", "cube, h not dividing"])
def test_surface_nets_volume_within_half_percent_at_6mm(bodies_6mm, body):
    # issue 6 acceptance: < 0.5 % at eps = 6.25 mm (dissertation: 2.3 % sphere, 1.7 % cube with tetrahedra).
    # With 3 bisection steps an aligned cube face is located within h/16; six faces of 1 m^2 give <= 0.23 %.
    res, rep, exact = bodies_6mm[body]
    assert np.all(res.spacing <= 0.00625)
    assert abs(rep.volumes["surface_nets"] / exact - 1) < 0.005


@pytest.mark.parametrize("body", ["sphere", "cube"])
def test_tetrahedron_method_converges_from_below(bodies_6mm, body):
    # eq. 4.1 centroids lie inside the body, so the mesh through them is inside and the volume from below
    # (spec §7.5); the inward offset is at most one voxel edge h, so the deficit is below area * h / V.
    res, rep, exact = bodies_6mm[body]
    area_over_v = 3 / 0.5 if body == "sphere" else 6.0  # sphere 3/r, cube 6/a (1/m)
    for m in ("tetrahedron", "divergence"):
        rel = rep.volumes[m] / exact - 1
        assert -area_over_v * res.spacing[0] < rel < 0
    # both bodies are star-shaped about the cloud centre: signed and unsigned sums agree to rounding
    assert rep.volumes["tetrahedron"] == pytest.approx(rep.volumes["divergence"], rel=1e-12)


def test_surface_is_closed_and_lies_near_the_sphere(bodies_6mm):
    res, rep, _ = bodies_6mm["sphere"]
    for mesh in (rep.centroid_mesh, rep.crossing_mesh):
        assert mesh.is_closed()
    # refined crossing vertices: within the bisection bracket h/16 plus the mesh-vertex averaging (chord) error
    d = np.abs(np.linalg.norm(rep.crossing_mesh.vertices - CENTRE, axis=1) - 0.5)
    assert d.max() < res.spacing[0] / 2


def test_error_decreases_with_resolution():
    errs = {}
    for eps in (0.05, 0.025, 0.0125):
        res = octree_boundary(sphere, *BOX, eps)
        rep = workspace_volume(res, ("surface_nets", "tetrahedron"))
        errs[eps] = {k: abs(v / (np.pi / 6) - 1) for k, v in rep.volumes.items()}
    for m in ("surface_nets", "tetrahedron"):
        assert errs[0.0125][m] < errs[0.025][m] < errs[0.05][m]
    # the tetrahedron method converges linearly (error ~ 3 h / (2 r)): halving eps roughly halves it
    assert 1.6 < errs[0.025]["tetrahedron"] / errs[0.0125]["tetrahedron"] < 2.4
    # the mid-point surface is unbiased: at least 10x more accurate than the centroid surface here
    assert errs[0.0125]["surface_nets"] < errs[0.0125]["tetrahedron"] / 10


@settings(max_examples=10, deadline=None)
@given(c=st.tuples(*[st.floats(-0.15, 0.15)] * 3), r=st.floats(0.15, 0.5), eps=st.sampled_from([0.06, 0.045, 0.035]))
def test_boundary_points_within_eps_of_the_sphere(c, r, eps):
    c = np.asarray(c)
    res = octree_boundary(lambda p: np.linalg.norm(p - c, axis=1) <= r, [-0.7] * 3, [0.7] * 3, eps)
    assert np.all(res.spacing <= eps)
    pts = res.boundary_points
    d = np.abs(np.linalg.norm(pts - c, axis=1) - r)
    # the centroid of the admissible corners of a voxel cut by a plane is at most one edge h from the plane
    # (worst case: four corners of a face admissible); curvature adds at most h^2 / r
    h = res.spacing.max()
    assert d.max() <= h + h * h / r <= eps + eps * eps / r
    # completeness: every point of the true surface has a boundary point within a voxel diagonal
    rng = np.random.default_rng(0)
    dirs = rng.normal(size=(200, 3))
    surf = c + r * dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    nearest = np.min(np.linalg.norm(surf[:, None, :] - pts[None, ::1, :], axis=2), axis=1)
    assert nearest.max() <= np.sqrt(3) * h


def _depth_first(fn, lo, hi, eps):
    """The spec's recursive algorithm (§7.3 Note) with memoised corners, as an independent reference."""
    levels = levels_for(np.asarray(lo, float), np.asarray(hi, float), eps)
    n = 1 << levels
    h = (np.asarray(hi) - np.asarray(lo)) / n
    cache: dict[tuple, bool] = {}

    def adm(i):
        if i not in cache:
            cache[i] = bool(fn((np.asarray(lo) + np.asarray(i) * h)[None])[0])
        return cache[i]

    leaves = set()

    def rec(i0, size):
        axes = [k for k in range(3) if size[k] > 1]
        half = [size[k] // 2 if k in axes else size[k] for k in range(3)]
        for c in range(1 << len(axes)):
            off = [0, 0, 0]
            for b, k in enumerate(axes):
                off[k] = half[k] * ((c >> b) & 1)
            ci = tuple(i0[k] + off[k] for k in range(3))
            corners = [adm(tuple(ci[k] + o[k] * half[k] for k in range(3))) for o in CORNER_OFFSETS]
            na = sum(corners)
            if na in (0, 8):
                continue
            if any(s > 1 for s in half):
                rec(ci, half)
            else:
                leaves.add(ci)

    rec((0, 0, 0), tuple(int(v) for v in n))
    return leaves, len(cache)


def test_level_by_level_equals_depth_first_recursion():
    # non-cubic box: the modification (split only axes above eps) changes the number of halvings per axis
    lo, hi, eps = [-0.6, -0.3, -0.45], [0.6, 0.3, 0.45], 0.05
    fn = lambda p: (np.linalg.norm((p - [0.05, 0.02, 0.0]) / [0.5, 0.25, 0.35], axis=1) <= 1.0)
    ref_leaves, ref_evals = _depth_first(fn, lo, hi, eps)
    res = octree_boundary(fn, lo, hi, eps, min_level=1, closure=False)
    assert res.levels.tolist() == [5, 4, 5]  # 1.2/32, 0.6/16, 0.9/32 <= 0.05
    assert {tuple(v) for v in res.leaf_index.tolist()} == ref_leaves
    # the reference never evaluates the 8 corners of the whole box (level 0 is split without looking at it)
    assert res.evaluations == ref_evals


def test_torus_closed_surface_divergence_vs_unsigned_sum():
    # a torus is not star-shaped about its centre (which lies in the hole): the unsigned eq. 4.14 sum counts the
    # tetrahedra of the inner wall with the wrong sign, the signed sum (divergence theorem) does not
    R, r = 0.35, 0.12
    c = np.array([0.011, -0.007, 0.013])

    def torus(p):
        q = p - c
        return (np.hypot(q[:, 0], q[:, 1]) - R) ** 2 + q[:, 2] ** 2 <= r * r

    res = octree_boundary(torus, [-0.6] * 3, [0.6] * 3, 0.0125)
    exact = 2 * np.pi**2 * R * r * r
    # unsigned sum about the centre in closed form: (1/3) * surface integral of |p.n| = (2 pi r / 3) *
    # integral over phi of |R cos(phi) + r| (R + r cos(phi)) (torus parametrisation, p.n = R cos(phi) + r)
    phi = np.linspace(0, 2 * np.pi, 200_001)
    unsigned = 2 * np.pi * r / 3 * np.trapezoid(np.abs(R * np.cos(phi) + r) * (R + r * np.cos(phi)), phi)
    rep = workspace_volume(res, ("surface_nets", "divergence", "tetrahedron"))
    mesh = rep.crossing_mesh
    assert mesh.is_closed() and rep.centroid_mesh.is_closed()
    assert abs(rep.volumes["surface_nets"] / exact - 1) < 0.01  # unbiased mid-points, h/r = 0.08
    # same mesh, unsigned about the centre; 5 %: the facet normals of a voxel-based mesh scatter about the surface
    # normal, which adds |p.n| where p.n changes sign (|phi| near 110 deg)
    assert abs(tetrahedron_volume(mesh, z=c) / unsigned - 1) < 0.05
    assert unsigned > 1.4 * exact
    assert rep.volumes["divergence"] < exact  # centroid mesh: from below


def test_pyramid_method_follows_eq_4_6():
    res = octree_boundary(sphere, *BOX, 0.05)
    s = res.boundary_points
    z = np.array([0.1, 0.0, 0.0])
    expected = sum(np.linalg.norm(z - p) for p in s) * (res.spacing.sum() / 3) ** 2 / 3
    assert pyramid_volume(res, z) == pytest.approx(expected, rel=1e-12)


def test_tetrahedron_volume_of_a_unit_cube_mesh():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    t = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5],
                  [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])
    from pkmstiff.workspace.surface import BoundarySurface

    mesh = BoundarySurface(v, t, "test")
    assert mesh.is_closed()
    assert mesh.signed_volume() == pytest.approx(1.0, abs=1e-15)
    assert tetrahedron_volume(mesh, z=[0.3, 0.6, 0.2]) == pytest.approx(1.0, abs=1e-15)


def test_workspace_touching_the_box_is_reported_and_closed():
    res = octree_boundary(lambda p: p[:, 0] <= 0.2, [-0.5] * 3, [0.5] * 3, 0.05)
    assert res.touches_box
    mesh = boundary_surface(res)
    assert mesh.is_closed()  # capped by virtual inadmissible corners outside the box
    # cut slab: x in [-0.5, 0.2] (box faces exact, x = 0.2 estimated by mid-points within h/2)
    assert mesh.signed_volume() == pytest.approx(0.7, abs=0.5 * res.spacing[0])


def test_stl_and_vtk_round_trip(tmp_path, bodies_6mm):
    import pyvista as pv

    mesh = bodies_6mm["sphere"][1].crossing_mesh
    for name in ("ws.stl", "ws.vtp"):
        back = pv.read(str(mesh.save(tmp_path / name, scale=1e3)))
        assert back.n_cells == mesh.triangles.shape[0]
        assert np.allclose(back.bounds, np.ravel(np.column_stack([mesh.vertices.min(0), mesh.vertices.max(0)])) * 1e3,
                           atol=1e-3)  # float32 STL coordinates in mm


def test_bad_input_names_the_argument():
    with pytest.raises(ArgumentError, match="hi > lo"):
        octree_boundary(sphere, [0, 0, 0], [1, -1, 1], 0.1)
    with pytest.raises(ArgumentError, match="eps"):
        octree_boundary(sphere, [0, 0, 0], [1, 1, 1], -1.0)
    with pytest.raises(ArgumentError, match="shape"):
        octree_boundary(lambda p: np.ones(3, bool), [0, 0, 0], [1, 1, 1], 0.5)


def test_unique_inverse_matches_numpy_unique():
    from pkmstiff.workspace.octree import unique_inverse

    rng = np.random.default_rng(7)
    for keys in (rng.integers(0, 50, 1000), np.arange(10)[::-1].copy(), np.empty(0, np.int64)):
        keys = keys.astype(np.int64)
        u, inv = unique_inverse(keys)
        u_ref, inv_ref = np.unique(keys, return_inverse=True)
        assert np.array_equal(u, u_ref) and np.array_equal(inv, inv_ref.ravel())


def test_boundary_points_are_the_centroids_of_the_admissible_corners():
    res = octree_boundary(lambda p: np.linalg.norm(p, axis=1) < 0.7, (-1, -1, -1), (1, 1, 1), 0.1)
    c = res.leaf_corners
    ref = res.lo + (res.leaf_index + (c[:, :, None] * CORNER_OFFSETS[None]).sum(1) / c.sum(1, keepdims=True)) \
        * res.spacing
    assert np.array_equal(res.boundary_points, ref)  # small integer sums over a count: exact in any order


def test_every_leaf_corner_is_the_predicates_value_and_the_closure_evaluates_each_point_once():
    """The closure adds voxels whose corners come partly from leaves (known) and partly from new evaluations, each
    distinct point looked up once per pass: every leaf's corner flags, the closure's included, are the predicate's
    value at that corner, and the closure evaluates no point twice (the slotted sphere needs a closure; a point of a
    voxel discarded during the refinement may be evaluated again by the closure, which knows only the leaves)."""
    seen: list[np.ndarray] = []

    def body(p):
        seen.append(np.round((p - BOX[0]) / 0.025).astype(np.int64))
        return _slotted_sphere(p)

    res = octree_boundary(body, *BOX, 0.025)
    assert res.closure_voxels > 0
    corners = res.leaf_index[:, None, :] + CORNER_OFFSETS[None]  # (M, 8, 3) lattice indices
    truth = _slotted_sphere(res.lo + corners.reshape(-1, 3) * res.spacing).reshape(-1, 8)
    assert np.array_equal(res.leaf_corners, truth)
    points = np.concatenate(seen)
    assert points.shape[0] == res.evaluations
    closure = points[points.shape[0] - dict(res.evaluations_per_level)[-1]:]  # its passes come last
    assert closure.shape[0] > 0 and np.unique(closure, axis=0).shape[0] == closure.shape[0]


@pytest.mark.parametrize("n_slices", [2, 3, 7])
def test_refining_slices_separately_gives_the_same_leaves(n_slices):
    """The design that lets workers refine subtrees (docs/user-guide/parallel.md): contiguous slices of a level's
    boundary voxels, refined to the finest level each with its own evaluator and joined in slice order, give the
    octree's leaves in the same order, the same inside volume (per-level counts summed level by level, bit for bit)
    and the same evaluations per level once the points evaluated by two slices are counted once (by key)."""
    from pkmstiff.workspace import octree as O

    def body(p):  # a sphere with a thin slot: voxels of several levels are discarded on both sides
        return sphere(p) & ~((np.abs(p[:, 2] - CENTRE[2]) < 0.03) & (np.linalg.norm(p - CENTRE, axis=1) > 0.2))

    lo, hi, eps = BOX[0], BOX[1], 0.0125
    ref = octree_boundary(body, lo, hi, eps, closure=False)
    levels = levels_for(lo, hi, eps)
    lat = O.Lattice(lo, hi, levels)

    class KeyedEvaluator(O._Evaluator):  # also records the keys it evaluated
        def __call__(self, idx):
            self.keys.append(lat.key(idx))
            return super().__call__(idx)

    l0 = 4  # split the work below the start level (3) so both levels' voxels come from the serial path
    # the same octree stopped at level l0 (the box's edges are 2**k times eps: its lattice points are the same)
    pre = octree_boundary(body, lo, hi, float(hi[0] - lo[0]) / 2 ** l0, closure=False)
    start = [l for l, _ in ref.evaluations_per_level]
    assert start[0] == 3 and l0 in start
    # the boundary voxels of level l0 of the full octree with their corners (the leaves of a level-l0 octree)
    size = 1 << (levels - l0)
    vox, corners = pre.leaf_index * size, pre.leaf_corners
    parts, keys = [], []
    for v, c in zip(np.array_split(vox, n_slices), np.array_split(corners, n_slices)):
        ev = KeyedEvaluator(body, lat)
        ev.keys = []
        parts.append(O._refine(v, c, l0, levels, lat, ev, []))
        keys.append(np.concatenate(ev.keys))
    assert np.array_equal(np.concatenate([p[0] for p in parts]), ref.leaf_index)
    assert np.array_equal(np.concatenate([p[1] for p in parts]), ref.leaf_corners)
    inside = [sum(p[2][level] for p in parts) for level in range(int(levels.max()) + 1)]
    inside[:l0 + 1] = [0] * (l0 + 1)
    volume = pre.inside_volume
    for level, count in enumerate(inside[l0 + 1:], l0 + 1):
        volume += float(count) * float(np.prod((1 << (levels - level)) * lat.h))
    assert volume == ref.inside_volume  # bit for bit: the same products summed in the same order
    evaluated = np.concatenate(keys)
    assert O.unique_sorted(evaluated).size == ref.evaluations - pre.evaluations
    assert evaluated.size > ref.evaluations - pre.evaluations  # slices share points on their common faces


class _InProcessSubtrees:
    """A :class:`~pkmstiff.workspace.octree.SubtreeRunner` that refines the slices here, one after the other, and
    counts every evaluation of the body (the octree's own and the subtrees'), less those taken out (``uncount``)."""

    def __init__(self, body, n_slices: int, level: int):
        self.body, self.n_slices, self.level = body, n_slices, level
        self.points = 0

    def __call__(self, p):  # the octree's own predicate
        self.points += len(p)
        return self.body(p)

    def counted(self, p):
        self.points += len(p)
        return self.body(p), np.ones((len(p), 1), np.int64)

    def slices(self, level, voxels, evaluations):
        return self.n_slices if level == self.level else 0

    def bounds(self, voxels, n_slices):  # slices falling in size, as the workers get them
        from pkmstiff.evaluation.parallel import guided_bounds

        return guided_bounds(voxels, n_slices, 1)

    def run(self, tasks):
        from pkmstiff.workspace.octree import refine_subtree

        return [refine_subtree(t, self.counted) for t in tasks]

    def uncount(self, points, counts):
        assert counts.shape == (1,) and counts[0] == points  # one per point
        self.points -= points


def _slotted_sphere(p):  # a sphere with a thin slot: voxels of several levels are discarded on both sides
    return sphere(p) & ~((np.abs(p[:, 2] - CENTRE[2]) < 0.03) & (np.linalg.norm(p - CENTRE, axis=1) > 0.2))


def _thin_plates(p):  # two plates thinner than a level-5 voxel, one touching the box (virtual corners outside)
    return ((np.abs(p[:, 1] - 0.1) < 0.012) & (np.linalg.norm(p[:, [0, 2]], axis=1) < 0.6)) | (p[:, 0] > 0.77)


@pytest.mark.parametrize(("body", "eps", "level", "n_slices"), [
    (_slotted_sphere, 0.0125, 4, 2), (_slotted_sphere, 0.0125, 5, 7), (_slotted_sphere, 0.025, 3, 3),
    (_thin_plates, 0.0125, 4, 3), (_thin_plates, 0.0125, 5, 2), (sphere, 0.025, 4, 5)])
@pytest.mark.parametrize("least", [0, 40])
def test_subtrees_closing_their_own_leaves_ahead_give_the_serial_closure(body, eps, level, n_slices, least):
    """Subtrees refined apart also close their own leaves within the region no other slice holds (in the workers):
    the closure of all leaves then reads those points back. Leaves, their order, corners, evaluations per level (the
    closure's included) and the body's evaluations counted (points evaluated ahead but not needed, or by two slices,
    taken out) are those of the serial run, and most of the closure's points come from the subtrees, whether or not
    their closures stop before small passes (``least``)."""
    from pkmstiff.workspace import octree as O

    serial = _InProcessSubtrees(body, 0, -1)
    ref = octree_boundary(serial, *BOX, eps)
    here = []  # points the closure of all leaves evaluated itself
    ahead = O._AheadEvaluator._values
    runner = _InProcessSubtrees(body, n_slices, level)

    def values(self, idx):
        here.append(idx.shape[0] - int(np.isin(self.lat.key(idx), self.ahead.keys).sum()))
        return ahead(self, idx)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(O._AheadEvaluator, "_values", values)
        mp.setattr(O, "AHEAD_LEAST_POINTS", least)
        res = octree_boundary(runner, *BOX, eps, subtrees=runner)
    assert res.closure_voxels == ref.closure_voxels
    assert np.array_equal(res.leaf_index, ref.leaf_index) and np.array_equal(res.leaf_corners, ref.leaf_corners)
    assert res.evaluations_per_level == ref.evaluations_per_level and res.evaluations == ref.evaluations
    assert runner.points == serial.points == ref.evaluations
    assert res.inside_volume == ref.inside_volume and res.touches_box == ref.touches_box
    closure = dict(ref.evaluations_per_level)[-1]
    assert (closure > 0) == (body is not sphere)  # the slot and the plates leave sign changes to close
    assert sum(here) <= closure / 2  # most of the closure's points were evaluated ahead, in the subtrees


def test_key_table_finds_every_key_and_nothing_else_while_it_grows():
    from pkmstiff.workspace.kernels import KeyTable

    rng = np.random.default_rng(5)
    keys = rng.choice(10**9, 30_000, replace=False).astype(np.int64)
    table = KeyTable(keys[:1000])  # grows several times below
    for a in range(1000, keys.size, 7000):
        table.add(keys[a:a + 7000])
    assert np.array_equal(table.find(keys), np.arange(keys.size))  # value = order of addition
    absent = np.setdiff1d(rng.integers(-5, 10**9, 5000), keys)
    assert np.all(table.find(absent) == -1)
    assert np.all(table.find(np.array([-1, -2])) == -1)  # -1 marks an empty slot: a query of -1 is absent too


@pytest.mark.parametrize("origin", [(0.0, 0.0, 0.0), (0.3, -1.7, 0.05)])
def test_compiled_triangle_volumes_are_the_numpy_formula(origin):
    from pkmstiff.workspace.kernels import six_volumes

    rng = np.random.default_rng(2)
    v = rng.normal(size=(500, 3))
    t = rng.integers(0, 500, (2000, 3))
    o = np.array(origin)
    p1, p2, p3 = (v[t[:, k]] - o for k in range(3))  # the shifted vertices, as the kernel shifts them
    x = np.cross(p2, p3)
    # the kernel's order of the three products, bit for bit
    assert np.array_equal(six_volumes(v, t, o), (p1[:, 0] * x[:, 0] + p1[:, 2] * x[:, 2]) + p1[:, 1] * x[:, 1])
    # and einsum's value within rounding (its order of summation is numpy's choice, 1e-15 relative per term)
    assert np.allclose(six_volumes(v, t, o), np.einsum("ij,ij->i", p1, x), rtol=1e-12, atol=1e-12)


def test_compiled_distances_are_numpys_norm_bit_for_bit():
    from pkmstiff.workspace.kernels import distances

    rng = np.random.default_rng(3)
    p = rng.normal(size=(20_000, 3)) * rng.uniform(1e-3, 1e3, (20_000, 1))
    z = np.array([0.11, -0.2, 0.3])
    assert np.array_equal(distances(p, z), np.linalg.norm(p - z, axis=1))


def test_compiled_extent_is_numpys_min_and_max():
    from pkmstiff.workspace.kernels import extent, extent_centre

    p = np.random.default_rng(4).normal(size=(1001, 3))
    lo, hi = extent(p)
    assert np.array_equal(lo, p.min(axis=0)) and np.array_equal(hi, p.max(axis=0))  # exact: comparisons only
    assert np.array_equal(extent_centre(p), 0.5 * (p.min(axis=0) + p.max(axis=0)))


def test_compiled_mesh_kernels_are_the_numpy_formulas(monkeypatch):
    """Centroids (eq. 4.1), crossing vertices, owned edges and lattice keys: the numpy formulations they replaced, bit
    for bit (the same IEEE operations in the same order; no fastmath), on random voxels that also leave the box."""
    from pkmstiff.workspace import kernels, octree

    rng = np.random.default_rng(11)
    n = np.array([6, 5, 7])
    vox = rng.integers(-1, n + 1, (400, 3))  # -1 and n: voxels at and beyond the box faces
    corners = rng.random((400, 8)) < 0.5
    corners[~corners.any(axis=1), 0] = True  # a leaf has at least one admissible corner
    lo, h = np.array([-0.3, 0.1, -1.7]), np.array([0.013, 0.021, 0.0077])
    cnt = corners.astype(np.int64)
    offs = np.stack([cnt[:, CORNER_OFFSETS[:, k] == 1].sum(axis=1) for k in range(3)], axis=1) / cnt.sum(axis=1)[:, None]
    assert np.array_equal(kernels.corner_centroids(vox, corners, lo, h), lo + (vox + offs) * h)

    start, axis = vox, rng.integers(0, 3, 400)
    vid = rng.integers(0, 50, (400, 4))
    t = rng.random(400)
    inside = lambda i: np.all((i >= 0) & (i <= n), axis=-1)
    tt = np.where(~inside(start), 1.0, np.where(~inside(start + np.eye(3, dtype=np.int64)[axis]), 0.0, t))
    pt = start.astype(float)
    pt[np.arange(400), axis] += tt
    acc = np.stack([np.bincount(vid.ravel(), np.repeat(pt[:, k], 4), minlength=50) for k in range(3)], axis=1)
    num = np.bincount(vid.ravel(), minlength=50).astype(float)
    used = num > 0
    got = kernels.crossing_vertices(vid, start, axis, t, n, lo, h, 50)
    assert np.array_equal(got[used], (lo + acc / num[:, None] * h)[used])

    parts = [np.flatnonzero(corners[:, 0] != corners[:, 1 << a]) for a in range(3)]
    vi = np.concatenate(parts)
    for threads, least in ((1, 100_000), (3, 50)):  # parts of 133 voxels each on three threads: the same arrays
        monkeypatch.setattr(octree, "THREAD_LEAST_ITEMS", least)
        s, a, low = octree.owned_edges(vox, corners, threads)
        assert np.array_equal(s, vox[vi]) and np.array_equal(low, corners[vi, 0])
        assert np.array_equal(a, np.concatenate([np.full(p.size, k) for k, p in enumerate(parts)]))

    dims = n + 3
    i = vox + 1
    assert np.array_equal(kernels.lattice_keys(vox, dims), i[:, 0] + dims[0] * (i[:, 1] + dims[1] * i[:, 2]))


def test_compiled_touches_box_is_the_numpy_formula():
    """An admissible corner on a face of the box and inside it: the numpy formulation it replaced, on random voxels at
    and beyond the faces (each voxel alone, so every voxel's answer is checked)."""
    from pkmstiff.workspace import kernels

    rng = np.random.default_rng(12)
    n = np.array([6, 5, 7])
    vox = rng.integers(-1, n + 1, (600, 3))
    corners = rng.random((600, 8)) < 0.3

    def numpy_touches(v, c):
        idx = v[:, None, :] + CORNER_OFFSETS[None]
        on_face = np.any((idx == 0) | (idx == n), axis=-1) & np.all((idx >= 0) & (idx <= n), axis=-1)
        return bool(np.any(on_face & c))

    got = [kernels.touches_box(vox[i:i + 1], corners[i:i + 1], n) for i in range(600)]
    want = [numpy_touches(vox[i:i + 1], corners[i:i + 1]) for i in range(600)]
    assert got == want and 0 < sum(want) < 600  # both answers occur
    assert kernels.touches_box(vox, corners, n) == numpy_touches(vox, corners)


def test_volumes_and_meshes_on_two_threads_are_those_of_one(monkeypatch):
    """A parallel run's mesh look-ups (edges split over threads) and volumes (the two meshes at once) give the same
    bits as one thread: each kernel computes every element alone, the parts are joined in order."""
    from pkmstiff.workspace import octree as O

    monkeypatch.setattr(O, "THREAD_LEAST_ITEMS", 100)  # split even this small result
    one = octree_boundary(_slotted_sphere, *BOX, 0.025)
    two = octree_boundary(_slotted_sphere, *BOX, 0.025, threads=2)  # the closure's edges and box test too
    assert two.threads == 2 and two.touches_box == one.touches_box
    assert all(np.array_equal(x, y) for x, y in zip(one.edges, two.edges))
    a, b = workspace_volume(one), workspace_volume(two)
    assert len(O.in_threads(lambda s, e: (s, e), two.sign_change_edges()[0].shape[0], 2)) == 2
    assert a.volumes == b.volumes and list(b.volumes) == list(a.volumes)
    for m, n in ((a.crossing_mesh, b.crossing_mesh), (a.centroid_mesh, b.centroid_mesh)):
        assert np.array_equal(m.vertices, n.vertices) and np.array_equal(m.triangles, n.triangles)
    assert np.array_equal(one.edge_rings, two.edge_rings)


def test_compiled_shared_face_test_is_the_numpy_formula():
    """Points in a closed coarse voxel of another slice: the numpy formulation it replaced (the up to eight coarse
    voxels touching each point looked up among the slices' sorted voxel keys), on random points of a lattice whose
    coarse voxels belong to three slices or none."""
    from pkmstiff.workspace import kernels
    from pkmstiff.workspace.octree import KeyTable, Lattice

    rng = np.random.default_rng(13)
    lat = Lattice(np.zeros(3), np.ones(3), np.array([5, 4, 5]))
    size = np.array([4, 2, 4])
    cells = lat.n // size
    coarse = np.stack(np.meshgrid(*[np.arange(c) for c in cells], indexing="ij"), -1).reshape(-1, 3)
    coarse = coarse[rng.random(len(coarse)) < 0.6]
    keys = lat.key(coarse * size)
    order = np.argsort(keys)
    keys, owner = keys[order], rng.integers(0, 3, len(keys))
    idx = np.concatenate([rng.integers(0, lat.n + 1, (3000, 3)),
                          rng.integers(0, cells + 1, (3000, 3)) * size])  # many on coarse faces and edges

    def numpy_other(me):
        q, r = np.divmod(idx, size)
        on = (r == 0).astype(np.int64)
        other = np.zeros(len(idx), bool)
        for o in CORNER_OFFSETS:
            qq = q - o * on
            valid = np.all((qq >= 0) & (qq < cells), axis=1)
            ck = lat.key(qq * size)
            pos = np.minimum(np.searchsorted(keys, ck), keys.size - 1)
            s = np.where(valid & (keys[pos] == ck), owner[pos], -1)
            other |= (s >= 0) & (s != me)
        return other & (r == 0).any(axis=1)

    table = KeyTable(np.empty(0, np.int64), capacity=keys.size)
    table.add(keys, owner)
    for me in range(3):
        got = kernels.on_other_slice(idx, size, cells, lat.dims, table.slots, table.shift, me)
        want = numpy_other(me)
        assert np.array_equal(got, want) and 0 < want.sum() < len(idx)
