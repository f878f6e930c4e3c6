"""The Snakemake study workflow: dry runs, configuration checks, file names, the summary."""

from __future__ import annotations

import importlib.util
import re
import shutil
import subprocess
import sys
import warnings
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
    proc = snakemake("-n", "--forceall", "-j2")
    assert proc.returncode == 0, proc.stderr + proc.stdout
    out = proc.stdout + proc.stderr
    counts = job_counts(out)
    # 3 x 3 x 3 x 3 grid, each point with both models, in jobs of about study.batch_seconds
    line = re.search(r"study: 81 grid points x 2 models \(nonsmooth, compliant\) = 162 runs in "
                     r"(\d+) jobs, estimated .+ on 2 cores", out)
    assert line, out
    assert counts["simulate"] == int(line.group(1)) >= 4 and "impacts" not in counts
    assert counts["summarize"] == 1 and counts["figures"] == 1


def test_dry_run_smoke_study():
    proc = snakemake("-n", "--forceall", "--configfile", "config/smoke.yaml")
    assert proc.returncode == 0, proc.stderr + proc.stdout
    out = proc.stdout + proc.stderr
    assert "study: 4 grid points x 2 models (nonsmooth, compliant) = 8 runs in 4 jobs" in out
    assert job_counts(out)["simulate"] == 4


def test_dry_run_groove_study():
    """config/groove.yaml (docs/model.md): the three clearances with contacts in the plane and
    in grooves."""
    proc = snakemake("-n", "--forceall", "--configfile", "config/groove.yaml")
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    assert "study: 6 grid points x 2 models (nonsmooth, compliant) = 12 runs" in out


def test_a_setting_null_by_default_can_be_swept():
    """analysis.life_load_rating is null unless given: sweeping it plans the study (the
    reference point is chosen over the other axes)."""
    proc = snakemake("-n", "--forceall", "--configfile", "config/smoke.yaml", "--config",
                     "sweep={'analysis.life_load_rating': [10000.0, 20000.0]}")
    assert proc.returncode == 0, proc.stderr + proc.stdout
    assert "study: 8 grid points x 2 models" in proc.stdout + proc.stderr


def test_a_boolean_can_be_set_and_swept_from_the_command_line():
    """Snakemake passes --config values as text: true and false are booleans, as in a file."""
    proc = snakemake("-n", "--forceall", "--configfile", "config/smoke.yaml", "--config",
                     "sweep={'analysis.zoom_adaptive': [true, false]}",
                     "model={'guard_contacts': True}")
    assert proc.returncode == 0, proc.stderr + proc.stdout
    assert "study: 8 grid points x 2 models" in proc.stdout + proc.stderr


def test_a_sweep_axis_from_the_command_line_replaces_the_files_by_either_name():
    """config/smoke.yaml sweeps mu: sweep.model.mu on the command line replaces that list."""
    proc = snakemake("-n", "--forceall", "--configfile", "config/smoke.yaml", "--config",
                     "sweep={'model.mu': [0.0, 0.01, 0.02]}")
    assert proc.returncode == 0, proc.stderr + proc.stdout
    assert "study: 6 grid points x 2 models" in proc.stdout + proc.stderr


def test_a_bearing_axis_is_held_by_its_name_from_the_command_line():
    """--config passes 6205 as a number: held in study.figure_fixed it is the bearing's name,
    as in a sweep's list; a name the axis lacks is still refused."""
    proc = snakemake("-n", "--forceall", "--configfile", "config/smoke_bearings.yaml",
                     "--config", "study={'figure_fixed': {'bearing': '6205'}}")
    assert proc.returncode == 0, proc.stderr + proc.stdout
    proc = snakemake("-n", "--forceall", "--configfile", "config/smoke_bearings.yaml",
                     "--config", "study={'figure_fixed': {'bearing': '6206'}}")
    assert proc.returncode == 2 and "study.figure_fixed.bearing" in proc.stdout + proc.stderr


def test_an_integer_axis_is_held_at_a_whole_number_only():
    """study.figure_fixed holds n_balls at one of its values: 8.5 is refused, not cut to 8."""
    proc = snakemake("-n", "--forceall", "--configfile", "config/smoke.yaml", "--config",
                     "sweep={'model.n_balls': [8, 9]}", "study={'figure_fixed': {'n_balls': 8.5}}")
    message = proc.stdout + proc.stderr
    lines = [x for x in message.splitlines() if "invalid configuration" in x]
    assert proc.returncode == 2 and len(lines) == 1, message
    assert "study.figure_fixed.n_balls: 8.5 is not allowed; allowed: one of" in lines[0], message


