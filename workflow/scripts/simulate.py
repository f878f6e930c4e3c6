"""Job of rule ``simulate``: the runs of one batch -> results/runs/<params>.nc, one per run.

A run whose solver does not converge (``simcore.SolverError``, or a singular matrix,
``numpy.linalg.LinAlgError``, raised from a kernel) does not stop the study: the
error, naming the run's parameters, goes to the log and to the terminal, and a small marker
file (the run's scalar coordinates, attribute ``failed = 1`` and the message) takes the place
of the run, so that the summary shows this point as missing.
"""

import time

from _job import SWEPT, job_log, label, remove_stale, set_threads

sm = snakemake  # noqa: F821  (injected by Snakemake)


def failed_marker(point, message, cfg):
    import xarray as xr

    import simcore

    attrs = {
        "Conventions": "CF-1.8",
        "title": "failed run of the bearing study",
        "source": f"bearingsim {simcore.__version__}",
        "failed": 1,
        "error": message,
    }
    for section in ("model", "solver"):
        for key, value in cfg[section].items():
            attrs[f"{section}.{key}"] = int(value) if isinstance(value, bool) else value
    return xr.Dataset(coords={key: float(point[key]) for key in SWEPT}, attrs=attrs)


with job_log(sm.log[0]) as terminal:
    n_threads = set_threads(sm.threads)
    remove_stale(sm.output)
    from numpy.linalg import LinAlgError

    import simcore

    for point, raw, path in zip(sm.params.points, sm.params.configs, sm.output, strict=True):
        cfg = simcore.validate_config(raw)
        start = time.perf_counter()
        try:
            ds = simcore.run(cfg)
        except (simcore.SolverError, LinAlgError) as exc:  # numerical failure of this run
            message = f"run {label(point)} failed: {type(exc).__name__}: {exc}"
            print(f"FAILED: {message}", flush=True)
            print(f"WARNING: {message} -> recorded as missing in {path}", file=terminal)
            ds = failed_marker(point, message, cfg)
        simcore.write_netcdf(ds, path)
        print(f"{label(point)}: {time.perf_counter() - start:.2f} s "
              f"(numba threads: {n_threads}) -> {path}", flush=True)
