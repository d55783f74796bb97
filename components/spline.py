"""Clamped cubic splines with the end-slope rule of Cobet 3.2.5 (docs/theory/components.md).

The end slopes are the secant slopes to the nearest neighbour,
``s'(x_0) = (y_1 - y_0)/(x_1 - x_0)`` and ``s'(x_N) = (y_N - y_{N-1})/(x_N - x_{N-1})``.
Because the spline is linear in the support values (the end slopes are linear in them too), a tensor
product of two such splines is the bicubic interpolant used for (swivel, tilt) grids.

Extrapolation outside the support range is a documented policy (``"clamp"`` = the end value, the spec's
Assumption; ``"error"`` raises :class:`~components.protocol.ComponentRangeError`). NaN abscissae give NaN.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Literal

import numpy as np

if TYPE_CHECKING:
    from scipy.interpolate import CubicSpline

from pkmstiff.errors import ArgumentError, ComponentRangeError

Extrapolation = Literal["clamp", "error"]
EXTRAPOLATION_POLICIES: tuple[str, ...] = ("clamp", "error")
_RANGE_TOL = 1e-12  # rad; absorbs round-off of angles computed exactly at a table end (e.g. arccos -> pi/2)


def _check_nodes(x: np.ndarray, what: str) -> None:
    if x.ndim != 1 or x.size < 2:
        raise ArgumentError(f"{what}: expected at least 2 support points in a 1-D array, found shape {x.shape}")
    if not np.all(np.isfinite(x)) or np.any(np.diff(x) <= 0):
        raise ArgumentError(f"{what}: support abscissae must be finite and strictly increasing, found "
                                 f"{x.tolist()}")


def secant_end_slopes(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """End slopes of the clamped spline: secant slopes to the nearest neighbour (along axis 0 of ``y``)."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    return (y[1] - y[0]) / (x[1] - x[0]), (y[-1] - y[-2]) / (x[-1] - x[-2])