def test_a_clearance_list_a_clearance_class_replaces_is_named():
    """config/smoke.yaml sweeps the clearance: a class set beside it takes the axis' place,
    which a WARNING line says, naming both keys."""
    proc = snakemake("-n", "--forceall", "--configfile", "config/smoke.yaml", "--config",
                     "model={'clearance_class': 'C3'}")
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    assert "study: 2 grid points" in out
    assert ("WARNING: sweep.clearance = [0.0001, 0.0004] is given and replaced by "
            "model.clearance_class = 'C3'") in out, out


def test_batches_are_sized_by_work_whatever_the_axes():
    """The same 8 runs along other axes: one job per run when each run exceeds
    study.batch_seconds, one job for all (at least four) when they fit in it."""
    sweep = ("sweep={'clearance': [1.0e-4], 'mu': [0.0], 'omega0': [50.0], 'e_N': [0.9], "
             "'model.cage_stiffness': [1.0e+4, 1.0e+5], 'solver.rho_inf': [0.0, 0.5], "
             "'drive': ['free', 'constant']}")
    for seconds, jobs in ((0.01, 8), (1.0e+4, 4)):
        proc = snakemake("-n", "--forceall", "--configfile", "config/smoke.yaml", "--config",
                         f"study={{'batch_seconds': {seconds}, 'models': ['nonsmooth'], "
                         "'results_dir': 'results/smoke'}", sweep)
        out = proc.stdout + proc.stderr
        assert proc.returncode == 0, out
        assert job_counts(out)["simulate"] == jobs, out


@pytest.mark.parametrize(
    "override, key",
    [
        ("model={'clearance': -1.0e-4}", "model.clearance"),
        ("sweep={'e_N': [0.9, 1.5]}", "sweep.e_N"),
        ("model={'e_N': 1.2}", "model.e_N"),
        ("model={'bogus': 1}", "model.bogus: unknown key"),
        ("sweep={'mu': []}", "sweep.mu"),
        ("sweep={'mu': [0.01, 0.0100000000001]}", "sweep.mu"),
        ("sweep={'model.bogus': [1.0]}", "sweep.model.bogus: unknown key"),
        ("sweep={'model.cage_stiffness': [1.0e+5, -1.0]}", "sweep.model.cage_stiffness.1"),
        ("sweep={'model.contact_model': ['compliant']}", "sweep.model.contact_model"),
        ("study={'batch_axes': ['omega0']}", "study.batch_axes: unknown key"),
        ("study={'dask_scheduler': 'not-an-address'}", "study.dask_scheduler: 'not-an-address'"),
        ("study={'figure_axes': ['mu', 'gravity']}", "study.figure_axes: 'gravity'"),
        ("study={'figure_fixed': {'omega0': 51.0}}", "study.figure_fixed.omega0: 51.0"),
        ("study={'keep': ['Lambda_N', 'F_N', 'position', 'angle']}",
         "study.keep lacks 'crank_angle' (the summary (nonsmooth runs)"),
    ],
)
def test_bad_config_stops_before_any_job(results, override, key):
    # not a dry run: if the check came late, jobs would start and write into `results`
    proc = snakemake("-j1", "--config", override, f"study={{'results_dir': '{results}'}}")
    message = proc.stdout + proc.stderr
    assert proc.returncode == 2, message  # as `python -m simcore run` on bad input
    # one line naming the key, without Snakemake's frame (the file and lines it came from)
    lines = [x for x in message.splitlines() if "invalid configuration" in x]
    assert len(lines) == 1 and key in lines[0], message
    assert "Error in file" not in message and 'File "' not in message, message
    assert not results.exists()
    assert "rule simulate" not in message


