"""Parameter identification on the base parameters (Szatmári §4.6, eq. 4.11–4.12; Denkena §1.3, Gl. 25–30).

The model: the nominal controller commands the drive values u of the plan's poses; the real machine (errors Δp)
reaches the pose FK_Δp(u) and the instrument reads y(Δp) (:func:`~pkmstiff.calibration.measurement.simulate_readings`).
Identification finds Δp with y(Δp) ≈ y_measured.

* **Parameters**: only the base parameters of the plan (pivoted QR of the scaled Jacobian,
  :mod:`.identifiability`) are estimated; every other parameter is held at its start value (zero). This fixes the
  gauge freedoms (directions no reading sees); they are named in the result (:attr:`Identification.gauge_freedoms`).
* **Scaling** (stated in every result, :data:`SCALING`): unknowns are x = Δp_b / scale_b (scale: 1 mm, 1 mrad,
  :mod:`.parameters`); residual rows are in m, orientation rows of the pose instrument weighted by the platform
  joint radius (:attr:`IdentificationJacobian.row_scale`).
* **Methods**: ``gauss-newton`` (Denkena Gl. 28–30: x ← x + J⁺ r), ``lm`` (Levenberg–Marquardt,
  ``scipy.optimize.least_squares(method="lm")``), ``minimax`` (Szatmári eq. 4.12: min max_i |r_i|, by sequential
  linear programming with a trust region, started from the least-squares solution), ``ga+lm`` (Szatmári's global
  stage: ``scipy.optimize.differential_evolution`` on the linearised least-squares cost within ±``bounds`` scales,
  followed by a Levenberg–Marquardt polish on the full model).
* **Robust loss** (``loss`` other than ``"linear"``): ``least_squares(method="trf", loss=...)`` with ``f_scale``
  2.5 × the MAD-based noise estimate of the least-squares residuals (``lm`` does not support robust losses).
* **Robust weights** (``robust`` = ``huber`` or ``tukey``; issue 26 item 5): iteratively reweighted least squares
  (IRLS) from the least-squares solution: scale ŝ = 1.4826 · MAD of the residuals, u = r/ŝ, weight ψ(u)/u (Huber,
  c = 1.345; Tukey's biweight, c = 4.685: 95 % efficiency at the normal distribution), each weighted problem
  solved by Levenberg–Marquardt, until the weights settle; σ then follows Huber's sandwich covariance
  (:func:`robust_covariance`), not s²(JᵀJ)⁻¹ of the down-weighted fit.
* **Outliers**: readings whose residual exceeds ``outlier_threshold`` × s (s² = ‖r‖²/(m − rank)) are listed.

The Jacobian at an estimate is the analytic identification Jacobian of the *perturbed* machine at the *reached*
poses (:func:`jacobian_at`), exact for pod chains and ball-bar/tracker readings; first-order for guide tilts and
orientation readings, which only slows Gauss–Newton, not its fixed point in the noise-free case.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import differential_evolution, least_squares, linprog

from pkmstiff.calibration.backlash import has_backlash, held_signs, plan_run_starts
from pkmstiff.calibration.identifiability import GaugeFreedom, Identifiability, identifiability
from pkmstiff.calibration.instruments import Setup
from pkmstiff.calibration.jacobian import identification_jacobian, reading_weights
from pkmstiff.calibration.measurement import commanded_drives, reached_poses, simulate_readings
from pkmstiff.calibration.parameters import ParameterSet
from pkmstiff.calibration.perturb import perturbed_machine, perturbed_state
from pkmstiff.calibration.plans import Plan
from pkmstiff.errors import InputError, NumericalError, PkmstiffError
from pkmstiff.machine import Machine

METHODS = ("lm", "gauss-newton", "minimax", "ga+lm")
LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")
#: IRLS weight functions of ``robust`` and their tuning constants c (95 % efficiency at the normal distribution:
#: Huber 1981 §7; Beaton & Tukey 1974)
ROBUST = {"huber": 1.345, "tukey": 4.685}
#: IRLS stops when no weight changes by more than this (or after :data:`ROBUST_ITERATIONS`)
ROBUST_TOL = 1e-6
ROBUST_ITERATIONS = 30

#: how unknowns and residuals are scaled (written into every result)
SCALING = ("unknowns x = delta_p / scale (scale 1 mm for lengths, 1 mrad for angles); residual rows in m, "
           "orientation rows weighted by the mean platform-joint radius")


@dataclass
class Identification:
    """Result of :func:`identify` (SI throughout; see the module docstring for the model and scaling).

    ``delta`` (n,) all parameters (non-base ones at their start values); ``base`` indices of the estimated
    parameters; ``residual_before``/``residual_after`` (m,) weighted residuals y_meas − y_model in m at the
    start and at the solution; ``J`` (m, n_base) weighted Jacobian of the model readings with respect to the
    base parameters (SI) at the solution.
    """

    machine: Machine
    params: ParameterSet
    plan: Plan
    method: str
    loss: str
    delta: np.ndarray
    base: np.ndarray
    rank: int
    condition_number: float
    gauge_freedoms: tuple[GaugeFreedom, ...]
    residual_before: np.ndarray
    residual_after: np.ndarray
    J: np.ndarray
    iterations: int
    outliers: list[dict] = field(default_factory=list)
    scaling: str = SCALING
    robust: str | None = None  # IRLS weight function ("huber", "tukey") or None (least squares)
    robust_weights: np.ndarray | None = None  # (m,) final IRLS weights in [0, 1]
    robust_scale: float | None = None  # ŝ (m), 1.4826 · MAD of the final residuals

    @property
    def base_names(self) -> tuple[str, ...]:
        return tuple(self.params.names[i] for i in self.base)

    @property
    def n_readings(self) -> int:
        return int(self.residual_after.size)

    def to_dict(self) -> dict:
        """JSON-ready summary; keys name their units."""
        names = self.base_names
        units = [self.params.units[i] for i in self.base]
        return {
            "machine": self.machine.name, "plan": self.plan.name, "instrument": self.plan.instrument.kind,
            "method": self.method, "loss": self.loss, "scaling": self.scaling, "iterations": self.iterations,
            "n_readings": self.n_readings, "n_parameters": self.params.n, "rank": self.rank,
            "condition_number": _num(self.condition_number),
            "gauge_freedoms": [g.label() for g in self.gauge_freedoms],
            "identified": [{"name": nm, "value_mm" if u == "m" else "value_mrad": float(self.delta[i]) * 1e3}
                           for nm, u, i in zip(names, units, self.base)],
            "residual_before": residual_stats(self.residual_before),
            "residual_after": residual_stats(self.residual_after),
            "outliers": self.outliers,
            **({} if self.robust is None else {"robust": self.robust, "robust_scale_um": self.robust_scale * 1e6,
                                               "down_weighted": int(np.sum(self.robust_weights < 0.5))}),
        }


def _num(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


@dataclass(frozen=True)
class ResidualStats:
    """RMS, largest absolute value, mean and standard deviation of residuals, all in m."""

    rms: float
    max_abs: float
    mean: float
    std: float

    @classmethod
    def of(cls, r: np.ndarray) -> ResidualStats:
        r = np.asarray(r, dtype=float)
        return cls(float(np.sqrt(np.mean(r ** 2))), float(np.max(np.abs(r))), float(np.mean(r)), float(np.std(r)))

    def to_dict(self) -> dict[str, float]:
        """The same in µm (keys ``rms_um``, ``max_abs_um``, ``mean_um``, ``std_um``)."""
        return {"rms_um": self.rms * 1e6, "max_abs_um": self.max_abs * 1e6, "mean_um": self.mean * 1e6,
                "std_um": self.std * 1e6}


def residual_stats(r: np.ndarray) -> dict[str, float]:
    """RMS, largest absolute, mean and standard deviation of residuals (m), in µm."""
    return ResidualStats.of(r).to_dict()


def setup_at(setup: Setup, params: ParameterSet, delta: np.ndarray) -> Setup:
    """The nominal set-up with the set-up errors of ``delta`` applied (target, fixed ball), for Jacobians."""
    st = perturbed_state(setup, params, delta)
    return Setup(setup.instrument, target=st.target, fixed_ball=st.fixed_ball, bar_length=setup.bar_length,
                 measuring_range=setup.measuring_range, placing_pose=setup.placing_pose)


def jacobian_at(machine: Machine, params: ParameterSet, plan: Plan, delta: np.ndarray) -> np.ndarray:
    """Identification Jacobian (m, n), unweighted, SI, at the error vector ``delta``: the perturbed machine at the
    poses it reaches for the plan's nominal drive values (see the module docstring)."""
    from pkmstiff.calibration.setups import PlanSet, actual_state, parts

    if isinstance(plan, PlanSet):
        J = np.zeros((plan.n_readings, params.n))
        k = plan.instrument.n_readings
        for part, sub, idx, rows in parts(plan, params):
            J[rows.start * k:rows.stop * k, idx] = jacobian_at(machine, sub, part, delta[idx])
        return J
    if not np.any(delta):
        return identification_jacobian(machine, params, plan).J
    starts = plan_run_starts(plan)
    x = plan.poses if not np.any(delta[params.chain >= 0]) else reached_poses(machine, params, delta, plan.poses,
                                                                             starts=starts)
    real = perturbed_machine(machine, params, delta)
    setup = setup_at(plan.setup, params, delta)
    if setup.placing_pose is not None:  # the ball where the machine put it, the pose it reached there
        xc = plan.setup.placing_pose[None, :]
        if np.any(delta[params.chain >= 0]):
            xc = reached_poses(machine, params, delta, xc)
        setup = dataclasses.replace(setup, fixed_ball=actual_state(machine, params, delta, plan.setup).fixed_ball,
                                    placing_pose=xc[0])
    signs = held_signs(commanded_drives(machine, plan.poses), starts) if has_backlash(params) else None
    return identification_jacobian(real, params, Plan(plan.name, setup, x), signs=signs).J


