"""Runs per minute of a study at -j1 and -j2, bytes per run file, and where a job's time goes.

    python benchmarks/bench_study.py                   24-point study (benchmarks/study24.yaml,
                                                       both models) at -j1 and -j2, bytes per
                                                       run file
    python benchmarks/bench_study.py --default 3       also the default study (81 points x 2
                                                       models) at -j2, 3 times (median)
    python benchmarks/bench_study.py --smoke           the smoke study instead of the 24 points
    python benchmarks/bench_study.py --jobs 2          only -j2
    python benchmarks/bench_study.py --default 1 --only-default
                                                       only the default study, once
    python benchmarks/bench_study.py --large --only-default
                                                       only the 2,000-run study (clearance x
                                                       mu, nonsmooth runs), once

Each study runs from scratch (``--forceall``) into a temporary results folder, so ``results/``
is left alone; the Numba caches are warmed first (one run and one zoom in a fresh process), so
every figure is a warm one. Printed:

* the wall time of each study and its runs per minute at -j1 and -j2, and the -j2 speed-up;
* per simulate job (one batch of runs of about ``study.batch_seconds`` of estimated work, and
  their impact tables): the job's wall time from its Snakemake ``benchmark:`` file against the
  simulation time of its runs (``wall_time_s`` of the run files); the rest is the impact tables
  (filter, forces, compliant zooms) and the per-job overhead (process start, imports, Numba
  cache load, writing);
* the study's estimate (the line it prints before its first job) against the measured wall
  time, and the measured costs beside the constants of the estimate
  (``simcore.study.plan.COST``): a nonsmooth step, the compliant runs' integration, a zoom, the
  rest of a run and a job's start;
* the time of each rule (simulate, summarize, figures) summed over its jobs, from the
  Snakemake ``benchmark:`` files, and the simulated time of the runs (steady runs last
  (settle + revolutions) turns at their own speed, so slow points dominate);
* bytes per run file with the default ``study.keep``: median over the study's runs, and the
  paper's case (``python -m simcore run`` without arguments, 3,000 steps);
* where the wall time went, from the ``TIMING`` lines the job scripts write into their logs:
  Snakemake's start until the first job, the simulate jobs' time summed by stage (process
  start, imports, Numba load, integration, run files, impact extraction, zooms, tables), the
  core time left idle during the simulate stage (the reference run's figures are drawn in it),
  then summarize and figures (the critical path after the last simulate job);
* the same overhead measured directly: a fresh process that imports simcore and runs one step;
* the machine's load average before and after (the numbers are only comparable on an idle
  machine).
"""

from __future__ import annotations

import argparse
import csv
import json
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


def run_study(configfile: str | None, jobs: int, results: Path) -> tuple[float, float, str]:
    """Run one study from scratch; return its wall time [s], its start [s since the epoch]
    and its terminal output."""
    cmd = [sys.executable, "-m", "snakemake", f"-j{jobs}", "--forceall", "--nolock", "--quiet"]
    if configfile:
        cmd += ["--configfile", configfile]
    cmd += ["--config", f"study={{'results_dir': '{results}'}}"]
    started = time.time()
    start = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"study failed ({' '.join(cmd)}):\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    return wall, started, proc.stdout + proc.stderr


def _timing(log: Path) -> dict | None:
    """The ``TIMING {json}`` line a job script wrote into its log (workflow/scripts/_job.py)."""
    if not log.exists():
        return None
    for line in log.read_text(errors="replace").splitlines():
        if line.startswith("TIMING "):
            return json.loads(line[len("TIMING "):])
    return None


