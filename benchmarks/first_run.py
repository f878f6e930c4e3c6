"""Where a new process's first run of the paper case spends its time (warm Numba cache).

Run as a fresh process by ``benchmarks/bench_core.py`` (which takes medians over several
processes); it prints one JSON object of the stages of one path:

- ``api``: ``import simcore; simcore.run(simcore.load_config())`` returning the dataset;
- ``cli``: ``python -m simcore run --out FILE.nc`` (``simcore/__main__.py`` run as the main
  module, as ``-m`` does), which also writes the netCDF file.

Stages, in seconds: ``start`` (interpreter start-up up to the first line, from the parent's
clock in ``FIRST_RUN_T0``), ``import_numpy``, ``import_numba``, ``import_simcore`` (the rest of
``import simcore``), ``config``, ``run`` (the run or the command, everything after the config)
and ``total``; ``cpu`` is the CPU time of the whole process (user + system), which waiting
for a core on a shared machine does not inflate. Inside ``run`` (the parts are timed where they
happen, so that the code under
test is not changed):

- ``numba_refresh``: the first ``refresh()`` of Numba's CPU target (it imports the lowering
  registries and starts its runtime; done by the first call of any kernel, compiled or cached),
  of which ``scipy_blas`` is the import of SciPy's BLAS that ``numba.np.arraymath`` makes;
- ``cache_load`` (and per specialisation in ``loads``): Numba's cache index look-up and the load
  of the cached object code, ``cache_index`` of which is the look-up and the unpickling;
- ``typeof``: the Python ``typeof`` of arguments the dispatcher cannot type in C (namedtuples of
  arrays), over every call of the run, with its call count;
- ``build_model``: the crank-slider model built from the configuration (both its builds: the
  warm-up's and the run's);
- ``warm_up``: :func:`simcore.runner.warm_up` (a two-step run that loads the kernels; it holds
  the Numba figures above, apart from ``typeof`` of the later calls);
- ``integrate``: the time loop of the run (``wall_time_s``);
- ``dataset``: :func:`simcore.io.trajectory_dataset` (the xarray Dataset of the run);
- ``import_xarray``, ``import_dask`` (``import_dask_array`` when xarray asks for it),
  ``import_netcdf4``: imports made during the run, wherever they happen;
- ``import_wait``: how long the run waited for the I/O layer's import when it ran in a
  background thread during the integration (:func:`simcore.runner.import_meanwhile`; then
  ``import_background`` is 1 and ``import_xarray`` is that thread's time, overlapping the
  integration);
- ``write``: :func:`simcore.io.write_netcdf` (CLI only).

Usage: python benchmarks/first_run.py {api,cli} [--out FILE.nc]
"""

from __future__ import annotations

import os
import time

_T_ENTRY = time.time()
_P_ENTRY = time.perf_counter()

import importlib.abc  # noqa: E402
import importlib.machinery  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402

TIMED_IMPORTS = {"xarray": "import_xarray", "dask": "import_dask",
                 "dask.array": "import_dask_array",
                 "netCDF4": "import_netcdf4", "scipy.linalg": "scipy_blas",
                 "h5netcdf": "import_h5netcdf"}

stages: dict = {}
loads: list = []
counts = {"typeof_calls": 0}


class _TimingLoader(importlib.abc.Loader):
    """Times the execution of a module (with everything it imports) the first time."""

    def __init__(self, loader, key):
        self.loader, self.key = loader, key

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module):
        t = time.perf_counter()
        try:
            self.loader.exec_module(module)
        finally:
            stages[self.key] = stages.get(self.key, 0.0) + time.perf_counter() - t


class _TimingFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name not in TIMED_IMPORTS:
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is not None and spec.loader is not None:
            spec.loader = _TimingLoader(spec.loader, TIMED_IMPORTS[name])
        return spec


def _wrap(owner, name, key, per_call=None):
    original = getattr(owner, name)

    def timed(*args, **kwargs):
        t = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            dt = time.perf_counter() - t
            stages[key] = stages.get(key, 0.0) + dt
            if per_call is not None:
                per_call(args, dt)

    setattr(owner, name, timed)


