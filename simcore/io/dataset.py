"""The run dataset, assembled in named stages from a :class:`simcore.model.Trajectory`.

:func:`trajectory_dataset` computes the values (contact series, body states, the mechanism's
derived series, energy and solver records), takes every variable's dimensions and attributes from
the registry (:mod:`simcore.io.variables`), adds the coordinates and the global attributes (every
setting of the run, the bearing's derived geometry, the run's timings and its energy audit).
"""

from __future__ import annotations

import datetime

import numpy as np
import xarray as xr

from ..config import output_every
from ..startup.patches import dataset_of_arrays
from .variables import (
    CONVENTIONS,
    COORDINATES,
    GUARD_COORDINATE,
    STAGES,
    STORAGE,
    VARIABLES,
    base_parameters,
    parameter_coords,
)


def trajectory_dataset(traj, model, layout, cfg: dict, compile_time_s: float = 0.0) -> xr.Dataset:
    """Turn a :class:`simcore.model.Trajectory` of the crank-slider into the run dataset.

    Parameters
    ----------
    traj : simcore.model.Trajectory
        Plain arrays of the run.
    model, layout
        The model and its layout (:func:`simcore.model.mechanism.crank_slider`).
    cfg : dict
        The validated configuration.
    compile_time_s : float
        Seconds spent compiling or loading the Numba kernels before the run (attribute
        ``compile_time_s``; ``wall_time_s`` is the integration alone) [s].

    Returns
    -------
    xarray.Dataset
        Variables of :data:`simcore.io.variables.VARIABLES`, each with its ``encoding["dtype"]``
        set to its stored type.
    """
    compliant = getattr(traj, "contact_model", "nonsmooth") == "compliant"
    nbody = len(model.body_names)
    # the ball-race contacts along `contact`, the guard contacts apart (their own variables)
    guards = traj.contact_columns(slice(layout.n_race_contacts, None))
    traj = traj.contact_columns(slice(0, layout.n_race_contacts))
    q = traj.q.reshape(traj.q.shape[0], nbody, 3)
    v = traj.v.reshape(traj.v.shape[0], nbody, 3)
    values = contact_series(traj)
    values.update(body_states(q, v))
    values.update(mechanism_series(q, v, layout))
    values.update(solver_records(traj))
    if compliant:
        values.update(F_N=traj.F_N, F_T=traj.F_T)
    if layout.guards:
        values.update(guard_series(guards, compliant))
    audit = traj.extras.get("energy_audit")
    if audit is not None:
        values["energy_error"] = audit.error
    adaptive = traj.extras.get("adaptive")
    if adaptive is not None:
        values["steps"] = adaptive["row_steps"].astype(np.int32)
    storage = stored_types(traj.iterations)
    data = {name: (VARIABLES[name].dims, value,
                   VARIABLES[name].attrs(compliant, storage[name]))
            for name, value in values.items()}
    coords = run_coordinates(traj.time, int(cfg["model"]["n_balls"]), model.body_names)
    coords.update(parameter_coords(base_parameters(cfg["model"])))
    if layout.guards:
        coords["guard"] = (GUARD_COORDINATE.dim, np.array(layout.guards),
                           GUARD_COORDINATE.attrs())
    attrs = run_attributes(traj, layout, cfg, compile_time_s, compliant)
    attrs.update(guard_attributes(guards, layout))
    ds = dataset_of_arrays(data, coords, attrs)
    for name in data:
        ds[name].encoding["dtype"] = np.dtype(storage[name])
    return ds


def contact_series(traj) -> dict:
    """Per-contact series (time, contact) of the run, by variable name."""
    return {"Lambda_N": traj.lambda_N, "Lambda_T": traj.lambda_T, "nu_N": traj.nu_N,
            "gap_N": traj.gap_N, "vn_pre": traj.vn_pre, "vn_post": traj.vn_post,
            "vn_free": traj.vn_free}


