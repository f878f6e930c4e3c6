"""The Snakemake study workflow: dry runs, configuration checks, file names, the summary."""

from __future__ import annotations

import importlib.util
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import xarray as xr

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def results(tmp_path):
    """A results folder in tmp_path; its job logs (under logs/ in the repository) are removed."""
    path = tmp_path / "res"
    yield path
    shutil.rmtree(ROOT / "logs" / "_".join(path.relative_to(path.anchor).parts),
                  ignore_errors=True)


def snakemake(*args, timeout=120):
    """Run Snakemake in the repository root; return the completed process (text output)."""
    cmd = [sys.executable, "-m", "snakemake", "--nolock", *args]
    return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout)


def job_counts(output: str) -> dict[str, int]:
    """The 'Job stats' table of a Snakemake run as {rule: count}."""
    table = output.split("Job stats:", 1)[1]
    counts = {}
    for line in table.splitlines()[3:]:
        parts = line.split()
        if len(parts) != 2 or not parts[1].isdigit():
            break
        counts[parts[0]] = int(parts[1])
    return counts


def test_dry_run_default_study():
    proc = snakemake("-n", "--forceall")
    assert proc.returncode == 0, proc.stderr + proc.stdout
    counts = job_counts(proc.stdout + proc.stderr)
    # 3 x 3 x 3 x 3 grid, one job per (clearance, mu) batch, which also makes the impact tables
    assert counts["simulate"] == 9 and "impacts" not in counts
    assert counts["summarize"] == 1 and counts["figures"] == 1
    assert len(set(re.findall(r"results/runs/\S+?\.nc", proc.stdout + proc.stderr))) == 81
    assert len(set(re.findall(r"results/impacts/\S+?\.nc", proc.stdout + proc.stderr))) == 81


def test_dry_run_smoke_study():
    proc = snakemake("-n", "--forceall", "--configfile", "config/smoke.yaml")
    assert proc.returncode == 0, proc.stderr + proc.stdout
    out = proc.stdout + proc.stderr
    assert job_counts(out)["simulate"] == 4
    assert len(set(re.findall(r"results/smoke/runs/\S+?\.nc", out))) == 4


def test_one_run_per_job_when_no_batch_axes():
    proc = snakemake("-n", "--forceall", "--configfile", "config/smoke.yaml",
                     "--config", "study={'batch_axes': [], 'results_dir': 'results/smoke'}",
                     "sweep={'clearance': [1.0e-4], 'mu': [0.0], 'omega0': [25.0, 50.0], "
                     "'e_N': [0.8, 0.9]}")
    assert proc.returncode == 0, proc.stderr + proc.stdout
    assert job_counts(proc.stdout + proc.stderr)["simulate"] == 4


@pytest.mark.parametrize(
    "override, key",
    [
        ("model={'clearance': -1.0e-4}", "model.clearance"),
        ("sweep={'e_N': [0.9, 1.5]}", "sweep.e_N"),
        ("model={'e_N': 1.2}", "model.e_N"),
        ("model={'bogus': 1}", "model.bogus: unknown key"),
        ("sweep={'mu': []}", "sweep.mu"),
        ("sweep={'mu': [0.01, 0.0100000000001]}", "sweep.mu"),
        ("study={'batch_axes': ['omega']}", "study.batch_axes"),
    ],
)
def test_bad_config_stops_before_any_job(results, override, key):
    # not a dry run: if the check came late, jobs would start and write into `results`
    proc = snakemake("-j1", "--config", override, f"study={{'results_dir': '{results}'}}")
    message = proc.stdout + proc.stderr
    assert proc.returncode != 0
    assert key in message, message
    assert "invalid configuration" in message
    assert not results.exists()
    assert "rule simulate" not in message


def test_file_names_carry_no_float_noise():
    sweep = "sweep={'clearance': [4.0e-4], 'mu': [0.30000000000000004, 0.1], " \
            "'omega0': [50.00000000000001], 'e_N': [0.9]}"
    proc = snakemake("-n", "--forceall", "--configfile", "config/smoke.yaml", "--config", sweep)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    names = set(re.findall(r"runs/(\S+?)\.nc", proc.stdout + proc.stderr))
    assert names == {"clearance~0.0004_mu~0.1_omega0~50.0_e_N~0.9",
                     "clearance~0.0004_mu~0.3_omega0~50.0_e_N~0.9"}


