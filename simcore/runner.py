"""One run of the crank-slider from a validated configuration: build, integrate, wrap.

The first run in a process first compiles the Numba kernels, or loads them from Numba's cache
(``__pycache__`` next to the sources): seconds to a minute. :func:`warm_up` does that with a
run of two steps, so that the run's ``wall_time_s`` measures the integration alone; the time it
took is recorded apart, as ``compile_time_s``. A cold compilation of the nonsmooth model is
shared with a second process (:mod:`simcore.startup.parallel_compile`). The first run in a process
imports the I/O layer (xarray) in a background thread while it integrates
(:func:`import_meanwhile`).
"""

from __future__ import annotations

import importlib
import sys
import threading
import time
import warnings

from .config import load_config, validate_config
from .config.limits import check_run
from .model import SolverError, SolverSettings  # noqa: F401  (SolverError re-exported)
from .model.mechanism import crank_slider
from .startup.parallel_compile import compile_with_helper, start_helper, stop_helper

#: (contact model, adaptive steps) whose kernels this process has compiled or loaded
_warm: set[tuple[str, bool]] = set()


def _simulate(model, cfg: dict, t_end: float | None = None, on_nonconvergence=None,
              progress: bool = False):
    """``model.simulate`` with the solver settings of ``cfg`` (shared by :func:`run` and
    :func:`warm_up`, so that both compile the same kernels)."""
    changes = {"progress": progress}
    if t_end is not None:
        changes["t_end"] = t_end
    if on_nonconvergence is not None:
        changes["on_nonconvergence"] = on_nonconvergence
    return model.simulate(SolverSettings.from_config(cfg, **changes))


#: seconds after which a warm-up still at work says on stderr that it compiles
COMPILE_NOTICE_AFTER = 3.0


def _compile_notice(stream) -> threading.Timer:
    """A started timer that tells ``stream``, after :data:`COMPILE_NOTICE_AFTER` seconds, that
    the kernels are being compiled (a cache load takes well under a second; a compilation
    10-60 s in which nothing else would be printed)."""
    def say():
        import numba

        timer.said = True
        stream.write("simcore: compiling the simulation kernels (first run after an install or "
                     "an edit of the kernels; 10-60 s, then cached in "
                     f"{numba.config.CACHE_DIR}) ...\n")
        stream.flush()

    timer = threading.Timer(COMPILE_NOTICE_AFTER, say)
    timer.said = False
    timer.daemon = True
    timer.start()
    return timer


def warm_up(config: dict | None = None, notify=None) -> float:
    """Compile (or load from Numba's cache) every kernel of a run, once per process.

    Runs two time steps of the crank-slider of ``config`` (default: the paper's case). A
    kernel is compiled for the types of its arguments, which do not depend on the settings, so
    the real runs that follow reuse it whatever their parameters.

    Parameters
    ----------
    config : dict, optional
        A configuration; only its ``model`` section and ``solver.dt`` are used.
    notify : file-like, optional
        Where to say that the kernels are being compiled, when loading them takes longer than
        :data:`COMPILE_NOTICE_AFTER` seconds, and how long it took (e.g. ``sys.stderr``);
        None: silent.

    Returns
    -------
    float
        Seconds spent [s]; 0.0 when this process had already warmed up.
    """
    cfg = validate_config(config) if config is not None else load_config()
    kind = cfg["model"]["contact_model"]
    loop = (kind, bool(cfg["solver"].get("adaptive", False)))  # (each its own time loop)
    if loop in _warm:
        return 0.0
    start = time.perf_counter()
    notice = _compile_notice(notify) if notify is not None else None
    model, _ = crank_slider(cfg["model"])
    # a cold compilation of the nonsmooth loop is shared with a second process
    helper = start_helper() if kind == "nonsmooth" else None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            # (an optimisation only: should it fail, the run below compiles whatever is
            # missing, and reports a real error itself)
            try:
                compile_with_helper(helper)
            except Exception:  # noqa: BLE001
                pass
            try:
                _simulate(model, cfg, t_end=2 * float(cfg["solver"]["dt"]),
                          on_nonconvergence="warn")
            except SolverError:
                pass  # the kernels are compiled all the same; the real run reports the failure
    finally:
        stop_helper(helper)
        if notice is not None:
            notice.cancel()
            notice.join()  # a notice being written is finished before the next line
    seconds = time.perf_counter() - start
    if notice is not None and notice.said:
        notify.write(f"simcore: kernels compiled in {seconds:.0f} s\n")
        notify.flush()
    _warm.add(loop)
    return seconds


