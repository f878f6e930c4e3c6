"""I/O layer: the only part of simcore that imports xarray.

Turns the kernels' plain arrays into the run dataset and writes netCDF atomically (temporary file
in the target folder, then ``os.replace``), so that no reader ever sees a half-written file.

The files follow the CF conventions (version 1.10), as ``.ci/cf-check`` verifies on every file of
the smoke study:

- every variable has UDUNITS ``units`` and a ``long_name``; a quantity that mixes units is split
  (the generalized coordinates ``q`` = (x, y, phi) become ``position`` [m] and ``angle`` [rad],
  the velocities ``velocity`` [m s-1] and ``angular_velocity`` [rad s-1]; :func:`generalized`
  rebuilds ``q`` and ``v`` for code that wants them);
- no ``_FillValue`` on coordinates;
- labels (``race``, ``body``, ``axis``, ``stage``) are stored as character arrays, which CF reads
  as string labels and xarray gives back as strings (``ds.race == "outer"`` keeps working);
- the swept parameters (``clearance``, ``mu``, ``omega0``, ``e_N``, and in a study every other
  axis of its grid and the contact ``model``, :func:`study_coords`) are coordinates of length-1
  dimensions, so that ``xr.open_mfdataset("results/runs/*.nc", combine="by_coords")`` assembles a
  study's runs into one grid. Read one value with ``ds.clearance.item()``: ``float()`` refuses a
  length-1 array.
"""

from __future__ import annotations

import datetime
import os
import sys
import tempfile
from numbers import Number
from pathlib import Path

import numpy as np
import xarray as xr

from ..config.parameters import BASE_AXES, coordinate_name


def _defer_dask_array_type() -> bool:
    """Let xarray ask for dask's array type without importing ``dask.array`` first.

    xarray checks every Variable it makes (the netCDF encoder makes one per variable written)
    with ``isinstance(data, array_type("dask"))``, and the first check imports ``dask.array``
    to learn that type: 0.15-0.2 s of a new process's first write, for a run that has NumPy
    arrays only. No dask array can exist before ``dask.array`` is imported, so xarray's record
    of dask (``xarray.namedarray.pycompat._cached_duck_array_modules["dask"]``) is given a
    stand-in whose ``type`` is ``dask.array.Array`` once that module is imported (by the user,
    or by xarray for a chunked dataset) and empty until then; anything else asked of it (the
    version) is answered by xarray's own record, made then. The answers are those of xarray's
    record at every moment. Nothing is changed where xarray has made its record already or
    keeps it elsewhere.

    Returns
    -------
    bool
        True when the stand-in was put in place.
    """
    try:
        from xarray.namedarray import pycompat

        cache = pycompat._cached_duck_array_modules
        record = pycompat.DuckArrayModule
    except (ImportError, AttributeError):
        return False
    if not isinstance(cache, dict) or "dask" in cache:
        return False

    class DaskArrayType:
        @property
        def type(self):
            array = getattr(sys.modules.get("dask.array"), "Array", None)
            return (array,) if isinstance(array, type) else ()

        def __getattr__(self, name):
            cache["dask"] = real = record("dask")
            return getattr(real, name)

    cache["dask"] = DaskArrayType()
    return True


DASK_ARRAY_TYPE_DEFERRED = _defer_dask_array_type()

#: CF version the files declare.
CONVENTIONS = "CF-1.10"

#: The paper's four study parameters by coordinate name (``clearance``, ``mu``, ``omega0``,
#: ``e_N``): scalar coordinates of every run file (a study adds its other axes,
#: :func:`study_coords`); names, units and long names come from the registry of swept
#: parameters (:mod:`simcore.config.parameters`).
BASE_PARAMETERS = tuple(coordinate_name(key) for key in BASE_AXES)