def breakdown(results: Path, started: float, wall: float, cores: int = 2) -> list[str]:
    """Where a study's wall time went, from the TIMING lines of its jobs' logs.

    Lines: Snakemake's own start (from the command to the first job's process), the simulate
    jobs summed (process start, imports, Numba load, integration, the rest of a run, writing
    the run files, impact extraction, zooms, writing the tables), the span of the simulate
    stage and the core time left idle in it, then summarize, figures and the gaps between
    them (the critical path after the last simulate job).
    """
    logs = ROOT / "logs" / "_".join(results.relative_to(results.anchor).parts)
    jobs = [t for t in (_timing(p) for p in sorted((logs / "simulate").glob("*.log")))
            if t is not None]
    summ, figs = _timing(logs / "summarize.log"), _timing(logs / "figures.log")
    ref = _timing(logs / "reference_figures.log")  # drawn during the simulate stage
    if not jobs:
        return ["(no TIMING lines in the simulate logs: a tool older than this benchmark)"]
    keys = ["numba_load", "integration", "run_other", "write_runs", "extract", "zoom",
            "write_tables", "table_other"]
    total = {k: sum(j[k] for j in jobs) for k in keys}
    start_cost = sum(j["script_start"] - j["process_start"] for j in jobs)
    imports = sum(j["imported"] - j["script_start"] for j in jobs)
    busy = sum(j["end"] - j["process_start"] for j in jobs)
    first = min(j["process_start"] for j in jobs)
    last = max(j["end"] for j in jobs)
    n_runs = sum(int(j["runs"]) for j in jobs)
    ref_busy = 0.0
    if ref is not None:  # the part of the reference figures' job inside the simulate stage
        ref_busy = max(0.0, min(ref["end"], last) - max(ref["process_start"], first))
    lines = [
        f"snakemake start (parse, DAG, warm-up check) until the first job: {first - started:.1f} s",
        f"simulate: {len(jobs)} jobs, {n_runs} runs, {busy:.1f} s of job time summed: "
        f"process start {start_cost:.1f} s, imports {imports:.1f} s, Numba load "
        f"{total['numba_load']:.1f} s, integration {total['integration']:.1f} s "
        f"({total['integration'] / max(n_runs, 1):.2f} s a run), rest of simcore.run "
        f"{total['run_other']:.1f} s, run files {total['write_runs']:.1f} s, impact extraction "
        f"{total['extract']:.1f} s, zooms {total['zoom']:.1f} s "
        f"({total['zoom'] / max(n_runs, 1):.2f} s a run), tables {total['write_tables']:.1f} s, "
        f"other {total['table_other']:.1f} s",
        f"simulate stage: {last - first:.1f} s wall; "
        f"{cores * (last - first) - busy - ref_busy:.1f} core-s idle "
        f"({100 * (1 - (busy + ref_busy) / (cores * (last - first))):.0f} % of {cores} cores)",
    ]
    if ref is not None:
        lines.append(f"reference figures: {ref['end'] - ref['process_start']:.1f} s, "
                     f"{ref_busy:.1f} s of it during the simulate stage")
    end = last
    for name, t in (("summarize", summ), ("figures", figs)):
        if t is None:
            continue
        lines.append(f"{name}: starts {t['process_start'] - end:.1f} s after the previous "
                     f"stage, {t['end'] - t['process_start']:.1f} s (process start and imports "
                     f"{t['imported'] - t['process_start']:.1f} s)")
        end = t["end"]
    lines.append(f"end of the last job to the end of snakemake: {started + wall - end:.1f} s")
    return lines


def job_costs(results: Path) -> tuple[list[float], list[list[float]], int]:
    """Per simulate job: wall time [s] and its runs' wall times [s]; number of runs (the run
    files listed in the job's marker, ``results/.batches/<batch>.json``)."""
    import netCDF4

    logs = ROOT / "logs" / "_".join(results.relative_to(results.anchor).parts) / "simulate"
    job_wall, run_wall = [], []
    n_runs = 0
    for bench in sorted(logs.glob("*.benchmark.tsv")):
        with open(bench, newline="") as fh:
            row = next(csv.DictReader(fh, delimiter="\t"))
        batch = bench.name.removesuffix(".benchmark.tsv")
        marker = json.loads((results / ".batches" / f"{batch}.json").read_text())
        walls = []
        for run in marker["runs"]:
            with netCDF4.Dataset(run["run"]) as nc:
                walls.append(float(getattr(nc, "wall_time_s", float("nan"))))
        n_runs += len(walls)
        job_wall.append(float(row["s"]))
        run_wall.append(walls)
    return job_wall, run_wall, n_runs


def study_config(configfile: str | None) -> dict:
    """The study's configuration as the workflow makes it: ``configfile`` merged over
    config/config.yaml (:func:`simcore.config.read_study_config`), validated."""
    from simcore.config import read_study_config, validate_config

    files = [ROOT / "config" / "config.yaml"] + ([ROOT / configfile] if configfile else [])
    return validate_config(read_study_config(files))