def import_meanwhile(name: str) -> threading.Thread | None:
    """Start importing module ``name`` in a background thread, unless it is imported already.

    The time loop's kernels release the interpreter lock, so a new process's first run
    imports the I/O layer (xarray and pandas with it, some 0.25 s) while it integrates instead
    of after. Nothing else is imported meanwhile by the run. A failed import is left to the
    caller's own import of the module, which raises it again.

    Parameters
    ----------
    name : str
        Absolute module name.

    Returns
    -------
    threading.Thread or None
        The started thread (join it before using the module), or None.
    """
    if name in sys.modules:
        return None

    def target():
        try:
            importlib.import_module(name)
        except BaseException:  # noqa: BLE001 - the caller's import reports it
            pass

    thread = threading.Thread(target=target, name=f"import {name}", daemon=True)
    thread.start()
    return thread


def run(config: dict, progress: bool = False):
    """Simulate the crank-slider bearing of ``config`` and return its dataset.

    Parameters
    ----------
    config : dict
        A configuration (validated here again, defaults filled).
    progress : bool
        Show a progress bar on stderr when it is a terminal.

    Returns
    -------
    xarray.Dataset
        See :func:`simcore.io.trajectory_dataset`; attribute ``wall_time_s`` is the integration
        alone, ``compile_time_s`` the compile or cache load before it (0 after the first run in
        a process).

    Raises
    ------
    simcore.ConfigError
        On bad input, before any work.
    simcore.ConfigError
        Also for a step size that cannot resolve the model (``solver.on_unresolved_dt``) and for
        a run whose arrays would exceed ``solver.max_memory_gb``: checked after building the
        model, before any array of the time loop is allocated (:mod:`simcore.config.limits`).
    simcore.SolverError
        When a step does not converge, or creates energy (:mod:`simcore.model.audit`), and
        ``solver.on_nonconvergence`` is ``"error"``.
    """
    cfg = validate_config(config)
    model, layout = crank_slider(cfg["model"])
    check_run(cfg, model)  # limits before any work
    compile_time_s = warm_up(cfg, notify=sys.stderr if progress else None)
    # (not earlier: while the kernels load, Numba's many short calls into LLVM would each wait
    # for the interpreter lock held by the importing thread)
    importer = import_meanwhile("simcore.io")
    try:
        traj = _simulate(model, cfg, progress=progress)
    finally:
        if importer is not None:
            importer.join()
    from .io import trajectory_dataset

    ds = trajectory_dataset(traj, model, layout, cfg, compile_time_s=compile_time_s)
    warn_if_rings_ran_on_lands(ds)
    return ds


def warn_if_rings_ran_on_lands(ds) -> None:
    """A RuntimeWarning where the rings' guard contact carried load: the balls bunched until
    they no longer held the rings apart (docs/model.md, "Guard contacts"). The run is whole
    and its steps may all have converged, but its loads are those of a bearing whose balls
    bunched; with a cage that holds them, that comes from a step too large for the speed
    (docs/reliability.md, section 4), which only a run at a smaller step tells apart."""
    n = int(ds.attrs.get("guard_rings_closed_samples", 0))
    if not n:
        return
    import warnings

    loaded = (ds["guard_Lambda_N"].sel(guard="rings").values > 0.0).nonzero()[0]
    warnings.warn(
        f"the rings ran on their lands on {n} of {ds.sizes['time']} output samples (from "
        f"t = {float(ds['time'][loaded[0]]):.4g} s): the balls bunched and no longer held them "
        f"apart. With a cage that should hold them, this is a step too large for the speed: "
        f"compare with a smaller solver.dt (now {ds.attrs['solver.dt']:g} s; python -m "
        "analysis dt-check RUN_FILE)", RuntimeWarning, stacklevel=3)
