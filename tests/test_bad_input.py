"""Every bad input of the issue on the bearing's integrity ends in one line naming the key and
what is allowed, exit code 2, before any work, and no file: the inputs that ended in a
traceback, the misleading messages, and the output paths of every command."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from command_line import call

import simcore
from analysis.__main__ import main as analysis_main
from simcore.cli import main as simcore_main


def _assert_refused(main, argv, words, folder: Path):
    before = sorted(folder.rglob("*"))
    code, lines = call(main, argv)
    assert code == 2, (argv, code, lines)
    assert len(lines) == 1 and lines[0].startswith("error: "), (argv, lines)
    for word in words:
        assert word in lines[0], (argv, word, lines[0])
    assert sorted(folder.rglob("*")) == before, argv  # nothing written
    return lines[0]


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    """A short run of the paper's case written to a file."""
    path = tmp_path_factory.mktemp("run") / "run.nc"
    ds = simcore.run(simcore.load_config(overrides=["solver.t_end=0.003"]))
    simcore.write_netcdf(ds, path)
    return path


@pytest.mark.parametrize("item, words", [
    # tracebacks before: OverflowError, ZeroDivisionError, ValueError naming rod.inertia
    ("solver.dt=1e-310", ["solver.dt", "1e-310", "max_memory_gb"]),
    ("model.ball_mass=1e-300", ["model.ball_mass", "1e-300", "between 1e-30 and 1e+30"]),
    ("model.rod_length=1e308", ["model.rod_length", "1e+308", "between 1e-30 and 1e+30"]),
    # misleading before: blamed on solver.dt <= 0 s; a singular Newton matrix after 100 steps
    ("model.cage_stiffness=1e308", ["model.cage_stiffness", "between 1e-30 and 1e+30"]),
    ("model.cage_damping=1e308", ["model.cage_damping", "between 1e-30 and 1e+30"]),
    # and within those magnitudes: the cage mode no step resolves, the Newton matrix
    ("model.cage_stiffness=1e25", ["model.cage_stiffness", "model.ball_mass", "N/m"]),
    ("model.cage_damping=1e13", ["model.cage_damping", "solver.dt", "N s/m"]),
])
def test_extreme_values_name_their_key(item, words, tmp_path):
    _assert_refused(simcore_main, ["run", "--set", item, "--out", str(tmp_path / "r.nc")],
                    words, tmp_path)


def test_a_mapping_with_keys_of_mixed_types_names_the_key(tmp_path):
    config = tmp_path / "mixed.yaml"
    config.write_text("model: {1: 2, x: 3}\n")
    _assert_refused(simcore_main, ["run", "--config", str(config), "--out",
                                   str(tmp_path / "r.nc")], ["model.1", "unknown key"], tmp_path)


def test_a_sweep_in_one_run_is_refused_or_named(tmp_path, run_file):
    """``simcore run`` makes one run: a sweep given with --set is refused (by the zoom too); a
    study's file run once warns that its sweep is not read, naming the values the run takes."""
    out = str(tmp_path / "r.nc")
    _assert_refused(simcore_main, ["run", "--set", "sweep.model.cage_stiffness=[1.0e+4, 1.0e+5]",
                                   "--out", out], ["sweep.model.cage_stiffness", "snakemake"],
                    tmp_path)
    _assert_refused(simcore_main, ["zoom", str(run_file), "--time", "1e-3", "--set",
                                   "sweep.mu=[0.0, 0.1]", "--out", out], ["sweep.mu"], tmp_path)
    code, lines = call(simcore_main, ["run", "--config", "config/smoke.yaml", "--set",
                                      "solver.t_end=0.001", "--quiet", "--out", out])
    cfg = simcore.load_config("config/smoke.yaml")
    assert code == 0 and len(lines) == 2, lines  # the sweep's, and the study section's
    assert lines[0].startswith("warning: sweep: not read by one run"), lines
    assert lines[0].endswith(", ".join(f"model.{key} = {cfg['model'][key]}"
                                       for key in ("clearance", "mu", "omega0", "e_N"))), lines
    assert lines[1].startswith("warning: study: not read by one run"), lines


