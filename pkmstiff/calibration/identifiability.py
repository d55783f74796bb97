"""Identifiability of the error parameters from a plan: numerical rank by the gap in the singular values, base
parameters by a fixed priority order (:func:`base_parameter_indices`), named gauge freedoms, condition number,
orthogonality matrix O and the observability indices O1–O5 (Szatmári §4.4.2, eq. 4.5–4.8; Denkena §1.4.3;
docs/theory/calibration.md).

All of it works on the scaled Jacobian J_s = W J D (W weights orientation rows by a length, D = diag(parameter
scales); :meth:`IdentificationJacobian.scaled`): rank and gauge freedoms do not depend on D (column scaling keeps
the null space up to the scaling), condition number and O1–O5 do, O does not (eq. 4.5 normalises columns).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pkmstiff.calibration.gauges import GaugeCandidate, gauge_candidates
from pkmstiff.calibration.instruments import Setup
from pkmstiff.calibration.jacobian import IdentificationJacobian, identification_jacobian
from pkmstiff.calibration.parameters import ParameterSet
from pkmstiff.calibration.plans import Plan
from pkmstiff.machine import Machine

#: a (unit) candidate direction is new when more than this much of it lies outside the gauge directions already
#: named (exact null directions agree to ~1e-10; anything independent leaves far more)
_NEW_SHARE = 1e-6
#: priority class of a parameter block when choosing base parameters (lower = kept first; every other block is
#: class 0): of exactly redundant glide parameters the drive zero is kept, then the guide start, the drive-joint
#: offset last
_PRIORITY = {"guide_start": 1, "drive_joint": 2}
#: a parameter is dropped when more than this much of its row of the orthonormal null basis lies outside the rows of
#: the parameters dropped before it. Structural rows are O(0.01–1); a relative perturbation δ of the Jacobian moves
#: the null basis by ≈ δ·cond (cond ≈ 1e4–1e5 here: 1e-12 -> 1e-7, LAPACK rounding -> 1e-11), so 1e-5 lies decades
#: from both (every bundled machine × instrument × frame, default plans: dropped ≥ 0.012, passed over ≤ 1e-10;
#: the tests assert the margins on Felix, the 6X and the Hexaglide)
BASE_THRESHOLD = 1e-5


def numerical_rank(sv: np.ndarray, shape: tuple[int, int]) -> tuple[int, float, float]:
    """Rank from the largest gap in the singular values (never a fixed tolerance, docs/theory/calibration.md).

    The descending singular values are extended by the rounding floor max(m, n) · ε · σ_1 (the level at which an
    exactly rank-deficient matrix's zero singular values sit); the rank is the position of the largest ratio
    σ_i/σ_{i+1} in that sequence. Returns (rank, gap ratio σ_r/max(σ_{r+1}, floor), threshold √(σ_r σ_{r+1}))
    — the threshold separates "identifiable" from "not" for directions (used to name the gauge freedoms).
    """
    s = np.asarray(sv, dtype=float)
    if s.size == 0 or not s[0] > 0:
        return 0, np.inf, np.inf
    floor = max(shape) * np.finfo(float).eps * s[0]
    ext = np.maximum(np.append(s, 0.0), floor)
    ratios = ext[:-1] / ext[1:]
    r = int(np.argmax(ratios)) + 1
    return r, float(ratios[r - 1]), float(np.sqrt(ext[r - 1] * ext[r]))


def base_priority(params: ParameterSet) -> np.ndarray:
    """Parameter indices in base-parameter priority order: by priority class of the block (:data:`_PRIORITY`), then
    in the error model's parameter order (chain by chain, the block order of :mod:`.parameters`, set-up last)."""
    return np.array(sorted(range(params.n), key=lambda i: (_PRIORITY.get(params.blocks[i], 0), i)), dtype=int)


def base_parameter_indices(null_basis: np.ndarray, priority: np.ndarray,
                           threshold: float = BASE_THRESHOLD) -> tuple[np.ndarray, float, float]:
    """Base parameters: walking ``priority`` (most wanted first), keep a parameter unless it is a combination of
    the parameters kept before it (docs/user-guide/calibration-identifiability.md).

    Matroid duality turns this into a walk over the k rows of the orthonormal null basis N (n, k) in *reverse*
    priority order: parameter j is dropped when its row N_j adds a new direction to the rows already dropped (its
    residual after projection on them exceeds ``threshold``), until k are dropped — then N restricted to the dropped
    rows is invertible, i.e. the kept columns are independent, and no kept parameter is a combination of earlier
    ones. Only the null space enters (fixed by the singular-value gap), never column norms, so exactly tied columns
    and a rounding-level perturbation do not change the choice. Returns (kept indices sorted, smallest residual
    dropped, largest residual passed over): the decision margins. If fewer than k rows pass the threshold (no case
    known), the largest remaining residuals are dropped to complete the set.
    """
    n, k = null_basis.shape
    if k == 0:
        return np.arange(n), np.inf, 0.0
    order = np.asarray(priority)[::-1]
    res = np.array(null_basis[order], dtype=float)  # residual rows, updated by modified Gram-Schmidt
    dropped: list[int] = []
    lo, hi, pos = np.inf, 0.0, 0
    while len(dropped) < k and pos < n:
        norms = np.linalg.norm(res[pos:], axis=1)
        over = np.flatnonzero(norms > threshold)
        if over.size == 0:
            hi = max(hi, float(norms.max(initial=0.0)))
            break
        i = pos + int(over[0])
        hi = max(hi, float(norms[:over[0]].max(initial=0.0)))
        lo = min(lo, float(norms[over[0]]))
        q = res[i] / norms[over[0]]
        res[i + 1:] -= np.outer(res[i + 1:] @ q, q)
        dropped.append(i)
        pos = i + 1
    while len(dropped) < k:  # fallback (see the docstring): pivot on the largest remaining residual
        rest = np.setdiff1d(np.arange(n), dropped)
        i = int(rest[np.argmax(np.linalg.norm(res[rest], axis=1))])
        q = res[i] / np.linalg.norm(res[i])
        res -= np.outer(res @ q, q)
        dropped.append(i)
    keep = np.setdiff1d(np.arange(n), order[dropped])
    return keep, lo, hi


def orthogonality_matrix(J: np.ndarray) -> np.ndarray:
    """O (n, n), o_kl = |j_k · j_l| / (|j_k| |j_l|) over the parameter columns (Szatmári eq. 4.5; docs/theory/calibration.md
    reading: n × n). A column without effect gets o_kk = 1 and o_kl = 0 (it is reported as a gauge freedom)."""
    norms = np.linalg.norm(J, axis=0)
    safe = np.where(norms > 0, norms, 1.0)
    U = J / safe
    O = np.abs(U.T @ U)
    O = np.triu(O) + np.triu(O, 1).T  # exactly symmetric whichever kernel the BLAS picks for UᵀU
    O = np.clip(O, 0.0, 1.0)
    np.fill_diagonal(O, 1.0)
    return O


def observability_indices(sv: np.ndarray, m: int) -> dict[str, float]:
    """O1–O5 of the identifiable singular values σ_1 ≥ … ≥ σ_r of the scaled Jacobian with m readings
    (docs/theory/calibration.md): O1 (Borm & Menq) = (Π σ_i)^(1/r)/√m, O2 (Driels & Pathre) = σ_r/σ_1, O3 (Nahvi) = σ_r,
    O4 (Nahvi & Hollerbach) = σ_r²/σ_1, O5 (Sun & Hollerbach) = 1/Σ σ_i⁻¹."""
    s = np.asarray(sv, dtype=float)
    if s.size == 0:
        return {k: 0.0 for k in ("O1", "O2", "O3", "O4", "O5")}
    return {"O1": float(np.exp(np.mean(np.log(s))) / np.sqrt(m)), "O2": float(s[-1] / s[0]), "O3": float(s[-1]),
            "O4": float(s[-1] ** 2 / s[0]), "O5": float(1.0 / np.sum(1.0 / s))}


@dataclass(frozen=True)
class GaugeFreedom:
    """A named set of parameter directions that no reading of the plan sees (to first order)."""

    name: str
    dof: int
    of: int  # size of the named group (e.g. 3 for a rotation); dof < of: only some of its directions
    kind: str  # "rigid", "combination", "parameter" or "unnamed"
    detail: str
    basis: np.ndarray = field(repr=False)  # (n, dof) SI parameter directions

    def label(self) -> str:
        part = f" ({self.dof} of {self.of} DOF{': ' + self.detail if self.detail else ''})" if self.dof < self.of \
            else (f" ({self.dof} DOF)" if self.of > 1 else "")
        return self.name + part

    def to_dict(self) -> dict:
        return {"name": self.name, "dof": self.dof, "of": self.of, "kind": self.kind, "detail": self.detail,
                "label": self.label()}


@dataclass(frozen=True)
class Identifiability:
    """What a plan can identify (see the module docstring); singular values in scaled units (readings in m per
    parameter scale)."""

    params: ParameterSet
    n_readings: int
    rank: int
    gap_ratio: float
    singular_values: np.ndarray
    base_parameters: tuple[str, ...]
    gauge_freedoms: tuple[GaugeFreedom, ...]
    condition_number: float
    condition_number_base: float
    orthogonality: np.ndarray
    max_orthogonality: float
    max_orthogonality_pair: tuple[str, str]
    observability: dict[str, float]

    @property
    def n_parameters(self) -> int:
        return self.params.n

    @property
    def null_dimension(self) -> int:
        return self.params.n - self.rank

    def to_dict(self) -> dict:
        return {"n_parameters": self.n_parameters, "n_readings": self.n_readings, "rank": self.rank,
                "null_dimension": self.null_dimension, "gap_ratio": _num(self.gap_ratio),
                "frame": self.params.frame, "base_parameters": list(self.base_parameters),
                "gauge_freedoms": [g.to_dict() for g in self.gauge_freedoms],
                "condition_number": _num(self.condition_number),
                "condition_number_base": _num(self.condition_number_base),
                "max_orthogonality": self.max_orthogonality,
                "max_orthogonality_pair": list(self.max_orthogonality_pair),
                "observability": self.observability,
                "singular_values_scaled": [float(v) for v in self.singular_values],
                "parameter_scales": {"length_m": _first(self.params, "m"), "angle_rad": _first(self.params, "rad")}}


def _num(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


def _first(params: ParameterSet, unit: str) -> float | None:
    for u, s in zip(params.units, params.scale):
        if u == unit:
            return float(s)
    return None


def _orth(A: np.ndarray, tol: float = 1e-12) -> np.ndarray:
    if A.size == 0:
        return A.reshape(A.shape[0], 0)
    U, s, _ = np.linalg.svd(A, full_matrices=False)
    return U[:, s > tol * max(s[0], 1e-300)] if s.size else U[:, :0]


def _right_singular(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values padded with zeros to the column count q and the q × q right singular vectors of A
    (economy SVD when A has at least as many rows as columns: the left vectors are never formed in full)."""
    m, q = A.shape
    _, s, Vt = np.linalg.svd(A, full_matrices=m < q)
    return np.concatenate([s, np.zeros(q - s.size)]), Vt.T


def _describe_axes(C: np.ndarray, axes: tuple[str, ...]) -> str:
    """Text for a sub-space of a group's coordinates (columns of C, group coordinates) e.g. 'axis (0, 0, 1)'."""
    if len(axes) != 3 or C.shape[1] == 0:
        return ""
    C = _orth(C)
    if C.shape[1] == 1:
        v = np.round(C[:, 0] * np.sign(C[np.argmax(np.abs(C[:, 0])), 0]), 3) + 0.0  # no "-0.000"
        return "along (" + ", ".join(f"{x:.3f}" for x in v) + ")"
    if C.shape[1] == 2:
        nrm = np.cross(C[:, 0], C[:, 1])
        nrm = np.round(nrm * np.sign(nrm[np.argmax(np.abs(nrm))]), 3) + 0.0
        return "normal to (" + ", ".join(f"{x:.3f}" for x in nrm) + ")"
    return ""


def _combination_text(x: np.ndarray, names: tuple[str, ...], top: int = 8) -> str:
    """'1.00·chain[1-6].platform_joint.z +0.94·chain[1-6].base_joint.z ...' (scaled coefficients ≥ 0.05 of the
    largest; equal coefficients of the same parameter over several chains grouped)."""
    x = x / x[np.argmax(np.abs(x))]
    groups: dict[tuple[float, str], list[str]] = {}
    for i in np.flatnonzero(np.abs(x) >= 0.05):
        head, _, tail = names[i].partition(".")
        key = (round(float(x[i]), 2), tail if head.startswith("chain") else names[i])
        groups.setdefault(key, []).append(head[5:] if head.startswith("chain") else "")
    items = sorted(groups.items(), key=lambda kv: (-abs(kv[0][0]) * len(kv[1]), kv[0][1]))
    parts = []
    for (c, tail), chains in items[:top]:
        who = tail if chains == [""] else (f"chain{chains[0]}.{tail}" if len(chains) == 1
                                            else f"chain[{','.join(chains)}].{tail}")
        parts.append(f"{'+' if c >= 0 else '-'}{abs(c):.2f}·{who}")
    more = " ..." if len(items) > top else ""
    return " ".join(parts).lstrip("+") + more


def name_gauges(Js: np.ndarray, scale: np.ndarray, params: ParameterSet, candidates: list[GaugeCandidate],
                null_basis: np.ndarray, threshold: float) -> tuple[GaugeFreedom, ...]:
    """Name the null space of the scaled Jacobian ``Js`` (basis ``null_basis`` (n, k), scaled coordinates) by the
    candidates, in order: a candidate direction counts when |Js x| ≤ ``threshold`` |x| and it is new with respect
    to the directions already named; what remains is reported as unnamed parameter combinations."""
    k = null_basis.shape[1]
    E = np.zeros((params.n, 0))
    out: list[GaugeFreedom] = []
    for cand in candidates:
        if E.shape[1] >= k:
            break
        Gs = cand.G / scale[:, None]
        Ug, sg, Vgt = np.linalg.svd(Gs, full_matrices=False)
        keep = sg > 1e-12 * sg[0]
        Q = Ug[:, keep]
        sm, V = _right_singular(Js @ Q)
        null_c = V[:, sm <= threshold]
        if null_c.shape[1] == 0:
            continue
        X = Q @ null_c
        Xn = X - E @ (E.T @ X)
        U, s, _ = np.linalg.svd(Xn, full_matrices=False)
        new = U[:, s > _NEW_SHARE]
        if new.shape[1] == 0:
            continue
        E = np.hstack([E, new])
        group = Vgt.T[:, keep] @ (null_c / sg[keep][:, None])  # group coordinates of the null directions
        detail = _describe_axes(group, cand.axes) if new.shape[1] < Q.shape[1] else ""
        out.append(GaugeFreedom(cand.name, int(new.shape[1]), int(Q.shape[1]), cand.kind, detail,
                                new * scale[:, None]))
    U, s, _ = np.linalg.svd(null_basis - E @ (E.T @ null_basis), full_matrices=False)
    rest = U[:, s > _NEW_SHARE]
    for j in range(rest.shape[1]):
        x = rest[:, j]
        out.append(GaugeFreedom("parameter combination " + _combination_text(x, params.names), 1, 1, "unnamed", "",
                                (x * scale)[:, None]))
    return tuple(out)


def analyse(jac: IdentificationJacobian, machine: Machine, setup: Setup | tuple[Setup, ...] | None
            ) -> Identifiability:
    """Identifiability from an identification Jacobian (see the module docstring); ``setup`` one set-up or the
    set-ups of a :class:`~pkmstiff.calibration.setups.PlanSet`."""
    params = jac.params
    Js = jac.scaled()
    m, n = Js.shape
    # everything below depends on J_s only through JsᵀJs: work on its triangular factor R (Js = Q R), n × n
    Rs = np.linalg.qr(Js, mode="r") if m > n else Js
    sv_all, V = _right_singular(Rs)
    sv = sv_all[:min(m, n)]
    rank, gap, thr = numerical_rank(sv, (m, n))
    null_basis = V[:, rank:]
    cands = gauge_candidates(machine, params, setup)
    gauges = name_gauges(Rs, params.scale, params, cands, null_basis, thr) if rank < n else ()
    keep = base_parameter_indices(null_basis, base_priority(params))[0]
    base = tuple(params.names[i] for i in keep)
    if rank:
        sb = np.linalg.svd(Rs[:, keep], compute_uv=False)
        cond_base = float(sb[0] / sb[-1]) if sb[-1] > 0 else np.inf
        cond = float(sv[0] / sv[rank - 1])
    else:
        cond_base = cond = np.inf
    O = orthogonality_matrix(Rs)  # column angles of R = those of J_s = those of W J (eq. 4.5 is scale-free)
    if n > 1:
        iu = np.triu_indices(n, 1)
        j = int(np.argmax(O[iu]))
        omax, pair = float(O[iu][j]), (params.names[iu[0][j]], params.names[iu[1][j]])
    else:
        omax, pair = 0.0, ("", "")
    return Identifiability(params=params, n_readings=m, rank=rank, gap_ratio=gap, singular_values=sv,
                           base_parameters=base, gauge_freedoms=gauges, condition_number=cond,
                           condition_number_base=cond_base, orthogonality=O, max_orthogonality=omax,
                           max_orthogonality_pair=pair, observability=observability_indices(sv[:rank], m))


def identifiability(machine: Machine, params: ParameterSet, plan: Plan) -> Identifiability:
    """Identification Jacobian of the plan and its identifiability analysis in one call."""
    from pkmstiff.calibration.setups import setups_of

    return analyse(identification_jacobian(machine, params, plan), machine, setups_of(plan))


def check_identifiable(ident: Identifiability, source: str) -> None:
    """Refuse, before any identification, a measurement whose poses lose parameter directions beyond the named
    gauge freedoms (docs/theory/calibration.md): the rank found must equal the parameter count less the named
    freedoms' DOF. A plan that misses this (e.g. a single ball-bar circle on Felix: rank 14, where 36 of the 42
    parameters are identifiable) leaves the identification ill-posed — an iterative solver then runs for minutes
    before it fails to converge — so this is one input error (exit status 2) naming the file, the rank found and the
    rank needed."""
    from pkmstiff.errors import InputError

    unnamed = sum(g.dof for g in ident.gauge_freedoms if g.kind == "unnamed")
    if unnamed == 0:
        return
    needed = ident.rank + unnamed
    raise InputError(
        source, "readings", f"poses that identify {needed} base parameters of {ident.n_parameters} (all but the "
        f"named gauge freedoms, {ident.n_parameters - needed} DOF); measure more ball-bar circles in other planes "
        f"and heights or a hemisphere path, or more poses spread over the workspace ('pkmstiff calibrate "
        f"identifiability MACHINE --instrument KIND --plan PLAN' shows what a plan identifies before measuring)",
        f"rank {ident.rank} ({unnamed} parameter combinations no reading sees, {ident.n_readings} readings)")