#: Data variables of a run file and the type each is stored as (attribute ``storage`` of the
#: variable says it too). float64 where digits matter: the impulses ``Lambda_N`` that the
#: impulse filter thresholds at ``analysis.zero_tol`` of the largest, the crank angle that
#: counts the revolutions of long runs and the energy. float32 (about 7 significant digits)
#: where the analysis needs fewer or the figures only plot, and for the restart state of the
#: compliant zoom (``position``, ``angle``, ``velocity``, ``angular_velocity``): a zoom started
#: from the float32 state gives the largest forces and contact times of the paper case's five
#: largest impacts within 6e-5 (relative) of the zoom from the float64 run in memory, at
#: E = 2.1e9 and 2.1e11 Pa (README, "The run file"). Compliant runs add ``F_N``, ``F_T``;
#: ``energy_error`` comes with the energy audit.
STORAGE = {
    "Lambda_N": "float64", "Lambda_T": "float32", "nu_N": "float32", "gap_N": "float32",
    "vn_pre": "float32", "vn_post": "float32", "vn_free": "float32",
    "position": "float32", "angle": "float32", "velocity": "float32",
    "angular_velocity": "float32", "crank_angle": "float64", "slider_x": "float32",
    "slider_v": "float32", "journal_x": "float32", "journal_y": "float32", "energy": "float64",
    "drive_torque": "float32", "iterations": "int16", "converged": "int8",
    "energy_error": "float32", "F_N": "float32", "F_T": "float32",
}

#: Every data variable a run file can hold (the allowed names of ``study.keep``).
RUN_VARIABLES = tuple(STORAGE)

#: Default of ``study.keep``: what the impact analysis (``Lambda_N``, ``vn_free``,
#: ``converged``), the compliant zoom (the restart state), the summary (``iterations``,
#: ``crank_angle``), the figures (``slider_x``, ``journal_x``, ``journal_y``) and the README's
#: examples read; ``F_N`` for compliant runs.
DEFAULT_KEEP = ("Lambda_N", "vn_free", "position", "angle", "velocity", "angular_velocity",
                "crank_angle", "slider_x", "journal_x", "journal_y", "iterations", "converged",
                "F_N")

__all__ = ["write_netcdf", "trajectory_dataset", "dataset_of_arrays", "failed_run_dataset",
           "generalized", "open_run", "parameter_coords", "study_coords", "history_line",
           "keep_variables", "CONVENTIONS", "BASE_PARAMETERS", "STORAGE", "RUN_VARIABLES",
           "DEFAULT_KEEP"]


def _is_text(var: xr.Variable) -> bool:
    if var.dtype.kind in "US":
        return True
    if var.dtype.kind == "O" and var.size:
        return all(isinstance(x, str) for x in np.asarray(var.values).ravel())
    return False


def keep_variables(ds: xr.Dataset, keep=None) -> xr.Dataset:
    """The run dataset with only the data variables named in ``keep`` (``study.keep``).

    Names of :data:`RUN_VARIABLES` that ``ds`` lacks (``F_N`` of a nonsmooth run) are skipped;
    variables that are not run variables (those of other datasets) are kept.

    Raises
    ------
    ValueError
        For a name that is not a run variable, naming the key and the allowed names.
    """
    if keep is None:
        return ds
    unknown = [name for name in keep if name not in STORAGE]
    if unknown:
        raise ValueError(f"study.keep: {unknown[0]!r} is not allowed; allowed: "
                         + ", ".join(RUN_VARIABLES))
    drop = [name for name in ds.data_vars if name in STORAGE and name not in keep]
    return ds.drop_vars(drop)


def write_netcdf(ds: xr.Dataset, path: str | Path, complevel: int = 4, keep=None) -> Path:
    """Write ``ds`` to ``path`` atomically, with zlib compression of the data variables.

    Coordinates are written without ``_FillValue`` and text variables as character arrays (both
    as CF asks; a text variable keeps a ``dtype`` its own encoding names). A data variable whose
    ``encoding`` names a ``dtype`` (the run variables, :data:`STORAGE`) is stored as that type.
    A data variable along ``time`` is chunked per time series (one chunk per contact, body and
    axis), which compresses the smooth series better than whole rows.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset to write.
    path : str or Path
        Target file; its folder is created if missing.
    complevel : int
        zlib compression level (0-9).
    keep : sequence of str, optional
        Data variables of a run to write (``study.keep``, see :func:`keep_variables`); None:
        all.

    Returns
    -------
    Path
        The written path.
    """
    path = Path(path)
    ds = keep_variables(ds, keep)
    path.parent.mkdir(parents=True, exist_ok=True)
    encoding = netcdf_encoding(ds, complevel)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        try:
            to_netcdf4(ds, tmp, encoding)
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


