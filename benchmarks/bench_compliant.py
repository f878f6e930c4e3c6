"""Speed of the compliant (Hertz) model on the paper's case, and the cost of one zoom.

Prints:
- steps per second of the compliant paper case (dt = 1e-6 s, E = 2.1e11 Pa, output every
  10 steps), median of N runs of ``--t-end`` seconds in one process on one thread (kernels
  loaded before timing), by wall time and by CPU time; and the CPU time of the same runs in
  kernel calls of 500 steps (the nonsmooth model's default chunk) instead of the compliant
  default;
- Newton iterations per step (smooth stage) and joint projection iterations;
- where the time goes: one step's parts timed apart in compiled loops (force evaluation without
  and with tangents, the Newton matrix solve, the explicit inverse of its factors that the
  chord iterates after it use, a chord iterate's update, the joint projection, the energy of
  an output sample), at the paper case's end and at a loaded state (the study's reference
  point's compliant twin after 0.2 s, at a step of 8 us);
- the cost of one zoom (0.5 ms at dt = 1e-6 s from the largest impact of a nonsmooth run);
- the cost of a compliant step in the study's setting: a zoom of a steady run of the default
  study (clearance 1e-4 m, omega0 = 50 rad/s) on its largest impact, 2,000 steps, where the
  loaded balls stay in contact with both races.

Usage: python benchmarks/bench_compliant.py [--repeats 5] [--t-end 0.05]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from _common import steady_run_largest_impact, timed_repeats


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--t-end", type=float, default=0.05)
    args = p.parse_args()

    import numba

    numba.set_num_threads(1)
    import simcore
    from simcore import kernels as nb
    from simcore.config import load_config
    from simcore.model import SolverSettings
    from simcore.model.driver import DEFAULT_CHUNK
    from simcore.model.mechanism import crank_slider
    from simcore.study.plan import twin_config

    cfg = load_config(overrides=["model.youngs_modulus=2.1e11"])
    model, _ = crank_slider(cfg["model"])
    dt = 1e-6
    fast = dict(contact_model="compliant", output_every=10)
    model.simulate(SolverSettings(dt, 20 * dt, **fast))  # load kernels
    timing = timed_repeats(lambda: model.simulate(SolverSettings(dt, args.t_end, **fast)),
                           args.repeats, lambda traj: traj.wall_time_s)
    traj, med, cmed = timing.result, timing.wall, timing.cpu
    n_steps = round(args.t_end / dt)
    print(f"compliant paper case (E = 2.1e11 Pa, dt = 1e-6 s, {n_steps} steps, 1 thread), "
          f"median of {args.repeats}: wall {med:.3f} s -> {n_steps / med:,.0f} steps/s; "
          f"CPU time {cmed:.3f} s -> {n_steps / cmed:,.0f} steps/s, "
          f"{1e6 * cmed / n_steps:.1f} us/step (CPU time: the machine may be shared)")
    small = timed_repeats(lambda: model.simulate(SolverSettings(dt, args.t_end, chunk=500,
                                                                **fast)),
                          args.repeats, lambda traj: traj.wall_time_s)
    print(f"the same in kernel calls of 500 steps instead of the compliant default "
          f"{DEFAULT_CHUNK['compliant']} (the checks between calls): CPU time "
          f"{small.cpu:.3f} s median, {small.cpu / cmed:.3f} times the default's")
    it = traj.iterations[1:]
    print(f"Newton iterations per step (largest of each 10-step interval): smooth max "
          f"{it[:, 0].max()}, mean {it[:, 0].mean():.2f}; joint projection max {it[:, 1].max()}")

    # the parts of one step, timed apart inside compiled loops (a call from Python would
    # mostly time the unboxing of the model bundle) at the loaded state where the run ended
    st = traj.extras["step_state"]
    cs = traj.extras["compliant_state"]
    arr = model.arrays()
    from numba import njit

    from simcore.kernels.compliant_step import (
        JointRows,
        chord_apply,
        chord_operator,
        compliant_work,
        newton_solve,
        project_joints_into,
        projection_work,
    )
    from simcore.kernels.generalized_alpha import (
        WITH_CONTACT_BLOCKS,
        alpha_coefficients,
        joint_coefficient,
        newton_matrix_into,
        smooth_work,
    )
    from simcore.kernels.hertz import (
        RECORD_ROWS,
        ContactLaw,
        contact_forces_into,
        elastic_energy_into,
        hertz_work,
    )
    from simcore.kernels.linalg import copy_vector

    hw = hertz_work()

    @njit
    def loop_forces(q, v, ma, v_pre, hw, tangent, reps):
        n, nc = q.shape[0], ma.ct_type.shape[0]
        f, K, C, Ks = np.zeros(n), np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
        w = np.zeros((RECORD_ROWS, nc))
        skip = np.zeros(nc, dtype=np.bool_)
        law = ContactLaw(v_pre, 1e-4)
        for _ in range(reps):
            nb.smooth_forces(q, v, ma, f, K, C, Ks, tangent)
            contact_forces_into(q, v, ma, law, f, K, C, tangent, w, hw, None, skip)
        return K, C

    @njit
    def loop_chord(rhs, G, cv, sw, bw, reps):
        # a chord iterate's update (products with the explicit inverse of the last factors)
        for _ in range(reps):
            copy_vector(sw.sol, rhs, rhs.shape[0])
            chord_apply(sw.fac, G, cv, 1.0, bw, sw.sol)

    @njit
    def loop_solve(J, rhs, G, cv, sw, bw, reps):
        # the Newton step as the compliant stage takes it (on a copy of the residual)
        for _ in range(reps):
            copy_vector(sw.sol, rhs, rhs.shape[0])
            newton_solve(J, G, cv, sw.sol, sw.fac, sw.S, sw.piv, bw)

    @njit
    def loop_operator(G, cv, sw, bw, reps):
        # the explicit inverse of a Newton step's factors, made for the chord iterates after it
        for _ in range(reps):
            chord_operator(sw.fac, G, cv, sw.S, sw.piv, bw)

    @njit
    def loop_project(q, v, ma, pw, reps):
        q1, v1 = np.zeros(q.shape[0]), np.zeros(q.shape[0])
        m = pw.g.shape[0]
        g, G, dgdt = np.zeros(m), np.zeros((m, q.shape[0])), np.zeros(m)
        nb.bilateral(q, v, 0.0, ma, g, G, np.zeros(m), dgdt)
        for _ in range(reps):
            project_joints_into(q, v, 0.0, 1e-6, 1e-5, 50, ma, q1, v1, pw, None,
                                JointRows(g, G, dgdt))

    @njit
    def loop_energy(q, v, ma, hw, reps):
        e = 0.0
        for _ in range(reps):
            e += nb.total_energy(q, v, ma) + elastic_energy_into(q, ma, None)
        return e

    def cpu(fn, *a):
        fn(*a, 1)
        t0 = time.process_time()
        fn(*a, 20000)
        return (time.process_time() - t0) / 20000 * 1e6

    def print_parts(what, st, cs, arr, J_of):
        """One step's parts at the state (st, cs) of a model with arrays ``arr``; ``J_of(K,
        C, arr)``: the Newton matrix and the coefficient cv of the joint rows."""
        K, C = loop_forces(st.q, st.v, arr, cs.v_pre, hw, np.bool_(True), 1)
        n = st.q.size
        m = nb.joint_row_count(arr.jt_type)
        G = np.zeros((m, n))
        nb.bilateral(st.q, st.v, 0.0, arr, np.zeros(m), G, np.zeros(m), np.zeros(m))
        J, cv = J_of(K, C, arr)
        rhs = np.ones(n + m)
        bw = compliant_work(n, m, arr.ct_type.size).branches
        sw = smooth_work(n, m)
        newton = cpu(loop_solve, J, rhs, G, cv, sw, bw)
        operator = cpu(loop_operator, G, cv, sw, bw)
        print(f"parts of a step, {what} (CPU us, {int(cs.closed.sum())} contacts closed): "
              f"forces {cpu(loop_forces, st.q, st.v, arr, cs.v_pre, hw, np.bool_(False)):.2f} "
              f"and with tangents "
              f"{cpu(loop_forces, st.q, st.v, arr, cs.v_pre, hw, np.bool_(True)):.2f} per "
              f"evaluation, Newton solve {newton:.2f}, chord operator {operator:.2f}, chord "
              f"update {cpu(loop_chord, rhs, G, cv, sw, bw):.2f}, joint projection "
              f"{cpu(loop_project, st.q, st.v, arr, projection_work(n, m)):.2f}, energy (per "
              f"output sample) {cpu(loop_energy, st.q, st.v, arr, hw):.2f}")

    print_parts("paper case", st, cs, arr,
                lambda K, C, arr: (np.diag(arr.mdiag) + 1e-12 * K + 1.5e-6 * C, 1.5e-6))

    # a loaded state: the reference point's twin (steady, several balls loaded) after 0.2 s
    twin = twin_config(load_config(overrides=[
        "model.clearance=4e-4", "model.mu=0.01", "model.omega0=50", "model.e_N=0.9",
        "model.youngs_modulus=2.1e11", "model.drive=constant"]))
    twin_model, _ = crank_slider(twin["model"])
    twin_settings = SolverSettings.from_config(twin, t_end=0.2)
    end = twin_model.simulate(twin_settings).extras
    coef = alpha_coefficients(twin_settings.rho_inf)
    h = 8e-6  # about the twin's mean step there

    def twin_matrix(K, C, arr):
        J = np.zeros_like(K)
        newton_matrix_into(J, K, C, h, coef, arr, WITH_CONTACT_BLOCKS)
        return J, joint_coefficient(h, coef)

    print_parts(f"reference point's twin at t = 0.2 s, h = {h:g} s", end["step_state"],
                end["compliant_state"], twin_model.arrays(), twin_matrix)

    run = simcore.run(load_config(overrides=["solver.t_end=0.004"]))
    lam = run["Lambda_N"].values
    k = np.unravel_index(int(np.argmax(lam)), lam.shape)
    t_imp = float(run.time[k[0]])
    simcore.zoom(run, t_imp, window=1e-5, adaptive=False)  # load
    zooms = []
    for _ in range(3):
        start = time.perf_counter()
        simcore.zoom(run, t_imp, window=5e-4, dt=1e-6, adaptive=False)
        zooms.append(time.perf_counter() - start)
    print(f"one zoom (0.5 ms at dt = 1e-6 s, 500 steps, incl. model build and Dataset): "
          f"{statistics.median(zooms):.3f} s median of 3")

    # the study's setting: a zoom of a steady run (default study config, clearance 1e-4 m,
    # omega0 = 50 rad/s) on its largest impact, where the loaded balls stay in contact
    run, t_imp = steady_run_largest_impact()
    dt_zoom, n_zoom = 3.128e-6, 2000  # the study's zoom step at this point
    timing = timed_repeats(
        lambda: simcore.zoom(run, t_imp, window=n_zoom * dt_zoom, dt=dt_zoom,
                             until_released=False, adaptive=False),
        args.repeats, lambda z: z.attrs["wall_time_s"])
    closed = int((timing.result["F_N"].values[-1] > 0.0).sum())
    print(f"study zoom (steady run, {closed} contacts loaded, {n_zoom} steps of "
          f"{dt_zoom:.4g} s), median of {args.repeats}: integration {timing.wall:.3f}"
          f" s wall -> {1e6 * timing.wall / n_zoom:.1f} us/step; whole zoom "
          f"{timing.cpu:.3f} s CPU")


if __name__ == "__main__":
    main()
