"""Job of rule ``reference_figures``: the figures of the reference run (the grid point nearest
to the model section) -> a temporary folder, from which the figures job moves them into
results/figures/.

It runs as soon as the reference run's batch is simulated, while the other batches still run,
so that the figures job at the end of the study (after the summary) has only the study's heat
maps left to draw. The figures are drawn into a hidden folder and renamed into place.
"""

import time

script_start = time.time()

import os  # noqa: E402
from pathlib import Path  # noqa: E402

from _job import folder_in_place, job_log, label, process_start_time, timing_line  # noqa: E402

sm = snakemake  # noqa: F821  (injected by Snakemake)
os.environ.setdefault("MPLBACKEND", "Agg")

with job_log(sm.log[0]):
    import xarray as xr

    from analysis.figures import plot_reference, plot_run

    imported = time.time()
    settings = sm.params.analysis
    with folder_in_place(sm.output[0]) as tmp:
        written = []
        with xr.open_dataset(sm.params.files["run"]) as run, \
                xr.open_dataset(sm.params.files["impacts"]) as imp:
            if int(run.attrs.get("failed", 0)):
                print(f"reference run {label(sm.params.reference)} failed: no run figures")
            else:
                run, imp = run.load(), imp.load()
                written += plot_run(run, imp, tmp, settings["zero_tol"], settings["zero_floor"],
                                    prefix="reference")
                written += plot_reference(run, imp, tmp, settle=settings["settle"],
                                          force_levels=settings["force_levels"],
                                          zero_tol=settings["zero_tol"],
                                          zero_floor=settings["zero_floor"], prefix="reference")
        print("reference figures:", ", ".join(Path(p).name for p in written), flush=True)
    print(timing_line(process_start=process_start_time(), script_start=script_start,
                      imported=imported, end=time.time()), flush=True)
