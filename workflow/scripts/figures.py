"""Job of rule ``figures``: figures of the reference run and of the study -> results/figures/.

The figures are drawn into a hidden folder next to the target and renamed into place at the
end, so that results/figures/ never holds a half-drawn set.
"""

import os
import shutil
import tempfile
from pathlib import Path

from _job import job_log, label, remove_stale

sm = snakemake  # noqa: F821  (injected by Snakemake)
os.environ.setdefault("MPLBACKEND", "Agg")

with job_log(sm.log[0]):
    import xarray as xr

    from analysis.figures import plot_run, plot_study

    settings = sm.params.analysis
    target = Path(sm.output[0])
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale([target])
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    tmp.chmod(0o755)
    try:
        with xr.open_dataset(sm.input.summary) as summary:
            # plot_study draws against every dimension but rank: leave out the iteration
            # statistics (dimension stage), which it does not plot.
            study = summary.load().drop_dims([d for d in ("stage",) if d in summary.dims])
            written = list(plot_study(study, tmp))
        with xr.open_dataset(sm.input.run) as run, xr.open_dataset(sm.input.impacts) as imp:
            if int(run.attrs.get("failed", 0)):
                print(f"reference run {label(sm.params.reference)} failed: no run figures")
            else:
                written += plot_run(run.load(), imp.load(), tmp, settings["zero_tol"],
                                    settings["zero_floor"], prefix="reference")
        print("figures:", ", ".join(Path(p).name for p in written), flush=True)
        if target.exists():
            shutil.rmtree(target)
        os.replace(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
