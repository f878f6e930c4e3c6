"""Job of rule ``summarize``: all runs and impact tables -> results/summary.nc."""

import time

script_start = time.time()

from _job import job_log, process_start_time, remove_stale, timing_line  # noqa: E402

sm = snakemake  # noqa: F821  (injected by Snakemake)

with job_log(sm.log[0]):
    remove_stale(sm.output)
    import simcore
    from analysis.summary import summarize

    imported = time.time()

    settings = dict(sm.params.analysis)
    summary = summarize(list(sm.input.runs), list(sm.input.impacts),
                        scheduler=sm.params.scheduler, num_workers=sm.threads,
                        settle=settings["settle"], force_levels=settings["force_levels"],
                        settings=settings)
    if sm.params.revolutions is not None:
        summary.attrs["study_revolutions"] = float(sm.params.revolutions)
    simcore.write_netcdf(summary, sm.output[0])
    n_failed = int(summary["failed"].sum())
    print(f"wrote {sm.output[0]}: {dict(summary.sizes)}, {n_failed} failed run(s)", flush=True)
    print(timing_line(process_start=process_start_time(), script_start=script_start,
                      imported=imported, end=time.time()), flush=True)
