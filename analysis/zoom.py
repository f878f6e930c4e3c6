"""Compliant zooms on the impacts a study reads: the paper's force beside the force of a
contact that deforms.

The zoomed impacts (:func:`zoom_rows`) are the largest Flores forces of the steady window (the
largest of each race first, ``zoom_top`` in all) and the largest of the start-up: the impacts
that give the summary's ``peak_force`` and ``startup_peak_force``. For each, the whole mechanism
is restarted from the run's state just before the impact with compliant (Hertz) contacts and a
small step (:func:`simcore.zoom`: adaptive steps of at most the shortest Hertz contact time it
must resolve over :data:`ADAPTIVE_STEPS_PER_CONTACT`, or with ``adaptive=False`` a fixed step,
that time over ``steps_per_contact``) for a window of three Flores contact times of the impact
(at least 0.5 ms, at most 20 ms), or until the ball of every impact it serves is free again. The
impact table gains ``F_max_zoom`` [N], the largest contact force of the impact's ball during the
impact: over the ball's contact episode that contains the first force of the impact's own
contact (for a pinch, the first sample where both contacts of the ball carry force, so that the
pinch's two rows read the same episode; the ball's force is the larger of its two contacts; NaN
when that force still rises at the end of the zoom), and ``contact_time_zoom`` [s], how long the
impact's own contact stayed closed in its first contact episode (NaN when it was still closed at
the end of the zoom: the impact turned into persistent contact, as it does for the loaded balls
of the bearing).

Where the zoom contradicts the paper's force, |F_max / F_max_zoom - 1| > ``analysis.method_tol``,
the row gets the flag bit ``method_disagrees`` and is no longer ``trusted``.

A row whose ball already carries load in the state the zoom would start from
(:func:`loaded_at_start`) is not zoomed and gets no verdict: the rigid state has no
deformation, so a compliant restart starts that ball's contacts undeformed under their load,
and what the zoom's ball then shows first is the overshoot of a suddenly applied load (up to
twice the load), not the impact (docs/forces.md, §8). The grid point's compliant twin, which
carries its loads from the start of its run, checks those numbers.

A zoom stops once, for each impact it serves, the ball's contacts have carried no force at one
sample after the impact's contact first closed (``watch_contacts`` of :func:`simcore.zoom`,
checked every 100 steps). Both numbers read only the samples up to that point, so they are
exactly those of the zoom over its whole window; a later, separate contact of the same ball
does not enter.
"""

from __future__ import annotations

import warnings

import numpy as np
import xarray as xr

from simcore.io.variables import label_attrs

from .impacts import FLAG, KIND, count_flags

_METHOD_DISAGREES = FLAG["method_disagrees"]

__all__ = ["ADAPTIVE_STEPS_PER_CONTACT", "STEPS_PER_CONTACT", "ZOOM_ADAPTIVE", "add_zoom_forces",
           "zoom_step", "zoom_rows", "loaded_at_start", "method_disagrees"]


#: steps of a zoom per Hertz contact time (dt = t_Hertz / N): doubling N changes F_max_zoom by
#: less than 1 % on the paper case and on a steady study run at E = 2.1e9 and 2.1e11 Pa
#: (docs/compliant.md, "Step of a zoom"); the study's setting analysis.zoom_steps_per_contact
STEPS_PER_CONTACT = 40

#: the study's zooms take adaptive steps (analysis.zoom_adaptive's default)
ZOOM_ADAPTIVE = True

#: an adaptive zoom's largest step and output interval: the Hertz contact time over this
#: number. The error control and the onset cutting shorten the steps inside an interval where a
#: contact needs it; the interval sets how finely the histories are read (a ball's release
#: shorter than it is not seen, the contact time from the indentation at its ends). At 5 the
#: zooms of two study points take fewer steps than fixed ones at t_Hertz / 20, F_max_zoom
#: within 0.6 % of t_Hertz / 80 (docs/compliant.md, "Adaptive zooms"); 5 steps per contact
#: time is also the compliant step's stability bound (simcore.config.limits)
ADAPTIVE_STEPS_PER_CONTACT = 5


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
    first = on[0]
    off = np.flatnonzero(~(force[first:] > 0.0))  # (a persistent contact: thousands of samples)
    if off.size == 0:
        return float("nan")
    last = first + off[0] - 1
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


