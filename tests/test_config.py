"""Bad input is refused before any work, with one line naming the key and what is allowed."""

import subprocess
import sys
import warnings

import pytest

import simcore
from simcore.config import ConfigError, load_config, read_yaml


def test_defaults_are_the_paper_case():
    cfg = load_config()
    m, s = cfg["model"], cfg["solver"]
    assert m["clearance"] == 4e-4 and m["mu"] == 0.01 and m["omega0"] == 50.0
    assert m["e_N"] == 0.9 and m["n_balls"] == 8 and m["drive"] == "free"
    assert s["dt"] == 1e-4 and s["t_end"] == 0.3 and s["rho_inf"] == 0.0 and s["tol"] == 1e-5


def test_config_file_matches_defaults():
    """The study's model section is the paper's case (the defaults) but for the drive and the
    material: the study runs the crank at constant speed with steel, `python -m simcore run`
    lets it run free with the paper's printed modulus."""
    cfg = load_config("config/config.yaml")
    defaults = load_config()["model"]
    assert defaults["drive"] == "free" and cfg["model"]["drive"] == "constant"
    assert defaults["youngs_modulus"] == 2.1e9 and cfg["model"]["youngs_modulus"] == 2.1e11
    assert {**cfg["model"], "drive": "free", "youngs_modulus": 2.1e9} == defaults