def netcdf_encoding(ds: xr.Dataset, complevel: int = 4) -> dict:
    """The ``encoding`` argument with which :func:`write_netcdf` writes ``ds`` (see there)."""
    encoding = {}
    for name, var in ds.variables.items():
        enc = {}
        text = _is_text(var)
        if text and "dtype" not in var.encoding:
            enc["dtype"] = "S1"
        if name in ds.coords and not text:
            enc["_FillValue"] = None  # CF: coordinates have no missing values
        if name in ds.data_vars and var.ndim > 0 and (var.dtype.kind in "fiub" or text):
            enc.update(zlib=True, complevel=complevel, shuffle=True)
            if var.encoding.get("dtype") is not None and not text:
                enc["dtype"] = var.encoding["dtype"]
            if var.dims[0] == "time" and not text:
                enc["chunksizes"] = (max(1, var.shape[0]),) + (1,) * (var.ndim - 1)
        if enc:
            encoding[name] = enc
    return encoding


_ATTRIBUTE_TYPES = (str, Number, np.ndarray, np.number, list, tuple, bytes)


def _plainly_writable(ds: xr.Dataset) -> bool:
    """True when no variable of ``ds`` is chunked (a dask array), ``ds`` names no unlimited
    dimension, and its names and attributes are of the kinds ``to_netcdf`` accepts (non-empty
    strings; numbers, strings, arrays, lists)."""
    if ds.encoding.get("unlimited_dims") is not None:
        return False
    for name, var in ds.variables.items():
        if not isinstance(name, str) or not name or var.chunks is not None:
            return False
    for attrs in [ds.attrs] + [var.attrs for var in ds.variables.values()]:
        for key, value in attrs.items():
            if not isinstance(key, str) or not key or not isinstance(value, _ATTRIBUTE_TYPES):
                return False
    return True


def to_netcdf4(ds: xr.Dataset, target: str | Path, encoding: dict) -> None:
    """``ds.to_netcdf(target, engine="netcdf4", encoding=encoding)``, the same file written
    with less to import, for a ``target`` that nothing else writes meanwhile (the fresh
    temporary file of :func:`write_netcdf`).

    ``Dataset.to_netcdf`` asks dask twice which scheduler is active: to decide whether to close
    the file between the writes of chunked arrays, and to choose the kind of lock that guards
    the file (a ``distributed`` lock under a ``distributed`` client). Asking imports
    ``distributed`` when it is installed: 0.15-0.3 s in a new process, for a dataset without
    chunked arrays, which neither question concerns. For such a dataset
    (:func:`_plainly_writable`) this opens xarray's netCDF4 store as ``to_netcdf`` does (mode
    "w", the default format) with the locks ``to_netcdf`` takes in a process without a
    ``distributed`` client (the netCDF library's and one for the file) and stores the dataset
    in it with ``Dataset.dump_to_store``, the step ``to_netcdf`` takes next, which writes the
    arrays there and then. Any other dataset (dask arrays, unlimited dimensions, names or
    attributes ``to_netcdf`` would refuse), or an xarray whose internals differ, goes through
    ``to_netcdf`` itself.
    """
    target = os.fspath(target)
    try:
        from xarray.backends import NetCDF4DataStore
        from xarray.backends.locks import SerializableLock, combine_locks
        from xarray.backends.netCDF4_ import NETCDF4_PYTHON_LOCK
    except ImportError:
        NetCDF4DataStore = None
    if NetCDF4DataStore is None or not _plainly_writable(ds):
        ds.to_netcdf(target, engine="netcdf4", encoding=encoding)
        return
    lock = combine_locks([NETCDF4_PYTHON_LOCK, SerializableLock(target)])
    store = NetCDF4DataStore.open(target, mode="w", format=None, lock=lock)
    try:
        ds.dump_to_store(store, encoding=encoding)
    finally:
        store.close()


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


def history_line(what: str) -> str:
    """One CF ``history`` line: UTC time stamp, package and version, what made the file."""
    from .. import __version__

    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    return f"{stamp} bearingsim {__version__}: {what}"


