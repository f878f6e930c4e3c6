"""One run of the crank-slider from a validated configuration: build, integrate, wrap.

The first run in a process first compiles the Numba kernels, or loads them from Numba's cache
(``__pycache__`` next to the sources): seconds to a minute. :func:`warm_up` does that with a
run of two steps, so that the run's ``wall_time_s`` measures the integration alone; the time it
took is recorded apart, as ``compile_time_s``.
"""

from __future__ import annotations

import time
import warnings

from .config import load_config, validate_config
from .mechanism import crank_slider
from .model import SolverError  # noqa: F401  (re-exported)

_warm = False


def _simulate(model, cfg: dict, t_end: float | None = None, on_nonconvergence=None,
              progress: bool = False):
    """``model.simulate`` with the solver settings of ``cfg`` (the one place that lists them,
    shared by :func:`run` and :func:`warm_up`, so that both compile the same kernels)."""
    solver = cfg["solver"]
    return model.simulate(solver["dt"], solver["t_end"] if t_end is None else t_end,
                          rho_inf=solver["rho_inf"], tol=solver["tol"],
                          max_iter=solver["max_iter"], proximal=solver["proximal"],
                          on_nonconvergence=on_nonconvergence or solver["on_nonconvergence"],
                          progress=progress)


def warm_up(config: dict | None = None) -> float:
    """Compile (or load from Numba's cache) every kernel of a run, once per process.

    Runs two time steps of the crank-slider of ``config`` (default: the paper's case). A
    kernel is compiled for the types of its arguments, which do not depend on the settings, so
    the real runs that follow reuse it whatever their parameters.

    Parameters
    ----------
    config : dict, optional
        A configuration; only its ``model`` section and ``solver.dt`` are used.

    Returns
    -------
    float
        Seconds spent [s]; 0.0 when this process had already warmed up.
    """
    global _warm
    if _warm:
        return 0.0
    start = time.perf_counter()
    cfg = validate_config(config) if config is not None else load_config()
    model, _ = crank_slider(cfg["model"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            _simulate(model, cfg, t_end=2 * float(cfg["solver"]["dt"]), on_nonconvergence="warn")
        except SolverError:
            pass  # the kernels are compiled all the same; the real run reports the failure
    _warm = True
    return time.perf_counter() - start


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
    simcore.SolverError
        When a step does not converge and ``solver.on_nonconvergence`` is ``"error"``.
    """
    from .io import trajectory_dataset

    cfg = validate_config(config)
    compile_time_s = warm_up(cfg)
    model, layout = crank_slider(cfg["model"])
    traj = _simulate(model, cfg, progress=progress)
    return trajectory_dataset(traj, model, layout, cfg, compile_time_s=compile_time_s)
