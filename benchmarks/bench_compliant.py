"""Speed of the compliant (Hertz) model on the paper's case, and the cost of one zoom.

Prints:
- steps per second of the compliant paper case (dt = 1e-6 s, E = 2.1e11 Pa, output every
  10 steps), median of N runs of ``--t-end`` seconds in one process on one thread (kernels
  loaded before timing);
- Newton iterations per step (smooth stage) and joint projection iterations;
- where the time goes: one step's parts timed apart (force evaluation with tangents, the
  Newton matrix solve, the joint projection);
- the cost of one zoom (0.5 ms at dt = 1e-6 s from the largest impact of a nonsmooth run).

Usage: python benchmarks/bench_compliant.py [--repeats 5] [--t-end 0.02]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def _time(fn, repeats=2000):
    fn()
    start = time.perf_counter()
    for _ in range(repeats):
        fn()
    return (time.perf_counter() - start) / repeats


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--t-end", type=float, default=0.02)
    args = p.parse_args()

    import numba

    numba.set_num_threads(1)
    import simcore
    from simcore import kernels as nb
    from simcore.config import load_config
    from simcore.mechanism import crank_slider

    cfg = load_config(overrides=["model.youngs_modulus=2.1e11"])
    model, _ = crank_slider(cfg["model"])
    dt = 1e-6
    model.simulate(dt, 20 * dt, contact_model="compliant", output_every=10)  # load kernels
    walls = []
    for _ in range(args.repeats):
        traj = model.simulate(dt, args.t_end, contact_model="compliant", output_every=10)
        walls.append(traj.wall_time_s)
    n_steps = round(args.t_end / dt)
    med = statistics.median(walls)
    print(f"compliant paper case (E = 2.1e11 Pa, dt = 1e-6 s, {n_steps} steps, 1 thread): "
          f"wall {med:.3f} s median of {args.repeats} (min {min(walls):.3f}, "
          f"max {max(walls):.3f}) -> {n_steps / med:,.0f} steps/s, "
          f"{1e6 * med / n_steps:.1f} us/step")
    it = traj.iterations[1:]
    print(f"Newton iterations per step (largest of each 10-step interval): smooth max "
          f"{it[:, 0].max()}, mean {it[:, 0].mean():.2f}; joint projection max {it[:, 1].max()}")

    # the parts of one step, timed apart at a loaded state of the run
    st = traj.extras["step_state"]
    cs = traj.extras["compliant_state"]
    arr = model.arrays()
    n, nc = st.q.size, arr.ct_type.size
    f, K, C, Ks = np.zeros(n), np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    w = np.zeros((11, nc))

    def forces():
        nb.smooth_forces(st.q, st.v, arr, f, K, C, Ks, True)
        nb.contact_forces(st.q, st.v, arr, cs.v_pre, 1e-4, f, K, C, True, w[0], w[1], w[2],
                          w[3], w[4], w[5:11])

    J = np.diag(arr.mdiag) + 1e-12 * K + 1e-6 * C
    m = nb.joint_row_count(arr.jt_type)
    G = np.zeros((m, n))
    nb.bilateral(st.q, st.v, 0.0, arr, np.zeros(m), G, np.zeros(m), np.zeros(m))
    rhs = np.ones(n + m)
    from simcore.kernels.generalized_alpha import _newton_direction

    def solve():
        _newton_direction(J, rhs, G, 1.5e-6)

    q1, v1 = np.zeros(n), np.zeros(n)

    def project():
        nb.project_joints(st.q, st.v, 0.0, dt, 1e-5, 50, arr, q1, v1)

    t_f, t_s, t_p = _time(forces), _time(solve), _time(project)
    print(f"one evaluation of forces and tangents {1e6 * t_f:.1f} us, one Newton matrix solve "
          f"(block inverse + joint Schur complement) {1e6 * t_s:.1f} us, joint projection "
          f"{1e6 * t_p:.1f} us")

    run = simcore.run(load_config(overrides=["solver.t_end=0.004"]))
    lam = run["Lambda_N"].values
    k = np.unravel_index(int(np.argmax(lam)), lam.shape)
    t_imp = float(run.time[k[0]])
    simcore.zoom(run, t_imp, window=1e-5)  # load
    zooms = []
    for _ in range(3):
        start = time.perf_counter()
        simcore.zoom(run, t_imp, window=5e-4, dt=1e-6)
        zooms.append(time.perf_counter() - start)
    print(f"one zoom (0.5 ms at dt = 1e-6 s, 500 steps, incl. model build and Dataset): "
          f"{statistics.median(zooms):.3f} s median of 3")


if __name__ == "__main__":
    main()
