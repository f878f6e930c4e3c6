"""The table of one run of a study, as the study's simulate jobs write it; an empty table for a
failed run.

* nonsmooth run: the impact table (filter and Flores forces, :func:`analysis.extract_impacts`)
  with the compliant zooms of the impacts the summary reads (:func:`analysis.zoom.
  add_zoom_forces`: the largest forces of the steady window and of the start-up, flagged
  ``method_disagrees`` where the zoom contradicts them);
* compliant run: its contact episodes (:func:`analysis.episodes.contact_episodes`).

The run's swept parameters are the table's scalar coordinates. The study computes the table in
the process that simulated the run, from the run in memory (every variable at full precision),
right after writing the run file: the process start, the imports and the Numba cache are paid
once per batch. The table also carries the run's summary numbers (attributes ``summary_*``,
:func:`analysis.summary.point_numbers`), so that the summary of the study reads the small
tables only.
"""

from __future__ import annotations

import time

import numpy as np
import xarray as xr

__all__ = ["impact_table", "refresh_summary_settings"]


def _failed_table(run_ds: xr.Dataset, coords: dict, source: str) -> xr.Dataset:
    import simcore.io

    return xr.Dataset(coords=coords, attrs={
        "Conventions": simcore.io.CONVENTIONS,
        "title": "impacts of a failed run (empty)",
        "history": simcore.io.history_line(f"impact table of the failed run {source}"),
        "failed": 1, "error": run_ds.attrs.get("error", "")})


def _nonsmooth_table(run_ds: xr.Dataset, settings: dict, timings: dict) -> xr.Dataset:
    """Impacts, Flores forces and the zooms of the impacts the summary reads."""
    from .impacts import extract_impacts
    from .summary import SteadyWindow

    start = time.perf_counter()
    impacts = extract_impacts(run_ds, zero_tol=settings["zero_tol"],
                              zero_floor=settings["zero_floor"], r_eff=settings["r_eff"],
                              v_min=settings["v_min"],
                              groove_conformity=settings.get("groove_conformity") or None,
                              contact_long_ratio=settings.get("contact_long_ratio", 10.0))
    extracted = time.perf_counter()
    timings["extract"] = timings.get("extract", 0.0) + extracted - start
    if settings.get("zoom_top", 0) > 0:
        from .zoom import STEPS_PER_CONTACT, ZOOM_ADAPTIVE, add_zoom_forces

        window = SteadyWindow.of_run(run_ds, float(settings.get("settle", 0.0)))
        impacts = add_zoom_forces(run_ds, impacts, zoom_top=settings["zoom_top"],
                                  steps_per_contact=settings.get("zoom_steps_per_contact",
                                                                 STEPS_PER_CONTACT),
                                  settle_time=window.settle_time,
                                  method_tol=settings.get("method_tol", 0.2),
                                  adaptive=bool(settings.get("zoom_adaptive", ZOOM_ADAPTIVE)))
    timings["zoom"] = timings.get("zoom", 0.0) + time.perf_counter() - extracted
    return impacts


def _stores_numbers(settings: dict) -> bool:
    """Whether a table made with these analysis settings carries its run's summary numbers
    (settings with the steady window and the force levels, as a study's are)."""
    return "settle" in settings and "force_levels" in settings


