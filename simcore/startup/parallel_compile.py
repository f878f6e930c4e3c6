"""Share a cold compilation of the nonsmooth model between two processes.

With an empty cache, a run's first call compiles every kernel it needs, one after the other:
the start's kernels (contact velocities, initial acceleration, energy), then the time loop,
whose typing compiles its three stages (the smooth stage, the position correction, the velocity
jump) before the loop itself, which links them all, then the energy audit's scale (called
between the loop's chunks). Numba looks a kernel up in its on-disk cache
when it first needs it, so a second process can compile part of that list meanwhile and this
process then loads it. :func:`start_helper` starts that process on :data:`HELPER_TASKS` (the
position correction first, then the start's kernels); this process compiles
:data:`MAIN_TASKS` (the velocity jump, then the smooth stage), waits until the helper has saved
the position correction (:meth:`Helper.wait_for`), and then runs, finding in the cache what the
helper has compiled. The tasks compile each kernel for the argument types a run gives it
(:func:`compile_tasks`), so the run's look-up finds the same entry. The two processes save their
entries one after the other (:func:`simcore.startup.patches.lock_cache_writes`): Numba's own
saving of an entry is not safe between processes, so no helper starts where the start-up patch
``parallel_compile`` is off.

The split is measured (docs/method.md, "The kernels"): the two lists take about the same time,
and the loop's own compilation, which needs all three stages, comes last in this process. With
a warm cache nothing is started; the helper is an optimisation only: if it cannot start, fails
or is slow, this process compiles whatever is missing itself, exactly as without it.
"""

from __future__ import annotations

import os
import selectors
import subprocess
import sys
import time

#: what the helper process compiles, in this order (names of :func:`compile_tasks`)
HELPER_TASKS = ("velocity_solver", "position", "initial_acceleration")
#: what this process compiles meanwhile (the smooth stage first: the velocity jump then finds
#: its contact solver in the cache)
MAIN_TASKS = ("smooth", "velocity", "contact_velocities", "energy", "energy_scale")
#: the loop's callees that the helper compiles; this process waits for them, then compiles
#: the loop
LOOP_NEEDS = ("velocity_solver", "position")
#: the helper's program
HELPER = "from simcore.startup.parallel_compile import helper_main; helper_main()"
#: shortest limit of the wait for the helper's share [s] (see :func:`compile_with_helper`;
#: that share takes about 8 s on a 2-core machine)
WAIT_LIMIT = 30.0


def compile_tasks() -> dict:
    """The kernels a nonsmooth run calls from Python or its time loop calls, as (kernel,
    arguments) by task name: the paper's crank-slider with the work arrays, settings and state
    a run makes. Only the arguments' types matter, and they do not depend on the model's
    values (any run's kernels are these); nothing is run."""
    import numpy as np

    from .. import kernels as nb
    from ..config import load_config
    from ..model.mechanism import crank_slider

    model, _ = crank_slider(load_config()["model"])
    arr = model.arrays()
    q, v = model.initial_state()
    n, nc, nbil = q.size, arr.ct_type.size, model.constraint_rows()
    work = nb.nonsmooth_work(n, nbil, nc)
    state = nb.StepState(q, v, np.zeros(n), np.zeros(n), np.zeros(nbil), np.zeros(nbil),
                         np.zeros(nc), np.zeros(nc), np.zeros(nc), np.zeros(nc))
    # the types of Model.simulate's StepSettings
    st = nb.StepSettings(1e-4, 0.0, 1e-5, 50, 1.0, -1, 0.0, 1e-3, 1e-3)
    tasks = nb.loop_stage_calls(st, arr, state, work)
    # the start of Model.simulate
    tasks["contact_velocities"] = (nb.contact_velocities_into,
                                   (q, v, arr, np.zeros(nc), np.zeros(nc), np.zeros(nc),
                                    np.zeros(6), np.zeros(6), work.smooth.trig))
    tasks["initial_acceleration"] = (nb.initial_acceleration,
                                     (q, v, 0.0, arr, np.zeros(n), np.zeros(n), np.zeros(nbil),
                                      work.smooth))
    tasks["energy"] = (nb.total_energy, (q, v, arr))
    rows = 2  # output rows of a one-step chunk
    out = nb.ChunkOutputs(*(np.zeros((rows, size)) for size in (n, n) + (nc,) * 7),
                          np.zeros(rows), np.zeros((rows, 3), np.int64), np.ones(rows, np.int8),
                          np.zeros(rows), np.zeros(rows, np.int8))
    retry = nb.RetrySettings(4, 0.005, 1e-9, 0.0)  # the types of Model.simulate's
    tasks["loop"] = (nb.integrate_chunk, (0, 1, st, arr, state, out, work, retry))
    # the energy audit's, between chunks
    tasks["energy_scale"] = (nb.energy_scale_terms_into,
                             (out.energy, out.q, arr, 0, 1, np.zeros(1)))
    return tasks


