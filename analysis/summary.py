"""Summary of a parameter study: one dataset over the swept parameters (SPEC section 8).

Every run file (``results/runs/<params>.nc``) and impact table (``results/impacts/<params>.nc``)
carries the swept parameters as scalar coordinates. :func:`summarize` opens them lazily with
dask (``xarray.open_mfdataset``), reduces each file to a few numbers in ``preprocess`` (while
the data are still lazy), turns the scalar coordinates into length-1 dimensions and lets
``combine="by_coords"`` assemble the grid. Only those reductions are ever computed, on the local
threads or on a dask distributed cluster.

A failed run (a marker file with attribute ``failed = 1``, written by the workflow when the
solver did not converge) gives ``failed = 1`` and NaN in every other variable of its point:
missing, never zero.
"""

from __future__ import annotations

from contextlib import nullcontext
from functools import partial
from typing import Sequence

import numpy as np
import xarray as xr

__all__ = ["summarize", "SWEPT", "STAGES", "N_TOP"]

#: Swept parameters, in the order of the summary's dimensions.
SWEPT = ("clearance", "mu", "omega0", "e_N")
#: Sub-problems of a time step (SPEC section 5).
STAGES = ("smooth", "position", "velocity")
#: Number of largest peak forces kept per run.
N_TOP = 3

_ATTRS = {
    "peak_force": ("N", "largest Flores peak force of the run's impacts"),
    "top3_force": ("N", "largest peak forces of the run's impacts, in decreasing order"),
    "n_simple": ("1", "number of simple (isolated) impacts"),
    "n_persistent": ("1", "number of impacts on persistent contact"),
    "max_Lambda_N": ("N s", "largest normal impulse of the run"),
    "iter_max": ("1", "largest number of Newton iterations per step"),
    "iter_mean": ("1", "mean number of Newton iterations per step"),
    "converged_fraction": ("1", "fraction of the steps in which every sub-problem converged"),
    "wall_time_s": ("s", "wall time of the simulation"),
    "failed": ("1", "1 where the run failed (its other values are missing)"),
}


def _failed(ds: xr.Dataset) -> bool:
    return bool(int(ds.attrs.get("failed", 0)))


def _point(ds: xr.Dataset, path: str) -> dict:
    try:
        return {key: float(ds[key].values.item()) for key in SWEPT}  # 0-d or length 1
    except KeyError as exc:
        raise ValueError(f"{path}: scalar coordinate {exc.args[0]} is missing") from None


def _as_grid(out: xr.Dataset, point: dict) -> xr.Dataset:
    """Give ``out`` the point's coordinates as length-1 dimensions, in the order of SWEPT."""
    out = out.drop_vars([k for k in SWEPT if k in out.coords])
    return out.expand_dims({key: [point[key]] for key in SWEPT})


def _reduce_run(ds: xr.Dataset) -> xr.Dataset:
    """One run file -> its summary numbers (lazy where the inputs are lazy)."""
    path = ds.encoding.get("source", "?")
    point = _point(ds, path)
    stage = xr.DataArray(list(STAGES), dims="stage", name="stage")
    if _failed(ds):
        nan = np.float64(np.nan)
        out = xr.Dataset(
            {
                "max_Lambda_N": nan,
                "iter_max": ("stage", np.full(len(STAGES), np.nan)),
                "iter_mean": ("stage", np.full(len(STAGES), np.nan)),
                "converged_fraction": nan,
                "wall_time_s": nan,
                "failed": np.float64(1.0),
            },
            coords={"stage": stage},
        )
        return _as_grid(out, point)
    steps = slice(1, None)  # t = 0 is the initial state, not a step
    iterations = ds["iterations"].isel(time=steps).astype("f8")
    out = xr.Dataset(
        {
            "max_Lambda_N": ds["Lambda_N"].max().astype("f8"),
            "iter_max": iterations.max("time"),
            "iter_mean": iterations.mean("time"),
            "converged_fraction": ds["converged"].isel(time=steps).astype("f8").mean("time"),
            "wall_time_s": np.float64(ds.attrs.get("wall_time_s", np.nan)),
            "failed": np.float64(0.0),
        }
    )
    out = out.assign_coords(stage=stage.values) if "stage" not in out.coords else out
    return _as_grid(out, point)


def _top(values: np.ndarray, n: int) -> np.ndarray:
    """The ``n`` largest finite values along the last axis, decreasing, NaN-padded."""
    values = np.asarray(values, dtype=float)
    out = np.full(values.shape[:-1] + (n,), np.nan)
    flat_in = values.reshape(-1, values.shape[-1])
    flat_out = out.reshape(-1, n)
    for row, dest in zip(flat_in, flat_out, strict=True):
        finite = np.sort(row[np.isfinite(row)])[::-1][:n]
        dest[: finite.size] = finite
    return out


def _count(ds: xr.Dataset, attr: str, kind: str):
    if attr in ds.attrs:
        return np.float64(ds.attrs[attr])
    if "kind" in ds and ds.sizes.get("impact", 0):
        return (ds["kind"] == kind).sum().astype("f8")
    return np.float64(0.0)


