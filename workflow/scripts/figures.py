"""Job of rule ``figures``: the study's figures, with the reference run's figures (drawn earlier
by rule ``reference_figures``) moved in -> results/figures/.

The figures are drawn into a hidden folder next to the target and renamed into place at the
end, so that results/figures/ never holds a half-drawn set. With two or more threads the
study's heat maps are shared by forked processes, one quantity at a time; the heat maps'
axes, panels and fixed values follow ``study.figure_axes`` and ``study.figure_fixed``.
"""

import time

script_start = time.time()

import multiprocessing  # noqa: E402
import os  # noqa: E402
import shutil  # noqa: E402
from pathlib import Path  # noqa: E402

from _job import folder_in_place, job_log, process_start_time, timing_line  # noqa: E402

sm = snakemake  # noqa: F821  (injected by Snakemake)
os.environ.setdefault("MPLBACKEND", "Agg")

#: the study's heat maps are drawn in this many parts (one quantity each with the defaults)
STUDY_PARTS = 8


def draw(part):
    """Draw one part of the study's heat maps into the hidden folder; return the paths."""
    return list(plot_study(summary, tmp, (part, STUDY_PARTS), figure_axes=sm.params.figure_axes,
                           figure_fixed=dict(sm.params.figure_fixed),
                           reference=dict(sm.params.reference_coords)))


with job_log(sm.log[0]):
    import xarray as xr

    from analysis.figures import plot_study
    from analysis.summary import summary_table

    imported = time.time()
    with folder_in_place(sm.output[0]) as tmp:
        with xr.open_dataset(sm.input.summary) as summary:
            summary = summary.load()
        workers = max(1, int(sm.threads))
        if workers > 1:
            with multiprocessing.get_context("fork").Pool(workers) as pool:
                written = [p for paths in pool.map(draw, range(STUDY_PARTS), chunksize=1)
                           for p in paths]
        else:
            written = [p for part in range(STUDY_PARTS) for p in draw(part)]
        summary_table(summary).to_csv(tmp / "summary_table.csv", index=False)
        for png in sorted(Path(sm.input.reference).glob("*.png")):  # the reference run's
            shutil.copy2(png, tmp / png.name)
            written.append(tmp / png.name)
        print("figures:", ", ".join(Path(p).name for p in written), flush=True)
    print(timing_line(process_start=process_start_time(), script_start=script_start,
                      imported=imported, end=time.time()), flush=True)
