"""Job of rule ``summarize``: all runs and impact tables -> results/summary.nc."""

from _job import job_log, remove_stale

sm = snakemake  # noqa: F821  (injected by Snakemake)

with job_log(sm.log[0]):
    remove_stale(sm.output)
    import simcore
    from analysis.summary import summarize

    summary = summarize(list(sm.input.runs), list(sm.input.impacts),
                        scheduler=sm.params.scheduler, num_workers=sm.threads)
    for key, value in sm.params.analysis.items():
        summary.attrs[key] = value  # the filter's threshold goes with the counts
    simcore.write_netcdf(summary, sm.output[0])
    n_failed = int(summary["failed"].sum())
    print(f"wrote {sm.output[0]}: {dict(summary.sizes)}, {n_failed} failed run(s)", flush=True)