def clamped_spline(x: np.ndarray, y: np.ndarray, what: str = "spline") -> CubicSpline:
    """Clamped cubic spline through ``(x, y)`` (``y`` may carry trailing axes) with secant end slopes."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    _check_nodes(x, what)
    if y.shape[0] != x.size:
        raise ArgumentError(f"{what}: {x.size} abscissae but {y.shape[0]} values")
    s0, sn = secant_end_slopes(x, y)
    from scipy.interpolate import CubicSpline  # here, not at import: scipy.interpolate takes ~0.5 s to import

    return CubicSpline(x, y, axis=0, bc_type=((1, s0), (1, sn)), extrapolate=True)


class PiecewiseCubic:
    """A cubic spline as its breakpoints ``x`` (m + 1,) and coefficients ``c`` (4, m, ...) in scipy's PPoly layout
    (``c[0]`` the cubic term). Holding only arrays, it is pickled without scipy: a cached machine
    (:mod:`pkmstiff.machine.cache`) is read and evaluated without importing scipy.interpolate (~0.5 s of start-up).

    Few points (below ``SCIPY_FROM``, while scipy.interpolate is not imported yet) are evaluated in numpy with the
    arithmetic of scipy's ``PPoly`` evaluation (interval by ``x[i] <= x < x[i+1]``, the last interval closed, the end
    intervals extrapolated; powers of the local coordinate accumulated from the constant term up), so the values
    equal scipy's bit for bit (tests/test_kernel_dispatch.py); batches go through scipy's compiled ``PPoly``.
    """

    __slots__ = ("x", "c", "_pp")

    #: evaluations of at least this many points use scipy's compiled PPoly (numpy's path is ~2x slower per point)
    SCIPY_FROM = 256

    def __init__(self, x: np.ndarray, c: np.ndarray) -> None:
        self.x = np.ascontiguousarray(x, dtype=float)
        self.c = np.ascontiguousarray(c, dtype=float)
        self._pp = None

    def __getstate__(self) -> tuple[np.ndarray, np.ndarray]:
        return self.x, self.c

    def __setstate__(self, state: tuple[np.ndarray, np.ndarray]) -> None:
        self.x, self.c = state
        self._pp = None

    def __call__(self, xq: np.ndarray, nu: int = 0) -> np.ndarray:
        """Value (``nu=0``) or ``nu``-th derivative at ``xq``; NaN at NaN."""
        xq = np.asarray(xq, dtype=float)
        if xq.size >= self.SCIPY_FROM or self._pp is not None or "scipy.interpolate" in sys.modules:
            if self._pp is None:
                from scipy.interpolate import PPoly

                self._pp = PPoly.construct_fast(self.c, self.x, extrapolate=True, axis=0)
            return self._pp(xq, nu)
        return self.evaluate_numpy(xq, nu)

    def evaluate_numpy(self, xq: np.ndarray, nu: int = 0) -> np.ndarray:
        """:meth:`__call__` in numpy (the arithmetic of scipy's PPoly evaluation, equal bit for bit)."""
        xq = np.asarray(xq, dtype=float)
        xf = xq.ravel()
        x, c = self.x, self.c
        k = c.shape[0]
        i = np.clip(np.searchsorted(x, xf, side="right") - 1, 0, x.size - 2)
        s = xf - x[i]
        cc = c.reshape(k, c.shape[1], -1)[:, i]  # (k, len(xq), P)
        res = np.zeros(cc.shape[1:])
        z = np.ones(xf.size)
        for kp in range(k):
            prefactor = 1.0
            for j in range(kp, kp - nu, -1):
                prefactor *= j
            res = res + cc[k - kp - 1] * z[:, None] * prefactor
            if kp < k - 1 and kp >= nu:
                z = z * s
        res[np.isnan(xf)] = np.nan
        return res.reshape(xq.shape + c.shape[2:])


def clamped_cubic(x: np.ndarray, y: np.ndarray, what: str = "spline") -> PiecewiseCubic:
    """:func:`clamped_spline` as a :class:`PiecewiseCubic` (built by scipy, evaluated without it)."""
    sp = clamped_spline(x, y, what)
    return PiecewiseCubic(sp.x, sp.c)


def apply_range_policy(
    value: np.ndarray, lo: float, hi: float, policy: str, *, angle: str, table: str, unit: str = "deg"
) -> np.ndarray:
    """Apply the extrapolation policy to abscissae ``value`` (rad) for a table covering ``[lo, hi]``.

    ``"clamp"`` clips to the range (NaN stays NaN); ``"error"`` raises naming the angle, the first
    offending value and the table range (in degrees when ``unit == "deg"``).
    """
    value = np.asarray(value, dtype=float)
    if policy == "clamp":
        return np.clip(value, lo, hi)
    if policy == "error":
        bad = (value < lo - _RANGE_TOL) | (value > hi + _RANGE_TOL)  # False for NaN
        if np.any(bad):
            idx = int(np.flatnonzero(bad.ravel())[0])
            conv = np.rad2deg if unit == "deg" else (lambda v: v)
            raise ComponentRangeError(
                f"{table}: {angle} = {conv(value.ravel()[idx]):.6g} {unit} (pose {idx}) lies outside the table range "
                f"[{conv(lo):.6g}, {conv(hi):.6g}] {unit} (extrapolation='error'; use 'clamp' to hold the end values)")
        return np.clip(value, lo, hi)  # only round-off excursions remain
    raise ArgumentError(f"{table}: unknown extrapolation policy {policy!r}, expected one of "
                             f"{EXTRAPOLATION_POLICIES}")


def spline_weights(x_nodes: np.ndarray, xq: np.ndarray) -> np.ndarray:
    """Weights ``W`` (len(xq), len(x_nodes)) with ``s(xq) = W @ y`` for the clamped end-slope spline.

    NaN entries of ``xq`` give rows of NaN.
    """
    x_nodes = np.asarray(x_nodes, dtype=float)
    basis = clamped_spline(x_nodes, np.eye(x_nodes.size))
    return basis(np.asarray(xq, dtype=float))
