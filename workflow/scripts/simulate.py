"""Job of rule ``simulate``: the runs of one batch -> their run files and impact tables (one of
each per run, ``results/runs/``, ``results/impacts/`` for the nonsmooth model and
``results/runs_compliant/``, ``results/impacts_compliant/`` for the compliant twin), then the
batch's marker ``results/.batches/<batch>.json`` (the job's output, written last).

Each run is simulated, its impact table (filter, Flores forces, compliant zooms of the largest
impacts of a nonsmooth run) is made from the run in memory, at full precision
(:func:`analysis.study_tables.impact_table`) and written, then the run file (its ``study.keep``
variables); both carry the study's coordinates and the attribute ``study_fingerprint``. A run
file on disk thus always has its table. The process start, the imports and the Numba cache
load are paid once per batch.

A run whose two files are in place, open and carry its fingerprint
(:func:`simcore.study.plan.fingerprint`) is not made again (a killed, repaired or regrouped
study redoes only what is missing or changed), unless ``BEARINGSIM_STUDY_REDO`` is set (the
workflow sets it under ``--forceall`` or ``--forcerun simulate``). A kept run whose settings
only the summary reads changed gets them in its files, with its table's summary numbers made
again from the run file (:func:`analysis.study_tables.refresh_summary_settings`).

A run whose solver does not converge (``simcore.SolverError``, or a singular matrix,
``numpy.linalg.LinAlgError``, raised from a kernel) does not stop the study: the error, naming
the run's parameters, goes to the log and to the terminal, and a small marker file (the run's
coordinates, attribute ``failed = 1`` and the message) takes the place of the run, so that the
summary shows this point as missing; its impact table is empty, with attribute ``failed = 1``.

The terminal gets one line per batch; the details of every run go to the job's simulate log,
those of every impact table to its impacts log. The simulate log ends with a ``TIMING`` line
(process start, imports, Numba load, integration per model, files, extraction, zooms), which
``benchmarks/bench_study.py`` sums into the study's breakdown.
"""

import time

script_start = time.time()

import json  # noqa: E402
import os  # noqa: E402
from pathlib import Path  # noqa: E402

from _job import (  # noqa: E402
    job_log,
    label,
    process_start_time,
    remove_stale,
    set_threads,
    timing_line,
)

sm = snakemake  # noqa: F821  (injected by Snakemake)


def write_marker(path, runs):
    """The batch's marker: its runs' files and fingerprints, written atomically."""
    from simcore.io import replacing

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    done = [{key: run[key] for key in ("run", "table", "model", "fingerprint")} for run in runs]
    with replacing(path) as tmp, open(tmp, "w") as fh:
        json.dump({"runs": done}, fh, indent=1)