def test_zoom_of_a_run_file_without_its_state_names_the_variables(tmp_path):
    run = tmp_path / "keep.nc"
    assert call(simcore_main, ["run", "--set", "study.keep=[Lambda_N, vn_free, gap_N]",
                               "--set", "solver.t_end=0.003", "--quiet", "--out", str(run)])[0] == 0
    _assert_refused(simcore_main, ["zoom", str(run), "--time", "1e-3", "--out",
                                   str(tmp_path / "z.nc")],
                    ["RUN", "lacks position, angle, velocity, angular_velocity", "study.keep"],
                    tmp_path)


def test_study_figures_of_a_file_that_is_not_a_summary(tmp_path, run_file):
    _assert_refused(analysis_main, ["study-figures", str(run_file), "--outdir",
                                    str(tmp_path / "figs")], ["SUMMARY", "not a study's summary"],
                    tmp_path)


def test_zoom_of_a_compliant_twin_points_to_the_nonsmooth_run(tmp_path):
    from simcore.study.plan import TWIN_DROPS

    run = tmp_path / "twin.nc"
    ds = simcore.run(simcore.load_config(overrides=[
        "model.contact_model=compliant", "model.youngs_modulus=2.1e11", "solver.adaptive=true",
        "solver.dt=1e-5", "solver.t_end=0.002"]))
    simcore.write_netcdf(ds.drop_vars(list(TWIN_DROPS)), run)  # what a study keeps of a twin
    _assert_refused(simcore_main, ["zoom", str(run), "--time", "1e-3", "--out",
                                   str(tmp_path / "z.nc")],
                    ["lacks velocity, angular_velocity", "compliant twin",
                     "the grid point's nonsmooth run"], tmp_path)


def test_the_analysis_of_a_failed_run_marker_names_it(tmp_path):
    from simcore.io import failed_run_dataset

    marker = tmp_path / "failed.nc"
    simcore.write_netcdf(failed_run_dataset(simcore.load_config(), "SolverError: step 12"),
                         marker)
    for argv in (["impacts", str(marker), "--out", str(tmp_path / "i.nc")],
                 ["figures", str(marker), "--outdir", str(tmp_path / "figs")],
                 ["top-forces", str(marker)]):
        _assert_refused(analysis_main, argv, ["RUN", "marker of a failed run",
                                              "SolverError: step 12"], tmp_path)


def test_an_output_name_too_long_for_the_file_system(tmp_path):
    out = str(tmp_path / ("a" * 300 + ".nc"))
    line = _assert_refused(simcore_main, ["run", "--out", out], ["--out", "303 bytes"], tmp_path)
    assert "at most 239 bytes" in line  # 255 less the temporary file's 16
    # the longest name allowed is written, through its temporary file
    out = tmp_path / ("b" * 236 + ".nc")
    assert call(simcore_main, ["run", "--set", "solver.t_end=0.001", "--quiet", "--out",
                                str(out)]) == (0, [])
    assert out.is_file()


def test_zoom_of_a_file_that_is_not_a_run(tmp_path, run_file):
    other = tmp_path / "other.nc"
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(other)
    _assert_refused(simcore_main, ["zoom", str(other), "--time", "1e-3", "--out",
                                   str(tmp_path / "z.nc")], ["RUN", "'time'"], tmp_path)
    (tmp_path / "not_netcdf.nc").write_text("text")
    _assert_refused(simcore_main, ["zoom", str(tmp_path / "not_netcdf.nc"), "--time", "1e-3",
                                   "--out", str(tmp_path / "z.nc")], ["RUN"], tmp_path)
    for out, word in ((tmp_path, "directory"), (tmp_path / "z.txt", ".nc")):
        _assert_refused(simcore_main, ["zoom", str(run_file), "--time", "1e-3", "--out",
                                       str(out)], ["--out", word], tmp_path)


