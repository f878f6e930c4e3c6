"""Every change simcore makes to other libraries' behaviour to start faster, in one place.

Each patch below touches a private part of another library (or Python's garbage collector) to
save start-up time (``numba_link_only`` also makes the compliant step faster); none changes a
result (``tests/test_startup.py`` runs the paper's case with and without them and compares the
files byte for byte). :func:`install` puts them in place; it
is called once, by ``import simcore``, before any kernel is compiled or loaded. The environment
variable :data:`SWITCH` chooses which:

- unset or ``1``: all of :data:`PATCHES`;
- ``0``: none (every library as it is shipped; CI runs the test suite so too);
- a comma-separated list of names of :data:`PATCHES`: those only (to find which one an upgrade
  broke).

Each patch checks that what it touches is there and otherwise leaves the library alone (the
code then runs the ordinary way); :data:`INSTALLED` says which are in place. The libraries whose
internals are touched (Numba with its llvmlite, SciPy, xarray) have upper version bounds in
``pyproject.toml``: a release outside them has not been tested with the patches.

What each one saves is measured by ``python benchmarks/bench_patches.py`` (``--cold`` for the
cold compile): A/B, alternating processes, medians; each patch's docstring gives its figure,
docs/performance.md ("Start-up patches") the table.
"""

from __future__ import annotations

import atexit
import functools
import gc
import os
import sys
from contextlib import contextmanager

#: the environment variable that chooses the patches (module docstring)
SWITCH = "BEARINGSIM_STARTUP_PATCHES"

#: every patch, by name (see the function of the same name for what it does and saves)
PATCHES = ("numba_internal_kernels", "numba_link_only", "parallel_compile", "scipy_blas",
           "gc_freeze", "xarray_dask_type", "netcdf_store", "fast_dataset")

#: which patches :func:`install` has put in place (name: True/False)
INSTALLED: dict[str, bool] = {}


def selected() -> frozenset[str]:
    """The patches :data:`SWITCH` asks for.

    Raises
    ------
    ValueError
        For a value that is neither 0, 1 nor a list of names of :data:`PATCHES` (one line
        naming the variable and the allowed values).
    """
    value = os.environ.get(SWITCH, "1").strip()
    if value in ("", "1"):
        return frozenset(PATCHES)
    if value == "0":
        return frozenset()
    names = {name.strip() for name in value.split(",") if name.strip()}
    unknown = sorted(names - set(PATCHES))
    if unknown:
        raise ValueError(f"{SWITCH}: {unknown[0]!r} is not allowed; allowed: 0, 1 or a "
                         f"comma-separated list of {', '.join(PATCHES)}")
    return frozenset(names)


def enabled(name: str) -> bool:
    """Whether patch ``name`` is asked for (:func:`selected`)."""
    return name in selected()


def install() -> dict[str, bool]:
    """Put the selected patches in place (once; later calls change nothing).

    Must run before any kernel is compiled or loaded: ``import simcore`` calls it first.

    Returns
    -------
    dict
        :data:`INSTALLED`.
    """
    if INSTALLED:
        return INSTALLED
    chosen = selected()
    INSTALLED.update({
        "numba_internal_kernels": "numba_internal_kernels" in chosen
        and _internal_kernel_class() is not None,
        "numba_link_only": "numba_link_only" in chosen and install_link_only(),
        "parallel_compile": "parallel_compile" in chosen and lock_cache_writes(),
        "scipy_blas": "scipy_blas" in chosen and preload_scipy_blas(),
        "gc_freeze": "gc_freeze" in chosen,
        "xarray_dask_type": "xarray_dask_type" in chosen and after_import(
            "xarray.namedarray.pycompat", defer_dask_array_type),
        "netcdf_store": "netcdf_store" in chosen,
        "fast_dataset": "fast_dataset" in chosen,
    })
    return INSTALLED


def after_import(name: str, action) -> bool:
    """Call ``action(module)`` once module ``name`` is imported: now if it is, else right
    after its import (an import hook, :class:`_AfterImport`). Returns True."""
    module = sys.modules.get(name)
    if module is not None:
        action(module)
    else:
        sys.meta_path.insert(0, _AfterImport(name, action))
    return True


