"""Admissibility of poses (docs/theory/admissibility.md, Cobet App. B), vectorised over poses.

Every check returns a per-pose boolean (True = admissible) and sets a bit of a reason code; the combined mask is
admissible where no bit is set. Poses whose inverse kinematics has no solution carry only ``UNREACHABLE``: the
other checks are not evaluated there (their inputs do not exist), so reason counts stay meaningful.

The collision checks loop over poses in compiled code (:mod:`pkmstiff.kinematics.kernels`): strut-strut evaluates every
pair of every pose (the per-pair detail is reported); strut-platform rejects or accepts most struts with the
exact Cyrus-Beck broad phase and runs the exact edge/face/piercing tests, with early exit, only on near misses.
Both use the same compiled primitives as the array functions of :mod:`pkmstiff.admissibility.collision`.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable

import numpy as np

from pkmstiff.kinematics import dispatch as _dispatch
from pkmstiff.admissibility.collision import unique_edges
from pkmstiff.machine.model import Machine, memo
from pkmstiff.machine.roles import DriveLoadData


class Reason(enum.IntFlag):
    """Reason codes (bit flags) for inadmissible poses."""

    UNREACHABLE = 1  # glide: a strut cannot reach its guide (negative discriminant, docs/theory/kinematics.md)
    DRIVE_RANGE = 2  # B.1/B.2: drive position or strut length outside its range
    DRIVE_SPACING = 4  # B.3/B.4: two drives on one guide too close / too far apart
    JOINT_ANGLE = 8  # B.5: swivel or tilt angle outside its limits
    INA_LIMIT = 16  # B.6: coupled INA Cardan limit |tilt| <= 75 deg - 2/3 |swivel|
    SINGULAR = 32  # App. B.3 / docs/theory/kinematics.md: condition number above the threshold
    STRUT_COLLISION = 64  # B.7-B.11: two struts closer than the sum of their radii
    PLATFORM_COLLISION = 128  # B.12: a strut touches or pierces the platform hull
    DRIVE_LOAD = 256  # B.13: static drive load exceeds the available drive force
    REQUIREMENT = 512  # a user requirement (e.g. minimum stiffness) is not met
    FRAME = 1024  # O' outside the frame limits of the machine file (bed, guide structure)


REASON_TEXT: dict[Reason, str] = {
    Reason.UNREACHABLE: "strut cannot reach its guide (no inverse-kinematics solution)",
    Reason.DRIVE_RANGE: "drive position / strut length outside its range",
    Reason.DRIVE_SPACING: "drives on a shared guide too close or too far apart",
    Reason.JOINT_ANGLE: "joint swivel/tilt angle outside its limits",
    Reason.INA_LIMIT: "INA coupled joint limit |tilt| <= 75 deg - 2/3 |swivel| violated",
    Reason.SINGULAR: "singular pose (condition number above threshold)",
    Reason.STRUT_COLLISION: "strut-strut collision",
    Reason.PLATFORM_COLLISION: "strut-platform collision",
    Reason.DRIVE_LOAD: "static drive load exceeds the available drive force",
    Reason.REQUIREMENT: "user requirement not met",
    Reason.FRAME: "platform outside the frame limits (machine bed / guide structure)",
}

ALL_CHECKS = ("frame", "drive_range", "drive_spacing", "joint_angles", "singularity", "strut_collision",
              "platform_collision", "drive_load")

#: one line per check name of :data:`ALL_CHECKS` (``pkmstiff quantities`` lists them; names for ``--skip-check``)
CHECK_TEXT = {
    "frame": REASON_TEXT[Reason.FRAME],
    "drive_range": REASON_TEXT[Reason.DRIVE_RANGE],
    "drive_spacing": REASON_TEXT[Reason.DRIVE_SPACING],
    "joint_angles": f"{REASON_TEXT[Reason.JOINT_ANGLE]} (and the INA coupled limit)",
    "singularity": REASON_TEXT[Reason.SINGULAR],
    "strut_collision": REASON_TEXT[Reason.STRUT_COLLISION],
    "platform_collision": REASON_TEXT[Reason.PLATFORM_COLLISION] + " (the machine file's platform hull)",
    "drive_load": REASON_TEXT[Reason.DRIVE_LOAD],
}


def checks_without(skip: Iterable[str] = (), source: str = "", key: str = "skip_checks") -> tuple[str, ...]:
    """The checks of :data:`ALL_CHECKS` (in that order) without the named ones (machines.md §1.7 item 9).

    An unknown name raises :class:`pkmstiff.errors.InputError` naming ``source``/``key`` and the known names.
    """
    from pkmstiff.errors import InputError

    skip = tuple(skip)
    for name in skip:
        if name not in ALL_CHECKS:
            raise InputError(source, key, f"admissibility check names from {', '.join(ALL_CHECKS)}", name)
    return tuple(c for c in ALL_CHECKS if c not in skip)


def checks_left_out(checks: Iterable[str]) -> list[str]:
    """The names of :data:`ALL_CHECKS` not in ``checks`` (what an output states as left out)."""
    applied = set(checks)
    return [c for c in ALL_CHECKS if c not in applied]


def left_out_text(left_out: Iterable[str]) -> str:
    """``admissibility checks left out: a, b`` (in the order of :data:`ALL_CHECKS`) for printed outputs and CSV
    comment lines; empty when every check applies."""
    given = set(left_out)
    names = [c for c in ALL_CHECKS if c in given]
    return f"admissibility checks left out: {', '.join(names)}" if names else ""


def reason_names(code: int) -> list[str]:
    """Names of the reasons set in a reason code, e.g. ``['DRIVE_RANGE', 'SINGULAR']``."""
    return [r.name for r in Reason if int(code) & int(r)]  # type: ignore[misc]


@dataclass
class CheckResult:
    """Outcome of one check: ``ok`` (N,), optional per-chain / per-pair detail, or why it was skipped."""

    ok: np.ndarray
    reason: Reason
    detail: np.ndarray | None = None  # (N, n) per chain, or (N, pairs) per strut pair, True = violated
    labels: list[str] | None = None  # labels of the detail columns
    skipped: str | None = None


@dataclass
class Admissibility:
    """Combined admissibility of N poses."""

    ok: np.ndarray  # (N,) bool
    reasons: np.ndarray  # (N,) uint32 bit mask of Reason
    checks: dict[str, CheckResult] = field(default_factory=dict)

    def summary(self) -> dict[str, int]:
        """Number of poses failing each reason (a pose may fail several), plus totals."""
        out = {"poses": int(self.ok.size), "admissible": int(self.ok.sum())}
        for r in Reason:
            out[r.name] = int(np.count_nonzero(self.reasons & int(r)))  # type: ignore[arg-type]
        return out

    def skipped(self) -> dict[str, str]:
        return {k: c.skipped for k, c in self.checks.items() if c.skipped}

    def failing(self, i: int) -> list[str]:
        """Human-readable failing reasons of pose ``i``, with the chains/pairs involved where known.

        Consistent with the reason code: an unreachable pose reports only that (naming the chains).
        """
        if self.reasons[i] & Reason.UNREACHABLE:
            rng = self.checks.get(Reason.DRIVE_RANGE.name.lower())
            who = ([lab for lab, bad in zip(rng.labels, rng.detail[i]) if bad]
                   if rng is not None and rng.detail is not None and rng.labels else [])
            return [REASON_TEXT[Reason.UNREACHABLE] + (f" ({', '.join(who)})" if who else "")]
        out = []
        for c in self.checks.values():
            if c.skipped or c.ok[i]:
                continue
            text = REASON_TEXT[c.reason]
            if c.detail is not None and c.labels is not None:
                who = [lab for lab, bad in zip(c.labels, c.detail[i]) if bad]
                if who:
                    text += f" ({', '.join(who)})"
            out.append(text)
        return out


# ------------------------------------------------------------------------------------------------- single checks


def check_frame(machine: Machine, position: np.ndarray) -> CheckResult:
    """Frame limits: the position of O' (N, 3) must lie in the machine file's box [limits.frame]."""
    lim = machine.limits
    if np.all(np.isinf(lim.position_min)) and np.all(np.isinf(lim.position_max)):
        return CheckResult(np.ones(len(position), bool), Reason.FRAME, skipped="no frame limits in the machine file")
    bad = (position < lim.position_min) | (position > lim.position_max)
    return CheckResult(~bad.any(axis=1), Reason.FRAME, bad, ["x", "y", "z"])


def check_drive_range(machine: Machine, drive: np.ndarray, reachable: np.ndarray) -> CheckResult:
    """B.1 (pod: l_min <= l <= l_max) and B.2 (glide: real root and 0 <= lambda <= t)."""
    ch = machine.chains
    with np.errstate(invalid="ignore"):
        if ch.kind == "glide":
            bad = ~reachable | (drive < 0.0) | (drive > ch.guide_length)
        else:
            bad = (drive < ch.length_min) | (drive > ch.length_max) | ~np.isfinite(drive)
    labels = [f"chain {i + 1}" for i in range(ch.n)]
    return CheckResult(~bad.any(axis=1), Reason.DRIVE_RANGE, bad, labels)


def check_drive_spacing(machine: Machine, q: np.ndarray) -> CheckResult:
    """B.3, B.4: ||q_i - q_j|| > d_min + s and < d_max - s for drives on a shared guide."""
    n_pose = q.shape[0]
    pairs = [(g.name, i, j, g) for g in machine.guides.values()
             for k, i in enumerate(g.chains) for j in g.chains[k + 1:]]
    if not pairs:
        return CheckResult(np.ones(n_pose, bool), Reason.DRIVE_SPACING, skipped="no shared guides")
    bad = np.zeros((n_pose, len(pairs)), bool)
    for col, (_, i, j, g) in enumerate(pairs):
        dist = np.linalg.norm(q[:, i] - q[:, j], axis=-1)
        bad[:, col] = (dist <= g.min_distance + g.safety_margin) | (dist >= g.max_distance - g.safety_margin)
    labels = [f"{name}: drives {i + 1}-{j + 1}" for name, i, j, _ in pairs]
    return CheckResult(~bad.any(axis=1), Reason.DRIVE_SPACING, bad, labels)


def check_joint_angles(
    machine: Machine, side_angles: dict[str, tuple[np.ndarray, np.ndarray]]
) -> tuple[CheckResult, CheckResult]:
    """B.5 limits on swivel and tilt and the coupled INA limit B.6 for both joint sides.

    ``side_angles`` maps ``"drive"``/``"platform"`` to ``(swivel, tilt)`` arrays (N, n) in rad, tilt in the joint
    type's convention. An undefined (NaN) swivel skips all swivel-dependent checks (docs/theory/kinematics.md). B.6 is
    applied symmetrically, |tilt| <= 75 deg - 2/3 |swivel| (spec assumption).
    """
    bad_lim, bad_ina, labels = [], [], []
    for side, (swivel, tilt) in side_angles.items():
        jt = machine.joint_type_arrays(side)  # type: ignore[arg-type]
        defined = np.isfinite(swivel)
        with np.errstate(invalid="ignore"):
            lim = (tilt < jt["tilt_min"]) | (tilt > jt["tilt_max"])
            lim |= defined & ((swivel < jt["swivel_min"]) | (swivel > jt["swivel_max"]))
            ina = jt["ina_coupled"] & defined & (np.abs(tilt) > np.deg2rad(75.0) - 2.0 / 3.0 * np.abs(swivel))
        bad_lim.append(lim)
        bad_ina.append(ina)
        labels += [f"{side} joint {i + 1}" for i in range(swivel.shape[1])]
    lim_all = np.concatenate(bad_lim, axis=1)
    ina_all = np.concatenate(bad_ina, axis=1)
    return (CheckResult(~lim_all.any(axis=1), Reason.JOINT_ANGLE, lim_all, labels),
            CheckResult(~ina_all.any(axis=1), Reason.INA_LIMIT, ina_all, labels))


def check_singularity(machine: Machine, kappa: np.ndarray | None = None, *,
                      singular: np.ndarray | None = None) -> CheckResult:
    """Singular if the condition number of J_C^-1 exceeds the threshold or is not finite (docs/theory/kinematics.md).

    Give either ``kappa`` (N,) or the ready decision ``singular`` (N,) bool, e.g. from
    :func:`pkmstiff.kinematics.singular_mask`, which needs κ only near the threshold.
    """
    if (kappa is None) == (singular is None):
        raise ValueError("check_singularity: expected exactly one of kappa (N,) or singular (N,) bool")
    bad = np.asarray(singular, bool) if kappa is None else ~(np.asarray(kappa) <= machine.limits.singularity_threshold)
    return CheckResult(~bad, Reason.SINGULAR)


def strut_pairs(n: int) -> list[tuple[int, int]]:
    return [(i, j) for i in range(n) for j in range(i + 1, n)]


def _kernel_array(x: np.ndarray) -> np.ndarray:
    """C-contiguous, writable float64 array (one compiled kernel signature for all callers)."""
    return np.require(x, dtype=np.float64, requirements=("C", "W"))


def _soa_points(x: np.ndarray) -> np.ndarray:
    """Per-chain points (N, n, 3) -> component-first (3, n, N) as used by the kernels (no copy for IK output)."""
    return _kernel_array(np.transpose(np.asarray(x, dtype=np.float64), (2, 1, 0)))


def check_strut_collision(machine: Machine, p: np.ndarray, q: np.ndarray) -> CheckResult:
    """B.7: struts i, j collide if the distance of their axes is below r_i + r_j (all pairs).

    Pairs that share a joint point in the geometry (same platform point or same fixed drive point) are skipped.
    The distance is the exact segment distance or Cobet's Table B.2 (``machine.limits.strut_collision_mode``),
    evaluated for every pair of every pose in one compiled loop (:func:`pkmstiff.kinematics.kernels.strut_collision`).
    """
    ch = machine.chains
    pairs = _collision_pairs(ch)
    if not pairs:
        return CheckResult(np.ones(p.shape[0], bool), Reason.STRUT_COLLISION, skipped="no strut pairs")
    mode = machine.limits.strut_collision_mode
    if mode not in ("exact", "table_B2"):
        raise ValueError(f"machine '{machine.name}': limits.strut_collision_mode: expected 'exact' or 'table_B2', "
                         f"found {mode!r}")
    ii = np.array([a for a, _ in pairs], dtype=np.int64)
    jj = np.array([b for _, b in pairs], dtype=np.int64)
    rsum = _kernel_array(ch.strut_radius[ii] + ch.strut_radius[jj])
    bad = np.empty((p.shape[0], len(pairs)), bool)
    _dispatch.run("strut_collision", p.shape[0], _soa_points(p), _soa_points(q), ii, jj, rsum, mode == "table_B2", bad)
    labels = [f"struts {a + 1}-{b + 1}" for a, b in pairs]
    return CheckResult(~bad.any(axis=1), Reason.STRUT_COLLISION, bad, labels)


_PAIR_CACHE: dict[int, tuple[Any, list[tuple[int, int]]]] = {}


def _collision_pairs(ch: Any) -> list[tuple[int, int]]:
    """Strut pairs that do not share a joint point, cached per chain table (the small-N path of the pipeline paid
    ~15 ``np.allclose`` calls per evaluation for this constant list)."""
    hit = _PAIR_CACHE.get(id(ch))
    if hit is None or hit[0] is not ch:  # the entry keeps the table alive: its id cannot be reused meanwhile
        pairs = [(i, j) for i, j in strut_pairs(ch.n)
                 if not np.allclose(ch.platform_joint[i], ch.platform_joint[j])
                 and not (ch.kind == "pod" and np.allclose(ch.drive_joint[i], ch.drive_joint[j]))]
        hit = _PAIR_CACHE[id(ch)] = (ch, pairs)
    return hit[1]


@dataclass(frozen=True)
class _HullCache:
    tri: np.ndarray  # (T, 3, 3) PKS
    edges: np.ndarray  # (E, 2, 3) PKS
    normals: np.ndarray  # (F, 3) unit outward normals of the convex hull's face planes
    offsets: np.ndarray  # (F,) n . x <= offset inside the convex hull


def _hull_cache(machine: Machine) -> _HullCache:
    """Kernel arrays of the platform hull (triangles, edges, face planes), computed once per hull object."""
    h = machine.hull

    def arrays() -> _HullCache:
        eq = h.face_planes()  # coplanar triangles share a plane
        return _HullCache(*(_kernel_array(x) for x in (h.vertices[h.triangles],
                                                       h.vertices[unique_edges(h.triangles)], eq[:, :3],
                                                       -eq[:, 3])))

    return memo(h, "_kernel_arrays", arrays)


def check_platform_collision(machine: Machine, q: np.ndarray, rot: np.ndarray, w: np.ndarray) -> CheckResult:
    """Strut-platform collision (Cobet Fig. B.3-B.5, eq. B.12 as corrected in the spec).

    The test runs in platform coordinates, where the hull is constant: strut i runs from p'_i to
    q'_i = R^T (q_i - w). A strut collides if (1) an edge of a hull triangle is closer to its axis than its radius,
    (2) its axis pierces a hull triangle (Cobet's two tests), or (3) an end of its axis is closer to a face than
    its radius (a strut ending above a face passes (1) and (2); with (3) the test is the exact segment-hull
    distance). A length (default: the strut radius) at the platform end is excluded because the strut's own joint
    lies on or near the hull (spec assumption). Broad phase (exact): Cyrus-Beck clipping against the convex hull
    with its face planes pushed out by the radius rejects struts that cannot touch; for a convex hull, clipping
    against the hull itself proves the collisions of struts that enter it. The exact tests (with early exit) run
    only on the remaining near misses. One compiled loop over poses and struts
    (:func:`pkmstiff.kinematics.kernels.platform_collision`); struts with NaN end points (unreachable) never collide.
    """
    ch = machine.chains
    n_pose = q.shape[0]
    if machine.hull.empty:
        return CheckResult(np.ones(n_pose, bool), Reason.PLATFORM_COLLISION, skipped="machine has no platform hull")
    hc = _hull_cache(machine)
    excl = ch.strut_radius if machine.limits.platform_end_exclusion is None else \
        np.full(ch.n, machine.limits.platform_end_exclusion)
    bad = np.empty((n_pose, ch.n), bool)
    _dispatch.run(
        "platform_collision", n_pose, _soa_points(q), _kernel_array(np.moveaxis(np.asarray(rot, dtype=np.float64), 0, 2)),
        _kernel_array(np.asarray(w, dtype=np.float64).T), _kernel_array(ch.platform_joint), _kernel_array(excl),
        _kernel_array(ch.strut_radius), hc.normals, hc.offsets, hc.tri, hc.edges, bool(machine.hull.convex), bad)
    labels = [f"strut {i + 1}" for i in range(ch.n)]
    return CheckResult(~bad.any(axis=1), Reason.PLATFORM_COLLISION, bad, labels)


def static_drive_loads(machine: Machine, jc: np.ndarray, rot: np.ndarray, data: DriveLoadData) -> np.ndarray:
    """Static drive loads tau_g = J_C^T g_P (eq. 4.90): the drive forces that hold the platform against gravity.

    g_P = (F, rho x F) with F = -m g_vec (the wrench at O' the drives must supply; g_vec points down).
    """
    force = -data.moved_mass * machine.gravity  # upward holding force, (3,)
    rho = np.einsum("nij,j->ni", rot, data.cog_offset)
    wrench = np.concatenate([np.broadcast_to(force, rho.shape), np.cross(rho, force)], axis=-1)
    return np.einsum("nji,nj->ni", jc, wrench)


def check_drive_load(machine: Machine, tau_g: np.ndarray | None, data: DriveLoadData | None) -> CheckResult:
    """B.13 (static case): admissible iff |tau_g,i| <= tau_max - tau_min - C_i for every drive."""
    if data is None or tau_g is None:
        n_pose = 0 if tau_g is None else tau_g.shape[0]
        return CheckResult(np.ones(n_pose, bool), Reason.DRIVE_LOAD,
                           skipped="no mass data (platform mass and drive force limits needed)")
    avail = data.max_force - data.force_reserve - (data.coulomb if machine.limits.drive_load_include_coulomb else 0.0)
    with np.errstate(invalid="ignore"):
        bad = ~(np.abs(tau_g) <= avail)
    return CheckResult(~bad.any(axis=1), Reason.DRIVE_LOAD, bad, [f"drive {i + 1}" for i in range(machine.n_chains)])


#: margin of the singularity check (docs/theory/kinematics.md, "Near-singular points"): an admissible pose whose κ
#: exceeds this fraction of ``limits.singularity_threshold`` is *near-singular*. It stays admissible (the spec's
#: threshold is the rule); statistics count and mark it, because there the stiffness and the eigenfrequencies fall
#: towards zero (Hexaglide, YZ section: k_x down to 3.5e-5 N/µm at κ ≈ 10⁴, while its 1 % quantile is 0.06 N/µm).
NEAR_SINGULAR_FRACTION = 1e-5


def near_singular_limit(machine: Machine) -> float:
    """κ above which an admissible pose counts as near-singular (:data:`NEAR_SINGULAR_FRACTION` of the threshold)."""
    return NEAR_SINGULAR_FRACTION * float(machine.limits.singularity_threshold)


def combine(n_pose: int, results: Iterable[CheckResult], reachable_pose: np.ndarray) -> Admissibility:
    """Combine check results into the mask and reason code; unreachable poses carry only UNREACHABLE."""
    reasons = np.zeros(n_pose, np.uint32)
    reasons[~reachable_pose] = int(Reason.UNREACHABLE)
    checks = {}
    for res in results:
        checks[res.reason.name.lower()] = res
        if res.skipped:
            continue
        reasons[reachable_pose & ~res.ok] |= np.uint32(int(res.reason))
    return Admissibility(ok=reasons == 0, reasons=reasons, checks=checks)


Requirement = Callable[[np.ndarray], np.ndarray]
