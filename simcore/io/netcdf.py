"""Atomic netCDF writing of run files and the other files of a study.

:func:`write_netcdf` writes to a temporary file in the target folder and renames it into place
(``os.replace``), so that no reader ever sees a half-written file; a failed write leaves nothing
behind, and a full disk is reported as such. The file's data reach the disk before the rename
and the rename before the function returns (:func:`replace_durably`), so that a machine that
goes down just after cannot leave an empty file in the place of a written one.
"""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import xarray as xr

from ..startup.patches import to_netcdf4
from .variables import RUN_VARIABLES, STORAGE


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


def _umask() -> int:
    """The process's umask, read without setting it where the system tells it (Linux's
    /proc/self/status): setting and restoring it would race with a write in another thread,
    which could then restore 0 for good."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)  # (elsewhere: set and restored at once)
    os.umask(mask)
    return mask


def replace_durably(tmp: str | Path, path: str | Path) -> None:
    """Rename the written file ``tmp`` to ``path`` (``os.replace``, atomic in one folder), its
    data flushed to the disk first and the folder's entry after: without the first, a file
    system that orders metadata before data may keep the rename and lose the data."""
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, path)
    try:
        folder = os.open(Path(path).parent, os.O_RDONLY)
    except OSError:  # a folder that cannot be opened (not on Linux): the rename stands
        return
    try:
        os.fsync(folder)
    except OSError:
        pass
    finally:
        os.close(folder)


@contextmanager
def replacing(path: str | Path, mode: int | None = None):
    """A temporary file in ``path``'s folder to write, renamed onto ``path``
    (:func:`replace_durably`) when the ``with`` block ends, removed if it raises: a reader
    sees the old file or the new one, never a part.

    Parameters
    ----------
    path : str or Path
        The file to replace (or create).
    mode : int, optional
        Permission bits of the new file; default: those of a file opened the ordinary way
        (0666 less the umask; ``mkstemp`` makes it its owner's only).

    Yields
    ------
    str
        The temporary file's path (it exists, empty).
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask() if mode is None else mode)
        replace_durably(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


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
    with replacing(path) as tmp:
        try:
            to_netcdf4(ds, tmp, encoding)
        except (OSError, RuntimeError) as exc:
            _raise_if_disk_full(exc, path, ds.nbytes)
            raise
    return path


def update_attributes(path: str | Path, values: dict, drop=()) -> Path:
    """Set and remove global attributes of the netCDF file ``path`` atomically: a copy of the
    file in its folder is edited (netCDF4, the data untouched) and renamed into place, so that
    the file on disk is always either the old one or the new one.

    Parameters
    ----------
    path : str or Path
        An existing netCDF4 file.
    values : dict
        Attributes to set (``name: value``, a value netCDF can hold: a number, a string, a 1-D
        array).
    drop : iterable of str
        Attributes to remove where present (before ``values`` are set).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OSError
        ``ENOSPC``, saying so and naming ``path``, where the disk is full (``path`` is then
        unchanged, as on any failure).
    """
    import shutil

    import netCDF4

    path = Path(path)
    with replacing(path, mode=os.stat(path).st_mode & 0o777) as tmp:
        try:
            shutil.copyfile(path, tmp)
            with netCDF4.Dataset(tmp, "a") as nc:
                for name in drop:
                    if name in nc.ncattrs():
                        nc.delncattr(name)
                for name, value in values.items():
                    nc.setncattr(name, value)
        except (OSError, RuntimeError) as exc:
            _raise_if_disk_full(exc, path, os.stat(path).st_size)
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