class _Model:
    """Weighted residual and Jacobian in the scaled base unknowns x (Δp_b = scale_b x)."""

    def __init__(self, machine: Machine, params: ParameterSet, plan: Plan, measured: np.ndarray, base: np.ndarray,
                 delta0: np.ndarray):
        self.machine, self.params, self.plan, self.base = machine, params, plan, base
        self.y = measured.reshape(-1)
        self.delta0 = delta0
        self.w = reading_weights(machine, plan.instrument, plan.n_poses)
        self.s = params.scale[base]
        self.n_eval = 0
        self.rw = np.ones(self.y.size)  # √(IRLS weights); 1 for least squares

    def plain_residual(self, x: np.ndarray) -> np.ndarray:
        """The residual without IRLS weights."""
        return self.w * (self.y - simulate_readings(self.machine, self.params, self.delta(x), self.plan).reshape(-1))

    def delta(self, x: np.ndarray) -> np.ndarray:
        d = self.delta0.copy()
        d[self.base] = self.delta0[self.base] + self.s * x
        return d

    def residual(self, x: np.ndarray) -> np.ndarray:
        self.n_eval += 1
        return self.rw * self.plain_residual(x)

    def jac(self, x: np.ndarray) -> np.ndarray:
        """∂residual/∂x = −W J_b S."""
        J = jacobian_at(self.machine, self.params, self.plan, self.delta(x))
        return -((self.rw * self.w)[:, None] * J[:, self.base]) * self.s[None, :]


