"""Compliant zoom: restart the whole mechanism from the state of a run just before a chosen
time, with compliant (Hertz) contacts and a small step, and return the force histories."""

from __future__ import annotations

import numpy as np

from ..config import (
    ConfigError,
    apply_overrides,
    output_every,
    parse_override,
    validate_config,
)
from ..config.limits import check_run_of_config
from ..model import ReleaseStop, SolverSettings
from ..model.mechanism import crank_slider

DEFAULT_WINDOW = 2e-3   # [s]
DEFAULT_DT = 1e-6       # [s]
#: the settings that parameters of :func:`zoom_config` set, {setting: parameter}: refused as
#: overrides, which would undo the parameter unseen
ZOOM_SETTINGS = {"solver.t_end": "window", "solver.dt": "dt", "solver.output_dt": "output_dt"}


def check_run_dataset(run_ds) -> None:
    """Refuse, in one line naming ``run``, a dataset that is not a run of this tool: a zoom
    needs its ``time``, its configuration (``model.*`` and ``solver.*`` attributes) and its
    state."""
    from ..io import GENERALIZED_PARTS

    if "time" not in run_ds.variables:
        raise ConfigError("run: the file has no variable 'time'; allowed: a run file of "
                          "python -m simcore run (or simcore.run)")
    if not any(str(key).startswith("model.") for key in run_ds.attrs):
        raise ConfigError("run: the file has no model.* attributes (the configuration of the "
                          "run); allowed: a run file of python -m simcore run (or simcore.run)")
    # a run file has the state q, v in parts (a run in memory whole)
    missing = [part for name, parts in GENERALIZED_PARTS.items() if name not in run_ds
               for part in parts if part not in run_ds]
    if missing:
        needed = ", ".join(part for parts in GENERALIZED_PARTS.values() for part in parts)
        twin = (" a study's compliant twin keeps no velocities;"
                if run_ds.attrs.get("model.contact_model") == "compliant" else "")
        raise ConfigError(f"run: the run file lacks {', '.join(missing)} (its state, to restart "
                          f"from;{twin} allowed: a run file whose study.keep holds {needed}"
                          + (", such as the grid point's nonsmooth run)" if twin else ")"))


def config_of_run(run_ds) -> dict:
    """The model and solver sections of the configuration that made ``run_ds`` (from its
    ``model.*`` / ``solver.*`` attributes)."""
    cfg: dict = {"model": {}, "solver": {}}
    for key, value in run_ds.attrs.items():
        section, _, name = key.partition(".")
        if section in cfg and name:
            if isinstance(value, np.generic):
                value = value.item()
            cfg[section][name] = value
    return cfg


def zoom_config(run_ds, window=DEFAULT_WINDOW, dt=DEFAULT_DT, overrides=(),
                output_dt=None, adaptive=True, names=None) -> dict:
    """Validated configuration of a zoom on ``run_ds``: the run's model with
    ``contact_model = compliant``, step ``dt`` [s] (with ``adaptive``, the largest) for
    ``window`` [s], then ``overrides`` (``section.key=value`` strings; not the settings of
    :data:`ZOOM_SETTINGS`, which ``window``, ``dt`` and ``output_dt`` set).

    ``names`` ({parameter: name}, e.g. ``{"window": "--window"}``) names the parameters in
    the message that refuses an override of their setting, as the caller calls them.

    Raises
    ------
    simcore.ConfigError
        One line: an override ``overrides: ITEM ...`` of a setting of :data:`ZOOM_SETTINGS`
        or naming the key of a bad override or value (``solver.t_end``, ``solver.dt``: the
        values of ``window``, ``dt``).
    """
    check_run_dataset(run_ds)
    for item in overrides:
        setting = ".".join(parse_override(item)[0])
        if setting in ZOOM_SETTINGS:
            param = ZOOM_SETTINGS[setting]
            option = (names or {}).get(param, param)
            raise ConfigError(f"overrides: {item.strip()} is not allowed in a zoom; allowed: "
                              f"{option}, which sets {setting}")
    cfg = config_of_run(run_ds)
    cfg["model"]["contact_model"] = "compliant"
    cfg["solver"].update({"dt": float(dt), "t_end": float(window), "output_dt": output_dt,
                          "adaptive": bool(adaptive)})
    apply_overrides(cfg, overrides)
    if cfg["model"].get("contact_model") != "compliant":
        raise ConfigError(f"model.contact_model: {cfg['model']['contact_model']!r} is not "
                          "allowed in a zoom; allowed: compliant (a zoom re-simulates with "
                          "compliant contacts)")
    cfg = validate_config(cfg)
    check_run_of_config(cfg)  # memory, step size and contact step, before any work
    return cfg