def _struck(F_contact: np.ndarray) -> np.ndarray:
    """The force samples of an impact's contact as its episodes are read: a force at the
    zoom's first sample alone (zero at the second) is dropped. That sample is the nonsmooth
    run's state, where a contact about to be struck can sit within the solver's tolerance
    (gaps of -5e-15 m, Hertz forces of 1e-14 N); it is not the impact (the same rule as the
    onset of :meth:`simcore.model.Model.simulate`'s ``watch_contacts``)."""
    F = np.asarray(F_contact, dtype=float)
    if F.size > 1 and F[0] > 0.0 and not F[1] > 0.0:
        F = F.copy()
        F[0] = 0.0
    return F


def _pinch_onset(F_ball_contacts: np.ndarray) -> np.ndarray:
    """The onset series of a pinch row: where both of the ball's contacts carry force (the ball
    squeezed between the races), else, if they never do together, where either does. The same
    for the pinch's two rows (the ball on either race), so that both read one episode: a light
    touch of one race before the squeeze is not the pinch."""
    both = F_ball_contacts.min(axis=1)
    return both if np.any(both > 0.0) else _struck(F_ball_contacts.max(axis=1))


def _episode_peak(F_ball: np.ndarray, F_contact: np.ndarray) -> float:
    """F_max_zoom of an impact [N]: the largest force of the impact's ball (``F_ball``, the
    larger of its contacts per sample) over the ball's contact episode that contains the first
    force of the impact's own contact (``F_contact``): from the sample where the ball's
    force last rose from zero up to the first later sample where it is zero again. NaN when
    that force is still rising at the last sample. An impact contact that never closes gets
    the largest force of the ball over the whole zoom (NaN if still rising at its end).

    Only the samples up to the end of that episode enter, so a zoom stopped there
    (``watch_contacts``) reports exactly what the zoom over its whole window reports."""
    first = np.flatnonzero(F_contact > 0.0)
    start, stop = 0, F_ball.size
    if first.size:
        zero = np.flatnonzero(F_ball[:first[0]] <= 0.0)
        start = int(zero[-1]) + 1 if zero.size else 0
        later = np.flatnonzero(F_ball[first[0]:] <= 0.0)
        stop = int(first[0] + later[0]) if later.size else F_ball.size
    peak = start + int(np.argmax(F_ball[start:stop]))
    return float(F_ball[peak]) if peak < F_ball.size - 1 else float("nan")


