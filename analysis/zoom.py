"""Compliant zooms on the largest impacts of a run: the paper's force beside the force of a
contact that deforms.

For each of the ``zoom_top`` largest impacts (by impulse) the whole mechanism is restarted from
the run's state just before the impact with compliant (Hertz) contacts and a small step
(:func:`simcore.zoom`) for a window of three Flores contact times of the impact (at least
0.5 ms, at most 20 ms), or until every contact that closed has opened again. The
impact table gains ``F_max_zoom`` [N], the largest contact force of the impact's ball in the
zoom (for a ball pinched between both races that is the larger of its two contacts; NaN when
that force still rises at the end of the zoom), and
``contact_time_zoom`` [s], how long the impact's own contact stayed closed in its first contact
episode (NaN when it was still closed at the end of the zoom: the impact turned into persistent
contact, as it does for the loaded balls of the bearing).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

__all__ = ["add_zoom_forces"]


def _first_episode(force: np.ndarray, dt: float) -> float:
    """Duration [s] of the first run of samples with a positive force (0 if none, NaN if it
    lasts to the last sample)."""
    on = np.flatnonzero(force > 0.0)
    if on.size == 0:
        return 0.0
    first = last = on[0]
    while last + 1 < force.size and force[last + 1] > 0.0:
        last += 1
    if last == force.size - 1:
        return float("nan")
    return float((last - first + 1) * dt)


def add_zoom_forces(run_ds: xr.Dataset, impacts_ds: xr.Dataset, zoom_top: int = 5,
                    dt: float = 1e-6, window: float = 5e-4, overrides=(),
                    max_window: float = 2e-2) -> xr.Dataset:
    """Impact table with ``F_max_zoom`` and ``contact_time_zoom`` for the largest impacts.

    Parameters
    ----------
    run_ds : xarray.Dataset
        The run the table comes from (with ``q``, ``v`` and its ``model.*`` attributes).
    impacts_ds : xarray.Dataset
        Its impact table (:func:`analysis.extract_impacts`).
    zoom_top : int
        How many of the largest impacts (by ``impulse``) to zoom; 0: none (the columns are
        all NaN).
    dt : float
        Step of the zooms [s].
    window : float
        Shortest window of a zoom [s]; it is stretched to three Flores contact times of the
        impacts it serves (``contact_time`` of the table), at most ``max_window`` [s]. A zoom
        stops earlier once its contacts have opened again.
    overrides : sequence of str
        ``section.key=value`` settings of the zooms (e.g. another ``model.youngs_modulus``).

    Returns
    -------
    xarray.Dataset
        A copy of ``impacts_ds`` with ``F_max_zoom`` [N] and ``contact_time_zoom`` [s] (NaN
        where not zoomed) and attributes ``zoom_top``, ``zoom_dt``, ``zoom_window``.
    """
    import simcore

    zoom_top = int(zoom_top)
    if zoom_top < 0:
        raise ValueError(f"analysis.zoom_top: {zoom_top} is not allowed; allowed: >= 0")
    out = impacts_ds.copy()
    n = out.sizes.get("impact", 0)
    F_zoom = np.full(n, np.nan)
    t_zoom = np.full(n, np.nan)
    if zoom_top > 0 and n > 0:
        impulse = np.asarray(out["impulse"].values, dtype=float)
        order = np.argsort(-impulse, kind="stable")[:zoom_top]
        flores_time = (np.asarray(out["contact_time"].values, dtype=float)
                       if "contact_time" in out else np.full(n, np.nan))
        # one zoom per distinct time, long enough for three Flores contact times of the
        # impacts it serves (a soft contact, E = 2.1e9 Pa, lasts milliseconds)
        windows: dict[float, float] = {}
        for row in order:
            time = float(out["time"].values[row])
            w = window
            if np.isfinite(flores_time[row]):
                w = min(max(w, 3.0 * flores_time[row]), max_window)
            windows[time] = max(windows.get(time, 0.0), w)
        zooms: dict[float, xr.Dataset] = {}
        for row in order:
            time = float(out["time"].values[row])
            if time not in zooms:
                zooms[time] = simcore.zoom(run_ds, time, window=windows[time], dt=dt,
                                           overrides=overrides)
            z = zooms[time]
            contact = int(out["contact"].values[row])
            ball = int(out["ball"].values[row])
            same_ball = np.flatnonzero(np.asarray(z["ball"].values) == ball)
            F_ball = np.asarray(z["F_N"].isel(contact=same_ball).values).max(axis=1)
            # a force still rising at the end of the zoom is no peak: flagged as NaN
            peak = int(np.argmax(F_ball))
            F_zoom[row] = float(F_ball[peak]) if peak < F_ball.size - 1 else np.nan
            t_zoom[row] = _first_episode(np.asarray(z["F_N"].sel(contact=contact).values),
                                         float(z.attrs["solver.output_dt"]))
    out["F_max_zoom"] = ("impact", F_zoom, {
        "units": "N", "long_name": "largest contact force of the impact's ball in a compliant "
        "(Hertz) zoom from the state before the impact (NaN: not zoomed, or the force was "
        "still rising at the end of the zoom)"})
    out["contact_time_zoom"] = ("impact", t_zoom, {
        "units": "s", "long_name": "duration of the impact's contact in the compliant zoom "
        "(first contact episode; NaN: not zoomed, or still closed at the end of the zoom)"})
    out.attrs.update({"zoom_top": zoom_top, "zoom_dt": float(dt), "zoom_window": float(window),
                      "zoom_max_window": float(max_window)})
    return out