def parameter_coords(values: dict, length_one: bool = True) -> dict:
    """Coordinates of swept parameters, with their units and long names (a category as its
    int8 code with ``flag_values``/``flag_meanings``), from the registry of swept parameters
    (:mod:`simcore.config.parameters`).

    Parameters
    ----------
    values : dict
        ``{"clearance": 4e-4, "model.cage_stiffness": 1e5, "solver_dt": 1e-4, ...}``: keys
        as a sweep writes them or coordinate names; keys that are not sweepable are ignored.
    length_one : bool
        True: each as the coordinate of a length-1 dimension of the same name (run files, so
        that ``open_mfdataset(..., combine="by_coords")`` works); False: scalar coordinates.

    Returns
    -------
    dict
        ``{name: (dims, values, attrs)}`` for ``xarray.Dataset(coords=...)``.
    """
    from ..config.parameters import canonical, registry

    params = registry()
    out = {}
    for key, value in values.items():
        full = canonical(key, params)
        if full is None:
            continue
        param = params[full]
        data = param.stored(value)
        out[param.name] = (((param.name,), [data]) if length_one else ((), data)) + (
            param.attrs(),)
    return out


def study_coords(ds: xr.Dataset, point: dict, axes, length_one: bool = True) -> xr.Dataset:
    """``ds`` with a study's coordinates: every value of ``point`` (``{sweep key: value}``,
    the grid point and ``model.contact_model``) as a coordinate (:func:`parameter_coords`),
    and the global attribute ``study_axes``, the coordinate names of the study's grid axes
    in order (space-separated), which the summary's dimensions follow."""
    from ..config.parameters import parameter

    ds = ds.assign_coords(parameter_coords(point, length_one=length_one))
    ds.attrs["study_axes"] = " ".join(parameter(key).name for key in axes)
    return ds


def _base(model: dict) -> dict:
    return {key: model[key] for key in BASE_PARAMETERS}


def _flatten(cfg: dict) -> dict:
    out = {}
    for section in ("model", "solver", "analysis"):
        for key, value in cfg.get(section, {}).items():
            if value is None:
                continue
            out[f"{section}.{key}"] = value if not isinstance(value, bool) else int(value)
    return out


def _global_attrs(cfg: dict, title: str, what: str) -> dict:
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
    attrs.update(_flatten(cfg))
    return attrs


