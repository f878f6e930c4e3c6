"""Job of rule ``summarize``: all runs and impact tables -> results/summary.nc."""

from _job import job_log, remove_stale

sm = snakemake  # noqa: F821  (injected by Snakemake)

with job_log(sm.log[0]):
    remove_stale(sm.output)
    import simcore
    from analysis.summary import summarize

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
