"""Structured hexahedral meshes built from scikit-fem primitives (no external mesher).

Every primitive is a 2-D quadrilateral mesh of its cross-section (rectangle, O-grid disk, annulus,
rectangle with a circular hole) extruded along one coordinate axis and returned as a
:class:`skfem.MeshHex` (straight-edged, trilinear geometry). Curved surfaces are therefore polygonal
with ``n_phi`` facets around the circumference; that geometric error falls as (pi/n_phi)^2 and is part
of the mesh-convergence studies. Lengths are in m.

The parametric component models (joints, platform) are assemblies of such parts joined by tie
constraints (:mod:`pkmstiff.fe.ties`), so the parts need not share nodes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np
from skfem import MeshHex

from pkmstiff.errors import ArgumentError

Axis = Literal["x", "y", "z"]

# global = _PERM[axis] @ local: the primitive is built along local z; cyclic permutations keep the
# hexahedra right-handed.
_PERM: dict[str, np.ndarray] = {
    "z": np.eye(3),
    "x": np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
    "y": np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]),
}
_AXIS_INDEX = {"x": 0, "y": 1, "z": 2}




@dataclass(frozen=True)
class QuadMesh2D:
    """Planar quadrilateral mesh: ``points`` (2, n) in m, ``quads`` (4, m) counter-clockwise vertex indices."""

    points: np.ndarray
    quads: np.ndarray


def divisions(length: float, h: float, minimum: int = 1) -> int:
    """Number of elements of size at most ``h`` along ``length`` (at least ``minimum``)."""
    return max(minimum, int(math.ceil(length / h - 1e-9)))


def n_phi_for(radius: float, h: float, minimum: int = 8) -> int:
    """Circumferential division (multiple of 4) giving arcs of at most ``h`` on ``radius``."""
    return max(minimum, 4 * int(math.ceil(2.0 * math.pi * radius / (4.0 * h) - 1e-9)))


def rect2d(x0: float, x1: float, y0: float, y1: float, nx: int, ny: int) -> QuadMesh2D:
    """Tensor-product mesh of the rectangle [x0, x1] x [y0, y1]."""
    xs, ys = np.linspace(x0, x1, nx + 1), np.linspace(y0, y1, ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    idx = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    quads = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]]).reshape(4, -1)
    return QuadMesh2D(np.stack([X.ravel(), Y.ravel()]), quads)


def _ring_layers(inner: np.ndarray, outer: np.ndarray, n_rad: int, first_index: np.ndarray | None
                 ) -> tuple[list[np.ndarray], np.ndarray]:
    """Quads between a closed inner and outer polyline (both (2, N), same N, counter-clockwise).

    Layer 0 is ``inner``; if ``first_index`` is given, layer 0 reuses those existing point indices and
    only the layers 1..n_rad are returned as new points (numbered after ``first_index.max()``).
    """
    N = inner.shape[1]
    s = np.linspace(0.0, 1.0, n_rad + 1)
    layers = inner[:, None, :] + s[None, :, None] * (outer - inner)[:, None, :]  # (2, n_rad+1, N)
    if first_index is None:
        idx = np.arange((n_rad + 1) * N).reshape(n_rad + 1, N)
        new_points = layers.reshape(2, -1)
    else:
        start = int(first_index.max()) + 1
        idx = np.vstack([first_index[None, :], start + np.arange(n_rad * N).reshape(n_rad, N)])
        new_points = layers[:, 1:, :].reshape(2, -1)
    j, jn = np.arange(N), np.roll(np.arange(N), -1)
    quads = np.concatenate(
        [np.stack([idx[l, j], idx[l + 1, j], idx[l + 1, jn], idx[l, jn]]) for l in range(n_rad)], axis=1)
    return [new_points], quads


def disk2d(radius: float, n_phi: int, n_rad: int, core: float = 0.45) -> QuadMesh2D:
    """O-grid disk: a core square (half-width ``core*radius``) and ``n_rad`` blended layers to the circle.

    The circle nodes sit at the uniform angles -45 deg + 360 deg * j / n_phi (``n_phi`` multiple of 4),
    so a tube built with :func:`annulus2d` and ``phase = -pi/4`` has matching nodes.
    """
    if n_phi % 4 or n_phi < 4:
        raise ArgumentError(f"disk2d: n_phi must be a positive multiple of 4, found {n_phi}")
    if not 0.1 <= core <= 0.65:
        raise ArgumentError(f"disk2d: core fraction must lie in [0.1, 0.65], found {core}")
    ns = n_phi // 4
    a = core * radius
    c = a * np.tan(-np.pi / 4 + np.arange(ns + 1) * (np.pi / 2) / ns)
    core_mesh = rect2d(0.0, 1.0, 0.0, 1.0, ns, ns)
    X, Y = np.meshgrid(c, c, indexing="ij")
    core_points = np.stack([X.ravel(), Y.ravel()])

    def cidx(i: np.ndarray, k: np.ndarray) -> np.ndarray:
        return i * (ns + 1) + k

    j = np.arange(ns)
    perim = np.concatenate([cidx(np.full(ns, ns), j), cidx(ns - j, np.full(ns, ns)),
                            cidx(np.zeros(ns, int), ns - j), cidx(j, np.zeros(ns, int))])
    phi = -np.pi / 4 + 2 * np.pi * np.arange(n_phi) / n_phi
    circle = radius * np.stack([np.cos(phi), np.sin(phi)])
    new, ring_quads = _ring_layers(core_points[:, perim], circle, n_rad, perim)
    return QuadMesh2D(np.hstack([core_points] + new), np.hstack([core_mesh.quads, ring_quads]))


def annulus2d(r_inner: float, r_outer: float, n_phi: int, n_rad: int, phase: float = -np.pi / 4) -> QuadMesh2D:
    """Annulus with ``n_phi`` uniform angular and ``n_rad`` radial divisions (first node at ``phase``)."""
    if not 0.0 < r_inner < r_outer:
        raise ArgumentError(f"annulus2d: expected 0 < r_inner < r_outer, found {r_inner}, {r_outer}")
    phi = phase + 2 * np.pi * np.arange(n_phi) / n_phi
    u = np.stack([np.cos(phi), np.sin(phi)])
    new, quads = _ring_layers(r_inner * u, r_outer * u, n_rad, None)
    return QuadMesh2D(new[0], quads)


def rect_with_hole2d(hx: float, hy: float, radius: float, nx: int, ny: int, n_rad: int) -> QuadMesh2D:
    """Rectangle [-hx, hx] x [-hy, hy] with a centred circular hole, O-grid from the hole to the sides.

    ``nx`` (``ny``) segments on each side parallel to x (y); the hole nodes are the radial projections
    of the side nodes.
    """
    if not 0.0 < radius < min(hx, hy):
        raise ArgumentError(
            f"rect_with_hole2d: expected 0 < hole radius < half-widths ({hx:g}, {hy:g}) m, found {radius:g} m")
    ty = np.linspace(-hy, hy, ny + 1)[:-1]
    tx = np.linspace(hx, -hx, nx + 1)[:-1]
    side = np.concatenate([
        np.stack([np.full(ny, hx), ty]), np.stack([tx, np.full(nx, hy)]),
        np.stack([np.full(ny, -hx), -ty]), np.stack([-tx, np.full(nx, -hy)])], axis=1)
    hole = radius * side / np.linalg.norm(side, axis=0)
    new, quads = _ring_layers(hole, side, n_rad, None)
    return QuadMesh2D(new[0], quads)


def extrude(q: QuadMesh2D, z: Sequence[float] | np.ndarray) -> MeshHex:
    """Extrude a planar quad mesh along local z through the increasing coordinates ``z``."""
    z = np.asarray(z, dtype=float)
    if z.ndim != 1 or z.size < 2 or np.any(np.diff(z) <= 0):
        raise ArgumentError(f"extrude: expected at least 2 increasing z values, found {z}")
    n2, nz = q.points.shape[1], z.size
    p = np.vstack([np.tile(q.points, nz), np.repeat(z, n2)])
    v = q.quads  # (4, m): (0,0), (1,0), (1,1), (0,1) in the quad's (xi, eta)
    layers = []
    for m in range(nz - 1):
        lo, hi = v + m * n2, v + (m + 1) * n2
        # skfem's MeshHex vertex order (as in MeshHex.init_tensor):
        # V000, V010, V100, V001, V110, V011, V101, V111 with V(xi, eta, zeta)
        layers.append(np.stack([lo[0], lo[3], lo[1], hi[0], lo[2], hi[3], hi[1], hi[2]]))
    return MeshHex(p, np.hstack(layers).astype(np.int64))


def _placed(mesh: MeshHex, axis: Axis, origin: np.ndarray) -> MeshHex:
    p = _PERM[axis] @ mesh.p + np.asarray(origin, dtype=float).reshape(3, 1)
    return MeshHex(p, mesh.t)


def _axis_of(p0: np.ndarray, p1: np.ndarray, what: str) -> tuple[Axis, np.ndarray, np.ndarray]:
    """Axis name and (start, end) ordered so that the extrusion runs in the positive axis direction."""
    d = np.asarray(p1, float) - np.asarray(p0, float)
    k = int(np.argmax(np.abs(d)))
    if abs(d[k]) == 0 or np.count_nonzero(np.abs(d) > 1e-12 * abs(d[k])) != 1:
        raise ArgumentError(f"{what}: end points must differ along exactly one coordinate axis, found {p0} -> {p1}")
    axis = "xyz"[k]
    a, b = np.asarray(p0, float), np.asarray(p1, float)
    return (axis, a, b) if d[k] > 0 else (axis, b, a)  # type: ignore[return-value]


def _zs(length: float, h: float, nz: int | None) -> np.ndarray:
    return np.linspace(0.0, length, (nz or divisions(length, h)) + 1)


def box(lo: Sequence[float], hi: Sequence[float], h: float, n: Sequence[int] | None = None) -> MeshHex:
    """Axis-aligned box between the corners ``lo`` and ``hi``, element edges at most ``h``."""
    lo_, hi_ = np.asarray(lo, float), np.asarray(hi, float)
    if np.any(hi_ <= lo_):
        raise ArgumentError(f"box: expected hi > lo in every coordinate, found lo={lo_}, hi={hi_}")
    counts = n if n is not None else [divisions(hi_[k] - lo_[k], h) for k in range(3)]
    return MeshHex.init_tensor(*(np.linspace(lo_[k], hi_[k], counts[k] + 1) for k in range(3)))


def cylinder(p0: Sequence[float], p1: Sequence[float], radius: float, h: float, n_phi: int | None = None,
             n_z: int | None = None) -> MeshHex:
    """Solid circular cylinder (O-grid) with axis from ``p0`` to ``p1`` (parallel to a coordinate axis)."""
    axis, a, b = _axis_of(np.asarray(p0), np.asarray(p1), "cylinder")
    if radius <= 0:
        raise ArgumentError(f"cylinder: radius must be positive, found {radius}")
    n_phi = n_phi or n_phi_for(radius, h)
    core = 0.45
    n_rad = divisions(radius * (1 - core), h)
    length = float(np.linalg.norm(b - a))
    return _placed(extrude(disk2d(radius, n_phi, n_rad, core), _zs(length, h, n_z)), axis, a)


def tube(p0: Sequence[float], p1: Sequence[float], r_inner: float, r_outer: float, h: float,
         n_phi: int | None = None, n_rad: int | None = None, n_z: int | None = None) -> MeshHex:
    """Hollow circular cylinder (ring) with axis from ``p0`` to ``p1``; nodes at -45 deg + k 360 deg/n_phi."""
    axis, a, b = _axis_of(np.asarray(p0), np.asarray(p1), "tube")
    n_phi = n_phi or n_phi_for(r_outer, h)
    n_rad = n_rad or divisions(r_outer - r_inner, h)
    length = float(np.linalg.norm(b - a))
    return _placed(extrude(annulus2d(r_inner, r_outer, n_phi, n_rad), _zs(length, h, n_z)), axis, a)


def block_with_bore(lo: Sequence[float], hi: Sequence[float], axis: Axis, radius: float, h: float,
                    n_rad: int | None = None, n_phi: int | None = None) -> MeshHex:
    """Box between ``lo`` and ``hi`` with a through bore of ``radius`` along ``axis`` through its centre.

    ``n_phi`` (optional): total number of segments around the bore (split over the four sides in
    proportion to their lengths); default: sides divided into segments of at most ``h``.
    """
    lo_, hi_ = np.asarray(lo, float), np.asarray(hi, float)
    if np.any(hi_ <= lo_):
        raise ArgumentError(f"block_with_bore: expected hi > lo, found lo={lo_}, hi={hi_}")
    P = _PERM[axis]
    # local extents: local = P^T global
    llo, lhi = P.T @ lo_, P.T @ hi_
    hx, hy = (lhi[0] - llo[0]) / 2, (lhi[1] - llo[1]) / 2
    wall = min(hx, hy) - radius
    if wall <= 0:
        raise ArgumentError(
            f"block_with_bore: bore radius {radius:g} m must be smaller than the half-widths ({hx:g}, {hy:g}) m")
    n_rad = n_rad or divisions(wall, h)
    if n_phi:
        nx = max(2, int(round(n_phi / 2 * hx / (hx + hy))))
        ny = max(2, n_phi // 2 - nx)
    else:
        nx, ny = divisions(2 * hx, h, 2), divisions(2 * hy, h, 2)
    q = rect_with_hole2d(hx, hy, radius, nx, ny, n_rad)
    m = extrude(q, _zs(lhi[2] - llo[2], h, None))
    centre_local = np.array([(llo[0] + lhi[0]) / 2, (llo[1] + lhi[1]) / 2, llo[2]])
    return _placed(m, axis, P @ centre_local)


def transformed(mesh: MeshHex, R: np.ndarray, t: Sequence[float] = (0.0, 0.0, 0.0)) -> MeshHex:
    """Rigidly moved copy ``x -> R x + t`` of a mesh (``R`` a proper rotation)."""
    return MeshHex(np.asarray(R, float) @ mesh.p + np.asarray(t, float).reshape(3, 1), mesh.t)


def rotation(axis: Sequence[float], angle: float) -> np.ndarray:
    """Rotation matrix about the unit vector ``axis`` by ``angle`` (rad), Rodrigues' formula."""
    k = np.asarray(axis, float)
    k = k / np.linalg.norm(k)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)


def mesh_volume(mesh: MeshHex) -> float:
    """Volume of a hexahedral mesh in m^3 (sum of the trilinear element volumes)."""
    from skfem import Basis, ElementHex1

    return float(Basis(mesh, ElementHex1(), intorder=2).dx.sum())