def _check_measured(plan: Plan, measured: np.ndarray, source: str) -> np.ndarray:
    y = np.asarray(measured, dtype=float)
    k = plan.setup.n_readings
    if y.ndim == 1 and k == 1:
        y = y[:, None]
    if y.shape != (plan.n_poses, k):
        raise InputError(source, "readings", f"{plan.n_poses} x {k} readings (one row per pose of plan "
                                    f"'{plan.name}')", f"shape {y.shape}")
    if not np.all(np.isfinite(y)):
        raise InputError(source, "readings", "finite readings", "NaN or inf")
    return y


def _gauss_newton(model: _Model, x: np.ndarray, max_iter: int, tol: float) -> tuple[np.ndarray, int]:
    """Denkena Gl. 28–30: x ← x + argmin ‖r − J_r Δx‖ (r = residual, J_r = −∂r/∂x), until ‖Δx‖ ≤ tol (1 + ‖x‖)."""
    r = model.residual(x)
    cost = float(r @ r)
    for it in range(1, max_iter + 1):
        A = -model.jac(x)
        dx = np.linalg.lstsq(A, r, rcond=None)[0]
        x = x + dx
        r = model.residual(x)
        new = float(r @ r)
        small = np.linalg.norm(dx) <= 1e-6 * (1.0 + np.linalg.norm(x))
        # converged: a tiny step, or a small step that no longer lowers the cost (the forward kinematics'
        # 1e-13 m tolerance sets a floor of ~1e-10 scales for the step)
        if np.linalg.norm(dx) <= tol * (1.0 + np.linalg.norm(x)) or (small and new >= cost * (1 - 1e-9)):
            return x, it
        cost = new
    raise NumericalError(f"Gauss-Newton did not converge in {max_iter} iterations (last step "
                           f"{np.linalg.norm(dx):.3g} scales); try --method lm or ga+lm, or check that the "
                           "measurement belongs to this machine and plan")


