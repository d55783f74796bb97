"""Result objects of the public API: section maps, workspaces and rotation maps, each with ``statistics()``,
``plot()`` and a conversion to the field's data structures (xarray for rasters, pandas for point lists).

They wrap the library's results (:class:`~pkmstiff.evaluation.sections.SectionResult`,
:class:`~pkmstiff.workspace.translational.WorkspaceResult`, :class:`~pkmstiff.workspace.rotation.RotationMapResult`),
kept as ``.result``. Arrays are SI; conversions state every unit in ``attrs`` (xarray) or in the column name (pandas).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # the library's results are imported where they are made (pkmstiff.api.machine), not here
    import pandas
    import xarray

    from pkmstiff.evaluation.sections import Plane, SectionResult
    from pkmstiff.machine import Machine
    from pkmstiff.workspace.rotation import RotationMapResult
    from pkmstiff.workspace.translational import WorkspaceResult

MM = 1e3  # m -> mm


def _raster_coords(plane: "Plane", frame: dict[str, Any], si: bool) -> dict[str, Any]:
    """xarray coordinates of a plane raster: the two in-plane axes (dims) and the fixed third one (scalar)."""
    scale, unit = (1.0, "m") if si else (MM, "mm")
    where = f"{frame['frame']} frame"
    coords: dict[str, Any] = {
        plane.u_name: (plane.u_name, plane.u_values * scale,
                       {"units": unit, "long_name": f"{plane.u_name} of O' ({where})"}),
        plane.v_name: (plane.v_name, plane.v_values * scale,
                       {"units": unit, "long_name": f"{plane.v_name} of O' ({where})"})}
    axes = {plane.u_name, plane.v_name}
    if len(axes) == 2 and axes <= set("xyz"):  # an axis plane: its position along the third axis
        normal = (set("xyz") - axes).pop()
        at = float(plane.origin["xyz".index(normal)])
        coords[normal] = ((), at * scale, {"units": unit, "long_name": f"{normal} of the plane ({where})"})
    return coords


@dataclass
class SectionMap:
    """Quantities on a section plane (:meth:`pkmstiff.api.StudyMachine.section`); ``result`` is the library's
    :class:`~pkmstiff.evaluation.sections.SectionResult` (values SI, NaN where inadmissible)."""

    result: "SectionResult"

    @property
    def quantities(self) -> list[str]:
        return list(self.result.values)

    @property
    def ok(self) -> np.ndarray:
        """(nv, nu) admissibility mask (rows along the plane's second axis)."""
        return self.result.ok

    @property
    def plane(self) -> "Plane":
        """The raster: ``u_values``/``v_values`` [m] along the plane's axes ``u_name``/``v_name`` (in the result's
        frame), ``points()``, ``cell_area`` [m²]."""
        return self.result.plane

    @property
    def values(self) -> dict[str, np.ndarray]:
        """Quantity name -> (nv, nu) values in SI (``si_units``), NaN where inadmissible."""
        return self.result.values

    def display(self, name: str) -> np.ndarray:
        """(nv, nu) values of quantity ``name`` in its display unit (``units[name]``)."""
        return self.result.display(name)

    @property
    def si_units(self) -> dict[str, str]:
        """SI unit of every quantity."""
        return dict(self.result.si_units)

    @property
    def units(self) -> dict[str, str]:
        """Display unit of every quantity."""
        return dict(self.result.units)

    @property
    def frame(self) -> str:
        return self.result.frame["frame"]

    def statistics(self) -> dict[str, dict[str, float]]:
        """Per quantity over the admissible points: min, mean, max (display unit, key ``unit``), count, admissible
        points and area [m²]."""
        return self.result.statistics()

    def plot(self, name: str, path: str | Path, clim: tuple[float, float] | None = None) -> Path:
        """PNG map of quantity ``name`` (display unit; white = inadmissible, black line = admissible boundary)."""
        from pkmstiff.plots.section_maps import plot_section

        return plot_section(self.result, name, path, clim=clim)

    def fails(self, check: str) -> np.ndarray:
        """(nv, nu) True where the admissibility check ``check`` fails (a name of
        :class:`pkmstiff.admissibility.checks.Reason`, e.g. ``"drive_load"``, ``"PLATFORM_COLLISION"``)."""
        from pkmstiff.admissibility.checks import Reason

        return (self.result.reasons & int(Reason[check.upper()])) != 0

    def reason_counts(self) -> dict[str, int]:
        """Raster points failing each admissibility check (a point may fail several)."""
        return self.result.reason_counts()

    def failing_check_codes(self) -> tuple[np.ndarray, list[str]]:
        """(nv, nu) int codes and their names: 0 = ``"admissible"``, k = the k-th check (in the order of
        :data:`pkmstiff.admissibility.checks.Reason`) is the first that fails at the point — for maps of why."""
        from pkmstiff.admissibility.checks import Reason

        reasons = list(Reason)
        code = np.zeros(self.result.reasons.shape, int)
        for k, reason in reversed(list(enumerate(reasons, start=1))):
            code[(self.result.reasons & int(reason)) > 0] = k
        return code, ["admissible"] + [x.name.lower().replace("_", " ") for x in reasons]

    def plot_admissibility(self, path: str | Path) -> Path:
        """PNG map of the first failing admissibility check per raster point."""
        from pkmstiff.plots.section_maps import plot_reasons

        return plot_reasons(self.result, path)

    def to_xarray(self, si: bool = False) -> "xarray.Dataset":
        """An ``xarray.Dataset``: one variable per quantity over the plane's two axes (dims named ``"y"``, ``"z"``,
        ...; coordinates in mm, or m with ``si=True``), NaN where inadmissible; ``admissible`` (bool mask) and
        ``reasons`` (bit set of failing checks, meanings in its attrs). Every variable and coordinate states its
        ``units`` in ``attrs``: the display unit (``"N/um"``, ``"Hz"``) or, with ``si=True``, the SI unit. The
        dataset's attrs give the machine, frame, orientation and tool length."""
        import xarray

        from pkmstiff.admissibility.checks import REASON_TEXT, Reason

        r = self.result
        dims = (r.plane.v_name, r.plane.u_name)
        data: dict[str, Any] = {}
        for name in r.values:
            data[name] = (dims, r.values[name] if si else r.display(name),
                          {"units": r.si_units[name] if si else r.units[name], "long_name": r.labels[name]})
        data["admissible"] = (dims, np.asarray(r.ok, bool), {"long_name": "pose admissible (every check passed)"})
        data["reasons"] = (dims, np.asarray(r.reasons), {
            "long_name": "failing admissibility checks (bit set)", "flag_masks": [int(x) for x in Reason],
            "flag_meanings": " ".join(x.name for x in Reason),
            "flag_descriptions": [REASON_TEXT[x] for x in Reason]})
        attrs = {"machine": r.machine, "plane": r.plane.name, **r.frame,
                 "orientation_deg": np.rad2deg(r.orientation).tolist(),
                 "tool_length_mm": "machine default" if r.tool_length is None else r.tool_length * MM,
                 "note": "positions of O' in the stated frame; quantities NaN where inadmissible"}
        return xarray.Dataset(data, coords=_raster_coords(r.plane, r.frame, si), attrs=attrs)


@dataclass
class Workspace:
    """A constant-orientation workspace (:meth:`pkmstiff.api.StudyMachine.workspace`); ``result`` is the library's
    :class:`~pkmstiff.workspace.translational.WorkspaceResult`."""

    result: "WorkspaceResult"
    machine: "Machine"

    @property
    def volume(self) -> float:
        """Volume [m³] of the closed boundary surface (surface nets; the figure to quote)."""
        return self.result.volume

    @property
    def volumes(self) -> dict[str, float]:
        """Volume [m³] by method (``surface_nets``, ``divergence``, ``tetrahedron``, ``pyramid``; docs/theory/
        workspace.md); :attr:`volume` is the one to quote."""
        return dict(self.result.volumes)

    @property
    def boundary_points(self) -> np.ndarray:
        """(M, 3) boundary points [m] in the machine frame."""
        return self.result.boundary_points

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) (3,) [m] of the boundary points, machine frame (NaN without a workspace)."""
        return self.result.bounding_box()

    def statistics(self) -> dict[str, Any]:
        """The workspace summary (keys name their units: ``volume_m3``, ``bounding_box_mm`` in the result's frame,
        ``resolution_mm``, evaluation counts and times)."""
        return self.result.summary()

    def plot(self, path: str | Path, pose: Any = None, show_points: bool = False,
             window_size: tuple[int, int] = (1200, 900), view: Any = None) -> Path:
        """PNG of the closed boundary surface [mm] with the machine drawn at ``pose`` (machine frame; default a
        central pose), seen along ``view`` (a direction (3,); default oblique)."""
        from pkmstiff.plots.workspace import plot_workspace

        return plot_workspace(self.result, self.machine, path, pose=pose, show_points=show_points,
                              window_size=window_size, view=view)

    def to_pandas(self) -> "pandas.DataFrame":
        """The boundary points, one row each: ``x_mm``, ``y_mm``, ``z_mm`` (machine frame, stated in ``attrs``)."""
        import pandas

        p = self.boundary_points * MM
        df = pandas.DataFrame({"x_mm": p[:, 0], "y_mm": p[:, 1], "z_mm": p[:, 2]})
        df.attrs.update({"machine": self.result.machine, "frame": "machine", "volume_m3": self.volume})
        return df


@dataclass
class RotationMap:
    """Largest admissible rotation angles on a raster (:meth:`pkmstiff.api.StudyMachine.rotation_map`);
    ``result`` is the library's :class:`~pkmstiff.workspace.rotation.RotationMapResult` (rad)."""

    result: "RotationMapResult"
    plane: "Plane"

    @property
    def angles(self) -> dict[str, np.ndarray]:
        """Direction -> (nv, nu) largest admissible angle [rad] (NaN where the base pose is inadmissible)."""
        return self.result.angles

    @property
    def at_limit(self) -> dict[str, np.ndarray]:
        """Direction -> (nv, nu) True where the pose stays admissible up to the search limit."""
        return self.result.at_limit

    @property
    def u_values(self) -> np.ndarray:
        """Raster values [m] along the plane's first axis."""
        return self.plane.u_values

    @property
    def v_values(self) -> np.ndarray:
        """Raster values [m] along the plane's second axis."""
        return self.plane.v_values

    def angle(self, direction: str) -> np.ndarray:
        """(nv, nu) largest admissible angle [rad] in ``direction`` (``"+a"``, ...); NaN where the base pose is
        inadmissible."""
        return self.result.angles[direction]

    def statistics(self) -> dict[str, Any]:
        """Per direction: max/mean/min [deg] and the points admissible up to the search limit."""
        return self.result.summary()["angles"]

    def plot(self, direction: str, path: str | Path) -> Path:
        """PNG map of the angle [deg] in ``direction`` over the raster [mm]."""
        from matplotlib.figure import Figure

        fig = Figure(figsize=(6.4, 4.8), layout="constrained")
        ax = fig.add_subplot()
        mesh = ax.pcolormesh(self.plane.u_values * MM, self.plane.v_values * MM, np.degrees(self.angle(direction)),
                             shading="nearest")
        fig.colorbar(mesh, ax=ax, label=f"largest admissible angle {direction} [deg]")
        ax.set_xlabel(f"{self.plane.u_name} [mm]")
        ax.set_ylabel(f"{self.plane.v_name} [mm]")
        ax.set_aspect("equal")
        ax.set_title(f"{self.plane.name} ({self.result.settings.get('frame', 'machine')} frame)")
        fig.savefig(path, dpi=110)
        return Path(path)

    def to_xarray(self) -> "xarray.Dataset":
        """An ``xarray.Dataset`` with one variable per direction (``angle_+a``, deg), ``admissible`` (base pose) and
        ``at_limit`` (admissible up to the search limit); coordinates in mm, units in ``attrs``."""
        import xarray

        r = self.result
        dims = (self.plane.v_name, self.plane.u_name)
        data: dict[str, Any] = {f"angle_{d}": (dims, np.degrees(a), {"units": "deg",
                                                                       "long_name": f"largest admissible angle {d}"})
                                for d, a in r.angles.items()}
        data.update({f"at_limit_{d}": (dims, a) for d, a in r.at_limit.items()})
        data["admissible"] = (dims, np.asarray(r.base_ok, bool), {"long_name": "base pose admissible"})
        frame = {"frame": r.settings.get("frame", "machine")}
        return xarray.Dataset(data, coords=_raster_coords(self.plane, frame, False),
                              attrs={"increment_deg": float(np.degrees(r.increment)),
                                     "max_angle_deg": float(np.degrees(r.max_angle)), "method": r.method, **frame})
