"""Summary of a parameter study: one dataset over the swept parameters.

Every run file (``results/runs/<params>.nc``) and impact table (``results/impacts/<params>.nc``)
carries the swept parameters as scalar coordinates. :func:`summarize` opens them lazily with
dask (``xarray.open_mfdataset``), reduces each file to a few numbers in ``preprocess`` (while
the data are still lazy), turns the scalar coordinates into length-1 dimensions and lets
``combine="by_coords"`` assemble the grid. Only those reductions are ever computed, on the local
threads or on a dask distributed cluster.

A study's impact tables also carry their point's numbers as attributes (``summary_*``,
:func:`point_numbers`, computed by the simulate job from the run in memory); when every table
has them for the requested settings, :func:`summarize` assembles the grid from those attributes
and opens no run file (seconds instead of a quarter of a minute for the 81-run study).

Steady operation
----------------
The first ``settle`` crank revolutions of a run are its start-up: their impacts give
``startup_peak_force`` and nothing else. Everything else about impacts (peak forces, p_max,
counts) is taken over the rest of the run, the *steady window*, and counts are also given per
crank revolution of that window. Revolutions are counted from the run's ``crank_angle``
(:func:`steady_window`), not from ``omega0``, so that they are right for the free drive too.

Counts come in two kinds:

* ``n_impacts``/``impacts_per_rev`` (by race and impact kind) count what the impulse filter
  calls an impact. Its zero threshold is relative (``zero_tol`` times the run's largest
  impulse), so it differs between runs; it is stored with the counts (``zero_threshold``).
* ``n_above``/``above_per_rev`` (by race and absolute force ``level``) count the impacts whose
  Flores peak force reaches ``level``; they compare across runs.

A failed run (a marker file with attribute ``failed = 1``, written by the workflow when the
solver did not converge) gives ``failed = 1`` and NaN in every other variable of its point:
missing, never zero.

The file is CF-1.10: categories (race, impact kind, solver stage) are small integer
coordinates with ``flag_values``/``flag_meanings``, every variable has UDUNITS ``units`` and a
``long_name``, and coordinates carry no fill value.
"""

from __future__ import annotations

import datetime
from contextlib import nullcontext
from functools import partial
from typing import Sequence

import numpy as np
import xarray as xr

__all__ = ["summarize", "summary_table", "steady_window", "category_codes", "impact_numbers",
           "point_numbers", "SWEPT", "STAGES", "RACES", "KINDS", "N_TOP"]

#: Swept parameters, in the order of the summary's dimensions.
SWEPT = ("clearance", "mu", "omega0", "e_N")
#: Sub-problems of a time step (code = position in the tuple).
STAGES = ("smooth", "position", "velocity")
#: Races of the bearing (code = position: 0 inner, 1 outer).
RACES = ("inner", "outer")
#: Impact kinds of the impact table (code = position).
KINDS = ("simple", "persistent", "pinch", "multi")
#: Number of largest peak forces kept per run.
N_TOP = 3

_TWO_PI = 2.0 * np.pi

_ATTRS = {
    "peak_force": ("N", "largest Flores peak force in the steady window, per race"),
    "p_max": ("Pa", "largest Hertz contact pressure in the steady window, per race"),
    "peak_force_flagged": ("1", "1 where the impact giving peak_force carries a flag"),
    "top3_force": ("N", "largest peak forces in the steady window (both races), decreasing"),
    "startup_peak_force": ("N", "largest Flores peak force of the start-up (the first "
                                "analysis.settle crank revolutions), both races"),
    "n_impacts": ("1", "impacts in the steady window (relative zero threshold), by race and "
                       "kind"),
    "impacts_per_rev": ("1", "impacts per crank revolution in the steady window (relative zero "
                             "threshold), by race and kind"),
    "n_above": ("1", "impacts in the steady window whose peak force reaches the level"),
    "above_per_rev": ("1", "impacts per crank revolution in the steady window whose peak force "
                           "reaches the level"),
    "n_flagged": ("1", "impacts in the steady window whose force carries a flag (missing where "
                       "the impact table has no flags)"),
    "zero_threshold": ("N s", "zero threshold of the impulse filter (zero_tol times the run's "
                              "largest impulse)"),
    "settle_time": ("s", "end of the start-up: first time the crank has turned analysis.settle "
                         "revolutions"),
    "revolutions": ("1", "crank revolutions in the steady window, from the crank angle"),
    "max_Lambda_N": ("N s", "largest normal impulse of the run"),
    "iter_max": ("1", "largest number of Newton iterations per step"),
    "iter_mean": ("1", "mean number of Newton iterations per step"),
    "converged_fraction": ("1", "fraction of the steps in which every sub-problem converged"),
    "wall_time_s": ("s", "wall time of the simulation"),
    "failed": ("1", "1 where the run failed (its other values are missing)"),
}

