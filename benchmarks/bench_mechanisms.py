"""Speed targets of issue 14 (generic link-and-joint kinematics).

Run from the repository root:
``python benchmarks/bench_mechanisms.py [--n-ik 10000] [--n-fk 200] [--n-vec 10000] [--repeat 3]``

1. Generic 6-UPS forward kinematics, one pose per call from a nearby start (the solution of a pose 1 mm / 0.1°
   away), target ≤ 5 ms per pose.
2. Inverse kinematics of 10,000 poses of the hybrid machine (``hybrid_tripod_wrist``) in one vectorised call from
   home, target ≤ 2 s.
3. Forward kinematics of 10,000 6-UPS poses in one vectorised call from home, side by side with a dedicated
   vectorised Newton on the platform pose (:func:`dedicated_fk_6ups`, issue 27 item 6: target within 3×) and with
   the full link-and-joint path (``PKMSTIFF_FULL_FK=1``).  The 6-UPS is a mechanism of length legs, so the generic
   call takes the fast path of :mod:`pkmstiff.mechanisms.reduced` (compiled Newton on the platform's 6 coordinates,
   struts in closed form, κ of ∂x_c/∂s from the same 6 × 6 Jacobian); the full path solves the 48 × 42 system of all
   seven links (struts eliminated per Newton step by the block Schur complement of
   :mod:`pkmstiff.mechanisms.fused`) and then the output check.  The dedicated Newton checks nothing.  Compare the
   CPU ratio: on a shared machine wall-clock time is mostly waiting.
Both wall-clock and CPU time of this process are printed (on a shared machine wall-clock includes waiting for the
CPU; the compiled kernels run on numba's threads from 2,048 poses on, so CPU time counts all of them, including
their spin-waiting on a loaded machine).  The IK is timed with numba's default thread count and with one thread.
Best of ``--repeat`` runs.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numba
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
import pkmstiff.mechanisms as mm  # noqa: E402


def timed(fn):
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def dedicated_fk_6ups(base: np.ndarray, plat: np.ndarray, lengths: np.ndarray, tol: float,
                      max_iter: int = 30) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The baseline: a hand-written vectorised Newton for the 6-UPS forward kinematics.

    Unknowns per pose: the platform frame (t, R) (world frame at home, like the generic link frame); residual
    r_i = |t + R p_i − b_i| − l_i; Jacobian rows [n_iᵀ, ((R p_i) × n_i)ᵀ] for a step (δt, δω) with
    R ← exp([δω]×) R; one 6×6 solve per pose and iteration (np.linalg.solve over all poses).  Returns t (N, 3),
    R (N, 3, 3) and the converged mask (max |r| ≤ tol)."""
    N = lengths.shape[0]
    t = np.zeros((N, 3))
    R = np.broadcast_to(np.eye(3), (N, 3, 3)).copy()
    act = np.arange(N)
    ok = np.zeros(N, dtype=bool)
    for _ in range(max_iter):
        Rp = np.einsum("nab,ib->nia", R[act], plat)
        d = t[act, None, :] + Rp - base
        ln = np.linalg.norm(d, axis=-1)
        r = ln - lengths[act]
        done = np.abs(r).max(axis=1) <= tol
        ok[act[done]] = True
        keep = ~done
        act, d, ln, r, Rp = act[keep], d[keep], ln[keep], r[keep], Rp[keep]
        if act.size == 0:
            break
        n = d / ln[..., None]
        J = np.concatenate([n, np.cross(Rp, n)], axis=-1)
        x = np.linalg.solve(J, -r[..., None])[..., 0]
        t[act] += x[:, :3]
        w = x[:, 3:]
        th = np.linalg.norm(w, axis=1)[:, None, None]
        K = np.zeros((act.size, 3, 3))
        K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -w[:, 2], w[:, 1], -w[:, 0]
        K -= np.swapaxes(K, 1, 2)
        with np.errstate(invalid="ignore", divide="ignore"):
            a = np.where(th < 1e-8, 1.0, np.sin(th) / th)
            b = np.where(th < 1e-8, 0.5, (1.0 - np.cos(th)) / th**2)
        R[act] = (np.eye(3) + a * K + b * (K @ K)) @ R[act]
    return t, R, ok


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-ik", type=int, default=10_000)
    ap.add_argument("--n-fk", type=int, default=200)
    ap.add_argument("--n-vec", type=int, default=10_000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    rng = np.random.default_rng(0)

    hexa = mm.load_mechanism("hexapod_6ups")
    P = np.array([0.0, 0.0, 1.2, 0, 0, 0]) + np.column_stack(
        [rng.uniform(-0.2, 0.2, (args.n_fk, 3)), np.radians(rng.uniform(-10, 10, (args.n_fk, 3)))])
    near = P + np.concatenate([np.full(3, 1e-3), np.full(3, np.radians(0.1))])
    targets = mm.inverse(hexa, P).drives
    starts = mm.inverse(hexa, near).q
    mm.forward(hexa, targets[:1], start=starts[:1])  # compile / warm up
    best = (np.inf, np.inf)
    for _ in range(args.repeat):
        def one_by_one():
            return [mm.forward(hexa, targets[i:i + 1], start=starts[i:i + 1]) for i in range(args.n_fk)]
        sols, w, c = timed(one_by_one)
        best = (min(best[0], w), min(best[1], c))
    err = max(np.abs(s.poses[0] - P[i]).max() for i, s in enumerate(sols))
    ok = all(s.converged[0] for s in sols)
    print(f"6-UPS forward kinematics, {args.n_fk} single-pose calls from a nearby start: "
          f"{1e3 * best[0] / args.n_fk:.2f} ms/pose wall, {1e3 * best[1] / args.n_fk:.2f} ms/pose CPU "
          f"(target <= 5 ms); all converged: {ok}; max pose error {err:.1e}")

    # 3. vectorised forward kinematics of many 6-UPS poses from home: generic solver vs the dedicated Newton
    from pkmstiff.mechanisms.constraints import link_rotations

    legs = [j for j in hexa.joints if j.drive is not None]
    base = np.array([j.point for j in hexa.joints if j.type == "cardan"])
    plat = np.array([j.point for j in legs])
    Pv = np.array([0.0, 0.0, 1.2, 0, 0, 0]) + np.column_stack(
        [rng.uniform(-0.2, 0.2, (args.n_vec, 3)), np.radians(rng.uniform(-10, 10, (args.n_vec, 3)))])
    lengths = mm.inverse(hexa, Pv).drives
    tol = 1e-13 * hexa.length_scale
    mm.forward(hexa, lengths[:10])
    mm.forward(hexa, lengths[:4096])  # compile the parallel kernels too
    dedicated_fk_6ups(base, plat, lengths[:10], tol)
    best_g = best_d = cpu_g = cpu_d = cpu_f = np.inf
    for _ in range(args.repeat):
        sol, wg, cg = timed(lambda: mm.forward(hexa, lengths))
        (t_d, R_d, ok_d), wd, cd = timed(lambda: dedicated_fk_6ups(base, plat, lengths, tol))
        os.environ["PKMSTIFF_FULL_FK"] = "1"
        full, _, cf = timed(lambda: mm.forward(hexa, lengths))
        del os.environ["PKMSTIFF_FULL_FK"]
        best_g, best_d, cpu_g, cpu_d = min(best_g, wg), min(best_d, wd), min(cpu_g, cg), min(cpu_d, cd)
        cpu_f = min(cpu_f, cf)
    ip = hexa.link_index("platform")
    dev = max(np.abs(sol.q[:, ip, :3] - t_d).max(), np.abs(link_rotations(sol.q[:, ip, 3:], 3)[0] - R_d).max())
    print(f"6-UPS forward kinematics of {args.n_vec} poses (vectorised, from home): generic {best_g:.3f} s, "
          f"dedicated Newton {best_d:.3f} s wall (ratio {best_g / best_d:.1f}, target <= 3); CPU {cpu_g:.3f} s / "
          f"{cpu_d:.3f} s (ratio {cpu_g / cpu_d:.1f}); converged "
          f"{sol.summary()['converged']} / {int(ok_d.sum())}; max deviation of the platform frame {dev:.1e}")
    print(f"  full link-and-joint path (PKMSTIFF_FULL_FK=1): CPU {cpu_f:.3f} s (ratio {cpu_f / cpu_d:.1f} to the "
          f"dedicated Newton); statuses equal: {bool((full.status == sol.status).all())}; max |q_fast − q_full| "
          f"{np.abs(full.q - sol.q).max():.1e}")

    hyb = mm.load_mechanism("hybrid_tripod_wrist")
    d = np.column_stack([rng.uniform(-0.1, 0.1, (args.n_ik, 3)), rng.uniform(-1.0, 1.0, args.n_ik),
                         np.radians(rng.uniform(20, 60, args.n_ik))])
    poses = mm.forward(hyb, d, steps=2).poses
    mm.inverse(hyb, poses[:10])
    mm.inverse(hyb, poses[:4096])  # compile the parallel kernels too
    threads = numba.get_num_threads()
    for n_threads in dict.fromkeys((threads, 1)):
        numba.set_num_threads(n_threads)
        best_w = best_c = np.inf
        for _ in range(args.repeat):
            sol, w, c = timed(lambda: mm.inverse(hyb, poses))
            best_w, best_c = min(best_w, w), min(best_c, c)
        print(f"hybrid machine inverse kinematics of {args.n_ik} poses (vectorised, from home, {n_threads} "
              f"thread{'s' if n_threads > 1 else ''}): {best_w:.2f} s wall, {best_c:.2f} s CPU (target <= 2 s); "
              f"{sol.summary()}; mean {sol.iterations.mean():.1f} Newton steps")
    numba.set_num_threads(threads)


if __name__ == "__main__":
    main()