class _AfterImport:
    """Meta-path hook that runs ``action(module)`` right after module ``name`` is executed, then
    removes itself."""

    def __init__(self, name: str, action):
        self.name, self.action = name, action

    def find_spec(self, name, path, target=None):
        if name != self.name:
            return None
        import importlib.machinery

        if self in sys.meta_path:
            sys.meta_path.remove(self)
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is not None and spec.loader is not None:
            spec.loader = _ActingLoader(spec.loader, self.action)
        return spec


class _ActingLoader:
    def __init__(self, loader, action):
        self.loader, self.action = loader, action

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module):
        self.loader.exec_module(module)
        self.action(module)


# --- gc_freeze: Python's cyclic garbage collector ---------------------------------------------

@contextmanager
def collector_paused():
    """Pause Python's cyclic garbage collector while a process loads what a run needs
    (patch ``gc_freeze``; without it, a plain block).

    Loading simcore, Numba's registries, xarray, pandas and dask creates a few hundred thousand
    objects that live as long as the process; the collector, started by the count of new
    objects, walks them again and again and finds nothing to free. Paused while loading and the
    first run, it runs again afterwards (in the state it was in), and collects what is left
    then.

    Patch ``gc_freeze`` (this and :func:`freeze_heap`) saves 0.40 s of CPU of a new process's
    first run to the dataset and 0.49 s of the command's (``benchmarks/bench_patches.py``).
    """
    if not enabled("gc_freeze"):
        yield
        return
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def freeze_heap() -> None:
    """Freeze every object alive now (patch ``gc_freeze``): the interpreter's shut-down, which
    walks the objects of NumPy, Numba, xarray and pandas with the cyclic collector several
    times, skips them; they are freed with the process. Python does not promise to finalize
    objects still alive at exit (``__del__`` of garbage in reference cycles then): callers
    close their files first."""
    if enabled("gc_freeze"):
        gc.freeze()


def freeze_heap_at_exit() -> None:
    """Register :func:`freeze_heap` to run at the interpreter's exit (once)."""
    if enabled("gc_freeze") and not _FREEZE_REGISTERED:
        atexit.register(freeze_heap)
        _FREEZE_REGISTERED.append(True)


_FREEZE_REGISTERED: list = []


# --- numba_internal_kernels: kernels compiled without a Python entry ---------------------------

def internal_njit(**options):
    """Numba's ``njit(**options)`` for a kernel that only other kernels call: with patch
    ``numba_internal_kernels``, compiled without a Python entry.

    Numba compiles every kernel with a Python entry (a wrapper that converts the Python
    arguments, each array of a bundle, into native ones), even one that only kernels call: 58
    entries in a cold compile, of which a run needs 5, each made, optimised and turned into
    machine code. Here a kernel that simcore calls only from other kernels is compiled without
    one (Numba's ``no_cpython_wrapper``); kernels call each other natively, so the machine code
    they run is the same and so are the results. A call from Python (a test, a benchmark's
    timing of one stage) goes to a twin compiled with an entry on its first call, not cached
    on disk.

    Entries and none cannot share a cache folder (a process with the patch off would find an
    entry missing), so :func:`simcore.startup.numba_cache.configure_cache` names the folder by
    the patch's state. Saves 1.9 s of wall and 3.8 s of CPU of a cold compile (16.4 s and 25.7 s
    with every patch; ``python benchmarks/bench_patches.py --cold --rounds 3``).

    Parameters
    ----------
    **options
        Numba's ``njit`` options (``cache=True`` caches on disk).

    Returns
    -------
    callable
        The decorator; plain ``njit(**options)`` with the patch off or where the subclass of
        Numba's dispatcher cannot be made.
    """
    from numba import config, njit

    cls = _internal_kernel_class() if enabled("numba_internal_kernels") else None
    if cls is None or config.DISABLE_JIT:
        return njit(**options)
    cache = options.pop("cache", False)
    targetoptions = dict(options, nopython=True, no_cpython_wrapper=True)

    def decorate(func):
        dispatcher = cls(py_func=func, locals={}, targetoptions=targetoptions)
        if cache:
            dispatcher.enable_caching()
        return dispatcher

    return decorate


