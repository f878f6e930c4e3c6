"""Share a cold compilation of the nonsmooth time loop between two processes.

A run's first call compiles the time loop's kernels one after the other, in the order the
loop's source calls them (the smooth stage, the position correction, then the velocity jump)
and finally the loop itself, which links them all: some 35-45 s of one core. When the kernels
are not in Numba's cache yet, :func:`start_helper` starts a second Python process that compiles
the velocity jump's kernels (:func:`compile_velocity_stage`) while this process compiles the
rest. Numba looks a kernel up in the cache when it first needs it, so by the time the loop gets
to the velocity jump it finds it compiled and loads it. The two processes save their cache
entries one after the other (:func:`simcore.numba_cache.lock_cache_writes`): Numba's own saving
of an entry is not safe between processes.
With two cores a cold start then takes about two thirds of the time; with a warm cache nothing
is started.

The helper is an optimisation only: if it fails, is slow, or the cache cannot be checked, this
process compiles everything itself, exactly as without it.
"""

from __future__ import annotations

import os
import subprocess
import sys

#: the helper process's program
HELPER = "from simcore.parallel_compile import compile_velocity_stage; compile_velocity_stage()"


def in_cache(dispatcher) -> bool | None:
    """Whether Numba's cache holds compiled code of ``dispatcher`` (its index file exists in
    the cache folder), or None when that cannot be told (no cache, another Numba layout)."""
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    index = getattr(cache_file, "_index_path", None)
    if not index:
        return None
    return os.path.exists(index)


def start_helper() -> subprocess.Popen | None:
    """Start the helper process when the velocity jump's kernels are not in the cache, more
    than one core is there to run it and cache saves are locked between processes; returns it,
    or None when nothing was started."""
    from . import kernels as nb
    from .numba_cache import lock_cache_writes

    if in_cache(nb.velocity_step) is not False or usable_cores() < 2:
        return None
    if not lock_cache_writes() or not sys.executable:
        return None  # (unlocked saves of two processes could mix up cache entries)
    try:
        return subprocess.Popen([sys.executable, "-c", HELPER], stdin=subprocess.DEVNULL,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except Exception:  # an optimisation only: whatever stops it, compile here
        return None


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the system tells it)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def stop_helper(helper: subprocess.Popen | None) -> None:
    """End the helper once this process has compiled everything (whatever it has not finished
    by then, this process has compiled itself)."""
    if helper is None:
        return
    if helper.poll() is None:
        helper.terminate()
    helper.wait()


def compile_velocity_stage() -> None:
    """Compile (or load) :func:`simcore.kernels.velocity_step` for the argument types the time
    loop gives it: the paper's crank-slider with the work arrays and bundles of a run, through
    one call on its start state (the values do not matter, the types do)."""
    import numpy as np

    from . import kernels as nb
    from .config import load_config
    from .mechanism import crank_slider

    model, _ = crank_slider(load_config()["model"])
    arr = model.arrays()
    q, _v = model.initial_state()
    n, nc, nbil = q.size, arr.ct_type.size, model.constraint_rows()
    work = nb.nonsmooth_work(n, nbil, nc)
    q_t, v_t, _acc1, _vdot1, f_t, _K, _C, _Ks, q1, v1 = work.step
    nu_c, gap = work.contact[0], work.contact[1]
    q_t[:] = q
    q1[:] = q
    h, tol = 1e-4, 1e-6
    # the types of integrate_chunk's call: floats, an int64 iteration limit, the state's arrays
    nb.velocity_step(q1, q_t, v_t, h, h, tol, 20, 1e-6, tol * h, arr, f_t, nu_c, gap,
                     np.zeros(nc), np.zeros(nc), v1, np.zeros(nc), np.zeros(nc),
                     np.zeros(nbil), work.velocity)