_COORDS = {
    "clearance": ("m", "radial clearance"),
    "mu": ("1", "friction coefficient"),
    "omega0": ("rad s-1", "crank speed (constant drive) or initial crank speed (free drive)"),
    "e_N": ("1", "normal restitution coefficient"),
    "rank": ("1", "rank of the peak force (1 = largest)"),
    "level": ("N", "absolute force level of the counts"),
    "race": ("1", "race of the contact"),
    "kind": ("1", "impact kind"),
    "stage": ("1", "sub-problem of the nonsmooth generalized-alpha step"),
}
_FLAGS = {"race": RACES, "kind": KINDS, "stage": STAGES}


# --- numbers of one run -------------------------------------------------------------------

def steady_window(time, crank_angle, settle: float) -> tuple[float, float]:
    """End of the start-up and the crank revolutions after it.

    Parameters
    ----------
    time : array_like
        Sample times [s], increasing.
    crank_angle : array_like
        Unwrapped crank angle at those times [rad].
    settle : float
        Start-up length [revolutions] (>= 0).

    Returns
    -------
    settle_time : float
        First sample time at which the crank has turned ``settle`` revolutions from its start
        [s]; the first sample time if ``settle`` is 0, the last one if the crank never turns
        that far (then the whole run is start-up).
    revolutions : float
        Net crank revolutions from ``settle_time`` to the end of the run [-] (0 if the crank
        never turned ``settle`` revolutions).
    """
    t = np.asarray(time, dtype=float)
    theta = np.asarray(crank_angle, dtype=float)
    if t.size == 0:
        return np.nan, np.nan
    turned = np.abs(theta - theta[0])
    target = _TWO_PI * float(settle)
    reached = np.flatnonzero(turned >= target * (1.0 - 1e-12))
    if reached.size == 0:
        return float(t[-1]), 0.0
    i = int(reached[0])
    return float(t[i]), float(abs(theta[-1] - theta[i]) / _TWO_PI)


def category_codes(values, meanings=None, names=RACES) -> np.ndarray:
    """Categories of an impact-table column as codes into ``names`` (-1: unknown or missing).

    Parameters
    ----------
    values : array_like
        Strings (older tables) or integer codes (newer ones; NaN where masked).
    meanings : str, optional
        The column's ``flag_meanings`` (space-separated names of codes 0, 1, ...); without it
        an integer code is taken to index ``names`` directly.
    names : sequence of str
        The categories of the summary.

    Returns
    -------
    numpy.ndarray of int
    """
    arr = np.asarray(values)
    lookup = {name: i for i, name in enumerate(names)}
    if arr.dtype.kind in "OUS":
        return np.array([lookup.get(v.decode() if isinstance(v, bytes) else str(v), -1)
                         for v in arr.ravel()], dtype=np.int64).reshape(arr.shape)
    codes = np.full(arr.shape, -1, dtype=np.int64)
    finite = np.isfinite(arr.astype(float))
    raw = np.where(finite, arr, -1).astype(np.int64)
    if meanings:
        table = np.array([lookup.get(name, -1) for name in str(meanings).split()], dtype=np.int64)
        ok = finite & (raw >= 0) & (raw < table.size)
        codes[ok] = table[raw[ok]]
    else:
        ok = finite & (raw >= 0) & (raw < len(names))
        codes[ok] = raw[ok]
    return codes


