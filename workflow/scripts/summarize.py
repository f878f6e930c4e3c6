"""Job of rule ``summarize``: the runs and impact tables of every model -> results/summary.nc.

The job gets the files per contact model (``params.runs``, ``params.impacts``: ``{model:
[paths]}``, the same grid points in the same order for each model) and the study's axes
(``params.axes``, coordinate names in order); :func:`analysis.summary.summarize` joins them
into one dataset with the axes and ``model`` as dimensions.
"""

import time

script_start = time.time()

from _job import job_log, process_start_time, remove_stale, timing_line  # noqa: E402

sm = snakemake  # noqa: F821  (injected by Snakemake)

with job_log(sm.log[0]):
    remove_stale(sm.output)
    import simcore
    from analysis.figures import REFERENCE_ATTRIBUTE, reference_attribute
    from analysis.summary import summarize

    imported = time.time()

    settings = dict(sm.params.analysis)
    summary = summarize(dict(sm.params.runs), dict(sm.params.impacts),
                        scheduler=sm.params.scheduler, num_workers=sm.threads,
                        settle=settings["settle"], force_levels=settings["force_levels"],
                        settings=settings, models=list(sm.params.runs),
                        axes=list(sm.params.axes), own_settings=list(sm.params.own_settings))
    summary.attrs["study_axes"] = " ".join(sm.params.axes)
    summary.attrs[REFERENCE_ATTRIBUTE] = reference_attribute(dict(sm.params.reference), summary)
    from simcore.io import setting_attribute

    for key, value in sm.params.fixed_model.items():  # what every grid point shares
        summary.attrs[f"model_{key}"] = setting_attribute(value)
    if sm.params.revolutions is not None:
        summary.attrs["study_revolutions"] = float(sm.params.revolutions)
    simcore.write_netcdf(summary, sm.output[0])
    n_failed = int(summary["failed"].sum())
    print(f"wrote {sm.output[0]}: {dict(summary.sizes)}, {n_failed} failed run(s)", flush=True)
    print(timing_line(process_start=process_start_time(), script_start=script_start,
                      imported=imported, end=time.time()), flush=True)