def trajectory_dataset(traj, model, layout, cfg: dict, compile_time_s: float = 0.0) -> xr.Dataset:
    """Turn a :class:`simcore.model.Trajectory` of the crank-slider into the run dataset.

    Every variable declares its dimensions, ``units`` and ``long_name`` here, where it is made.

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
        ``compile_time_s``; ``wall_time_s`` is the integration alone).
    """
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
    TBA = ("time", "body", "axis")
    TB = ("time", "body")
    data = {
        "Lambda_N": (TC, traj.lambda_N, _attrs(
            "N s", "normal contact impulse of the velocity jump of the step ending at time")),
        "Lambda_T": (TC, traj.lambda_T, _attrs(
            "N s", "tangential contact impulse along t = e_z x n")),
        "nu_N": (TC, traj.nu_N, _attrs(
            "N s2", "position-correction multiplier of the contact")),
        "gap_N": (TC, traj.gap_N, _attrs("m", "normal gap after the step (negative: penetration)")),
        "vn_pre": (TC, traj.vn_pre, _attrs(
            "m s-1", "normal relative velocity at the start of the step (negative: approaching)")),
        "vn_post": (TC, traj.vn_post, _attrs(
            "m s-1", "normal relative velocity after the velocity jump (negative: approaching)")),
        "vn_free": (TC, traj.vn_free, _attrs(
            "m s-1", "normal relative velocity before the velocity jump: smooth-step velocity "
            "at the corrected position (negative: approaching; t = 0: initial velocity)")),
        "position": (TBA, q[:, :, :2], _attrs("m", "position of the body's centre of mass")),
        "angle": (TB, q[:, :, 2], _attrs("rad", "rotation angle of the body, unwrapped")),
        "velocity": (TBA, v[:, :, :2], _attrs("m s-1", "velocity of the body's centre of mass")),
        "angular_velocity": (TB, v[:, :, 2], _attrs("rad s-1", "angular velocity of the body")),
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
            "energy (energy audit)",
            flag_values=np.array([0, 1], dtype=np.int8), flag_meanings="no yes")),
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
    if int(np.max(traj.iterations, initial=0)) > np.iinfo(np.int16).max:
        storage = dict(STORAGE, iterations="int32")
    else:
        storage = STORAGE
    for name, (*_, attrs) in data.items():
        attrs["storage"] = storage[name]
    contact = np.arange(2 * n_balls)
    coords = {
        "time": ("time", traj.time, _attrs("s", "time since the start of the run")),
        "contact": ("contact", contact, _attrs(
            "1", "ball-race contact index (balls 0..n-1 on the inner race, then on the outer "
                 "race)")),
        "ball": ("contact", np.concatenate([np.arange(n_balls)] * 2),
                 _attrs("1", "ball index of the contact")),
        "race": ("contact", np.array(["inner"] * n_balls + ["outer"] * n_balls),
                 {"long_name": "race of the contact (inner or outer)"}),
        "body": ("body", np.array(model.body_names), {"long_name": "body name"}),
        "axis": ("axis", np.array(["x", "y"]),
                 {"long_name": "axis of the plane (x along the slider, y across)"}),
        "stage": ("stage", np.array(["smooth", "position", "velocity"]),
                  {"long_name": "sub-problem of the nonsmooth generalized-alpha step"}),
    }
    out_every = int(round(cfg["solver"].get("output_dt") / cfg["solver"]["dt"])) if cfg[
        "solver"].get("output_dt") is not None else 1
    coords.update(parameter_coords(_base(m)))
    kind = "compliant (Hertz) contact run" if compliant else "nonsmooth generalized-alpha run"
    attrs = _global_attrs(
        cfg, f"Ball bearing (SKF 6012) in a crank-slider: {kind}",
        f"simcore.run, {m['contact_model']} contacts, {m['drive']} drive, "
        f"t_end = {cfg['solver']['t_end']} s, dt = {cfg['solver']['dt']} s")
    attrs.update({
        "contact_model": "compliant" if compliant else "nonsmooth",
        "output_interval_s": float(cfg["solver"]["dt"]) * out_every,
        "outer_radius": layout.outer_radius,
        "pitch_radius": layout.pitch_radius,
        "initial_cage_speed": layout.cage_speed,
        "initial_ball_spin": layout.ball_spin,
        "position_tolerance_m": cfg["solver"]["tol"] * cfg["solver"]["dt"],
        "contact_set_velocity_problem": "contacts with nu_N > 0 or gap_N <= tol*dt after the "
                                        "position correction",
        "wall_time_s": float(traj.wall_time_s),
        "compile_time_s": float(compile_time_s),
        "n_unconverged_steps": int(np.sum(traj.converged == 0)),
    })
    if audit is not None:
        attrs.update(audit.summary(traj.energy))
    attrs["solver.output_dt"] = float(cfg["solver"]["dt"]) * out_every
    ds = dataset_of_arrays(data, coords, attrs)
    for name in data:
        ds[name].encoding["dtype"] = np.dtype(storage[name])
    return ds


def dataset_of_arrays(data: dict, coords: dict, attrs: dict) -> xr.Dataset:
    """``xr.Dataset(data, coords=coords, attrs=attrs)`` for entries ``(dims, values[, attrs])``
    whose values are NumPy arrays, lists or numbers: the same dataset, built a faster way.

    The ordinary constructor asks of every value whether it is a dask array, which imports
    ``dask.array`` (0.2-0.3 s), and of every dimension coordinate whether it is a dask
    collection, which imports ``dask`` (about 0.1 s); a run has NumPy arrays only, and the
    first run in a new process would pay for both imports. Here each entry becomes an
    ``xr.Variable`` made on xarray's fast path (which takes a NumPy array as it is), and each
    dimension coordinate gets the index the ordinary constructor gives it, a
    ``xarray.indexes.PandasIndex`` of ``pandas.Index(values)`` that keeps the coordinate's
    dtype, with its variable made by that index. Values of dtype object, datetime, timedelta
    or float16 (which the ordinary constructor converts) go to the ordinary constructor.
    """
    import pandas as pd

    def variable(spec):
        dims, values, *rest = spec
        values = np.asarray(values)
        if values.dtype.kind in "OMm" or values.dtype == np.float16:
            return None
        return xr.Variable(dims, values, rest[0] if rest else None, fastpath=True)

    data_vars = {k: variable(v) for k, v in data.items()}
    coord_vars = {k: variable(v) for k, v in coords.items()}
    if any(v is None for v in (*data_vars.values(), *coord_vars.values())):
        return xr.Dataset(data, coords=coords, attrs=attrs)
    indexes = {}
    for name, var in list(coord_vars.items()):
        if var.dims == (name,):  # a dimension coordinate
            index = xr.indexes.PandasIndex(pd.Index(var.values), name, coord_dtype=var.dtype)
            indexes[name] = index
            coord_vars.update(index.create_variables({name: var}))
    return xr.Dataset(data_vars, coords=xr.Coordinates(coord_vars, indexes=indexes),
                      attrs=attrs)


