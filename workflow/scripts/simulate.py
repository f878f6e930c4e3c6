"""Job of rule ``simulate``: the runs of one batch -> results/runs/<params>.nc, one per run.

A run whose solver does not converge (``simcore.SolverError``, or a singular matrix,
``numpy.linalg.LinAlgError``, raised from a kernel) does not stop the study: the
error, naming the run's parameters, goes to the log and to the terminal, and a small marker
file (the run's parameter coordinates, attribute ``failed = 1`` and the message) takes the place
of the run, so that the summary shows this point as missing.

The terminal gets one line per batch; the details of every run go to the job's log.
"""

import time

from _job import batch_label, job_log, label, remove_stale, set_threads

sm = snakemake  # noqa: F821  (injected by Snakemake)

with job_log(sm.log[0]) as terminal:
    batch_start = time.perf_counter()
    n_threads = set_threads(sm.threads)
    remove_stale(sm.output)
    from numpy.linalg import LinAlgError

    import simcore
    from simcore.io import failed_run_dataset

    simulated = loading = 0.0
    n_failed = 0
    for point, raw, path in zip(sm.params.points, sm.params.configs, sm.output, strict=True):
        cfg = simcore.validate_config(raw)
        start = time.perf_counter()
        try:
            ds = simcore.run(cfg)
            simulated += ds.attrs["wall_time_s"]
            loading += ds.attrs["compile_time_s"]
        except (simcore.SolverError, LinAlgError) as exc:  # numerical failure of this run
            message = f"run {label(point)} failed: {type(exc).__name__}: {exc}"
            print(f"FAILED: {message}", flush=True)
            print(f"WARNING: {message} -> recorded as missing in {path}", file=terminal)
            ds = failed_run_dataset(cfg, message)
            n_failed += 1
        simcore.write_netcdf(ds, path, keep=sm.params.keep)  # study.keep
        print(f"{label(point)}: {time.perf_counter() - start:.2f} s "
              f"(numba threads: {n_threads}) -> {path}", flush=True)
    total = time.perf_counter() - batch_start
    failed = f", {n_failed} FAILED" if n_failed else ""
    print(f"simulated {batch_label(sm.wildcards)}: {len(sm.output)} run(s) in {total:.1f} s "
          f"(integration {simulated:.1f} s, Numba load {loading:.1f} s){failed}", file=terminal)
