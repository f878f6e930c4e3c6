"""The run file: CF conventions, runs that combine by coordinates, the split of q and v."""

import importlib.util
import subprocess
import sys
import warnings
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

import simcore
from simcore.io import failed_run_dataset, generalized, open_run, state_at, write_netcdf
from simcore.model import SolverSettings
from simcore.model.mechanism import crank_slider

ROOT = Path(__file__).resolve().parents[1]
LABELS = ("race", "body", "axis", "stage", "guard")


def _cfg(**model):
    items = ["solver.t_end=0.003"] + [f"model.{k}={v}" for k, v in model.items()]
    return simcore.load_config(overrides=items)


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("runs")
    paths = []
    for clearance in (1e-4, 4e-4):
        ds = simcore.run(_cfg(clearance=clearance))
        paths.append(write_netcdf(ds, folder / f"clearance~{clearance}.nc"))
    return paths


def test_every_variable_has_units_and_long_name_and_coordinates_no_fill(two_runs):
    with netCDF4.Dataset(two_runs[0]) as nc:
        assert nc.Conventions == "CF-1.10" and nc.history and nc.title
        for name, var in nc.variables.items():
            attrs = var.ncattrs()
            assert "long_name" in attrs, name
            if name in LABELS:  # labels: character arrays, no units
                assert var.dtype == np.dtype("S1") and var.ndim == 2, name
            else:
                assert "units" in attrs and " or " not in var.units, name
            if name in nc.dimensions:  # a coordinate variable
                assert "_FillValue" not in attrs, name


def test_labels_read_back_as_strings(two_runs):
    ds = open_run(two_runs[1])
    n = ds.sizes["contact"] // 2
    assert list(ds.race.values) == ["inner"] * n + ["outer"] * n
    assert list(ds.stage.values) == ["smooth", "position", "velocity"]
    assert ds.clearance.item() == 4e-4
    assert float(ds.angular_velocity.sel(body="crank").isel(time=0)) == 50.0


def test_a_file_without_velocities_opens_with_its_coordinates(two_runs, tmp_path):
    """A study's compliant twin keeps no velocities: ``open_run`` gives it ``q`` (the stored
    position and angle, stacked as the kernels order them) and no ``v``."""
    with xr.open_dataset(two_runs[0]) as ds:
        path = write_netcdf(ds.load().drop_vars(["velocity", "angular_velocity"]),
                            tmp_path / "no_v.nc")
    full, part = open_run(two_runs[0]), open_run(path)
    assert "v" in full and "v" not in part
    np.testing.assert_array_equal(part["q"].values, full["q"].values)
    np.testing.assert_array_equal(part["q"].sel(dof="phi").values,
                                  full["angle"].transpose("time", "body").values)


@pytest.mark.filterwarnings("ignore:In a future version of xarray:FutureWarning")
def test_every_long_name_is_a_label_and_a_longer_text_its_comment():
    """xarray labels a plot's axis with long_name: every variable of either model gets one of
    at most LABEL_LENGTH characters; where the registry's text is longer, the file keeps it
    whole as the CF comment."""
    from simcore.io.variables import LABEL_LENGTH, VARIABLES

    for name, var in VARIABLES.items():
        for compliant in (False, True):
            text = var.compliant_long_name if compliant and var.compliant_long_name \
                else var.long_name
            attrs = var.attrs(compliant=compliant)
            assert attrs["long_name"] and len(attrs["long_name"]) <= LABEL_LENGTH, (name, attrs)
            if len(text) > LABEL_LENGTH:
                assert attrs["comment"] == text, name
            else:
                assert attrs["long_name"] == text and "comment" not in attrs, name


