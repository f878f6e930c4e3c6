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
- a profile of a step, of the paper case and of a steady run (``STEADY_RUN``): the loop of
  ``integrate_chunk`` where no step is retried, from the run's own start, with a read of the
  thread's CPU clock between the stages (the cost of a read, measured on an empty loop, is
  subtracted); it checks that the profiled steps end where the run's do, to the bit.

Wall times are printed with the process's CPU time beside them: on a shared machine the wall
time includes the time the process waited for a core.

The child processes write Python's bytecode caches (``PYTHONDONTWRITEBYTECODE`` is removed from
their environment), as an installed package has them: without, every process compiles simcore's
sources again (some 50 ms).

Usage: python benchmarks/bench_core.py [--repeats 5] [--first-run-only]
"""

from __future__ import annotations

import argparse
import ctypes
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

#: The overrides of config/config.yaml that give the second profiled run.
STEADY_RUN = ("model.clearance=1e-4", "model.omega0=50.0")
STAGES = ("save the start, smooth stage", "position correction",
          "normal velocities before the jump", "velocity jump", "accept and outputs")


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
    from numba import njit

    from simcore.kernels import smooth_step, total_energy
    from simcore.kernels.contact import contact_velocities_into
    from simcore.kernels.generalized_alpha import alpha_coefficients
    from simcore.kernels.nonsmooth_step import (
        _accept_substep,
        _creates_energy,
        _normal_velocities_before_jump,
        _record_substep,
        _save_step_start,
        _update_energy_scale,
        position_step,
        velocity_step,
    )

    # the thread's CPU time (the machine may be shared) from clock_gettime, called by the kernel
    # itself: a read costs a quarter of a microsecond, where an object-mode call of
    # time.process_time() cost a few and disturbed the stages around it
    clock_gettime = ctypes.CDLL(None, use_errno=True).clock_gettime
    clock_gettime.argtypes = [ctypes.c_int, ctypes.c_void_p]
    clock_gettime.restype = ctypes.c_int
    thread_cpu = time.CLOCK_THREAD_CPUTIME_ID

    @njit
    def clock(now):  # now: a struct timespec (seconds, nanoseconds) to write into
        clock_gettime(thread_cpu, now.ctypes.data)
        return now[0] + 1e-9 * now[1]

    @njit
    def clock_cost(n):
        now = np.zeros(2, dtype=np.int64)
        t0 = clock(now)
        for _ in range(n):
            clock(now)
        return (clock(now) - t0) / n

    def profile(n_steps, st, ma, state, out, work, rs, spent, now):
        # integrate_chunk's loop where no step is retried (the paper case's), its stages
        # timed; main() checks that it takes the run's steps
        h = st.h
        coef = alpha_coefficients(st.rho_inf)
        q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, q1, v1 = work.step
        contact = work.contact
        nu_c, gap, vn_free = contact[0], contact[1], contact[4]
        pwk = work.position
        rw = work.retry
        retried = 0
        for k in range(n_steps):
            t1 = st.t0 + (k + 1) * h
            c0 = clock(now)
            _update_energy_scale(k, out.energy, out.q, ma, rw.energy_scale)
            if rs.max_halvings > 0:
                _save_step_start(state, rw, nu_c, pwk.nu_b)
            it_s, ok_s = smooth_step(state.q, state.v, state.acc, state.vdot, state.lam_s, t1,
                                     h, coef, st, ma, work.step, work.smooth)
            c1 = clock(now)
            it_p, ok_p = position_step(q_t, t1, h, st, ma, Ks_t, q1, nu_c, gap, pwk)
            c2 = clock(now)
            _normal_velocities_before_jump(v_t, pwk.GN, pwk.metric.cols, pwk.metric.ncols,
                                           pwk.nu_b.shape[0], vn_free)
            c3 = clock(now)
            it_v, ok_v = velocity_step(q1, v_t, t1, h, st, ma, f_t, nu_c, gap, state, v1,
                                       work.velocity)
            c4 = clock(now)
            _accept_substep(state, work.step)
            contact_velocities_into(state.q, state.v, ma, gap, contact[2], contact[3],
                                    pwk.scratch.wN, pwk.scratch.wT, pwk.scratch.trig)
            _record_substep(k, 0, 1, h, (it_s, it_p, it_v), st, state, out, contact,
                            rw.lam_best)
            out.energy[k + 1] = total_energy(state.q, state.v, ma)
            ok = ok_s and ok_p and ok_v
            if not ok or _creates_energy(k, h, rs, out, rw.energy_scale):
                retried += 1  # the run would take this step again: the profile is not its
            out.converged[k + 1] = 1 if ok else 0
            c5 = clock(now)
            spent[0] += c1 - c0
            spent[1] += c2 - c1
            spent[2] += c3 - c2
            spent[3] += c4 - c3
            spent[4] += c5 - c4
        return retried

    from simcore.kernels.jit import _STEP
    from simcore.startup.patches import link_only
    # the step kernels' options and linking, not cached (the ctypes clock is a dynamic global)
    options = {key: value for key, value in _STEP.items() if key != "cache"}
    return clock_cost, njit(**options)(link_only(profile))


def profile_step(model, settings, n_steps: int,
                 repeats: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Seconds per step spent in each of :data:`STAGES` (minimum over ``repeats`` runs of the
    first ``n_steps`` steps of the case), and the coordinates q the last run ends at."""
    from simcore.model.driver import (
        _allocate,
        _kernel_settings,
        _nonsmooth_outputs,
        _retry_settings,
        _start,
    )

    clock_cost, profile = _profile_kernel()
    retry = _retry_settings(model, settings)
    best = None
    for _ in range(repeats + 1):  # the first run compiles
        # the run's own start, settings and outputs (those of model.simulate)
        start = _start(model, settings, None, None, 0.0)
        out = _allocate(model, settings, start, 0.0)
        spent = np.zeros(len(STAGES))
        retried = profile(n_steps, _kernel_settings(settings, start.drive_row, 0.0),
                          start.arrays, start.state, _nonsmooth_outputs(out), start.work, retry,
                          spent, np.zeros(2, dtype=np.int64))
        if retried:
            raise RuntimeError(f"{retried} steps of the profiled case need a retry, which the "
                               "profile does not take: it would time other steps than the run")
        per_step = spent / n_steps
        best = per_step if best is None else np.minimum(best, per_step)
    cost = min(clock_cost(20000) for _ in range(3))
    return np.maximum(best - cost, 0.0), start.state.q


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
    # a run of the default study's kind: several balls loaded at once, more contact rows
    steady = simcore.load_config("config/config.yaml", overrides=list(STEADY_RUN))
    profiles = {"paper case (start-up of a free crank)": (cfg, traj),
                f"steady run ({', '.join(STEADY_RUN)})": (steady, None)}
    for title, (case, run) in profiles.items():
        case_model, _ = crank_slider(case["model"])
        settings = SolverSettings.from_config(case)
        if run is None:
            run = case_model.simulate(settings)
        steps = run.time.size - 1
        per_step, q_end = profile_step(case_model, settings, steps)
        # a profile times the run only if it takes the run's steps: the same end, to the bit
        if not np.array_equal(q_end, run.q[-1]):
            apart = np.abs(q_end - run.q[-1]).max()
            raise RuntimeError(f"the profiled steps of the {title} end {apart:.1e} from the "
                               "run's: the profile is not the run's loop")
        total = per_step.sum()
        print(f"profile of a step, {title}: CPU time, {steps} steps, minimum of 3 runs, "
              f"clock reads subtracted; the steps end where the run's do, to the bit: "
              f"{1e6 * total:.1f} us in the stages")
        for name, sec in zip(STAGES, per_step, strict=True):
            print(f"  {name:<36s} {1e6 * sec:6.1f} us  {100 * sec / total:5.1f} %")


if __name__ == "__main__":
    main()
