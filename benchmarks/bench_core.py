"""Speed of the simulation core on the paper's case (docs/model.md).

Prints, in one run:

- cold compile: a new process with an empty Numba cache (a temporary ``NUMBA_CACHE_DIR``):
  imports, then the first (compiling) 1-step run of the paper case;
- a new process with a warm cache: imports, then the first 1-step run (cache load);
- the warm wall time of the full paper case (0.3 s, h = 1e-4, 3,000 steps): median of N runs
  in one process, one thread, and the steps per second;
- a profile of a step: the same time loop as ``integrate_chunk`` with a read of the process's
  CPU clock between the stages (the cost of a clock read, measured on an empty loop, is
  subtracted), as the share of each stage in the step.

Wall times are printed with the process's CPU time beside them: on a shared machine the wall
time includes the time the process waited for a core.

Usage: python benchmarks/bench_core.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

ONE_STEP = (
    "import time; t0 = time.perf_counter(); import simcore; "
    "cfg = simcore.load_config(overrides=['solver.t_end=1e-4']); "
    "t1 = time.perf_counter(); simcore.run(cfg); t2 = time.perf_counter(); "
    "print(f'{t1 - t0:.4f} {t2 - t1:.4f}')"
)

STAGES = ("smooth stage", "position correction", "normal velocities before the jump",
          "velocity jump", "accept and outputs")


def _subprocess_times(env_extra: dict) -> tuple[float, float, float]:
    env = dict(os.environ, NUMBA_NUM_THREADS="1", **env_extra)
    start = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", ONE_STEP], capture_output=True, text=True,
                         env=env, check=True).stdout.split()
    total = time.perf_counter() - start
    return float(out[0]), float(out[1]), total


def _profile_kernel():
    """The stage-timing copy of ``integrate_chunk`` (compiled on first use, not cached)."""
    from numba import njit, objmode

    from simcore.kernels import contact_velocities, smooth_step, total_energy
    from simcore.kernels.generalized_alpha import alpha_coefficients
    from simcore.kernels.nonsmooth_step import position_step, velocity_step

    @njit
    def clock():
        with objmode(t="float64"):
            t = time.process_time()  # CPU time: the machine may be shared
        return t

    @njit
    def clock_cost(n):
        t0 = clock()
        for _ in range(n):
            clock()
        return (clock() - t0) / n

    @njit
    def profile(n_steps, st, ma, state, work, spent):
        h, tol, max_iter, eta = st.h, st.tol, st.max_iter, st.eta
        q, v, acc, vdot = state.q, state.v, state.acc, state.vdot
        n = q.shape[0]
        nc = ma.ct_type.shape[0]
        coef = alpha_coefficients(st.rho_inf)
        q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, q1, v1 = work.step
        sw = work.smooth
        nu_c, gap, vn, vt = np.zeros(nc), np.zeros(nc), np.zeros(nc), np.zeros(nc)
        vnf = np.zeros(nc)
        pwk = work.position
        vwk = work.velocity
        energy = 0.0
        for k in range(n_steps):
            t1 = (k + 1) * h
            c0 = clock()
            smooth_step(q, v, acc, vdot, state.lam_s, t1, h, coef, tol, max_iter, ma, q_t,
                        v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, sw, None, 1.0, None)
            c1 = clock()
            position_step(q_t, t1, h, tol, max_iter, eta, ma, Ks_t, q1, nu_c, gap, pwk)
            c2 = clock()
            for j in range(nc):
                s = 0.0
                for i in range(n):
                    s += pwk.GN[j, i] * v_t[i]
                vnf[j] = s
            c3 = clock()
            velocity_step(q1, q_t, v_t, t1, h, tol, max_iter, eta, tol * h, ma, f_t, nu_c,
                          gap, state.vn, state.vt, v1, state.lamN, state.lamT, state.lam_b,
                          vwk)
            c4 = clock()
            q[:] = q1
            v[:] = v1
            acc[:] = acc1
            vdot[:] = vdot1
            contact_velocities(q, v, ma, gap, vn, vt)
            state.vn[:] = vn
            state.vt[:] = vt
            energy += total_energy(q, v, ma)
            c5 = clock()
            spent[0] += c1 - c0
            spent[1] += c2 - c1
            spent[2] += c3 - c2
            spent[3] += c4 - c3
            spent[4] += c5 - c4
        return energy

    return clock_cost, profile


def profile_step(model, s, n_steps: int, repeats: int = 3) -> np.ndarray:
    """Seconds per step spent in each of :data:`STAGES` (minimum over ``repeats`` runs of the
    first ``n_steps`` steps of the case)."""
    from simcore import kernels as nb

    clock_cost, profile = _profile_kernel()
    best = None
    for _ in range(repeats + 1):  # the first run compiles
        arr = model.arrays()
        q, v = model.initial_state()
        n, nc = q.size, arr.ct_type.size
        nbil = int(nb.joint_row_count(arr.jt_type))
        acc, vdot, lam_s = np.zeros(n), np.zeros(n), np.zeros(nbil)
        nb.initial_acceleration(q, v, 0.0, arr, vdot, lam_s, None, 1.0)
        acc[:] = vdot
        gap0, vn0, vt0 = np.zeros(nc), np.zeros(nc), np.zeros(nc)
        nb.contact_velocities(q, v, arr, gap0, vn0, vt0)
        st = nb.StepSettings(float(s["dt"]), float(s["rho_inf"]), float(s["tol"]),
                             int(s["max_iter"]), float(s["proximal"]), int(model.drive_row()),
                             0.0, 1.0, 1e-3)
        state = nb.StepState(q, v, acc, vdot, lam_s, np.zeros(nbil), np.zeros(nc),
                             np.zeros(nc), vn0, vt0)
        spent = np.zeros(len(STAGES))
        profile(n_steps, st, arr, state, nb.nonsmooth_work(n, nbil, nc), spent)
        per_step = spent / n_steps
        best = per_step if best is None else np.minimum(best, per_step)
    cost = min(clock_cost(20000) for _ in range(3))
    return np.maximum(best - cost, 0.0)


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--repeats", type=int, default=5)
    args = p.parse_args()

    with tempfile.TemporaryDirectory() as cache:
        imp, first, total = _subprocess_times({"NUMBA_CACHE_DIR": cache})
        print(f"cold compile (empty cache): import {imp:.2f} s, first 1-step run {first:.2f} s "
              f"(compile of everything a run needs), process total {total:.2f} s")
    _subprocess_times({})  # make sure the default cache is warm
    warm = [_subprocess_times({}) for _ in range(3)]
    print("new process, warm cache: import {:.2f} s, first 1-step run {:.2f} s, process total "
          "{:.2f} s (median of 3)".format(*(statistics.median(w[i] for w in warm)
                                            for i in range(3))))

    import numba

    import simcore
    from simcore.mechanism import crank_slider

    numba.set_num_threads(1)
    cfg = simcore.load_config()
    model, _ = crank_slider(cfg["model"])
    s = cfg["solver"]
    model.simulate(s["dt"], 10 * s["dt"])  # load the kernels
    walls, cpus = [], []
    for _ in range(args.repeats):
        c0 = time.process_time()
        traj = model.simulate(s["dt"], s["t_end"], rho_inf=s["rho_inf"], tol=s["tol"],
                              max_iter=s["max_iter"], proximal=s["proximal"])
        cpus.append(time.process_time() - c0)
        walls.append(traj.wall_time_s)
    n_steps = traj.time.size - 1
    med = statistics.median(walls)
    cpu = statistics.median(cpus)
    print(f"paper case, warm, 1 thread: {n_steps} steps, wall {med:.3f} s median of "
          f"{args.repeats} (min {min(walls):.3f}, max {max(walls):.3f}), "
          f"{n_steps / med:,.0f} steps/s, {1e6 * med / n_steps:.1f} us a step; "
          f"CPU time {cpu:.3f} s median ({n_steps / cpu:,.0f} steps/s)")
    it = traj.iterations[1:]
    print("iterations per step (max/mean): smooth {}/{:.2f}, position {}/{:.2f}, velocity "
          "{}/{:.2f}".format(it[:, 0].max(), it[:, 0].mean(), it[:, 1].max(), it[:, 1].mean(),
                             it[:, 2].max(), it[:, 2].mean()))
    t0 = time.perf_counter()
    simcore.run(cfg)
    print(f"simcore.run of the paper case incl. model build and Dataset: "
          f"{time.perf_counter() - t0:.3f} s")
    per_step = profile_step(model, s, n_steps)
    total = per_step.sum()
    print(f"profile of a step (CPU time, {n_steps} steps, minimum of 3 runs, clock reads "
          f"subtracted): {1e6 * total:.1f} us in the stages")
    for name, sec in zip(STAGES, per_step, strict=True):
        print(f"  {name:<36s} {1e6 * sec:6.1f} us  {100 * sec / total:5.1f} %")


if __name__ == "__main__":
    main()