def test_runs_combine_by_coords_without_arguments(two_runs):
    """The bare call of the docs assembles the grid; current xarray warns there of its new
    defaults (FutureWarning), which simcore.io.open_runs avoids (the test after this one)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        grid = xr.open_mfdataset([str(p) for p in two_runs], combine="by_coords").load()
    with grid:
        assert grid.sizes["clearance"] == 2
        assert grid.Lambda_N.dims == ("clearance", "time", "contact")
        for path in two_runs:
            with xr.open_dataset(path) as one:
                c = one.clearance.item()
                np.testing.assert_array_equal(grid.Lambda_N.sel(clearance=c).values,
                                              one.Lambda_N.values)
                assert grid.clearance.attrs["units"] == "m"


def test_open_runs_gives_the_grid_of_runs_of_different_length_without_a_warning(two_runs,
                                                                                tmp_path):
    """Runs of different length (a shorter run, as at a higher crank speed) and a failed run's
    marker combine into one grid: each run's numbers where it ran, NaN after its end and for
    the failed one; no warning (xarray's FutureWarning on its defaults, dask's on chunks)."""
    from simcore.io import open_runs

    short = simcore.run(simcore.load_config(overrides=["solver.t_end=0.001",
                                                       "model.clearance=2e-4"]))
    paths = [*two_runs, write_netcdf(short, tmp_path / "short.nc"),
             write_netcdf(failed_run_dataset(_cfg(clearance=2e-5), "SolverError: test"),
                          tmp_path / "failed.nc")]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        grid = open_runs([str(p) for p in paths]).load()
    assert list(grid.clearance.values) == [2e-5, 1e-4, 2e-4, 4e-4]
    assert bool(grid.Lambda_N.sel(clearance=2e-5).isnull().all())
    n = short.sizes["time"]
    assert n < grid.sizes["time"]
    np.testing.assert_array_equal(grid.Lambda_N.sel(clearance=2e-4).values[:n],
                                  short.Lambda_N.values)
    assert bool(grid.Lambda_N.sel(clearance=2e-4).isel(time=slice(n, None)).isnull().all())
    for path in two_runs:
        with xr.open_dataset(path) as one:
            np.testing.assert_array_equal(
                grid.Lambda_N.sel(clearance=one.clearance.item()).values, one.Lambda_N.values)


def test_generalized_coordinates_are_those_of_the_kernels():
    cfg = _cfg()
    ds = generalized(simcore.run(cfg))
    model, _ = crank_slider(cfg["model"])
    s = cfg["solver"]
    traj = model.simulate(SolverSettings(s["dt"], s["t_end"], rho_inf=s["rho_inf"], tol=s["tol"],
                                         max_iter=s["max_iter"], proximal=s["proximal"]))
    nbody = len(model.body_names)
    np.testing.assert_array_equal(ds.q.values, traj.q.reshape(-1, nbody, 3))
    np.testing.assert_array_equal(ds.v.values, traj.v.reshape(-1, nbody, 3))
    assert list(ds.dof.values) == ["x", "y", "phi"]
    # one sample's state (a zoom's restart) from the parts of a run, as from q and v
    for i in (0, 17, ds.sizes["time"] - 1):
        for run in (ds.drop_vars(["q", "v"]), ds):
            q_i, v_i = state_at(run, i)
            np.testing.assert_array_equal(q_i, traj.q[i])
            np.testing.assert_array_equal(v_i, traj.v[i])


@pytest.mark.filterwarnings("ignore:In a future version of xarray:FutureWarning")
def test_failed_run_file_combines_with_the_runs(two_runs, tmp_path):
    cfg = _cfg(clearance=2e-5)
    marker = write_netcdf(failed_run_dataset(cfg, "SolverError: test"), tmp_path / "f.nc")
    with xr.open_mfdataset([str(p) for p in two_runs] + [str(marker)],
                           combine="by_coords") as grid:
        assert list(grid.clearance.values) == [2e-5, 1e-4, 4e-4]
        assert bool(grid.Lambda_N.sel(clearance=2e-5).isnull().all())


def test_the_title_names_the_runs_own_bearing():
    ds = simcore.run(simcore.load_config(overrides=["model.bearing=6205", "solver.t_end=0.002"]))
    assert ds.attrs["title"].startswith("Ball bearing 6205 in a crank-slider")
    assert "6012" not in ds.attrs["title"]


def test_compile_time_is_recorded_apart_from_the_run():
    """In a new process the first run carries the compile (or cache load), the second none."""
    code = (
        "import simcore\n"
        "cfg = simcore.load_config(overrides=['solver.t_end=0.001'])\n"
        "a, b = simcore.run(cfg), simcore.run(cfg)\n"
        "print(a.attrs['compile_time_s'], b.attrs['compile_time_s'])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    first, second = map(float, out.stdout.split())
    assert first > 0.0 and second == 0.0


@pytest.mark.skipif(importlib.util.find_spec("cfchecker") is None,
                    reason="cfchecker not installed (pip install -e '.[cf]', needs libudunits2)")
def test_run_and_failed_files_pass_the_cf_checker(two_runs, tmp_path):
    marker = write_netcdf(failed_run_dataset(_cfg(), "SolverError: test"), tmp_path / "f.nc")
    out = subprocess.run([sys.executable, str(ROOT / ".ci" / "cf-check"), str(two_runs[0]),
                          str(marker)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "2 of 2 files pass" in out.stdout


# --- study.keep and the stored types --------------------------------------------------------

@pytest.fixture(scope="module")
def short_paper_case():
    """The paper's case over its first 50 ms (the first impacts at 1.5 ms) and its config."""
    cfg = simcore.load_config(overrides=["solver.t_end=0.05"])
    return simcore.run(cfg), cfg