def compile_task(call) -> None:
    """Compile (or load from the cache) one (kernel, arguments) of :func:`compile_tasks` for
    the types of its arguments, without running it."""
    from numba import typeof

    kernel, args = call
    kernel.compile(tuple(typeof(a) for a in args))


def helper_main() -> None:
    """The helper process: compile :data:`HELPER_TASKS` in order, writing ``done <name>
    <seconds>`` on stdout after each (its cache entry is saved by then; seconds since the
    process started its tasks)."""
    start = time.perf_counter()
    tasks = compile_tasks()
    for name in HELPER_TASKS:
        compile_task(tasks[name])
        print(f"done {name} {time.perf_counter() - start:.2f}", flush=True)


class Helper:
    """The helper process and what it has reported done."""

    def __init__(self, process: subprocess.Popen):
        self.process = process
        self.done: dict[str, float] = {}  # task name: seconds into the helper's work
        self._buffer = b""

    def wait_for(self, name: str, limit: float = WAIT_LIMIT) -> bool:
        """Wait until the helper reports task ``name`` done (True), or has ended, or ``limit``
        seconds have passed (False)."""
        deadline = time.monotonic() + limit
        with selectors.DefaultSelector() as sel:
            sel.register(self.process.stdout, selectors.EVENT_READ)
            while name not in self.done:
                left = deadline - time.monotonic()
                if left <= 0 or not sel.select(left):
                    return False
                chunk = os.read(self.process.stdout.fileno(), 4096)
                if not chunk:  # the helper has ended
                    return False
                self._buffer += chunk
                *lines, self._buffer = self._buffer.split(b"\n")
                for line in lines:
                    self._read(line)
        return True

    def _read(self, line: bytes) -> None:
        """Take a ``done <name> <seconds>`` line; anything else is ignored."""
        words = line.decode(errors="replace").split()
        if len(words) == 3 and words[0] == "done":
            try:
                self.done[words[1]] = float(words[2])
            except ValueError:
                pass

    def stop(self) -> None:
        """End the helper (whatever it has not finished, this process compiles itself)."""
        if self.process.poll() is None:
            self.process.terminate()
        self.process.wait()
        self.process.stdout.close()


def start_helper() -> Helper | None:
    """Start the helper process when cache saves are locked between processes (start-up patch
    ``parallel_compile``), the time loop is not in the cache and more than one core is there
    to run it; returns it, or None when nothing was started."""
    from .. import kernels as nb
    from .patches import cache_writes_locked, in_cache

    if not cache_writes_locked() or not sys.executable:
        return None  # (patch off: unlocked saves of two processes could mix up cache entries)
    if in_cache(nb.integrate_chunk) is not False or usable_cores() < 2:
        return None
    try:
        process = subprocess.Popen([sys.executable, "-c", HELPER], stdin=subprocess.DEVNULL,
                                   stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    except Exception:  # an optimisation only: whatever stops it, compile here
        return None
    return Helper(process)


def compile_with_helper(helper: Helper | None) -> None:
    """This process's share of a cold compilation: :data:`MAIN_TASKS`, then the wait for the
    helper's share of the loop's callees (:data:`LOOP_NEEDS`), then the loop itself (while the
    helper compiles the initial acceleration). Nothing to do without a helper.

    The helper's share takes about as long as this process's: it is waited for at most
    :data:`WAIT_LIMIT` seconds, or twice the time this process's own tasks took if that is
    longer; a helper that has ended, failed or is slower than that is not waited for, and the
    loop's compilation compiles what is missing. An error here is the caller's to catch (the
    run then compiles everything itself, :func:`simcore.runner.warm_up`)."""
    if helper is None:
        return
    start = time.monotonic()
    tasks = compile_tasks()
    for name in MAIN_TASKS:
        compile_task(tasks[name])
    deadline = time.monotonic() + max(WAIT_LIMIT, 2.0 * (time.monotonic() - start))
    for name in LOOP_NEEDS:
        if not helper.wait_for(name, limit=deadline - time.monotonic()):
            break  # ended, failed or slow: the loop compiles what is missing
    compile_task(tasks["loop"])


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the system tells it)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def stop_helper(helper: Helper | None) -> None:
    """End the helper once this process has compiled everything."""
    if helper is not None:
        helper.stop()
