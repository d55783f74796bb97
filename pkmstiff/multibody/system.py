"""The generic SDE multibody model: bodies, stiffness–damping elements and rigid bindings (docs/theory/structure.md).

DOF ordering: bodies in the order they were added, 3 DOF per point mass ``(u_x, u_y, u_z)`` and 6 per rigid body
``(u_x, u_y, u_z, θ_x, θ_y, θ_z)`` (global axes, reference point = CoG); the frame has none.  Every quantity may
differ per pose (leading pose axis of length N, or none/1 to broadcast).
"""

from __future__ import annotations

import copy
from typing import Any, Iterable, Sequence

import numpy as np

from pkmstiff.errors import InputError
from pkmstiff.multibody.bodies import FRAME, Body, RigidBody, make_point_mass, make_rigid_body
from pkmstiff.multibody.elements import BindingKind, MatrixSpec, RigidBinding, SDESet, matrix_spec
from pkmstiff.multibody.inputs import common_poses, pose_array

DOF_NAMES = ("ux", "uy", "uz", "rx", "ry", "rz")


class SDEModel:
    """Container of bodies, SDE sets and rigid bindings with the DOF map.

    Build it with :meth:`add_point_mass`, :meth:`add_rigid_body`, :meth:`add_sde` / :meth:`add_sde_set` and
    :meth:`add_rigid_binding`; analyse it with the functions of :mod:`pkmstiff.multibody` (they chunk over poses).
    """

    def __init__(self) -> None:
        self._bodies: dict[str, Body] = {}
        self._sets: list[SDESet] = []
        self._bindings: list[RigidBinding] = []
        self._element_names: set[str] = set()
        self._cache: dict[Any, Any] = {}
        self._n_poses = 1
        self._view = False

    # ------------------------------------------------------------------ building
    def _check_mutable(self) -> None:
        if self._view:
            raise InputError("SDEModel", "poses view", "a full model (views are read-only)", "a view")
        self._cache.clear()

    def _update_poses(self, arrays: Iterable[np.ndarray], source: str) -> None:
        self._n_poses = common_poses([self._n_poses] + [a.shape[0] for a in arrays], source)

    def add_body(self, body: Body) -> slice:
        """Add a pre-built :class:`PointMass` or :class:`RigidBody`; returns its DOF slice."""
        self._check_mutable()
        if body.name == FRAME or body.name in self._bodies:
            raise InputError("SDEModel", "body name", f"a new name other than '{FRAME}'", body.name)
        arrays = [body.mass, body.position] + ([body.inertia] if isinstance(body, RigidBody) else [])
        self._update_poses(arrays, f"body '{body.name}'")
        self._bodies[body.name] = body
        return self.dof_index(body.name)

    def add_point_mass(self, name: str, mass: Any, position: Any = (0.0, 0.0, 0.0)) -> slice:
        """Point mass (3 DOF): ``mass`` kg, ``position`` m (scalar/(3,) or with pose axis)."""
        return self.add_body(make_point_mass(name, mass, position))

    def add_rigid_body(self, name: str, mass: Any, position: Any, inertia: Any, rotation: Any | None = None) -> slice:
        """Rigid body (6 DOF): CoG ``position`` (m), ``inertia`` about the CoG (kg m²; body axes if ``rotation``)."""
        return self.add_body(make_rigid_body(name, mass, position, inertia, rotation))

    def _side_kind(self, name: str, source: str) -> str:
        if name == FRAME:
            return "frame"
        if name not in self._bodies:
            raise InputError(source, "body", f"an existing body or '{FRAME}' (known: {list(self._bodies)})", name)
        return "rigid" if isinstance(self._bodies[name], RigidBody) else "point"

    def add_sde_set(
        self,
        names: Sequence[str],
        body_a: Sequence[str] | str,
        body_b: Sequence[str] | str,
        point: Any,
        *,
        k: Any = None,
        axis: Any = None,
        stiffness: Any = None,
        c: Any = None,
        damping: Any = None,
        groups: Sequence[str] | str | None = None,
        check_psd: bool = True,
    ) -> None:
        """Add E elements at once (shapes with E, optional leading pose axis N).

        ``point`` (E, 3) coupling points (m).  Stiffness: ``k`` (E,) N/m along ``axis`` (E, 3), or ``stiffness``
        (E, 3, 3) in N/m resp. (E, 6, 6) in N/m, N, N m/rad blocks.  Damping: ``c`` along the same ``axis`` (N s/m)
        or ``damping`` matrices of the same size as the stiffness; optional.  All elements of a set must have the
        same kind of body on side a (frame / point mass / rigid body) and the same on side b.
        """
        self._check_mutable()
        names = tuple(names)
        n_el = len(names)
        source = f"SDE set {list(names)[:3]}{'...' if n_el > 3 else ''}"
        if n_el == 0:
            raise InputError(source, "names", "at least one element", "none")
        dupl = [n for n in names if n in self._element_names] + [n for i, n in enumerate(names) if n in names[:i]]
        if dupl:
            raise InputError(source, "names", "unique element names", f"duplicates {dupl}")
        side_a = (body_a,) * n_el if isinstance(body_a, str) else tuple(body_a)
        side_b = (body_b,) * n_el if isinstance(body_b, str) else tuple(body_b)
        if len(side_a) != n_el or len(side_b) != n_el:
            raise InputError(source, "body_a/body_b", f"{n_el} body names", f"{len(side_a)}/{len(side_b)}")
        kinds_a = {self._side_kind(b, source) for b in side_a}
        kinds_b = {self._side_kind(b, source) for b in side_b}
        if len(kinds_a) != 1 or len(kinds_b) != 1:
            raise InputError(source, "body_a/body_b", "one kind of body per side within a set",
                                f"{kinds_a}/{kinds_b}")
        for a, b in zip(side_a, side_b):
            if a == b:
                raise InputError(source, "body_a/body_b", "two different bodies", f"'{a}' twice")
        stiff = matrix_spec(source, "stiffness", n_el, k=k, axis=axis, matrix=stiffness, check_psd=check_psd)
        if stiff.dim == 6 and ({"point"} & (kinds_a | kinds_b)):
            raise InputError(source, "stiffness", "3x3 stiffness for elements on point masses", "6x6")
        if "frame" in kinds_a and "frame" in kinds_b:
            raise InputError(source, "body_a/body_b", "at least one moving body", "frame on both sides")
        damp: MatrixSpec | None = None
        if c is not None or damping is not None:
            damp = matrix_spec(source, "damping", n_el, k=c, axis=axis if c is not None else None, matrix=damping,
                               check_psd=check_psd)
            if damp.dim != stiff.dim:
                raise InputError(source, "damping", f"{stiff.dim}x{stiff.dim} like the stiffness",
                                    f"{damp.dim}x{damp.dim}")
        pts = pose_array(point, (n_el, 3), source, "point")
        if groups is None:
            grp = names
        elif isinstance(groups, str):
            grp = (groups,) * n_el
        else:
            grp = tuple(groups)
            if len(grp) != n_el:
                raise InputError(source, "groups", f"{n_el} group names", len(grp))
        arrays = [pts, stiff.matrix if stiff.matrix is not None else stiff.k]
        if stiff.axis is not None:
            arrays.append(stiff.axis)
        if damp is not None:
            arrays.append(damp.matrix if damp.matrix is not None else damp.k)
        self._update_poses(arrays, source)
        self._sets.append(SDESet(names, side_a, side_b, pts, stiff, damp, grp))
        self._element_names.update(names)

    def add_sde(
        self,
        name: str,
        body_a: str,
        body_b: str,
        point: Any,
        *,
        k: Any = None,
        axis: Any = None,
        stiffness: Any = None,
        c: Any = None,
        damping: Any = None,
        group: str | None = None,
        check_psd: bool = True,
    ) -> None:
        """Add one SDE between ``body_a`` and ``body_b`` at ``point`` ((3,) or (N, 3), m).

        Stiffness ``k`` (scalar or (N,), N/m) along ``axis`` ((3,) or (N, 3)) -> ``k n nᵀ``, or ``stiffness``
        ((3, 3)/(6, 6) or with pose axis).  Damping ``c`` (N s/m along ``axis``) or ``damping`` matrix, optional.
        """
        def el(value: Any, core_ndim: int) -> Any:
            if value is None:
                return None
            arr = np.asarray(value, dtype=float)
            return np.expand_dims(arr, arr.ndim - core_ndim)  # insert the element axis before the core shape

        self.add_sde_set(
            [name], body_a, body_b, el(point, 1), k=el(k, 0), axis=el(axis, 1), stiffness=el(stiffness, 2),
            c=el(c, 0), damping=el(damping, 2), groups=None if group is None else [group], check_psd=check_psd,
        )

    def add_rigid_binding(
        self, name: str, body_a: str, body_b: str, point: Any, *, kind: BindingKind | None = None, axis: Any = None
    ) -> None:
        """Rigid connection at ``point`` (m), eliminated exactly by a null-space basis (docs/theory/structure.md, preferred method).

        ``kind``: ``"axial"`` (needs ``axis``: rigid strut), ``"point"`` (no relative translation), ``"full"`` (also
        no relative rotation; both sides rigid or frame), ``"angular"`` (needs ``axis``: no relative rotation about
        it; both sides rigid or frame).  Default: ``"axial"`` if ``axis`` is given, else ``"full"``
        between rigid bodies/frame and ``"point"`` otherwise.
        """
        self._check_mutable()
        source = f"rigid binding '{name}'"
        if name in self._element_names or any(b.name == name for b in self._bindings):
            raise InputError(source, "name", "a new name", name)
        ka, kb = self._side_kind(body_a, source), self._side_kind(body_b, source)
        if body_a == body_b or (ka == "frame" and kb == "frame"):
            raise InputError(source, "body_a/body_b", "two different bodies, at least one moving", (body_a, body_b))
        if kind is None:
            kind = "axial" if axis is not None else ("point" if "point" in (ka, kb) else "full")
        if kind not in ("axial", "point", "full", "angular"):
            raise InputError(source, "kind", "'axial', 'point', 'full' or 'angular'", kind)
        if kind in ("full", "angular") and "point" in (ka, kb):
            raise InputError(source, "kind", "'point' or 'axial' for a point mass", kind)
        ax = None
        if kind in ("axial", "angular"):
            if axis is None:
                raise InputError(source, "axis", "a direction (3,) for an axial binding", None)
            ax = pose_array(axis, (3,), source, "axis")
            norm = np.linalg.norm(ax, axis=-1)
            if np.any(norm < 1e-12):
                raise InputError(source, "axis", "a non-zero direction", "zero vector")
            ax = ax / norm[:, None]
        pts = pose_array(point, (3,), source, "point")
        self._update_poses([pts] + ([ax] if ax is not None else []), source)
        self._bindings.append(RigidBinding(name, body_a, body_b, pts, kind, ax))

    # ------------------------------------------------------------------ queries
    @property
    def n_poses(self) -> int:
        """Number of poses N (1 if every quantity is pose-independent)."""
        return self._n_poses

    @property
    def bodies(self) -> list[Body]:
        return list(self._bodies.values())

    @property
    def body_names(self) -> list[str]:
        return list(self._bodies)

    def body(self, name: str) -> Body:
        if name not in self._bodies:
            raise InputError("SDEModel", "body", f"one of {list(self._bodies)}", name)
        return self._bodies[name]

    @property
    def sets(self) -> list[SDESet]:
        return list(self._sets)

    @property
    def bindings(self) -> list[RigidBinding]:
        return list(self._bindings)

    @property
    def n_dof(self) -> int:
        return sum(b.n_dof for b in self._bodies.values())

    def dof_index(self, name: str) -> slice:
        """Slice of the global DOF vector belonging to body ``name``."""
        start = 0
        for b in self._bodies.values():
            if b.name == name:
                return slice(start, start + b.n_dof)
            start += b.n_dof
        raise InputError("SDEModel", "body", f"one of {list(self._bodies)}", name)

    @property
    def dof_labels(self) -> list[str]:
        """Labels ``'<body>.<ux|uy|uz|rx|ry|rz>'`` in global DOF order."""
        return [f"{b.name}.{DOF_NAMES[i]}" for b in self._bodies.values() for i in range(b.n_dof)]

    @property
    def element_names(self) -> list[str]:
        """SDE names in the order of the element axis of energy results."""
        return [n for s in self._sets for n in s.names]

    @property
    def element_groups(self) -> list[str]:
        return [g for s in self._sets for g in s.groups]

    @property
    def n_elements(self) -> int:
        return sum(s.size for s in self._sets)

    @property
    def n_constraints(self) -> int:
        return sum(b.n_constraints for b in self._bindings)

    @property
    def massless_dofs(self) -> np.ndarray:
        """Indices of DOFs without mass/inertia (condensed statically before eigenanalysis, docs/theory/structure.md)."""
        out: list[int] = []
        for b in self._bodies.values():
            s = self.dof_index(b.name)
            if np.all(b.mass == 0):
                out.extend(range(s.start, s.start + 3))
            if isinstance(b, RigidBody) and np.all(b.inertia == 0):
                out.extend(range(s.start + 3, s.start + 6))
        return np.array(out, dtype=int)

    def poses(self, sl: slice) -> "SDEModel":
        """Read-only view restricted to the poses ``sl`` (shares the structural cache)."""
        view = copy.copy(self)
        view._bodies = {n: b.poses(sl) for n, b in self._bodies.items()}
        view._sets = [s.poses(sl) for s in self._sets]
        view._bindings = [b.poses(sl) for b in self._bindings]
        view._n_poses = len(range(*sl.indices(self._n_poses))) if self._n_poses > 1 else 1
        view._view = True
        return view

    def chunks(self, chunk_size: int, n_poses: int | None = None) -> Iterable[tuple[slice, "SDEModel"]]:
        """``(slice, view)`` pairs covering all poses in chunks of at most ``chunk_size``.

        ``n_poses``: total number of poses of the analysis when its inputs (e.g. a per-pose point) have more poses
        than a pose-independent model (the model is then broadcast); it must equal the model's N otherwise.
        """
        if chunk_size < 1:
            raise InputError("SDEModel.chunks", "chunk_size", "integer >= 1", chunk_size)
        total = self._n_poses if n_poses is None else common_poses([self._n_poses, n_poses], "analysis input")
        for start in range(0, total, chunk_size):
            sl = slice(start, min(start + chunk_size, total))
            yield sl, (self.poses(sl) if self._n_poses > 1 else self)

    def cached(self, key: Any, build: Any) -> Any:
        """Structural data shared by all pose views (built once)."""
        if key not in self._cache:
            self._cache[key] = build()
        return self._cache[key]