def impact_numbers(time, race, kind, f_max, p_max, flags, settle_time: float,
                   revolutions: float, levels: Sequence[float]) -> dict:
    """Peak forces and counts of one impact table (plain arrays in, plain arrays out).

    Parameters
    ----------
    time : array_like
        Impact times [s]; an impact belongs to the steady window if ``time > settle_time``,
        to the start-up otherwise.
    race, kind : array_like of int
        Codes into :data:`RACES` and :data:`KINDS` (-1: unknown; such rows count in no race
        or kind, but in ``top3_force``, ``startup_peak_force`` and ``n_flagged``).
    f_max : array_like
        Flores peak forces [N] (NaN where there is none).
    p_max : array_like or None
        Peak contact pressures [Pa], None if the table has none.
    flags : array_like or None
        Flag bitmask of each force (0: clean), None if the table has none.
    settle_time : float
        End of the start-up [s] (:func:`steady_window`).
    revolutions : float
        Crank revolutions of the steady window [-]; per-revolution counts are NaN if it is
        not positive.
    levels : sequence of float
        Absolute force levels [N].

    Returns
    -------
    dict of numpy.ndarray
        ``peak_force`` (race), ``p_max`` (race), ``peak_force_flagged`` (race), ``top3_force``
        (rank), ``startup_peak_force`` (), ``n_impacts`` and ``impacts_per_rev`` (race, kind),
        ``n_above`` and ``above_per_rev`` (race, level), ``n_flagged`` ().
    """
    t = np.asarray(time, dtype=float).ravel()
    race = np.asarray(race, dtype=np.int64).ravel()
    kind = np.asarray(kind, dtype=np.int64).ravel()
    f = np.asarray(f_max, dtype=float).ravel()
    levels = np.asarray(levels, dtype=float)
    steady = t > settle_time
    n_race, n_kind = len(RACES), len(KINDS)

    def largest(values, mask):
        sel = values[mask & np.isfinite(values)]
        return float(sel.max()) if sel.size else np.nan

    peak = np.array([largest(f, steady & (race == r)) for r in range(n_race)])
    if p_max is None:
        pressure = np.full(n_race, np.nan)
    else:
        p = np.asarray(p_max, dtype=float).ravel()
        pressure = np.array([largest(p, steady & (race == r)) for r in range(n_race)])
    flagged = None if flags is None else np.asarray(flags, dtype=float).ravel()
    peak_flagged = np.full(n_race, np.nan)
    if flagged is not None:
        for r in range(n_race):
            idx = np.flatnonzero(steady & (race == r) & np.isfinite(f))
            if idx.size:
                peak_flagged[r] = float(flagged[idx[np.argmax(f[idx])]] != 0)
    top = np.sort(f[steady & np.isfinite(f)])[::-1][:N_TOP]
    top3 = np.full(N_TOP, np.nan)
    top3[: top.size] = top
    n_impacts = np.array([[np.sum(steady & (race == r) & (kind == k)) for k in range(n_kind)]
                          for r in range(n_race)], dtype=float)
    reached = f[:, None] >= levels[None, :]  # NaN compares False
    n_above = np.array([np.sum(reached[steady & (race == r)], axis=0) for r in range(n_race)],
                       dtype=float).reshape(n_race, levels.size)
    per_rev = 1.0 / revolutions if np.isfinite(revolutions) and revolutions > 0 else np.nan
    return {
        "peak_force": peak,
        "p_max": pressure,
        "peak_force_flagged": peak_flagged,
        "top3_force": top3,
        "startup_peak_force": np.array(largest(f, ~steady)),
        "n_impacts": n_impacts,
        "impacts_per_rev": n_impacts * per_rev,
        "n_above": n_above,
        "above_per_rev": n_above * per_rev,
        "n_flagged": np.array(np.nan if flagged is None
                              else float(np.sum(steady & (flagged != 0)))),
    }


# --- lazy per-file reductions (preprocess of open_mfdataset) --------------------------------

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


def _lazy(fn, args, spec: dict) -> dict:
    """Run ``fn(*args)`` (returning a dict of arrays) as one dask task; ``spec`` maps each
    returned name to its dims and shape. Returns xarray variables backed by dask."""
    import dask
    import dask.array as da

    result = dask.delayed(fn, pure=True)(*args)
    return {name: (dims, da.from_delayed(result[name], shape, dtype=float))
            for name, (dims, shape) in spec.items()}


