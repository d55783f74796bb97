"""Example: a small spring–mass system with the generic SDE layer (pkmstiff.multibody).

A rigid table (20 kg) on four vertical springs at its corners and three horizontal springs, carrying a 5 kg point
mass on a 3×3 spring; evaluated for three payload positions at once (a leading "pose" axis) to show batching.
Prints the static stiffness at a point above the table, the weak points for a horizontal load, the lowest
natural frequencies with the dominant motion of the table, and the first resonance of a receptance.

Run: ``python studies/example_spring_mass.py``
"""

from __future__ import annotations

import numpy as np

import pkmstiff.multibody as sde


def build(payload_x_m: np.ndarray) -> sde.SDEModel:
    n = payload_x_m.size
    cog = np.array([0.0, 0.0, 0.8])  # table CoG, m (same for all poses)
    payload = np.stack([payload_x_m, np.zeros(n), np.full(n, 0.95)], axis=1)  # (N, 3): payload per pose, m
    m = sde.SDEModel()
    m.add_rigid_body("table", mass=20.0, position=cog, inertia=[0.5, 0.8, 1.2])  # kg, kg m^2 (principal = global)
    m.add_point_mass("payload", mass=5.0, position=payload)
    corners = np.array([[0.4, 0.3, 0.0], [-0.4, 0.3, 0.0], [-0.4, -0.3, 0.0], [0.4, -0.3, 0.0]])
    m.add_sde_set([f"foot{i}" for i in range(4)], "table", sde.FRAME, cog + corners,
                  k=2e6, axis=[0.0, 0.0, 1.0], c=200.0, groups="feet")  # N/m, N s/m along z
    m.add_sde("side_x", "table", sde.FRAME, cog + [0.4, 0.0, 0.0], k=5e5, axis=[1, 0, 0], group="sides")
    m.add_sde("side_y1", "table", sde.FRAME, cog + [0.2, 0.3, 0.0], k=5e5, axis=[0, 1, 0], group="sides")
    m.add_sde("side_y2", "table", sde.FRAME, cog + [-0.2, -0.3, 0.0], k=5e5, axis=[0, 1, 0], group="sides")
    m.add_sde("mount", "payload", "table", payload, stiffness=np.diag([3e6, 3e6, 8e6]), group="mount")
    return m


def main() -> None:
    payload_x = np.array([0.0, 0.2, 0.4])
    model = build(payload_x)
    print(f"DOFs: {model.n_dof} ({', '.join(model.dof_labels)})")
    tcp = np.array([0.0, 0.0, 1.05])  # point 0.25 m above the table CoG
    comp = sde.point_compliance(model, "table", tcp)  # (N, 6, 6)
    k_axes = sde.axis_stiffness(comp)
    for x, k in zip(payload_x, k_axes):
        print(f"payload at x = {x:.1f} m: k_x {k[0] / 1e6:.3f} N/um, k_y {k[1] / 1e6:.3f} N/um, "
              f"k_z {k[2] / 1e6:.3f} N/um, "
              f"k_rx {k[3] / 1e6:.4f} Nm/urad")
    labels, shares = sde.weak_points(model, "table", tcp, [1.0, 0.0, 0.0], groups="group")
    print("weak points for a force along x at the point (payload at x = 0):",
          {lab: f"{100 * s:.1f} %" for lab, s in zip(labels, shares[0])})
    res = sde.modes(model, n_modes=4, shapes=True)
    idx, share = sde.describe_modes(model, res.shapes, "table")
    for p, x in enumerate(payload_x):
        text = ", ".join(f"{res.frequencies_hz[p, j]:.1f} Hz {sde.mode_label(idx[p, j], share[p, j])}"
                         for j in range(4))
        print(f"payload at x = {x:.1f} m: modes (dominant table motion): {text}")
    freq = np.linspace(1.0, 150.0, 1500)
    zdir = sde.PointDirection("table", [0.0, 0.0, 1.0], tcp)
    h = sde.receptance(model, freq, zdir, zdir, zeta=0.02)
    pf, pm = sde.find_peaks(freq, h, max_peaks=2, min_rel_height=0.05)
    for p, x in enumerate(payload_x):
        print(f"payload at x = {x:.1f} m: receptance z->z peaks at {np.round(pf[p], 1)} Hz, "
              f"|H| = {np.round(pm[p] * 1e6, 3)} um/N")


if __name__ == "__main__":
    main()