def zoom_step(zoom_model: dict, run_dt: float, speeds, steps_per_contact: int) -> float:
    """Step of a zoom [s]: the shortest Hertz contact time it must resolve over
    ``steps_per_contact``, at most ``run_dt``.

    The contact time is the shorter of a ball hitting the stiffer race at the crank pin's speed
    (every contact of the mechanism is integrated in the zoom, :func:`simcore.config.limits.
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
    from simcore.config.limits import hertz_contact_time

    t_contact = hertz_contact_time(zoom_model)
    for v in speeds:
        if np.isfinite(v) and v > 0.0:
            t_contact = min(t_contact, hertz_contact_time(zoom_model, speed=float(v)))
    return min(t_contact / int(steps_per_contact), float(run_dt))


def zoom_rows(impacts_ds: xr.Dataset, zoom_top: int, settle_time: float = -np.inf) -> np.ndarray:
    """The impact rows a study zooms: where the summary reads its peak forces.

    The largest Flores forces (``F_max``) of the steady window (``time > settle_time``): first
    the largest of each race (largest first), then the next largest of either race, ``zoom_top``
    rows in all; and the largest of the start-up (``time <= settle_time``) on top of them, so
    that the impacts that give ``peak_force`` and ``startup_peak_force`` have an
    ``F_max_zoom``. Rows without a force (no approach) are not zoomed.

    Parameters
    ----------
    impacts_ds : xarray.Dataset
        An impact table (columns ``time``, ``race``, ``F_max``).
    zoom_top : int
        Zooms of the steady window (>= 0; 0: none at all).
    settle_time : float
        End of the start-up [s] (:func:`analysis.summary.steady_window`); -inf: the whole run
        is steady.

    Returns
    -------
    numpy.ndarray of int
        Row indices, steady ones by decreasing force, then the start-up's.
    """
    n = impacts_ds.sizes.get("impact", 0)
    if zoom_top <= 0 or n == 0:
        return np.zeros(0, dtype=np.int64)
    force = np.asarray(impacts_ds["F_max"].values, dtype=float)
    race = np.asarray(impacts_ds["race"].values)
    steady = np.asarray(impacts_ds["time"].values, dtype=float) > settle_time
    has_force = np.isfinite(force)
    by_force = np.argsort(-np.where(has_force, force, -np.inf), kind="stable")
    candidates = by_force[has_force[by_force] & steady[by_force]]
    first_of_race = [int(candidates[race[candidates] == r][0]) for r in np.unique(race)
                     if np.any(race[candidates] == r)]
    first_of_race.sort(key=lambda row: -force[row])
    chosen = list(first_of_race[:zoom_top])
    for row in candidates:
        if len(chosen) >= zoom_top:
            break
        if int(row) not in chosen:
            chosen.append(int(row))
    startup = by_force[has_force[by_force] & ~steady[by_force]]
    if startup.size:
        chosen.append(int(startup[0]))
    return np.asarray(chosen, dtype=np.int64)


def loaded_at_start(run_ds: xr.Dataset, impacts_ds: xr.Dataset, rows,
                    method_tol: float) -> np.ndarray:
    """Which of ``rows`` have a ball that carries load in the run's state a zoom of the row
    starts from: the largest rigid contact force Λ_N / h of the ball's contacts over the step
    that ends at that state (the last sample before the impact) above ``method_tol`` times the
    row's ``F_max``, so that starting them undeformed could alone move the zoom's force by
    more than the tolerance.

    Returns
    -------
    numpy.ndarray of bool
        One per row of ``rows``.
    """
    from simcore.study.zoom import start_index

    rows = np.asarray(rows, dtype=np.int64)
    out = np.zeros(rows.size, dtype=bool)
    if rows.size == 0:
        return out
    t = np.asarray(run_ds["time"].values, dtype=float)
    lam = np.asarray(run_ds["Lambda_N"].values, dtype=float)
    ball_of_contact = np.asarray(run_ds["ball"].values)
    for g, row in enumerate(rows):
        i = start_index(run_ds, float(impacts_ds["time"].values[row]))
        if i < 1:
            continue  # (the run's first sample: nothing has been carried yet)
        ball = ball_of_contact == int(impacts_ds["ball"].values[row])
        force = lam[i, ball].max() / (t[i] - t[i - 1])
        out[g] = force > float(method_tol) * float(impacts_ds["F_max"].values[row])
    return out


def _zoom_plans(run_ds, table, rows, dt, window, max_window, overrides, steps_per_contact):
    """One zoom per distinct impact time: {time: (window [s], step [s], rows it serves)}, the
    step its shortest Hertz contact time over ``steps_per_contact`` (an adaptive zoom's
    largest step) or ``dt``.

    A zoom lasts three Flores contact times of the impacts it serves (a soft contact,
    E = 2.1e9 Pa, lasts milliseconds), at least ``window``, at most ``max_window``."""
    from simcore.study.zoom import zoom_config

    n = table.sizes.get("impact", 0)
    times = np.asarray(table["time"].values, dtype=float)
    flores_time = (np.asarray(table["contact_time"].values, dtype=float)
                   if "contact_time" in table else np.full(n, np.nan))
    v_pre = (np.asarray(table["v_pre"].values, dtype=float)
             if "v_pre" in table else np.full(n, np.nan))
    windows: dict[float, float] = {}
    served: dict[float, list[int]] = {}
    for row in rows:
        time = float(times[row])
        w = window
        if np.isfinite(flores_time[row]):
            w = min(max(w, 3.0 * flores_time[row]), max_window)
        windows[time] = max(windows.get(time, 0.0), w)
        served.setdefault(time, []).append(int(row))
    if dt is None:
        model = zoom_config(run_ds, window=max(windows.values()), dt=1e-6,
                            overrides=overrides)["model"]
        run_dt = float(run_ds.attrs.get("solver.dt", np.inf))
        steps = {time: zoom_step(model, run_dt, v_pre[served[time]], steps_per_contact)
                 for time in windows}
    else:
        steps = dict.fromkeys(windows, float(dt))
    return {time: (windows[time], steps[time], served[time]) for time in windows}


def _at_sample_instants(traj, model, zcfg):
    """The force and the indentation of an adaptive zoom's contacts as a fixed step's samples
    read them: (F_N [N], indentation [m]), both zero at an output time where the contact is
    open (its gap, from the state q, v at that instant, not negative).

    An adaptive zoom's F_N is the largest force of the steps in each output interval, so a
    ball that leaves a race and strikes it again inside one interval shows no zero there, and
    two impacts would read as one contact episode; a fixed step's sample is the force at the
    end of its one step. Masking the interval's largest force where the contact is open at the
    sample instant gives the episodes the fixed step's meaning and keeps every peak of an
    interval that ends in contact."""
    import simcore.kernels as nb

    arrays = model.arrays(zcfg["model"].get("damping_law", "flores"), compliant=True)
    n_rows, nc = traj.F_N.shape
    gap = np.empty((n_rows, nc))
    vn, vt = np.empty(nc), np.empty(nc)
    for i in range(n_rows):
        nb.contact_velocities(traj.q[i], traj.v[i], arrays, gap[i], vn, vt)
    closed = gap < 0.0
    return np.where(closed, traj.F_N, 0.0), np.where(closed, -gap, 0.0)


def _zoom_numbers(run_ds, table, time, plan, overrides, adaptive=False):
    """Run the zoom of one impact time; ({row: (F_max_zoom [N], contact_time_zoom [s],
    zoom_flagged)}, steps the zoom took, its smallest step [s]).

    The zoom watches, for every impact it serves, the contacts of the impact's ball (onset: the
    impact's own contact) and stops once all those episodes have ended."""
    from simcore.config import output_every
    from simcore.study.zoom import zoom_trajectory

    window, step, rows = plan
    ball_of_contact = np.asarray(run_ds["ball"].values)
    balls = np.asarray(table["ball"].values)
    contacts = np.asarray(table["contact"].values)
    groups = np.zeros((len(rows), ball_of_contact.size), dtype=bool)
    onset = np.zeros_like(groups)
    kinds = np.asarray(table["kind"].values) if "kind" in table else np.full(len(balls), -1)
    for g, row in enumerate(rows):
        groups[g] = ball_of_contact == int(balls[row])
        if kinds[row] == KIND["pinch"]:  # a pinch's episode starts where both races carry it
            onset[g] = groups[g]
        else:
            onset[g, int(contacts[row])] = True
    # (the zoom's arrays: its dataset would be built for three of them) a zoom's flagged step
    # (not converged, energy created, an integrity check such as an indentation beyond Hertz's
    # range) flags its impacts (zoom_flagged) instead of stopping the study
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        traj, model, _, zcfg = zoom_trajectory(
            run_ds, time, window=window, dt=step,
            overrides=[*overrides, "solver.on_nonconvergence=warn"], watch_contacts=groups,
            watch_onset=onset, adaptive=adaptive)
    F_N, indentation = traj.F_N, None
    if adaptive:
        F_N, indentation = _at_sample_instants(traj, model, zcfg)
    flagged = int(not np.all(traj.converged))
    output_dt = float(zcfg["solver"]["dt"]) * output_every(zcfg)
    out = {}
    for g, row in enumerate(rows):
        F_contact = _struck(F_N[:, int(contacts[row])])
        ball = np.flatnonzero(groups[g])  # (the run's ball contacts come first, guards after)
        F_ball = F_N[:, ball].max(axis=1)
        onset = _pinch_onset(F_N[:, ball]) if kinds[row] == KIND["pinch"] else F_contact
        # (the contact time from the indentation at the samples: F^(2/3) of a fixed step)
        pulse = (F_contact if indentation is None
                 else _struck(indentation[:, int(contacts[row])] ** 1.5))
        out[row] = (_episode_peak(F_ball, onset), _first_episode(pulse, output_dt), flagged)
    records = traj.extras.get("adaptive")
    if records is None:
        return out, (traj.time.size - 1) * output_every(zcfg), float(zcfg["solver"]["dt"])
    return out, records["n_steps_accepted"], records["dt_smallest_s"]


