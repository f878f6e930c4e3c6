"""Job of rule ``figures``: figures of the reference run and of the study -> results/figures/.

The figures are drawn into a hidden folder next to the target and renamed into place at the
end, so that results/figures/ never holds a half-drawn set.
"""

import multiprocessing
import os
import shutil
import tempfile
from pathlib import Path

from _job import job_log, label, remove_stale

sm = snakemake  # noqa: F821  (injected by Snakemake)
os.environ.setdefault("MPLBACKEND", "Agg")

with job_log(sm.log[0]):
    import xarray as xr

    from analysis.figures import plot_reference, plot_run, plot_study
    from analysis.summary import summary_table

    settings = sm.params.analysis
    target = Path(sm.output[0])
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale([target])
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    tmp.chmod(0o755)
    try:
        with xr.open_dataset(sm.input.summary) as summary:
            summary = summary.load()
        # the study's heat maps take most of the time: with two threads, a forked process
        # draws every other quantity while this one draws the rest and the run figures
        workers = max(1, int(sm.threads))
        pool = multiprocessing.get_context("fork").Pool(workers - 1) if workers > 1 else None
        try:
            shares = [pool.apply_async(plot_study, (summary, tmp, (i, workers)))
                      for i in range(1, workers)] if pool is not None else []
            written = list(plot_study(summary, tmp, (0, workers)))
            summary_table(summary).to_csv(tmp / "summary_table.csv", index=False)
            with xr.open_dataset(sm.input.run) as run, \
                    xr.open_dataset(sm.input.impacts) as imp:
                if int(run.attrs.get("failed", 0)):
                    print(f"reference run {label(sm.params.reference)} failed: no run figures")
                else:
                    run, imp = run.load(), imp.load()
                    written += plot_run(run, imp, tmp, settings["zero_tol"],
                                        settings["zero_floor"], prefix="reference")
                    written += plot_reference(run, imp, tmp, settle=settings["settle"],
                                              force_levels=settings["force_levels"],
                                              zero_tol=settings["zero_tol"],
                                              zero_floor=settings["zero_floor"],
                                              prefix="reference")
            for share in shares:
                written += share.get()
        finally:
            if pool is not None:
                pool.close()
                pool.join()
        print("figures:", ", ".join(Path(p).name for p in written), flush=True)
        if target.exists():
            shutil.rmtree(target)
        os.replace(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
