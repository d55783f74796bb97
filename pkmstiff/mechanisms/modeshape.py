"""Mode shapes of a mechanism's elastic model as displacements of the drawn link points (issue 27, item 1): the
counterpart of :mod:`pkmstiff.plots.modes` for mechanism files.

Every link is drawn through its joint points (and the output point) — :func:`link_points`.  A point of a rigid
link moves with the link's body, ``u + θ × (x − x_body)`` (the body's modal DOFs at its reference point); the two
end points of a strut link move with what the strut ends on (its node, or the body of the other link); the output
point of a flexible link moves with the link's tool body; the ground does not move.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import pkmstiff.multibody as sde
from pkmstiff.mechanisms.constraints import Frames
from pkmstiff.mechanisms.model import Mechanism
from pkmstiff.mechanisms.solver import Solution

Array = np.ndarray
#: joint types that place no point on the links they relate (orientation constraints)
_POINTLESS = ("fixed", "equal_orientation", "common_axis", "perpendicular_axes")


def link_points(mech: Mechanism) -> dict[int, list[tuple[np.ndarray, int]]]:
    """Home points of every link (link coordinates) with their joint index (−1: the output point), in the order a
    link's polygon is drawn."""
    pts: dict[int, list[tuple[np.ndarray, int]]] = {i: [] for i in range(len(mech.links))}
    for ji, jt in enumerate(mech.joints):
        if jt.type in _POINTLESS:
            continue
        for li in set(jt.links):
            pts[li].append((np.asarray(jt.point, float), ji))
    if mech.output is not None:
        pts[mech.output.link].append((np.asarray(mech.output.point, float), -1))
    return pts


@dataclass
class MechanismModeShape:
    """One mode at one configuration: ``world`` {link: (P, 3)} undeformed points [m] (planar z = 0), ``displacement``
    {link: (P, 3)} mass-normalised modal displacements of the same points, frequency [Hz] and dominant motion."""

    mode: int
    frequency_hz: float
    description: str
    world: dict[int, Array]
    displacement: dict[int, Array]

    def scale_for(self, amplitude: float) -> float:
        """Factor that makes the largest point displacement equal ``amplitude`` [m]."""
        peak = max((float(np.max(np.linalg.norm(d, axis=1))) for d in self.displacement.values() if len(d)),
                   default=0.0)
        return amplitude / peak if peak > 0 else 0.0


def mode_shapes(mech: Mechanism, sol: Solution, n_modes: int, point: Array | None = None
                ) -> list[MechanismModeShape]:
    """The ``n_modes`` lowest modes of the elastic model at the first configuration of ``sol`` (raises
    :class:`~pkmstiff.errors.NumericalError` where the stiffness matrix is singular); ``point``: the load point of
    :func:`~pkmstiff.mechanisms.structure.mechanism_structure` (the output point moves with its body either way)."""
    from pkmstiff.errors import InputError
    from pkmstiff.mechanisms.stiffness import take
    from pkmstiff.mechanisms.structure import _home3, mechanism_structure

    ms = mechanism_structure(mech, solution=take(sol, np.array([0])), point=point)
    if ms.model is None:
        raise InputError(mech.path or mech.name, "pose", "a configuration the elastic model can be built at",
                         "no configuration or a component outside its range")
    model = ms.model
    n_modes = min(n_modes, sde.dynamic_dofs(model))
    mr = sde.modes(model, n_modes, shapes=True)
    rigid = isinstance(model.body(ms.output_body), sde.RigidBody)
    descr = sde.describe_modes(model, mr.shapes, ms.output_body) if rigid else None
    pl = ms.plan
    F = Frames(sol.q[:1], mech.dim, derivatives=False)
    ends = {li: {e.joint: e for e in pair} for li, pair in pl.struts}
    out = []
    for k in range(n_modes):
        v = mr.shapes[0, k]

        def motion(body: str, x: Array, v: Array = v) -> Array:
            b = v[model.dof_index(body)]
            u = np.zeros(3)
            u[:min(3, b.size)] = b[:3]
            if b.size == 6:
                ref = np.asarray(model.body(body).position, float).reshape(-1, 3)[0]
                u = u + np.cross(b[3:6], x - ref)
            return u

        world, disp = {}, {}
        for li, plist in link_points(mech).items():
            if not plist or li in mech.ground:
                continue
            w, d = [], []
            for p, ji in plist:
                x = _home3(mech, F.t[0, li] + F.R[0, li] @ p)
                if ji < 0:  # the output point: the body its stiffness is evaluated on
                    body = ms.load_body
                elif li in ends:  # a strut: its end moves with its node or the body across the joint
                    e = ends[li][ji]
                    body = e.node or ("" if e.other in mech.ground else pl.body_name(e.other))
                else:
                    body = mech.links[li]
                w.append(x)
                d.append(motion(body, x) if body else np.zeros(3))
            world[li], disp[li] = np.array(w), np.array(d)
        text = sde.mode_label(descr[0][0, k], descr[1][0, k]) if descr is not None else ""
        out.append(MechanismModeShape(k + 1, float(mr.frequencies_hz[0, k]), text, world, disp))
    return out
