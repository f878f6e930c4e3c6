"""Job of rule ``figures``: the study's figures, with the reference run's figures (drawn earlier
by rule ``reference_figures``) moved in -> results/figures/.

The figures are drawn into a hidden folder next to the target and renamed into place at the
end, so that results/figures/ never holds a half-drawn set. With two or more threads the
study's heat maps are shared by forked processes, one quantity at a time. Where
:func:`analysis.figures.plot_study` does not yet draw the ``model`` dimension or axes beyond
the paper's four, this job draws them as separate sets (:func:`_pieces`).
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


#: largest number of separate sets of heat maps the interim split below draws
MAX_SETS = 12


def _pieces(ds):
    """(suffix, summary) pieces that :func:`analysis.figures.plot_study` can draw.

    A ``plot_study`` that takes a ``model`` draws both models and any axes itself: one piece.
    An older one knows one model and the paper's four axes: each model is drawn apart (the
    nonsmooth one under the usual names, the others with the model's name appended:
    ``study_peak_force_outer_compliant``), and each value of every other axis apart
    (``study_peak_force_outer_cage_stiffness~10000.0``), at most :data:`MAX_SETS` sets.
    """
    import itertools

    if "model" in inspect.signature(plot_study).parameters:
        return [("", ds)]
    pieces = [("", ds)]
    if "model" in ds.dims:
        meanings = ds["model"].attrs["flag_meanings"].split()
        pieces = [("" if meanings[int(code)] == "nonsmooth" else f"_{meanings[int(code)]}",
                   ds.sel(model=code, drop=True)) for code in ds["model"].values]
    from simcore.io import BASE_PARAMETERS

    extra = [d for d in sm.params.axes if d not in BASE_PARAMETERS and d in ds.dims]
    if not extra:
        return pieces
    combos = list(itertools.product(*(range(ds.sizes[d]) for d in extra)))
    if len(combos) * len(pieces) > MAX_SETS:
        print(f"figures: {len(combos) * len(pieces)} sets of heat maps over "
              f"{', '.join(extra)} is more than {MAX_SETS}; drawn: the first value of each")
        combos = combos[:1]
    out = []
    for suffix, piece in pieces:
        for at in combos:
            where = dict(zip(extra, at, strict=True))
            label = "_".join(f"{d}~{piece[d].values[i]}" for d, i in where.items())
            out.append((f"{suffix}_{label}", piece.isel(where, drop=True)))
    return out


def draw(part):
    """Draw one part of the study's heat maps into the hidden folder; return the paths."""
    paths = []
    for suffix, piece in _pieces(summary):
        if not suffix:
            paths += list(plot_study(piece, tmp, (part, STUDY_PARTS), **options))
            continue
        sub = tmp / f".{part}{suffix}"
        sub.mkdir()
        for path in plot_study(piece, sub, (part, STUDY_PARTS), **options):
            path = Path(path)
            target = tmp / f"{path.stem}{suffix}{path.suffix}"
            path.replace(target)
            paths.append(target)
        shutil.rmtree(sub)
    return paths


with job_log(sm.log[0]):
    import xarray as xr

    from analysis.figures import plot_study
    from analysis.summary import summary_table

    imported = time.time()
    # study.figure_axes, study.figure_fixed and the reference point (coordinate names,
    # checked by the workflow), where plot_study takes them
    given = {"figure_axes": sm.params.figure_axes, "figure_fixed": dict(sm.params.figure_fixed),
             "reference": dict(sm.params.reference_coords)}
    options = {key: value for key, value in given.items()
               if key in inspect.signature(plot_study).parameters}
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
        table_of = summary if "model" in inspect.signature(summary_table).parameters \
            else _pieces(summary)[0][1]
        summary_table(table_of).to_csv(tmp / "summary_table.csv", index=False)
        for png in sorted(Path(sm.input.reference).glob("*.png")):  # the reference run's
            shutil.copy2(png, tmp / png.name)
            written.append(tmp / png.name)
        print("figures:", ", ".join(Path(p).name for p in written), flush=True)
    print(timing_line(process_start=process_start_time(), script_start=script_start,
                      imported=imported, end=time.time()), flush=True)
