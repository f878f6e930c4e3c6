"""The run file: CF conventions, runs that combine by coordinates, the split of q and v."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

import simcore
from simcore.io import failed_run_dataset, generalized, open_run, write_netcdf
from simcore.mechanism import crank_slider

ROOT = Path(__file__).resolve().parents[1]
LABELS = ("race", "body", "axis", "stage")


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


@pytest.mark.filterwarnings("ignore:In a future version of xarray:FutureWarning")
def test_runs_combine_by_coords_without_arguments(two_runs):
    with xr.open_mfdataset([str(p) for p in two_runs], combine="by_coords") as grid:
        assert grid.sizes["clearance"] == 2
        assert grid.Lambda_N.dims == ("clearance", "time", "contact")
        for path in two_runs:
            with xr.open_dataset(path) as one:
                c = one.clearance.item()
                np.testing.assert_array_equal(grid.Lambda_N.sel(clearance=c).values,
                                              one.Lambda_N.values)
                assert grid.clearance.attrs["units"] == "m"


def test_generalized_coordinates_are_those_of_the_kernels():
    cfg = _cfg()
    ds = generalized(simcore.run(cfg))
    model, _ = crank_slider(cfg["model"])
    s = cfg["solver"]
    traj = model.simulate(s["dt"], s["t_end"], rho_inf=s["rho_inf"], tol=s["tol"],
                          max_iter=s["max_iter"], proximal=s["proximal"])
    nbody = len(model.body_names)
    np.testing.assert_array_equal(ds.q.values, traj.q.reshape(-1, nbody, 3))
    np.testing.assert_array_equal(ds.v.values, traj.v.reshape(-1, nbody, 3))
    assert list(ds.dof.values) == ["x", "y", "phi"]


@pytest.mark.filterwarnings("ignore:In a future version of xarray:FutureWarning")
def test_failed_run_file_combines_with_the_runs(two_runs, tmp_path):
    cfg = _cfg(clearance=2e-5)
    marker = write_netcdf(failed_run_dataset(cfg, "SolverError: test"), tmp_path / "f.nc")
    with xr.open_mfdataset([str(p) for p in two_runs] + [str(marker)],
                           combine="by_coords") as grid:
        assert list(grid.clearance.values) == [2e-5, 1e-4, 4e-4]
        assert bool(grid.Lambda_N.sel(clearance=2e-5).isnull().all())


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
