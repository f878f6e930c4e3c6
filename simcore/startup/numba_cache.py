"""Key Numba's on-disk cache by the kernel sources, so that it cannot serve stale code.

Numba checks a cached function against the modification time and size of the file that defines
it, not against the functions it calls. With the kernels split over several modules, an edit to
a callee (say ``contact.py``) would leave the cached machine code of its callers (say
``nonsmooth_step.py``) in use. :func:`configure_cache` therefore points ``numba.config.CACHE_DIR``
at a folder named after a SHA-1 of every kernel source file, before any kernel is compiled: any
edit anywhere in the kernels gives a new folder and a fresh compilation.

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


def cache_dir_for(folder: str | Path = KERNELS_DIR) -> Path:
    """The cache folder for the sources in ``folder``: ``<folder>/__pycache__/numba-<key>``, or
    ``~/.cache/bearingsim/numba-<key>`` when the package folder is read-only."""
    key = kernel_source_key(folder)
    local = Path(folder) / "__pycache__" / f"numba-{key}"
    if _writable(local):
        return local
    return Path.home() / ".cache" / "bearingsim" / f"numba-{key}"


def configure_cache(folder: str | Path = KERNELS_DIR) -> str:
    """Set ``numba.config.CACHE_DIR`` to :func:`cache_dir_for` unless the user chose a folder
    with ``NUMBA_CACHE_DIR``. Returns the folder in use (must run before the kernels are
    decorated, i.e. imported)."""
    import numba

    lock_cache_writes()
    user = os.environ.get("NUMBA_CACHE_DIR", "")
    if user:
        return user
    path = str(cache_dir_for(folder))
    numba.config.CACHE_DIR = path
    return path


def lock_cache_writes() -> bool:
    """Make Numba's writing of a cache entry safe between processes.

    Numba saves an entry by reading the function's index file, choosing the first free data
    file number, writing the index and then the data file. Each file is replaced atomically, but
    the sequence is not: two processes that save different specialisations of one function at
    the same moment (the study's warm-up processes and a cold run's compile helper,
    :mod:`simcore.startup.parallel_compile`, both compile shared callees) can choose the same
    data file,
    and the index can then name the other specialisation's machine code, in a cache folder that
    stays in use until the kernels are edited. Here the whole sequence runs under an exclusive
    ``flock`` on a lock file beside the index (``<index>.lock``), so saves of one function
    follow one another; loading is unchanged. Applied once per process, before any kernel is
    compiled.

    Returns
    -------
    bool
        True when saves are locked (POSIX ``fcntl`` and Numba's ``IndexDataCacheFile.save`` are
        there); False otherwise, and then no second compiling process is started.
    """
    try:
        import fcntl

        from numba.core.caching import IndexDataCacheFile
    except ImportError:
        return False
    save = IndexDataCacheFile.save
    if getattr(save, "locked_between_processes", False):
        return True

    def locked_save(self, key, data):
        path = getattr(self, "_index_path", None)
        if path is None:  # another Numba layout: save as Numba does
            return save(self, key, data)
        with open(path + ".lock", "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                return save(self, key, data)
            finally:
                fcntl.flock(lock, fcntl.LOCK_UN)

    locked_save.locked_between_processes = True
    IndexDataCacheFile.save = locked_save
    return True


def preload_scipy_blas() -> bool:
    """Load SciPy's ``cython_blas`` extension module on its own, without the ``scipy.linalg``
    package around it.

    The first call of any kernel in a process, even one loaded from the cache, makes Numba import
    its lowering registries; one of them, ``numba.np.arraymath``, checks at import that BLAS is
    there with ``import scipy.linalg.cython_blas``. Python imports the parent package first, and
    ``scipy.linalg`` with what it imports (SciPy's array-API layer, which touches ``numpy.f2py``
    and ``numpy.testing``) takes about 0.2 s, a fifth of a new process's first run, for a
    module the kernels never use. Loaded here from its file (about 2 ms), the extension module
    sits in ``sys.modules`` under its own name, so Numba's check finds it and goes on exactly as
    before: BLAS is reported present, Numba's check of the Fortran integer width runs, and a kernel
    that uses BLAS gets its functions from this same module. ``scipy.linalg`` is imported the
    ordinary way by whoever asks for it later, and gets the module as its attribute then.

    Does nothing (returns False) when ``scipy.linalg`` or Numba's registries are already imported,
    when SciPy is missing, or when the module cannot be found or loaded this way (the ordinary
    import then happens as before).

    Returns
    -------
    bool
        True when the module was loaded here.
    """
    import importlib.machinery
    import importlib.util
    import sys

    name = "scipy.linalg.cython_blas"
    if name in sys.modules or "scipy.linalg" in sys.modules or "numba.np.arraymath" in sys.modules:
        return False
    try:
        import scipy  # light: its submodules load on demand (Numba imports it anyway)
    except ImportError:
        return False
    folders = [os.path.join(folder, "linalg") for folder in getattr(scipy, "__path__", [])]
    spec = importlib.machinery.PathFinder.find_spec(name, folders)
    if spec is None or not isinstance(spec.loader, importlib.machinery.ExtensionFileLoader):
        return False
    try:
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    except Exception:  # leave the ordinary import to Numba
        sys.modules.pop(name, None)
        return False
    sys.meta_path.insert(0, _AttachOnImport("scipy.linalg", "cython_blas", module))
    return True


class _AttachOnImport:
    """Meta-path hook that sets ``module`` as attribute ``attr`` of package ``package`` once that
    package is imported (what the import system does for a submodule it loads itself), then
    removes itself."""

    def __init__(self, package: str, attr: str, module):
        self.package, self.attr, self.module = package, attr, module

    def find_spec(self, name, path, target=None):
        if name != self.package:
            return None
        import importlib.machinery
        import sys

        sys.meta_path.remove(self)
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is None or spec.loader is None:
            return spec
        spec.loader = _AttachingLoader(spec.loader, self.attr, self.module)
        return spec


class _AttachingLoader:
    def __init__(self, loader, attr, module):
        self.loader, self.attr, self.module = loader, attr, module

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, package):
        setattr(package, self.attr, self.module)
        self.loader.exec_module(package)