def guard_series(guards, compliant: bool) -> dict:
    """Series (time, guard) of the guard contacts, from the trajectory's guard columns."""
    values = {"guard_Lambda_N": guards.lambda_N, "guard_gap_N": guards.gap_N}
    if compliant:
        values["guard_F_N"] = guards.F_N
    return values


def guard_attributes(guards, layout) -> dict:
    """What the guard contacts and the integrity checks did: ``guard_ball_ball_closed_samples``
    and ``guard_rings_closed_samples`` (output samples where a guard of that kind carries a
    load; absent without guards) and ``integrity_violations`` (flagged samples per integrity
    check, or ``none``)."""
    counts = guards.extras.get("integrity", {})
    attrs = {"integrity_violations": "; ".join(f"{name}: {n} samples"
                                               for name, n in counts.items()) or "none"}
    if layout.guards:
        loaded = guards.lambda_N > 0.0
        rings = np.array([name == "rings" for name in layout.guards])
        attrs["guard_ball_ball_closed_samples"] = int(loaded[:, ~rings].any(axis=1).sum())
        attrs["guard_rings_closed_samples"] = int(loaded[:, rings].any(axis=1).sum())
    return attrs


def body_states(q: np.ndarray, v: np.ndarray) -> dict:
    """Positions and velocities split by units from q, v (time, body, dof: x, y, phi)."""
    return {"position": q[:, :, :2], "angle": q[:, :, 2],
            "velocity": v[:, :, :2], "angular_velocity": v[:, :, 2]}


def mechanism_series(q: np.ndarray, v: np.ndarray, layout) -> dict:
    """The crank-slider's derived series: crank angle, slider motion and the journal orbit
    (outer-race centre minus inner-race centre)."""
    def centre(body, point):
        phi = q[:, body, 2]
        c, s = np.cos(phi), np.sin(phi)
        return (q[:, body, 0] + c * point[0] - s * point[1],
                q[:, body, 1] + s * point[0] + c * point[1])

    ax, ay = centre(layout.crank, layout.crank_pin)
    cx, cy = centre(layout.rod, layout.rod_big_end)
    return {"crank_angle": q[:, layout.crank, 2], "slider_x": q[:, layout.slider, 0],
            "slider_v": v[:, layout.slider, 0], "journal_x": cx - ax, "journal_y": cy - ay}


def solver_records(traj) -> dict:
    """Energy, drive torque and the solver's iterations, convergence flags and halvings."""
    halvings = traj.halvings if traj.halvings is not None else np.zeros_like(traj.converged)
    return {"energy": traj.energy, "drive_torque": traj.drive_torque,
            "iterations": traj.iterations.astype(np.int32),
            "converged": traj.converged.astype(np.int8),
            "halvings": halvings.astype(np.int8)}


def n_retried_steps(traj) -> int:
    """Steps of the run taken again as substeps after a failure (halvings > 0; of a compliant
    run, the output intervals holding such a step)."""
    return 0 if traj.halvings is None else int(np.count_nonzero(traj.halvings))


def stored_types(iterations: np.ndarray) -> dict:
    """:data:`~simcore.io.variables.STORAGE`, with ``iterations`` as int32 where a count
    exceeds int16."""
    if int(np.max(iterations, initial=0)) > np.iinfo(np.int16).max:
        return dict(STORAGE, iterations="int32")
    return STORAGE


def run_coordinates(time: np.ndarray, n_balls: int, body_names) -> dict:
    """The coordinates of a run but the swept parameters: time [s], the contacts (ball, race),
    the bodies, the plane's axes and the step's stages."""
    values = {
        "time": time,
        "contact": np.arange(2 * n_balls),
        "ball": np.concatenate([np.arange(n_balls)] * 2),
        "race": np.array(["inner"] * n_balls + ["outer"] * n_balls),
        "body": np.array(body_names),
        "axis": np.array(["x", "y"]),
        "stage": np.array(STAGES),
    }
    return {name: (coord.dim, values[name], coord.attrs())
            for name, coord in COORDINATES.items()}