def _lm(model: _Model, x: np.ndarray, tol: float, max_nfev: int) -> tuple[np.ndarray, int]:
    res = least_squares(model.residual, x, jac=model.jac, method="lm", xtol=tol, ftol=tol, gtol=tol,
                        max_nfev=max_nfev)
    if res.status <= 0:
        raise NumericalError(f"Levenberg-Marquardt did not converge ({res.message.strip()}); try --method ga+lm, "
                               "or check that the measurement belongs to this machine and plan")
    return res.x, int(res.nfev)


def _robust(model: _Model, x: np.ndarray, loss: str, f_scale: float | None, tol: float,
            max_nfev: int) -> tuple[np.ndarray, int]:
    if f_scale is None:
        r = model.residual(x)
        mad = 1.4826 * float(np.median(np.abs(r - np.median(r))))
        f_scale = 2.5 * mad if mad > 0 else 1e-6
    res = least_squares(model.residual, x, jac=model.jac, method="trf", loss=loss, f_scale=f_scale, xtol=tol,
                        ftol=tol, gtol=tol, max_nfev=max_nfev, x_scale=1.0)
    if res.status <= 0:
        raise NumericalError(f"robust identification (loss {loss}) did not converge ({res.message.strip()}); "
                               "try another --loss or a larger f_scale")
    return res.x, int(res.nfev)


def robust_scale(r: np.ndarray) -> float:
    """ŝ = 1.4826 · median |r − median r| (MAD; consistent for normal noise)."""
    return 1.4826 * float(np.median(np.abs(r - np.median(r))))