def test_keep_setting_drops_and_keeps_variables(short_paper_case, tmp_path):
    from simcore.io import DEFAULT_KEEP, RUN_VARIABLES

    ds, cfg = short_paper_case
    assert tuple(cfg["study"]["keep"]) == DEFAULT_KEEP
    assert set(ds.data_vars) <= set(RUN_VARIABLES)
    for keep, expected in ((["Lambda_N", "converged"], {"Lambda_N", "converged"}),
                           (cfg["study"]["keep"], set(DEFAULT_KEEP) - {"F_N", "guard_F_N"}),
                           # (nonsmooth: no forces)
                           (None, set(ds.data_vars))):
        path = write_netcdf(ds, tmp_path / "k.nc", keep=keep)
        with xr.open_dataset(path) as back:
            assert set(back.data_vars) == expected
            assert set(back.coords) == set(ds.coords)
    # the dataset in memory keeps all
    assert set(ds.data_vars) > set(DEFAULT_KEEP) - {"F_N", "guard_F_N"}


def test_stored_types_are_those_of_the_storage_table(short_paper_case, tmp_path):
    from simcore.io import STORAGE

    ds, _ = short_paper_case
    path = write_netcdf(ds, tmp_path / "all.nc")
    with netCDF4.Dataset(path) as nc:
        for name in ds.data_vars:
            var = nc.variables[name]
            assert var.dtype == np.dtype(STORAGE[name]), name
            assert var.storage == STORAGE[name], name
            assert var.chunking()[0] == ds.sizes["time"], name  # one chunk per time series
        assert nc.variables["time"].dtype == np.float64
    with xr.open_dataset(path) as back:  # float64 impulses and crank angle: exact
        for name in ("Lambda_N", "crank_angle", "iterations", "converged"):
            np.testing.assert_array_equal(back[name].values, ds[name].values, err_msg=name)
        for name in ("vn_free", "slider_x", "journal_x", "position", "angle", "velocity",
                     "angular_velocity"):  # float32: 7 significant digits
            np.testing.assert_allclose(back[name].values, ds[name].values, rtol=1e-7,
                                       atol=1e-7 * float(np.abs(ds[name]).max()), err_msg=name)


def test_unknown_keep_names_are_refused_before_any_work(tmp_path):
    from simcore.config import load_schema
    from simcore.io import DEFAULT_KEEP, RUN_VARIABLES, keep_variables

    keep = load_schema()["properties"]["study"]["properties"]["keep"]
    assert tuple(keep["items"]["enum"]) == RUN_VARIABLES
    assert tuple(keep["default"]) == DEFAULT_KEEP
    with pytest.raises(simcore.ConfigError) as err:
        simcore.load_config(overrides=["study.keep=[Lambda_N, lambda_n]"])
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("study.keep.1: 'lambda_n' is not allowed")
    assert all(f"'{name}'" in msg for name in RUN_VARIABLES)
    with pytest.raises(ValueError, match="study.keep: 'q' is not allowed; allowed: Lambda_N"):
        keep_variables(xr.Dataset(), ["q"])
    out = tmp_path / "x.nc"
    res = subprocess.run([sys.executable, "-m", "simcore", "run", "--quiet", "--set",
                          "study.keep=[gap]", "--out", str(out)], capture_output=True, text=True,
                         cwd=ROOT)
    assert res.returncode == 2 and res.stderr.startswith("error: study.keep.0: 'gap'")
    assert not out.exists()


