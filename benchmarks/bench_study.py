"""Wall time of the smoke and default studies, and where a job's time goes.

    python benchmarks/bench_study.py              smoke and default studies at -j1 and -j2
    python benchmarks/bench_study.py --smoke      smoke study only (about a minute)
    python benchmarks/bench_study.py --jobs 2     default and smoke studies at -j2 only

Each study runs from scratch (``--forceall``) into a temporary results folder, so ``results/``
is left alone. Printed:

* the wall time of each study and its runs per minute at -j1 and -j2, and the -j2 speed-up;
* per simulate job (one batch of runs, see ``study.batch_axes``): the job's wall time from its
  Snakemake ``benchmark:`` file against the simulation time of its runs (``wall_time_s`` of the
  run files); the difference is the per-job overhead (process start, imports, Numba cache load,
  writing the files);
* the time of each rule (simulate, impacts, summarize, figures) summed over its jobs, from the
  Snakemake ``benchmark:`` files, and the simulated time of the runs (steady runs last
  (settle + revolutions) turns at their own speed, so slow points dominate);
* the same overhead measured directly: a fresh process that imports simcore and runs one step;
* the machine's load average before and after (the numbers are only comparable on an idle
  machine).
"""

from __future__ import annotations

import argparse
import csv
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

ONE_STEP = """
import sys
import time
t0 = time.perf_counter()
import numba
import xarray
import simcore
t1 = time.perf_counter()
simcore.run(simcore.load_config(overrides=["solver.t_end=1.0e-4"]))
t2 = time.perf_counter()
cfg = simcore.load_config()  # the paper's case, default solver settings
t3 = time.perf_counter()
simcore.run(cfg)
t4 = time.perf_counter()
print(t1 - t0, t2 - t1, t4 - t3)
"""


def run_study(configfile: str | None, jobs: int, results: Path) -> float:
    """Run one study from scratch; return its wall time [s]."""
    cmd = [sys.executable, "-m", "snakemake", f"-j{jobs}", "--forceall", "--nolock", "--quiet"]
    if configfile:
        cmd += ["--configfile", configfile]
    cmd += ["--config", f"study={{'results_dir': '{results}'}}"]
    start = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"study failed ({' '.join(cmd)}):\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    return wall


def job_costs(results: Path) -> tuple[list[float], list[list[float]], int]:
    """Per simulate job: wall time [s] and its runs' wall times [s]; number of runs."""
    import xarray as xr

    logs = ROOT / "logs" / "_".join(results.relative_to(results.anchor).parts) / "simulate"
    job_wall, run_wall = [], []
    n_runs = 0
    for bench in sorted(logs.glob("*.benchmark.tsv")):
        with open(bench, newline="") as fh:
            row = next(csv.DictReader(fh, delimiter="\t"))
        batch = bench.name.removesuffix(".benchmark.tsv")
        files = sorted((results / "runs").glob(_batch_glob(batch)))
        walls = []
        for path in files:
            with xr.open_dataset(path) as ds:
                walls.append(float(ds.attrs.get("wall_time_s", float("nan"))))
        n_runs += len(files)
        job_wall.append(float(row["s"]))
        run_wall.append(walls)
    return job_wall, run_wall, n_runs


def _batch_glob(batch: str) -> str:
    """Glob of the run files of a batch named like ``clearance~0.0004_mu~0.01`` (or ``all``)."""
    fixed = dict(re.findall(r"(clearance|mu|omega0|e_N)~([^_]+)", batch))
    keys = ("clearance", "mu", "omega0", "e_N")
    return "_".join(f"{key}~{fixed.get(key, '*')}" for key in keys) + ".nc"