@functools.cache
def _internal_kernel_class():
    """The dispatcher class of :func:`internal_njit` (made once), or None where Numba's
    ``CPUDispatcher`` is not there to subclass."""
    try:
        from numba import njit
        from numba.core.registry import CPUDispatcher
    except ImportError:
        return None

    class InternalKernel(CPUDispatcher):
        """A kernel compiled without a Python entry; a call from Python goes to
        :meth:`python_twin`."""

        _twin = None

        def python_twin(self):
            """The same function compiled with a Python entry (made on first use, not cached
            on disk: its cache entry would carry what this one's lacks)."""
            if self._twin is None:
                options = {k: v for k, v in self.targetoptions.items()
                           if k not in ("nopython", "no_cpython_wrapper")}
                self._twin = njit(**options)(self.py_func)
            return self._twin

        def __call__(self, *args, **kwargs):
            return self.python_twin()(*args, **kwargs)

    return InternalKernel


# --- numba_link_only: Numba's CPUCodeLibrary._optimize_final_module ---------------------------

#: (library name, mangled-name prefix) of the functions registered by :func:`link_only`
_LINK_ONLY: set[tuple[str, str]] = set()
#: names of the libraries this process has linked (:func:`_link`), and of those where the
#: linking failed and Numba's whole optimisation ran instead
LINKED: list[str] = []
LINK_FAILED: list[str] = []


def link_only(func):
    """Register the Python function ``func`` (a time loop or a step kernel) so that the library
    Numba compiles for it is only linked (:func:`install_link_only`); returns ``func``."""
    name = func.__qualname__
    path = func.__module__.split(".") + name.split(".")
    _LINK_ONLY.add((name, "_ZN" + "".join(f"{len(p)}{p}" for p in path)))
    return func


def install_link_only() -> bool:
    """Make Numba only link the libraries of the functions registered by :func:`link_only`.

    Numba compiles every function into a library of its own, optimised as a whole with the
    libraries of its callees linked in (so that small callees get inlined), then turned into
    machine code. The time loops and the step kernels (:func:`simcore.kernels.jit.step_kernel`)
    call functions already optimised in their own libraries with their callees; optimising
    them all once more inside each caller's library costs compile time and, inside the
    compliant step, gives slower code. Their libraries are therefore only linked: the direct
    callees are inlined and the argument passing cleaned up (the inliner, SROA, instcombine and
    CFG simplification), nothing more; the arithmetic is IEEE without fast-math either way, so
    the results are the same to the bit.

    This replaces a private method of Numba (``CPUCodeLibrary._optimize_final_module``) for the
    registered functions only; where it is missing or anything in the linking fails, the
    function is optimised as any other kernel (:data:`LINK_FAILED` names it).

    Saves 5.8 s of wall and 9.0 s of CPU of a cold compile (16.4 s and 25.7 s with every patch;
    ``python benchmarks/bench_patches.py --cold --rounds 3``) and a fifth of the compliant
    paper case's run time (docs/performance.md, "A cold compile").

    Returns
    -------
    bool
        True when the hook is in place (now or before).
    """
    try:
        from numba.core.codegen import CPUCodeLibrary
    except ImportError:
        return False
    optimize = getattr(CPUCodeLibrary, "_optimize_final_module", None)
    if optimize is None:
        return False
    if getattr(optimize, "link_only", False):
        return True

    def _optimize_final_module(self):
        loops = _registered_loops(self)
        if loops:
            try:
                _link(self, loops)
                LINKED.append(self.name)
                return
            except Exception:  # noqa: BLE001 - Numba's or llvmlite's internals moved
                LINK_FAILED.append(self.name)
        return optimize(self)

    _optimize_final_module.link_only = True
    CPUCodeLibrary._optimize_final_module = _optimize_final_module
    return True


