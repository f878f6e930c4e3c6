"""I/O layer: the only part of simcore that imports xarray.

Turns the kernels' plain arrays into a CF-style ``xarray.Dataset`` (SPEC section 5) and writes
netCDF atomically (temporary file in the target folder, then ``os.replace``), so that no reader
ever sees a half-written file.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr


def write_netcdf(ds: xr.Dataset, path: str | Path, complevel: int = 4) -> Path:
    """Write ``ds`` to ``path`` atomically, with zlib compression of the float variables.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset to write.
    path : str or Path
        Target file; its folder is created if missing.
    complevel : int
        zlib compression level (0-9).

    Returns
    -------
    Path
        The written path.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    encoding = {}
    for name, var in ds.data_vars.items():
        if var.ndim > 0 and var.dtype.kind in "fiub":
            encoding[name] = {"zlib": True, "complevel": complevel, "shuffle": True}
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        try:
            ds.to_netcdf(tmp, engine="netcdf4", encoding=encoding)
        except (OSError, RuntimeError) as exc:
            _raise_if_disk_full(exc, path, ds.nbytes)
            raise
        # mkstemp creates the file for its owner only; give it the permissions of a file
        # opened the ordinary way (0666 less the umask)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def _raise_if_disk_full(exc: BaseException, path: Path, nbytes: int) -> None:
    """Turn a write failure on a full disk into ``OSError(ENOSPC)`` saying so.

    The netCDF library reports a full disk as "NetCDF: HDF error" (a RuntimeError); the file
    system's free space tells what happened.
    """
    import errno
    import shutil

    full = isinstance(exc, OSError) and exc.errno == errno.ENOSPC
    if not full:
        try:
            free = shutil.disk_usage(path.parent).free
        except OSError:
            return
        full = free < max(nbytes, 1 << 20)
    if full:
        raise OSError(errno.ENOSPC, f"No space left on device while writing {path} "
                      f"({type(exc).__name__}: {exc})") from exc


def _attrs(units: str, long_name: str, **extra) -> dict:
    out = {"units": units, "long_name": long_name}
    out.update(extra)
    return out


__all__ = ["write_netcdf", "np"]


def _flatten(cfg: dict) -> dict:
    out = {}
    for section in ("model", "solver", "analysis"):
        for key, value in cfg.get(section, {}).items():
            if value is None:
                continue
            out[f"{section}.{key}"] = value if not isinstance(value, bool) else int(value)
    return out


