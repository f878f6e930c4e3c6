"""The helper process of a cold compilation (simcore.startup.parallel_compile)."""

import os
import subprocess
import sys

import numba
import pytest

import simcore
from simcore import kernels as nb
from simcore.runner import warm_up
from simcore.startup import parallel_compile, patches

#: the helper runs only with cache saves locked between processes (start-up patch)
needs_lock = pytest.mark.skipif(
    not (patches.enabled("parallel_compile") and patches.enabled("numba_link_only")),
    reason="start-up patches parallel_compile and numba_link_only are off")

#: after the helper's tasks, this process's own and a run's warm-up: how the run got each of
#: the helper's kernels (cache hits, misses) and how many specialisations each task's kernel has
RUN_AND_REPORT = """
import simcore, simcore.runner as s
from simcore.startup import parallel_compile as pc
s.start_helper = lambda: None
tasks = pc.compile_tasks()
for name in pc.MAIN_TASKS:
    pc.compile_task(tasks[name])
s.warm_up(simcore.load_config())
for name, (kernel, _) in tasks.items():
    st = kernel.stats
    print(name, st.cache_hits.total(), st.cache_misses.total(), len(kernel.signatures))
from simcore.startup import patches
print("linked", ",".join(patches.LINKED) or "-", ",".join(patches.LINK_FAILED) or "-")
"""


@pytest.mark.slow
@needs_lock
def test_the_run_loads_what_the_helper_compiled(tmp_path):
    """With an empty cache, the helper's kernels are those the run then needs: it finds each
    in the cache (a hit, no compilation), and no kernel of the plan gets a second
    specialisation, so the tasks' argument types are the run's."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    done = subprocess.run([sys.executable, "-c", parallel_compile.HELPER], env=env, check=True,
                          capture_output=True, text=True).stdout.split("\n")
    assert [line.split()[:2] for line in done[:-1]] == [
        ["done", name] for name in parallel_compile.HELPER_TASKS]
    out = subprocess.run([sys.executable, "-c", RUN_AND_REPORT], env=env, check=True,
                         capture_output=True, text=True).stdout.split("\n")
    *counts, linked = [line.split() for line in out if line]
    # the loop and the step kernels compiled here linked, none failed
    assert linked[0] == "linked" and linked[2] == "-"
    assert "integrate_chunk" in linked[1].split(",")
    report = {name: (int(hits), int(misses), int(n)) for name, hits, misses, n in counts}
    for name in parallel_compile.HELPER_TASKS:
        assert report[name] == (1, 0, 1), name
    for name, (_hits, _misses, n_signatures) in report.items():
        assert n_signatures == 1, name


#: a run's warm-up without a helper (so that nothing but the run compiles or loads here), then
#: whether each task's argument types are among the specialisations the run itself made or
#: loaded of the kernels it calls from Python
RUN_TYPES = """
import simcore, simcore.runner as s
from numba import typeof
from simcore.startup import parallel_compile as pc
s.start_helper = lambda: None
s.warm_up(simcore.load_config())
tasks = pc.compile_tasks()
for name in ("loop", "contact_velocities", "initial_acceleration", "energy", "energy_scale"):
    kernel, args = tasks[name]
    print(name, tuple(typeof(a) for a in args) in kernel.signatures, len(kernel.signatures))
"""


def test_the_tasks_have_the_run_s_argument_types():
    """The tasks of the kernels a run calls from Python have the types the run gives them (in a
    new process whose run compiles or loads them itself; the stages, which only the loop
    calls, are checked by the slow test above)."""
    out = subprocess.run([sys.executable, "-c", RUN_TYPES], check=True, capture_output=True,
                         text=True).stdout.split("\n")
    assert [line.split() for line in out if line] == [
        [name, "True", "1"]
        for name in ("loop", "contact_velocities", "initial_acceleration", "energy",
                     "energy_scale")]
    assert set(parallel_compile.compile_tasks()) == set(
        parallel_compile.HELPER_TASKS + parallel_compile.MAIN_TASKS + ("loop",))


def test_a_failing_share_leaves_the_compilation_to_the_run(monkeypatch):
    """An error in this process's share of a shared compile does not reach the run: the
    warm-up goes on and the run compiles (here: loads) what it needs."""
    import simcore.runner as sim

    def failing(helper):
        raise RuntimeError("the helper's protocol broke")

    monkeypatch.setattr(sim, "compile_with_helper", failing)
    monkeypatch.setattr(sim, "_warm", set())
    assert sim.warm_up(simcore.load_config()) > 0.0


def test_no_helper_with_a_warm_cache():
    warm_up(simcore.load_config())
    if patches.enabled("parallel_compile"):
        assert patches.in_cache(nb.integrate_chunk) is True
    assert parallel_compile.start_helper() is None


def test_waiting_for_the_helper_s_report():
    """A task is waited for until the helper reports it done; a helper that ends without
    reporting it, or does not report it in time, is not waited for any longer."""
    quick = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdout.buffer.write("
                              "b'done a 1.5\\n\\xff\\xfe\\ndone x y\\nwhat\\ndone b 2.0\\n')"],
                             stdout=subprocess.PIPE)
    helper = parallel_compile.Helper(quick)
    # (lines that are not reports, undecodable bytes among them, are passed over)
    assert helper.wait_for("b") and helper.done == {"a": 1.5, "b": 2.0}
    assert not helper.wait_for("c")  # ended without it
    helper.stop()
    slow = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"],
                            stdout=subprocess.PIPE)
    helper = parallel_compile.Helper(slow)
    assert not helper.wait_for("a", limit=0.2)
    helper.stop()
    assert slow.returncode is not None


def test_cache_state_unknown_without_a_cache():
    uncached = numba.njit(lambda x: x + 1)
    assert patches.in_cache(uncached) is None
    parallel_compile.stop_helper(None)  # nothing to stop
