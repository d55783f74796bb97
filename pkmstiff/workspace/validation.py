"""Accuracy of the volume methods on the dissertation's regular bodies (docs/theory/workspace.md, Cobet Figs. 4.14-4.16).

Sphere of diameter 1000 mm (V = pi/6 m^3) and cube of edge 1000 mm (V = 1 m^3), centred slightly off the lattice
planes of the box [-0.8, 0.8]^3 m (an aligned face would lie exactly on voxel corners, which flatters or penalises
the methods depending on the inequality used); 1.6 m = 6.25 mm * 2**8, so eps = 50, 25, ..., 3.125 mm are reached
by repeated halving as in the dissertation.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from pkmstiff.workspace.octree import octree_boundary
from pkmstiff.workspace.volume import workspace_volume

CENTRE = np.array([0.0123, 0.0271, 0.0389])
BOX = (np.full(3, -0.8), np.full(3, 0.8))


def _sphere(p: np.ndarray) -> np.ndarray:
    return np.linalg.norm(p - CENTRE, axis=1) <= 0.5


def _cube(p: np.ndarray) -> np.ndarray:
    return np.all(np.abs(p - CENTRE) <= 0.5, axis=1)


BODIES: dict[str, tuple[Callable[[np.ndarray], np.ndarray], float]] = {
    "sphere d = 1000 mm": (_sphere, np.pi / 6), "cube 1000 mm": (_cube, 1.0)}


def volume_convergence(eps_values_m=(0.05, 0.025, 0.0125, 0.00625), refine_steps=(0, 3),
                       pyramid_z_near_boundary: bool = True) -> dict[str, dict[str, np.ndarray]]:
    """Relative volume errors in % per body and method over eps.

    Methods: pyramid (z at the centre, and near the boundary: 0.4 m from the centre along x), tetrahedron
    (eq. 4.14 on the eq. 4.1 points), divergence (signed sum on the same mesh), surface nets with each number of
    bisection steps in ``refine_steps``; keys ``"evaluations, surface nets K"`` hold the evaluations per eps.
    """
    out: dict[str, dict[str, np.ndarray]] = {}
    for body, (fn, exact) in BODIES.items():
        rows: dict[str, list[float]] = {}
        for eps in eps_values_m:
            res = octree_boundary(fn, *BOX, eps)
            rep = workspace_volume(res, ("pyramid", "tetrahedron", "divergence"))
            vals = {"pyramid (z at centre)": rep.volumes["pyramid"],
                    "tetrahedron (eq. 4.14)": rep.volumes["tetrahedron"],
                    "divergence (eq. 4.1 points)": rep.volumes["divergence"]}
            if pyramid_z_near_boundary:
                vals["pyramid (z near boundary)"] = workspace_volume(
                    res, ("pyramid",), z=CENTRE + [0.4, 0, 0]).volumes["pyramid"]
            for k in refine_steps:
                r = workspace_volume(res, ("surface_nets",), refine_steps=k, admissible=fn)
                vals[f"surface nets, {k} bisections"] = r.volumes["surface_nets"]
                rows.setdefault(f"evaluations, surface nets {k}", []).append(res.evaluations + r.refine_evaluations)
            for k, v in vals.items():
                rows.setdefault(k, []).append(100.0 * (v / exact - 1.0))
        out[body] = {k: np.array(v) for k, v in rows.items()}
    return out
