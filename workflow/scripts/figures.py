"""Job of rule ``figures``: the study's figures, with the reference run's figures (drawn earlier
by rule ``reference_figures``) moved in -> results/figures/.

The figures are drawn into a hidden folder next to the target and renamed into place at the
end, so that results/figures/ never holds a half-drawn set. With two or more threads the
study's heat maps are shared by forked processes, one quantity at a time.
"""

import time

script_start = time.time()

import inspect  # noqa: E402
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
    """Draw one part of the study's heat maps into the hidden folder; return the paths.

    Where :func:`analysis.figures.plot_study` does not draw the summary's ``model`` dimension
    itself, each model's heat maps are drawn apart: the nonsmooth ones under their usual
    names, the others with the model's name appended (``study_peak_force_outer_compliant``).
    """
    if "model" not in summary.dims or "model" in inspect.signature(plot_study).parameters:
        return list(plot_study(summary, tmp, (part, STUDY_PARTS), **options))
    meanings = summary["model"].attrs["flag_meanings"].split()
    paths = []
    for code in summary["model"].values:
        name = meanings[int(code)]
        one = summary.sel(model=code, drop=True)
        if name == "nonsmooth":
            paths += list(plot_study(one, tmp, (part, STUDY_PARTS), **options))
            continue
        sub = tmp / f".{name}.{part}"
        sub.mkdir()
        for path in plot_study(one, sub, (part, STUDY_PARTS), **options):
            path = Path(path)
            target = tmp / f"{path.stem}_{name}{path.suffix}"
            path.replace(target)
            paths.append(target)
        shutil.rmtree(sub)
    return paths


with job_log(sm.log[0]):
    import xarray as xr

    from analysis.figures import plot_study
    from analysis.summary import summary_table

    imported = time.time()
    # study.figure_axes (coordinate names, checked by the workflow), where plot_study takes it
    options = {}
    if "figure_axes" in inspect.signature(plot_study).parameters:
        options["figure_axes"] = sm.params.figure_axes
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
        table_of = summary.sel(model=summary["model"].values[0], drop=True) if (
            "model" in summary.dims and "model" not in inspect.signature(
                summary_table).parameters) else summary
        summary_table(table_of).to_csv(tmp / "summary_table.csv", index=False)
        for png in sorted(Path(sm.input.reference).glob("*.png")):  # the reference run's
            shutil.copy2(png, tmp / png.name)
            written.append(tmp / png.name)
        print("figures:", ", ".join(Path(p).name for p in written), flush=True)
    print(timing_line(process_start=process_start_time(), script_start=script_start,
                      imported=imported, end=time.time()), flush=True)
