"""Measurement-plan optimisation (Szatmári §4.4.3, eq. 4.8; Denkena §1.4.5, Gl. 90–92).

One optimiser serves every case: the gradient method of Denkena §1.4.5 — central-difference gradient Δᵏ of the
objective (Gl. 91), a step whose length is found by Armijo backtracking from a largest step λ_max (Gl. 92), along
−H Δᵏ with a BFGS inverse-Hessian estimate H (H = I is the plain −Δᵏ of the paper; the quasi-Newton direction
converges in far fewer iterations in the narrow valleys of cond₂) on the barrier-augmented objective Ω̃ = Ω + μ b (b ≥ 0 a log barrier that keeps the free variables inside
their bounds, e.g. the base-point distance of Gl. 88 or the largest tilt); a trial point that is not admissible
(any App. B check, the instrument's range) is treated as outside the constraint set and the step is shortened.
Optima are local (Denkena §1.4.5): several seeded starts are run and the distinct optima reported.

Objectives over the scaled identification Jacobian restricted to the base-parameter columns chosen at the start
plan (kept fixed, so that every plan is judged on the same parameters): ``cond`` (σ_max/σ_min), ``orthogonality``
(Szatmári eq. 4.8: the largest off-diagonal entry of O, eq. 4.5; its central-difference gradient is that of the
active entry), ``O1``…``O5`` (maximised; minimised as −log O_i).

Hemisphere paths: the free variables are the orientation nodes (B, L, D) of :func:`~.plans.hemisphere_plan`;
pose sets: the positions (m) and tilt-and-torsion angles (rad) of every pose. Denkena's double pendulum
(:func:`optimise_pendulum`): the controls of the measurements and the base point z, objective cond₂ of Gl. 96.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from pkmstiff.admissibility import evaluate_poses
from pkmstiff.calibration import pendulum
from pkmstiff.calibration.identifiability import analyse, orthogonality_matrix
from pkmstiff.calibration.jacobian import identification_jacobian
from pkmstiff.calibration.parameters import ParameterSet
from pkmstiff.calibration.plans import Plan, Segment, check_plan, hemisphere_plan, poses_for_target, tilt_torsion_matrix
from pkmstiff.errors import InadmissibleError, InputError
from pkmstiff.machine import Machine

OBJECTIVES = ("cond", "orthogonality", "O1", "O2", "O3", "O4", "O5")
#: orientation nodes per turn of the hemisphere spiral when none are given (:func:`default_node_count`)
NODES_PER_TURN = 6


@dataclass
class Optimum:
    """One local optimum: variables, objective Ω (as defined for the objective, lower is better), iterations."""

    x: np.ndarray
    value: float
    start_value: float
    iterations: int
    start: int


@dataclass
class PlanOptimisation:
    """Result of a multi-start optimisation: every run's optimum, the distinct optima (best first), the start plan's
    objective and the best plan."""

    objective: str
    start_value: float
    runs: list[Optimum]
    distinct: list[Optimum]
    best_plan: Plan | None = None
    notes: list[str] = field(default_factory=list)
    reference_value: float | None = None  # Ω of the reference plan (the unoptimised default path), if given
    kept_reference: bool = False  # the reference was at least as good as every optimum: it is the best plan

    @property
    def best(self) -> Optimum:
        return self.distinct[0]


# ------------------------------------------------------------------------------------------------ optimiser


def armijo_minimise(f: Callable[[np.ndarray], float], x0: np.ndarray, *, barrier: Callable[[np.ndarray], float]
                    | None = None, feasible: Callable[[np.ndarray], bool] | None = None, mu: float = 1e-3,
                    step_max: float = 0.2, h: float = 1e-5, max_iter: int = 30, tol: float = 1e-9,
                    c1: float = 1e-4, quasi_newton: bool = True) -> tuple[np.ndarray, float, int]:
    """Descent method with Armijo backtracking on Ω̃ = Ω + μ b (Denkena Gl. 91–92): central-difference gradient,
    direction −H g with H a BFGS inverse-Hessian estimate (``quasi_newton``; H = I is Denkena's plain gradient
    method, much slower in the narrow valleys of cond₂), first trial step the full step but at most ``step_max``
    long (in the variables' units); ``feasible`` rejects trial points. Returns (x, Ω(x), iterations)."""
    b = barrier or (lambda x: 0.0)

    def F(x):
        bv = b(x)
        if not np.isfinite(bv):
            return np.inf
        return f(x) + mu * bv

    x = np.asarray(x0, dtype=float).copy()
    fx = F(x)
    n = x.size
    H = np.eye(n)  # inverse-Hessian estimate (BFGS); H = I gives Denkena's plain gradient direction
    it = 0

    def grad(x):
        g = np.empty_like(x)
        for k in range(n):  # central differences (Gl. 91)
            e = np.zeros_like(x)
            e[k] = h
            fp, fm = F(x + e), F(x - e)
            g[k] = (fp - fm) / (2 * h) if np.isfinite(fp) and np.isfinite(fm) else 0.0
        return g

    g = grad(x)
    for it in range(1, max_iter + 1):
        if not np.linalg.norm(g) > 0:
            break
        d = -H @ g if quasi_newton else -g
        if d @ g >= 0:  # not a descent direction: restart from the gradient
            H, d = np.eye(n), -g
        dn = np.linalg.norm(d)
        lam = min(1.0, step_max / dn)  # λ_max: a full (quasi-)Newton step, at most step_max long (Gl. 92)
        moved = False
        while lam * dn > 1e-12 * max(1.0, np.linalg.norm(x)):  # Armijo backtracking
            xt = x + lam * d
            if feasible is None or feasible(xt):
                ft = F(xt)
                if ft <= fx + c1 * lam * (g @ d):
                    moved = True
                    break
            lam *= 0.5
        if not moved:
            break
        g_new = grad(xt)
        sk, yk = xt - x, g_new - g
        if quasi_newton and sk @ yk > 1e-12 * np.linalg.norm(sk) * np.linalg.norm(yk):
            rho = 1.0 / (sk @ yk)
            V = np.eye(n) - rho * np.outer(sk, yk)
            H = V @ H @ V.T + rho * np.outer(sk, sk)
        done = abs(fx - ft) <= tol * max(1.0, abs(fx))
        x, fx, g = xt, ft, g_new
        if done:
            break
    return x, f(x), it


def _distinct(runs: list[Optimum], rtol: float = 1e-3, key: Callable[[np.ndarray], np.ndarray] | None = None,
              ktol: float = 0.05) -> list[Optimum]:
    """The distinct optima, best first: an optimum is new if its objective differs by more than ``rtol``
    (relative) from every kept one or, with ``key``, if its strategy ``key(x)`` differs from theirs by more than
    ``ktol`` (Denkena §1.5: optima of comparable condition but considerably different strategies)."""
    out: list[Optimum] = []
    for r in sorted(runs, key=lambda o: o.value):
        if not np.isfinite(r.value):
            continue
        if all(abs(r.value - o.value) > rtol * abs(o.value)
               or (key is not None and np.linalg.norm(key(r.x) - key(o.x)) > ktol) for o in out):
            out.append(r)
    return out


def multistart(f, x0: np.ndarray, sample: Callable[[np.random.Generator], np.ndarray], starts: int, seed: int,
               **kw) -> tuple[list[Optimum], float]:
    """Run :func:`armijo_minimise` from ``x0`` and ``starts − 1`` seeded random starts (``sample(rng)``; starts
    that ``kw['feasible']`` rejects are redrawn up to 20 times). Returns (runs, Ω(x0)).

    The start is kept: the descent runs on Ω + μ b, so its end point may have a larger Ω than where it began; a run
    that ends worse than its own start returns its start (0 iterations), so no run — and no best plan — is ever
    worse than ``x0``."""
    rng = np.random.default_rng(seed)
    feasible = kw.get("feasible")
    f0 = f(x0)
    runs = []
    for j in range(starts):
        xs = x0
        if j:
            for _ in range(20):
                xs = sample(rng)
                if feasible is None or feasible(xs):
                    break
            else:
                continue
        x, v, it = armijo_minimise(f, xs, **kw)
        fs = float(f(xs))
        if not v <= fs:  # worse than (or not comparable with) its start: keep the start
            x, v, it = np.asarray(xs, dtype=float).copy(), fs, 0
        runs.append(Optimum(x, float(v), fs, it, j))
    return runs, float(f0)


# --------------------------------------------------------------------------------------------- objectives


def _objective_of(Js: np.ndarray, objective: str) -> float:
    sv = np.linalg.svd(Js, compute_uv=False)
    if objective == "cond":
        return float(sv[0] / sv[-1]) if sv[-1] > 0 else np.inf
    if objective == "orthogonality":
        O = orthogonality_matrix(Js)
        iu = np.triu_indices(O.shape[0], 1)
        return float(O[iu].max())
    from pkmstiff.calibration.identifiability import observability_indices
    o = observability_indices(sv, Js.shape[0])[objective]
    return float(-np.log(o)) if o > 0 else np.inf


def plan_objective(machine: Machine, params: ParameterSet, plan: Plan, objective: str,
                   columns: np.ndarray | None = None) -> float:
    """Ω of a plan (module docstring); ``columns`` the parameter columns to judge (default: all)."""
    if objective not in OBJECTIVES:
        raise InputError("--objective", "objective", f"one of {', '.join(OBJECTIVES)}", objective)
    Js = identification_jacobian(machine, params, plan).scaled()
    if columns is not None:
        Js = Js[:, columns]
    return _objective_of(Js, objective)


def base_columns(machine: Machine, params: ParameterSet, plan: Plan) -> np.ndarray:
    """Indices of the base parameters (identifiable set) of ``plan``."""
    res = analyse(identification_jacobian(machine, params, plan), machine, plan.setup)
    return np.array([params.index(n) for n in res.base_parameters], dtype=int)


def objective_label(objective: str, value: float) -> float:
    """The user-facing figure of Ω: cond and the orthogonality entry as they are, O_i = exp(−Ω)."""
    return float(np.exp(-value)) if objective.startswith("O") else float(value)


# ------------------------------------------------------------------------------------ hemisphere nodes


@dataclass(frozen=True)
class HemisphereSpec:
    """The fixed part of a hemisphere plan whose orientation nodes are optimised; ``tilt``/``torsion`` the
    amplitudes of the default orientation schedule of :func:`~.plans.hemisphere_plan` (the plan without nodes,
    :meth:`default_path`)."""

    setup: object
    n: int = 240
    turns: float = 4.0
    polar: tuple[float, float] = (np.radians(10), np.radians(80))
    side: float = 1.0
    max_tilt: float = np.radians(25)
    max_torsion: float = np.radians(25)
    tilt: float = np.radians(20)
    torsion: float = np.radians(15)

    def plan(self, nodes: np.ndarray, name: str = "hemisphere") -> Plan:
        return hemisphere_plan(self.setup, n=self.n, turns=self.turns, polar=self.polar, side=self.side,
                               nodes=np.asarray(nodes).reshape(-1, 3), name=name)

    def default_path(self, name: str = "hemisphere, default orientation schedule") -> Plan:
        """The same path with the default orientation schedule (no nodes) of amplitudes ``tilt``, ``torsion``."""
        return hemisphere_plan(self.setup, n=self.n, turns=self.turns, polar=self.polar, side=self.side,
                               tilt=self.tilt, torsion=self.torsion, name=name)


def default_schedule(plan: Plan, side: float) -> tuple[float, float]:
    """(tilt, torsion) in rad of the default orientation schedule of the ball bar's default hemisphere ``plan``
    (:data:`~pkmstiff.calibration.instruments.ball_bar.DEFAULT_SCHEDULES`, the one that rebuilds its poses)."""
    from pkmstiff.calibration.instruments.ball_bar import DEFAULT_SCHEDULES

    for t, d in DEFAULT_SCHEDULES:
        p = hemisphere_plan(plan.setup, n=plan.n_poses, side=side, tilt=np.radians(t), torsion=np.radians(d))
        if np.allclose(p.poses, plan.poses, rtol=0.0, atol=1e-12):
            return float(np.radians(t)), float(np.radians(d))
    raise InputError(plan.name, "plan", "the default hemisphere plan of a ball bar", "another plan")


def default_node_count(turns: float) -> int:
    """Orientation nodes of a hemisphere path when none are given (the rule measured in
    docs/user-guide/calibration-simulation.md, "How many nodes")."""
    return NODES_PER_TURN * max(1, int(np.ceil(turns)))


def start_nodes(k: int, tilt: float, torsion: float) -> np.ndarray:
    """Start nodes (k, 3): tilt alternating tilt/2 and tilt, azimuth advancing by the golden angle, torsion
    alternating ±torsion/2 (Assumption: a spread start; the optimiser moves the nodes)."""
    j = np.arange(k)
    return np.c_[tilt * (0.75 + 0.25 * (-1.0) ** j), np.mod(j * np.radians(137.5), 2 * np.pi),
                 0.5 * torsion * (-1.0) ** j]


def _admissible(machine: Machine, plan: Plan) -> bool:
    try:
        check_plan(machine, plan)
    except InadmissibleError:
        return False
    return True


def optimise_hemisphere(machine: Machine, params: ParameterSet, spec: HemisphereSpec, nodes0: np.ndarray,
                        objective: str = "orthogonality", starts: int = 3, seed: int = 0, max_iter: int = 15,
                        step_max: float = np.radians(5), mu: float = 1e-6,
                        reference: Plan | None = None) -> PlanOptimisation:
    """Optimise the orientation nodes of a hemisphere path (Szatmári §4.4.3, eq. 4.8 for ``orthogonality``):
    bounds 0 ≤ B ≤ max_tilt, |D| ≤ max_torsion by a log barrier, admissibility of every pose by rejection.

    ``reference`` (e.g. :meth:`HemisphereSpec.default_path`, the unoptimised default path on the same sampling):
    judged on the same base-parameter columns; when no optimum beats it, it is the best plan
    (``kept_reference``), so the result is never worse than the reference either (issue 26 item 7)."""
    nodes0 = np.asarray(nodes0, float)
    plan0 = spec.plan(nodes0)
    if not _admissible(machine, plan0):
        check_plan(machine, plan0)  # raises the one-line reason
    if reference is not None and not _admissible(machine, reference):
        reference = None
    # the base parameters every plan is judged on: the reference's (the default path sees all it can), else the
    # start's (a start with few nodes may see fewer)
    cols = base_columns(machine, params, plan0 if reference is None else reference)

    def f(x):  # eq. 4.8 on the plain maximum: its central-difference gradient is that of the active entry
        return plan_objective(machine, params, spec.plan(x), objective, cols)

    def barrier(x):
        N = x.reshape(-1, 3)
        s = np.r_[N[:, 0], spec.max_tilt - N[:, 0], spec.max_torsion - np.abs(N[:, 2])]
        return -np.sum(np.log(s)) if np.all(s > 0) else np.inf

    def feasible(x):
        return np.isfinite(barrier(x)) and _admissible(machine, spec.plan(x))

    def sample(rng):
        k = len(nodes0)
        return np.c_[rng.uniform(0.2, 0.9, k) * spec.max_tilt, rng.uniform(0, 2 * np.pi, k),
                     rng.uniform(-0.5, 0.5, k) * spec.max_torsion].ravel()

    runs, f0 = multistart(f, nodes0.ravel(), sample, starts, seed, barrier=barrier, feasible=feasible,
                          step_max=step_max, max_iter=max_iter, h=1e-5, mu=mu)
    start_value = f0
    distinct = _distinct(runs, rtol=1e-6)  # entries of O near 1 differ in the 4th to 6th digit
    best = spec.plan(distinct[0].x, name=f"hemisphere, optimised nodes ({objective})")
    out = PlanOptimisation(objective, start_value, runs, distinct, best)
    if reference is not None:
        out.reference_value = plan_objective(machine, params, reference, objective, cols)
        if out.reference_value <= out.best.value:
            out.best_plan, out.kept_reference = reference, True
            out.notes.append(f"no optimum beats the reference plan '{reference.name}' ({objective} "
                             f"{objective_label(objective, out.reference_value):.6g} against "
                             f"{objective_label(objective, out.best.value):.6g}): the reference is kept")
    return out


# ------------------------------------------------------------------------------------------- pose sets


def _poses_of(x: np.ndarray, setup) -> np.ndarray:
    X = x.reshape(-1, 6)
    R = tilt_torsion_matrix(X[:, 3], X[:, 4], X[:, 5])
    return poses_for_target(X[:, :3], R, setup.target)


def optimise_pose_set(machine: Machine, params: ParameterSet, plan0: Plan, objective: str = "cond",
                      starts: int = 3, seed: int = 0, max_iter: int = 15, spread: float = 0.05,
                      max_tilt: float = np.radians(20), step_max: float = 0.01, mu: float = 1e-6) -> PlanOptimisation:
    """Optimise a 6-D pose set (tracker or pose instrument; Denkena Gl. 90–92 with cond₂): variables are the target
    positions (m) and tilt-and-torsion angles B, L, D (rad) of every pose; bound |B| ≤ ``max_tilt`` by a log
    barrier, admissibility by rejection. Random starts perturb the start plan's positions by ±``spread`` m."""
    from pkmstiff.calibration.instruments import target_points
    from pkmstiff.kinematics.rotation import cardan_matrix

    x = plan0.poses
    R = cardan_matrix(x[:, 3], x[:, 4], x[:, 5])
    P = target_points(plan0.setup.state(), x[:, :3], R)
    z = R[:, :, 2]
    B = np.arccos(np.clip(z[:, 2], -1, 1))
    L = np.arctan2(z[:, 1], z[:, 0])
    # D from R = R_z(L) R_y(B) R_z(D − L): the first column's angle after removing the tilt
    Rt = np.einsum("nji,njk->nik", tilt_torsion_matrix(B, L, L), R)
    D = L + np.arctan2(Rt[:, 1, 0], Rt[:, 0, 0])
    x0 = np.c_[P, B, L, D].ravel()

    def mk(xv, name="pose set"):
        return Plan(name, plan0.setup, _poses_of(xv, plan0.setup), (Segment(name, 0, len(P), "points"),))

    cols = base_columns(machine, params, plan0)

    def f(xv):
        return plan_objective(machine, params, mk(xv), objective, cols)

    def barrier(xv):
        Bv = xv.reshape(-1, 6)[:, 3]
        s = max_tilt - np.abs(Bv)
        return -np.sum(np.log(s)) if np.all(s > 0) else np.inf

    def feasible(xv):
        return np.isfinite(barrier(xv)) and bool(evaluate_poses(machine, mk(xv).poses).ok.all())

    def sample(rng):
        X = x0.reshape(-1, 6).copy()
        X[:, :3] += rng.uniform(-spread, spread, X[:, :3].shape)
        X[:, 3] = rng.uniform(0, 0.8, len(X)) * max_tilt
        X[:, 4] = rng.uniform(0, 2 * np.pi, len(X))
        return X.ravel()

    if not feasible(x0):
        check_plan(machine, plan0)
        raise InadmissibleError(f"plan '{plan0.name}': start pose set tilts beyond {np.degrees(max_tilt):g} deg")
    runs, f0 = multistart(f, x0, sample, starts, seed, barrier=barrier, feasible=feasible, step_max=step_max,
                          max_iter=max_iter, h=1e-6, mu=mu)
    distinct = _distinct(runs, rtol=1e-6)  # entries of O near 1 differ in the 4th to 6th digit
    return PlanOptimisation(objective, f0, runs, distinct, mk(distinct[0].x, f"pose set, optimised ({objective})"))


# ------------------------------------------------------------------------------------ double pendulum


def pendulum_cond(x: np.ndarray, p: np.ndarray) -> float:
    """cond₂ of Denkena's Gl. 96 for x = (φ1, φ2 of each measurement…, z_x, z_y)."""
    u = x[:-2].reshape(-1, 2)
    sv = np.linalg.svd(pendulum.extended_jacobian(x[-2:], p, u), compute_uv=False)
    return float(sv[0] / sv[-1]) if sv[-1] > 0 else np.inf


def optimise_pendulum(p: tuple[float, float] = (1.0, 1.0), measurements: int = 2, d_range: tuple[float, float]
                      = (0.5, 2.5), starts: int = 24, seed: int = 0, max_iter: int = 60,
                      eps: float = 0.05) -> PlanOptimisation:
    """Denkena §1.5: optimal controls (φ1, φ2) of ``measurements`` measurements and one base point z for cond₂ of
    the extended Jacobian (Gl. 96), with the base-point constraint d_min (1 − ε) < ‖z − x_i‖ < d_max (1 + ε)
    (Gl. 88) as a log barrier, seeded random starts (Bild 1-11 shows four different optima with cond₂ 2.2–3.2).
    Assumption: arm lengths ``p`` = (1, 1) m and the distance range ``d_range`` — not given in the paper.

    Distinct optima are distinct strategies (controls and base point, or values differing by 1 %). cond₂ is
    invariant under a rotation of the whole set-up about the pendulum's base and under a mirror image, so the
    best strategy found (cond₂ ≈ 2.36: one arm folded back, the other stretched, the base point at 1 m from both
    tips) appears several times, rotated; with the default 24 starts (seed 0) a second, different local optimum at
    cond₂ ≈ 3.73 is found too (a Nelder–Mead polish stays there), and other starts end near 5.4–5.8."""
    p = np.asarray(p, float)
    lo, hi = d_range[0] * (1 - eps), d_range[1] * (1 + eps)

    def dist(x):
        u = x[:-2].reshape(-1, 2)
        return np.linalg.norm(pendulum.forward(p, u)[:, :2] - x[-2:], axis=1)

    def barrier(x):
        d = dist(x)
        s = np.r_[d - lo, hi - d]
        return -np.sum(np.log(s)) if np.all(s > 0) else np.inf

    def sample(rng):
        while True:
            x = np.r_[rng.uniform(-np.pi, np.pi, 2 * measurements), rng.uniform(-2.0, 2.0, 2)]
            if np.isfinite(barrier(x)):
                return x

    rng0 = np.random.default_rng(seed)
    x0 = sample(rng0)
    runs, f0 = multistart(lambda x: pendulum_cond(x, p), x0, sample, starts, seed + 1, barrier=barrier,
                          step_max=0.5, max_iter=max_iter, h=1e-6, mu=1e-4)
    def strategy(x):  # controls wrapped to (−π, π], base point as it is
        return np.r_[np.angle(np.exp(1j * x[:-2])), x[-2:]]

    distinct = _distinct(runs, rtol=1e-2, key=strategy, ktol=0.05)
    return PlanOptimisation("cond", f0, runs, distinct)


__all__ = ("NODES_PER_TURN", "OBJECTIVES", "HemisphereSpec", "Optimum", "PlanOptimisation", "armijo_minimise",
           "base_columns", "default_node_count", "default_schedule", "multistart", "objective_label",
           "optimise_hemisphere", "optimise_pendulum", "optimise_pose_set", "pendulum_cond", "plan_objective",
           "plan_toml", "start_nodes")


# ------------------------------------------------------------------------------------------- plan files


def _num(v: float) -> str:
    return repr(float(v))


def _q(v: float, unit: str, scale: float) -> str:
    return f'"{float(v) / scale!r} {unit}"'


def plan_toml(plan: Plan, name: str, description: str = "", hemisphere: HemisphereSpec | None = None,
              nodes: np.ndarray | None = None) -> str:
    """A plan file :func:`~.plans.read_plan` reads back to the same poses: a hemisphere path with its orientation
    nodes (deg) or, without ``nodes``, with its default schedule (``tilt``, ``torsion``), or the poses (platform
    origin in mm, Cardan angles in deg, full precision)."""
    st = plan.setup
    lines = ["[plan]", f"name = {name!r}".replace("'", '"'), f'instrument = "{st.instrument.kind}"']
    if description:
        lines.append(f'description = "{description}"')
    lines += ["", "[setup]", "target = [" + ", ".join(_q(v, "mm", 1e-3) for v in st.target) + "]"]
    lines += st.instrument.setup_toml(st, _q)
    lines += ["", "[[paths]]"]
    if hemisphere is not None:
        h = hemisphere
        lines += ['kind = "hemisphere"', f"points = {h.n}", f"turns = {_num(h.turns)}",
                  f"polar_min = {_q(h.polar[0], 'deg', np.pi / 180)}",
                  f"polar_max = {_q(h.polar[1], 'deg', np.pi / 180)}", f"side = {_num(h.side)}"]
        lines += [f"tilt = {_q(h.tilt, 'deg', np.pi / 180)}", f"torsion = {_q(h.torsion, 'deg', np.pi / 180)}"] \
            if nodes is None else ["nodes = [" + ", ".join("[" + ", ".join(_q(v, "deg", np.pi / 180) for v in row)
                                                            + "]" for row in np.asarray(nodes).reshape(-1, 3)) + "]"]
    else:
        x = plan.poses
        lines += ['kind = "poses"',
                  "positions = [" + ", ".join("[" + ", ".join(_q(v, "mm", 1e-3) for v in r[:3]) + "]" for r in x)
                  + "]",
                  "angles = [" + ", ".join("[" + ", ".join(_q(v, "deg", np.pi / 180) for v in r[3:]) + "]"
                                           for r in x) + "]"]
    return "\n".join(lines) + "\n"
