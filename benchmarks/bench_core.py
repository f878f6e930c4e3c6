"""Speed of the simulation core on the paper's case (docs/model.md).

Prints:
- cold compile: a new process with an empty Numba cache, time of the first (compiling) run
  of a 1-step case;
- first step, warm cache: a new process with the package's cache, import + 1-step run;
- warm wall time of the full paper case (0.3 s, h = 1e-4): median of N runs in one process;
- steps per second, and where the time goes (a profile of one stage at a time is not possible
  inside one njit loop, so the stages are timed by running the kernels of one step apart).

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

ONE_STEP = (
    "import time; t0 = time.perf_counter(); import simcore; "
    "cfg = simcore.load_config(overrides=['solver.t_end=1e-4']); "
    "t1 = time.perf_counter(); simcore.run(cfg); t2 = time.perf_counter(); "
    "print(f'{t1 - t0:.4f} {t2 - t1:.4f}')"
)


def _subprocess_times(env_extra: dict) -> tuple[float, float, float]:
    env = dict(os.environ, **env_extra)
    start = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", ONE_STEP], capture_output=True, text=True,
                         env=env, check=True).stdout.split()
    total = time.perf_counter() - start
    return float(out[0]), float(out[1]), total


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--repeats", type=int, default=5)
    args = p.parse_args()

    with tempfile.TemporaryDirectory() as cache:
        imp, first, total = _subprocess_times({"NUMBA_CACHE_DIR": cache})
        print(f"cold compile (empty cache): import {imp:.2f} s, first 1-step run {first:.2f} s, "
              f"process total {total:.2f} s")
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
    walls = []
    for _ in range(args.repeats):
        traj = model.simulate(s["dt"], s["t_end"], rho_inf=s["rho_inf"], tol=s["tol"],
                              max_iter=s["max_iter"])
        walls.append(traj.wall_time_s)
    n_steps = traj.time.size - 1
    med = statistics.median(walls)
    print(f"paper case, warm, 1 thread: {n_steps} steps, wall {med:.3f} s median of "
          f"{args.repeats} (min {min(walls):.3f}, max {max(walls):.3f}), "
          f"{n_steps / med:,.0f} steps/s")
    it = traj.iterations[1:]
    print("iterations per step (max/mean): smooth {}/{:.2f}, position {}/{:.2f}, velocity "
          "{}/{:.2f}".format(it[:, 0].max(), it[:, 0].mean(), it[:, 1].max(), it[:, 1].mean(),
                             it[:, 2].max(), it[:, 2].mean()))
    t0 = time.perf_counter()
    simcore.run(cfg)
    print(f"simcore.run of the paper case incl. model build and Dataset: "
          f"{time.perf_counter() - t0:.3f} s")


if __name__ == "__main__":
    main()
