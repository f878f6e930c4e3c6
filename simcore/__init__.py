"""simcore: nonsmooth multibody simulation of a ball bearing inside a crank-slider.

Public API
----------
load_config(path=None, overrides=())  -> validated configuration dict
run(config)                           -> xarray.Dataset of one run (README, "The run file")
write_netcdf(ds, path)                -> atomic netCDF writing
zoom(run_ds, time, window, dt=...)    -> compliant re-simulation from a run's state
"""

import atexit
import gc
from contextlib import contextmanager
from importlib.metadata import PackageNotFoundError, version


@contextmanager
def _collector_paused():
    """Pause Python's cyclic garbage collector while a process loads what a run needs.

    Loading simcore, Numba's registries, xarray, pandas and dask creates a few hundred thousand
    objects that live as long as the process; the collector, started by the count of new
    objects, walks them again and again (its full passes over the growing heap take 0.05-0.15 s
    each) and finds nothing to free: some 0.25 s of a new process's first run of the paper case,
    0.35 s of the command's. Paused while loading and the first run, it runs again afterwards
    (in the state it was in), and collects what is left then.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


with _collector_paused():
    from .config import ConfigError, load_config, load_schema, validate_config
    from .model import SolverError

try:
    __version__ = version("bearingsim")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"


_first_run_done = False

#: Freeze Python's heap when the process exits (registered by the first :func:`run`). The
#: interpreter's shut-down walks every object still alive with the cyclic collector, several
#: times: with NumPy, Numba, xarray and pandas loaded that took 0.35-0.4 s of a script that
#: runs the paper's case in 0.65 s. Frozen, they are skipped, and freed with the process.
#: Python does not promise to finalize objects that still exist at exit (``__del__`` of
#: garbage in reference cycles then); set to False to keep its last collections anyway.
freeze_at_exit = True


def _freeze_at_exit():
    if freeze_at_exit:
        gc.freeze()


def run(config, progress=False):
    """Simulate one run; see :func:`simcore.runner.run`."""
    global _first_run_done
    from .runner import run as _run

    if _first_run_done:
        return _run(config, progress=progress)
    with _collector_paused():  # the first run loads the kernels, xarray, ...
        ds = _run(config, progress=progress)
    _first_run_done = True
    atexit.register(_freeze_at_exit)
    return ds


def write_netcdf(ds, path, complevel=4, keep=None):
    """Write a dataset atomically (``keep``: the variables a run file stores, ``study.keep``);
    see :func:`simcore.io.write_netcdf`."""
    from .io import write_netcdf as _write

    return _write(ds, path, complevel=complevel, keep=keep)


def zoom(run_ds, time, window=2e-3, dt=1e-6, overrides=(), output_dt=None,
         until_released=True, progress=False, watch_contacts=None, watch_onset=None):
    """Compliant zoom on a run; see :func:`simcore.study.zoom.zoom`."""
    from .study.zoom import zoom as _zoom

    return _zoom(run_ds, time, window=window, dt=dt, overrides=overrides, output_dt=output_dt,
                 until_released=until_released, progress=progress,
                 watch_contacts=watch_contacts, watch_onset=watch_onset)


__all__ = ["ConfigError", "SolverError", "load_config", "load_schema", "validate_config", "run",
           "write_netcdf", "zoom", "__version__"]