def _registered_loops(library) -> list:
    """The :func:`link_only` functions that ``library`` defines (not others of the same name
    elsewhere), as LLVM function values."""
    name = getattr(library, "name", None)
    prefixes = tuple(prefix for lib, prefix in _LINK_ONLY if lib == name)
    if not prefixes:
        return []
    try:
        return [f for f in library._final_module.functions
                if not f.is_declaration and f.name.startswith(prefixes)]
    except AttributeError:
        return []


def _link(library, loops) -> None:
    """Inline the direct callees of ``loops`` into them and clean up, nothing more."""
    import llvmlite.binding as llvm

    # everything that may be missing in another Numba or llvmlite first, before the module
    # is touched (a failure then leaves it as Numba made it, for Numba's own optimisation)
    builder = library._codegen._pass_builder(opt=0)
    passes = llvm.create_new_module_pass_manager()
    passes.add_always_inliner_pass()
    passes.add_sroa_pass()
    passes.add_instruction_combine_pass()
    passes.add_simplify_cfg_pass()
    module = library._final_module
    # (the called function is a call instruction's last operand)
    callees = {list(ins.operands)[-1].name for loop in loops for block in loop.blocks
               for ins in block.instructions if ins.opcode == "call"}
    inline = [f for f in module.functions
              if f.name in callees and not f.is_declaration and not has_noinline(f)]
    for f in inline:
        f.add_function_attribute("alwaysinline")
    passes.run(module, builder)


def has_noinline(function) -> bool:
    """Whether an LLVM function carries ``noinline`` (which excludes ``alwaysinline``)."""
    names = {a.decode() if isinstance(a, bytes) else str(a) for a in function.attributes}
    return "noinline" in names


# --- parallel_compile: Numba's IndexDataCacheFile.save and a dispatcher's _cache ---------------

