"""I/O layer: the only part of simcore that imports xarray.

Turns the kernels' plain arrays into the run dataset and writes netCDF atomically, by role:

- :mod:`.variables`: the registry of every run-file variable and coordinate (dimensions, units,
  long name, stored type, description) and of the swept parameters;
- :mod:`.dataset`: the run dataset assembled in named stages (:func:`trajectory_dataset`), the
  global attributes, the file of a failed run;
- :mod:`.netcdf`: atomic writing (temporary file in the target folder, then ``os.replace``, so
  that no reader ever sees a half-written file; :func:`update_attributes` edits a copy), the
  encoding, ``study.keep``;
- :mod:`.read`: reading a run back (``q`` and ``v`` of the kernels, one sample's state), a
  study's runs as one grid (:func:`open_runs`), and a file's categories by their names
  (:func:`with_category_names`).

The files follow the CF conventions (version 1.10), as ``.ci/cf-check`` verifies on every file of
the smoke study:

- every variable has UDUNITS ``units`` and a ``long_name``; a quantity that mixes units is split
  (the generalized coordinates ``q`` = (x, y, phi) become ``position`` [m] and ``angle`` [rad],
  the velocities ``velocity`` [m s-1] and ``angular_velocity`` [rad s-1]; :func:`generalized`
  rebuilds ``q`` and ``v`` for code that wants them);
- no ``_FillValue`` on coordinates;
- labels (``race``, ``body``, ``axis``, ``stage``) are stored as character arrays, which CF reads
  as string labels and xarray gives back as strings (``ds.race == "outer"`` keeps working);
- the swept parameters (``clearance``, ``mu``, ``omega0``, ``e_N``, and in a study every other
  axis of its grid and the contact ``model``, :func:`study_coords`) are coordinates of length-1
  dimensions, so that ``xr.open_mfdataset("results/runs/*.nc", combine="by_coords")`` assembles a
  study's runs into one grid (:func:`open_runs` adds the arguments that keep it so under
  xarray's announced defaults). Read one value with ``ds.clearance.item()``: ``float()`` refuses a
  length-1 array.
"""

from __future__ import annotations

from ..startup.patches import dataset_of_arrays, to_netcdf4
from .dataset import (
    failed_run_dataset,
    global_attributes,
    history_line,
    setting_attribute,
    trajectory_dataset,
)
from .netcdf import (
    keep_variables,
    netcdf_encoding,
    replace_durably,
    replacing,
    update_attributes,
    write_netcdf,
)
from .read import (
    GENERALIZED_PARTS,
    generalized,
    load_netcdf,
    open_run,
    open_runs,
    state_at,
    time_steps,
    with_category_names,
)
from .variables import (
    CONVENTIONS,
    COORDINATES,
    DEFAULT_KEEP,
    PARAMETERS,
    RUN_VARIABLES,
    STORAGE,
    VARIABLES,
    parameter_coords,
    study_coords,
)

#: The paper's four study parameters (coordinate names), axes of every study.
BASE_PARAMETERS = tuple(PARAMETERS)

__all__ = ["write_netcdf", "replace_durably", "replacing", "update_attributes",
           "trajectory_dataset", "dataset_of_arrays",
           "failed_run_dataset",
           "generalized", "load_netcdf", "open_run", "open_runs", "state_at", "time_steps",
           "with_category_names",
           "parameter_coords",
           "study_coords",
           "history_line", "setting_attribute", "BASE_PARAMETERS",
           "keep_variables", "netcdf_encoding", "to_netcdf4", "global_attributes",
           "GENERALIZED_PARTS", "CONVENTIONS", "COORDINATES", "PARAMETERS", "STORAGE",
           "VARIABLES", "RUN_VARIABLES", "DEFAULT_KEEP"]