def estimate_check(results: Path, wall: float, out: str, configfile: str | None) -> list[str]:
    """The study's printed estimate against its wall time, and the measured costs beside the
    constants of the estimate (simcore.study.plan.COST), from the jobs' TIMING lines: a
    nonsmooth step, the adaptive twins' integration (estimated from their planned fixed steps,
    ``COST.compliant_step`` and ``COST.adaptive_share``), a zoom of those the runs ask for
    (``analysis.zoom_top``, at most five a run; rows that share an impact share its zoom), the
    rest of a run and a job's start."""
    from simcore.study.plan import COST, plan_runs, zooms_counted

    logs = ROOT / "logs" / "_".join(results.relative_to(results.anchor).parts)
    jobs = [t for t in (_timing(p) for p in sorted((logs / "simulate").glob("*.log")))
            if t is not None]
    lines = []
    match = re.search(r"^study: (.*)$", out, re.M)
    if match:
        lines.append(f"printed before the first job: {match.group(1)}; measured: {wall:.0f} s")
    if not jobs:
        return lines
    runs = plan_runs(study_config(configfile))
    total = {key: sum(j.get(key, 0) for j in jobs) for key in (
        "steps_nonsmooth", "steps_compliant", "integration_nonsmooth", "integration_compliant",
        "zoom")}
    n_runs = sum(j["runs"] - j.get("skipped", 0) for j in jobs)
    per_run = sum(j["write_runs"] + j["extract"] + j["write_tables"] + j["table_other"]
                  + j["run_other"] for j in jobs) / max(n_runs, 1)
    per_job = sum(j["imported"] - j["process_start"] + j["numba_load"] for j in jobs) / len(jobs)
    asked = sum(zooms_counted(run.config["analysis"].get("zoom_top", 0)) for run in runs
                if run.model == "nonsmooth")
    parts = []
    if total["steps_nonsmooth"]:
        parts.append(f"nonsmooth step "
                     f"{1e6 * total['integration_nonsmooth'] / total['steps_nonsmooth']:.3g} us "
                     f"(estimate {1e6 * COST.nonsmooth_step:.3g})")
    if total["steps_compliant"]:
        planned = sum(run.seconds - COST.per_run for run in runs if run.model == "compliant")
        parts.append(f"compliant runs' integration {total['integration_compliant']:.1f} s "
                     f"(estimate {planned:.1f} s; a step taken "
                     f"{1e6 * total['integration_compliant'] / total['steps_compliant']:.3g} us)")
    if asked:
        parts.append(f"zoom {total['zoom'] / asked:.3g} s (estimate {COST.per_zoom})")
    parts.append(f"rest of a run {per_run:.3f} s (estimate {COST.per_run})")
    cpu = sum(j.get("cpu", float("nan")) for j in jobs)
    busy = sum(j["end"] - j["process_start"] for j in jobs)
    lines.append(f"simulate jobs: {cpu:.0f} CPU-s of their processes against {busy:.0f} s of "
                 "their wall time (a CPU-s count below the wall time: the machine was shared)")
    parts.append(f"job start {per_job:.2f} s (estimate {COST.per_job})")
    lines.append("measured cost: " + ", ".join(parts))
    return lines


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


def file_sizes(results: Path) -> list[int]:
    """Bytes of each run file of a study (failed-run markers left out)."""
    import xarray as xr

    sizes = []
    for path in sorted((results / "runs").glob("*.nc")):
        with xr.open_dataset(path) as ds:
            failed = int(ds.attrs.get("failed", 0))
        if not failed:
            sizes.append(path.stat().st_size)
    return sizes


def paper_case_bytes(folder: Path) -> int:
    """Bytes of the paper's case run file (``python -m simcore run``, default study.keep)."""
    out = folder / "paper.nc"
    subprocess.run([sys.executable, "-m", "simcore", "run", "--quiet", "--out", str(out)],
                   cwd=ROOT, check=True, capture_output=True)
    return out.stat().st_size