def test_default_keep_file_gives_the_impact_table_of_the_run(short_paper_case, tmp_path):
    """extract_impacts on the written-and-read default file equals that on the dataset in
    memory: impulses, times, contacts, kinds and flags exactly (float64 Lambda_N); v_pre and
    F_max to 1e-6 (vn_free is stored as float32)."""
    import analysis

    ds, cfg = short_paper_case
    path = write_netcdf(ds, tmp_path / "p.nc", keep=cfg["study"]["keep"])
    with xr.open_dataset(path) as f:
        back = f.load()
    ref, got = analysis.extract_impacts(ds), analysis.extract_impacts(back)
    assert ref.sizes["impact"] == got.sizes["impact"] > 10
    for name in ("time", "contact", "ball", "race", "kind", "flags", "impulse", "trusted"):
        np.testing.assert_array_equal(got[name].values, ref[name].values, err_msg=name)
    for name in ("v_pre", "F_max"):
        np.testing.assert_allclose(got[name].values, ref[name].values, rtol=1e-6, err_msg=name)
    q_ref, q_got = generalized(ds), generalized(back)  # the zoom's restart state, float32
    for name in ("q", "v"):
        np.testing.assert_allclose(q_got[name].values, q_ref[name].values, rtol=6e-8,
                                   atol=6e-8 * float(np.abs(q_ref[name]).max()), err_msg=name)


@pytest.mark.parametrize("youngs_modulus", [2.1e9, 2.1e11])
def test_zoom_from_the_default_file_agrees_with_the_zoom_from_memory(short_paper_case, tmp_path,
                                                                     youngs_modulus):
    """The restart state is stored as float32: a zoom of the largest impact (a pinch at
    1.5 ms) from the written default file gives the largest force and the contact time of the
    zoom from the float64 run in memory within 0.1 % (measured on the paper case: 6e-5)."""
    import analysis
    from analysis.zoom import add_zoom_forces

    ds, cfg = short_paper_case
    path = write_netcdf(ds, tmp_path / "z.nc", keep=cfg["study"]["keep"])
    back = simcore.io.open_run(path)
    assert back["position"].dtype == np.float32
    imp = analysis.extract_impacts(ds)
    ov = [f"model.youngs_modulus={youngs_modulus}"]
    memory = add_zoom_forces(ds, imp, zoom_top=2, overrides=ov)
    from_file = add_zoom_forces(back, imp, zoom_top=2, overrides=ov)
    zoomed = np.isfinite(memory["F_max_zoom"].values)
    assert zoomed.sum() == 2
    for name in ("F_max_zoom", "contact_time_zoom"):
        np.testing.assert_allclose(from_file[name].values[zoomed], memory[name].values[zoomed],
                                   rtol=1e-3, err_msg=name)


@pytest.mark.filterwarnings("ignore:In a future version of xarray:FutureWarning")
def test_runs_of_a_class_sweep_combine_into_one_grid():
    """The clearance of a swept clearance class is not an axis: each run keeps it as a scalar
    coordinate, so ``combine_by_coords`` makes the study's grid (no clearance dimension, no
    empty cells) with the clearance along the class axis."""
    from simcore.io import parameter_coords, study_coords

    axes = ["model.mu", "model.omega0", "model.e_N", "model.clearance_class"]
    runs = []
    for cls, clearance in (("CN", 9e-6), ("C4", 2.6e-5)):
        ds = xr.Dataset({"Lambda_N": ("time", [0.0, 1.0])}, coords={"time": [0.0, 1e-4]})
        ds = ds.assign_coords(parameter_coords({"clearance": clearance, "mu": 0.01,
                                                "omega0": 100.0, "e_N": 0.9}))
        runs.append(study_coords(ds, {"model.clearance_class": cls, "model.mu": 0.01,
                                      "model.omega0": 100.0, "model.e_N": 0.9}, axes))
    grid = xr.combine_by_coords(runs, combine_attrs="drop_conflicts")
    assert "clearance" not in grid.dims and grid.sizes["clearance_class"] == 2
    assert grid["clearance"].dims == ("clearance_class",)
    np.testing.assert_array_equal(grid["clearance"].values, [9e-6, 2.6e-5])
    assert np.isfinite(grid["Lambda_N"].values).all()
    # a study that sweeps the clearance itself keeps it as an axis
    kept = study_coords(runs[0].expand_dims("clearance").assign_coords(
        clearance=("clearance", [9e-6])), {"model.clearance": 9e-6}, ["model.clearance"])
    assert "clearance" in kept.dims


