"""Benchmark (issue 2): IK + inverse Jacobian + J_C + singularity + joint angles + all admissibility checks.

Target: >= 100,000 poses/s for the Hexaglide on one core.
Run: ``python benchmarks/bench_admissibility.py [N] [MACHINE] [--stages] [--repeat R]``
(defaults: N = 200000, MACHINE = hexaglide). Poses are random over the machine's working region (Hexaglide:
x ±0.4 m, y -0.6..0.8 m, z -1.2..-0.5 m; 6X: x, y ±0.5 m, z 0.6..1.6 m; rotations ±0.1 rad), so collisions and
out-of-range chains occur as in a real map.

Times are CPU times of this process (``time.process_time``, best of R runs), which on a shared machine are not
inflated by waiting for the CPU; the wall-clock time is printed as well. The first call is timed separately: it
includes compiling the numba kernels (first run on a machine) or loading them from numba's cache.
``--stages`` adds the CPU time of each stage of the pipeline for the same poses.
"""

import os
import sys as _sys

_sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))  # run from a clone

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core: must be set before numpy is imported
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402
from typing import Callable  # noqa: E402

import numpy as np  # noqa: E402

import pkmstiff  # noqa: E402
import pkmstiff.admissibility.checks as adm  # noqa: E402
from pkmstiff.kinematics.joint_angles import joint_angles  # noqa: E402
from pkmstiff.kinematics import inverse_jacobian, inverse_kinematics, jacobian_and_singular  # noqa: E402
from pkmstiff.machine.roles import drive_load_data  # noqa: E402
from pkmstiff.admissibility.pipeline import evaluate_poses  # noqa: E402

BOXES = {"hexapod_6x": ((-0.5, 0.5), (-0.5, 0.5), (0.6, 1.6))}
DEFAULT_BOX = ((-0.4, 0.4), (-0.6, 0.8), (-1.2, -0.5))  # Hexaglide working region (sections' y, z box)


def sample_poses(machine: str, n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    box = BOXES.get(machine, DEFAULT_BOX)
    return np.column_stack([*(rng.uniform(lo, hi, n) for lo, hi in box),
                            *(rng.uniform(-0.1, 0.1, n) for _ in range(3))])


def cpu_time(f: Callable[[], object], repeat: int) -> tuple[float, float, object]:
    """Best CPU and wall-clock time of ``repeat`` calls of f, and f's last result."""
    best_cpu = best_wall = np.inf
    out = None
    for _ in range(repeat):
        c0, t0 = time.process_time(), time.perf_counter()
        out = f()
        best_cpu = min(best_cpu, time.process_time() - c0)
        best_wall = min(best_wall, time.perf_counter() - t0)
    return best_cpu, best_wall, out


def stages(m: pkmstiff.machine.model.Machine, poses: np.ndarray, repeat: int) -> dict[str, float]:
    """CPU time of each pipeline stage for all poses, in one chunk (s)."""
    t: dict[str, float] = {}
    t["IK"], _, ik = cpu_time(lambda: inverse_kinematics(m, poses), repeat)
    t["J_C^-1"], _, jinv = cpu_time(lambda: inverse_jacobian(m, ik), repeat)
    t["J_C + singularity"], _, (jc, _) = cpu_time(lambda: jacobian_and_singular(m, jinv), repeat)
    t["joint angles"], _, ja = cpu_time(lambda: joint_angles(m, ik), repeat)
    t["drive range + spacing"], _, _ = cpu_time(
        lambda: (adm.check_drive_range(m, ik.drive, ik.reachable), adm.check_drive_spacing(m, ik.q)), repeat)
    t["joint limits + INA"], _, _ = cpu_time(lambda: adm.check_joint_angles(m, ja.for_admissibility()), repeat)
    t["strut-strut"], _, _ = cpu_time(lambda: adm.check_strut_collision(m, ik.p, ik.q), repeat)
    t["strut-platform"], _, _ = cpu_time(lambda: adm.check_platform_collision(m, ik.q, ik.R, ik.poses[:, :3]), repeat)
    data = drive_load_data(m)
    if data is not None:
        t["drive loads + check"], _, _ = cpu_time(
            lambda: adm.check_drive_load(m, adm.static_drive_loads(m, jc, ik.R, data), data), repeat)
    return t


def main(n: int = 200_000, machine: str = "hexaglide", show_stages: bool = False, repeat: int = 3) -> float:
    """Run the benchmark and print the figures; returns the CPU-time throughput in poses/s."""
    m = pkmstiff.load_machine(machine)
    poses = sample_poses(machine, n)
    c0, t0 = time.process_time(), time.perf_counter()
    evaluate_poses(m, poses[:100])
    print(f"first call (100 poses; JIT compile, or load from numba's cache): {time.process_time() - c0:.2f} s CPU, "
          f"{time.perf_counter() - t0:.2f} s wall")
    cpu, wall, ev = cpu_time(lambda: evaluate_poses(m, poses), repeat)
    rate = n / cpu
    print(f"{machine}: {n} poses in {cpu:.3f} s CPU ({wall:.3f} s wall) -> {rate:,.0f} poses/s "
          f"(one thread; best of {repeat})")
    s = ev.admissibility.summary()  # type: ignore[union-attr]
    print(f"admissible {s['admissible']} of {n}; reasons: "
          + ", ".join(f"{k}={v}" for k, v in s.items() if k not in ("poses", "admissible") and v))
    if show_stages:
        k = min(n, 50_000)
        st = stages(m, poses[:k], repeat)
        print(f"stages for {k} poses (CPU s, best of {repeat}): "
              + ", ".join(f"{name} {v:.3f}" for name, v in st.items()) + f"; sum {sum(st.values()):.3f}")
    return rate


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("n", nargs="?", type=int, default=200_000, help="number of poses")
    ap.add_argument("machine", nargs="?", default="hexaglide", help="bundled machine name")
    ap.add_argument("--stages", action="store_true", help="also time each pipeline stage")
    ap.add_argument("--repeat", type=int, default=3, help="runs per measurement (best is reported)")
    a = ap.parse_args()
    main(a.n, a.machine, a.stages, a.repeat)
