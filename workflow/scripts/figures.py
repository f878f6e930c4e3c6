"""Job of rule ``figures``: figures of the reference run and of the study -> results/figures/.

The figures are drawn into a hidden folder next to the target and renamed into place at the
end, so that results/figures/ never holds a half-drawn set. With two or more threads the
drawing is shared by forked processes: the reference run's two groups of figures (the slowest
pieces) first, then the study's heat maps one quantity at a time, so that the processes finish
together.
"""

import time

script_start = time.time()

import multiprocessing  # noqa: E402
import os  # noqa: E402
import shutil  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

from _job import job_log, label, process_start_time, remove_stale, timing_line  # noqa: E402

sm = snakemake  # noqa: F821  (injected by Snakemake)
os.environ.setdefault("MPLBACKEND", "Agg")

#: the study's heat maps are drawn in this many parts (one quantity each with the defaults)
STUDY_PARTS = 8


def draw(task):
    """Draw one piece of the figure set into the hidden folder; return the paths written."""
    kind, arg = task
    settings = sm.params.analysis
    if kind == "study":
        return list(plot_study(summary, tmp, (arg, STUDY_PARTS)))
    if reference is None:
        return []
    run, imp = reference
    if kind == "run":
        return list(plot_run(run, imp, tmp, settings["zero_tol"], settings["zero_floor"],
                             prefix="reference"))
    return list(plot_reference(run, imp, tmp, settle=settings["settle"],
                               force_levels=settings["force_levels"],
                               zero_tol=settings["zero_tol"], zero_floor=settings["zero_floor"],
                               prefix="reference"))


with job_log(sm.log[0]):
    import xarray as xr

    from analysis.figures import plot_reference, plot_run, plot_study
    from analysis.summary import summary_table

    imported = time.time()

    target = Path(sm.output[0])
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale([target])
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    tmp.chmod(0o755)
    try:
        with xr.open_dataset(sm.input.summary) as summary:
            summary = summary.load()
        with xr.open_dataset(sm.input.run) as run, xr.open_dataset(sm.input.impacts) as imp:
            if int(run.attrs.get("failed", 0)):
                print(f"reference run {label(sm.params.reference)} failed: no run figures")
                reference = None
            else:
                reference = (run.load(), imp.load())
        # the slowest pieces first (reference figures ~2-3 s, a study quantity ~1 s)
        tasks = [("reference", None), ("run", None)] + [("study", i)
                                                         for i in range(STUDY_PARTS)]
        workers = max(1, int(sm.threads))
        if workers > 1:
            with multiprocessing.get_context("fork").Pool(workers) as pool:
                written = [p for paths in pool.map(draw, tasks, chunksize=1) for p in paths]
        else:
            written = [p for task in tasks for p in draw(task)]
        summary_table(summary).to_csv(tmp / "summary_table.csv", index=False)
        print("figures:", ", ".join(Path(p).name for p in written), flush=True)
        print(timing_line(process_start=process_start_time(), script_start=script_start,
                          imported=imported, end=time.time()), flush=True)
        if target.exists():
            shutil.rmtree(target)
        os.replace(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