def _reduce_impacts(ds: xr.Dataset) -> xr.Dataset:
    """One impact table -> peak forces and counts (lazy where the inputs are lazy)."""
    path = ds.encoding.get("source", "?")
    point = _point(ds, path)
    rank = np.arange(1, N_TOP + 1)
    if _failed(ds):
        out = xr.Dataset(
            {
                "peak_force": np.float64(np.nan),
                "top3_force": ("rank", np.full(N_TOP, np.nan)),
                "n_simple": np.float64(np.nan),
                "n_persistent": np.float64(np.nan),
            },
            coords={"rank": rank},
        )
        return _as_grid(out, point)
    if "F_max" in ds and ds.sizes.get("impact", 0):
        f_max = ds["F_max"].astype("f8")
        peak = f_max.max("impact", skipna=True)
        top = xr.apply_ufunc(
            partial(_top, n=N_TOP),
            f_max,
            input_core_dims=[["impact"]],
            output_core_dims=[["rank"]],
            dask="parallelized",
            output_dtypes=[float],
            dask_gufunc_kwargs={"output_sizes": {"rank": N_TOP}},
        )
    else:  # no impact in this run
        peak = xr.DataArray(np.float64(np.nan))
        top = xr.DataArray(np.full(N_TOP, np.nan), dims="rank")
    out = xr.Dataset(
        {
            "peak_force": peak.reset_coords(drop=True),
            "top3_force": top.reset_coords(drop=True),
            "n_simple": _count(ds, "n_simple", "simple"),
            "n_persistent": _count(ds, "n_persistent", "persistent"),
        }
    )
    out = out.assign_coords(rank=rank)
    return _as_grid(out, point)


def _open(files: Sequence[str], reducer) -> xr.Dataset:
    # parallel=False: opening netCDF files from several threads at once crashed netCDF4 1.7.5
    # here (segmentation fault, "NetCDF: HDF error"). The files are opened one after the other
    # (metadata only); the reductions still run in parallel on the dask scheduler.
    return xr.open_mfdataset(
        [str(f) for f in files],
        preprocess=reducer,
        combine="by_coords",
        parallel=False,
        chunks={},
        data_vars="all",
        coords="different",
        compat="no_conflicts",
        join="outer",
        engine="netcdf4",
    )


def _scheduler(scheduler, num_workers):
    """Context and compute() keywords for local threads, a new local cluster or an address."""
    if scheduler in (None, "", "threads"):
        return nullcontext(), {"scheduler": "threads", "num_workers": num_workers}
    if scheduler == "synchronous":
        return nullcontext(), {"scheduler": "synchronous"}
    from distributed import Client, LocalCluster

    if scheduler == "local":
        cluster = LocalCluster(n_workers=num_workers or 1, threads_per_worker=1,
                               processes=True, dashboard_address=None)
        return Client(cluster), {}
    return Client(scheduler), {}


def summarize(run_files: Sequence[str], impact_files: Sequence[str], scheduler=None,
              num_workers: int | None = None) -> xr.Dataset:
    """Summarise a study over its swept parameters.

    Parameters
    ----------
    run_files : sequence of path
        Run files (SPEC section 5), or failed-run markers (attribute ``failed = 1``).
    impact_files : sequence of path
        Impact tables of the same runs (dimension ``impact``; attributes ``n_simple`` and
        ``n_persistent``).
    scheduler : str, optional
        None or ``"threads"``: dask's local threads; ``"synchronous"``: no parallelism;
        ``"local"``: start a ``distributed.LocalCluster``; anything else: the address of a
        running dask distributed scheduler (``tcp://host:8786``), which needs the package
        ``distributed`` and the files visible from its workers.
    num_workers : int, optional
        Local threads or local-cluster workers.

    Returns
    -------
    xarray.Dataset
        Dimensions ``clearance``, ``mu``, ``omega0``, ``e_N`` (plus ``rank`` and ``stage``), in
        memory, every variable with ``units`` and ``long_name``.
    """
    if not run_files or not impact_files:
        raise ValueError("summarize: no run or impact files given")
    context, compute_kw = _scheduler(scheduler, num_workers)
    with context:
        runs = _open(run_files, _reduce_run)
        impacts = _open(impact_files, _reduce_impacts)
        lazy = xr.merge([runs, impacts], join="outer", compat="no_conflicts",
                        combine_attrs="drop")
        summary = lazy.compute(**compute_kw)
        runs.close()
        impacts.close()
    for name, (units, long_name) in _ATTRS.items():
        summary[name].attrs.update(units=units, long_name=long_name)
    for name, units, long_name in (
        ("clearance", "m", "radial clearance"),
        ("mu", "1", "friction coefficient"),
        ("omega0", "rad s-1", "initial crank angular velocity"),
        ("e_N", "1", "normal restitution coefficient"),
        ("rank", "1", "rank of the peak force (1 = largest)"),
        ("stage", "", "sub-problem of the time step"),
    ):
        if name in summary.coords:
            summary[name].attrs.update(units=units, long_name=long_name)
    # A point whose run file says "failed" is missing everywhere, whatever the impact file says.
    failed = summary["failed"] > 0
    for name in summary.data_vars:
        if name != "failed":
            summary[name] = summary[name].where(~failed)
    order = list(SWEPT) + [d for d in ("rank", "stage") if d in summary.dims]
    summary = summary.transpose(*order)
    summary.attrs.update(
        Conventions="CF-1.8",
        title="bearing study summary",
        n_runs=int(summary["failed"].size),
        n_failed=int(failed.sum()),
    )
    return summary
