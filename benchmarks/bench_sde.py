"""Benchmark of the generic SDE layer on a synthetic PKM-like model (single-threaded).

Model: spindle + platform (rigid bodies) + 6 drives (point masses) = 30 DOF; 13 SDEs: 6 drive–frame 3×3
(``R diag(kx, ky, kz) Rᵀ``), 6 drive–platform axial along the strut, 1 platform–spindle 6×6.  Random but realistic
geometry per pose, stiffnesses 1e7–1e9 N/m, masses 10–120 kg.  Timed: model build, and assembly + TCP compliance
+ 6 lowest natural frequencies (:func:`pkmstiff.multibody.evaluate_point`).  Prints poses/s and peak memory.

Usage: ``python benchmarks/bench_sde.py [n_poses ...] [--chunk N]`` (default 10000 100000).
The CPU time (process time) is printed beside the wall time: on a machine shared with other jobs it is the better
measure of the single-core cost.
"""

from __future__ import annotations

import os

os.environ["OMP_NUM_THREADS"] = "1"
os.environ["OPENBLAS_NUM_THREADS"] = "1"
os.environ["MKL_NUM_THREADS"] = "1"

import argparse  # noqa: E402
import resource  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from pkmstiff.multibody import SDEModel, evaluate_point  # noqa: E402
from pkmstiff.multibody.linalg import rotation_about_axis  # noqa: E402


def pkm_like_model(n_poses: int, seed: int = 0, check_psd: bool = False) -> SDEModel:
    """Synthetic 30-DOF PKM-like SDE model with per-pose geometry (leading pose axis N)."""
    rng = np.random.default_rng(seed)
    ang = np.arange(6) * np.pi / 3 + np.repeat([0.0, 0.3], 3)
    p_local = 0.3 * np.stack([np.cos(ang), np.sin(ang), np.zeros(6)], axis=1)  # platform joints (PKS)
    ang_q = ang + np.tile([0.45, -0.45], 3)  # drive joints offset from the platform joints (no common line)
    guide_dir = np.stack([np.cos(ang_q), np.sin(ang_q), np.full(6, -0.8)], axis=1)
    guide_dir /= np.linalg.norm(guide_dir, axis=1)[:, None]
    w = rng.uniform([-0.2, -0.2, 0.8], [0.2, 0.2, 1.2], size=(n_poses, 3))  # tool reference point O'
    tilt = rng.uniform(-0.2, 0.2, size=(n_poses, 2))
    c, s = np.cos(tilt), np.sin(tilt)
    rot = np.zeros((n_poses, 3, 3))  # R = R_x(a) R_y(b)
    rot[:, 0, 0], rot[:, 0, 2] = c[:, 1], s[:, 1]
    rot[:, 1, 0], rot[:, 1, 1], rot[:, 1, 2] = s[:, 0] * s[:, 1], c[:, 0], -s[:, 0] * c[:, 1]
    rot[:, 2, 0], rot[:, 2, 1], rot[:, 2, 2] = -c[:, 0] * s[:, 1], s[:, 0], c[:, 0] * c[:, 1]
    p = w[:, None, :] + np.einsum("nij,ej->nei", rot, p_local)  # (N, 6, 3)
    q = 1.2 * np.stack([np.cos(ang_q), np.sin(ang_q), np.zeros(6)], axis=1)[None] + \
        rng.uniform(-0.05, 0.05, (n_poses, 6, 1)) * guide_dir[None]
    q[..., 2] += 2.0
    strut = p - q
    m = SDEModel()
    cog_s = w + rot[:, :, 2] * 0.25
    m.add_rigid_body("spindle", 40.0, cog_s, [0.8, 0.8, 0.3], rotation=rot)
    m.add_rigid_body("platform", 120.0, w + rot[:, :, 2] * 0.05, [6.0, 6.0, 10.0], rotation=rot)
    masses = rng.uniform(10.0, 120.0, 6)
    for i in range(6):
        m.add_point_mass(f"drive{i + 1}", masses[i], q[:, i])
    frames = np.stack([rotation_about_axis([0, 0, 1], a) @ rotation_about_axis([0, 1, 0], 0.6) for a in ang_q])
    kdiag = rng.uniform(1e7, 1e9, size=(6, 3))
    kw = np.einsum("eij,ej,ekj->eik", frames, kdiag, frames)
    names = [f"drive{i + 1}" for i in range(6)]
    m.add_sde_set([f"W{i + 1}" for i in range(6)], names, "frame", q, stiffness=kw, groups="drive",
                  check_psd=check_psd)
    kv = rng.uniform(5e7, 3e8, size=(n_poses, 6))
    m.add_sde_set([f"V{i + 1}" for i in range(6)], names, "platform", p, k=kv, axis=strut, groups="strut",
                  check_psd=check_psd)
    ku = np.diag([2e9, 2e9, 3e9, 4e8, 4e8, 6e8])
    m.add_sde("U", "platform", "spindle", w, stiffness=ku, group="platform", check_psd=check_psd)
    return m


def run(n_poses: int, chunk: int) -> None:
    tracemalloc.start()
    t0 = time.perf_counter()
    model = pkm_like_model(n_poses)
    t1, c1 = time.perf_counter(), time.process_time()
    tcp = model.body("spindle").position + np.array([0.0, 0.0, -0.35])
    res = evaluate_point(model, "spindle", tcp, n_modes=6, chunk_size=chunk)
    t2, c2 = time.perf_counter(), time.process_time()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert np.all(np.isfinite(res.frequencies_hz)) and np.all(res.frequencies_hz > 0)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{n_poses:>8d} poses  chunk {chunk:>5d}  build {t1 - t0:6.3f} s  "
          f"assembly+TCP compliance+6 modes {t2 - t1:6.3f} s = {n_poses / (t2 - t1):8.0f} poses/s "
          f"(CPU {c2 - c1:6.3f} s = {n_poses / (c2 - c1):8.0f} poses/s)  "
          f"(total {n_poses / (t2 - t0):8.0f} poses/s)  peak traced {peak / 2**20:7.1f} MiB  max RSS {rss:7.1f} MiB  "
          f"f1 median {np.median(res.frequencies_hz[:, 0]):6.1f} Hz")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("poses", nargs="*", type=int, default=[10_000, 100_000])
    ap.add_argument("--chunk", type=int, default=2048)
    args = ap.parse_args()
    for n in args.poses:
        run(n, args.chunk)


if __name__ == "__main__":
    main()