def test_yaml_exponent_without_sign_is_a_number(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("model:\n  cage_stiffness: 1.0e5\n")
    assert read_yaml(p)["model"]["cage_stiffness"] == 1e5
    assert load_config(p)["model"]["cage_stiffness"] == 1e5


@pytest.mark.parametrize("override, key, allowed", [
    ("model.clearance=-1e-4", "model.clearance", "(0, 0.005]"),
    ("model.clearance=0", "model.clearance", "(0, 0.005]"),
    ("model.e_N=1.5", "model.e_N", "[0, 1]"),
    ("model.e_N=-0.1", "model.e_N", "[0, 1]"),
    ("model.mu=-0.01", "model.mu", "[0, 2]"),
    ("solver.dt=0", "solver.dt", "(0, 0.1]"),
    ("solver.dt=-1e-4", "solver.dt", "(0, 0.1]"),
    ("solver.t_end=1e-5", "solver.t_end", ">= solver.dt"),
    ("model.clearence=1e-4", "model.clearence", "unknown key"),
    ("solvr.dt=1e-4", "solvr", "unknown key"),
    ("model.n_balls=40", "model.n_balls", "fit on the pitch circle"),
    ("model.mu=abc", "model.mu", "a number"),
    ("model.drive=fast", "model.drive", "'free', 'constant'"),
    ("sweep.mu=[]", "sweep.mu", "non-empty"),
    ("study.models=[nonsmooth, nonsmooth]", "study.models",
     "distinct names from 'nonsmooth', 'compliant'"),
    ("study.figure_axes=[]", "study.figure_axes", "null or a list of 1 to 4 distinct names"),
    ("sweep.clearance=[4e-4, -1e-4]", "sweep.clearance.1", "(0, 0.005]"),
    ("model.mu=.nan", "model.mu", "a finite number"),
    ("model.inner_mass=.inf", "model.inner_mass", "a finite number"),
    ("sweep.mu=[0.01, .nan]", "sweep.mu.1", "a finite number"),
    ("analysis.zero_tol=.nan", "analysis.zero_tol", "a finite number"),
    ("model.n_balls=2", "model.n_balls", "[3, 64]"),
])
def test_bad_values_name_the_key(override, key, allowed):
    with pytest.raises(ConfigError) as err:
        load_config(overrides=[override])
    msg = str(err.value)
    assert msg.startswith(key + ":"), msg
    assert allowed in msg, msg
    assert "\n" not in msg


def test_cli_refuses_bad_input_and_writes_nothing(tmp_path):
    out = tmp_path / "run.nc"
    res = subprocess.run([sys.executable, "-m", "simcore", "run", "--set", "model.e_N=2",
                          "--out", str(out)], capture_output=True, text=True)
    assert res.returncode != 0
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "model.e_N" in lines[0] and "[0, 1]" in lines[0]
    assert not out.exists()


def test_cli_runs_and_writes_atomically(tmp_path):
    out = tmp_path / "run.nc"
    out.write_text("previous content")
    res = subprocess.run([sys.executable, "-m", "simcore", "run", "--set", "solver.t_end=0.002",
                          "--out", str(out)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert "largest Lambda_N" in res.stdout and "position" in res.stdout
    import xarray as xr

    with xr.open_dataset(out) as ds:
        assert ds.sizes["time"] == 21
    assert not list(tmp_path.glob(".*.tmp"))


def test_nonconvergence_is_an_error_or_a_flag(tmp_path):
    cfg = load_config(overrides=["solver.t_end=0.005", "solver.max_iter=1",
                                 "solver.on_nonconvergence=error"])
    with pytest.raises(simcore.SolverError, match=r"step \d+ \(t = "):
        simcore.run(cfg)
    cfg["solver"]["on_nonconvergence"] = "warn"
    with pytest.warns(RuntimeWarning, match="did not converge"):
        ds = simcore.run(cfg)
    assert int(ds["converged"].min()) == 0
    assert ds.attrs["n_unconverged_steps"] > 0
    out = tmp_path / "x.nc"
    res = subprocess.run([sys.executable, "-m", "simcore", "run", "--set", "solver.t_end=0.005",
                          "--set", "solver.max_iter=1", "--out", str(out)],
                         capture_output=True, text=True)
    assert res.returncode != 0 and "did not converge" in res.stderr and not out.exists()


def test_written_files_get_ordinary_permissions(tmp_path, monkeypatch):
    """0666 less the process's umask, which the write reads without setting it (Linux: from
    /proc): setting and restoring it would race with a write in another thread (netCDF4 itself
    is not safe for several threads at once, so the test does not write from threads)."""
    import os
    import sys

    import xarray as xr

    ds = xr.Dataset({"a": ("x", [1.0, 2.0])})
    before = os.umask(0o027)
    try:
        out = simcore.write_netcdf(ds, tmp_path / "a.nc")
        assert os.stat(out).st_mode & 0o777 == 0o640
        if sys.platform.startswith("linux"):
            def never(mask):
                raise AssertionError("the umask was set")

            monkeypatch.setattr(os, "umask", never)
            out = simcore.write_netcdf(ds, tmp_path / "b.nc")
            assert os.stat(out).st_mode & 0o777 == 0o640
    finally:
        monkeypatch.undo()
        os.umask(before)


def test_a_written_file_reaches_the_disk_before_its_rename(tmp_path, monkeypatch):
    """The temporary file's data are flushed (fsync) before it is renamed into place and the
    folder after: a crash just after the write cannot leave an empty file under the name."""
    import os

    import xarray as xr

    events = []
    fsync, replace = os.fsync, os.replace

    def record_fsync(fd):
        events.append(("fsync", os.fstat(fd).st_ino))
        fsync(fd)

    def record_replace(src, dst):
        events.append(("replace", os.stat(src).st_ino))
        replace(src, dst)

    monkeypatch.setattr(os, "fsync", record_fsync)
    monkeypatch.setattr(os, "replace", record_replace)
    out = simcore.write_netcdf(xr.Dataset({"a": ("x", [1.0, 2.0])}), tmp_path / "a.nc")
    monkeypatch.undo()
    file, folder = os.stat(out).st_ino, os.stat(tmp_path).st_ino
    assert events == [("fsync", file), ("replace", file), ("fsync", folder)]


@pytest.mark.parametrize("args, key", [(["--threads", "9999"], "--threads"),
                                       (["--out", "/nonexistent-dir/x.nc"], "--out")])
def test_cli_refuses_bad_options_in_one_line(tmp_path, args, key):
    cmd = [sys.executable, "-m", "simcore", "run", "--set", "solver.t_end=0.001"]
    if "--out" not in args:
        cmd += ["--out", str(tmp_path / "x.nc")]
    res = subprocess.run(cmd + args, capture_output=True, text=True)
    assert res.returncode != 0
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and key in lines[0], res.stderr


def test_study_config_is_read_with_the_cli_types(tmp_path):
    """Files merged in order, a quoted number stays a string (refused by the schema), the
    command line's --config strings are read as numbers."""
    from simcore.config import read_study_config, validate_config

    base, extra = tmp_path / "base.yaml", tmp_path / "extra.yaml"
    base.write_text("model:\n  mu: 0.1\n  e_N: 0.5\nsweep:\n  mu: [0.0, 0.1]\n")
    extra.write_text("model:\n  mu: 0.2\n")
    cfg = read_study_config([base, extra], {"solver": {"dt": "5.0e-5"}})
    assert cfg["model"] == {"mu": 0.2, "e_N": 0.5} and cfg["solver"]["dt"] == 5e-5
    extra.write_text('sweep:\n  mu: ["0.2"]\n')
    with pytest.raises(ConfigError, match=r"^sweep\.mu\.0: '0\.2' is not allowed"):
        validate_config(read_study_config([base, extra]))
    extra.write_text("model:\n  mu: 0.1\n  mu: 0.2\n")
    with pytest.raises(ConfigError, match="--configfile: .*twice"):
        read_study_config([base, extra])


@pytest.mark.parametrize("address", ["tcp://10.0.0.1:8786", "scheduler.example.org:8786",
                                     "tls://node-1:8786", "[::1]:8786", "tcp://[fe80::1]:1"])
def test_a_dask_scheduler_is_a_name_of_the_summary_or_an_address_with_a_port(address):
    """study.dask_scheduler: null, a scheduler the summary takes by name, or host:port (the
    summary's Client would fail on anything else after every run); an accepted address is one
    distributed can read."""
    from analysis.summary import NAMED_SCHEDULERS

    for value in (None, *NAMED_SCHEDULERS, address):
        given = "null" if value is None else f"'{value}'"
        assert load_config(overrides=[f"study.dask_scheduler={given}"])
    distributed = pytest.importorskip("distributed.comm.addressing")
    _, location = distributed.parse_address(address)
    assert distributed.parse_host_port(location)[1] > 0


@pytest.mark.parametrize("value", ["not-an-address", "tcp://host", "host:", "inproc://a/1/2",
                                   "tcp://host:8786 extra", "Threads"])
def test_a_dask_scheduler_without_a_port_is_refused_before_any_job(value):
    with pytest.raises(ConfigError) as err:
        load_config(overrides=[f"study.dask_scheduler='{value}'"])
    msg = str(err.value)
    assert msg.startswith(f"study.dask_scheduler: {value!r} is not allowed; allowed: "), msg
    assert "host:port" in msg and "synchronous" in msg, msg


def test_a_later_study_config_replaces_a_sweep_axis_whatever_its_spelling(tmp_path):
    """A sweep axis of a later file or of the command line replaces the earlier files' list
    of that axis, short or long name; within one source both names stay refused."""
    from simcore.config import read_study_config, validate_config
    from simcore.study import plan

    base, extra = tmp_path / "base.yaml", tmp_path / "extra.yaml"
    base.write_text("sweep:\n  mu: [0.0, 0.1]\n  e_N: [0.5]\n")
    extra.write_text("sweep:\n  model.mu: [0.2, 0.3]\n")
    cfg = read_study_config([base, extra])
    assert cfg["sweep"] == {"e_N": [0.5], "model.mu": [0.2, 0.3]}
    assert plan.study_axes(validate_config(cfg))["model.mu"] == [0.2, 0.3]
    cfg = read_study_config([base, extra], {"sweep": {"mu": ["0.0", "0.01"]}})
    assert cfg["sweep"] == {"e_N": [0.5], "mu": [0.0, 0.01]}
    extra.write_text("sweep:\n  model.mu: [0.2]\n  mu: [0.3]\n")
    with pytest.raises(ConfigError, match=r"^sweep\.(model\.)?mu: the same key as "):
        plan.study_axes(validate_config(read_study_config([base, extra])))


def test_solver_settings_defaults_are_the_schema_defaults():
    """``SolverSettings`` made in Python (no configuration) takes the same defaults as a
    configuration does, for every field named like a schema key of ``solver`` or ``model``;
    its bounds are the schema's."""
    import dataclasses

    from simcore.config import load_schema
    from simcore.model import SolverSettings
    from simcore.model.driver import KEEP_GROWTH_RANGE, MAX_ADAPTIVE_RETRIES, MAX_HALVINGS

    sections = load_schema()["properties"]
    checked = []
    for field in dataclasses.fields(SolverSettings):
        for section in ("solver", "model"):
            node = sections[section]["properties"].get(field.name)
            if node is not None and "default" in node and field.default is not dataclasses.MISSING:
                assert field.default == node["default"], (section, field.name)
                checked.append(field.name)
                break
    assert {"tol", "max_iter", "dt_min", "adaptive_tol", "max_halvings",
            "adaptive_keep_growth"} <= set(checked)
    # every field a configuration sets is checked against its key's range and read from it
    from simcore.model.driver import SETTING_KEYS

    named = {f.name: f"{section}.{f.name}" for f in dataclasses.fields(SolverSettings)
             for section in ("model", "solver") if f.name in sections[section]["properties"]}
    assert named == SETTING_KEYS
    solver = sections["solver"]["properties"]
    assert solver["max_halvings"]["maximum"] == MAX_HALVINGS
    assert solver["adaptive_retries"]["maximum"] == MAX_ADAPTIVE_RETRIES
    keep = solver["adaptive_keep_growth"]
    assert (keep["minimum"], keep["maximum"]) == KEEP_GROWTH_RANGE


@pytest.mark.parametrize("field, value", [
    ("dt", 0.2), ("rho_inf", 1.5), ("rho_inf", -0.1), ("tol", 0.0), ("max_iter", 0),
    ("max_iter", 2.5), ("proximal", -1e-6), ("on_nonconvergence", "ignore"),
    ("damping_law", "linear"), ("friction_regularization", 0.0), ("energy_tol", 0.0),
    ("max_halvings", 11), ("max_indentation", 1.5), ("adaptive", 2), ("dt_min", 0.0),
    ("adaptive_tol", 2.0), ("adaptive_keep_growth", 0.9), ("adaptive_retries", 4)])
def test_solver_settings_refuse_what_a_configuration_refuses(field, value):
    """A value a configuration refuses for a key (its schema range) is refused as well by
    ``SolverSettings`` made in Python, naming the same key, before any work."""
    from simcore.model import SolverSettings
    from simcore.model.driver import SETTING_KEYS

    key = SETTING_KEYS[field]
    with pytest.raises(ConfigError, match=f"^{key}: "):
        load_config(overrides=[f"{key}={value}"])
    with pytest.raises(ValueError, match=f"^{key}: .* is not allowed; allowed: "):
        SolverSettings(**{"dt": 1e-6, "t_end": 1e-3, field: value})


@pytest.mark.parametrize("key, value", [("clearance", -1e-3), ("n_balls", 2.5),
                                        ("cage_damping", -1.0), ("bearing", "9999")])
def test_a_model_section_changed_by_hand_is_checked_by_the_builders(key, value):
    """A validated ``model`` section changed by hand (a notebook's way to vary one value) is
    checked by the mechanism builders as a configuration would be: the value the schema
    refuses is refused naming the key."""
    from simcore.model.mechanism import bearing_alone, crank_slider

    with pytest.raises(ConfigError, match=f"^model.{key}: "):
        load_config(overrides=[f"model.{key}={value}"])
    for build in (crank_slider, lambda m: bearing_alone(m, 100.0)):
        model = dict(load_config()["model"], **{key: value})
        with pytest.raises(ConfigError, match=f"^model.{key}: .* is not allowed; allowed: "):
            build(model)


def test_the_builders_refuse_an_unknown_model_key():
    """A misspelt key beside the right one, which the builders would never read, is refused
    by name with the keys allowed, as a configuration refuses it."""
    from simcore.model.mechanism import bearing_alone, crank_slider

    with pytest.raises(ConfigError) as from_file:
        load_config(overrides=["model.clearence=1e-4"])
    assert str(from_file.value).startswith("model.clearence: unknown key; allowed keys here: ")
    assert "clearance" in str(from_file.value).split("allowed keys here: ")[1].split(", ")
    for build in (crank_slider, lambda m: bearing_alone(m, 100.0)):
        with pytest.raises(ConfigError) as from_builder:
            build(dict(load_config()["model"], clearence=1e-4))
        assert str(from_builder.value) == str(from_file.value)


def test_solver_settings_store_values_as_a_configuration_does():
    """NumPy scalars, a whole float of an integer key and 0/1 of a boolean key become the
    Python values a configuration holds, which the run file's attributes then carry."""
    import numpy as np

    from simcore.model import SolverSettings

    settings = SolverSettings(np.float64(1e-6), 1e-3, max_iter=np.int64(20), max_halvings=3.0,
                              contact_model="compliant", adaptive=1)
    assert (type(settings.dt), type(settings.max_iter), type(settings.max_halvings)) == (
        float, int, int)
    assert settings.adaptive is True and (settings.max_iter, settings.max_halvings) == (20, 3)


def test_the_schema_names_the_contact_models_of_the_code():
    """The schema's contact models (``model.contact_model``, ``study.models`` and its default)
    are the models the driver runs, in the order of their codes in the files."""
    from simcore.config import load_schema
    from simcore.model import CONTACT_MODELS

    sections = load_schema()["properties"]
    models = sections["study"]["properties"]["models"]
    assert tuple(sections["model"]["properties"]["contact_model"]["enum"]) == CONTACT_MODELS
    assert tuple(models["items"]["enum"]) == CONTACT_MODELS
    assert tuple(models["default"]) == CONTACT_MODELS


def test_a_whole_float_for_an_integer_key_is_stored_as_an_int():
    """``n_balls: 8.0`` is valid (the schema's integer admits it) and is kept as the int 8, so
    the run file's attribute has the schema's type; 8.5 is refused naming the key."""
    cfg = load_config(overrides=["model.n_balls=8.0", "solver.max_iter=50.0"])
    assert type(cfg["model"]["n_balls"]) is int and cfg["model"]["n_balls"] == 8
    assert type(cfg["solver"]["max_iter"]) is int
    with pytest.raises(ConfigError, match=r"^model\.n_balls: 8\.5 is not allowed"):
        load_config(overrides=["model.n_balls=8.5"])


def test_the_largest_force_line_says_when_the_run_ends_before_the_peak():
    """A force still rising at the last sample is not called the peak; one that has turned is
    reported plainly."""
    import numpy as np
    import xarray as xr

    from simcore.cli import largest_force_line

    def run(force):
        f = np.zeros((len(force), 2))
        f[:, 1] = force
        return xr.Dataset({"F_N": (("time", "contact"), f)},
                          coords={"time": np.arange(len(force)) * 1e-6, "contact": [0, 1],
                                  "ball": ("contact", [0, 0]),
                                  "race": ("contact", ["inner", "outer"])})

    rising = largest_force_line(run([0.0, 1.0, 2.0, 3.0]), "a longer --window")
    assert rising.startswith("largest F_N: 3 N at t = 3e-06 s, contact 1 (ball 0, outer race)")
    assert "NOT the peak" in rising and rising.endswith("a longer --window)")
    turned = largest_force_line(run([0.0, 2.0, 3.0, 1.0]), "a longer --window")
    assert turned == "largest F_N: 3 N at t = 2e-06 s, contact 1 (ball 0, outer race)"


@pytest.mark.parametrize("key, what", [("analysis.force_levels", "not allowed as a sweep axis"),
                                       ("model.bogus", "unknown key")])
def test_a_setting_that_cannot_be_swept_is_not_called_unknown(key, what):
    with pytest.raises(simcore.ConfigError, match=rf"^sweep\.{key}: {what}"):
        simcore.validate_config({"sweep": {key: ["6012"]}})


@pytest.mark.parametrize("key", ["model.bearing", "bearing"])
@pytest.mark.parametrize("given", ["ball_radius", "n_balls", "inner_radius", "ball_mass"])
def test_a_bearing_sweep_refuses_a_value_each_bearing_sets(key, given):
    """Each grid point of a bearing sweep takes its entry's radii, ball count and masses: one
    value for all of them is refused, naming it, before any work."""
    value = {"n_balls": 10, "inner_radius": 0.03}.get(given, 0.004)
    with pytest.raises(simcore.ConfigError, match=rf"^model\.{given}: not allowed while "
                                                   r"sweep\.model\.bearing"):
        simcore.validate_config({"model": {given: value}, "sweep": {key: ["6012", "6205"]}})
    assert simcore.validate_config({"model": {given: value}})["model"][given] == value
    # swept (by either spelling), the runs would be labelled with values they do not run at
    for written in (given, f"model.{given}"):
        with pytest.raises(simcore.ConfigError, match=rf"^sweep\.{written}: not allowed while "
                                                       r"sweep\.model\.bearing"):
            simcore.validate_config({"sweep": {key: ["6012", "6205"], written: [value]}})


def test_a_clearance_class_beside_a_given_clearance_warns_naming_both():
    """python -m simcore run --set model.clearance=1e-4 --set model.clearance_class=C3 runs
    at the class's clearance: it says so, as for a ball count given against the catalogue."""
    with pytest.warns(UserWarning, match=r"^model\.clearance = 0\.0001 is given and replaced "
                                         r"by model\.clearance_class = 'C3' \(1\.65e-05 m"):
        cfg = load_config(overrides=["model.clearance=1e-4", "model.clearance_class=C3"])
    assert cfg["model"]["clearance"] == 1.65e-5
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_config(overrides=["model.clearance_class=C3"])
        load_config(overrides=["model.clearance=1e-4"])


def test_bearing_names_given_as_numbers_are_names():
    """YAML reads 6012 as a number: as the bearing and in a sweep of it, it is the name."""
    cfg = simcore.validate_config({"model": {"bearing": 6012},
                                   "sweep": {"bearing": [6205, "6012-paper"]}})
    assert cfg["model"]["bearing"] == "6012" and cfg["model"]["n_balls"] == 14
    assert cfg["sweep"]["bearing"] == ["6205", "6012-paper"]
    with pytest.raises(simcore.ConfigError, match=r"^sweep\.bearing\.0: '6013' is not allowed; "
                                                   r"allowed: one of '6012-paper', '6203'"):
        simcore.validate_config({"sweep": {"bearing": [6013]}})