def test_a_study_outside_the_repository_without_its_base_settings_stops(tmp_path):
    """Run from a folder that lacks config/config.yaml, with only a smaller --configfile (which
    Snakemake then reads alone), the study stops naming the base settings instead of running
    at the schema's defaults."""
    (tmp_path / "config").mkdir()
    shutil.copy(ROOT / "config" / "smoke.yaml", tmp_path / "config" / "smoke.yaml")
    proc = subprocess.run([sys.executable, "-m", "snakemake", "--nolock", "-j1", "-s",
                           str(ROOT / "Snakefile"), "--configfile", "config/smoke.yaml"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    message = proc.stdout + proc.stderr
    assert proc.returncode == 2, message
    lines = [x for x in message.splitlines() if "invalid configuration" in x]
    assert len(lines) == 1 and lines[0].startswith(
        "invalid configuration: config/config.yaml: not found in"), message
    assert not (tmp_path / "results").exists() and not (tmp_path / "logs").exists()


@pytest.mark.parametrize("folder", ["", "/", "//", "{file}", "{file}/results", "results/{{x}}",
                                    "{{batch}}/results", "results}}"])
def test_a_results_folder_that_cannot_hold_results_is_refused(folder, tmp_path):
    """The root (where an empty results_dir would put the study), a file or a path with
    Snakemake's wildcard braces is refused, naming study.results_dir (a dry run: nothing would
    be written even if the check were missing)."""
    existing = tmp_path / "a_file"
    existing.write_text("not a folder")
    folder = folder.format(file=existing)
    proc = snakemake("-n", "-j1", "--configfile", "config/smoke.yaml", "--config",
                     f"study={{'results_dir': '{folder}'}}")
    message = proc.stdout + proc.stderr
    assert proc.returncode == 2, message
    lines = [x for x in message.splitlines() if "invalid configuration" in x]
    assert len(lines) == 1 and "study.results_dir" in lines[0], message
    assert "Traceback" not in message


def test_a_figures_folder_holding_other_files_is_refused_and_kept(results):
    """The figures job replaces <results_dir>/figures as a whole: a study's own figures are
    replaced on a re-run, but a folder holding anything else (a user's file, the repository's
    docs/figures) is refused before any job, naming the file, which stays."""
    figures = results / "figures"
    figures.mkdir(parents=True)
    for name in ("study_peak_force_outer_nonsmooth.png", "pairs_p_max_inner_compliant.png",
                 "life_clearance_speed.png", "reference_lambda.png", "summary_table.csv",
                 ".snakemake_timestamp"):
        (figures / name).write_text("a study's")
    study = f"study={{'results_dir': '{results}'}}"
    proc = snakemake("-n", "-j1", "--configfile", "config/smoke.yaml", "--config", study)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    (figures / "notes.txt").write_text("mine")
    for folder, named in ((str(results), str(figures / "notes.txt")),
                          ("docs", "docs/figures/")):
        proc = snakemake("-n", "-j1", "--configfile", "config/smoke.yaml", "--config",
                         f"study={{'results_dir': '{folder}'}}")
        message = proc.stdout + proc.stderr
        lines = [x for x in message.splitlines() if "invalid configuration" in x]
        assert proc.returncode == 2 and len(lines) == 1, message
        assert f"study.results_dir: {folder!r}" in lines[0] and named in lines[0], message
    assert (figures / "notes.txt").read_text() == "mine"


def test_a_sweep_of_ten_thousand_points_stops_before_any_job_until_max_runs_allows_it(results):
    study = f"'results_dir': '{results}'"
    proc = snakemake("-j2", "--configfile", "benchmarks/study10000.yaml", "--config",
                     f"study={{{study}}}")
    message = proc.stdout + proc.stderr
    assert proc.returncode != 0 and not results.exists()
    assert re.search(r"invalid configuration: study\.max_runs: 10,000 grid points x 1 model "
                     r"\(nonsmooth\) = 10,000 runs in \d+ jobs, estimated [\d.]+ (min|h)", message)
    assert "at most study.max_runs = 5,000 runs" in message
    proc = snakemake("-n", "-j2", "--configfile", "benchmarks/study10000.yaml", "--config",
                     f"study={{{study}, 'max_runs': 10000}}")
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    assert "study: 10,000 grid points x 1 model (nonsmooth) = 10,000 runs" in out
    assert job_counts(out)["simulate"] >= 100


@pytest.mark.skipif(importlib.util.find_spec("snakemake_executor_plugin_slurm") is None,
                    reason="snakemake-executor-plugin-slurm is not installed ('.[slurm]')")
def test_slurm_profile_dry_run():
    proc = snakemake("--profile", "profiles/slurm", "-n", "--forceall")
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    assert "Group job runs" in out  # short runs are packed into few cluster jobs
    assert job_counts(out)["simulate"] >= 4


def test_lint_is_clean():
    proc = snakemake("--lint")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def _check_study(results: Path) -> xr.Dataset:
    """Outputs of a finished study exist and open; failed points are exactly the marker files."""
    from simcore.study.plan import FOLDERS

    s = xr.load_dataset(results / "summary.nc")
    axes = s.attrs["study_axes"].split()
    assert {"clearance", "mu", "omega0", "e_N", "model"} <= set(s.dims)
    meanings = s["model"].attrs["flag_meanings"].split()
    n_runs = 0
    for model, (run_dir, table_dir) in FOLDERS.items():
        runs = sorted((results / run_dir).glob("*.nc"))
        assert runs and len(runs) == len(list((results / table_dir).glob("*.nc")))
        n_runs += len(runs)
        for path in runs:
            with xr.open_dataset(path) as run:
                point = {key: run[key].item() for key in axes}
                assert run["model"].item() == meanings.index(model)
                failed = int(run.attrs.get("failed", 0))
                if not failed:  # the settings every point shares, as the runs have them
                    for key in {"bearing", "n_balls", "youngs_modulus", "drive"} - set(axes):
                        assert s.attrs[f"model_{key}"] == run.attrs[f"model.{key}"], key
            at = dict(point, model=meanings.index(model))
            assert float(s["failed"].sel(at)) == failed
            assert bool(s["wall_time_s"].sel(at).isnull()) == bool(failed)
    assert list((results / "figures").glob("*.png"))
    assert not list(results.rglob(".*.tmp")), "a temporary file was left behind"
    assert s["failed"].size == n_runs
    assert not {f"model_{name}" for name in axes} & set(s.attrs)  # (swept: not one value)
    return s


@pytest.mark.slow
def test_smoke_study_end_to_end(results):
    proc = snakemake("-j2", "--configfile", "config/smoke.yaml", "--config",
                     f"study={{'results_dir': '{results}'}}", timeout=900)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    _check_study(results)
    # --forceall redoes every run, not only the missing ones (docs/study.md)
    before = {p: p.stat().st_mtime_ns for p in (results / "runs").glob("*.nc")}
    proc = snakemake("-j2", "--forceall", "--until", "summarize", "--configfile",
                     "config/smoke.yaml", "--config", f"study={{'results_dir': '{results}'}}",
                     timeout=900)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert all(p.stat().st_mtime_ns != mtime for p, mtime in before.items())


@pytest.mark.slow
def test_a_study_over_any_two_settings_runs_with_their_units_and_names(results):
    """Issue 25: cage stiffness x Young's modulus, no code: the summary has both as dimensions
    with the schema's units and long names, and figures are drawn for them. (At the paper's
    modulus the compliant twins indent the balls beyond Hertz's range, which
    solver.max_indentation = 0.1 stops; the study is run with it raised.)"""
    from simcore.config.parameters import parameter

    proc = snakemake("-j2", "--configfile", "config/smoke.yaml", "--config",
                     f"study={{'results_dir': '{results}'}}",
                     "solver={'max_indentation': 0.6}",
                     "sweep={'clearance': [4.0e-4], 'mu': [0.01], 'omega0': [100.0], "
                     "'e_N': [0.9], 'model.cage_stiffness': [1.0e+4, 1.0e+5], "
                     "'youngs_modulus': [2.1e+9, 2.1e+11]}", timeout=1800)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    s = _check_study(results)
    assert s.attrs["study_axes"].split() == ["clearance", "mu", "omega0", "e_N",
                                             "cage_stiffness", "youngs_modulus"]
    for key, units in (("model.cage_stiffness", "N m-1"), ("model.youngs_modulus", "Pa")):
        name = parameter(key).name
        assert s.sizes[name] == 2 and s[name].attrs["units"] == units
        assert s[name].attrs["long_name"] == parameter(key).long_name
    assert int(s["failed"].sum()) == 0
    assert s["peak_force"].sizes["model"] == 2
    # the heat maps are drawn over the two swept settings (analysis.figures.figure_layout)
    from analysis.figures import figure_layout

    layout = figure_layout(s)
    assert (layout.x, layout.y) == ("cage_stiffness", "youngs_modulus")
    names = {p.name for p in (results / "figures").glob("study_*.png")}
    assert {"study_peak_force_outer_nonsmooth.png", "study_method_ratio_outer.png"} <= names


@pytest.mark.slow
def test_a_study_over_bearings_and_classes(results):
    """config/smoke_bearings.yaml: the 6205 and the 6012, each in CN and C3. Every run has its
    bearing's balls, the summary its class's clearance for each bearing's bore over both axes
    and each bearing's static rating, all read from the data files here."""
    from importlib import resources

    import numpy as np
    import yaml

    data = resources.files("simcore").joinpath("data")
    catalogue = yaml.safe_load(data.joinpath("bearings.yaml").read_text())
    rows = yaml.safe_load(data.joinpath("clearance_iso5753.yaml").read_text())["rows"]
    proc = snakemake("-j2", "--configfile", "config/smoke_bearings.yaml", "--config",
                     f"study={{'results_dir': '{results}'}}", timeout=900)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    s = xr.load_dataset(results / "summary.nc")
    assert s.attrs["study_axes"].split() == ["mu", "omega0", "e_N", "bearing", "clearance_class"]
    assert s.sizes["bearing"] == 2 and s.sizes["clearance_class"] == 2
    assert "clearance" not in s.dims and int(s["failed"].sum()) == 0
    assert not {"model_bearing", "model_n_balls", "model_ball_radius"} & set(s.attrs)
    names = s["bearing"].attrs["flag_meanings"].split()
    classes = s["clearance_class"].attrs["flag_meanings"].split()
    assert [names[c] for c in s["bearing"].values] == ["6205", "6012"]
    for code in s["bearing"].values:
        entry = catalogue[names[code]]
        row = next(r for r in rows if r["over"] < entry["d"] <= r["incl"])
        for cls in s["clearance_class"].values:
            lo, hi = row[classes[cls]]
            at = {"bearing": code, "clearance_class": cls}
            assert float(s["clearance"].sel(at).squeeze()) == pytest.approx(0.25e-6 * (lo + hi))
        assert np.all(s["static_load_rating"].sel(bearing=code).values == entry["C0"])
        assert np.all(s["L10h"].sel(bearing=code).values > 0)
    for path in (results / "runs").glob("*.nc"):
        with xr.open_dataset(path) as run:
            entry = catalogue[run.attrs["model.bearing"]]
            assert run.attrs["model.n_balls"] == entry["Z"]
            assert run.sizes["contact"] == 2 * entry["Z"]
    from analysis.figures import figure_layout

    layout = figure_layout(s)
    assert {layout.x, layout.y} == {"bearing", "clearance_class"}
    figures = {p.name for p in (results / "figures").glob("*.png")}
    assert {"life_clearance_speed.png", "study_peak_force_outer_compliant.png"} <= figures


@pytest.mark.slow
def test_failed_runs_do_not_stop_the_study(results):
    """Too few Newton iterations and no retries of a failed step (a retry's velocity jump may
    take four times the cap): some runs fail, the study still finishes and marks them."""
    proc = snakemake("-j2", "--configfile", "config/smoke.yaml", "--config",
                     "solver={'t_end': 1.0e-3, 'max_iter': 3, 'max_halvings': 0}",
                     f"study={{'results_dir': '{results}'}}", timeout=900)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    s = _check_study(results)
    n_failed = int(s["failed"].sum())
    assert 1 <= n_failed, "expected at least one run to fail with max_iter = 3, no retries"
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
    assert len(done) < 8 + 8 + 1, "the study finished before it could be stopped"
    for path in done:
        xr.open_dataset(path).close()  # nothing half-written
    resumed = snakemake("-j2", "--rerun-incomplete", "--configfile", "config/smoke.yaml",
                        "--config", f"study={{'results_dir': '{results}'}}", timeout=900)
    assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    _check_study(results)
    for path, mtime in done.items():
        assert path.stat().st_mtime_ns == mtime, f"{path.name} was redone"


@pytest.mark.parametrize(("overrides", "named"), [
    ([], "the source paper's SKF-6012 ball bearing"),
    (["model.bearing=6205", "model.clearance_class=C3"], "the 6205 ball bearing")])
def test_the_report_texts_render_and_name_the_studys_bearing(overrides, named):
    """The report's texts (Jinja templates that Snakemake fills with the study's configuration)
    render for the default study and for a catalogue bearing, and name that bearing; the
    captions of five kinds of figure render to text."""
    from types import SimpleNamespace

    import jinja2

    import simcore

    with warnings.catch_warnings():  # the base clearance beside a class: a study's, unsaid
        warnings.filterwarnings("ignore", "model.clearance = .* is given and replaced")
        config = simcore.load_config("config/config.yaml", overrides=overrides)
    report = ROOT / "workflow" / "report"
    text = jinja2.Template((report / "workflow.rst").read_text()).render(
        snakemake=SimpleNamespace(config=config))
    assert named in " ".join(text.split())
    caption = jinja2.Template((report / "figures.rst").read_text())
    names = ["study_peak_force_outer_compliant", "study_method_ratio_outer",
             "life_clearance_speed", "study_L10h", "study_p_max_groove_inner_nonsmooth"]
    for name in names:
        words = caption.render(snakemake=SimpleNamespace(
            config=config, wildcards=SimpleNamespace(name=name))).split()
        assert len(words) > 10, name