@pytest.mark.parametrize("command", [["impacts"], ["filter"], ["dt-check", "--t-check", "1e-3"]])
def test_analysis_output_files_follow_the_rules_of_simcore_run(command, tmp_path, run_file):
    (tmp_path / "folder").mkdir()
    for out, word in ((tmp_path / "folder", "directory"), (tmp_path / "x.txt", ".nc"),
                      (tmp_path / "none" / "x.nc", "does not exist"),
                      (tmp_path / ("c" * 300 + ".nc"), "bytes")):
        _assert_refused(analysis_main, [command[0], str(run_file), *command[1:], "--out",
                                        str(out)], ["--out", word], tmp_path)


def test_analysis_output_folders_and_numbers_are_checked_first(tmp_path, run_file):
    (tmp_path / "file.png").write_bytes(b"")
    _assert_refused(analysis_main, ["figures", str(run_file), "--outdir",
                                    str(tmp_path / "file.png")], ["--outdir"], tmp_path)
    for option, value, word in (("--zero-tol", "2", "[0, 1)"), ("--v-min", "0", "> 0"),
                                ("--groove-conformity", "0.4", "0.5"),
                                ("--zero-floor", "-1", ">= 0")):
        _assert_refused(analysis_main, ["impacts", str(run_file), option, value, "--out",
                                        str(tmp_path / "i.nc")], [option, word], tmp_path)


def test_an_output_that_is_an_input_file_is_refused(tmp_path, run_file):
    """An --out that is the command's own input (under any spelling of its path) would replace
    it: refused, naming the input, and the input is left as it was."""
    run = tmp_path / "run.nc"
    run.write_bytes(run_file.read_bytes())
    (tmp_path / "link.nc").symlink_to(run)
    for out in (run, tmp_path / "." / "run.nc", tmp_path / "link.nc"):
        for main, argv in ((simcore_main, ["zoom", str(run), "--time", "1e-3"]),
                           (analysis_main, ["impacts", str(run)]),
                           (analysis_main, ["filter", str(run)]),
                           (analysis_main, ["dt-check", str(run), "--t-check", "1e-3"])):
            _assert_refused(main, [*argv, "--out", str(out)],
                            ["--out", "is the input RUN", "allowed: another file"], tmp_path)
    assert run.read_bytes() == run_file.read_bytes()
    config = tmp_path / "config.nc"  # a configuration whatever its name
    config.write_text("solver: {t_end: 0.001}\n")
    _assert_refused(simcore_main, ["run", "--config", str(config), "--out", str(config)],
                    ["--out", "is the input --config"], tmp_path)


def test_figures_takes_only_the_impact_table_of_its_run_and_a_plain_prefix(tmp_path, run_file):
    """``figures --impacts``: a file that is missing, not an impact table, or the table of
    another run (other parameters, impacts outside the run's span) is refused naming
    --impacts; a --prefix with a folder in it names --prefix; no figures folder is made."""
    from analysis import extract_impacts
    from analysis.__main__ import check_impacts

    with xr.open_dataset(run_file) as ds:
        table = extract_impacts(ds.load())
    own = simcore.write_netcdf(table, tmp_path / "own.nc")
    other_mu = simcore.write_netcdf(table.assign_coords(mu=0.05), tmp_path / "mu.nc")
    later = simcore.write_netcdf(table.assign(time=table["time"] + 1.0), tmp_path / "later.nc")
    assert check_impacts(str(own), str(run_file)) is None
    figures = ["figures", str(run_file), "--outdir", str(tmp_path / "figs")]
    for impacts, words in ((tmp_path / "none.nc", ["does not exist"]),
                           (run_file, ["not an impact table"]),
                           (other_mu, ["another run", "mu"]),
                           (later, ["another run", "RUN spans"])):
        _assert_refused(analysis_main, [*figures, "--impacts", str(impacts)],
                        ["--impacts", *words, "python -m analysis impacts"], tmp_path)
    _assert_refused(analysis_main, [*figures, "--prefix", "a/b"],
                    ["--prefix", "'a/b' is not allowed", "without '/'"], tmp_path)
    assert not (tmp_path / "figs").exists()