def impact_table(run_ds: xr.Dataset, settings: dict, point: dict, source: str = "",
                 timings: dict | None = None) -> xr.Dataset:
    """Table of one run of a study (impacts of a nonsmooth run, episodes of a compliant one).

    Parameters
    ----------
    run_ds : xarray.Dataset
        The run (from :func:`simcore.run`, or a run file), or the marker dataset of a failed
        run (attribute ``failed = 1``, :func:`simcore.io.failed_run_dataset`).
    settings : dict
        The validated ``analysis`` section (``zero_tol``, ``zero_floor``, ``r_eff``, ``v_min``,
        and where present ``groove_conformity``, ``contact_long_ratio``, ``zoom_top``,
        ``zoom_steps_per_contact``, ``zoom_adaptive``, ``method_tol``, ``settle``,
        ``force_levels``).
    point : dict
        The run's swept parameters (e.g. ``clearance`` [m], ``mu`` [-], ``omega0`` [rad/s],
        ``e_N`` [-]), stored as scalar coordinates with units.
    source : str
        The run file's path: the table's attribute ``run_file`` (where given), and the
        history of a failed run's table.
    timings : dict, optional
        If given, the seconds spent are added to its keys ``extract`` (filter and Flores forces,
        or episodes) and ``zoom`` (the compliant zooms) [s].

    Returns
    -------
    xarray.Dataset
        The table with ``F_max_zoom``, ``contact_time_zoom`` and ``dt_zoom`` where
        ``analysis.zoom_top`` > 0 (nonsmooth), attribute ``failed`` (0 or 1); for a failed run
        an empty table carrying the run's ``error``. Where ``settings`` has ``settle`` and
        ``force_levels``, also the run's summary numbers as attributes ``summary_*``
        (:func:`analysis.summary.point_numbers`), which :func:`analysis.summary.summarize`
        reads instead of the run file.
    """
    import simcore.io

    from .summary import COMPLIANT, point_numbers, run_model, stored_attributes

    coords = simcore.io.parameter_coords(point, length_one=False)  # with units
    timings = {} if timings is None else timings
    if int(run_ds.attrs.get("failed", 0)):
        table = _failed_table(run_ds, coords, source)
    elif run_model(run_ds) == COMPLIANT:
        from .episodes import contact_episodes

        start = time.perf_counter()
        table = contact_episodes(run_ds, r_eff=settings.get("r_eff", "concave"),
                                 groove_conformity=settings.get("groove_conformity"))
        timings["extract"] = timings.get("extract", 0.0) + time.perf_counter() - start
    else:
        table = _nonsmooth_table(run_ds, settings, timings)
    table = table.assign_coords(coords)
    table.attrs.setdefault("failed", 0)
    if source:
        table.attrs["run_file"] = str(source)
    if _stores_numbers(settings):  # the summary reads no run file
        numbers = point_numbers(run_ds, table, settings)
        table.attrs.update(stored_attributes(numbers, settings))
    return table


def _same_attribute(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    if isinstance(a, str) or isinstance(b, str):
        return str(a) == str(b)
    a, b = np.asarray(a, dtype=float).ravel(), np.asarray(b, dtype=float).ravel()
    return a.shape == b.shape and bool(np.all(a == b))


def refresh_summary_settings(run_path, table_path, config: dict) -> bool:
    """Bring a kept run's files up to the settings that only the summary reads.

    A study keeps a run whose fingerprint matches (:func:`simcore.study.plan.fingerprint`),
    which leaves out :data:`simcore.study.plan.SUMMARY_ONLY_SETTINGS`. Where one of those
    changed, the run file's ``analysis.<key>`` attributes and the table's stored summary
    numbers (``summary_*``, :func:`analysis.summary.stored_attributes`) are of the old values:
    this sets both to ``config``'s, the numbers computed again from the run file, each file
    edited atomically (:func:`simcore.io.update_attributes`), the table first.

    Parameters
    ----------
    run_path, table_path : path
        The run file and its impact table (or contact episodes), both finished.
    config : dict
        The run's validated configuration (its ``analysis`` section).

    Returns
    -------
    bool
        True when a file was edited (False: both already of these settings).
    """
    from simcore.io import update_attributes
    from simcore.io.dataset import flat_settings
    from simcore.study.plan import SUMMARY_ONLY_SETTINGS

    from .summary import STORED, point_numbers, stored_attributes, stored_numbers

    settings = config["analysis"]
    names = [f"analysis.{key}" for key in SUMMARY_ONLY_SETTINGS]
    wanted = flat_settings({"analysis": {key: settings.get(key)
                                         for key in SUMMARY_ONLY_SETTINGS}})
    with xr.open_dataset(run_path) as run, xr.open_dataset(table_path) as table:
        run_stale = not all(_same_attribute(run.attrs.get(name), wanted.get(name))
                            for name in names)
        table_stale = (_stores_numbers(settings)
                       and stored_numbers(table.attrs, settings) is None)
        if table_stale:
            numbers = stored_attributes(point_numbers(run, table, settings), settings)
            old = [name for name in table.attrs if name.startswith(STORED)]
    if table_stale:
        update_attributes(table_path, numbers, drop=old)
    if run_stale:
        update_attributes(run_path, wanted, drop=names)
    return run_stale or table_stale
