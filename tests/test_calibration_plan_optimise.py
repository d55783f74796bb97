"""Plan optimisation (issue 16 item 3): Armijo gradient method on a barrier-augmented objective, hemisphere nodes
(Szatmári eq. 4.8), pose sets (Denkena Gl. 90–92), Denkena's double pendulum; seeded and reproducible."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pkmstiff.calibration import Plan, Segment, check_plan, default_plan, error_model, read_plan
from pkmstiff.calibration.planning import (
    NODES_PER_TURN,
    HemisphereSpec,
    armijo_minimise,
    base_columns,
    default_node_count,
    default_schedule,
    optimise_hemisphere,
    optimise_pendulum,
    optimise_pose_set,
    pendulum_cond,
    plan_objective,
    start_nodes,
)
from pkmstiff.cli import main
from pkmstiff.errors import InadmissibleError
from pkmstiff.machine import load_machine


def test_armijo_with_a_barrier_stops_at_the_bound():
    # minimise (x − 2)² subject to x < 1 (log barrier, μ = 1e-4): the minimiser of (x−2)² − μ log(1 − x) is
    # 1 − μ / (2 (2 − x)) ≈ 1 − 5e-5; the optimiser gets within 1e-3 of it in 200 iterations
    x, fx, _ = armijo_minimise(lambda v: float((v[0] - 2.0) ** 2), np.array([0.0]),
                               barrier=lambda v: -np.log(1 - v[0]) if v[0] < 1 else np.inf, mu=1e-4,
                               step_max=0.5, max_iter=200)
    assert x[0] < 1 and x[0] == pytest.approx(1 - 5e-5, abs=1e-3)
    assert fx == pytest.approx(1.0, abs=3e-3)


def test_double_pendulum_multistart_finds_several_optima_in_the_reported_range():
    res = optimise_pendulum(starts=24, seed=0, max_iter=60)
    good = [o for o in res.distinct if 2.0 <= o.value <= 4.0]
    # Denkena Bild 1-11: four optima with cond₂ 2.23 … 3.23 and considerably different strategies
    assert len(good) >= 2
    # not only rotated/mirrored copies of one strategy (cond₂ is invariant to those): at least two different optimal
    # values in the reported range, 1 % apart (the distinctness tolerance of the optimiser's report)
    values = sorted(o.value for o in good)
    assert values[-1] > 1.01 * values[0], values
    wrap = [np.r_[np.angle(np.exp(1j * o.x[:4])), o.x[4:]] for o in good]
    assert min(np.linalg.norm(a - b) for i, a in enumerate(wrap) for b in wrap[:i]) > 0.05  # distinct strategies
    assert min(o.value for o in res.runs) < res.start_value  # the optimiser improves on its first start
    for o in res.distinct[:2]:
        assert pendulum_cond(o.x, np.array([1.0, 1.0])) == pytest.approx(o.value, rel=1e-12)


def _hemi(m, max_tilt):
    d = default_plan(m, "ballbar")
    side = 1.0 if m.tool.axis[2] <= 0 else -1.0
    return HemisphereSpec(d.setup, n=80, turns=2.0, side=side, max_tilt=max_tilt, max_torsion=max_tilt)


def test_felix_hemisphere_nodes_lower_the_largest_orthogonality_entry_reproducibly(felix):
    spec = _hemi(felix, np.radians(20))
    params = error_model(felix)
    nodes0 = start_nodes(4, np.radians(12), np.radians(3))
    a = optimise_hemisphere(felix, params, spec, nodes0, "orthogonality", starts=2, seed=3, max_iter=3)
    assert a.best.value < a.start_value  # eq. 4.8 objective lowered
    check_plan(felix, a.best_plan)  # stays admissible (raises otherwise)
    b = optimise_hemisphere(felix, params, spec, nodes0, "orthogonality", starts=2, seed=3, max_iter=3)
    assert np.array_equal(a.best.x, b.best.x) and a.best.value == b.best.value  # same seed, same plan


def test_hexaglide_hemisphere_nodes_lower_cond(hexaglide):
    spec = _hemi(hexaglide, np.radians(6))
    params = error_model(hexaglide)
    res = optimise_hemisphere(hexaglide, params, spec, start_nodes(4, np.radians(3), np.radians(1)), "cond",
                              starts=1, seed=0, max_iter=3)
    assert res.best.value < res.start_value
    check_plan(hexaglide, res.best_plan)


def test_pose_set_lowers_cond(felix):
    d = default_plan(felix, "tracker")
    plan0 = Plan("six", d.setup, d.poses[::5][:8], (Segment("six", 0, 8, "points"),))
    params = error_model(felix, setup=plan0.setup)
    res = optimise_pose_set(felix, params, plan0, "cond", starts=1, seed=0, max_iter=2)
    assert res.best.value < res.start_value
    assert plan_objective(felix, params, res.best_plan, "cond", None) > 0
    check_plan(felix, res.best_plan)


def test_plan_command_writes_a_plan_the_simulation_reads(tmp_path, capsys):
    out = tmp_path / "opt.toml"
    code = main(["calibrate", "plan", "felix", "--instrument", "ballbar", "--objective", "orthogonality",
                 "--nodes", "4", "--points", "60", "--turns", "1", "--starts", "1", "--iterations", "2",
                 "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 0 and "(start plan) ->" in text and "distinct optima" in text
    plan = read_plan(out)
    assert plan.n_poses == 60
    code = main(["calibrate", "simulate", "felix", "--plan", str(out), "--feed", "6000", "--out",
                 str(tmp_path / "m.csv")])
    assert code == 0


def test_plan_command_bad_input(tmp_path, capsys):
    code = main(["calibrate", "plan", "felix", "--instrument", "ballbar", "--nodes", "0", "--out",
                 str(tmp_path / "p.toml")])
    err = capsys.readouterr().err
    assert code == 2 and "--nodes" in err and err.count("\n") == 1
    # an unknown objective is an argparse usage error: one line, exit status 2 (no SystemExit from main)
    assert main(["calibrate", "plan", "felix", "--instrument", "ballbar", "--objective", "O9", "--out", "x.toml"]) == 2
    assert "--objective" in capsys.readouterr().err


def test_plan_command_for_a_tracker_pose_set(tmp_path, capsys):
    out = tmp_path / "t.toml"
    code = main(["calibrate", "plan", "felix", "--instrument", "tracker", "--objective", "cond", "--poses", "4",
                 "--starts", "1", "--iterations", "1", "--out", str(out), "--json"])
    import json
    rep = json.loads(capsys.readouterr().out)
    assert code == 0 and rep["best_cond"] <= rep["start_cond"]  # Armijo steps never increase Ω + μ b
    plan = read_plan(out)
    assert plan.n_poses == 4 and plan.instrument.kind == "tracker"


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), starts=st.integers(1, 4), mu=st.sampled_from([0.0, 1.0, 10.0]))
def test_multistart_never_returns_worse_than_its_start(seed, starts, mu):
    """Over random starts of a rugged objective with a strong barrier, every run and the best optimum are at most
    the start's Ω (issue 26 item 7). Without the guard in ``multistart`` the descent on Ω + μ b ends at a larger Ω
    in 72 of 100 starts at μ = 10 (3 of 100 at μ = 1), so this test fails."""
    from pkmstiff.calibration.planning import _distinct, multistart

    rng = np.random.default_rng(seed)
    x0 = rng.uniform(-2, 2, 3)

    def f(x):  # Rastrigin-like: many local minima
        return float(np.sum(x ** 2 - 2 * np.cos(3 * x)))

    def barrier(x):  # pulls towards the box edge at 3, away from the minimum of f
        s = 3.0 - np.abs(x)
        return -float(np.sum(np.log(s))) + float(np.sum((x - 2.5) ** 2)) if np.all(s > 0) else np.inf

    def sample(r):
        return r.uniform(-2.5, 2.5, 3)

    runs, f0 = multistart(f, x0, sample, starts, seed, barrier=barrier, mu=mu, max_iter=20)
    assert runs[0].value <= f0  # the run from the start
    assert all(o.value <= o.start_value for o in runs)
    assert _distinct(runs)[0].value <= f0


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), nodes=st.integers(1, 3), tilt=st.floats(0.2, 0.9))
def test_hemisphere_optimisation_is_never_worse_than_its_start_or_the_default_path(felix, seed, nodes, tilt):
    """Over random start nodes (issue 26 item 7): the best plan's criterion is at most the start's and at most the
    unoptimised default path's (on the same sampling and base parameters); when no optimum beats the default path,
    the default path is the best plan."""
    spec = _hemi(felix, np.radians(20))
    spec = HemisphereSpec(spec.setup, n=60, turns=1.0, side=spec.side, max_tilt=spec.max_tilt,
                          max_torsion=spec.max_torsion)
    params = error_model(felix)
    rng = np.random.default_rng(seed)
    nodes0 = np.c_[rng.uniform(0.1, 1.0, nodes) * tilt * spec.max_tilt, rng.uniform(0, 2 * np.pi, nodes),
                   rng.uniform(-0.2, 0.2, nodes) * spec.max_torsion]
    try:
        res = optimise_hemisphere(felix, params, spec, nodes0, "cond", starts=2, seed=seed, max_iter=2,
                                  reference=spec.default_path())
    except InadmissibleError:  # a random start outside the workspace: refused before any optimisation
        return
    best = res.reference_value if res.kept_reference else res.best.value
    assert best <= res.start_value and best <= res.reference_value
    cols = base_columns(felix, params, spec.default_path())
    assert plan_objective(felix, params, res.best_plan, "cond", cols) == pytest.approx(best, rel=1e-12)
    if res.kept_reference:
        assert np.array_equal(res.best_plan.poses, spec.default_path().poses)


def test_plan_command_compares_with_the_default_path(tmp_path, capsys):
    """Two nodes cannot beat the default orientation schedule on Felix (κ 1.4e8 start): the command says so, prints
    the start, default-path and final criterion, and writes the default path, which reads back to its poses."""
    import json

    out = tmp_path / "p.toml"
    code = main(["calibrate", "plan", "felix", "--instrument", "ballbar", "--objective", "cond", "--nodes", "2",
                 "--points", "60", "--turns", "1", "--starts", "1", "--iterations", "1", "--out", str(out), "--json"])
    rep = json.loads(capsys.readouterr().out)
    assert code == 0 and rep["kept_default_path"] and rep["nodes"] == 2
    assert rep["best_cond"] == rep["default_path_cond"] <= min(rep["start_cond"], rep["optimised_cond"])
    plan = read_plan(out)
    d = default_plan(load_machine("felix"), "ballbar")
    tilt, torsion = default_schedule(d, 1.0)
    spec = HemisphereSpec(d.setup, n=60, turns=1.0, side=1.0, tilt=tilt, torsion=torsion)
    assert np.allclose(plan.poses, spec.default_path().poses, rtol=0, atol=1e-12)  # written with 17 digits
    code = main(["calibrate", "plan", "felix", "--instrument", "ballbar", "--objective", "cond", "--nodes", "2",
                 "--points", "60", "--turns", "1", "--starts", "1", "--iterations", "1", "--out", str(out),
                 "--force"])
    text = capsys.readouterr().out
    assert code == 0 and "(start plan) ->" in text and "default path (unoptimised schedule) cond" in text
    assert "no optimum beats it, the default path is written" in text


def test_default_node_count_rule():
    assert default_node_count(4.0) == NODES_PER_TURN * 4 and default_node_count(0.5) == NODES_PER_TURN
