"""Maximum rotation angles: predictor (eq. 4.21-4.24), predictor-corrector vs plain search (spec §7.6)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.errors import ArgumentError
from pkmstiff.workspace.rotation import SIX_DIRECTIONS, _prediction, rotation_angle_map, rotational_workspace_map

INC = math.radians(2.0)


@pytest.fixture(scope="module")
def yz_maps(hexaglide):
    # Y-Z plane at x = 0 through the working region below the guides (spec §7.2), 25 mm raster
    u = np.arange(-0.1, 0.9001, 0.05)
    v = np.arange(-1.2, -0.55, 0.05)
    kw = dict(origin=[0, 0, 0], u_axis=[0, 1, 0], v_axis=[0, 0, 1], u_values=u, v_values=v,
              base_orientation=(0, 0, 0), direction=SIX_DIRECTIONS, increment=INC)
    return {"plain": rotation_angle_map(hexaglide, **kw, method="plain"),
            "predictor_corrector": rotation_angle_map(hexaglide, **kw, method="predictor_corrector"),
            "verified": rotation_angle_map(hexaglide, **kw, method="predictor_corrector", verify=True)}


def _same(a, b):
    return np.array_equal(np.isnan(a), np.isnan(b)) and np.array_equal(a[~np.isnan(a)], b[~np.isnan(b)])


def test_verified_predictor_corrector_equals_plain_search(yz_maps):
    plain, pc = yz_maps["plain"], yz_maps["verified"]
    assert plain.base_ok.sum() > 50  # the plane cuts the workspace
    for d in SIX_DIRECTIONS:
        assert _same(pc.angles[d], plain.angles[d]), d
        assert np.nanmax(plain.angles[d]) >= 5 * INC  # non-trivial maps


def test_predictor_corrector_saves_evaluations(yz_maps):
    pc, plain = yz_maps["predictor_corrector"], yz_maps["plain"]
    total_pc = sum(pc.evaluations.values())
    total_seq = sum(plain.plain_sequential.values())
    assert total_pc < 0.5 * total_seq
    # the plain search's sequential count follows from its own results (k* + 1 per point beyond the base check)
    for d in SIX_DIRECTIONS:
        k = np.rint(plain.angles[d] / INC)
        lim = plain.at_limit[d]
        assert plain.plain_sequential[d] == int(np.nansum(np.where(lim, k, k + 1)))


def test_unverified_differences_are_inadmissible_gaps(yz_maps, hexaglide):
    # without verification the corrector may start above an inadmissible gap (spec caveat): wherever it differs
    # from the plain search, the plain result + 1 increment is inadmissible and the corrector's result admissible
    plain, pc = yz_maps["plain"], yz_maps["predictor_corrector"]
    for j, d in enumerate(SIX_DIRECTIONS):
        a, b = plain.angles[d], pc.angles[d]
        assert np.array_equal(np.isnan(a), np.isnan(b))
        diff = np.flatnonzero(~np.isnan(a) & (a != b))
        if diff.size == 0:
            continue
        assert np.all(b.ravel()[diff] > a.ravel()[diff])
        vec = np.zeros(6)
        vec[3:] = {"+a": (1, 0, 0), "-a": (-1, 0, 0), "+b": (0, 1, 0), "-b": (0, -1, 0), "+a+b": (1, 1, 0),
                   "-a-b": (-1, -1, 0)}[d]
        base = plain.base_poses.reshape(-1, 6)[diff]
        gap = evaluate_poses(hexaglide, base + (a.ravel()[diff] + INC)[:, None] * vec).ok
        top = evaluate_poses(hexaglide, base + b.ravel()[diff][:, None] * vec).ok
        assert not gap.any() and top.all()


def test_prediction_is_exact_for_a_linear_field():
    # eq. 4.22/4.23 extrapolate linearly, so a linear field is predicted exactly where two neighbours exist in
    # each direction; eq. 4.24 uses the direct neighbour; none: the base angle (0)
    u = np.array([0.0, 0.1, 0.25, 0.3, 0.5])
    v = np.array([-1.0, -0.8, -0.7, -0.4])
    f = (0.3 + 0.5 * u[None, :] - 0.2 * v[:, None])[:, :, None]
    m, n = np.array([2, 3, 0, 1, 0]), np.array([2, 4, 3, 1, 0])
    pred = _prediction(f.copy(), u, v, m, n)[:, 0]
    exact = f[m, n, 0]
    assert np.allclose(pred[:2], exact[:2], rtol=0, atol=1e-14)
    assert pred[2] == pytest.approx(exact[2])  # first row: linear in u, two u-neighbours
    # (1, 1): one neighbour each way -> mean of f(0, 1) and f(1, 0) (eq. 4.24, 4.21)
    assert pred[3] == pytest.approx(0.5 * (f[1, 0, 0] + f[0, 1, 0]))
    assert pred[4] == 0.0
    g = f.copy()
    g[2, 1, 0] = np.nan  # an unavailable (outside) u-neighbour: only the v direction predicts (eq. 4.23)
    p = _prediction(g, u, v, np.array([2]), np.array([2]))[0, 0]
    assert p == pytest.approx(f[2, 2, 0], abs=1e-14)


def test_rotational_workspace_maps_equal_plain(hexaglide):
    # rotational workspace at x = y = 0, z = -900 mm (Cobet Figs. 4.4, 4.5): +a over (b, c) and +b over (a, c)
    kw = dict(u_values=np.radians(np.arange(-20, 21, 5.0)), v_values=np.radians(np.arange(-40, 41, 10.0)),
              increment=INC)
    for d in ("+a", "+b"):
        pc = rotational_workspace_map(hexaglide, (0.0, 0.3, -0.9), d, verify=True, **kw)
        pl = rotational_workspace_map(hexaglide, (0.0, 0.3, -0.9), d, method="plain", **kw)
        assert _same(pc.angle, pl.angle)
        assert pc.base_ok.sum() > 5 and np.nanmax(pc.angle) > 2 * INC
        assert pc.settings["u_angle"] == ("b" if d == "+a" else "a") and pc.settings["v_angle"] == "c"


def test_bad_arguments(hexaglide):
    kw = dict(origin=[0, 0, 0], u_axis=[0, 1, 0], v_axis=[0, 0, 1], u_values=[0.0, 0.1], v_values=[-1.0, -0.9])
    with pytest.raises(ArgumentError, match="direction"):
        rotation_angle_map(hexaglide, **kw, direction="+x")
    with pytest.raises(ArgumentError, match="increment"):
        rotation_angle_map(hexaglide, **kw, increment=0.0)
    with pytest.raises(ArgumentError, match="u_values"):
        rotation_angle_map(hexaglide, **{**kw, "u_values": [0.1, 0.0]})
    with pytest.raises(ArgumentError, match="method"):
        rotation_angle_map(hexaglide, **kw, method="fast")


@pytest.mark.parametrize("lookahead", [2, 8])
def test_corrector_lookahead_changes_neither_angles_nor_counts(yz_maps, hexaglide, monkeypatch, lookahead):
    # several increments per batch when few searches are left: the one-at-a-time search's angles and evaluation
    # counts (the fixture's maps were made with the default lookahead; 1 is the one-at-a-time search itself)
    import pkmstiff.workspace.rotation as rot

    u, v = yz_maps["predictor_corrector"].u_values, yz_maps["predictor_corrector"].v_values
    kw = dict(origin=[0, 0, 0], u_axis=[0, 1, 0], v_axis=[0, 0, 1], u_values=u, v_values=v,
              base_orientation=(0, 0, 0), direction=SIX_DIRECTIONS, increment=INC, method="predictor_corrector")
    for lo, posed in ((1, 1), (lookahead, 10_000)):  # 10,000: look ahead in every batch
        monkeypatch.setattr(rot, "LOOKAHEAD", lo)
        monkeypatch.setattr(rot, "LOOKAHEAD_POSES", posed)
        for verify in (False, True):
            res = rotation_angle_map(hexaglide, **kw, verify=verify)
            ref = yz_maps["verified" if verify else "predictor_corrector"]
            for d in SIX_DIRECTIONS:
                assert _same(res.angles[d], ref.angles[d]), (lo, d)
            assert res.evaluations == ref.evaluations and res.verify_corrections == ref.verify_corrections


def test_search_evaluator_equals_the_staged_pipeline(hexaglide, monkeypatch):
    # the searches' evaluator (the fused kernel in chunks, FUSED_CHUNK = 7 here to cross chunk ends) gives the
    # admissibility of the staged pipeline pose for pose, with the checks subset and with a requirement (which
    # takes the staged pipeline itself)
    import pkmstiff.workspace.rotation as rot
    from pkmstiff.admissibility import fastpath
    from pkmstiff.admissibility.checks import ALL_CHECKS
    from pkmstiff.workspace.oracle import staged_admissible
    from pkmstiff.workspace.requirements import parse_requirements

    monkeypatch.setenv("PKMSTIFF_JIT", "1")  # the fused kernel runs only with the compiled kernels
    monkeypatch.setattr(fastpath, "FUSED_CHUNK", 7)
    m = hexaglide
    rng = np.random.default_rng(3)  # about half of these poses are admissible
    p = rng.uniform([-0.1, 0.0, -1.1, -0.2, -0.2, -0.2], [0.1, 0.9, -0.6, 0.2, 0.2, 0.2], size=(300, 6))
    for checks, reqs in ((ALL_CHECKS, []), (ALL_CHECKS[:3], []), (ALL_CHECKS, parse_requirements(["kappa < 50"]))):
        ok = rot._Evaluator(m, checks, reqs)(p)
        assert np.array_equal(ok, staged_admissible(m, p, checks, reqs))
        assert ok.any() and not ok.all()


def _numpy_steps(ev, pts, dvec, inc, K, active, up, cur, result, evals, lookahead, budget):
    """The corrector's batch as numpy array operations (the formulation the compiled one replaced)."""
    D = active.shape[1]
    at = np.flatnonzero(active)
    pi, di = np.divmod(at, D)
    A = at.size
    L = max(1, min(lookahead, budget // A))
    u, c = up.ravel()[at], cur.ravel()[at]
    sign = np.where(u, 1, -1)
    n = np.minimum(np.where(u, K - c, c - 1), L)
    r, col = np.nonzero(np.arange(1, L + 1)[None, :] <= n[:, None])
    ok = np.zeros((A, L), bool)
    ok[r, col] = ev(pts[pi[r]] + ((c[r] + sign[r] * (col + 1)) * inc)[:, None] * dvec[di[r]])
    j = np.arange(1, L + 1)
    stop = np.where((j[None, :] <= n[:, None]) & (ok != u[:, None]), j[None, :], L + 1).min(axis=1)
    stopped = stop <= n
    walked = np.where(stopped, stop, n)
    evals += np.bincount(di, walked, D).astype(np.int64)
    new = c + sign * walked
    res = np.where(u, np.where(stopped, new - 1, new), np.where(stopped, new, 0))
    done = stopped | np.where(u, new >= K, new <= 1)
    keep = u | done
    result.ravel()[at[keep]] = res[keep]
    cur.ravel()[at] = new
    active.ravel()[at[done]] = False


@pytest.mark.parametrize("budget", [1, 64, 4096])  # one increment per search, look-ahead on few, on all
def test_compiled_corrector_batch_is_the_numpy_formulation(monkeypatch, budget):
    """Random corrector states and a random admissibility field: the compiled batch evaluates the same poses (bit for
    bit, in the same order) and leaves the same state and counts as the numpy formulation."""
    from pkmstiff.workspace import rotation as R

    rng = np.random.default_rng(3)
    P, D, K, inc = 40, 3, 30, math.radians(1.0)
    pts, dvec = rng.normal(size=(P, 6)), rng.normal(size=(D, 6))
    field = {}

    def ev(poses):  # deterministic per pose, recording what it was asked
        seen.append(poses.copy())
        return np.array([field.setdefault(p.tobytes(), bool(rng.random() < 0.8)) for p in poses], bool)

    monkeypatch.setattr(R, "LOOKAHEAD_POSES", budget)
    up = rng.random((P, D)) < 0.6
    cur = np.where(up, rng.integers(0, K, (P, D)), rng.integers(1, K + 1, (P, D)))
    state = [rng.random((P, D)) < 0.7, up, cur, np.where(up, cur, -1), np.zeros(D, np.int64)]
    runs = []
    for fn in (lambda *a: R._steps(*a), lambda *a: _numpy_steps(*a, R.LOOKAHEAD, budget)):
        seen: list[np.ndarray] = []
        active, u, c, result, evals = (x.copy() for x in state)
        for _ in range(6):
            if active.any():
                fn(ev, pts, dvec, inc, K, active, u, c, result, evals)
        runs.append((np.concatenate(seen).tobytes(), active, c, result, evals))
    (p1, *s1), (p2, *s2) = runs
    assert p1 == p2
    assert all(np.array_equal(a, b) for a, b in zip(s1, s2))