def start_index(run_ds, time: float) -> int:
    """Index of the last sample of ``run_ds`` strictly before ``time`` [s] (the state before
    the step that ends at ``time``); a one-line ConfigError naming ``time`` when it is not
    inside the run."""
    t = np.asarray(run_ds["time"].values, dtype=float)
    time = float(time)
    if not np.isfinite(time) or time <= t[0] or time > t[-1]:
        raise ConfigError(f"time: {time!r} is not allowed; allowed: a time inside the run, "
                          f"in ({t[0]:.6g}, {t[-1]:.6g}] s")
    return int(np.searchsorted(t, time, side="left") - 1)


def zoom(run_ds, time, window=DEFAULT_WINDOW, dt=DEFAULT_DT, overrides=(), output_dt=None,
         until_released=True, progress=False, watch_contacts=None, watch_onset=None,
         adaptive=True):
    """Re-simulate the whole mechanism with compliant contacts from the state of ``run_ds``
    just before ``time``.

    Parameters
    ----------
    run_ds : xarray.Dataset
        A run (needs ``q`` and ``v`` (time, body, dof) and the ``model.*`` attributes).
    time : float
        Time of interest [s], inside the run; the zoom starts from the last sample before it.
    window : float
        Longest duration of the zoom [s].
    dt : float
        Step of the zoom [s]; with ``adaptive``, its largest step.
    overrides : sequence of str
        ``section.key=value`` settings applied to the zoom (e.g. ``model.youngs_modulus=2.1e11``).
    output_dt : float, optional
        Output interval [s] (default: every step).
    until_released : bool
        Stop early once every contact that closed during the zoom is open again, or with
        ``watch_contacts`` once every watched group's contact episode has ended (checked every
        100 steps).
    watch_contacts, watch_onset : array of bool, optional
        Groups of contacts (nc,) or (groups, nc) and their onset contacts: see
        :meth:`simcore.model.Model.simulate`. :func:`analysis.zoom.add_zoom_forces` watches
        the contacts of the ball of each impact, with the impact's contact as onset.
    adaptive : bool
        Adaptive steps (``solver.adaptive``, the default; docs/compliant.md): each step's size
        from the local error estimate and cut where a contact closes, at most ``dt``, the
        output every ``output_dt`` as with a fixed step (``solver.dt_min`` and
        ``solver.adaptive_tol`` from the run's settings or ``overrides``); False: every step
        ``dt``.

    Returns
    -------
    xarray.Dataset
        A compliant run dataset (``F_N``, ``F_T``, ``Lambda_N``, ``gap_N``, ``q``, ``v``, ...)
        starting at the run's sample before ``time``, with attributes ``zoom_time``,
        ``zoom_start_time`` [s] and ``zoom_source`` (the run's title).

    Raises
    ------
    simcore.ConfigError
        Bad settings or a time outside the run (one line naming the key), before any work.
    """
    from ..io import trajectory_dataset

    traj, model, layout, cfg = zoom_trajectory(
        run_ds, time, window=window, dt=dt, overrides=overrides, output_dt=output_dt,
        until_released=until_released, progress=progress, watch_contacts=watch_contacts,
        watch_onset=watch_onset, adaptive=adaptive)
    ds = trajectory_dataset(traj, model, layout, cfg)
    ds.attrs.update({
        "zoom_time": float(time),
        "zoom_start_time": float(traj.time[0]),
        "zoom_source": str(run_ds.attrs.get("title", "")),
        "solver.output_dt": float(cfg["solver"]["dt"]) * output_every(cfg),
    })
    return ds


def zoom_trajectory(run_ds, time, window=DEFAULT_WINDOW, dt=DEFAULT_DT, overrides=(),
                    output_dt=None, until_released=True, progress=False, watch_contacts=None,
                    watch_onset=None, adaptive=True):
    """:func:`zoom` as plain arrays: (trajectory, model, layout, configuration), the
    :class:`simcore.model.Trajectory` of the zoom with the model, layout and validated
    configuration that made it (what :func:`zoom` turns into its dataset). Same parameters and
    errors as :func:`zoom`; for code that reads a few arrays of many zooms
    (:func:`analysis.zoom.add_zoom_forces`)."""
    from ..io import state_at

    cfg = zoom_config(run_ds, window=window, dt=dt, overrides=overrides, output_dt=output_dt,
                      adaptive=adaptive)
    i = start_index(run_ds, time)
    model, layout = crank_slider(cfg["model"])
    q0, v0 = state_at(run_ds, i)
    if q0.size != 3 * len(model.body_names):
        raise ConfigError("run: its bodies do not match the model its attributes describe")
    t0 = float(run_ds["time"].values[i])
    every = output_every(cfg)
    settings = SolverSettings.from_config(cfg, progress=progress, chunk=max(100, every),
                                          contact_model="compliant")
    release = ReleaseStop(watch_contacts, watch_onset) if until_released else None
    traj = model.simulate(settings, q0=q0, v0=v0, t0=t0, release=release)
    return traj, model, layout, cfg