def rule_costs(results: Path) -> dict[str, float]:
    """Seconds per rule summed over its jobs (Snakemake benchmark files)."""
    logs = ROOT / "logs" / "_".join(results.relative_to(results.anchor).parts)
    costs: dict[str, float] = {}
    for bench in logs.rglob("*.benchmark.tsv"):
        rule = bench.parent.name if bench.parent != logs else bench.name.split(".")[0]
        with open(bench, newline="") as fh:
            row = next(csv.DictReader(fh, delimiter="\t"))
        costs[rule] = costs.get(rule, 0.0) + float(row["s"])
    return costs


def simulated_time(results: Path) -> float:
    """Simulated time summed over the run files [s]."""
    import xarray as xr

    total = 0.0
    for path in (results / "runs").glob("*.nc"):
        with xr.open_dataset(path) as ds:
            if "time" in ds.dims:
                total += float(ds["time"][-1] - ds["time"][0])
    return total


def fresh_process() -> tuple[float, float, float, float]:
    """A new process: (imports, first run of one step, one default run, total wall) [s]."""
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", ONE_STEP], capture_output=True, text=True,
                          check=True, cwd=ROOT)
    total = time.perf_counter() - start
    imports, first, run = (float(x) for x in proc.stdout.split())
    return imports, first, run, total - run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="smoke study only")
    parser.add_argument("--jobs", default="1,2", help="comma-separated -j values (default 1,2)")
    args = parser.parse_args()
    job_counts = [int(j) for j in args.jobs.split(",")]
    print("load average before (1, 5, 15 min): " + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    studies = [("smoke", "config/smoke.yaml")]
    if not args.smoke:
        studies.append(("default", None))

    fresh_process()  # fill Numba's cache if the sources changed since the last run
    imports, first, run, overhead = fresh_process()
    print(f"per-job overhead: {overhead:.2f} s = process start and exit + imports {imports:.2f} s"
          f" + first call (Numba cache load, one step) {first:.2f} s")
    print(f"one run of the paper's case (free drive, t_end 0.3 s, dt 1e-4 s): {run:.2f} s; "
          f"a simulate job of 9 runs (study.batch_axes: omega0, e_N) simulates "
          f"{9 * run:.1f} s against {overhead:.2f} s overhead "
          f"({'below' if overhead < 9 * run else 'ABOVE'}); one run per job would be "
          f"{'below' if overhead < run else 'ABOVE'}")

    tmp = Path(tempfile.mkdtemp(prefix="bench_study."))
    try:
        for name, configfile in studies:
            walls = {}
            for jobs in job_counts:
                results = tmp / f"{name}-j{jobs}"
                walls[jobs] = run_study(configfile, jobs, results)
                job_wall, run_wall, n_runs = job_costs(results)
                n_jobs = max(len(job_wall), 1)
                sim = sum(sum(w) for w in run_wall)
                print(f"{name:8s} -j{jobs}: {walls[jobs]:7.1f} s wall, {n_runs} runs, "
                      f"{60 * n_runs / walls[jobs]:6.1f} runs/min; {len(job_wall)} simulate "
                      f"jobs of {sum(job_wall) / n_jobs:.2f} s, of which simulation "
                      f"{sim / n_jobs:.2f} s ({sim / max(n_runs, 1):.2f} s per run; the first "
                      f"run of a job includes the Numba cache load)")
                print(f"{name:8s} -j{jobs}: per rule (summed over jobs): " + ", ".join(
                    f"{rule} {sec:.1f} s" for rule, sec in sorted(rule_costs(results).items()))
                    + f"; simulated time {simulated_time(results):.2f} s")
            if 1 in walls and 2 in walls:
                print(f"{name:8s} speed-up -j2 over -j1: {walls[1] / walls[2]:.2f}x")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        print("load average after (1, 5, 15 min): "
              + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
        for name, _ in studies:
            for jobs in job_counts:
                shutil.rmtree(ROOT / "logs" / "_".join((tmp / f"{name}-j{jobs}").relative_to(
                    tmp.anchor).parts), ignore_errors=True)


if __name__ == "__main__":
    main()