def method_disagrees(F_max, F_max_zoom, method_tol: float) -> np.ndarray:
    """Where the paper's force and its compliant reference differ by more than ``method_tol``:
    |F_max / F_max_zoom - 1| > method_tol (False where either is missing)."""
    F_max = np.asarray(F_max, dtype=float)
    F_ref = np.asarray(F_max_zoom, dtype=float)
    both = np.isfinite(F_max) & np.isfinite(F_ref) & (F_ref > 0.0)
    ratio = np.divide(F_max, F_ref, out=np.full(F_max.shape, np.nan), where=both)
    return both & (np.abs(ratio - 1.0) > float(method_tol))


# (over 80 lines: 53 of them the docstring of its eleven settings; the body is named stages)
def add_zoom_forces(run_ds: xr.Dataset, impacts_ds: xr.Dataset, zoom_top: int = 5,
                    dt: float | None = None, window: float = 5e-4, overrides=(),
                    max_window: float = 2e-2, steps_per_contact: int = STEPS_PER_CONTACT,
                    settle_time: float = -np.inf, method_tol: float = 0.2,
                    adaptive: bool = ZOOM_ADAPTIVE, loaded: str = "skip") -> xr.Dataset:
    """Impact table with ``F_max_zoom`` and ``contact_time_zoom`` for the impacts the summary
    reads (:func:`zoom_rows`), and the flag ``method_disagrees`` where they contradict F_max.

    Parameters
    ----------
    run_ds : xarray.Dataset
        The run the table comes from (with ``q``, ``v`` and its ``model.*`` attributes).
    impacts_ds : xarray.Dataset
        Its impact table (:func:`analysis.extract_impacts`).
    zoom_top : int
        Zooms of the largest forces of the steady window (the start-up's largest gets one more);
        0: none (the columns are all NaN).
    dt : float, optional
        Step of every zoom [s]. Default (None): from the physics, per zoom, the shortest Hertz
        contact time it must resolve over ``steps_per_contact`` (:func:`zoom_step`).
    window : float
        Shortest window of a zoom [s]; it is stretched to three Flores contact times of the
        impacts it serves (``contact_time`` of the table), at most ``max_window`` [s]. A zoom
        stops earlier once the ball of every impact it serves is free again.
    overrides : sequence of str
        ``section.key=value`` settings of the zooms (e.g. another ``model.youngs_modulus``).
    max_window : float
        Longest window of a zoom [s].
    steps_per_contact : int
        Steps per Hertz contact time of a fixed-step zoom when ``dt`` is None [-].
    settle_time : float
        End of the start-up [s]; -inf (default): the whole run is steady.
    method_tol : float
        A zoomed row whose |F_max / F_max_zoom - 1| exceeds it gets the flag bit
        ``method_disagrees`` and ``trusted`` = 0 [-] (``analysis.method_tol``); a zoom that
        flagged one of its steps (``zoom_flagged``) gives no verdict.
    adaptive : bool
        Adaptive steps (``analysis.zoom_adaptive``): each zoom's steps chosen by the error
        control and cut at contact onsets, at most its Hertz contact time over
        :data:`ADAPTIVE_STEPS_PER_CONTACT` (or ``dt``), which is also its output interval; the
        contact episodes and contact times are read at the output instants from the gaps
        (:func:`_at_sample_instants`). False: the fixed step ``dt`` or t_Hertz /
        ``steps_per_contact``.
    loaded : {"skip", "zoom"}
        Rows whose ball carries load at the zoom's start (:func:`loaded_at_start`): "skip"
        (default) leaves them unzoomed, without a verdict, and marks them in the column
        ``zoom_loaded_start``; "zoom" zooms them all the same (their numbers then measure the
        restart, e.g. for comparing zoom steps, not the impact), still without a verdict.

    Returns
    -------
    xarray.Dataset
        A copy of ``impacts_ds`` with ``F_max_zoom`` [N], ``contact_time_zoom`` [s] and
        ``dt_zoom`` [s] (NaN where not zoomed), the flags and counts updated, and attributes
        ``zoom_top``, ``zoom_steps_per_contact`` (the steps per contact time used, 0 for a
        given ``dt``), ``zoom_adaptive`` (0/1), ``zoom_window`` and ``zoom_max_window`` [s],
        ``method_tol``, ``n_zoomed``, ``n_zoom_steps`` (steps of all the zooms: accepted
        adaptive steps, or fixed steps), ``n_method_disagrees``; column ``dt_zoom_smallest``
        [s], the smallest step each zoom took.
    """
    zoom_top = int(zoom_top)
    if zoom_top < 0:
        raise ValueError(f"analysis.zoom_top: {zoom_top} is not allowed; allowed: >= 0")
    if dt is None and int(steps_per_contact) < 1:
        raise ValueError(f"steps_per_contact: {steps_per_contact!r} is not allowed; "
                         "allowed: >= 1")
    if not (np.isfinite(method_tol) and method_tol > 0):
        raise ValueError(f"analysis.method_tol: {method_tol!r} is not allowed; allowed: > 0")
    out = impacts_ds.copy()
    n = out.sizes.get("impact", 0)
    F_zoom, t_zoom, dt_zoom = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    zoom_flagged = np.zeros(n, dtype=np.int8)
    dt_smallest = np.full(n, np.nan)
    n_steps = 0
    if loaded not in ("skip", "zoom"):
        raise ValueError(f"loaded: {loaded!r} is not allowed; allowed: 'skip' or 'zoom'")
    rows = zoom_rows(out, zoom_top, settle_time)
    at_load = np.zeros(n, dtype=bool)
    at_load[rows] = loaded_at_start(run_ds, out, rows, method_tol)
    if loaded == "skip":
        rows = rows[~at_load[rows]]
    if rows.size:
        plans = _zoom_plans(run_ds, out, rows, dt, window, max_window, overrides,
                            ADAPTIVE_STEPS_PER_CONTACT if adaptive else steps_per_contact)
        for time, plan in plans.items():
            numbers, steps, smallest = _zoom_numbers(run_ds, out, time, plan, overrides,
                                                     adaptive)
            n_steps += steps
            for row, (force, duration, flag) in numbers.items():
                F_zoom[row], t_zoom[row], dt_zoom[row] = force, duration, plan[1]
                dt_smallest[row] = smallest
                zoom_flagged[row] = flag
    _zoom_columns(out, F_zoom, t_zoom, (dt_zoom, dt_smallest), (zoom_flagged, at_load),
                  adaptive)
    # no verdict from a zoom that started under load or flagged one of its own steps
    disagree = method_disagrees(out["F_max"].values,
                                np.where(at_load | (zoom_flagged > 0), np.nan, F_zoom),
                                method_tol)
    if "flags" in out:
        flags = np.asarray(out["flags"].values).copy()
        flags[disagree] |= _METHOD_DISAGREES
        out["flags"] = out["flags"].copy(data=flags)
        trusted = (flags == 0) & np.isfinite(np.asarray(out["F_max"].values, dtype=float))
        out["trusted"] = out["trusted"].copy(data=trusted.astype(np.int8))
        count_flags(out)
    out.attrs.update({"zoom_top": zoom_top,
                      "zoom_steps_per_contact": 0 if dt is not None else int(
                          ADAPTIVE_STEPS_PER_CONTACT if adaptive else steps_per_contact),
                      "zoom_window": float(window), "zoom_max_window": float(max_window),
                      "zoom_settle_time": float(settle_time), "method_tol": float(method_tol),
                      "n_zoomed": int(rows.size), "zoom_adaptive": int(bool(adaptive)),
                      "n_zoom_loaded_start": int(np.count_nonzero(at_load)),
                      "n_zoom_steps": int(n_steps),
                      "n_method_disagrees": int(np.count_nonzero(disagree))})
    return out


