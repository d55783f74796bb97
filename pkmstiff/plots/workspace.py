"""Figures of workspaces and rotation-angle maps (coordinates in mm, angles in degrees, volumes in m^3).

3-D figures use pyvista off-screen; 2-D maps and curves use matplotlib (Agg backend). The machine sketch is the
shared one of :mod:`pkmstiff.plots.sketch` (guides or fixed drive joints, struts, joints, platform hull at a pose
computed by the inverse kinematics).
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from pkmstiff.errors import PlotDependencyError
from pkmstiff.io.atomic import atomic_path
from pkmstiff.machine.model import Machine
from pkmstiff.plots import offscreen
from pkmstiff.plots.sketch import add_sketch, machine_sketch
from pkmstiff.workspace.rotation import RotationMapResult
from pkmstiff.workspace.translational import WorkspaceResult

__all__ = ["machine_sketch", "plot_convergence", "plot_rotation_maps", "plot_rotational_workspace",
           "plot_volume_vs_orientation", "plot_workspace", "reference_pose"]

INADMISSIBLE = "#f2d7d5"  # face colour where the base orientation is inadmissible (no angle)


def reference_pose(res: WorkspaceResult, machine: Machine) -> np.ndarray | None:
    """An admissible pose near the centre of the workspace: the centre of the boundary's box if admissible, else
    the evaluated admissible corner closest to it; None for an empty workspace."""
    o = res.octree
    lo, hi = res.bounding_box()
    if not np.isfinite(lo).all():
        return None
    c = np.concatenate([0.5 * (lo + hi), res.orientation])
    from pkmstiff.admissibility.pipeline import evaluate_poses

    if evaluate_poses(machine, c[None]).ok[0]:
        return c
    pts = o.admissible_points() if o.admissible_keys.size else o.boundary_points
    return np.concatenate([pts[np.argmin(np.linalg.norm(pts - c[:3], axis=1))], res.orientation])


def plot_workspace(res: WorkspaceResult, machine: Machine, path: str | Path, pose: Sequence[float] | None = None,
                   window_size: tuple[int, int] = (1200, 900), show_points: bool = False,
                   view: Sequence[float] | None = None) -> Path:
    """PNG of the closed workspace surface (mm) with the machine sketch at ``pose`` (default: a central pose)."""
    pv = offscreen()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    pl = pv.Plotter(off_screen=True, window_size=list(window_size))
    pl.set_background("white")
    if res.surface is not None and res.surface.triangles.shape[0]:
        mesh = res.surface.to_pyvista()
        mesh.points *= 1e3
        mesh = mesh.compute_normals(auto_orient_normals=False, consistent_normals=False, split_vertices=False)
        pl.add_mesh(mesh, color="#e8a33d", opacity=0.85, smooth_shading=True, specular=0.2)
    if show_points:
        pl.add_points(res.boundary_points * 1e3, color="black", point_size=2, render_points_as_spheres=False)
    x = reference_pose(res, machine) if pose is None else np.asarray(pose, float)
    if x is not None:
        add_sketch(pl, machine, x, opacity=0.25, colour="gray")  # ghosted: the volume stays in view
    lo, hi = res.bounding_box()
    s = res.summary()
    ori = s["orientation_deg"]
    rng = (res.settings or {}).get("orientation_range")
    if rng:  # one angle varies: say so instead of printing the base orientation as if it were fixed
        k = "abc".index(rng[0])
        parts = [f"{c} = {rng[1]:g}…{rng[2]:g}° ({(res.settings or {}).get('range_mode', 'all')})" if i == k
                 else f"{c} = {ori[i]:g}°" for i, c in enumerate("abc")]
        orientation = ", ".join(parts)
    else:
        orientation = f"a, b, c = {', '.join(f'{d:g}°' for d in ori)}"
    extent = "" if not np.isfinite(lo).all() else ("; " + ", ".join(
        f"{c} {a * 1e3:.0f}…{b * 1e3:.0f} mm" for c, a, b in zip("xyz", lo, hi)))
    title = (f"{machine.name}: workspace (machine frame) at {orientation}, resolution {s['resolution_mm']:g} mm\n"
             f"V = {res.volume:.4f} m³{extent}; {s['boundary_points']:,} boundary points")
    text = pl.add_text(title + "\nmachine ghosted grey", position=(0.01, 0.985), viewport=True, font_size=8,
                       color="black")  # a margin to the edges; a text actor's font is 2 x font_size px
    text.GetTextProperty().SetVerticalJustificationToTop()
    direction = np.asarray((1.0, 1.0, 1.0) if view is None else view, float)
    direction = direction / np.linalg.norm(direction)
    from pkmstiff.plots.axes3d import add_mm_axes, frame_camera

    box = np.column_stack([lo, hi]) * 1e3 if np.isfinite(lo).all() else None
    if box is not None:
        add_mm_axes(pl, box.ravel(), direction)
    frame_camera(pl, direction, box, zoom=1.35)  # the camera frames the volume; the machine may leave the view
    _fill_bottom(pl)
    with atomic_path(path) as tmp:
        pl.screenshot(str(tmp))
    pl.close()
    return path




def _fill_bottom(pl, margin: float = 0.03) -> None:
    """Pan the camera along its view-up so that the drawing reaches down to ``margin`` × the window height from
    the bottom: the title takes the top of the canvas, the empty bottom is given to the data (the ghosted machine
    above may leave the view)."""
    pl.render_window.Render()
    img = np.asarray(pl.screenshot(return_img=True)).astype(int)
    rows = np.flatnonzero((np.abs(img - img[0, 0]).sum(axis=2) > 30).any(axis=1))
    if rows.size == 0:
        return
    ren, cam = pl.renderer, pl.camera
    up, focus = np.asarray(cam.GetViewUp()), np.asarray(cam.GetFocalPoint())

    def display_y(p) -> float:
        ren.SetWorldPoint(*p, 1.0)
        ren.WorldToDisplay()
        return ren.GetDisplayPoint()[1]

    px_per_mm = display_y(focus + up) - display_y(focus)  # screen pixels per mm along view-up at the focus
    empty = img.shape[0] - 1 - int(rows.max()) - margin * img.shape[0]
    if px_per_mm > 0 and empty > 0:
        shift = empty / px_per_mm * up  # the camera up = the drawing down
        cam.SetFocalPoint(*(focus + shift))
        cam.SetPosition(*(np.asarray(cam.GetPosition()) + shift))
        pl.render_window.Render()  # the screenshot after this one takes the window's image as it is


def _figure(figsize: tuple[float, float]):
    """A matplotlib Figure that renders without a GUI back-end (no pyplot, no global back-end switch)."""
    try:
        from matplotlib.figure import Figure
    except ModuleNotFoundError:
        raise PlotDependencyError("the 2-D workspace figures need matplotlib: pip install matplotlib "
                                  "(or pass --no-plot)") from None
    return Figure(figsize=figsize)


def plot_rotation_maps(res: RotationMapResult, path: str | Path, labels: tuple[str, str] = ("u [mm]", "v [mm]"),
                       scale: tuple[float, float] = (1e3, 1e3), title: str = "", cmap: str = "viridis") -> Path:
    """One contour panel per direction (Cobet's display, §7.2) on one shared colour scale; shaded = inadmissible
    base orientation. The colour map is perceptual and 0° is one of its colours (dark), so a point that admits no
    rotation reads as data, not as a gap."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    dirs = list(res.angles)
    ncol = min(3, len(dirs))
    nrow = int(np.ceil(len(dirs) / ncol))
    U, V = np.meshgrid(res.u_values * scale[0], res.v_values * scale[1])
    du, dv = float(np.ptp(U)) or 1.0, float(np.ptp(V)) or 1.0
    aspect = dv / du if scale[0] == scale[1] else 0.75
    fig = _figure((4.2 * ncol + 1.2, (3.7 * aspect + 0.8) * nrow + (0.5 if title else 0.0)))
    fig.set_layout_engine("constrained")
    axes = fig.subplots(nrow, ncol, squeeze=False)
    vmax = max(float(np.nanmax(np.degrees(a))) if np.isfinite(a).any() else 0.0 for a in res.angles.values())
    step = 5.0 if vmax > 20 else 1.0  # contour levels at round angles
    levels = np.arange(0.0, max(np.ceil(vmax / step), 1.0) * step + 0.5 * step, step)
    cs = None
    for ax, d in zip(axes.ravel(), dirs):
        a = np.degrees(res.angles[d])
        ax.set_facecolor(INADMISSIBLE)
        if np.isfinite(a).any():
            cs = ax.contourf(U, V, np.ma.masked_invalid(a), levels=levels, cmap=cmap, extend="neither")
        ax.set_title(f"{d}: max {np.nanmax(a) if np.isfinite(a).any() else float('nan'):.0f}°, "
                     f"mean {np.nanmean(a) if np.isfinite(a).any() else float('nan'):.1f}°", fontsize=10)
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        ax.set_aspect("equal" if scale[0] == scale[1] else "auto")
    for ax in axes.ravel()[len(dirs):]:
        ax.set_visible(False)
    if cs is not None:  # one colour bar for every panel (same levels)
        fig.colorbar(cs, ax=axes, label="max. admissible angle [°]", fraction=0.04, pad=0.02)
    if title:
        fig.suptitle(title + " (shaded: base orientation inadmissible)", fontsize=10)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, facecolor="white")
    return path


