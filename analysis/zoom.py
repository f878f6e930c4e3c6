"""Compliant zooms on the largest impacts of a run: the paper's force beside the force of a
contact that deforms.

For each of the ``zoom_top`` largest impacts (by impulse) the whole mechanism is restarted from
the run's state just before the impact with compliant (Hertz) contacts and a small step
(:func:`simcore.zoom`, its step the shortest Hertz contact time it must resolve over
:data:`STEPS_PER_CONTACT`) for a window of three Flores contact times of the impact (at least
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

__all__ = ["STEPS_PER_CONTACT", "add_zoom_forces", "zoom_step"]


#: steps of a zoom per Hertz contact time (dt = t_Hertz / N): doubling N changes F_max_zoom by
#: less than 1 % on the paper case and on a steady study run at E = 2.1e9 and 2.1e11 Pa
#: (docs/compliant.md, "Step of a zoom"); the study's setting analysis.zoom_steps_per_contact
STEPS_PER_CONTACT = 40


def _first_episode(force: np.ndarray, dt: float) -> float:
    """Duration [s] of the first run of samples with a positive force (0 if none, NaN if it
    lasts to the last sample).

    The ends are placed between samples: near its ends a Hertz force goes as the indentation
    to the power 3/2 and the indentation changes linearly in time, so F^(2/3) is extrapolated
    linearly from the two samples inside the episode to zero, and the crossing is kept within
    the step where the force switched (an error of order dt^2 instead of dt).
    """
    on = np.flatnonzero(force > 0.0)
    if on.size == 0:
        return 0.0
    first = last = on[0]
    while last + 1 < force.size and force[last + 1] > 0.0:
        last += 1
    if last == force.size - 1:
        return float("nan")
    s = np.cbrt(np.asarray(force[first:last + 1], dtype=float)) ** 2  # ~ indentation
    t_start, t_end = float(first), float(last)
    # half a step where the samples cannot place the switch (as counting samples does)
    if first > 0:  # the force was zero at sample first - 1
        back = 0.5
        if s.size > 1 and s[1] > s[0]:
            back = min(1.0, s[0] / (s[1] - s[0]))
        t_start -= back
    ahead = 0.5  # the force is zero at sample last + 1
    if s.size > 1 and s[-2] > s[-1]:
        ahead = min(1.0, s[-1] / (s[-2] - s[-1]))
    t_end += ahead
    return float((t_end - t_start) * dt)


def zoom_step(zoom_model: dict, run_dt: float, speeds, steps_per_contact: int) -> float:
    """Step of a zoom [s]: the shortest Hertz contact time it must resolve over
    ``steps_per_contact``, at most ``run_dt``.

    The contact time is the shorter of a ball hitting the stiffer race at the crank pin's speed
    (every contact of the mechanism is integrated in the zoom, :func:`simcore.limits.
    hertz_contact_time`) and at the approach speed of each impact the zoom serves, both with the
    zoom's model (so a stiffer ``model.youngs_modulus`` override gives a shorter step).

    Parameters
    ----------
    zoom_model : dict
        Validated ``model`` section of the zoom.
    run_dt : float
        The run's step [s], the largest step a zoom takes.
    speeds : sequence of float
        Approach speeds ``v_pre`` [m/s] of the impacts the zoom serves (NaN ignored).
    steps_per_contact : int
        N, steps per Hertz contact time.
    """
    from simcore.limits import hertz_contact_time

    t_contact = hertz_contact_time(zoom_model)
    for v in speeds:
        if np.isfinite(v) and v > 0.0:
            t_contact = min(t_contact, hertz_contact_time(zoom_model, speed=float(v)))
    return min(t_contact / int(steps_per_contact), float(run_dt))


def add_zoom_forces(run_ds: xr.Dataset, impacts_ds: xr.Dataset, zoom_top: int = 5,
                    dt: float | None = None, window: float = 5e-4, overrides=(),
                    max_window: float = 2e-2,
                    steps_per_contact: int = STEPS_PER_CONTACT) -> xr.Dataset:
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
    dt : float, optional
        Step of every zoom [s]. Default (None): from the physics, per zoom, the shortest Hertz
        contact time it must resolve over ``steps_per_contact`` (:func:`zoom_step`).
    window : float
        Shortest window of a zoom [s]; it is stretched to three Flores contact times of the
        impacts it serves (``contact_time`` of the table), at most ``max_window`` [s]. A zoom
        stops earlier once its contacts have opened again.
    overrides : sequence of str
        ``section.key=value`` settings of the zooms (e.g. another ``model.youngs_modulus``).
    steps_per_contact : int
        Steps per Hertz contact time when ``dt`` is None [-].

    Returns
    -------
    xarray.Dataset
        A copy of ``impacts_ds`` with ``F_max_zoom`` [N], ``contact_time_zoom`` [s] and
        ``dt_zoom`` [s] (NaN where not zoomed) and attributes ``zoom_top``,
        ``zoom_steps_per_contact`` (0 for a fixed ``dt``), ``zoom_window``.
    """
    import simcore
    from simcore.compliant_zoom import zoom_config

    zoom_top = int(zoom_top)
    if zoom_top < 0:
        raise ValueError(f"analysis.zoom_top: {zoom_top} is not allowed; allowed: >= 0")
    if dt is None and int(steps_per_contact) < 1:
        raise ValueError(f"steps_per_contact: {steps_per_contact!r} is not allowed; "
                         "allowed: >= 1")
    out = impacts_ds.copy()
    n = out.sizes.get("impact", 0)
    F_zoom = np.full(n, np.nan)
    t_zoom = np.full(n, np.nan)
    dt_zoom = np.full(n, np.nan)
    if zoom_top > 0 and n > 0:
        impulse = np.asarray(out["impulse"].values, dtype=float)
        order = np.argsort(-impulse, kind="stable")[:zoom_top]
        flores_time = (np.asarray(out["contact_time"].values, dtype=float)
                       if "contact_time" in out else np.full(n, np.nan))
        v_pre = (np.asarray(out["v_pre"].values, dtype=float)
                 if "v_pre" in out else np.full(n, np.nan))
        # one zoom per distinct time, long enough for three Flores contact times of the
        # impacts it serves (a soft contact, E = 2.1e9 Pa, lasts milliseconds)
        windows: dict[float, float] = {}
        speeds: dict[float, list[float]] = {}
        for row in order:
            time = float(out["time"].values[row])
            w = window
            if np.isfinite(flores_time[row]):
                w = min(max(w, 3.0 * flores_time[row]), max_window)
            windows[time] = max(windows.get(time, 0.0), w)
            speeds.setdefault(time, []).append(float(v_pre[row]))
        steps: dict[float, float] = {}
        if dt is None:
            model = zoom_config(run_ds, window=max(windows.values()), dt=1e-6,
                                overrides=overrides)["model"]
            run_dt = float(run_ds.attrs.get("solver.dt", np.inf))
            steps = {time: zoom_step(model, run_dt, speeds[time], steps_per_contact)
                     for time in windows}
        else:
            steps = dict.fromkeys(windows, float(dt))
        zooms: dict[float, xr.Dataset] = {}
        for row in order:
            time = float(out["time"].values[row])
            if time not in zooms:
                zooms[time] = simcore.zoom(run_ds, time, window=windows[time], dt=steps[time],
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
            dt_zoom[row] = steps[time]
    out["F_max_zoom"] = ("impact", F_zoom, {
        "units": "N", "long_name": "largest contact force of the impact's ball in a compliant "
        "(Hertz) zoom from the state before the impact (NaN: not zoomed, or the force was "
        "still rising at the end of the zoom)"})
    out["contact_time_zoom"] = ("impact", t_zoom, {
        "units": "s", "long_name": "duration of the impact's contact in the compliant zoom "
        "(first contact episode; NaN: not zoomed, or still closed at the end of the zoom)"})
    out["dt_zoom"] = ("impact", dt_zoom, {
        "units": "s", "long_name": "time step of the compliant zoom of the impact (its shortest "
        "Hertz contact time over zoom_steps_per_contact, at most the run's step; NaN: not "
        "zoomed)"})
    out.attrs.update({"zoom_top": zoom_top,
                      "zoom_steps_per_contact": int(steps_per_contact) if dt is None else 0,
                      "zoom_window": float(window), "zoom_max_window": float(max_window)})
    return out
