"""The impact table of one run of a study, as the study's simulate jobs write it: the filter
and Flores forces (:func:`analysis.extract_impacts`), the compliant zooms of the largest impacts
(:func:`analysis.zoom.add_zoom_forces`) and the run's swept parameters as coordinates; an empty
table for a failed run.

The study computes it in the process that simulated the run, from the run in memory (every
variable at full precision), right after writing the run file: the process start, the imports
and the Numba cache are paid once per batch, not once for the runs and once for the tables. The
table also carries its point's summary numbers (attributes ``summary_*``), so that the summary
of the study reads the small tables only.
"""

from __future__ import annotations

import time

import xarray as xr

__all__ = ["impact_table"]


def impact_table(run_ds: xr.Dataset, settings: dict, point: dict, source: str = "",
                 timings: dict | None = None) -> xr.Dataset:
    """Impact table of one run of a study.

    Parameters
    ----------
    run_ds : xarray.Dataset
        The run (from :func:`simcore.run`, or a run file), or the marker dataset of a failed
        run (attribute ``failed = 1``, :func:`simcore.io.failed_run_dataset`).
    settings : dict
        The validated ``analysis`` section (``zero_tol``, ``zero_floor``, ``r_eff``, ``v_min``,
        ``zoom_top``, ``zoom_steps_per_contact``).
    point : dict
        The run's swept parameters (``clearance`` [m], ``mu`` [-], ``omega0`` [rad/s],
        ``e_N`` [-]), stored as scalar coordinates with units.
    source : str
        The run file's path, for the history of a failed run's table.
    timings : dict, optional
        If given, the seconds spent are added to its keys ``extract`` (filter and Flores forces)
        and ``zoom`` (the compliant zooms) [s].

    Returns
    -------
    xarray.Dataset
        The impact table with ``F_max_zoom``, ``contact_time_zoom`` and ``dt_zoom`` where
        ``analysis.zoom_top`` > 0, attribute ``failed`` (0 or 1); for a failed run an empty
        table carrying the run's ``error``. Where ``settings`` has ``settle`` and
        ``force_levels``, also the point's summary numbers as attributes ``summary_*``
        (:func:`analysis.summary.point_numbers`), which :func:`analysis.summary.summarize`
        reads instead of the run file.
    """
    import simcore.io

    from .impacts import extract_impacts
    from .summary import point_numbers

    coords = simcore.io.parameter_coords(point, length_one=False)  # with units
    summarised = "settle" in settings and "force_levels" in settings
    if int(run_ds.attrs.get("failed", 0)):
        table = xr.Dataset(coords=coords, attrs={
            "Conventions": simcore.io.CONVENTIONS,
            "title": "impacts of a failed run (empty)",
            "history": simcore.io.history_line(f"impact table of the failed run {source}"),
            "failed": 1, "error": run_ds.attrs.get("error", "")})
        if summarised:
            table.attrs.update(point_numbers(run_ds, table, settings["settle"],
                                             settings["force_levels"]))
        return table
    timings = {} if timings is None else timings
    start = time.perf_counter()
    impacts = extract_impacts(run_ds, zero_tol=settings["zero_tol"],
                              zero_floor=settings["zero_floor"], r_eff=settings["r_eff"],
                              v_min=settings["v_min"])
    extracted = time.perf_counter()
    timings["extract"] = timings.get("extract", 0.0) + extracted - start
    if settings.get("zoom_top", 0) > 0:
        from .zoom import STEPS_PER_CONTACT, add_zoom_forces

        impacts = add_zoom_forces(run_ds, impacts, zoom_top=settings["zoom_top"],
                                  steps_per_contact=settings.get("zoom_steps_per_contact",
                                                                 STEPS_PER_CONTACT))
    timings["zoom"] = timings.get("zoom", 0.0) + time.perf_counter() - extracted
    impacts = impacts.assign_coords(coords)
    impacts.attrs.setdefault("failed", 0)
    if summarised:  # the point's summary numbers: the summary then reads no run file
        impacts.attrs.update(point_numbers(run_ds, impacts, settings["settle"],
                                           settings["force_levels"]))
    return impacts