def _instrument_numba():
    from numba.core import base, caching, dispatcher

    first = {"done": False}
    refresh = base.BaseContext.refresh

    def timed_refresh(self):
        if first["done"]:
            return refresh(self)
        first["done"] = True
        t = time.perf_counter()
        try:
            return refresh(self)
        finally:
            stages["numba_refresh"] = time.perf_counter() - t

    base.BaseContext.refresh = timed_refresh

    def record(args, dt):
        func = args[0]._py_func
        loads.append({"function": f"{func.__module__.rsplit('.', 1)[-1]}.{func.__qualname__}",
                      "seconds": dt})

    _wrap(caching.Cache, "_load_overload", "cache_load", per_call=record)
    _wrap(caching.IndexDataCacheFile, "load", "cache_index")

    typeof_pyval = dispatcher.Dispatcher.typeof_pyval

    def timed_typeof(self, val):
        t = time.perf_counter()
        try:
            return typeof_pyval(self, val)
        finally:
            stages["typeof"] = stages.get("typeof", 0.0) + time.perf_counter() - t
            counts["typeof_calls"] += 1

    dispatcher.Dispatcher.typeof_pyval = timed_typeof


def _wrap_import_meanwhile(simulate):
    """Time the run's wait for the import :func:`simcore.runner.import_meanwhile` starts."""
    original = simulate.import_meanwhile

    def timed(name):
        thread = original(name)
        if thread is not None:
            stages["import_background"] = 1
            _wrap(thread, "join", "import_wait")
        return thread

    simulate.import_meanwhile = timed


def _wrap_io(module):
    _wrap(module, "trajectory_dataset", "dataset")
    _wrap(module, "write_netcdf", "write")


class _IoFinder(importlib.abc.MetaPathFinder):
    """Wraps the dataset and writer functions of :mod:`simcore.io` when it is imported (the
    code under test decides when that is)."""

    def find_spec(self, name, path, target=None):
        if name != "simcore.io":
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        loader = spec.loader

        class _Loader(importlib.abc.Loader):
            def create_module(self, spec):
                return loader.create_module(spec)

            def exec_module(self, module):
                loader.exec_module(module)
                _wrap_io(module)

        spec.loader = _Loader()
        return spec


def main(argv=None) -> None:
    import argparse

    p = argparse.ArgumentParser()
    p.add_argument("path", choices=("api", "cli"))
    p.add_argument("--out", default=None)
    args = p.parse_args(argv)
    t0 = float(os.environ.get("FIRST_RUN_T0", _T_ENTRY))
    stages["start"] = _T_ENTRY - t0
    sys.meta_path.insert(0, _TimingFinder())
    t = time.perf_counter()
    import numpy  # noqa: F401

    stages["import_numpy"] = time.perf_counter() - t
    t = time.perf_counter()
    import numba  # noqa: F401

    stages["import_numba"] = time.perf_counter() - t
    _instrument_numba()
    sys.meta_path.insert(0, _IoFinder())
    t = time.perf_counter()
    import simcore

    stages["import_simcore"] = time.perf_counter() - t
    stages["xarray_at_import"] = "xarray" in sys.modules
    import simcore.runner as simulate

    _wrap(simulate, "crank_slider", "build_model")
    _wrap(simulate, "warm_up", "warm_up")
    _wrap_import_meanwhile(simulate)
    if args.path == "api":
        t = time.perf_counter()
        cfg = simcore.load_config()
        stages["config"] = time.perf_counter() - t
        t = time.perf_counter()
        ds = simcore.run(cfg)
        stages["run"] = time.perf_counter() - t
        stages["integrate"] = float(ds.attrs["wall_time_s"])
        stages["max_lambda_N"] = float(ds["Lambda_N"].values.max())
    else:

        out = args.out or os.path.join(tempfile.mkdtemp(prefix="first_run_"), "paper.nc")
        stages["config"] = 0.0  # the command reads its configuration itself
        original_run = simulate.run

        def timed_run(cfg, progress=False):
            ds = original_run(cfg, progress=progress)
            stages["integrate"] = float(ds.attrs["wall_time_s"])
            stages["max_lambda_N"] = float(ds["Lambda_N"].values.max())
            return ds

        simulate.run = timed_run
        import runpy

        t = time.perf_counter()
        sys.argv = ["simcore", "run", "--quiet", "--out", out]
        try:  # as ``python -m simcore run --out FILE``, shut-down measures included
            runpy.run_module("simcore", run_name="__main__", alter_sys=True)
            code = 0
        except SystemExit as exc:
            code = exc.code
        stages["run"] = time.perf_counter() - t
        if code != 0:
            raise SystemExit(f"the command failed with exit code {code}")
        stages["file_bytes"] = os.path.getsize(out)
        if args.out is None:
            os.unlink(out)
            os.rmdir(os.path.dirname(out))
    stages["total"] = stages["start"] + time.perf_counter() - _P_ENTRY
    stages["cpu"] = time.process_time()  # CPU time of the process since it started
    stages["typeof_calls"] = counts["typeof_calls"]
    stages["loads"] = loads
    stages["modules"] = len(sys.modules)
    print(json.dumps(stages))


if __name__ == "__main__":
    main()