open(sm.log.impacts, "w").close()  # a new impacts log; each table appends its lines
with job_log(sm.log.simulate) as terminal:
    batch_start = time.perf_counter()
    n_threads = set_threads(sm.threads)
    remove_stale([run[kind] for run in sm.params.runs for kind in ("run", "table")])
    from numpy.linalg import LinAlgError

    import simcore
    from analysis.study_tables import impact_table, refresh_summary_settings
    from simcore.io import failed_run_dataset, study_coords
    from simcore.study.repair import finished

    imported = time.time()
    integration = {"nonsmooth": 0.0, "compliant": 0.0}
    steps = {"nonsmooth": 0, "compliant": 0}
    loading = tabulating = writing_runs = writing_tables = 0.0
    stages = {"extract": 0.0, "zoom": 0.0}
    n_failed = n_skipped = n_zooms = 0
    redo = bool(os.environ.get("BEARINGSIM_STUDY_REDO"))
    for run in sm.params.runs:
        point = {k: v for k, v in run["coords"].items() if k != "model.contact_model"}
        where = f"{label(point)} ({run['model']})"
        if not redo and finished(run["run"], run["table"], run["fingerprint"]):
            # (a setting only the summary reads may have changed: not in the fingerprint)
            updated = refresh_summary_settings(run["run"], run["table"], run["config"])
            print(f"{where}: up to date, kept"
                  f"{' (summary settings updated)' if updated else ''} -> {run['run']}",
                  flush=True)
            n_skipped += 1
            continue
        cfg = simcore.validate_config(run["config"])
        start_run = time.perf_counter()
        try:
            ds = simcore.run(cfg)
            integration[run["model"]] += ds.attrs["wall_time_s"]
            # (an adaptive run counts the steps it took, in every try its wall time counts)
            steps[run["model"]] += int(ds.attrs.get(
                "n_steps_all_tries", round(cfg["solver"]["t_end"] / cfg["solver"]["dt"])))
            loading += ds.attrs["compile_time_s"]
        except (simcore.SolverError, LinAlgError) as exc:  # numerical failure of this run
            message = f"run {label(point)} failed ({run['model']} model): " \
                      f"{type(exc).__name__}: {exc}"
            print(f"FAILED: {message}", flush=True)
            print(f"WARNING: {message} -> recorded as missing in {run['run']}", file=terminal)
            ds = failed_run_dataset(cfg, message)
            n_failed += 1
        ds = study_coords(ds, run["coords"], sm.params.axes)
        ds.attrs["study_fingerprint"] = run["fingerprint"]
        simulated_at = time.perf_counter()
        # the table first, the run file last: a run file on disk always has its table
        with job_log(sm.log.impacts, mode="a"):
            start = time.perf_counter()
            settings = run["config"]["analysis"]
            impacts = impact_table(ds, settings, run["coords"], source=run["run"],
                                   timings=stages)
            impacts = study_coords(impacts, run["coords"], sm.params.axes, length_one=False)
            impacts.attrs["study_fingerprint"] = run["fingerprint"]
            n_zooms += int(impacts["F_max_zoom"].notnull().sum()) if "F_max_zoom" in impacts \
                else 0
            if impacts.attrs["failed"]:
                print(f"{where}: failed run, empty impact table", flush=True)
            else:
                print(f"{where}: {impacts.sizes.get('impact', 0)} impacts, "
                      f"{time.perf_counter() - start:.2f} s -> {run['table']}", flush=True)
            written = time.perf_counter()
            simcore.write_netcdf(impacts, run["table"])
            writing_tables += time.perf_counter() - written
            tabulating += time.perf_counter() - start
        written = time.perf_counter()
        simcore.write_netcdf(ds, run["run"], keep=run["keep"])  # study.keep
        writing_runs += time.perf_counter() - written
        print(f"{where}: {simulated_at - start_run:.2f} s "
              f"(numba threads: {n_threads}) -> {run['run']}", flush=True)
    write_marker(sm.output[0], sm.params.runs)
    total = time.perf_counter() - batch_start
    simulated = sum(integration.values())
    failed = f", {n_failed} FAILED" if n_failed else ""
    kept = f", {n_skipped} up to date" if n_skipped else ""
    print(f"impact tables (filter, forces, zooms): {tabulating:.1f} s", flush=True)
    print(timing_line(process_start=process_start_time(), script_start=script_start,
                      imported=imported, end=time.time(), cpu=time.process_time(),
                      runs=len(sm.params.runs),
                      skipped=n_skipped, numba_load=loading, integration=simulated,
                      integration_nonsmooth=integration["nonsmooth"],
                      integration_compliant=integration["compliant"],
                      steps_nonsmooth=steps["nonsmooth"], steps_compliant=steps["compliant"],
                      zooms=n_zooms,
                      run_other=total - (imported - script_start) - loading - simulated
                      - writing_runs - tabulating,
                      extract=stages["extract"], zoom=stages["zoom"],
                      write_runs=writing_runs, write_tables=writing_tables,
                      table_other=tabulating - writing_tables - sum(stages.values())),
          flush=True)
    print(f"simulated batch {sm.wildcards.batch}: {len(sm.params.runs)} run(s) in {total:.1f} s "
          f"(integration {simulated:.1f} s, Numba load {loading:.1f} s){kept}{failed}",
          file=terminal)