def lock_cache_writes() -> bool:
    """Make Numba's writing of a cache entry safe between processes (part of patch
    ``parallel_compile``, :mod:`simcore.startup.parallel_compile`).

    Numba saves an entry by reading the function's index file, choosing the first free data
    file number, writing the index and then the data file. Each file is replaced atomically, but
    the sequence is not: two processes that save different specialisations of one function at
    the same moment (the study's warm-up processes and a cold run's compile helper both compile
    shared callees) can choose the same data file, and the index can then name the other
    specialisation's machine code, in a cache folder that stays in use until the kernels are
    edited. Here the whole sequence runs under an exclusive ``flock`` on a lock file beside the
    index (``<index>.lock``), so saves of one function follow one another; loading is
    unchanged. Without it (switched off, or another Numba), simcore compiles in one process at
    a time: no helper process, and the study's warm-up compiles the compliant kernels after the
    nonsmooth ones.

    Patch ``parallel_compile`` (this, the helper process and :func:`in_cache`, which reads a
    dispatcher's private ``_cache``) shares a cold compile between two idle cores (its two
    halves are chosen to take about the same time; ``benchmarks/bench_patches.py --cold``
    measures the gain, which a loaded machine with no idle core cannot resolve).

    Returns
    -------
    bool
        True when saves are locked (POSIX ``fcntl`` and Numba's ``IndexDataCacheFile.save`` are
        there); False otherwise.
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


def cache_writes_locked() -> bool:
    """Whether Numba's cache saves are locked between processes in this process
    (:func:`lock_cache_writes` installed): only then may two processes compile at once."""
    try:
        from numba.core.caching import IndexDataCacheFile
    except ImportError:
        return False
    return bool(getattr(IndexDataCacheFile.save, "locked_between_processes", False))


def in_cache(dispatcher) -> bool | None:
    """Whether Numba's cache holds compiled code of ``dispatcher`` (its index file exists in
    the cache folder), or None when that cannot be told (no cache, another Numba layout)."""
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    index = getattr(cache_file, "_index_path", None)
    if not index:
        return None
    return os.path.exists(index)


# --- scipy_blas: SciPy's cython_blas loaded without scipy.linalg ------------------------------

def preload_scipy_blas() -> bool:
    """Load SciPy's ``cython_blas`` extension module on its own, without the ``scipy.linalg``
    package around it.

    The first call of any kernel in a process, even one loaded from the cache, makes Numba
    import its lowering registries; one of them, ``numba.np.arraymath``, checks at import that
    BLAS is there with ``import scipy.linalg.cython_blas``. Python imports the parent package
    first, and ``scipy.linalg`` with what it imports (SciPy's array-API layer, which touches
    ``numpy.f2py`` and ``numpy.testing``) is a large share of a new process's first run, for a
    module the kernels never use. Loaded here from its file (about 2 ms), the extension module
    sits in ``sys.modules`` under its own name, so Numba's check finds it and goes on exactly as
    before: BLAS is reported present, and a kernel that uses BLAS gets its functions from this
    same module. ``scipy.linalg`` is imported the ordinary way by whoever asks for it later, and
    gets the module as its attribute then (an import hook, :class:`_AttachOnImport`).

    Does nothing (returns False) when ``scipy.linalg`` or Numba's registries are already
    imported, when SciPy is missing, or when the module cannot be found or loaded this way (the
    ordinary import then happens as before).

    Saves 0.05 s of CPU of a new process's first run, 0.04 s of the command's
    (``benchmarks/bench_patches.py``): below the 0.2 s a patch should save on its own, kept
    because together with ``fast_dataset`` it is a tenth of a first run.

    Returns
    -------
    bool
        True when the module was loaded here.
    """
    import importlib.machinery
    import importlib.util

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
    # scipy.linalg, imported the ordinary way later, gets the module as its attribute (what
    # the import system does for a submodule it loads itself; set after the package's own code,
    # which does not import it)
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


# --- xarray_dask_type: xarray's record of dask's array type -----------------------------------

def defer_dask_array_type(pycompat) -> bool:
    """Let xarray ask for dask's array type without importing ``dask.array`` first.

    xarray checks every Variable it makes (the netCDF encoder makes one per variable written)
    with ``isinstance(data, array_type("dask"))``, and the first check imports ``dask.array``
    to learn that type, for a run that has NumPy arrays only. No dask array can exist before
    ``dask.array`` is imported, so xarray's record of dask (the private
    ``xarray.namedarray.pycompat._cached_duck_array_modules["dask"]``) is given a stand-in whose
    ``type`` is ``dask.array.Array`` once that module is imported (by the user, or by xarray for
    a chunked dataset) and empty until then; anything else asked of it (the version) is
    answered by xarray's own record, made then. Nothing is changed where xarray has made its
    record already or keeps it elsewhere.

    Saves 0.23 s of CPU of the command's first run (which writes a file; nothing of a run that
    only returns its dataset), ``benchmarks/bench_patches.py``.

    Parameters
    ----------
    pycompat : module
        ``xarray.namedarray.pycompat``.

    Returns
    -------
    bool
        True when the stand-in was put in place.
    """
    cache = getattr(pycompat, "_cached_duck_array_modules", None)
    record = getattr(pycompat, "DuckArrayModule", None)
    if not isinstance(cache, dict) or record is None or "dask" in cache:
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


def dask_array_type_deferred() -> bool:
    """Whether xarray's record of dask is the stand-in of :func:`defer_dask_array_type`."""
    pycompat = sys.modules.get("xarray.namedarray.pycompat")
    cache = getattr(pycompat, "_cached_duck_array_modules", {})
    return type(cache.get("dask")).__name__ == "DaskArrayType"


# --- fast_dataset: xarray Variables made on its fast path -------------------------------------

