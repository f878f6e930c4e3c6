"""simcore: nonsmooth multibody simulation of a ball bearing inside a crank-slider.

Public API
----------
load_config(path=None, overrides=())  -> validated configuration dict
run(config)                           -> xarray.Dataset of one run (README, "The run file")
write_netcdf(ds, path)                -> atomic netCDF writing
zoom(run_ds, time, window, dt=...)    -> compliant re-simulation from a run's state
"""

from importlib.metadata import PackageNotFoundError, version

from .startup import patches

patches.install()  # before any kernel is compiled or loaded (BEARINGSIM_STARTUP_PATCHES=0: none)

with patches.collector_paused():
    from .config import ConfigError, load_config, load_schema, validate_config
    from .model import SolverError

try:
    __version__ = version("bearingsim")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"


_first_run_done = False


def run(config, progress=False):
    """Simulate one run; see :func:`simcore.runner.run`. The first run in a process loads the
    kernels, xarray, ... with the garbage collector paused and freezes the heap at exit
    (start-up patch ``gc_freeze``, :mod:`simcore.startup.patches`)."""
    global _first_run_done
    from .runner import run as _run

    if _first_run_done:
        return _run(config, progress=progress)
    with patches.collector_paused():
        ds = _run(config, progress=progress)
    _first_run_done = True
    patches.freeze_heap_at_exit()
    return ds


def write_netcdf(ds, path, complevel=4, keep=None):
    """Write a dataset atomically (``keep``: the variables a run file stores, ``study.keep``);
    see :func:`simcore.io.write_netcdf`."""
    from .io import write_netcdf as _write

    return _write(ds, path, complevel=complevel, keep=keep)


def zoom(run_ds, time, window=2e-3, dt=1e-6, overrides=(), output_dt=None,
         until_released=True, progress=False, watch_contacts=None, watch_onset=None,
         adaptive=True):
    """Compliant zoom on a run; see :func:`simcore.study.zoom.zoom`."""
    from .study.zoom import zoom as _zoom

    return _zoom(run_ds, time, window=window, dt=dt, overrides=overrides, output_dt=output_dt,
                 until_released=until_released, progress=progress,
                 watch_contacts=watch_contacts, watch_onset=watch_onset, adaptive=adaptive)


__all__ = ["ConfigError", "SolverError", "load_config", "load_schema", "validate_config", "run",
           "write_netcdf", "zoom", "__version__"]
