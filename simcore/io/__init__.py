"""I/O layer: the only part of simcore that imports xarray.

Turns the kernels' plain arrays into the run dataset and writes netCDF atomically, by role:

- :mod:`.variables`: the registry of every run-file variable and coordinate (dimensions, units,
  long name, stored type, description) and of the swept parameters;
- :mod:`.dataset`: the run dataset assembled in named stages (:func:`trajectory_dataset`), the
  global attributes, the file of a failed run;
- :mod:`.netcdf`: atomic writing (temporary file in the target folder, then ``os.replace``, so
  that no reader ever sees a half-written file), the encoding, ``study.keep``;
- :mod:`.read`: reading a run back (``q`` and ``v`` of the kernels, one sample's state).

The files follow the CF conventions (version 1.10), as ``.ci/cf-check`` verifies on every file of
the smoke study:

- every variable has UDUNITS ``units`` and a ``long_name``; a quantity that mixes units is split
  (the generalized coordinates ``q`` = (x, y, phi) become ``position`` [m] and ``angle`` [rad],
  the velocities ``velocity`` [m s-1] and ``angular_velocity`` [rad s-1]; :func:`generalized`
  rebuilds ``q`` and ``v`` for code that wants them);
- no ``_FillValue`` on coordinates;
- labels (``race``, ``body``, ``axis``, ``stage``) are stored as character arrays, which CF reads
  as string labels and xarray gives back as strings (``ds.race == "outer"`` keeps working);
- the swept parameters (``clearance``, ``mu``, ``omega0``, ``e_N``) are coordinates of length-1
  dimensions, so that ``xr.open_mfdataset("results/runs/*.nc", combine="by_coords")`` assembles a
  study's runs into one grid. Read one value with ``ds.clearance.item()``: ``float()`` refuses a
  length-1 array.
"""

from __future__ import annotations

import sys

from .dataset import (
    dataset_of_arrays,
    failed_run_dataset,
    global_attributes,
    history_line,
    trajectory_dataset,
)
from .netcdf import keep_variables, netcdf_encoding, to_netcdf4, write_netcdf
from .read import GENERALIZED_PARTS, generalized, open_run, state_at
from .variables import (
    CONVENTIONS,
    COORDINATES,
    DEFAULT_KEEP,
    PARAMETERS,
    RUN_VARIABLES,
    STORAGE,
    VARIABLES,
    parameter_coords,
)


def _defer_dask_array_type() -> bool:
    """Let xarray ask for dask's array type without importing ``dask.array`` first.

    xarray checks every Variable it makes (the netCDF encoder makes one per variable written)
    with ``isinstance(data, array_type("dask"))``, and the first check imports ``dask.array``
    to learn that type: 0.15-0.2 s of a new process's first write, for a run that has NumPy
    arrays only. No dask array can exist before ``dask.array`` is imported, so xarray's record
    of dask (``xarray.namedarray.pycompat._cached_duck_array_modules["dask"]``) is given a
    stand-in whose ``type`` is ``dask.array.Array`` once that module is imported (by the user,
    or by xarray for a chunked dataset) and empty until then; anything else asked of it (the
    version) is answered by xarray's own record, made then. The answers are those of xarray's
    record at every moment. Nothing is changed where xarray has made its record already or
    keeps it elsewhere.

    Returns
    -------
    bool
        True when the stand-in was put in place.
    """
    try:
        from xarray.namedarray import pycompat

        cache = pycompat._cached_duck_array_modules
        record = pycompat.DuckArrayModule
    except (ImportError, AttributeError):
        return False
    if not isinstance(cache, dict) or "dask" in cache:
        return False

    class DaskArrayType:
        @property
        def type(self):
            array = getattr(sys.modules.get("dask.array"), "Array", None)
            return (array,) if isinstance(array, type) else ()

        def __getattr__(self, name):
            cache["dask"] = real = record("dask")
            return getattr(real, name)

    cache["dask"] = DaskArrayType()
    return True


DASK_ARRAY_TYPE_DEFERRED = _defer_dask_array_type()

__all__ = ["write_netcdf", "trajectory_dataset", "dataset_of_arrays", "failed_run_dataset",
           "generalized", "open_run", "state_at", "parameter_coords", "history_line",
           "keep_variables", "netcdf_encoding", "to_netcdf4", "global_attributes",
           "GENERALIZED_PARTS", "CONVENTIONS", "COORDINATES", "PARAMETERS", "STORAGE",
           "VARIABLES", "RUN_VARIABLES", "DEFAULT_KEEP"]
