"""Speed of the simulation core on the paper's case (docs/model.md).

Prints, in one run:

- cold compile: a new process with an empty Numba cache (a temporary ``NUMBA_CACHE_DIR``):
  imports, then the first (compiling) 1-step run of the paper case, whose compile a second
  process shares (``simcore.startup.parallel_compile``): wall time, and the CPU time of both;
- a new process with a warm cache: the first run of the paper case in all, from the interpreter's
  start to the returned dataset (``simcore.run``, the API) and to the written file
  (``python -m simcore run``, the CLI), with where the time goes (``benchmarks/first_run.py``,
  median of N processes each);
- the warm wall time of the full paper case (0.3 s, h = 1e-4, 3,000 steps): median of N runs
  in one process, one thread, and the steps per second;
- a profile of a step: the same time loop as ``integrate_chunk`` with a read of the process's
  CPU clock between the stages (the cost of a clock read, measured on an empty loop, is
  subtracted), as the share of each stage in the step.

Wall times are printed with the process's CPU time beside them: on a shared machine the wall
time includes the time the process waited for a core.

The child processes write Python's bytecode caches (``PYTHONDONTWRITEBYTECODE`` is removed from
their environment), as an installed package has them: without, every process compiles simcore's
sources again (some 50 ms).

Usage: python benchmarks/bench_core.py [--repeats 5] [--first-run-only]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
from _common import timed_repeats

ONE_STEP = (
    "import time; t0 = time.perf_counter(); import simcore; "
    "cfg = simcore.load_config(overrides=['solver.t_end=1e-4']); "
    "t1 = time.perf_counter(); simcore.run(cfg); t2 = time.perf_counter(); "
    "print(f'{t1 - t0:.4f} {t2 - t1:.4f}')"
)

STAGES = ("smooth stage", "position correction", "normal velocities before the jump",
          "velocity jump", "accept and outputs")


def _subprocess_times(env_extra: dict) -> tuple[float, float, float]:
    env = _child_env(**env_extra)
    start = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", ONE_STEP], capture_output=True, text=True,
                         env=env, check=True).stdout.split()
    total = time.perf_counter() - start
    return float(out[0]), float(out[1]), total


def _child_env(**extra) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.update(NUMBA_NUM_THREADS="1", **extra)
    return env


def first_run_stages(path: str, repeats: int) -> list[dict]:
    """Stages of ``repeats`` new processes' first run of the paper case (``path``: "api" or
    "cli"), see ``benchmarks/first_run.py``; one process before them fills the caches."""

    script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "first_run.py")
    rows = []
    for i in range(repeats + 1):
        row = run_child([sys.executable, script, path], _child_env(FIRST_RUN_T0="{t0}"))
        if i:
            rows.append(row)
    return rows


def run_child(argv: list, env: dict) -> dict:
    """Run one ``first_run.py`` process; its JSON stages plus, from this side, ``process_wall``
    (start to exit, interpreter shut-down included) and ``process_cpu`` (its CPU time, user +
    system, shut-down included)."""
    import json
    import resource

    def cpu():
        r = resource.getrusage(resource.RUSAGE_CHILDREN)
        return r.ru_utime + r.ru_stime

    c0, t0 = cpu(), time.time()
    env = {k: v.format(t0=repr(t0)) for k, v in env.items()}
    out = subprocess.run(argv, capture_output=True, text=True, env=env, check=True).stdout
    row = json.loads(out.strip().splitlines()[-1])
    row["process_wall"] = time.time() - t0
    row["process_cpu"] = cpu() - c0
    return row


#: Stages that add up to ``total`` (with ``unlisted``), and parts of ``run`` that do not
#: overlap (with ``run_rest``).
TOP_STAGES = ("start", "import_numpy", "import_numba", "import_simcore", "config", "run")
RUN_PARTS = ("warm_up", "integrate", "import_xarray", "dataset", "write")

#: (key, label, indentation) of the printed breakdown; a stage's parts follow it, indented.
FIRST_RUN_LINES = (
    ("start", "interpreter start-up", 0),
    ("import_numpy", "import numpy", 0),
    ("import_numba", "import numba", 0),
    ("import_simcore", "import simcore (the rest: kernels decorated, config, model)", 0),
    ("config", "load_config (CLI: inside the command)", 0),
    ("run", "the run (API: simcore.run; CLI: the command)", 0),
    ("warm_up", "kernels ready (simulate.warm_up: a 2-step run)", 1),
    ("numba_refresh", "Numba's registries, first kernel call", 2),
    ("scipy_blas", "of which SciPy's scipy.linalg (BLAS check)", 3),
    ("cache_load", "cache load, all specialisations", 2),
    ("cache_index", "of which index look-up and unpickling", 3),
    ("integrate", "integration, 3,000 steps (wall_time_s)", 1),
    ("typeof", "typeof of the argument bundles, every call", 1),
    ("import_xarray", "import xarray, pandas (a thread, beside the integration)", 1),
    ("import_wait", "of which the run waited for after the integration", 2),
    ("dataset", "trajectory_dataset", 1),
    ("write", "write_netcdf", 1),
    ("import_dask", "import dask (inside one of the above, where it happens)", 1),
    ("import_dask_array", "import dask.array (likewise)", 1),
    ("import_netcdf4", "import netCDF4", 1),
    ("run_rest", "the rest of the run (config checks, model, summary, ...)", 1),
    ("unlisted", "the rest (the measuring script's own imports)", 0),
)


def print_first_run(rows_by_path: dict) -> None:
    paths = list(rows_by_path)
    med = {p: {} for p in paths}
    for p, rows in rows_by_path.items():
        for row in rows:  # what the listed stages leave out (harness, checks, summary, ...)
            # an import in the background overlaps the integration: the run waited only
            # import_wait for it
            parts = [k for k in RUN_PARTS if not (k == "import_xarray"
                                                  and row.get("import_background"))]
            row["run_rest"] = (row["run"] - sum(row.get(k, 0.0) for k in parts)
                               - row.get("import_wait", 0.0))
            row["unlisted"] = row["total"] - sum(row[k] for k in TOP_STAGES)
        for key in rows[0]:
            values = [r.get(key, 0.0) for r in rows]
            if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
                med[p][key] = statistics.median(values)
    n = len(next(iter(rows_by_path.values())))
    print(f"new process, warm cache, first run of the paper case (median of {n} processes "
          "each; seconds):")
    print(f"  {'':62s}" + "".join(f"{p.upper():>8s}" for p in paths))
    print(f"  {'total, interpreter start to the dataset / the written file':62s}"
          + "".join(f"{med[p]['total']:8.3f}" for p in paths))
    print(f"  {'the process, start to exit (shut-down included): wall':62s}"
          + "".join(f"{med[p]['process_wall']:8.3f}" for p in paths))
    print(f"  {'the process, start to exit: CPU time (user + system)':62s}"
          + "".join(f"{med[p]['process_cpu']:8.3f}" for p in paths))
    for key, label, depth in FIRST_RUN_LINES:
        if not any(med[p].get(key, 0.0) for p in paths):
            continue
        text = "  " * depth + label
        print(f"    {text:60s}" + "".join(
            f"{med[p].get(key, 0.0):8.3f}" if key in med[p] else f"{'-':>8s}" for p in paths))
    for p in paths:
        loads: dict = {}
        for row in rows_by_path[p]:
            for item in row["loads"]:
                loads.setdefault(item["function"], []).append(item["seconds"])
        calls = med[p].get("typeof_calls", 0)
        print(f"  {p.upper()}: {len(loads)} specialisations loaded (ms each, median): "
              + ", ".join(f"{name} {1e3 * statistics.median(v):.1f}"
                          for name, v in loads.items())
              + f"; {calls:.0f} typeof calls; {med[p]['modules']:.0f} modules imported")


def _profile_kernel():
    """The stage-timing copy of ``integrate_chunk`` (compiled on first use, not cached)."""
    from numba import njit, objmode

    from simcore.kernels import smooth_step, total_energy
    from simcore.kernels.contact import contact_velocities_into
    from simcore.kernels.generalized_alpha import alpha_coefficients
    from simcore.kernels.nonsmooth_step import (
        _accept_substep,
        _normal_velocities_before_jump,
        position_step,
        velocity_step,
    )

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
        # the stages of integrate_chunk's whole step (no retries), a clock read between them
        h = st.h
        coef = alpha_coefficients(st.rho_inf)
        q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, q1, v1 = work.step
        contact = work.contact
        nu_c, gap, vn_free = contact[0], contact[1], contact[4]
        pwk = work.position
        nbil = pwk.nu_b.shape[0]
        energy = 0.0
        for k in range(n_steps):
            t1 = (k + 1) * h
            c0 = clock()
            smooth_step(state.q, state.v, state.acc, state.vdot, state.lam_s, t1, h, coef, st,
                        ma, work.step, work.smooth)
            c1 = clock()
            position_step(q_t, t1, h, st, ma, Ks_t, q1, nu_c, gap, pwk)
            c2 = clock()
            _normal_velocities_before_jump(v_t, pwk.GN, pwk.metric.cols, pwk.metric.ncols,
                                           nbil, vn_free)
            c3 = clock()
            velocity_step(q1, v_t, t1, h, st, ma, f_t, nu_c, gap, state, v1, work.velocity)
            c4 = clock()
            _accept_substep(state, work.step)
            contact_velocities_into(state.q, state.v, ma, gap, contact[2], contact[3],
                                    pwk.scratch.wN, pwk.scratch.wT, pwk.scratch.trig)
            energy += total_energy(state.q, state.v, ma)
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
        nb.initial_acceleration(q, v, 0.0, arr, np.zeros(n), vdot, lam_s, nb.smooth_work(n, nbil))
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
    p.add_argument("--first-run-only", action="store_true",
                   help="print only the new process's first run (API and CLI)")
    args = p.parse_args()

    first = {path: first_run_stages(path, args.repeats) for path in ("api", "cli")}
    print_first_run(first)
    if args.first_run_only:
        return

    with tempfile.TemporaryDirectory() as cache:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        imp, first, total = _subprocess_times({"NUMBA_CACHE_DIR": cache})
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        print(f"cold compile (empty cache): import {imp:.2f} s, first 1-step run {first:.2f} s "
              f"(compile of everything a run needs), process total {total:.2f} s wall, "
              f"{cpu:.1f} s CPU with the compile's helper process")

    import numba

    import simcore
    from simcore.model import SolverSettings
    from simcore.model.mechanism import crank_slider

    numba.set_num_threads(1)
    cfg = simcore.load_config()
    model, _ = crank_slider(cfg["model"])
    s = cfg["solver"]
    model.simulate(SolverSettings(s["dt"], 10 * s["dt"]))  # load the kernels
    timing = timed_repeats(lambda: model.simulate(SolverSettings.from_config(cfg)),
                           args.repeats, lambda traj: traj.wall_time_s)
    traj, med, cpu = timing.result, timing.wall, timing.cpu
    n_steps = traj.time.size - 1
    print(f"paper case, warm, 1 thread: {n_steps} steps, wall {med:.3f} s median of "
          f"{args.repeats} (min {min(timing.walls):.3f}, max {max(timing.walls):.3f}), "
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