def plot_volume_vs_orientation(angles_rad: np.ndarray, volumes: Mapping[str, np.ndarray], path: str | Path,
                               title: str = "") -> Path:
    """Workspace volume (m^3) over one tool angle at a time, one curve per rotation axis."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = _figure((6.4, 4.2))
    ax = fig.subplots()
    for ax_name, vols in volumes.items():
        ax.plot(np.degrees(angles_rad), vols, marker="o", ms=3, label=f"rotation about {ax_name}")
    ax.set_xlabel("tool angle [°] (other angles 0)")
    ax.set_ylabel("workspace volume [m$^3$]")
    ax.grid(True, alpha=0.3)
    ax.legend()
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    return path


def plot_convergence(eps_mm: np.ndarray, errors: Mapping[str, Mapping[str, np.ndarray]], path: str | Path) -> Path:
    """|relative volume error| [%] over eps [mm], log-log, one panel per body, one curve per method."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = _figure((5.6 * len(errors), 5.0))
    axes = fig.subplots(1, len(errors), squeeze=False)
    for ax, (body, by_method) in zip(axes.ravel(), errors.items()):
        for meth, err in by_method.items():
            ax.loglog(eps_mm, np.maximum(np.abs(err), 1e-4), marker="o", ms=3, label=meth)
        ax.axhline(0.5, color="red", lw=0.8, ls="--", label="0.5 % target")
        ax.set_xticks(eps_mm, [f"{e:g}" for e in eps_mm])
        ax.minorticks_off()
        ax.set_xlabel("resolution eps [mm]")
        ax.set_ylabel("|volume error| [%]")
        ax.set_title(body, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()  # one legend below the panels: no curve hidden
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 4 if len(errors) > 1 else 2), fontsize=9,
               frameon=False)
    rows = 1 + (len(labels) - 1) // (4 if len(errors) > 1 else 2)
    fig.tight_layout(rect=(0, 0.03 + 0.045 * rows, 1, 1))
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    return path


