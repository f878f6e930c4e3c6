"""Job of rule ``impacts``: filter and Flores forces of the runs of one batch.

results/runs/<params>.nc -> results/impacts/<params>.nc, one table per run; a failed run gives
an empty table with attribute ``failed = 1``.
"""

import time

from _job import SWEPT, job_log, label, remove_stale, set_threads

sm = snakemake  # noqa: F821  (injected by Snakemake)

with job_log(sm.log[0]):
    set_threads(sm.threads)
    remove_stale(sm.output)
    import xarray as xr

    import analysis
    import simcore
    import simcore.io

    settings = sm.params.analysis
    for source, path in zip(sm.input.runs, sm.output, strict=True):
        start = time.perf_counter()
        with xr.open_dataset(source) as run:
            run = run.load()
        point = {key: run[key].values.item() for key in SWEPT}  # length-1 coordinates
        coords = simcore.io.parameter_coords(point, length_one=False)  # with units
        if int(run.attrs.get("failed", 0)):
            print(f"{label(point)}: failed run, empty impact table", flush=True)
            impacts = xr.Dataset(coords=coords, attrs={
                "Conventions": simcore.io.CONVENTIONS,
                "title": "impacts of a failed run (empty)",
                "history": simcore.io.history_line(f"impact table of the failed run {source}"),
                "failed": 1, "error": run.attrs.get("error", "")})
        else:
            impacts = analysis.extract_impacts(
                run,
                zero_tol=settings["zero_tol"],
                zero_floor=settings["zero_floor"],
                r_eff=settings["r_eff"],
                v_min=settings["v_min"],
            )
            if settings.get("zoom_top", 0) > 0:
                from analysis.zoom import add_zoom_forces

                impacts = add_zoom_forces(run, impacts, zoom_top=settings["zoom_top"])
            impacts = impacts.assign_coords(coords)
            impacts.attrs.setdefault("failed", 0)
            print(f"{label(point)}: {impacts.sizes.get('impact', 0)} impacts, "
                  f"{time.perf_counter() - start:.2f} s -> {path}", flush=True)
        simcore.write_netcdf(impacts, path)