@pytest.mark.skipif(importlib.util.find_spec("snakemake_executor_plugin_slurm") is None,
                    reason="snakemake-executor-plugin-slurm is not installed ('.[slurm]')")
def test_slurm_profile_dry_run():
    proc = snakemake("--profile", "profiles/slurm", "-n", "--forceall")
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    assert "Group job runs" in out  # short runs are packed into few cluster jobs
    assert job_counts(out)["simulate"] == 9


def test_lint_is_clean():
    proc = snakemake("--lint")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def _check_study(results: Path) -> xr.Dataset:
    """Outputs of a finished study exist and open; failed points are exactly the marker files."""
    runs = sorted((results / "runs").glob("*.nc"))
    assert runs and len(runs) == len(list((results / "impacts").glob("*.nc")))
    assert list((results / "figures").glob("*.png"))
    assert not list(results.rglob(".*.tmp")), "a temporary file was left behind"
    s = xr.load_dataset(results / "summary.nc")
    assert {"clearance", "mu", "omega0", "e_N"} <= set(s.dims)
    assert s["failed"].size == len(runs)
    for path in runs:
        with xr.open_dataset(path) as run:
            point = {key: run[key].item() for key in ("clearance", "mu", "omega0", "e_N")}
            failed = int(run.attrs.get("failed", 0))
        assert float(s["failed"].sel(point)) == failed
        assert bool(s["wall_time_s"].sel(point).isnull()) == bool(failed)
    return s


@pytest.mark.slow
def test_smoke_study_end_to_end(results):
    proc = snakemake("-j2", "--configfile", "config/smoke.yaml", "--config",
                     f"study={{'results_dir': '{results}'}}", timeout=900)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    _check_study(results)


@pytest.mark.slow
def test_failed_runs_do_not_stop_the_study(results):
    """Too few Newton iterations: some runs fail, the study still finishes and marks them."""
    proc = snakemake("-j2", "--configfile", "config/smoke.yaml", "--config",
                     "solver={'t_end': 1.0e-3, 'max_iter': 3}",
                     f"study={{'results_dir': '{results}'}}", timeout=900)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    s = _check_study(results)
    n_failed = int(s["failed"].sum())
    assert 1 <= n_failed, "expected at least one run to fail with max_iter = 3"
    assert re.search(r"WARNING: run clearance=\S+, mu=\S+, omega0=\S+, e_N=\S+ failed", out)
    assert "failed run (marked missing" in out


@pytest.mark.slow
def test_killed_study_resumes_and_redoes_only_the_unfinished(results):
    """Stop a study (SIGTERM, as Ctrl-C or a batch system does) once its first run file exists;
    every file left under results/ opens, and the next call finishes the study without redoing
    that run."""
    import os
    import signal
    import time

    cmd = [sys.executable, "-m", "snakemake", "--nolock", "-j1", "--configfile",
           "config/smoke.yaml", "--config", f"study={{'results_dir': '{results}'}}"]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    deadline = time.monotonic() + 600
    first = []
    while time.monotonic() < deadline and not first and proc.poll() is None:
        time.sleep(0.2)
        first = sorted((results / "runs").glob("*.nc"))
    assert first, "no run finished before the study ended or timed out"
    os.killpg(proc.pid, signal.SIGTERM)
    proc.wait(timeout=120)
    done = {p: p.stat().st_mtime_ns for p in results.rglob("*.nc")}
    assert len(done) < 4 + 4 + 1, "the study finished before it could be stopped"
    for path in done:
        xr.open_dataset(path).close()  # nothing half-written
    resumed = snakemake("-j2", "--rerun-incomplete", "--configfile", "config/smoke.yaml",
                        "--config", f"study={{'results_dir': '{results}'}}", timeout=900)
    assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    _check_study(results)
    for path, mtime in done.items():
        assert path.stat().st_mtime_ns == mtime, f"{path.name} was redone"
