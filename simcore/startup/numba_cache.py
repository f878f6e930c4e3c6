"""Key Numba's on-disk cache by the kernel sources, so that it cannot serve stale code.

Numba checks a cached function against the modification time and size of the file that defines
it, not against the functions it calls. With the kernels split over several modules, an edit to
a callee (say ``contact.py``) would leave the cached machine code of its callers (say
``nonsmooth_step.py``) in use. :func:`configure_cache` therefore points ``numba.config.CACHE_DIR``
at a folder named after a SHA-1 of every kernel source file, before any kernel is compiled: any
edit anywhere in the kernels gives a new folder and a fresh compilation.

The folder is also named by the state of the start-up patch ``numba_internal_kernels``
(:func:`simcore.startup.patches.internal_njit`): with it, kernels that only kernels call are
cached without a Python entry, which a process with the patch off would look for
(:func:`all_entries`).

This module must not import any kernel module; :mod:`simcore.kernels` calls it first.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

KERNELS_DIR = Path(__file__).parent.parent / "kernels"


def kernel_source_key(folder: str | Path = KERNELS_DIR, length: int = 12) -> str:
    """SHA-1 (hex, first ``length`` digits) of the names and contents of the ``*.py`` files of
    ``folder``, in sorted order."""
    digest = hashlib.sha1()
    for path in sorted(Path(folder).glob("*.py")):
        digest.update(path.name.encode())
        digest.update(b"\0")
        digest.update(path.read_bytes())
        digest.update(b"\0")
    return digest.hexdigest()[:length]


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(folder, os.W_OK)


#: the name the cache folder adds where every kernel has a Python entry (start-up patch
#: ``numba_internal_kernels`` off)
ENTRIES = "python-entries"


def all_entries() -> bool:
    """Whether every kernel is compiled with a Python entry (patch ``numba_internal_kernels``
    off), so that the cache folder's name says :data:`ENTRIES`."""
    from .patches import enabled

    return not enabled("numba_internal_kernels")


def cache_dir_for(folder: str | Path = KERNELS_DIR) -> Path:
    """The cache folder for the sources in ``folder``: ``<folder>/__pycache__/numba-<key>``, or
    ``~/.cache/bearingsim/numba-<key>`` when the package folder is read-only (``<key>-``
    :data:`ENTRIES` where :func:`all_entries`)."""
    key = kernel_source_key(folder) + (f"-{ENTRIES}" if all_entries() else "")
    local = Path(folder) / "__pycache__" / f"numba-{key}"
    if _writable(local):
        return local
    return Path.home() / ".cache" / "bearingsim" / f"numba-{key}"


def cache_folder(folder: str | Path = KERNELS_DIR) -> str:
    """The cache folder in use for the sources in ``folder``: the user's ``NUMBA_CACHE_DIR``
    (its subfolder :data:`ENTRIES` where :func:`all_entries`), else :func:`cache_dir_for`."""
    user = os.environ.get("NUMBA_CACHE_DIR", "")
    if not user:
        return str(cache_dir_for(folder))
    return os.path.join(user, ENTRIES) if all_entries() else user


def configure_cache(folder: str | Path = KERNELS_DIR) -> str:
    """Set ``numba.config.CACHE_DIR`` to :func:`cache_folder`. Returns the folder (must run
    before the kernels are decorated, i.e. imported)."""
    import numba

    path = cache_folder(folder)
    numba.config.CACHE_DIR = path
    return path
