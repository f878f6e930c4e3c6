"""Contact episodes of a compliant run: the compliant model's counterpart of an impact table.

A compliant (Hertz) run writes, per output interval and contact, the largest contact force of
the interval (``F_N``). An *episode* is a maximal run of intervals in which a contact carries a
force (F_N > 0): one impact, or one stretch of persistent contact. Its force is the largest
``F_N`` of the episode, the force itself (no impulse-to-force model is involved); its contact
stresses are those of Hertz at that force (:func:`analysis.impacts.run_geometry`).

The episodes give the compliant model's counts above absolute force levels and its largest
forces (``n_above``, ``top3_force`` of the summary). Counts of episodes and counts of the
nonsmooth model's impacts do not compare one to one: the impulse filter splits a persistent
contact into many impacts on persistent contact, the compliant model keeps it as one episode.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .impacts import RACE, race_codes, race_stresses, run_geometry

__all__ = ["contact_episodes", "episode_peaks", "compliant_forces"]


def compliant_forces(run_ds: xr.Dataset) -> np.ndarray:
    """``F_N`` of a compliant run as float64 (contact, time) [N], read at the precision the run
    file stores it (float32), so that a run in memory and its file give the same numbers."""
    if "F_N" not in run_ds:
        raise ValueError("compliant run has no variable 'F_N' (add it to study.keep)")
    F = np.asarray(run_ds["F_N"].transpose("contact", "time").values)
    return F.astype(np.float32).astype(np.float64)


def episode_peaks(force: np.ndarray):
    """Episodes of positive force along the last axis of ``force`` (contact, time).

    Parameters
    ----------
    force : numpy.ndarray
        Largest force of each output interval (contact, time) [N].

    Returns
    -------
    contact, start, stop, peak_index : numpy.ndarray of int
        Per episode: its contact, first sample, one past its last sample and the sample of its
        largest force; sorted by contact, then time.
    peak : numpy.ndarray
        The episode's largest force [N].
    """
    force = np.asarray(force, dtype=float)
    nc, nt = force.shape
    on = np.zeros((nc, nt + 2), dtype=np.int8)
    on[:, 1:-1] = force > 0.0
    edges = np.diff(on, axis=1)
    c_start, start = np.nonzero(edges == 1)
    c_stop, stop = np.nonzero(edges == -1)  # (both sorted by contact, then time: they pair up)
    peak_index = np.empty(start.size, dtype=np.int64)
    peak = np.empty(start.size)
    for i, (c, a, b) in enumerate(zip(c_start, start, stop, strict=True)):
        k = a + int(np.argmax(force[c, a:b]))
        peak_index[i], peak[i] = k, force[c, k]
    return c_start.astype(np.int64), start.astype(np.int64), stop.astype(np.int64), \
        peak_index, peak


def _stress_columns(geo: dict, races: np.ndarray, force: np.ndarray) -> dict:
    """Hertz indentation, contact semi-axes and pressure at each episode's force."""
    stress = race_stresses(geo, races, force)
    return {
        "delta_max": (stress["delta_max"], "m", "Hertz indentation under F_max"),
        "contact_radius": (stress["contact_radius"], "m", "Hertz contact radius under F_max "
                                                         "(ellipse: semi-major axis)"),
        "contact_semi_minor": (stress["contact_semi_minor"], "m", "semi-minor axis of the "
                                                                 "contact under F_max"),
        "p_max": (stress["p_max"], "Pa", "largest Hertz contact pressure under F_max"),
    }


def contact_episodes(run_ds: xr.Dataset, r_eff: str = "concave",
                     groove_conformity=None) -> xr.Dataset:
    """Table of the contact episodes of a compliant run (one row per episode).

    Parameters
    ----------
    run_ds : xarray.Dataset
        A compliant run: ``F_N`` (time, contact), coordinates ``ball`` and ``race`` on
        ``contact``, the model settings in its attributes (:func:`analysis.impacts.
        run_geometry`) and ``output_interval_s`` (else ``solver.dt``).
    r_eff : {"concave", "paper"}
        Effective radius of the outer-race contacts for the stresses.
    groove_conformity : float or None
        Groove radius over ball diameter for elliptical contact stresses; None or 0: the
        run's own contacts (:func:`analysis.impacts.run_geometry`).

    Returns
    -------
    xarray.Dataset
        Dimension ``impact`` (one row per episode, sorted by the time of its peak, then
        contact); columns ``contact``, ``ball``, ``race`` (0 inner, 1 outer), ``time`` (of the
        largest force) [s], ``start_time`` [s], ``contact_time`` (samples with a force times
        the output interval, an upper bound) [s], ``F_max`` (largest ``F_N``) [N], and the
        Hertz ``delta_max``, ``contact_radius``, ``contact_semi_minor`` [m] and ``p_max`` [Pa]
        at it.
    """
    groove = None if not groove_conformity else float(groove_conformity)
    geo = run_geometry(run_ds, r_eff, groove)
    force = compliant_forces(run_ds)
    times = np.asarray(run_ds["time"].values, dtype=float)
    interval = float(run_ds.attrs.get("output_interval_s", run_ds.attrs.get("solver.dt", np.nan)))
    contact, start, stop, peak_index, peak = episode_peaks(force)
    order = np.lexsort((contact, peak_index))
    contact, start, stop, peak_index, peak = (a[order] for a in
                                              (contact, start, stop, peak_index, peak))
    races = race_codes(run_ds, force.shape[0])[contact]
    balls = np.asarray(run_ds["ball"].values).astype(np.int64)[contact]
    columns = {
        "contact": (contact, "1", "contact index (balls 0..n-1 on the inner race, then outer)"),
        "ball": (balls, "1", "ball index"),
        "race": (races.astype(np.int8), None, "race of the contact"),
        "time": (times[peak_index], "s", "time of the episode's largest force (end of its "
                                          "output interval)"),
        "start_time": (times[start], "s", "end of the episode's first output interval"),
        "contact_time": ((stop - start) * interval, "s", "output intervals with a force times "
                                                         "the interval (an upper bound)"),
        "F_max": (peak, "N", "largest contact force F_N of the episode"),
        **_stress_columns(geo, races, peak),
    }
    ds = xr.Dataset(coords={"impact": ("impact", np.arange(peak.size, dtype=np.int64),
                                       {"units": "1", "long_name": "episode number"})})
    for name, (values, units, long_name) in columns.items():
        attrs = {"long_name": long_name} if units is None else {"units": units,
                                                                  "long_name": long_name}
        ds[name] = ("impact", values, attrs)
    ds["race"].attrs.update(flag_values=np.array(list(RACE.values()), dtype=np.int8),
                            flag_meanings=" ".join(RACE))
    from simcore import __version__

    ds.attrs.update({
        "Conventions": "CF-1.10",
        "title": "contact episodes of a compliant run: largest contact force, Hertz stresses",
        "source": f"bearingsim {__version__} (analysis.episodes.contact_episodes)",
        "history": f"analysis.episodes.contact_episodes(r_eff={r_eff}, groove_conformity="
                   f"{'none' if groove is None else f'{groove:g}'}) on run "
                   f"'{run_ds.attrs.get('title', 'untitled')}'",
        "contact_model": "compliant",
        "r_eff": r_eff,
        "groove_conformity": "none" if groove is None else groove,
        "contact_geometry": geo["contacts"],
        "output_interval_s": interval,
        "n_episodes": int(peak.size),
    })
    return ds