def _zoom_columns(out: xr.Dataset, F_zoom, t_zoom, steps, marks, adaptive) -> None:
    """The zoom columns of the impact table, each with its units and meaning; ``steps``: the
    zooms' (largest) steps and their smallest steps taken [s]; ``marks``: the rows whose zoom
    flagged a step, and those not zoomed for a loaded ball."""
    dt_zoom, dt_smallest = steps
    zoom_flagged, at_load = marks
    out["F_max_zoom"] = ("impact", F_zoom, {"units": "N", **label_attrs(
        "largest contact force of the impact's ball during the impact (the ball's contact "
        "episode that contains the impact contact's first closing) in a compliant (Hertz) zoom "
        "from the state before the impact (NaN: not zoomed, e.g. its ball loaded at the zoom's "
        "start (zoom_loaded_start), or the force was still rising at the end of the zoom)",
        "largest force of the impact's ball in its compliant zoom")})
    out["contact_time_zoom"] = ("impact", t_zoom, {"units": "s", **label_attrs(
        "duration of the impact's contact in the compliant zoom (first contact episode; NaN: "
        "not zoomed, or still closed at the end of the zoom)",
        "duration of the impact's contact in its compliant zoom")})
    step = ("largest step allowed to the adaptive steps of the compliant zoom of the impact, "
            "also its output interval" if adaptive else
            "time step of the compliant zoom of the impact")
    out["dt_zoom"] = ("impact", dt_zoom, {"units": "s", **label_attrs(
        f"{step} (its shortest Hertz contact time over the table's zoom_steps_per_contact, at "
        "most the run's step; NaN: not zoomed)",
        "largest time step of the impact's compliant zoom" if adaptive else
        "time step of the impact's compliant zoom")})
    out["dt_zoom_smallest"] = ("impact", dt_smallest, {"units": "s", **label_attrs(
        "smallest time step the compliant zoom of the impact took (adaptive: chosen by the "
        "error control and at contact onsets; fixed: dt_zoom; NaN: not zoomed)",
        "smallest time step the impact's compliant zoom took")})
    out["zoom_flagged"] = ("impact", zoom_flagged, {"units": "1", **label_attrs(
        "1 where the compliant zoom of the impact flagged a step (not converged, energy "
        "created, or an integrity check such as an indentation beyond solver.max_indentation, "
        "Hertz's range)", "1 where the impact's compliant zoom flagged a step"),
        "flag_values": np.array([0, 1], np.int8), "flag_meanings": "no yes"})
    out["zoom_loaded_start"] = ("impact", np.asarray(at_load, dtype=np.int8), {
        "units": "1", **label_attrs(
            "1 where the impact was chosen for a compliant zoom but its ball carried load in "
            "the state the zoom would start from (rigid contact force above method_tol x "
            "F_max): a restart starts those contacts undeformed, so no zoom verdict (the grid "
            "point's compliant twin checks the number)",
            "1 where the impact's ball was loaded at its zoom's start: no zoom"),
        "flag_values": np.array([0, 1], np.int8), "flag_meanings": "no yes"})
