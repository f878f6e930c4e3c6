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

RUN_AND_REPORT = (
    "import simcore, simcore.simulate as s; from simcore import kernels as nb; "
    "s.start_helper = lambda: None; s.warm_up(simcore.load_config()); "
    "st = nb.velocity_step.stats; print(st.cache_hits.total(), st.cache_misses.total())"
)


@pytest.mark.slow
def test_the_loop_loads_what_the_helper_compiled(tmp_path):
    """With an empty cache, the helper's velocity_step is the one the time loop then needs:
    the run finds it in the cache (a hit, no compilation), so the helper's argument types are
    the loop's."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    subprocess.run([sys.executable, "-c", parallel_compile.HELPER], env=env, check=True)
    out = subprocess.run([sys.executable, "-c", RUN_AND_REPORT], env=env, check=True,
                         capture_output=True, text=True).stdout.split()
    assert out == ["1", "0"]


def test_no_helper_with_a_warm_cache():
    warm_up(simcore.load_config())
    assert parallel_compile.in_cache(nb.velocity_step) is True
    assert parallel_compile.start_helper() is None


def test_cache_state_unknown_without_a_cache():
    uncached = numba.njit(lambda x: x + 1)
    assert parallel_compile.in_cache(uncached) is None
    parallel_compile.stop_helper(None)  # nothing to stop
