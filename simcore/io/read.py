"""Reading a run file back: the generalized coordinates of the kernels, one sample's state,
the time steps the run took, and category coordinates by their names."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

#: The run-file variables that make up ``q`` and ``v`` (:func:`generalized`).
GENERALIZED_PARTS = {"q": ("position", "angle"), "v": ("velocity", "angular_velocity")}


def generalized(ds: xr.Dataset) -> xr.Dataset:
    """Add the generalized coordinates ``q`` and velocities ``v`` (time, body, dof) to a run.

    ``dof`` is (x, y, phi): ``q`` stacks ``position`` [m] and ``angle`` [rad], ``v`` stacks
    ``velocity`` [m s-1] and ``angular_velocity`` [rad s-1], as the kernels order them. The two
    variables mix units, so they live in memory only (the files keep the split variables).
    Each is added where the run has its parts: a compliant twin of a study keeps no velocities
    (``study.keep``), so its file gets ``q`` only.
    """
    def stack(lin, rot, long_name):
        lin = lin.transpose("time", "body", "axis")
        rot = rot.transpose("time", "body")
        values = np.concatenate([lin.values, rot.values[..., None]], axis=-1)
        return xr.DataArray(values, dims=("time", "body", "dof"),
                            coords={"time": ds["time"], "body": ds["body"],
                                    "dof": ["x", "y", "phi"]},
                            attrs={"long_name": long_name})

    long_names = {"q": "positions x [m], y [m] and angle phi [rad]",
                  "v": "velocities vx, vy [m s-1] and angular velocity omega [rad s-1]"}
    return ds.assign({name: stack(*(ds[p] for p in parts), long_names[name])
                      for name, parts in GENERALIZED_PARTS.items()
                      if all(p in ds for p in parts)})


def state_at(ds: xr.Dataset, i: int) -> tuple[np.ndarray, np.ndarray]:
    """The generalized coordinates and velocities (n,) of sample ``i`` of a run, in the
    kernels' order (x, y, phi of each body): from ``q`` and ``v`` where the run has them, else
    from their parts (:data:`GENERALIZED_PARTS`), without stacking the whole run as
    :func:`generalized` does."""
    def one(name):
        if name in ds:
            return np.asarray(ds[name].isel(time=i).values, dtype=float).ravel()
        lin, rot = GENERALIZED_PARTS[name]
        lin = ds[lin].isel(time=i).transpose("body", "axis").values
        rot = ds[rot].isel(time=i).transpose("body").values
        return np.concatenate([lin, rot[:, None]], axis=1).astype(float).ravel()

    return one("q"), one("v")


def time_steps(ds: xr.Dataset) -> float:
    """The time steps a run took: its accepted adaptive steps (attribute ``n_steps_accepted``),
    else its length over ``solver.dt`` (NaN for a file without that setting)."""
    attrs = ds.attrs
    if "n_steps_accepted" in attrs:
        return float(attrs["n_steps_accepted"])
    dt = attrs.get("solver.dt")
    time = np.asarray(ds["time"].values, dtype=float)
    if not dt or time.size == 0:
        return np.nan
    return float(round((time[-1] - time[0]) / float(dt)))


#: The first bytes of a netCDF file: classic (CDF\x01, \x02, \x05) or netCDF-4 (HDF5).
_NETCDF_MAGIC = (b"CDF", b"\x89HDF")


def load_netcdf(path: str | Path, name: str) -> xr.Dataset:
    """The netCDF file ``path``, loaded into memory, for a command line's argument ``name``.

    Raises
    ------
    ValueError
        One line naming ``name`` and ``path``: it does not exist, is a folder, is not a
        netCDF file, or cannot be read (the reader's first line).
    """
    path = Path(path)
    if not path.exists():
        raise ValueError(f"{name}: {path} does not exist")
    if path.is_dir():
        raise ValueError(f"{name}: {path} is a folder; allowed: a netCDF file")
    try:
        with open(path, "rb") as head:
            magic = head.read(4)
    except OSError as exc:  # no permission, a device that fails
        raise ValueError(f"{name}: cannot read {path}: {exc.strerror}") from None
    if not magic.startswith(_NETCDF_MAGIC):
        raise ValueError(f"{name}: {path} is not a netCDF file")
    try:
        with xr.open_dataset(path) as ds:
            return ds.load()
    except (OSError, ValueError) as exc:
        raise ValueError(f"{name}: cannot read {path}: {str(exc).splitlines()[0]}") from None


def open_run(path: str | Path) -> xr.Dataset:
    """Open a run file (in memory) with ``q`` and ``v`` added where it has their parts
    (:func:`generalized`)."""
    with xr.open_dataset(path) as ds:
        ds = ds.load()
    if int(ds.attrs.get("failed", 0)):
        return ds
    return generalized(ds)


def open_runs(paths) -> xr.Dataset:
    """A study's run files as one grid over its swept axes (lazy, with dask).

    ``xarray.open_mfdataset`` with ``combine="by_coords"`` and the arguments that keep its
    result what a study's files mean, whatever xarray's defaults: every variable along the
    swept axes (``data_vars="all"``), runs of different length padded with NaN at the end
    (``join="outer"``: a run at a higher crank speed is shorter in time), one chunk per file
    along ``time``, ``contact`` and ``body`` (fewer dask tasks, and no warning that their
    chunks were split). A failed run's marker file combines as missing values.

    Parameters
    ----------
    paths : str or sequence of str or path
        A glob (``"results/runs/*.nc"``) or the files. The runs of one bearing: bearings with
        different ball counts have different ``contact`` and ``body`` and do not combine.

    Returns
    -------
    xarray.Dataset
    """
    return xr.open_mfdataset(paths, combine="by_coords", data_vars="all", join="outer",
                             chunks={"time": -1, "contact": -1, "body": -1})


def with_category_names(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with every category by its names: a coordinate or variable stored as int8 codes
    with CF ``flag_values`` and ``flag_meanings`` (a summary's ``model``, ``race``, ``kind``,
    ``stage`` and an enumerated or boolean swept axis such as ``bearing`` or
    ``clearance_class``, a run file's swept categories, an impact table's ``race``, ``kind``,
    ``trusted`` and ``approach``) gets the names of its codes, so that
    ``s.peak_force.sel(model="compliant", race="outer", bearing="6205")`` and
    ``table.where(table.race == "outer")`` read as the study was written. The file keeps the
    codes (the data contract stores no strings); this is for reading. A code without a meaning
    becomes ``""``. A bit mask (``flag_masks``, an impact table's ``flags``) keeps its codes.

    Parameters
    ----------
    ds : xarray.Dataset
        A run file, an impact table or a study summary, as opened.

    Returns
    -------
    xarray.Dataset
        A new dataset; the categories' other attributes (``long_name``, ``sweep_key``) stay.
    """
    def named(var):
        codes = np.atleast_1d(var.attrs["flag_values"]).tolist()
        meaning = dict(zip(codes, str(var.attrs["flag_meanings"]).split(), strict=True))
        values = np.asarray(var.values)
        labels = np.array([meaning.get(int(v), "") if np.isfinite(v) else ""
                           for v in values.ravel()], dtype=object).reshape(values.shape)
        attrs = {k: v for k, v in var.attrs.items()
                 if k not in ("flag_values", "flag_meanings", "units")}
        return var.dims, labels, attrs

    def categories(variables):
        return {name: named(var) for name, var in variables.items()
                if "flag_values" in var.attrs and "flag_meanings" in var.attrs}

    return ds.assign(categories(ds.data_vars)).assign_coords(categories(ds.coords))