@pytest.mark.filterwarnings("ignore:In a future version of xarray:FutureWarning")
def test_runs_of_a_bearing_and_class_sweep_combine_into_one_grid():
    """Bearings x classes: each run's clearance (its class for its bearing's bore) is a scalar
    coordinate that ``combine_by_coords`` lays over both axes."""
    from simcore.io import parameter_coords, study_coords

    axes = ["model.mu", "model.omega0", "model.e_N", "model.bearing", "model.clearance_class"]
    clearance = {("6205", "CN"): 6.25e-6, ("6205", "C3"): 1.025e-5, ("6012", "CN"): 9e-6,
                 ("6012", "C3"): 1.65e-5}
    runs = []
    for (name, cls), value in clearance.items():
        ds = xr.Dataset({"Lambda_N": ("time", [0.0, 1.0])}, coords={"time": [0.0, 1e-4]})
        ds = ds.assign_coords(parameter_coords({"clearance": value, "mu": 0.01,
                                                "omega0": 100.0, "e_N": 0.9}))
        runs.append(study_coords(ds, {"model.bearing": name, "model.clearance_class": cls,
                                      "model.mu": 0.01, "model.omega0": 100.0,
                                      "model.e_N": 0.9}, axes))
    grid = xr.combine_by_coords(runs, combine_attrs="drop_conflicts")
    assert "clearance" not in grid.dims
    assert set(grid["clearance"].dims) == {"bearing", "clearance_class"}
    meanings = grid["bearing"].attrs["flag_meanings"].split()
    classes = grid["clearance_class"].attrs["flag_meanings"].split()
    for (name, cls), value in clearance.items():
        at = {"bearing": meanings.index(name), "clearance_class": classes.index(cls)}
        assert float(grid["clearance"].sel(at)) == value
    assert np.isfinite(grid["Lambda_N"].values).all()


def test_category_coordinates_read_by_their_names():
    """Codes with CF flag_values/flag_meanings become their names, so that a selection reads
    as the study was written; the codes' selection gives the same numbers; numbers and the
    dataset opened stay as they were."""
    from simcore.io import parameter_coords, with_category_names

    flags = {"flag_values": np.array([0, 1], "i1"), "units": "1"}
    ds = xr.Dataset(
        {"peak": (("model", "guard_contacts", "mu"), np.arange(4.0).reshape(2, 2, 1))},
        coords={"model": ("model", np.array([0, 1], "i1"),
                          dict(flags, flag_meanings="nonsmooth compliant",
                               long_name="contact model")),
                "guard_contacts": ("guard_contacts", np.array([1, 0], "i1"),
                                   dict(flags, flag_meanings="false true")),
                "mu": ("mu", [0.01], {"units": "1"})})
    # the swept categories as a study's run file writes them (the registry's attributes)
    ds = ds.assign_coords(parameter_coords({"model.bearing": "6205",
                                            "model.clearance_class": "C3"}))
    named = with_category_names(ds)
    assert list(named["model"].values) == ["nonsmooth", "compliant"]
    assert list(named["guard_contacts"].values) == ["true", "false"]
    assert named["bearing"].values.tolist() == ["6205"]
    assert named["clearance_class"].values.tolist() == ["C3"]
    assert float(named["peak"].sel(model="compliant", guard_contacts="false").item()) == float(
        ds["peak"].sel(model=1, guard_contacts=0).item()) == 3.0
    assert named["model"].attrs == {"long_name": "contact model"}
    assert named["mu"].equals(ds["mu"]) and named["mu"].attrs == {"units": "1"}
    assert ds["model"].dtype == np.int8 and ds["bearing"].values.tolist() == [2]


def test_time_steps_of_a_run():
    """Steps of solver.dt over the run's span, or the accepted steps of an adaptive run; NaN
    where a file does not say its step."""
    from simcore.io import time_steps

    t = np.linspace(0.0, 0.25, 11)  # 0.25 s, sampled every 25 ms
    fixed = xr.Dataset(coords={"time": t}, attrs={"solver.dt": 1e-4})
    assert time_steps(fixed) == 2500.0
    adaptive = xr.Dataset(coords={"time": t},
                          attrs={"solver.dt": 1e-4, "n_steps_accepted": 731})
    assert time_steps(adaptive) == 731.0
    assert np.isnan(time_steps(xr.Dataset(coords={"time": t})))
