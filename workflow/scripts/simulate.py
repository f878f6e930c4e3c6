"""Job of rule ``simulate``: the runs of one batch -> results/runs/<params>.nc, and their impact
tables -> results/impacts/<params>.nc, one of each per run, in one process.

Each run is simulated, written (``study.keep``), then its impact table (filter, Flores forces,
compliant zooms of the largest impacts) is made from the run still in memory, at full
precision (:func:`analysis.study_tables.impact_table`), and written: the process start, the
imports and the Numba cache load are paid once per batch.

A run whose solver does not converge (``simcore.SolverError``, or a singular matrix,
``numpy.linalg.LinAlgError``, raised from a kernel) does not stop the study: the
error, naming the run's parameters, goes to the log and to the terminal, and a small marker
file (the run's parameter coordinates, attribute ``failed = 1`` and the message) takes the place
of the run, so that the summary shows this point as missing; its impact table is empty, with
attribute ``failed = 1``.

The terminal gets one line per batch; the details of every run go to the job's simulate log,
those of every impact table to its impacts log. The simulate log ends with a ``TIMING`` line
(process start, imports, Numba load, integration, files, extraction, zooms), which
``benchmarks/bench_study.py`` sums into the study's breakdown.
"""

import time

script_start = time.time()

from _job import (  # noqa: E402
    batch_label,
    job_log,
    label,
    process_start_time,
    remove_stale,
    set_threads,
    timing_line,
)

sm = snakemake  # noqa: F821  (injected by Snakemake)

open(sm.log.impacts, "w").close()  # a new impacts log; each table appends its lines
with job_log(sm.log.simulate) as terminal:
    batch_start = time.perf_counter()
    n_threads = set_threads(sm.threads)
    remove_stale(list(sm.output.runs) + list(sm.output.impacts))
    from numpy.linalg import LinAlgError

    import simcore
    from analysis.study_tables import impact_table
    from simcore.io import failed_run_dataset

    imported = time.time()
    simulated = loading = tabulating = writing_runs = writing_tables = 0.0
    stages = {"extract": 0.0, "zoom": 0.0}
    n_failed = 0
    for point, raw, path, table_path in zip(sm.params.points, sm.params.configs,
                                            sm.output.runs, sm.output.impacts, strict=True):
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
        written = time.perf_counter()
        simcore.write_netcdf(ds, path, keep=sm.params.keep)  # study.keep
        writing_runs += time.perf_counter() - written
        print(f"{label(point)}: {time.perf_counter() - start:.2f} s "
              f"(numba threads: {n_threads}) -> {path}", flush=True)
        with job_log(sm.log.impacts, mode="a"):
            start = time.perf_counter()
            impacts = impact_table(ds, sm.params.analysis, point, source=path, timings=stages)
            if impacts.attrs["failed"]:
                print(f"{label(point)}: failed run, empty impact table", flush=True)
            else:
                print(f"{label(point)}: {impacts.sizes.get('impact', 0)} impacts, "
                      f"{time.perf_counter() - start:.2f} s -> {table_path}", flush=True)
            written = time.perf_counter()
            simcore.write_netcdf(impacts, table_path)
            writing_tables += time.perf_counter() - written
            tabulating += time.perf_counter() - start
    total = time.perf_counter() - batch_start
    failed = f", {n_failed} FAILED" if n_failed else ""
    print(f"impact tables (filter, forces, zooms): {tabulating:.1f} s", flush=True)
    print(timing_line(process_start=process_start_time(), script_start=script_start,
                      imported=imported, end=time.time(), runs=len(sm.output.runs),
                      numba_load=loading, integration=simulated,
                      run_other=total - (imported - script_start) - loading - simulated
                      - writing_runs - tabulating,
                      extract=stages["extract"], zoom=stages["zoom"],
                      write_runs=writing_runs, write_tables=writing_tables,
                      table_other=tabulating - writing_tables - sum(stages.values())),
          flush=True)
    print(f"simulated {batch_label(sm.wildcards)}: {len(sm.output.runs)} run(s) in {total:.1f} s "
          f"(integration {simulated:.1f} s, Numba load {loading:.1f} s){failed}", file=terminal)