def _settle_numbers(time, crank_angle, settle):
    t_settle, revolutions = steady_window(time, crank_angle, settle)
    return {"settle_time": np.array(t_settle), "revolutions": np.array(revolutions)}


def _reduce_run(ds: xr.Dataset, settle: float) -> xr.Dataset:
    """One run file -> its summary numbers (lazy where the inputs are lazy)."""
    path = ds.encoding.get("source", "?")
    point = _point(ds, path)
    stage = np.arange(len(STAGES), dtype=np.int8)
    if _failed(ds):
        nan = np.float64(np.nan)
        out = xr.Dataset(
            {
                "settle_time": nan,
                "revolutions": nan,
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
    if "stage" in iterations.coords:
        iterations = iterations.drop_vars("stage")
    if "crank_angle" in ds:
        window = _lazy(_settle_numbers, (ds["time"].values, ds["crank_angle"].data, settle),
                       {"settle_time": ((), ()), "revolutions": ((), ())})
    else:  # no crank angle: the whole run is the steady window, its revolutions unknown
        window = {"settle_time": np.float64(ds["time"].values[0]), "revolutions": np.nan}
    out = xr.Dataset(
        {
            **window,
            "max_Lambda_N": ds["Lambda_N"].max().astype("f8"),
            "iter_max": iterations.max("time"),
            "iter_mean": iterations.mean("time"),
            "converged_fraction": ds["converged"].isel(time=steps).astype("f8").mean("time"),
            "wall_time_s": np.float64(ds.attrs.get("wall_time_s", np.nan)),
            "failed": np.float64(0.0),
        }
    )
    out = out.reset_coords(drop=True).assign_coords(stage=stage)
    return _as_grid(out, point)


def _impact_spec(n_levels: int) -> dict:
    n_race, n_kind = len(RACES), len(KINDS)
    return {
        "peak_force": (("race",), (n_race,)),
        "p_max": (("race",), (n_race,)),
        "peak_force_flagged": (("race",), (n_race,)),
        "top3_force": (("rank",), (N_TOP,)),
        "startup_peak_force": ((), ()),
        "n_impacts": (("race", "kind"), (n_race, n_kind)),
        "impacts_per_rev": (("race", "kind"), (n_race, n_kind)),
        "n_above": (("race", "level"), (n_race, n_levels)),
        "above_per_rev": (("race", "level"), (n_race, n_levels)),
        "n_flagged": ((), ()),
    }


def _impact_table_numbers(time, race, race_meanings, kind, kind_meanings, f_max, p_max, flags,
                          settle_time, revolutions, levels):
    n = np.asarray(f_max).size
    t = np.full(n, np.inf) if time is None else time  # no times: all steady
    r = np.full(n, -1) if race is None else category_codes(race, race_meanings, RACES)
    k = np.full(n, -1) if kind is None else category_codes(kind, kind_meanings, KINDS)
    return impact_numbers(t, r, k, f_max, p_max, flags, settle_time, revolutions, levels)


def _reduce_impacts(ds: xr.Dataset, windows: xr.Dataset, levels: np.ndarray) -> xr.Dataset:
    """One impact table -> peak forces and counts (lazy where the inputs are lazy)."""
    path = ds.encoding.get("source", "?")
    point = _point(ds, path)
    spec = _impact_spec(levels.size)
    coords = {"rank": np.arange(1, N_TOP + 1), "level": levels,
              "race": np.arange(len(RACES), dtype=np.int8),
              "kind": np.arange(len(KINDS), dtype=np.int8)}
    zero = np.float64(ds.attrs.get("zero_threshold", np.nan))
    if _failed(ds):
        data = {name: (dims, np.full(shape, np.nan)) for name, (dims, shape) in spec.items()}
        data["zero_threshold"] = np.float64(np.nan)
        return _as_grid(xr.Dataset(data, coords=coords), point)
    window = windows.sel(point)
    settle_time = float(window["settle_time"])
    revolutions = float(window["revolutions"])
    if np.isnan(settle_time):
        settle_time = -np.inf

    def column(name):
        return ds[name].data if name in ds.variables and ds[name].dims == ("impact",) else None

    def meanings(name):
        return ds[name].attrs.get("flag_meanings") if name in ds.variables else None

    f_max = column("F_max")
    if f_max is None:  # a table without forces: every impact counts, none has a force
        f_max = np.full(ds.sizes.get("impact", 0), np.nan)
    args = (column("time"), column("race"), meanings("race"), column("kind"), meanings("kind"),
            f_max, column("p_max"), column("flags"), settle_time, revolutions, levels)
    data = _lazy(_impact_table_numbers, args, spec)
    data["zero_threshold"] = zero
    return _as_grid(xr.Dataset(data, coords=coords), point)


# --- numbers stored in a study's impact tables (no run file read) ----------------------------

#: Prefix of the attributes in which a study impact table carries its point's summary numbers.
STORED = "summary_"
_RUN_SPEC = {"settle_time": (), "revolutions": (), "max_Lambda_N": (),
             "iter_max": (("stage",), (len(STAGES),)), "iter_mean": (("stage",), (len(STAGES),)),
             "converged_fraction": (), "wall_time_s": (), "failed": ()}


def _run_numbers(run_ds: xr.Dataset, settle: float) -> dict:
    """The numbers of :func:`_reduce_run` from a run in memory (plain arrays)."""
    steps = slice(1, None)  # t = 0 is the initial state, not a step
    iterations = np.asarray(run_ds["iterations"].values[steps], dtype="f8")
    if "crank_angle" in run_ds:
        settle_time, revolutions = steady_window(run_ds["time"].values,
                                                 run_ds["crank_angle"].values, settle)
    else:
        settle_time, revolutions = float(run_ds["time"].values[0]), np.nan
    return {
        "settle_time": np.float64(settle_time),
        "revolutions": np.float64(revolutions),
        "max_Lambda_N": np.float64(np.max(run_ds["Lambda_N"].values)),
        "iter_max": np.max(iterations, axis=0),
        "iter_mean": np.mean(iterations, axis=0),
        "converged_fraction": np.mean(np.asarray(run_ds["converged"].values[steps], "f8")),
        "wall_time_s": np.float64(run_ds.attrs.get("wall_time_s", np.nan)),
        "failed": np.float64(0.0),
    }


def point_numbers(run_ds: xr.Dataset, impacts_ds: xr.Dataset, settle: float,
                  force_levels: Sequence[float]) -> dict:
    """The summary numbers of one grid point, as attributes for its impact table.

    A study's simulate job calls this with the run and its impact table still in memory and
    stores the result in the table's attributes; :func:`summarize` then takes the numbers from
    there and opens no run file. The numbers are those :func:`summarize` computes from the
    files (the run's variables it reads are written at full precision).

    Parameters
    ----------
    run_ds : xarray.Dataset
        The run (or the marker dataset of a failed run, attribute ``failed = 1``).
    impacts_ds : xarray.Dataset
        Its impact table (:func:`analysis.study_tables.impact_table`).
    settle : float
        Start-up [crank revolutions] (``analysis.settle``).
    force_levels : sequence of float
        Absolute force levels [N] (``analysis.force_levels``).

    Returns
    -------
    dict
        ``summary_settle`` [revolutions] and ``summary_force_levels`` [N] (the settings they
        were made with), ``summary_failed``, and for a run that did not fail
        ``summary_<name>`` for every variable of the summary but ``zero_threshold`` (float64,
        arrays flattened in C order over the dimensions of :func:`summarize`).
    """
    levels = np.asarray(sorted(float(v) for v in force_levels), dtype=float)
    out = {f"{STORED}settle": float(settle), f"{STORED}force_levels": levels}
    if _failed(run_ds):
        out[f"{STORED}failed"] = 1.0
        return out
    numbers = _run_numbers(run_ds, float(settle))
    settle_time, revolutions = float(numbers["settle_time"]), float(numbers["revolutions"])
    if np.isnan(settle_time):
        settle_time = -np.inf

    def column(name):
        if name in impacts_ds.variables and impacts_ds[name].dims == ("impact",):
            return impacts_ds[name].values
        return None

    def meanings(name):
        return impacts_ds[name].attrs.get("flag_meanings") if name in impacts_ds.variables \
            else None

    f_max = column("F_max")
    if f_max is None:
        f_max = np.full(impacts_ds.sizes.get("impact", 0), np.nan)
    numbers.update(_impact_table_numbers(
        column("time"), column("race"), meanings("race"), column("kind"), meanings("kind"),
        f_max, column("p_max"), column("flags"), settle_time, revolutions, levels))
    for name, value in numbers.items():
        value = np.asarray(value, dtype="f8")
        out[f"{STORED}{name}"] = value.ravel() if value.ndim else float(value)
    return out


def _read_stored(path, settle: float, levels: np.ndarray):
    """(point, attributes) of an impact table that carries its summary numbers for these
    settings, else None."""
    import netCDF4

    with netCDF4.Dataset(str(path)) as nc:
        attrs = {key: nc.getncattr(key) for key in nc.ncattrs()}
        if f"{STORED}failed" not in attrs:
            return None
        stored_levels = np.atleast_1d(np.asarray(attrs.get(f"{STORED}force_levels", []), float))
        if (float(attrs.get(f"{STORED}settle", np.nan)) != settle
                or stored_levels.shape != levels.shape or not np.all(stored_levels == levels)):
            return None
        try:
            point = {key: float(np.asarray(nc.variables[key][...]).item()) for key in SWEPT}
        except KeyError as exc:
            raise ValueError(f"{path}: scalar coordinate {exc.args[0]} is missing") from None
    return point, attrs


def _grid_from_stored(stored: list, levels: np.ndarray) -> tuple[xr.Dataset, xr.Dataset]:
    """The run and impact parts of the summary (as :func:`summarize` assembles them from the
    files) from the numbers stored in the impact tables."""
    axes = {key: np.array(sorted({p[key] for p, _ in stored}), dtype=float) for key in SWEPT}
    shape = tuple(axes[key].size for key in SWEPT)
    impact_spec = dict(_impact_spec(levels.size), zero_threshold=((), ()))
    specs = {name: (spec if spec else ((), ())) for name, spec in _RUN_SPEC.items()}
    arrays = {name: np.full(shape + tuple(dims_shape[1]), np.nan)
              for name, dims_shape in {**specs, **impact_spec}.items()}
    for point, attrs in stored:
        at = tuple(int(np.searchsorted(axes[key], point[key])) for key in SWEPT)
        failed = bool(float(attrs[f"{STORED}failed"]))
        arrays["failed"][at] = 1.0 if failed else 0.0
        if failed:
            continue
        for name in arrays:
            if name == "failed":
                continue
            if name == "zero_threshold":
                arrays[name][at] = float(attrs.get("zero_threshold", np.nan))
                continue
            value = np.asarray(attrs[f"{STORED}{name}"], dtype="f8")
            arrays[name][at] = value.reshape(arrays[name].shape[len(SWEPT):])
    swept = list(SWEPT)
    runs = xr.Dataset(
        {name: (swept + list(specs[name][0]), arrays[name]) for name in _RUN_SPEC},
        coords={"stage": np.arange(len(STAGES), dtype=np.int8), **axes})
    impacts = xr.Dataset(
        {name: (swept + list(impact_spec[name][0]), arrays[name]) for name in impact_spec},
        coords={"rank": np.arange(1, N_TOP + 1), "level": levels,
                "race": np.arange(len(RACES), dtype=np.int8),
                "kind": np.arange(len(KINDS), dtype=np.int8), **axes})
    return runs, impacts


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


def _describe(summary: xr.Dataset) -> xr.Dataset:
    """units, long_name, flag attributes; no fill value on coordinates."""
    for name, (units, long_name) in _ATTRS.items():
        if name in summary:
            summary[name].attrs.update(units=units, long_name=long_name)
    for name, (units, long_name) in _COORDS.items():
        if name in summary.coords:
            summary[name].attrs.update(units=units, long_name=long_name)
            if name in _FLAGS:
                summary[name].attrs.update(
                    flag_values=np.arange(len(_FLAGS[name]), dtype=np.int8),
                    flag_meanings=" ".join(_FLAGS[name]))
    for name in summary.coords:
        summary[name].encoding["_FillValue"] = None
    return summary


def _from_files(run_files, impact_files, scheduler, num_workers, settle, levels):
    """The run and impact parts of the summary, reduced from the files on dask."""
    context, compute_kw = _scheduler(scheduler, num_workers)
    with context:
        with _open(run_files, partial(_reduce_run, settle=settle)) as lazy_runs:
            runs = lazy_runs.compute(**compute_kw)
        windows = runs[["settle_time", "revolutions"]]
        with _open(impact_files, partial(_reduce_impacts, windows=windows,
                                         levels=levels)) as lazy_impacts:
            impacts = lazy_impacts.compute(**compute_kw)
    return runs, impacts


def summarize(run_files: Sequence[str], impact_files: Sequence[str], scheduler=None,
              num_workers: int | None = None, settle: float = 0.0,
              force_levels: Sequence[float] = (100.0, 1000.0),
              settings: dict | None = None) -> xr.Dataset:
    """Summarise a study over its swept parameters.

    Parameters
    ----------
    run_files : sequence of path
        Run files, or failed-run markers (attribute ``failed = 1``).
    impact_files : sequence of path
        Impact tables of the same runs (dimension ``impact``; columns ``time``, ``race``,
        ``kind``, ``F_max``, and where present ``p_max`` and ``flags``; attribute
        ``zero_threshold``). Older tables with string ``race``/``kind`` are read too; a column
        a table lacks counts as missing.
    scheduler : str, optional
        None or ``"threads"``: dask's local threads; ``"synchronous"``: no parallelism;
        ``"local"``: start a ``distributed.LocalCluster``; anything else: the address of a
        running dask distributed scheduler (``tcp://host:8786``), which needs the package
        ``distributed`` and the files visible from its workers.
    num_workers : int, optional
        Local threads or local-cluster workers.
    settle : float
        Start-up left out of the statistics [crank revolutions] (:func:`steady_window`).
    force_levels : sequence of float
        Absolute force levels of ``n_above``/``above_per_rev`` [N].
    settings : dict, optional
        The analysis settings, recorded as attributes ``analysis_<key>`` (no dots: CF names).

    Returns
    -------
    xarray.Dataset
        Dimensions ``clearance``, ``mu``, ``omega0``, ``e_N`` plus ``race``, ``kind``,
        ``level``, ``rank`` and ``stage``, in memory, every variable with ``units`` and
        ``long_name`` (see the module docstring).

    Notes
    -----
    When every impact table carries its point's numbers for these ``settle`` and
    ``force_levels`` (attributes ``summary_*`` of :func:`point_numbers`, which the study's
    simulate jobs store), the summary is assembled from those attributes: no run file and no
    table column is read, and ``scheduler`` is not used; a table marked failed there makes its
    point missing. Otherwise every file is reduced as described in the module docstring.
    """
    if not run_files or not impact_files:
        raise ValueError("summarize: no run or impact files given")
    settle = float(settle)
    if not np.isfinite(settle) or settle < 0:
        raise ValueError(f"summarize: settle must be a number >= 0 [revolutions], got {settle}")
    levels = np.asarray(sorted(float(v) for v in force_levels), dtype=float)
    if levels.size == 0 or not np.all(np.isfinite(levels) & (levels > 0)):
        raise ValueError(f"summarize: force_levels must be numbers > 0 [N], got {force_levels}")
    stored = []
    for path in impact_files:  # the numbers the study's jobs stored in the impact tables
        found = _read_stored(path, settle, levels)
        if found is None:
            stored = None
            break
        stored.append(found)
    if stored:
        runs, impacts = _grid_from_stored(stored, levels)
    else:
        runs, impacts = _from_files(run_files, impact_files, scheduler, num_workers, settle,
                                    levels)
    summary = xr.merge([runs, impacts], join="outer", compat="no_conflicts",
                       combine_attrs="drop")
    # A point whose run file says "failed" is missing everywhere, whatever the impact file says.
    failed = summary["failed"] > 0
    for name in summary.data_vars:
        if name != "failed":
            summary[name] = summary[name].where(~failed)
    order = list(SWEPT) + [d for d in ("race", "kind", "level", "rank", "stage")
                           if d in summary.dims]
    summary = _describe(summary.transpose(*order))
    from simcore import __version__

    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    summary.attrs.update(
        Conventions="CF-1.10",
        title="Ball bearing (SKF 6012) in a crank-slider: parameter study summary",
        source=f"bearingsim {__version__} (analysis.summary)",
        history=f"{now}: summary of {int(summary['failed'].size)} runs by bearingsim "
                f"{__version__} (analysis.summary.summarize)",
        n_runs=int(summary["failed"].size),
        n_failed=int(failed.sum()),
        settle_revolutions=settle,
    )
    for key, value in (settings or {}).items():
        if value is not None:
            summary.attrs[f"analysis_{key}"] = value
    return summary


# --- the study in one table -----------------------------------------------------------------

def _where(da: xr.DataArray) -> str:
    """``clearance=0.0004, mu=0.05, ...`` of the largest finite value of ``da``."""
    values = np.asarray(da.values, dtype=float)
    if not np.isfinite(values).any():
        return ""
    idx = np.unravel_index(np.nanargmax(values), values.shape)
    return ", ".join(f"{d}={float(da[d].values[i]):g}" for d, i in zip(da.dims, idx, strict=True))


def summary_table(summary: xr.Dataset):
    """The study in numbers: each quantity's smallest, median and largest value over the grid.

    Parameters
    ----------
    summary : xarray.Dataset
        Output of :func:`summarize`.

    Returns
    -------
    pandas.DataFrame
        Columns ``quantity``, ``unit``, ``min``, ``median``, ``max``, ``largest at`` (the grid
        point of the largest value); failed runs are left out (their values are missing).
    """
    import pandas as pd

    rows = []

    def add(name, unit, da, scale=1.0):
        values = np.asarray(da.values, dtype=float) * scale
        finite = values[np.isfinite(values)]
        if not finite.size:
            return
        rows.append({"quantity": name, "unit": unit, "min": f"{finite.min():.4g}",
                     "median": f"{np.median(finite):.4g}", "max": f"{finite.max():.4g}",
                     "largest at": _where(da)})

    n_runs = int(summary["failed"].size)
    n_failed = int((summary["failed"] > 0).sum())
    grid = " x ".join(f"{summary.sizes[d]} {d}" for d in SWEPT if d in summary.dims)
    rows.append({"quantity": f"runs, of which {n_failed} failed", "unit": "1", "min": "",
                 "median": "", "max": str(n_runs), "largest at": f"grid: {grid}"})
    def have(*names):
        return all(name in summary for name in names)

    for r in (1, 0):
        if have("peak_force"):
            add(f"peak force, {RACES[r]} race", "kN", summary["peak_force"].isel(race=r), 1e-3)
    for r in (1, 0):
        if have("p_max"):
            add(f"peak contact pressure p_max, {RACES[r]} race", "MPa",
                summary["p_max"].isel(race=r), 1e-6)
    if have("startup_peak_force"):
        add("start-up peak force", "kN", summary["startup_peak_force"], 1e-3)
    if have("above_per_rev"):
        for i, level in enumerate(summary["level"].values):
            add(f"impacts per revolution with F_max >= {level:g} N", "1",
                summary["above_per_rev"].isel(level=i).sum("race", min_count=1))
    if have("impacts_per_rev"):
        add("impacts per revolution (relative zero threshold)", "1",
            summary["impacts_per_rev"].sum(["race", "kind"], min_count=1))
    if have("revolutions"):
        add("steady revolutions per run", "1", summary["revolutions"])
    if have("iter_max"):
        add("Newton iterations per step, largest (any stage)", "1",
            summary["iter_max"].max("stage"))
    if have("wall_time_s"):
        add("wall time per run", "s", summary["wall_time_s"])
    return pd.DataFrame(rows, columns=["quantity", "unit", "min", "median", "max",
                                       "largest at"])