def robust_weights(u: np.ndarray, kind: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """IRLS weights w = ψ(u)/u, ψ(u) and ψ'(u) of the standardised residuals u = r/ŝ (:data:`ROBUST`): Huber
    ψ = clip(u, ±c); Tukey's biweight ψ = u (1 − (u/c)²)² for |u| < c, else 0."""
    c = ROBUST[kind]
    a = np.abs(u)
    if kind == "huber":
        inside = a <= c
        psi = np.clip(u, -c, c)
        return np.where(inside, 1.0, c / np.maximum(a, 1e-300)), psi, inside.astype(float)
    z = np.where(a < c, 1.0 - (u / c) ** 2, 0.0)
    return z ** 2, u * z ** 2, np.where(a < c, z * (1.0 - 5.0 * (u / c) ** 2), 0.0)


def robust_covariance(J: np.ndarray, r: np.ndarray, scale: float, kind: str) -> tuple[np.ndarray, float]:
    """Huber's covariance of an M-estimate (Huber 1981, Robust Statistics, §7.6; statsmodels' RLM "H1"):

        Σ = K² · [Σ ψ(u_i)² / (m − p)] / [(Σ ψ'(u_i) / m)²] · ŝ² (JᵀJ)⁻¹,   K = 1 + (p/m) var ψ' / (mean ψ')²,

    u = r/ŝ, J (m, p) the Jacobian without IRLS weights. Returns (Σ, s_eff) with s_eff the scale that replaces s
    in s²(JᵀJ)⁻¹ (for normal noise without outliers s_eff ≈ s)."""
    m, p = J.shape
    _, psi, dpsi = robust_weights(r / scale, kind)
    mean = float(np.mean(dpsi))
    if not mean > 0:
        from pkmstiff.errors import NumericalError
        raise NumericalError(f"robust identification ({kind}): no reading inside the weight function's core; "
                             "the residual scale is degenerate")
    K = 1.0 + p / m * float(np.var(dpsi)) / mean ** 2
    s_eff = scale * K * float(np.sqrt(np.sum(psi ** 2) / (m - p))) / mean
    _, sv, Vt = np.linalg.svd(J, full_matrices=False)
    Vs = Vt.T / sv[None, :]
    return s_eff ** 2 * (Vs @ Vs.T), s_eff


def irls(residual: Callable[[np.ndarray], np.ndarray], set_weights: Callable[[np.ndarray], None],
         solve: Callable[[np.ndarray], tuple[np.ndarray, int]], x: np.ndarray, kind: str
         ) -> tuple[np.ndarray, np.ndarray, float, int]:
    """Iteratively reweighted least squares (module docstring): ``residual(x)`` the plain residual,
    ``set_weights(√w)`` installs the row weights of the next ``solve(x) -> (x, evaluations)``. Starts from ``x``
    (the least-squares solution). Returns (x, weights, ŝ, evaluations)."""
    if kind not in ROBUST:
        raise InputError("--robust", "robust", f"one of {', '.join(ROBUST)}", kind)
    w = np.ones(residual(x).size)
    evals = 0
    for _ in range(ROBUST_ITERATIONS):
        r = residual(x)
        scale = robust_scale(r)
        if not scale > 0:
            break
        w_new = robust_weights(r / scale, kind)[0]
        if np.max(np.abs(w_new - w)) <= ROBUST_TOL:
            break
        w = w_new
        set_weights(np.sqrt(w))
        x, n = solve(x)
        evals += n
    r = residual(x)
    return x, w, robust_scale(r), evals


def _minimax(model: _Model, x: np.ndarray, max_iter: int = 30, radius: float = 0.1) -> tuple[np.ndarray, int]:
    """Szatmári eq. 4.12: min_x max_i |r_i(x)|, by sequential LP: min t s.t. −t ≤ r + A Δx ≤ t (A = ∂r/∂x),
    |Δx_j| ≤ ρ; a step is taken when it lowers the worst residual, else ρ is halved."""
    r = model.residual(x)
    worst = np.max(np.abs(r))
    n = x.size
    c = np.zeros(n + 1)
    c[-1] = 1.0
    it = 0
    A = model.jac(x)
    for it in range(1, max_iter + 1):
        if worst <= 1e-12:  # already at the forward kinematics' resolution: nothing left to minimise
            break
        one = np.ones((r.size, 1))
        An, rn = A / worst, r / worst  # LP in units of the current worst residual (well scaled for HiGHS)
        A_ub = np.vstack([np.hstack([An, -one]), np.hstack([-An, -one])])
        b_ub = np.concatenate([-rn, rn])
        bounds = [(-radius, radius)] * n + [(0, None)]
        lp = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs", options={"time_limit": 30.0})
        if lp.status != 0:
            raise NumericalError(f"minimax identification: the linear program failed ({lp.message}); try "
                                   "--method lm")
        dx = lp.x[:n]
        r_new = model.residual(x + dx)
        w_new = np.max(np.abs(r_new))
        if w_new < worst:
            x, r, worst = x + dx, r_new, w_new
            A = model.jac(x)
            if np.max(np.abs(dx)) < 0.5 * radius:
                radius = max(np.max(np.abs(dx)) * 2.0, 1e-12)
        else:
            radius *= 0.5
        if radius < 1e-10 or 1.0 - lp.x[-1] <= 1e-9:
            break
    return x, it


def _global(model: _Model, x0: np.ndarray, bounds: float, seed: int | None, maxiter: int) -> np.ndarray:
    """Global stage: differential evolution on the linearised cost ‖r0 − A0 x‖² within ±``bounds`` scales (the
    full model would need one forward kinematics per member and generation)."""
    r0 = model.residual(x0)
    A0 = model.jac(x0)

    def cost(X: np.ndarray) -> np.ndarray:  # X (n, S): the whole population at once
        R = r0[:, None] + A0 @ (X - x0[:, None])
        return np.einsum("ij,ij->j", R, R)

    n = x0.size
    de = differential_evolution(cost, [(x - bounds, x + bounds) for x in x0], seed=seed, maxiter=maxiter,
                                popsize=max(5, 60 // max(n, 1)), tol=1e-12, polish=False, vectorized=True,
                                updating="deferred", init="sobol")
    return de.x


def identify(machine: Machine, params: ParameterSet, plan: Plan, measured: np.ndarray, method: str = "lm", *,
             loss: str = "linear", f_scale: float | None = None, delta0: np.ndarray | None = None,
             base: np.ndarray | None = None, tol: float = 1e-12, max_iter: int = 50,
             outlier_threshold: float = 3.0, bounds: float = 5.0, seed: int | None = 0,
             de_maxiter: int = 200, source: str = "measurement",
             ident: Identifiability | None = None, robust: str | None = None) -> Identification:
    """Identify the base parameters of ``params`` from ``measured`` readings (N, k) of ``plan`` (SI) (Szatmári
    §4.6; see the module docstring). ``base`` (indices) overrides the base parameters of the identifiability
    analysis; ``delta0`` is the start (default zero), also the value of the parameters held fixed. ``ident`` is the
    identifiability of ``plan`` with ``params`` when already computed (it depends on neither the readings nor the
    start, so repeated identifications of one plan share it). ``robust`` (``huber``, ``tukey``) down-weights
    outliers by IRLS after the least-squares solution (module docstring)."""
    if method not in METHODS:
        raise InputError(source, "method", f"one of {', '.join(METHODS)}", method)
    if loss not in LOSSES:
        raise InputError(source, "loss", f"one of {', '.join(LOSSES)}", loss)
    if robust is not None and (robust not in ROBUST or loss != "linear" or method not in ("lm", "gauss-newton")):
        raise InputError(source, "robust", f"one of {', '.join(ROBUST)} with --loss linear and --method lm or "
                                           "gauss-newton", f"{robust} with --loss {loss}, --method {method}")
    y = _check_measured(plan, measured, source)
    ident = identifiability(machine, params, plan) if ident is None else ident
    b = np.array([params.index(nm) for nm in ident.base_parameters], dtype=int) if base is None else \
        np.asarray(base, dtype=int)
    m = y.size
    if m <= b.size:
        raise InputError(source, "readings", f"more than {b.size} readings (the rank of the plan) to "
                                    "identify and estimate the noise; measure more poses",
                                    f"{m} readings")
    d0 = np.zeros(params.n) if delta0 is None else params.check_vector(delta0, "start vector")
    model = _Model(machine, params, plan, y, b, d0)
    x0 = np.zeros(b.size)
    r_before = model.residual(x0)
    try:
        if loss != "linear":
            x, it = _lm(model, x0, tol, max_iter * (b.size + 1))
            x, it2 = _robust(model, x, loss, f_scale, tol, max_iter * (b.size + 1))
            it += it2
        elif method == "gauss-newton":
            x, it = _gauss_newton(model, x0, max_iter, tol)
        elif method == "lm":
            x, it = _lm(model, x0, tol, max_iter * (b.size + 1))
        elif method == "minimax":
            x, it = _lm(model, x0, tol, max_iter * (b.size + 1))
            x, it2 = _minimax(model, x)
            it += it2
        else:
            xg = _global(model, x0, bounds, seed, de_maxiter)
            x, it = _lm(model, xg, tol, max_iter * (b.size + 1))
        weights = scale = None
        if robust is not None:
            def set_weights(rw: np.ndarray) -> None:
                model.rw = rw

            x, weights, scale, it2 = irls(model.plain_residual, set_weights,
                                          lambda xs: _lm(model, xs, tol, max_iter * (b.size + 1)), x, robust)
            it += it2
            model.rw = np.ones(model.y.size)  # residuals and Jacobian of the result: without IRLS weights
    except NumericalError:  # the solver's own failure: its message says what to try
        raise
    except PkmstiffError as exc:
        raise NumericalError(f"identification failed at an estimate the model cannot evaluate ({exc}); the "
                               "measurement probably does not belong to this machine/plan, or try --method ga+lm"
                               ) from None
    delta = model.delta(x)
    r_after = model.residual(x)
    if not np.all(np.isfinite(x)) or np.max(np.abs(params.scale[b] * x)) > 0.1:
        raise NumericalError("identification diverged (a parameter error above 100 mm / 100 mrad); check that the "
                               "measurement belongs to this machine and plan, or try --method ga+lm")
    Jw = -model.jac(x) / model.s[None, :]
    sv = np.linalg.svd(Jw * model.s[None, :], compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    res = Identification(machine=machine, params=params, plan=plan, method=method, loss=loss, delta=delta, base=b,
                         rank=int(b.size), condition_number=cond, gauge_freedoms=ident.gauge_freedoms,
                         residual_before=r_before, residual_after=r_after, J=Jw, iterations=int(it), robust=robust,
                         robust_weights=weights, robust_scale=scale)
    res.outliers = outlier_report(res, outlier_threshold)
    return res


def noise_estimate(r: np.ndarray, rank: int) -> float:
    """s = sqrt(‖r‖² / (m − rank)) (m readings), the residual standard deviation."""
    dof = r.size - rank
    return float(np.sqrt(np.dot(r, r) / dof)) if dof > 0 else math.inf


def outlier_report(res: Identification, threshold: float = 3.0) -> list[dict]:
    """Readings whose residual exceeds ``threshold`` × s: pose (1-based), reading name, residual (µm), |r|/s."""
    r = res.residual_after
    s = noise_estimate(r, res.rank)
    if not np.isfinite(s) or s <= 0:
        return []
    names = res.plan.instrument.reading_names
    k = len(names)
    out = []
    for i in np.flatnonzero(np.abs(r) > threshold * s):
        out.append({"pose": int(i // k) + 1, "reading": names[i % k], "residual_um": float(r[i]) * 1e6,
                    "standardised": float(abs(r[i]) / s)})
    return out