def trajectory_dataset(traj, model, layout, cfg: dict) -> xr.Dataset:
    """Turn a :class:`simcore.model.Trajectory` of the crank-slider into the run dataset.

    Every variable declares its dimensions, ``units`` and ``long_name`` here, where it is made.
    """
    from . import __version__

    m = cfg["model"]
    n_balls = int(m["n_balls"])
    nbody = len(model.body_names)
    q = traj.q.reshape(traj.q.shape[0], nbody, 3)
    v = traj.v.reshape(traj.v.shape[0], nbody, 3)
    # bearing journal: outer-race centre minus inner-race centre (vectorised body points)
    def centre(body, point):
        phi = q[:, body, 2]
        c, s = np.cos(phi), np.sin(phi)
        return (q[:, body, 0] + c * point[0] - s * point[1],
                q[:, body, 1] + s * point[0] + c * point[1])

    ax, ay = centre(layout.crank, layout.crank_pin)
    cx, cy = centre(layout.rod, layout.rod_big_end)
    jx, jy = cx - ax, cy - ay
    crank_angle = q[:, layout.crank, 2]
    TC = ("time", "contact")
    compliant = getattr(traj, "contact_model", "nonsmooth") == "compliant"
    data = {
        "Lambda_N": (TC, traj.lambda_N, _attrs(
            "N s", "normal contact impulse of the velocity jump of the step ending at time")),
        "Lambda_T": (TC, traj.lambda_T, _attrs(
            "N s", "tangential contact impulse along t = e_z x n")),
        "nu_N": (TC, traj.nu_N, _attrs(
            "N s^2", "position-correction multiplier of the contact")),
        "gap_N": (TC, traj.gap_N, _attrs("m", "normal gap after the step (negative: penetration)")),
        "vn_pre": (TC, traj.vn_pre, _attrs(
            "m s-1", "normal relative velocity at the start of the step (negative: approaching)")),
        "vn_post": (TC, traj.vn_post, _attrs(
            "m s-1", "normal relative velocity after the velocity jump (negative: approaching)")),
        "vn_free": (TC, traj.vn_free, _attrs(
            "m s-1", "normal relative velocity before the velocity jump: smooth-step velocity "
            "at the corrected position (negative: approaching; t = 0: initial velocity)")),
        "q": (("time", "body", "dof"), q, _attrs(
            "m or rad", "body positions (x [m], y [m], phi [rad]) of the centre of mass")),
        "v": (("time", "body", "dof"), v, _attrs(
            "m s-1 or rad s-1", "body velocities (vx, vy [m/s], omega [rad/s])")),
        "crank_angle": (("time",), crank_angle, _attrs("rad", "crank angle, unwrapped")),
        "slider_x": (("time",), q[:, layout.slider, 0], _attrs("m", "slider position")),
        "slider_v": (("time",), v[:, layout.slider, 0], _attrs("m s-1", "slider velocity")),
        "journal_x": (("time",), jx, _attrs(
            "m", "outer-race centre minus inner-race centre, x (journal orbit)")),
        "journal_y": (("time",), jy, _attrs(
            "m", "outer-race centre minus inner-race centre, y (journal orbit)")),
        "energy": (("time",), traj.energy, _attrs(
            "J", "kinetic + gravitational + cage spring energy")),
        "drive_torque": (("time",), traj.drive_torque, _attrs(
            "N m", "torque of the constant-speed drive (0 for the free drive)")),
        "iterations": (("time", "stage"), traj.iterations.astype(np.int32), _attrs(
            "1", "Newton iterations of each sub-problem of the step")),
        "converged": (("time",), traj.converged.astype(np.int8), _attrs(
            "1", "1 where every sub-problem of the step converged and the step created no "
            "energy (energy audit)")),
    }
    if compliant:
        data.update({
            "Lambda_N": (TC, traj.lambda_N, _attrs(
                "N s", "normal contact impulse over the output interval ending at time "
                "(integral of F dt)")),
            "Lambda_T": (TC, traj.lambda_T, _attrs(
                "N s", "tangential contact impulse over the output interval, along t = e_z x n")),
            "nu_N": (TC, traj.nu_N, _attrs(
                "N s^2", "position-correction multiplier (0: compliant contacts have none)")),
            "gap_N": (TC, traj.gap_N, _attrs(
                "m", "smallest normal gap in the output interval (negative: indentation)")),
            "vn_pre": (TC, traj.vn_pre, _attrs(
                "m s-1", "normal relative velocity at the start of the output interval "
                "(negative: approaching)")),
            "vn_post": (TC, traj.vn_post, _attrs(
                "m s-1", "normal relative velocity at time (negative: approaching)")),
            "vn_free": (TC, traj.vn_free, _attrs(
                "m s-1", "normal relative velocity at time (compliant: no jump, = vn_post)")),
            "F_N": (TC, traj.F_N, _attrs(
                "N", "largest normal contact force in the output interval ending at time")),
            "F_T": (TC, traj.F_T, _attrs(
                "N", "friction force along t = e_z x n at the instant of the largest normal "
                "force of the interval")),
            "energy": (("time",), traj.energy, _attrs(
                "J", "kinetic + gravitational + cage spring + contact elastic energy")),
            "iterations": (("time", "stage"), traj.iterations.astype(np.int32), _attrs(
                "1", "largest Newton iterations per step in the output interval (smooth: "
                "generalized-alpha step with contact forces, position: joint projection, "
                "velocity: 0)")),
        })
    audit = traj.extras.get("energy_audit")
    if audit is not None:
        data["energy_error"] = (("time",), audit.error, _attrs(
            "J", "energy created by the step ending at time: energy change minus drive work "
            "(<= 0 when the step only dissipates)"))
    contact = np.arange(2 * n_balls)
    coords = {
        "time": ("time", traj.time, _attrs("s", "time")),
        "contact": ("contact", contact, {"long_name": "ball-race contact index"}),
        "ball": ("contact", np.concatenate([np.arange(n_balls)] * 2),
                 {"long_name": "ball index"}),
        "race": ("contact", np.array(["inner"] * n_balls + ["outer"] * n_balls, dtype=object),
                 {"long_name": "race of the contact"}),
        "body": ("body", np.array(model.body_names, dtype=object), {"long_name": "body name"}),
        "dof": ("dof", np.array(["x", "y", "phi"], dtype=object),
                {"long_name": "planar degree of freedom"}),
        "stage": ("stage", np.array(["smooth", "position", "velocity"], dtype=object),
                  {"long_name": "sub-problem of the nonsmooth generalized-alpha step"}),
        "clearance": ((), float(m["clearance"]), _attrs("m", "radial clearance")),
        "mu": ((), float(m["mu"]), _attrs("1", "friction coefficient")),
        "omega0": ((), float(m["omega0"]), _attrs("rad s-1", "crank speed")),
        "e_N": ((), float(m["e_N"]), _attrs("1", "normal restitution coefficient")),
    }
    out_every = int(round(cfg["solver"].get("output_dt") / cfg["solver"]["dt"])) if cfg[
        "solver"].get("output_dt") is not None else 1
    attrs = {
        "Conventions": "CF-1.10",
        "title": ("Ball bearing (SKF 6012) in a crank-slider: "
                  + ("compliant (Hertz) contact run" if compliant
                     else "nonsmooth generalized-alpha run")),
        "contact_model": "compliant" if compliant else "nonsmooth",
        "output_interval_s": float(cfg["solver"]["dt"]) * out_every,
        "source": f"bearingsim {__version__} (simcore)",
        "outer_radius": layout.outer_radius,
        "pitch_radius": layout.pitch_radius,
        "initial_cage_speed": layout.cage_speed,
        "initial_ball_spin": layout.ball_spin,
        "position_tolerance_m": cfg["solver"]["tol"] * cfg["solver"]["dt"],
        "contact_set_velocity_problem": "contacts with nu_N > 0 or gap_N <= tol*dt after the "
                                        "position correction",
        "wall_time_s": float(traj.wall_time_s),
        "n_unconverged_steps": int(np.sum(traj.converged == 0)),
    }
    if audit is not None:
        attrs.update(audit.summary(traj.energy))
    attrs.update(_flatten(cfg))
    attrs["solver.output_dt"] = float(cfg["solver"]["dt"]) * out_every
    return xr.Dataset(data, coords=coords, attrs=attrs)
