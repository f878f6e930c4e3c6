"""Job of rule ``summarize``: the runs and impact tables of every model -> results/summary.nc.

The job gets the files per contact model (``params.runs``, ``params.impacts``: ``{model:
[paths]}``, the same grid points in the same order for each model) and the study's axes
(``params.axes``, coordinate names in order; every file also carries them as its attribute
``study_axes`` and as scalar coordinates, with the contact ``model``).

Where :func:`analysis.summary.summarize` takes the files of every model itself (a ``models``
parameter) it is called once. Otherwise each model's files are summarised apart, in groups of
the grid points that share the values of the axes beyond the paper's four (each group a grid
over those four), and the parts are joined here: the axes as dimensions (a category as its int8
code, as in the run files), and a dimension ``model`` (0 nonsmooth, 1 compliant, CF
``flag_values``/``flag_meanings``).
"""

import time

script_start = time.time()

import inspect  # noqa: E402

from _job import job_log, process_start_time, remove_stale, timing_line  # noqa: E402

sm = snakemake  # noqa: F821  (injected by Snakemake)


def read_coords(path, names):
    """The values of the coordinates ``names`` stored in a file (netCDF4 alone: fast)."""
    import netCDF4
    import numpy as np

    with netCDF4.Dataset(str(path)) as nc:
        return tuple(np.asarray(nc.variables[name][...]).reshape(-1)[0].item() for name in names)


def summarize_grid(runs, tables, common):
    """One model's files -> its summary over every axis of the study."""
    import xarray as xr

    from simcore.config.parameters import parameter
    from simcore.io import BASE_PARAMETERS, parameter_coords

    extra = [name for name in sm.params.axes if name not in BASE_PARAMETERS]
    groups = {}
    for run, table in zip(runs, tables, strict=True):
        key = read_coords(table, extra) if extra else ()
        groups.setdefault(key, ([], []))
        groups[key][0].append(run)
        groups[key][1].append(table)
    parts = []
    for key, (group_runs, group_tables) in groups.items():
        part = summarize(group_runs, group_tables, **common)
        if extra:
            coords = {}
            for name, code in zip(extra, key, strict=True):
                param = parameter(name)
                value = param.categories[int(code)] if param.kind == "category" else code
                coords.update(parameter_coords({name: value}))
            part = part.expand_dims({name: 1 for name in extra}).assign_coords(
                {name: (dims, data, attrs) for name, (dims, data, attrs) in coords.items()})
        parts.append(part)
    out = parts[0] if len(parts) == 1 else xr.combine_by_coords(parts, combine_attrs="override")
    order = [name for name in sm.params.axes if name in out.dims]
    return out.transpose(*order, ...)


with job_log(sm.log[0]):
    remove_stale(sm.output)
    import numpy as np
    import xarray as xr

    import simcore
    from analysis.summary import summarize
    from simcore.io import parameter_coords

    imported = time.time()

    settings = dict(sm.params.analysis)
    common = dict(scheduler=sm.params.scheduler, num_workers=sm.threads,
                  settle=settings["settle"], force_levels=settings["force_levels"],
                  settings=settings)
    models = list(sm.params.runs)
    if "models" in inspect.signature(summarize).parameters:
        summary = summarize(dict(sm.params.runs), dict(sm.params.impacts), models=models,
                            axes=list(sm.params.axes), **common)
    else:
        per_model = [summarize_grid(sm.params.runs[m], sm.params.impacts[m], common)
                     for m in models]
        model_coord = parameter_coords({"model.contact_model": models[0]})["model"]
        codes = [int(parameter_coords({"model.contact_model": m})["model"][1][0])
                 for m in models]
        summary = xr.concat(per_model, dim="model", combine_attrs="override")
        summary = summary.assign_coords(
            model=("model", np.array(codes, dtype=np.int8), model_coord[2]))
        summary["model"].encoding["_FillValue"] = None
    summary.attrs["study_axes"] = " ".join(sm.params.axes)
    if sm.params.revolutions is not None:
        summary.attrs["study_revolutions"] = float(sm.params.revolutions)
    simcore.write_netcdf(summary, sm.output[0])
    n_failed = int(summary["failed"].sum())
    print(f"wrote {sm.output[0]}: {dict(summary.sizes)}, {n_failed} failed run(s)", flush=True)
    print(timing_line(process_start=process_start_time(), script_start=script_start,
                      imported=imported, end=time.time()), flush=True)