def main() -> None:
    import statistics

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true",
                        help="the smoke study instead of the 24-point study")
    parser.add_argument("--jobs", default="1,2", help="comma-separated -j values (default 1,2)")
    parser.add_argument("--default", type=int, default=0, metavar="N",
                        help="also run the default study (81 grid points, both models) N times "
                             "at -j2 (median)")
    parser.add_argument("--only-default", action="store_true",
                        help="with --default: leave out the small study")
    parser.add_argument("--large", action="store_true",
                        help="also the 2,000-run study (benchmarks/study2000.yaml: clearance x "
                             "mu, nonsmooth runs) at -j2, once (about 10 minutes)")
    args = parser.parse_args()
    job_counts = [int(j) for j in args.jobs.split(",")]
    print("load average before (1, 5, 15 min): " + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    studies = [] if (args.only_default and (args.default or args.large)) else [
        ("smoke", "config/smoke.yaml", job_counts, 1) if args.smoke else
        ("study24", "benchmarks/study24.yaml", job_counts, 1)]
    if args.default:
        studies.append(("default", None, [2], args.default))
    if args.large:
        studies.append(("study2000", "benchmarks/study2000.yaml", [2], 1))

    fresh_process()  # fill Numba's cache if the sources changed since the last run
    imports, first, run, overhead = fresh_process()
    print(f"per-job overhead: {overhead:.2f} s = process start and exit + imports {imports:.2f} s"
          f" + first call (Numba cache load, one step) {first:.2f} s")
    print(f"one run of the paper's case (free drive, t_end 0.3 s, dt 1e-4 s): {run:.2f} s")

    tmp = Path(tempfile.mkdtemp(prefix="bench_study."))
    made = []
    try:
        print(f"bytes per run file (default study.keep): paper's case {paper_case_bytes(tmp):,}")
        for name, configfile, jobs_list, repeat in studies:
            walls = {}
            for jobs in jobs_list:
                times = []
                for rep in range(repeat):
                    results = tmp / f"{name}-j{jobs}-{rep}"
                    made.append(results)
                    wall, started, out = run_study(configfile, jobs, results)
                    times.append(wall)
                    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
                    job_wall, run_wall, n_runs = job_costs(results)
                    n_jobs = max(len(job_wall), 1)
                    sim = sum(sum(w) for w in run_wall)
                    print(f"{name:8s} -j{jobs}: {times[-1]:7.1f} s wall, {n_runs} runs, "
                          f"{60 * n_runs / times[-1]:6.1f} runs/min (load average after: "
                          f"{load}); {len(job_wall)} simulate jobs of "
                          f"{sum(job_wall) / n_jobs:.2f} s, of which simulation "
                          f"{sim / n_jobs:.2f} s ({sim / max(n_runs, 1):.2f} s per run), the rest "
                          "impact tables with zooms and job overhead", flush=True)
                    print(f"{name:8s} -j{jobs}: per rule (summed over jobs): " + ", ".join(
                        f"{rule} {sec:.1f} s" for rule, sec in sorted(rule_costs(results).items()))
                        + f"; simulated time {simulated_time(results):.2f} s", flush=True)
                    for line in breakdown(results, started, wall, cores=jobs) + \
                            estimate_check(results, wall, out, configfile):
                        print(f"{name:8s} -j{jobs}:   {line}", flush=True)
                walls[jobs] = statistics.median(times)
                sizes = file_sizes(results)
                if repeat > 1:
                    print(f"{name:8s} -j{jobs}: median of {repeat}: {walls[jobs]:.1f} s, "
                          f"{60 * n_runs / walls[jobs]:.1f} runs/min (all: "
                          + ", ".join(f"{t:.1f}" for t in times) + " s)")
                if sizes:
                    print(f"{name:8s}: bytes per run file (default study.keep): median "
                          f"{statistics.median(sizes):,.0f}, {min(sizes):,} to {max(sizes):,} "
                          f"over {len(sizes)} runs")
            if 1 in walls and 2 in walls:
                print(f"{name:8s} speed-up -j2 over -j1: {walls[1] / walls[2]:.2f}x")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        print("load average after (1, 5, 15 min): "
              + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
        for results in made:
            shutil.rmtree(ROOT / "logs" / "_".join(results.relative_to(results.anchor).parts),
                          ignore_errors=True)


if __name__ == "__main__":
    main()