def plot_rotational_workspace(results: Sequence[RotationMapResult], path: str | Path, title: str = "",
                              cmap: str = "viridis") -> Path:
    """Projections of the rotational workspace at a point (docs/theory/workspace.md): one panel per result, e.g. max. +a over
    (b, c) and max. +b over (a, c); axes and values in degrees."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = _figure((5.2 * len(results), 4.2))
    axes = fig.subplots(1, len(results), squeeze=False)
    for ax, res in zip(axes.ravel(), results):
        d = next(iter(res.angles))
        a = np.degrees(res.angles[d])
        ax.set_facecolor(INADMISSIBLE)
        U, V = np.meshgrid(np.degrees(res.u_values), np.degrees(res.v_values))
        if np.isfinite(a).any():
            cs = ax.contourf(U, V, np.ma.masked_invalid(a), levels=18, cmap=cmap)
            fig.colorbar(cs, ax=ax, label=f"max. rotation {d} [°]")
        ax.set_xlabel(f"{res.settings.get('u_angle', 'u')} [°]")
        ax.set_ylabel(f"{res.settings.get('v_angle', 'v')} [°]")
        ax.set_title(f"max. {d} over ({res.settings.get('u_angle')}, {res.settings.get('v_angle')})", fontsize=10)
    if title:
        fig.suptitle(title + " (shaded: base orientation inadmissible)", fontsize=10)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    return path
