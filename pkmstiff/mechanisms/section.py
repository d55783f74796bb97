"""A mechanism on a workspace section plane: kinematic quantities and joint-limit admissibility (issue 14, item 5).

The mechanism counterpart of :func:`pkmstiff.evaluation.sections.evaluate_section`: every raster point of an axis
plane is an output pose (position = the point, orientation fixed), solved by the inverse kinematics
(:func:`pkmstiff.mechanisms.evaluate`, continuation from home) and classified by the reason bits of
:data:`pkmstiff.mechanisms.REASONS` (no solution, singular, a joint outside its limits).  Quantities:

``kappa``
    condition number σ_1/σ_k of the kinematic Jacobian ∂x/∂s (output pose rates per drive rate, SI: m and rad
    per m or rad; k = number of drives), from implicit differentiation of the forward kinematics
    (:func:`kinematic_jacobian`).  For six drives and six pose coordinates this is κ of J⁻¹ = (∂x/∂s)⁻¹, the
    machines' ``kappa`` (Cobet eq. A.18); ∞ where the Jacobian loses rank (a singular configuration).
``<drive name>``
    a drive value (m or rad inside; mm or deg displayed).
``kappa_out``
    condition number of ∂x_c/∂s of the *controlled* outputs the file declares (point coordinates and full
    orientation or tool axis, :func:`~pkmstiff.mechanisms.outputs.output_condition`): ∞ at an output singularity
    such as a wrist singularity, where ``kappa`` of the Cardan pose stays finite.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pkmstiff.errors import ArgumentError
from pkmstiff.evaluation.sections import raster
from pkmstiff.mechanisms.evaluate import REASONS, evaluate
from pkmstiff.mechanisms.model import Mechanism
from pkmstiff.mechanisms.outputs import condition_numbers, configuration_rates, output_condition
from pkmstiff.mechanisms.solver import STATUS, Solution, inverse, output_pose
from pkmstiff.mechanisms.stiffness import take
from pkmstiff.mechanisms.structure import LABELS

Array = NDArray[np.float64]


def kinematic_jacobian(sol: Solution, h: float = 1e-6) -> Array:
    """∂x/∂s (N, pose_size, n_drives) of the Cardan output pose at the configurations of ``sol`` (SI).

    Implicit differentiation of the forward kinematics F(q, s) = 0 (patent claim 9,
    :func:`~pkmstiff.mechanisms.outputs.configuration_rates`); the pose rates are central differences of the output
    pose along q_s (step h·length scale: truncation O(h²) ≈ 1e-12 relative).  NaN where ``sol`` found no
    configuration.  The conditioning of the *controlled* outputs is :func:`~pkmstiff.mechanisms.outputs.output_condition`.
    """
    mech = sol.mech
    N, L, d = sol.q.shape
    nd = len(mech.drives)
    drv = np.where(sol.ok[:, None], sol.drives, 0.0)
    qs_all = configuration_rates(mech, sol.q, drv)
    out = np.full((N, mech.pose_size, nd), np.nan)
    qf = sol.q.reshape(N, -1)
    for c in range(nd):
        qs = qs_all[:, :, c]
        eps = h * mech.length_scale / np.maximum(np.abs(qs).max(axis=1, keepdims=True), 1e-300)
        pp = output_pose(mech, (qf + eps * qs).reshape(N, L, d))
        pm = output_pose(mech, (qf - eps * qs).reshape(N, L, d))
        dp = pp - pm
        if mech.dim == 3:
            dp[:, 3:] = (dp[:, 3:] + np.pi) % (2.0 * np.pi) - np.pi  # angle differences across ±π
        out[:, :, c] = dp / (2.0 * eps)
    out[~sol.ok] = np.nan
    return out


def quantity_names(mech: Mechanism) -> tuple[str, ...]:
    """Quantities a mechanism section offers: ``kappa``, ``kappa_out``, every drive name and, with elastic data
    (:mod:`pkmstiff.mechanisms.elastic`), the stiffness at the output point ``kx`` … ``krz``, natural frequencies
    ``f1``, ``f2``, … and component shares ``share_<component>_<x|y|z>`` (as the machines' quantities)."""
    out = ("kappa", "kappa_out") + mech.drive_names
    if mech.elastic is not None:
        out += ELASTIC + tuple(f"f{i}" for i in range(1, 7)) + tuple(
            f"share_{lab}_{d}" for lab in LABELS for d in "xyz")
    return out


#: stiffness quantities of an elastic mechanism: k = 1/C_jj at the output point (N/µm, N·m/µrad displayed)
ELASTIC = ("kx", "ky", "kz", "krx", "kry", "krz")
_FREQ = re.compile(r"f([1-9]\d*)$")


def quantity_label(name: str) -> str:
    """The text a figure or table shows for a section quantity: the machines' label for the stiffness and frequency
    quantities (:mod:`pkmstiff.evaluation.quantities`), the same wording for the component shares."""
    from pkmstiff.evaluation.quantities import get_quantity

    if name == "kappa":
        return "condition number of dx/ds"
    if name == "kappa_out":
        return "condition number of the controlled outputs"
    if name.startswith("share_"):
        return f"share of the {name[len('share_'):-2]} in the TCP compliance along {name[-1]}"
    if name in ELASTIC or _FREQ.match(name):
        return get_quantity(name).label
    return f"drive {name}"


def _known(mech: Mechanism, name: str) -> bool:
    m = _FREQ.match(name)
    return name in quantity_names(mech) or (mech.elastic is not None and m is not None)


def check_quantities(mech: Mechanism, names) -> None:
    """Raise :class:`ArgumentError` naming the quantities ``mech`` does not offer."""
    bad = [n for n in names if not _known(mech, n)]
    if bad:
        raise ArgumentError(f"quantities: expected names from {', '.join(quantity_names(mech))} for mechanism "
                            f"'{mech.name}', found {', '.join(bad)}")


def elastic_values(mech: Mechanism, sol: Solution, names, point: Array | None = None
                   ) -> tuple[dict[str, Array], dict[str, str], dict[str, float]]:
    """SI values (N,), display units and scales of the elastic quantities among ``names`` at the configurations of
    ``sol`` (:func:`~pkmstiff.mechanisms.stiffness.evaluate_mechanism`, chunked; at ``point``, home coordinates on
    the output link, instead of the output point)."""
    from pkmstiff.mechanisms.stiffness import evaluate_mechanism

    freq = [int(m.group(1)) for n in names if (m := _FREQ.match(n))]
    dirs = tuple(sorted({n[-1] for n in names if n.startswith("share_")}))
    if not freq and not dirs and not any(n in ELASTIC for n in names):
        return {}, {}, {}
    res = evaluate_mechanism(mech, sol, max(freq, default=0), dirs, point=point)
    values, units, scales = {}, {}, {}
    for n in names:
        if n in ELASTIC:
            i = ELASTIC.index(n)
            values[n] = res.stiffness[:, i]
            units[n], scales[n] = ("N/um", 1e-6) if i < 3 else ("N*m/urad", 1e-6)
        elif (m := _FREQ.match(n)):
            values[n], units[n], scales[n] = res.frequencies_hz[:, int(m.group(1)) - 1], "Hz", 1.0
        elif n.startswith("share_"):
            lab = n[len("share_"):-2]
            values[n], units[n], scales[n] = res.shares[n[-1]][:, LABELS.index(lab)], "%", 100.0
    return values, units, scales


#: the per-pose fields of a :class:`Solution` besides its status
_PER_POSE = ("q", "iterations", "residual", "rank", "rcond", "sigma_ratio")


def _start_q(mech: Mechanism, start: Array | None) -> Array:
    """The configuration (L, d) a mode-keeping continuation starts from: ``start``, default home's solution."""
    return inverse(mech, mech.home_output_pose[None]).q[0] if start is None else np.asarray(start, dtype=float)


def raster_inverse(mech: Mechanism, P: Array, shape: tuple[int, int], start: Array | None = None,
                   **solve_kw) -> Solution:
    """Inverse kinematics of the raster poses P (nv·nu, pose_size), row-major over ``shape`` = (nv, nu), by
    continuation from neighbouring points in the working and assembly mode of the start (``start``: a configuration
    (L, d), default home).

    The point nearest the start's output point is solved from the start, then in waves every unsolved 4-neighbour of
    a point solved in the last wave starts from that point's configuration (one raster step).  A solution whose mode
    signature (:func:`pkmstiff.mechanisms.modes.signature`) differs from the start's — the step crossed a singularity
    into another working or assembly mode — is rejected (status ``other_mode``), as is a failed solve.  A rejected
    point is tried again from each other neighbour solved later (at most once per direction), and a point still
    unsolved when the waves stop — one rejected from every neighbour or that no wave reached — is tried once from the
    start; the waves go on from the points solved there.  A point whose signature has a zero where the start's is
    regular lies on a singularity of that mode's boundary: status ``singular``."""
    from pkmstiff.mechanisms.modes import signature

    nv, nu = shape
    n = nv * nu
    q0 = _start_q(mech, start)
    start_pose = output_pose(mech, q0[None])[0]
    start_sig = signature(mech, q0[None])[0]
    ref = None
    begin0 = None if start is None else q0[None]  # home: the solver's own home start
    sol = Solution(mech, np.broadcast_to(q0, (n,) + q0.shape).copy(), np.full(n, "no_solution", dtype=_STATUS_DTYPE),
                   np.zeros(n, int), np.full(n, np.nan), np.zeros(n, int), 0, np.full(n, np.nan), np.full(n, np.nan))
    tried = np.zeros(n, np.uint8)  #: bit d: tried from the neighbour in direction d; bit 4: tried from the start
    ok = np.zeros(n, bool)
    steps = ((0, 1), (0, -1), (1, 0), (-1, 0))

    def solve(idx: Array, begin: Array) -> Array:
        nonlocal ref
        part = inverse(mech, P[idx], start=begin, output_check=False, **solve_kw)  # κ_out: only where asked
        sol.n_free = part.n_free
        status, ref = mode_status(mech, part, start_sig, ref)
        for f in _PER_POSE:
            getattr(sol, f)[idx] = getattr(part, f)  # idx are unsolved points: the last try is their result
        sol.status[idx] = status
        good = (status == "converged") | (status == "singular")
        ok[idx] = good
        return idx[good]

    d = np.linalg.norm(P[:, :mech.dim] - start_pose[None, :mech.dim], axis=1)
    seed = np.array([int(np.argmin(d))])
    tried[seed] |= 16
    frontier = solve(seed, begin0)
    grid = np.arange(n).reshape(nv, nu)
    empty = np.zeros(0, int)
    pending = (empty, empty, empty)  # (point, source, direction bit) not yet tried, from earlier waves
    while True:
        while True:
            cand, src, bit = [pending[0]], [pending[1]], [pending[2]]
            iv, iu = np.divmod(frontier, nu)
            for k, (di, dj) in enumerate(steps):
                jv, ju = iv + di, iu + dj
                inside = (jv >= 0) & (jv < nv) & (ju >= 0) & (ju < nu)
                cand.append(grid[jv[inside], ju[inside]])
                src.append(frontier[inside])
                bit.append(np.full(int(inside.sum()), 1 << k))
            c, sr, b = (np.concatenate(a).astype(int) for a in (cand, src, bit))
            keep = ~ok[c] & (tried[c] & b == 0)
            c, sr, b = c[keep], sr[keep], b[keep]
            if not c.size:
                break
            cand_all, first = np.unique(c, return_index=True)
            tried[cand_all] |= b[first].astype(np.uint8)
            rest = np.ones(c.size, bool)
            rest[first] = False
            pending = (c[rest], sr[rest], b[rest])  # other solved neighbours: tried if this one fails
            frontier = solve(cand_all, sol.q[sr[first]])
        rest = np.flatnonzero(~ok & (tried & 16 == 0))
        if not rest.size:
            break
        tried[rest] |= 16
        pending = (empty, empty, empty)
        frontier = solve(rest, begin0)
    return sol


_STATUS_DTYPE = f"<U{max(map(len, STATUS))}"


def mode_filter(mech: Mechanism, sol: Solution, start: Array | None = None) -> Solution:
    """``sol`` (solved from ``start``, default home) with the status ``other_mode`` where a configuration is in
    another working or assembly mode than the start's and ``singular`` where it lies on a singularity of a block
    regular at the start (:mod:`pkmstiff.mechanisms.modes`; the start's singular blocks take the sign of the first
    configuration found).  Modifies and returns ``sol``."""
    from pkmstiff.mechanisms.modes import signature

    q0 = _start_q(mech, start)
    sol.status = mode_status(mech, sol, signature(mech, q0[None])[0], None)[0]
    return sol


def mode_status(mech: Mechanism, sol: Solution, start_sig: Array, ref: Array | None
                 ) -> tuple[Array, Array | None]:
    """The status of ``sol`` with ``other_mode`` / ``singular`` against the reference signature ``ref`` (None: the
    start's signature, its zeros taken from the first configuration of ``sol``), and that reference."""
    from pkmstiff.mechanisms.modes import on_singularity, other_mode, reference, signature

    status = sol.status.astype(_STATUS_DTYPE)
    found = np.flatnonzero(sol.ok)
    if found.size:
        sig = signature(mech, sol.q[found])
        if ref is None:
            ref = reference(start_sig, sig[0])
        status[found[other_mode(sig, ref)]] = "other_mode"
        status[found[on_singularity(sig, ref) & (status[found] == "converged")]] = "singular"
    return status, ref


@dataclass
class MechanismSection:
    """Values on a plane (SI, NaN where inadmissible), reasons (bits of REASONS) and the raster (m)."""

    mechanism: str
    plane: str  #: "yz", "xz" or "xy"
    at: float  #: m, position along the plane normal
    u_values: Array  #: (nu,) m
    v_values: Array  #: (nv,) m
    orientation: Array  #: (3,) rad (a, b, c) or planar (φ, 0, 0)
    values: dict[str, Array]  #: name → (nv, nu) SI
    units: dict[str, str]  #: name → display unit
    scales: dict[str, float]  #: name → SI-to-display factor
    reasons: Array  #: (nv, nu) int
    status: Array  #: (nv, nu) str (solver status)
    settings: dict = field(default_factory=dict)

    @property
    def ok(self) -> Array:
        return self.reasons == 0

    @property
    def cell_area(self) -> float:
        return float((self.u_values[1] - self.u_values[0]) * (self.v_values[1] - self.v_values[0]))

    def display(self, name: str) -> Array:
        return self.values[name] * self.scales[name]

    def statistics(self) -> dict[str, dict]:
        out = {}
        for n in self.values:
            v = self.display(n)[self.ok]
            v = v[np.isfinite(v)]
            out[n] = {"unit": self.units[n], "min": float(v.min()) if v.size else None,
                      "mean": float(v.mean()) if v.size else None, "max": float(v.max()) if v.size else None,
                      "count": int(v.size)}
        return out

    def reason_counts(self) -> dict[str, int]:
        return {k: int(np.count_nonzero(self.reasons & b)) for k, b in REASONS.items()}


def plane_poses(mech: Mechanism, plane: str, at: float, u_values: Array, v_values: Array,
                orientation: Array) -> Array:
    """Output poses (nv·nu, pose_size) of the raster points (row-major over v, then u)."""
    plane = plane.lower()
    if mech.dim == 2 and plane != "xy":
        raise ArgumentError(f"mechanism '{mech.name}' is planar: its section plane is xy, found {plane!r}")
    U, V = np.meshgrid(u_values, v_values)
    axes = {"x": 0, "y": 1, "z": 2}
    P = np.zeros((U.size, mech.pose_size))
    if mech.dim == 2:
        P[:, 0], P[:, 1], P[:, 2] = U.ravel(), V.ravel(), orientation[0]
        return P
    normal = ({"x", "y", "z"} - set(plane)).pop()
    P[:, axes[plane[0]]], P[:, axes[plane[1]]], P[:, axes[normal]] = U.ravel(), V.ravel(), at
    P[:, 3:6] = orientation
    return P


#: solver options of a section raster: continuation in 4 steps from home, one refinement (8 steps), and at most 6
#: step halvings — most raster points of a section are unreachable, and they must be given up quickly
SOLVE = {"steps": 4, "max_refine": 1, "max_backtrack": 6}
#: from a neighbouring raster point (one step away; larger steps are split by the solver's default continuation)
NEIGHBOUR = {"steps": 1, "max_refine": 1, "max_backtrack": 6}


def fit_window(mech: Mechanism, plane: str, at: float, orientation: Array, step: float,
               extent: float | None = None, n: int = 25, start: Array | None = None) -> tuple[tuple[float, float], ...]:
    """In-plane ranges (m) covering the admissible points of a coarse n×n pass over the start's output point ±
    ``extent`` (default the mechanism's length scale; solved from the start ``start`` (L, d), default home, points in
    another working mode than the start's left out: :func:`mode_filter`), widened by one coarse cell and snapped to
    ``step``."""
    plane = plane.lower()
    centre = mech.home_output_pose if start is None else output_pose(mech, np.asarray(start, float)[None])[0]
    ax = {"x": 0, "y": 1, "z": 2}
    extent = mech.length_scale if extent is None else extent
    cu, cv = centre[ax[plane[0]]], centre[ax[plane[1]]]
    uu = np.linspace(cu - extent, cu + extent, n)
    vv = np.linspace(cv - extent, cv + extent, n)
    P = plane_poses(mech, plane, at, uu, vv, orientation)
    begin = None if start is None else np.asarray(start, float)[None]
    ev = evaluate(mech, P, solution=mode_filter(mech, inverse(mech, P, start=begin, **SOLVE), start))
    ok = ev.admissible.reshape(n, n)
    if not ok.any():
        raise ArgumentError(f"section of '{mech.name}': no admissible point on the {plane} plane at "
                                  f"{at * 1e3:g} mm within ±{extent * 1e3:g} mm of "
                                  f"{'home' if start is None else 'the start pose'} (give --range)")
    cell = 2.0 * extent / (n - 1)
    iu, iv = np.flatnonzero(ok.any(axis=0)), np.flatnonzero(ok.any(axis=1))
    snap = lambda lo, hi: (np.floor((lo - cell) / step) * step, np.ceil((hi + cell) / step) * step)  # noqa: E731
    return snap(uu[iu[0]], uu[iu[-1]]), snap(vv[iv[0]], vv[iv[-1]])


def evaluate_section(mech: Mechanism, plane: str, at: float, u_range: tuple[float, float],
                     v_range: tuple[float, float], step: float, orientation=(0.0, 0.0, 0.0),
                     names=("kappa",), point: Array | None = None, start: Array | None = None) -> MechanismSection:
    """Quantities ``names`` and admissibility on an axis plane (ranges, step, ``at`` in m; orientation rad); the
    elastic quantities at ``point`` (home coordinates on the output link, e.g. a tool tip) instead of the output
    point; in the working mode of ``start`` (a configuration (L, d), default home; :func:`raster_inverse`)."""
    check_quantities(mech, names)
    ori = np.asarray(orientation, dtype=float)
    uu, vv = raster(*u_range, step), raster(*v_range, step)
    if uu.size < 2 or vv.size < 2:
        raise ArgumentError("section: the window must span at least two raster steps along each axis")
    P = plane_poses(mech, plane, at, uu, vv, ori)
    shape = (vv.size, uu.size)
    ev = evaluate(mech, P, solution=raster_inverse(mech, P, shape, start, **NEIGHBOUR))
    values, units, scales = {}, {}, {}
    if "kappa" in names:
        kap = condition_numbers(kinematic_jacobian(ev.solution))
        values["kappa"], units["kappa"], scales["kappa"] = kap, "1", 1.0
    if "kappa_out" in names:
        q = np.where(ev.solution.ok[:, None, None], ev.solution.q, np.nan)
        values["kappa_out"], units["kappa_out"], scales["kappa_out"] = output_condition(mech, q, ev.drives), "1", 1.0
    for i, (dn, du) in enumerate(zip(mech.drive_names, mech.drive_units)):
        if dn in names:
            values[dn] = ev.drives[:, i]
            units[dn], scales[dn] = ("mm", 1e3) if du == "m" else ("deg", 180.0 / np.pi)
    ok = ev.admissible
    idx = np.flatnonzero(ok)
    ev_vals, ev_units, ev_scales = elastic_values(mech, take(ev.solution, idx), names, point)
    for n, v in ev_vals.items():
        values[n] = np.full(ok.shape, np.nan)
        values[n][idx] = v
    units.update(ev_units)
    scales.update(ev_scales)
    values = {n: np.where(ok, values[n], np.nan).reshape(shape) for n in names}
    return MechanismSection(mech.name, plane.lower(), at, uu, vv, ori, values, units, scales,
                            ev.reasons.reshape(shape), ev.status.reshape(shape),
                            {"solver": dict(SOLVE), "planar": mech.dim == 2})


#: raster of the fallback path of :func:`solve_in_mode`: steps per length scale, and the extent around the start in
#: length scales (that of the coarse pass of :func:`fit_window`)
_PATH_STEPS = 20
_PATH_EXTENT = 1.0


def solve_in_mode(mech: Mechanism, poses: Array, start: Array | None = None) -> Solution:
    """Configurations of output poses in the working and assembly mode of ``start`` (a configuration (L, d), default
    home) — the configuration a section finds at the same point.

    First the inverse kinematics along the straight path from the start (:func:`~pkmstiff.mechanisms.inverse`,
    :data:`SOLVE`), checked by :func:`mode_filter`.  A pose that fails there (the straight path leaves the workspace
    or crosses a singularity) is solved as a section raster point: a raster of the plane through it normal to z (the
    plane of motion of a planar mechanism) at its orientation, over the start's output point ± the mechanism's size
    and the pose, step 1/20 of the size, laid so that the pose is a raster node, solved by :func:`raster_inverse`
    from the start (neighbour continuation that keeps the mode); its result at that node is the pose's."""
    poses = np.atleast_2d(np.asarray(poses, dtype=float))
    q0 = _start_q(mech, start)
    sol = mode_filter(mech, inverse(mech, poses, start=q0[None], **SOLVE), q0)
    p0 = output_pose(mech, q0[None])[0]
    h = mech.length_scale / _PATH_STEPS
    ext = _PATH_EXTENT * mech.length_scale
    for i in np.flatnonzero(~sol.ok):
        u, v = poses[i, 0], poses[i, 1]
        ku = np.arange(np.floor((min(p0[0] - ext, u) - u) / h), np.ceil((max(p0[0] + ext, u) - u) / h) + 1)
        kv = np.arange(np.floor((min(p0[1] - ext, v) - v) / h), np.ceil((max(p0[1] + ext, v) - v) / h) + 1)
        uu, vv = u + h * ku, v + h * kv
        ori = poses[i, 2:3] if mech.dim == 2 else poses[i, 3:6]
        P = plane_poses(mech, "xy", poses[i, 2] if mech.dim == 3 else 0.0, uu, vv, np.resize(ori, 3))
        part = raster_inverse(mech, P, (vv.size, uu.size), start=q0, **NEIGHBOUR)
        j = int(np.flatnonzero(kv == 0)[0] * uu.size + np.flatnonzero(ku == 0)[0])
        for f in ("status", *_PER_POSE):
            getattr(sol, f)[i] = getattr(part, f)[j]
    return sol