def run_attributes(traj, layout, cfg: dict, compile_time_s: float, compliant: bool) -> dict:
    """Global attributes of a run: the file's description, every setting, the bearing's derived
    geometry, the run's timings and convergence, and the energy audit's summary."""
    m, solver = cfg["model"], cfg["solver"]
    kind = "compliant (Hertz) contact run" if compliant else "nonsmooth generalized-alpha run"
    attrs = global_attributes(
        cfg, f"Ball bearing {m['bearing']} in a crank-slider: {kind}",
        f"simcore.run, {m['contact_model']} contacts, {m['drive']} drive, "
        f"t_end = {solver['t_end']} s, dt = {solver['dt']} s")
    output_interval_s = float(solver["dt"]) * output_every(cfg)
    attrs.update({
        "contact_model": "compliant" if compliant else "nonsmooth",
        "output_interval_s": output_interval_s,
        "outer_radius": layout.outer_radius,
        "pitch_radius": layout.pitch_radius,
        "initial_cage_speed": layout.cage_speed,
        "initial_ball_spin": layout.ball_spin,
        "position_tolerance_m": solver["tol"] * solver["dt"],
        "contact_set_velocity_problem": "contacts with nu_N > 0 or gap_N <= tol*dt after the "
                                        "position correction",
        "wall_time_s": float(traj.wall_time_s),
        "compile_time_s": float(compile_time_s),
        "n_unconverged_steps": int(np.sum(traj.converged == 0)),
        "n_retried_steps": n_retried_steps(traj),
    })
    audit = traj.extras.get("energy_audit")
    if audit is not None:
        attrs.update(audit.summary(traj.energy))
    steps = traj.extras.get("adaptive")
    if steps is not None:  # adaptive steps: how many, how many redone, the smallest
        attrs.update({k: v for k, v in steps.items() if k != "row_steps"})
    attrs["solver.output_dt"] = output_interval_s
    return attrs


def history_line(what: str) -> str:
    """One CF ``history`` line: UTC time stamp, package and version, what made the file."""
    from .. import __version__

    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    return f"{stamp} bearingsim {__version__}: {what}"


def setting_attribute(value):
    """A setting as a netCDF attribute value: a boolean as 0/1 (netCDF has no boolean
    attribute), anything else as it is."""
    return int(value) if isinstance(value, bool | np.bool_) else value


def flat_settings(cfg: dict) -> dict:
    """Every set value of the model, solver and analysis sections as ``section.key``
    attributes (booleans as 0/1, unset values left out)."""
    out = {}
    for section in ("model", "solver", "analysis"):
        for key, value in cfg.get(section, {}).items():
            if value is None:
                continue
            out[f"{section}.{key}"] = setting_attribute(value)
    return out


def global_attributes(cfg: dict, title: str, what: str) -> dict:
    """The CF global attributes every file of a run has, then its settings
    (:func:`flat_settings`)."""
    from .. import __version__

    attrs = {
        "Conventions": CONVENTIONS,
        "title": title,
        "source": f"bearingsim {__version__} (simcore)",
        "history": history_line(what),
        "references": "Sanchez, Cardona and Cavalieri, Simulacion de un rodamiento de bolas en "
                      "un mecanismo considerando efectos de impacto y friccion; Flores et al. "
                      "(2011) for the peak contact forces",
        "comment": "Global attributes named section.key hold every setting of the run.",
    }
    attrs.update(flat_settings(cfg))
    return attrs


def failed_run_dataset(cfg: dict, message: str) -> xr.Dataset:
    """The small file that stands for a run whose solver failed (attribute ``failed = 1``).

    It has the run's parameter coordinates (length-1 dimensions, as a run file), every setting
    and the error message, so that the study's summary shows the point as missing.
    """
    attrs = global_attributes(cfg, "failed run of the bearing study",
                              f"simcore.run failed: {message}")
    attrs.update({"failed": 1, "error": message})
    return xr.Dataset(coords=parameter_coords(base_parameters(cfg["model"])), attrs=attrs)
