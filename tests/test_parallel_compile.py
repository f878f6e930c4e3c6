"""The helper process of a cold compilation (simcore.parallel_compile)."""

import os
import subprocess
import sys

import numba
import pytest

import simcore
from simcore import kernels as nb
from simcore import parallel_compile
from simcore.simulate import warm_up

#: after the helper's tasks, this process's own and a run's warm-up: how the run got each of
#: the helper's kernels (cache hits, misses) and how many specialisations each task's kernel has
RUN_AND_REPORT = """
import simcore, simcore.simulate as s
from simcore import parallel_compile as pc
s.start_helper = lambda: None
tasks = pc.compile_tasks()
for name in pc.MAIN_TASKS:
    pc.compile_task(tasks[name])
s.warm_up(simcore.load_config())
for name, (kernel, _) in tasks.items():
    st = kernel.stats
    print(name, st.cache_hits.total(), st.cache_misses.total(), len(kernel.signatures))
from simcore.kernels import jit
print("linked", ",".join(jit.LINKED) or "-", ",".join(jit.LINK_FAILED) or "-")
"""


@pytest.mark.slow
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
    assert linked == ["linked", "integrate_chunk", "-"]  # the loop linked, none failed
    report = {name: (int(hits), int(misses), int(n)) for name, hits, misses, n in counts}
    for name in parallel_compile.HELPER_TASKS:
        assert report[name] == (1, 0, 1), name
    for name, (_hits, _misses, n_signatures) in report.items():
        assert n_signatures == 1, name


def test_the_tasks_have_the_run_s_argument_types():
    """Each task compiles its kernel for the types a run gives it: the cache that the paper
    case's run has filled (or loaded from) holds an entry for each task's types. (The slow test
    above checks the same from an empty cache, where an entry of other types would show.)"""
    warm_up(simcore.load_config())
    if parallel_compile.in_cache(nb.integrate_chunk) is None:
        pytest.skip("no Numba cache to look in")
    tasks = parallel_compile.compile_tasks()
    assert set(tasks) == set(parallel_compile.HELPER_TASKS + parallel_compile.MAIN_TASKS
                             + ("loop",))
    for name, (kernel, args) in tasks.items():
        signature = tuple(numba.typeof(a) for a in args)
        assert kernel._cache.load_overload(signature, kernel.targetctx) is not None, name


def test_no_helper_with_a_warm_cache():
    warm_up(simcore.load_config())
    assert parallel_compile.in_cache(nb.integrate_chunk) is True
    assert parallel_compile.start_helper() is None
    parallel_compile.compile_with_helper(None)  # nothing to do


def test_waiting_for_the_helper_s_report():
    """A task is waited for until the helper reports it done; a helper that ends without
    reporting it, or does not report it in time, is not waited for any longer."""
    quick = subprocess.Popen([sys.executable, "-c", "print('done a 1.5'); print('done b 2.0')"],
                             stdout=subprocess.PIPE)
    helper = parallel_compile.Helper(quick)
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
    assert parallel_compile.in_cache(uncached) is None
    parallel_compile.stop_helper(None)  # nothing to stop