def dataset_of_arrays(data: dict, coords: dict, attrs: dict):
    """``xr.Dataset(data, coords=coords, attrs=attrs)`` for entries ``(dims, values[, attrs])``
    whose values are NumPy arrays, lists or numbers: the same dataset, built a faster way where
    patch ``fast_dataset`` is selected.

    The ordinary constructor asks of every value whether it is a dask array, which imports
    ``dask.array``, and of every dimension coordinate whether it is a dask collection, which
    imports ``dask``; a run has NumPy arrays only, and the first run in a new process would pay
    for both imports. Here each entry becomes an ``xr.Variable`` made on xarray's fast path
    (``fastpath=True``, which takes a NumPy array as it is), and each dimension coordinate gets
    the index the ordinary constructor gives it, a ``xarray.indexes.PandasIndex`` of
    ``pandas.Index(values)`` that keeps the coordinate's dtype, with its variable made by that
    index. Values of dtype object, datetime, timedelta or float16 (which the ordinary
    constructor converts) go to the ordinary constructor.

    Saves 0.07 s of CPU of a new process's first run to the dataset (nothing measurable of the
    command's, whose write imports dask anyway), ``benchmarks/bench_patches.py``: kept with
    ``scipy_blas`` (see there).
    """
    import numpy as np
    import pandas as pd
    import xarray as xr

    if not enabled("fast_dataset"):
        return xr.Dataset(data, coords=coords, attrs=attrs)

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


# --- netcdf_store: to_netcdf through xarray's backend store -----------------------------------

def to_netcdf4(ds, target, encoding: dict) -> None:
    """``ds.to_netcdf(target, engine="netcdf4", encoding=encoding)``, the same file written
    with less to import where patch ``netcdf_store`` is selected, for a ``target`` that nothing
    else writes meanwhile (the fresh temporary file of :func:`simcore.io.write_netcdf`).

    ``Dataset.to_netcdf`` asks dask twice which scheduler is active: to decide whether to close
    the file between the writes of chunked arrays, and to choose the kind of lock that guards
    the file (a ``distributed`` lock under a ``distributed`` client). Asking imports
    ``distributed`` when it is installed, for a dataset without chunked arrays, which neither
    question concerns. For such a dataset (:func:`_plainly_writable`) this opens xarray's
    netCDF4 store as ``to_netcdf`` does (mode "w", the default format) with the locks
    ``to_netcdf`` takes in a process without a ``distributed`` client (the netCDF library's and
    one for the file) and stores the dataset in it with ``Dataset.dump_to_store``, the step
    ``to_netcdf`` takes next. Any other dataset (dask arrays, unlimited dimensions, names or
    attributes ``to_netcdf`` would refuse), or an xarray whose internals differ, goes through
    ``to_netcdf`` itself.

    Saves 0.20 s of CPU of the command's first run where ``distributed`` is installed (the test
    extra installs it; without it there is nothing to save), ``benchmarks/bench_patches.py``.
    """
    target = os.fspath(target)
    store_class = None
    if enabled("netcdf_store"):
        try:
            from xarray.backends import NetCDF4DataStore as store_class
            from xarray.backends.locks import SerializableLock, combine_locks
            from xarray.backends.netCDF4_ import NETCDF4_PYTHON_LOCK
        except ImportError:
            store_class = None
    if store_class is None or not _plainly_writable(ds):
        ds.to_netcdf(target, engine="netcdf4", encoding=encoding)
        return
    lock = combine_locks([NETCDF4_PYTHON_LOCK, SerializableLock(target)])
    store = store_class.open(target, mode="w", format=None, lock=lock)
    try:
        ds.dump_to_store(store, encoding=encoding)
    finally:
        store.close()


def _plainly_writable(ds) -> bool:
    """True when no variable of ``ds`` is chunked (a dask array), ``ds`` names no unlimited
    dimension, and its names and attributes are of the kinds ``to_netcdf`` accepts (non-empty
    strings; numbers, strings, arrays, lists)."""
    from numbers import Number

    import numpy as np

    kinds = (str, Number, np.ndarray, np.number, list, tuple, bytes)
    if ds.encoding.get("unlimited_dims") is not None:
        return False
    for name, var in ds.variables.items():
        if not isinstance(name, str) or not name or var.chunks is not None:
            return False
    for attrs in [ds.attrs] + [var.attrs for var in ds.variables.values()]:
        for key, value in attrs.items():
            if not isinstance(key, str) or not key or not isinstance(value, kinds):
                return False
    return True