def failed_run_dataset(cfg: dict, message: str) -> xr.Dataset:
    """The small file that stands for a run whose solver failed (attribute ``failed = 1``).

    It has the run's parameter coordinates (length-1 dimensions, as a run file), every setting
    and the error message, so that the study's summary shows the point as missing.
    """
    attrs = _global_attrs(cfg, "failed run of the bearing study",
                          f"simcore.run failed: {message}")
    attrs.update({"failed": 1, "error": message})
    return xr.Dataset(coords=parameter_coords(_base(cfg["model"])), attrs=attrs)


#: The run-file variables that make up ``q`` and ``v`` (:func:`generalized`).
GENERALIZED_PARTS = {"q": ("position", "angle"), "v": ("velocity", "angular_velocity")}


def generalized(ds: xr.Dataset) -> xr.Dataset:
    """Add the generalized coordinates ``q`` and velocities ``v`` (time, body, dof) to a run.

    ``dof`` is (x, y, phi): ``q`` stacks ``position`` [m] and ``angle`` [rad], ``v`` stacks
    ``velocity`` [m s-1] and ``angular_velocity`` [rad s-1], as the kernels order them. The two
    variables mix units, so they live in memory only (the files keep the split variables).
    """
    def stack(lin, rot, long_name):
        lin = lin.transpose("time", "body", "axis")
        rot = rot.transpose("time", "body")
        values = np.concatenate([lin.values, rot.values[..., None]], axis=-1)
        return xr.DataArray(values, dims=("time", "body", "dof"),
                            coords={"time": ds["time"], "body": ds["body"],
                                    "dof": ["x", "y", "phi"]},
                            attrs={"long_name": long_name})

    q = stack(*(ds[p] for p in GENERALIZED_PARTS["q"]),
              "positions x [m], y [m] and angle phi [rad]")
    v = stack(*(ds[p] for p in GENERALIZED_PARTS["v"]),
              "velocities vx, vy [m s-1] and angular velocity omega [rad s-1]")
    return ds.assign(q=q, v=v)


def state_at(ds: xr.Dataset, i: int) -> tuple[np.ndarray, np.ndarray]:
    """The generalized coordinates and velocities (n,) of sample ``i`` of a run, in the
    kernels' order (x, y, phi of each body): from ``q`` and ``v`` where the run has them, else
    from their parts (:data:`GENERALIZED_PARTS`), without stacking the whole run as
    :func:`generalized` does."""
    def one(name):
        if name in ds:
            return np.asarray(ds[name].isel(time=i).values, dtype=float).ravel()
        lin, rot = GENERALIZED_PARTS[name]
        lin = ds[lin].isel(time=i).transpose("body", "axis").values
        rot = ds[rot].isel(time=i).transpose("body").values
        return np.concatenate([lin, rot[:, None]], axis=1).astype(float).ravel()

    return one("q"), one("v")


def open_run(path: str | Path) -> xr.Dataset:
    """Open a run file (in memory) with ``q`` and ``v`` added (:func:`generalized`)."""
    with xr.open_dataset(path) as ds:
        ds = ds.load()
    if int(ds.attrs.get("failed", 0)):
        return ds
    return generalized(ds)
