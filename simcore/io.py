"""I/O layer: the only part of simcore that imports xarray.

Turns the kernels' plain arrays into a CF-style ``xarray.Dataset`` (SPEC section 5) and writes
netCDF atomically (temporary file in the target folder, then ``os.replace``), so that no reader
ever sees a half-written file.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr


def write_netcdf(ds: xr.Dataset, path: str | Path, complevel: int = 4) -> Path:
    """Write ``ds`` to ``path`` atomically, with zlib compression of the float variables.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset to write.
    path : str or Path
        Target file; its folder is created if missing.
    complevel : int
        zlib compression level (0-9).

    Returns
    -------
    Path
        The written path.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    encoding = {}
    for name, var in ds.data_vars.items():
        if var.ndim > 0 and var.dtype.kind in "fiub":
            encoding[name] = {"zlib": True, "complevel": complevel, "shuffle": True}
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        ds.to_netcdf(tmp, engine="netcdf4", encoding=encoding)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def _attrs(units: str, long_name: str, **extra) -> dict:
    out = {"units": units, "long_name": long_name}
    out.update(extra)
    return out


__all__ = ["write_netcdf", "np"]
