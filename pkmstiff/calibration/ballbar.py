"""Ball-bar (double ball bar, DBB) circular-test evaluation, vectorised over the samples.

What is computed (SI throughout: m, rad):

* radial deviations ``d_k`` of the actual path from the commanded path, measured along the bar
  (docs/theory/calibration.md: the reading is the distance between the two ball centres);
* a geometric least-squares circle fit in the plane of the run: centre offset, radius deviation, residuals;
* the minimum-zone circle (ISO 12181-2 MZCI) and the circularity about it (:func:`min_zone_circle`);
* the circular-test figures of ISO 230-4 as Szatmári §2.2.3.1 lists them: circular deviation G, radial
  deviation F (max / min), hysteresis H, per direction (CCW, CW);
* Fourier harmonics A0…An with phases (Szatmári eq. 4.9/4.10), the automatic choice of n (the region-B rule
  of Szatmári Fig. 4.29, made precise in :func:`choose_harmonics`) and the filtered reconstruction.

Readings of the sources (marked "Reading:" in the docstrings): Szatmári names G, F and H but does not define
them; the definitions follow ISO 230-4 (the standard the thesis cites) with the choices stated there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pkmstiff.calibration.instruments import BallbarMeasurement
from pkmstiff.errors import BallbarError, MeasurementFileError

Array = NDArray[np.float64]
TWO_PI = 2.0 * math.pi

# Planes by name: (first in-plane axis, second in-plane axis); the normal is e1 × e2, so an angle
# increasing from e1 towards e2 is counter-clockwise seen from the normal's tip (ISO 230-4 ZX plane: Z then X).
_PLANES = {
    "XY": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    "YZ": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "ZX": ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
    "XZ": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
}


# --------------------------------------------------------------------------------------------------- Fourier

@dataclass(frozen=True)
class Harmonics:
    """Fourier harmonics of a periodic deviation d(θ) = A0 + Σ_k A_k cos(kθ − φ_k) (Szatmári eq. 4.9/4.10).

    ``amplitude[0]`` is A0 = a0/2 (the mean, signed: radius deviation of the base circle), ``amplitude[k]``
    = A_k = √(a_k² + b_k²) ≥ 0 for k ≥ 1 [m]; ``phase[k]`` = φ_k = atan2(b_k, a_k) in [0, 2π) [rad]
    (Szatmári's case formula gives the same angle mod 2π). Physical meaning (Szatmári Fig. 4.27): A1, φ1
    centre displacement (magnitude and direction), A2 ovality, A3 three-lobe, A4 four-lobe form.
    ``n_samples`` samples were used, on a uniform angle grid if ``resampled`` is False, else after linear
    periodic interpolation onto a uniform grid of ``n_samples`` points (one revolution) or, for a run of
    several revolutions, averaged onto ``2·n_max + 1`` or ``2·n_max + 2`` angles of one revolution.
    """

    amplitude: Array
    phase: Array
    n_samples: int
    resampled: bool

    @property
    def n_max(self) -> int:
        """Highest harmonic available (below the Nyquist harmonic)."""
        return len(self.amplitude) - 1

    @property
    def cosine(self) -> Array:
        """a_k (with a_0 → A0) [m]."""
        return self.amplitude * np.cos(self.phase)

    @property
    def sine(self) -> Array:
        """b_k [m]."""
        return self.amplitude * np.sin(self.phase)

    def evaluate(self, theta: ArrayLike, n: int) -> Array:
        """Filtered reconstruction A0 + Σ_{k=1..n} A_k cos(kθ − φ_k) at angles ``theta`` [rad] (vectorised)."""
        return reconstruct(self, theta, n)


def _sorted_periodic(theta: Array, values: Array) -> tuple[Array, Array]:
    wrapped = np.mod(theta, TWO_PI)
    order = np.argsort(wrapped, kind="stable")
    return wrapped[order], values[order]


def _largest_gap(ts: Array) -> tuple[float, float]:
    """Largest angular gap between sorted wrapped angles, closing gap included; (gap, angle where it starts)."""
    gaps = np.diff(np.concatenate([ts, ts[:1] + TWO_PI]))
    i = int(np.argmax(gaps))
    return float(gaps[i]), float(ts[i])


def fourier_harmonics(theta: ArrayLike, deviation: ArrayLike, *, max_gap: float = math.radians(10.0),
                      source: str = "") -> Harmonics:
    """Harmonics of ``deviation`` [m] sampled at angles ``theta`` [rad] over one revolution, by FFT (Szatmári §4.5.2).

    ``theta`` may start anywhere and be in any order; angles are taken modulo 2π. If the samples lie on a
    uniform grid (spacing 2π/N to 1e-9 relative) the FFT is exact; otherwise the samples are sorted and
    interpolated linearly and periodically onto N uniform points (overshoot samples that revisit an angle
    are kept; interpolation then runs between them). A gap wider than ``max_gap`` [rad] between neighbouring
    samples is an error (the path is not a closed revolution). Cost: one sort and one real FFT, O(N log N).
    """
    th = np.asarray(theta, dtype=float).ravel()
    d = np.asarray(deviation, dtype=float).ravel()
    if th.shape != d.shape:
        raise BallbarError(f"angles and deviations differ in length ({th.size} vs {d.size})", source)
    n = th.size
    if n < 3:
        raise BallbarError(f"a Fourier evaluation needs at least 3 samples, found {n}", source)
    if not (np.all(np.isfinite(th)) and np.all(np.isfinite(d))):
        raise BallbarError("angles and deviations must be finite numbers (found NaN or inf)", source)
    revolutions = revolution_count(th)
    if revolutions >= MULTI_REVOLUTION:
        return _revolution_harmonics(th, d, revolutions, max_gap, source)
    ts, ds = _sorted_periodic(th, d)
    gap, at = _largest_gap(ts)
    step = TWO_PI / n
    if gap > max(max_gap, 1.5 * step):
        raise BallbarError(f"the samples do not cover a full revolution: gap of {math.degrees(gap):.3g} deg after "
                           f"{math.degrees(at):.4g} deg (allowed {math.degrees(max(max_gap, 1.5 * step)):.3g} deg)",
                           source)
    spacing = np.diff(ts)
    uniform = bool(np.all(np.abs(spacing - step) <= 1e-9 * step)) and abs(ts[0] + TWO_PI - ts[-1] - step) <= 1e-9 * step
    if uniform:
        theta0, values = float(ts[0]), ds
    else:
        theta0 = 0.0
        values = np.interp(np.arange(n) * step, ts, ds, period=TWO_PI)
    return _spectrum(values, theta0, n, not uniform)


#: a run whose commanded angle travels this many revolutions or more is analysed per revolution
#: (:func:`_revolution_harmonics`); one revolution with overshoot stays below it
MULTI_REVOLUTION = 1.5


def revolution_count(theta: ArrayLike) -> float:
    """Revolutions travelled by the commanded angle (time order): the span of the unwrapped angle / 2π."""
    u = np.unwrap(np.asarray(theta, dtype=float).ravel())
    return float((u.max() - u.min()) / TWO_PI) if u.size else 0.0


def _revolution_harmonics(th: Array, d: Array, revolutions: float, max_gap: float, source: str) -> Harmonics:
    """Harmonics of a run of several revolutions (the same circle travelled again), revolution by revolution:
    the samples are averaged onto the M = 2π / (median angle step) uniform angles of one revolution (nearest
    angle; an angle no sample reached is interpolated periodically), so the spectrum ends at the Nyquist harmonic of ONE
    revolution (M/2) — physics: the path repeats every revolution, harmonics above the per-revolution sampling
    are aliases — and memory and the harmonic count stay those of one revolution."""
    n = th.size
    steps = np.abs(np.diff(np.unwrap(th)))
    spacing = float(np.median(steps[steps > 0])) if np.any(steps > 0) else TWO_PI * revolutions / n
    m = int(min(max(3, round(TWO_PI / spacing)), n))  # the sampling of one revolution
    step = TWO_PI / m
    ts, _ = _sorted_periodic(th, d)
    gap, at = _largest_gap(ts)
    if gap > max(max_gap, 1.5 * step):
        raise BallbarError(f"the samples do not cover a full revolution: gap of {math.degrees(gap):.3g} deg after "
                           f"{math.degrees(at):.4g} deg (allowed {math.degrees(max(max_gap, 1.5 * step)):.3g} deg)",
                           source)
    bins = np.rint(np.mod(th, TWO_PI) / step).astype(np.int64) % m
    count = np.bincount(bins, minlength=m)
    total = np.bincount(bins, weights=d, minlength=m)
    have = count > 0
    grid = np.arange(m) * step
    values = np.interp(grid, grid[have], total[have] / count[have], period=TWO_PI)
    return _spectrum(values, 0.0, n, True)


def _spectrum(values: Array, theta0: float, n_samples: int, resampled: bool) -> Harmonics:
    """Amplitudes and phases of uniform ``values`` over one revolution starting at ``theta0`` (real FFT)."""
    n = values.size
    c = np.fft.rfft(values) / n
    kmax = (n - 1) // 2  # drop the Nyquist term of even N: its phase is undefined
    k = np.arange(kmax + 1)
    # d = Σ a_k cos kθ' + b_k sin kθ' with θ' = θ − θ0 gives C_k = a_k − i b_k = 2 c_k (k ≥ 1);
    # back to θ: C_k(θ) = C_k(θ') e^{−ikθ0}
    C = 2.0 * c[: kmax + 1] * np.exp(-1j * k * theta0)
    C[0] = c[0].real
    amp = np.abs(C)
    amp[0] = c[0].real  # A0 keeps its sign
    phase = np.mod(np.arctan2(-C.imag, C.real), TWO_PI)
    phase[0] = 0.0
    return Harmonics(amplitude=amp, phase=phase, n_samples=n_samples, resampled=resampled)


def reconstruct(harmonics: Harmonics, theta: ArrayLike, n: int) -> Array:
    """A0 + Σ_{k=1..n} A_k cos(kθ − φ_k) (Szatmári eq. 4.9 truncated after n terms), vectorised over ``theta``."""
    if not 0 <= n <= harmonics.n_max:
        raise BallbarError(f"number of harmonics must be in 0..{harmonics.n_max}, found {n}")
    th = np.asarray(theta, dtype=float)
    out = np.full(th.shape, harmonics.amplitude[0])
    if n:
        k = np.arange(1, n + 1)
        flat, res = th.reshape(-1), out.reshape(-1)
        rows = max(1, RECONSTRUCT_CHUNK // n)  # (rows, n) blocks: memory bounded for any N and n
        for i in range(0, flat.size, rows):
            res[i:i + rows] += np.cos(flat[i:i + rows, None] * k - harmonics.phase[1: n + 1]) \
                @ harmonics.amplitude[1: n + 1]
    return out


#: elements of one (samples × harmonics) block of :func:`reconstruct` (8 MB of float64)
RECONSTRUCT_CHUNK = 1 << 20


@dataclass(frozen=True)
class HarmonicChoice:
    """Number ``n`` of harmonics kept for the filtered reconstruction and how it was chosen.

    ``rule`` is "auto" (:func:`choose_harmonics`) or "fixed". For "auto": ``noise_sd`` is the estimated
    standard deviation of the white measurement noise per sample [m], ``threshold`` the amplitude [m] a
    harmonic must exceed to count as signal, ``alpha`` the false-alarm probability, ``candidates`` the
    number of harmonics searched (1..candidates).
    """

    n: int
    rule: Literal["auto", "fixed"]
    threshold: float = float("nan")
    noise_sd: float = float("nan")
    alpha: float = float("nan")
    candidates: int = 0


MIN_SAMPLES_AUTO = 64


def choose_harmonics(harmonics: Harmonics, *, alpha: float = 0.01, min_relative: float = 0.0,
                     source: str = "") -> HarmonicChoice:
    """Automatic number of harmonics: the region-B rule of Szatmári Fig. 4.29 made precise.

    Szatmári (§4.5.3) describes three regions over the number of Fourier coefficients: A (too few, the shape is
    lost), B (right: smooth path, noise removed), C (too many, noise kept), and notes (§4.5.2) that noise sits in
    the high harmonics. Criterion defined here (toolkit's reading; Szatmári gives no formula):

    1. Noise floor. White noise of standard deviation σ on N samples gives each harmonic k ≥ 1 a Rayleigh-
       distributed amplitude with scale s = σ √(2/N). s is estimated robustly from the band
       K/4 < k ≤ K/2 (K = highest harmonic), where a ball-bar run carries no machine error, as
       s² = median(A_k²) / (2 ln 2) (the median of an exponential variable with mean 2s²).
    2. Threshold. A harmonic among the candidates 1..K/4 is signal if A_k > T = s √(2 ln(K/4 / α)): then the
       probability that noise alone crosses T anywhere among the candidates is ≤ α (union bound,
       P(A > c s) = exp(−c²/2)). Optionally also A_k ≥ ``min_relative`` · max_{j≥1} A_j (Szatmári §4.5.2 notes
       that beyond the first 4–5 harmonics the rest are < 5 % of the largest; pass 0.05 to apply that too).
    3. n = the highest signal harmonic (0 if none): dropping it would leave region B towards A, adding more
       harmonics only adds noise (region C).

    Needs at least ``MIN_SAMPLES_AUTO`` samples (else give n explicitly).
    """
    if not 0.0 < alpha < 1.0:
        raise BallbarError(f"alpha must be in (0, 1), found {alpha}", source)
    if harmonics.n_samples < MIN_SAMPLES_AUTO:
        raise BallbarError(f"automatic choice of harmonics needs at least {MIN_SAMPLES_AUTO} samples, found "
                           f"{harmonics.n_samples}; give the number of harmonics explicitly", source)
    K = harmonics.n_max
    n_cand = max(K // 4, 1)
    band = harmonics.amplitude[n_cand + 1: K // 2 + 1]
    s2 = float(np.median(band**2)) / (2.0 * math.log(2.0))
    s = math.sqrt(s2)
    threshold = s * math.sqrt(2.0 * math.log(n_cand / alpha))
    cand = harmonics.amplitude[1: n_cand + 1]
    significant = cand > threshold
    if min_relative > 0 and cand.size:
        significant &= cand >= min_relative * float(cand.max())
    idx = np.flatnonzero(significant)
    n = int(idx[-1] + 1) if idx.size else 0
    noise_sd = s * math.sqrt(harmonics.n_samples / 2.0)
    return HarmonicChoice(n=n, rule="auto", threshold=threshold, noise_sd=noise_sd, alpha=alpha, candidates=n_cand)


def fixed_harmonics(harmonics: Harmonics, n: int, source: str = "") -> HarmonicChoice:
    """A user-given number of harmonics, checked against the spectrum length."""
    if not 0 <= n <= harmonics.n_max:
        raise BallbarError(f"number of harmonics must be in 0..{harmonics.n_max} for {harmonics.n_samples} "
                           f"samples, found {n}", source)
    return HarmonicChoice(n=n, rule="fixed")


# ---------------------------------------------------------------------------------------------- geometry

@dataclass(frozen=True)
class PlaneFrame:
    """Plane of a circular run: ``origin`` (the fixed ball projected into the plane) and orthonormal axes
    ``e1``, ``e2``, ``normal`` = e1 × e2 (all (3,), m); θ is measured from e1 towards e2."""

    origin: Array
    e1: Array
    e2: Array
    normal: Array
    name: str

    def coordinates(self, points: ArrayLike) -> Array:
        """In-plane coordinates (N, 2) of points (N, 3) [m]."""
        rel = np.asarray(points, dtype=float) - self.origin
        return np.stack([rel @ self.e1, rel @ self.e2], axis=-1)

    def to_space(self, uv: ArrayLike) -> Array:
        """Vectors (…, 3) from in-plane components (…, 2)."""
        uv = np.asarray(uv, dtype=float)
        return uv[..., :1] * self.e1 + uv[..., 1:2] * self.e2


def plane_frame(positions: ArrayLike, fixed_ball: ArrayLike, plane: str | ArrayLike = "auto",
                *, planar_tol: float = 1e-3, source: str = "") -> PlaneFrame:
    """Plane of the commanded ball positions (N, 3) [m].

    ``plane``: "XY", "YZ", "ZX" or "XZ" (axes as in ``_PLANES``), a normal vector (3,), or "auto" (the best-fit
    plane of the positions by SVD; its axes are the named plane's if the normal is within 1e-6 of a coordinate
    axis, otherwise e1 is the direction of the first sample). Positions farther than ``planar_tol`` times the
    circle radius from the plane are an error (a circle analysis needs a planar run).
    """
    P = np.asarray(positions, dtype=float)
    s = np.asarray(fixed_ball, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape[0] < 3:
        raise BallbarError(f"expected ball positions of shape (N >= 3, 3), found {P.shape}", source)
    centroid = P.mean(axis=0)
    if isinstance(plane, str):
        key = plane.upper()
        if key == "AUTO":
            _, _, vt = np.linalg.svd(P - centroid, full_matrices=False)
            nrm = vt[2]
            name = "auto"
            for pname, (a1, a2) in _PLANES.items():
                pn = np.cross(a1, a2)
                if abs(abs(nrm @ pn) - 1.0) < 1e-6 and pname != "XZ":
                    e1, e2, name = np.array(a1), np.array(a2), pname
                    break
            else:
                r0 = P[0] - centroid
                e1 = r0 - (r0 @ nrm) * nrm
                e1 /= np.linalg.norm(e1)
                e2 = np.cross(nrm, e1)
        elif key in _PLANES:
            e1, e2 = (np.array(v) for v in _PLANES[key])
            name = key
        else:
            raise BallbarError(f"plane must be one of XY, YZ, ZX, XZ, auto or a normal vector, found {plane!r}",
                               source)
    else:
        nrm = np.asarray(plane, dtype=float)
        if nrm.shape != (3,) or not np.linalg.norm(nrm) > 0:
            raise BallbarError(f"plane normal must be a non-zero 3-vector, found {plane!r}", source)
        nrm = nrm / np.linalg.norm(nrm)
        r0 = P[0] - centroid
        e1 = r0 - (r0 @ nrm) * nrm
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(nrm, e1)
        name = "normal"
    normal = np.cross(e1, e2)
    height = (P - centroid) @ normal
    radius = float(np.mean(np.linalg.norm((P - centroid) - np.outer(height, normal), axis=1)))
    spread = float(np.max(np.abs(height)))
    if spread > planar_tol * max(radius, 1e-12):
        raise BallbarError(f"the commanded ball positions are not in the {name} plane: out-of-plane spread "
                           f"{spread * 1e3:.4g} mm on a radius of {radius * 1e3:.4g} mm", source)
    origin = s + ((centroid - s) @ normal) * normal
    return PlaneFrame(origin=origin, e1=e1, e2=e2, normal=normal, name=name)


def radial_deviations(positions: ArrayLike, fixed_ball: ArrayLike, bar_length: float, reading: ArrayLike) -> Array:
    """Deviation of the actual from the commanded path along the bar [m], vectorised (docs/theory/calibration.md).

    The measured ball distance is ``bar_length + reading``; the commanded distance is |P_k − s|.
    """
    P = np.asarray(positions, dtype=float)
    s = np.asarray(fixed_ball, dtype=float)
    return bar_length + np.asarray(reading, dtype=float) - np.linalg.norm(P - s, axis=-1)


@dataclass(frozen=True)
class CircleFit:
    """Geometric least-squares circle in the plane: ``centre`` (2,) and ``radius`` [m]; ``residual`` (N,) =
    distance of each point from the circle (positive outside) [m]; ``iterations`` of Gauss–Newton."""

    centre: Array
    radius: float
    residual: Array
    iterations: int


def fit_circle(points: ArrayLike, *, max_iter: int = 20, source: str = "") -> CircleFit:
    """Geometric least-squares circle through in-plane points (N, 2) [m]: min Σ (|q_k − c| − r)².

    Gauss–Newton from the algebraic (Kåsa) fit, each step one (N × 3) least-squares solve; stops when the
    step is below 1e-14 of the radius (well under the 0.1 µm instrument resolution for any bar length).
    """
    q = np.asarray(points, dtype=float)
    if q.ndim != 2 or q.shape[1] != 2 or q.shape[0] < 3:
        raise BallbarError(f"a circle fit needs points of shape (N >= 3, 2), found {q.shape}", source)
    ref = q.mean(axis=0)
    qr = q - ref  # fit about the centroid for conditioning
    A = np.column_stack([2.0 * qr, np.ones(len(qr))])
    sol, *_ = np.linalg.lstsq(A, np.einsum("ij,ij->i", qr, qr), rcond=None)
    c = sol[:2]
    r = math.sqrt(max(sol[2] + c @ c, 0.0))
    it = 0
    for it in range(1, max_iter + 1):
        diff = qr - c
        dist = np.linalg.norm(diff, axis=1)
        if np.any(dist == 0):
            raise BallbarError("circle fit failed: a point coincides with the centre", source)
        res = dist - r
        J = np.column_stack([-diff / dist[:, None], -np.ones(len(qr))])
        step, *_ = np.linalg.lstsq(J, -res, rcond=None)
        c = c + step[:2]
        r = r + step[2]
        if np.max(np.abs(step)) <= 1e-14 * max(abs(r), 1e-300):
            break
    residual = np.linalg.norm(qr - c, axis=1) - r
    return CircleFit(centre=c + ref, radius=float(r), residual=residual, iterations=it)


@dataclass(frozen=True)
class MinimumZone:
    """Minimum-zone circle (ISO 12181-2 MZCI, the reference ISO 230-4 permits): ``centre`` (2,) [m] of the two
    concentric circles of least radial separation that enclose the points, ``outer``/``inner`` radii [m],
    ``circularity`` = outer − inner [m], ``iterations`` of the linearised LP."""

    centre: Array
    outer: float
    inner: float
    circularity: float
    iterations: int


def _zone(q: Array, c: Array) -> tuple[float, float]:
    rho = np.linalg.norm(q - c, axis=1)
    return float(rho.max()), float(rho.min())


def _zone_lp(u: Array, rs: Array, t: float, source: str) -> Any:
    """The linearised zone LP in scaled unknowns z = (δ1, δ2, R', r'): min R' − r' s.t. rs_k − u_k·δ ≤ R',
    rs_k − u_k·δ ≥ r', |δ_i| ≤ t; by constraint generation (exact): solved on the 32 outermost and innermost
    points, then the constraints the solution violates are added until none is (a ball-bar run has a handful
    of active points among thousands of samples)."""
    from scipy.optimize import linprog

    m = min(32, rs.size)
    order = np.argsort(rs)
    out_k, in_k = order[-m:], order[:m]
    c = np.array([0.0, 0.0, 1.0, -1.0])
    bounds = [(-t, t), (-t, t), (None, None), (None, None)]
    for _ in range(100):
        zo, zi = np.zeros((out_k.size, 1)), np.zeros((in_k.size, 1))
        A_ub = np.vstack([np.hstack([-u[out_k], -np.ones_like(zo), zo]), np.hstack([u[in_k], zi, np.ones_like(zi)])])
        b_ub = np.concatenate([-rs[out_k], rs[in_k]])
        lp = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs-ds",
                     options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10})
        if lp.status != 0:
            raise BallbarError(f"minimum-zone circle: the linear program failed ({lp.message})", source)
        v = rs - u @ lp.x[:2]
        tol = 1e-9  # of the zone width (the solver's tolerances are 1e-10)
        vo = np.setdiff1d(np.flatnonzero(v > lp.x[2] + tol), out_k)
        vi = np.setdiff1d(np.flatnonzero(v < lp.x[3] - tol), in_k)
        if not vo.size and not vi.size:
            return lp
        out_k = np.union1d(out_k, vo[np.argsort(v[vo])[-m:]])
        in_k = np.union1d(in_k, vi[np.argsort(v[vi])[:m]])
    raise BallbarError("minimum-zone circle: constraint generation did not converge", source)


def min_zone_circle(points: ArrayLike, *, start: ArrayLike | None = None, max_iter: int = 30,
                    source: str = "") -> MinimumZone:
    """Minimum-zone (Chebyshev) circle of in-plane points (N, 2) [m]: min over centres c of max|q_k − c| − min|q_k − c|.

    Method (toolkit's choice): sequential linear programming. About the current centre c0 the distances are
    linearised, ρ_k(c0 + δ) ≈ ρ_k − u_k·δ (u_k the unit vector c0 → q_k); the LP in (δ, R, r)
        min R − r   s.t.   ρ_k − u_k·δ ≤ R,   ρ_k − u_k·δ ≥ r,   |δ| ≤ trust
    (HiGHS dual simplex: a vertex solution, exact up to rounding; by constraint generation, :func:`_zone_lp`)
    gives the step; c0 ← c0 + δ while the exact
    zone width decreases, else the trust region is halved. The linearisation error is ≤ |δ|²/(2 min ρ), so for
    ball-bar profiles (µm deviations on ≥ 50 mm radii) two or three steps reach rounding level. The start is the
    least-squares centre (``start`` or :func:`fit_circle`); as every accepted step lowers the exact width, the
    result never exceeds the least-squares circularity. The LP is scaled to the current width (unknowns of
    order one) so the solver's tolerances are relative to the zone, not to the radius.
    """
    q = np.asarray(points, dtype=float)
    if q.ndim != 2 or q.shape[1] != 2 or q.shape[0] < 3 or not np.all(np.isfinite(q)):
        raise BallbarError(f"a minimum-zone circle needs finite points of shape (N >= 3, 2), found {q.shape}", source)
    ref = q.mean(axis=0)
    qr = q - ref
    c = (fit_circle(q, source=source).centre if start is None else np.asarray(start, dtype=float)) - ref
    R, r = _zone(qr, c)
    width = R - r
    trust = max(width, 1e-15 * max(R, 1e-300))
    it = 0
    for it in range(1, max_iter + 1):
        if width <= 1e-15 * R:
            break
        diff = qr - c
        rho = np.linalg.norm(diff, axis=1)
        u = diff / rho[:, None]
        s = width  # scale: unknowns in units of the current zone width
        rs = (rho - r) / s  # radii shifted by the inner radius (a well-conditioned LP)
        lp = _zone_lp(u, rs, trust / s, source)
        if (lp.x[2] - lp.x[3]) >= 1.0 - 1e-12:  # the linearised zone cannot shrink: c is optimal (convex LP)
            break
        cn = c + s * lp.x[:2]
        Rn, rn = _zone(qr, cn)
        if Rn - rn < width:
            step = float(np.linalg.norm(cn - c))
            c, R, r, width = cn, Rn, rn, Rn - rn
            if step <= 1e-15 * R:
                break
            trust = max(2.0 * step, 1e-15 * R)
        else:
            trust *= 0.25
            if trust <= 1e-15 * R:
                break
    return MinimumZone(centre=c + ref, outer=R, inner=r, circularity=width, iterations=it)


# ------------------------------------------------------------------------------------------ circular test

@dataclass(frozen=True)
class RunEvaluation:
    """Evaluation of one direction of a circular test (all lengths in m, angles in rad).

    ``theta`` (N,) sample angles in the plane, ``deviation`` (N,) radial deviation from the commanded path
    about the fixed ball; ``fit`` the least-squares circle of the actual points; ``centre_offset`` (2,) its
    centre relative to the fixed ball's projection (in-plane e1, e2 components), ``centre_offset_xyz`` (3,);
    ``radius_nominal`` mean commanded in-plane radius, ``radius_deviation`` = fit radius − nominal.
    ``circular_deviation`` G, ``radial_deviation_max``/``min`` F; ``harmonics``, ``choice`` and ``filtered``
    (N,) the reconstruction with ``choice.n`` harmonics at the samples.
    """

    direction: str
    theta: Array
    deviation: Array
    fit: CircleFit
    centre_offset: Array
    centre_offset_xyz: Array
    radius_nominal: float
    radius_deviation: float
    circular_deviation: float
    radial_deviation_max: float
    radial_deviation_min: float
    harmonics: Harmonics
    choice: HarmonicChoice
    filtered: Array
    circular_deviation_min_zone: float = float("nan")

    def to_dict(self, n_report: int | None = None) -> dict[str, Any]:
        """JSON-ready summary; lengths in µm (keys name units), angles in degrees."""
        um = 1e6
        n_rep = self.choice.n if n_report is None else n_report
        n_rep = min(max(n_rep, 4), self.harmonics.n_max)
        return {
            "direction": self.direction,
            "samples": int(self.theta.size),
            "circular_deviation_G_um": self.circular_deviation * um,
            "circular_deviation_G_min_zone_um": self.circular_deviation_min_zone * um,
            "radial_deviation_F_max_um": self.radial_deviation_max * um,
            "radial_deviation_F_min_um": self.radial_deviation_min * um,
            "centre_offset_um": (self.centre_offset * um).tolist(),
            "centre_offset_xyz_um": (self.centre_offset_xyz * um).tolist(),
            "centre_offset_magnitude_um": float(np.linalg.norm(self.centre_offset)) * um,
            "radius_nominal_mm": self.radius_nominal * 1e3,
            "radius_deviation_um": self.radius_deviation * um,
            "fit_rms_um": float(np.sqrt(np.mean(self.fit.residual**2))) * um,
            "harmonics": {
                "rule": self.choice.rule,
                "n": self.choice.n,
                "threshold_um": None if math.isnan(self.choice.threshold) else self.choice.threshold * um,
                "noise_sd_um": None if math.isnan(self.choice.noise_sd) else self.choice.noise_sd * um,
                "alpha": None if math.isnan(self.choice.alpha) else self.choice.alpha,
                "resampled": self.harmonics.resampled,
                "amplitude_um": (self.harmonics.amplitude[: n_rep + 1] * um).tolist(),
                "phase_deg": np.degrees(self.harmonics.phase[: n_rep + 1]).tolist(),
            },
            "filtered_rms_residual_um": float(np.sqrt(np.mean((self.deviation - self.filtered) ** 2))) * um,
        }


def evaluate_run(theta: ArrayLike, deviation: ArrayLike, radius_nominal: ArrayLike | float, *,
                 direction: str = "ccw", harmonics: int | Literal["auto"] = "auto", alpha: float = 0.01,
                 min_relative: float = 0.0, max_gap: float = math.radians(10.0), source: str = "") -> RunEvaluation:
    """Evaluate one circular run from in-plane angles θ (N,) [rad], radial deviations d (N,) [m] about the fixed
    ball and the commanded in-plane radius (scalar or (N,)) [m].

    Reading (ISO 230-4 as cited by Szatmári §2.2.3.1, not defined in the thesis):

    * circular deviation G = max − min of the radial distances of the actual points from the least-squares
      circle (ISO 230-4 allows the LSQ centre), and ``circular_deviation_min_zone`` the same about the
      minimum-zone centre (:func:`min_zone_circle`, ISO 12181-2 MZCI; never larger than G);
    * radial deviation F = the largest positive (F_max) and negative (F_min) deviation of the actual path from
      the nominal path, whose centre is the fixed ball (the ball bar is centred on the nominal centre);
    * centre offset and radius deviation from the same LSQ circle; to first order they equal (a1, b1) and A0
      of the Fourier series of d (Szatmári Fig. 4.27).
    """
    th = np.asarray(theta, dtype=float).ravel()
    d = np.asarray(deviation, dtype=float).ravel()
    rn = np.broadcast_to(np.asarray(radius_nominal, dtype=float), th.shape)
    h = fourier_harmonics(th, d, max_gap=max_gap, source=source)
    if harmonics == "auto":
        choice = choose_harmonics(h, alpha=alpha, min_relative=min_relative, source=source)
    else:
        choice = fixed_harmonics(h, int(harmonics), source)
    rho = rn + d
    pts = np.column_stack([rho * np.cos(th), rho * np.sin(th)])
    fit = fit_circle(pts, source=source)
    mz = min_zone_circle(pts, start=fit.centre, source=source)
    r_nom = float(np.mean(rn))
    return RunEvaluation(
        direction=direction, theta=th, deviation=d, fit=fit, centre_offset=fit.centre,
        centre_offset_xyz=np.full(3, np.nan), radius_nominal=r_nom, radius_deviation=fit.radius - r_nom,
        circular_deviation=float(fit.residual.max() - fit.residual.min()),
        radial_deviation_max=float(d.max()), radial_deviation_min=float(d.min()),
        harmonics=h, choice=choice, filtered=reconstruct(h, th, choice.n), circular_deviation_min_zone=mz.circularity)


def hysteresis(theta_a: ArrayLike, dev_a: ArrayLike, theta_b: ArrayLike, dev_b: ArrayLike,
               n_grid: int = 3600) -> float:
    """Circular hysteresis H = max over θ of |d_a(θ) − d_b(θ)| [m] between two runs in opposite directions.

    Reading (ISO 230-4, Szatmári §2.2.3.1 names H only): the largest radial difference between the CCW and CW
    paths, both about the fixed ball (common reference, no fit), compared on a grid of ``n_grid`` angles after
    linear periodic interpolation of each run.
    """
    grid = np.arange(n_grid) * (TWO_PI / n_grid)
    ta, da = _sorted_periodic(np.asarray(theta_a, dtype=float), np.asarray(dev_a, dtype=float))
    tb, db = _sorted_periodic(np.asarray(theta_b, dtype=float), np.asarray(dev_b, dtype=float))
    ga = np.interp(grid, ta, da, period=TWO_PI)
    gb = np.interp(grid, tb, db, period=TWO_PI)
    return float(np.max(np.abs(ga - gb)))


@dataclass(frozen=True)
class BallbarEvaluation:
    """Evaluation of a circular ball-bar test: one :class:`RunEvaluation` per direction present ("ccw", "cw"),
    hysteresis H (None unless both directions), circularity of all samples together about one LSQ circle [m],
    the plane frame, the bar length [m] and ``circularity_min_zone``: all samples about the minimum-zone centre
    (:func:`min_zone_circle`) [m], ≤ ``circularity``."""

    runs: dict[str, RunEvaluation]
    hysteresis: float | None
    circularity: float
    plane: PlaneFrame
    bar_length: float
    notes: list[str] = field(default_factory=list)
    circularity_min_zone: float = float("nan")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict; keys name their units (µm, mm, deg)."""
        return {
            "plane": self.plane.name,
            "plane_normal": self.plane.normal.tolist(),
            "bar_length_mm": self.bar_length * 1e3,
            "hysteresis_H_um": None if self.hysteresis is None else self.hysteresis * 1e6,
            "circularity_um": self.circularity * 1e6,
            "circularity_min_zone_um": self.circularity_min_zone * 1e6,
            "runs": {k: r.to_dict() for k, r in self.runs.items()},
            "notes": list(self.notes),
        }


def direction_labels(theta_time_ordered: ArrayLike) -> str:
    """"ccw" if the unwrapped angle increases over the run (counter-clockwise seen from the plane normal), else "cw"."""
    un = np.unwrap(np.asarray(theta_time_ordered, dtype=float))
    return "ccw" if un[-1] >= un[0] else "cw"


def evaluate_circular_test(positions: ArrayLike, reading: ArrayLike, fixed_ball: ArrayLike, bar_length: float, *,
                           direction: ArrayLike | None = None, plane: str | ArrayLike = "auto",
                           harmonics: int | Literal["auto"] = "auto", alpha: float = 0.01,
                           min_relative: float = 0.0, max_gap: float = math.radians(10.0),
                           source: str = "") -> BallbarEvaluation:
    """Full ball-bar evaluation from commanded moving-ball positions (N, 3) [m] in time order, instrument readings
    (N,) [m, relative to ``bar_length``], the fixed-ball position (3,) [m] and the bar length [m].

    ``direction`` (N,) of "ccw"/"cw" (or +1/−1) splits the samples into runs; without it the whole file is one
    run whose direction follows from the sense of rotation. Works in any plane (:func:`plane_frame`).
    """
    P = np.asarray(positions, dtype=float)
    s = np.asarray(fixed_ball, dtype=float)
    r = np.asarray(reading, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3 or r.shape != (P.shape[0],):
        raise BallbarError(f"expected positions (N, 3) and readings (N,), found {P.shape} and {r.shape}", source)
    frame = plane_frame(P, s, plane, source=source)
    d = radial_deviations(P, s, bar_length, r)
    uv = frame.coordinates(P)
    theta = np.arctan2(uv[:, 1], uv[:, 0])
    r_nom = np.linalg.norm(uv, axis=1)
    # in-plane projection of the deviation along the bar (the bar may leave the plane if the fixed ball does)
    along = np.linalg.norm(P - s, axis=1)
    d_plane = d * np.divide(r_nom, along, out=np.ones_like(along), where=along > 0)
    if direction is None:
        labels = np.full(P.shape[0], direction_labels(theta))
    else:
        raw = np.asarray(direction)
        if raw.dtype.kind in "iuf":
            labels = np.where(raw > 0, "ccw", "cw")
        else:
            labels = np.char.lower(raw.astype(str))
        bad = ~np.isin(labels, ("ccw", "cw"))
        if bad.any():
            raise BallbarError(f"direction must be 'ccw' or 'cw', found {raw[np.argmax(bad)]!r} at sample "
                               f"{int(np.argmax(bad))}", source)
    runs: dict[str, RunEvaluation] = {}
    for lab in ("ccw", "cw"):
        sel = labels == lab
        if not sel.any():
            continue
        run = evaluate_run(theta[sel], d_plane[sel], r_nom[sel], direction=lab, harmonics=harmonics, alpha=alpha,
                           min_relative=min_relative, max_gap=max_gap, source=f"{source} ({lab} run)" if source
                           else f"{lab} run")
        runs[lab] = replace(run, centre_offset_xyz=frame.to_space(run.centre_offset) + (frame.origin - s))
    H = None
    if len(runs) == 2:
        H = hysteresis(runs["ccw"].theta, runs["ccw"].deviation, runs["cw"].theta, runs["cw"].deviation)
    rho = r_nom + d_plane
    pts = np.column_stack([rho * np.cos(theta), rho * np.sin(theta)])
    allfit = fit_circle(pts, source=source)
    circ = float(allfit.residual.max() - allfit.residual.min())
    mz = min_zone_circle(pts, start=allfit.centre, source=source)
    return BallbarEvaluation(runs=runs, hysteresis=H, circularity=circ, plane=frame, bar_length=float(bar_length),
                             circularity_min_zone=mz.circularity)


def ball_positions(poses: ArrayLike, ball_offset: ArrayLike) -> Array:
    """Commanded moving-ball centres (N, 3) [m] from poses (N, 6) (x, y, z [m], a, b, c [rad]) and the ball offset
    in the pose frame (3,) [m]: p = o + R(a, b, c) v (docs/theory/calibration.md, with Δv = 0 for the commanded path)."""
    from pkmstiff.kinematics.rotation import cardan_matrix

    X = np.asarray(poses, dtype=float)
    v = np.asarray(ball_offset, dtype=float)
    R = cardan_matrix(X[:, 3], X[:, 4], X[:, 5])
    return X[:, :3] + R @ v


def commanded_poses(meas: Any, machine: Any = None, start_pose: ArrayLike | None = None, source: str = "") -> Array:
    """Commanded poses (N, 6) [m, rad] of a measurement: its pose columns, or — for a file with drive values only —
    the forward kinematics of ``machine`` (a :class:`~pkmstiff.machine.Machine`) from ``start_pose`` (6,)
    (Newton on the inverse kinematics, Cobet eq. A.12–A.17, all samples started from the same pose)."""
    if meas.poses is not None:
        return np.asarray(meas.poses, dtype=float)
    if machine is None or start_pose is None:
        raise BallbarError("the file has drive values but no commanded pose columns (x_mm … c_deg); give a machine "
                           "and a start pose for the forward kinematics (--machine, --start-pose)", source)
    from pkmstiff.kinematics import forward_kinematics

    q = np.asarray(meas.drives, dtype=float)
    if q.shape[1] != machine.n_chains:
        raise BallbarError(f"the file has {q.shape[1]} drive columns, machine '{machine.name}' has "
                           f"{machine.n_chains} drives", source)
    x0 = np.asarray(start_pose, dtype=float)
    if x0.shape != (6,) or not np.all(np.isfinite(x0)):
        raise BallbarError(f"start pose must be 6 finite numbers, found {start_pose!r}", source)
    fk = forward_kinematics(machine, q, x0)
    if not fk.converged.all():
        bad = int(np.flatnonzero(~fk.converged)[0])
        raise BallbarError(f"forward kinematics did not converge for {int((~fk.converged).sum())} of {len(q)} "
                           f"samples (first: sample {bad}, status {fk.status[bad]}); try a start pose nearer the "
                           f"path", source)
    return fk.poses


def evaluate_measurement(meas: Any, *, harmonics: int | Literal["auto"] = "auto", alpha: float = 0.01,
                         min_relative: float = 0.0, plane: str | ArrayLike | None = None, machine: Any = None,
                         start_pose: ArrayLike | None = None, source: str = "") -> BallbarEvaluation:
    """Evaluate a :class:`~pkmstiff.calibration.measurement_file.BallbarMeasurement` (a circular test).

    The commanded moving-ball positions come from the poses (:func:`commanded_poses`: the pose columns, or the
    forward kinematics of ``machine`` from ``start_pose`` for a drive-only file) and the header's ball offset.
    ``plane`` overrides the file's ``plane`` header.
    """
    if not isinstance(meas, BallbarMeasurement):
        kind = meas.instrument
        raise MeasurementFileError(source, None, f"a circular-test evaluation needs a ball-bar measurement, found a "
                                   f"{kind} file (instrument_type: {kind}); identify from it with 'pkmstiff "
                                   "calibrate identify'")
    P = ball_positions(commanded_poses(meas, machine, start_pose, source), meas.ball_offset)
    return evaluate_circular_test(P, meas.reading, meas.fixed_ball, meas.bar_length, direction=meas.direction,
                                  plane=meas.plane if plane is None else plane, harmonics=harmonics, alpha=alpha,
                                  min_relative=min_relative, source=source)
