"""The Numba cache is keyed by the kernel sources: an edit in one module recompiles its callers
in other modules (Numba alone checks only the file that defines a function)."""

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from simcore.startup import numba_cache, patches

ROOT = Path(__file__).resolve().parents[1]


def test_key_changes_with_any_kernel_source(tmp_path):
    folder = tmp_path / "kernels"
    shutil.copytree(numba_cache.KERNELS_DIR, folder, ignore=shutil.ignore_patterns("__pycache__"))
    key = numba_cache.kernel_source_key(folder)
    assert key == numba_cache.kernel_source_key(numba_cache.KERNELS_DIR)
    assert len(key) == 12 and int(key, 16) >= 0
    (folder / "contact.py").write_text((folder / "contact.py").read_text() + "\n# edited\n")
    edited = numba_cache.kernel_source_key(folder)
    assert edited != key
    # a new module counts as well
    (folder / "extra.py").write_text("X = 1\n")
    assert numba_cache.kernel_source_key(folder) not in (key, edited)
    suffix = f"-{numba_cache.ENTRIES}" if numba_cache.all_entries() else ""
    expected = f"numba-{numba_cache.kernel_source_key(folder)}{suffix}"
    assert numba_cache.cache_dir_for(folder).name == expected


def test_every_kernel_caches_in_the_keyed_folder():
    from simcore import kernels

    if os.environ.get("NUMBA_CACHE_DIR"):
        pytest.skip("the user chose NUMBA_CACHE_DIR; the keyed folder is not used")
    assert Path(kernels.CACHE_DIR) == numba_cache.cache_dir_for()
    for name in ("integrate_chunk", "smooth_step", "contact_rows", "body_point",
                 "total_energy", "contact_forces"):
        path = getattr(kernels, name)._cache._cache_path
        assert Path(path).is_relative_to(kernels.CACHE_DIR), (name, path)


def test_analysis_kernels_cache_in_the_same_folder_when_analysis_is_imported_first():
    """In a fresh process that imports ``analysis`` before ``simcore`` (the study's warm-up
    does), every analysis kernel caches in the simulation kernels' folder, where the jobs
    look."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        pytest.skip("the user chose NUMBA_CACHE_DIR; the keyed folder is not used")
    code = (
        "import analysis, analysis.forces, analysis.filtering\n"
        "from numba.core.registry import CPUDispatcher\n"
        "from simcore import kernels\n"
        "paths = [f._cache._cache_path for m in (analysis.forces, analysis.filtering)\n"
        "         for f in vars(m).values() if isinstance(f, CPUDispatcher)]\n"
        "print(len(paths), all(p.startswith(kernels.CACHE_DIR) for p in paths))\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    count, inside = res.stdout.split()
    assert int(count) >= 2 and inside == "True", res.stdout


CALLEE = """
from numba import njit


@njit(cache=True)
def value():
    return {value}
"""
CALLER = """
from numba import njit

from .callee import value


@njit(cache=True)
def twice():
    return 2 * value()
"""
INIT = """
from pathlib import Path

from simcore.startup.numba_cache import configure_cache

{keyed}CACHE_DIR = configure_cache(Path(__file__).parent)
"""


def _make_package(root, keyed):
    pkg = root / "kpkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text(textwrap.dedent(INIT.format(keyed="" if keyed else "# ")))
    (pkg / "callee.py").write_text(CALLEE.format(value=1))
    (pkg / "caller.py").write_text(CALLER)
    return pkg


def _run(root, env):
    code = "from kpkg.caller import twice; print(twice())"
    out = subprocess.run([sys.executable, "-c", code], cwd=root, env=env, capture_output=True,
                         text=True, check=True)
    return int(out.stdout.strip())


@pytest.mark.parametrize("keyed", [True, False])
def test_editing_a_callee_in_another_module_recompiles_the_caller(tmp_path, keyed):
    pkg = _make_package(tmp_path, keyed)
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), str(ROOT)])
    if not keyed:
        # what Numba does by itself: one fixed cache folder, checked per defining file
        env["NUMBA_CACHE_DIR"] = str(tmp_path / "plain-cache")
    assert _run(tmp_path, env) == 2
    assert _run(tmp_path, env) == 2  # from the cache
    (pkg / "callee.py").write_text(CALLEE.format(value=5))
    if keyed:
        assert _run(tmp_path, env) == 10
        assert len(list(pkg.glob("__pycache__/numba-*"))) == 2
    else:
        # the pitfall the keying removes: the caller's cached code still returns the old value
        assert _run(tmp_path, env) == 2


def _save_entries(folder, worker, count, barrier):
    from numba.core.caching import IndexDataCacheFile

    cache = IndexDataCacheFile(folder, "kernel", "stamp")
    barrier.wait()
    for i in range(count):
        cache.save((worker, i), ("code of", worker, i))


def test_cache_saves_of_several_processes_keep_every_entry(tmp_path):
    """Processes saving different entries of one function at the same time (the compile helper
    and the warm-up processes do): with the locked save every entry is there afterwards with
    its own data. (Numba's unlocked save loses entries or mixes up their data files here.)"""
    import multiprocessing

    from numba.core.caching import IndexDataCacheFile

    if not patches.enabled("parallel_compile"):
        pytest.skip("start-up patch parallel_compile is off: saves are Numba's own")
    assert patches.cache_writes_locked()
    context = multiprocessing.get_context("fork")
    workers, count = 4, 25
    barrier = context.Barrier(workers)
    procs = [context.Process(target=_save_entries, args=(str(tmp_path), w, count, barrier))
             for w in range(workers)]
    for proc in procs:
        proc.start()
    for proc in procs:
        proc.join(60)
        assert proc.exitcode == 0
    cache = IndexDataCacheFile(str(tmp_path), "kernel", "stamp")
    for w in range(workers):
        for i in range(count):
            assert cache.load((w, i)) == ("code of", w, i)




def _toy_stage(x, i):
    return x[i] * x[i] + 1.0


_stage = njit(_toy_stage)


def _toy_loop(x, out):
    for i in range(x.shape[0]):
        out[i] = _stage(x, i)
    return out.sum()


def test_a_loop_kernel_is_linked():
    """A registered loop's library is only linked (simcore.startup.patches.link_only): the hook
    runs for it, without falling back on Numba's optimisation, and the loop computes what the
    Python function computes. (That the paper case keeps its speed and figures is measured by
    benchmarks/bench_core.py and tested by the crank-slider tests.)"""
    x = np.linspace(0.0, 1.0, 7)
    expected = _toy_loop(x, np.zeros(7))
    linked = njit(patches.link_only(_toy_loop))
    before = len(patches.LINKED)
    assert linked(x, np.zeros(7)) == expected
    if not patches.enabled("numba_link_only"):  # switched off: Numba's own optimisation
        assert not patches.INSTALLED["numba_link_only"] and patches.LINKED[before:] == []
        return
    assert patches.INSTALLED["numba_link_only"]
    assert patches.LINKED[before:] == ["_toy_loop"] and not patches.LINK_FAILED


def _toy_step(x, out):
    s = 0.0
    for i in range(x.shape[0]):
        out[i] = _stage(x, i)
        s += out[i]
    return s


def test_a_step_kernel_is_linked():
    """A step kernel (simcore.kernels.jit.step_kernel) is registered as a loop is: called from
    Python (through its twin with an entry), its library is only linked and it computes what
    the Python function computes."""
    from simcore.kernels.jit import step_kernel

    x = np.linspace(0.0, 1.0, 5)
    expected = _toy_step(x, np.zeros(5))
    before = len(patches.LINKED)
    assert step_kernel(_toy_step)(x, np.zeros(5)) == expected
    if not patches.enabled("numba_link_only"):
        assert patches.LINKED[before:] == []
        return
    assert patches.LINKED[before:] == ["_toy_step"] and not patches.LINK_FAILED


def test_a_noinline_callee_is_left_as_it_is():
    """``noinline`` excludes ``alwaysinline`` (LLVM refuses the pair): the linking passes over
    such a callee (llvmlite reports attributes as bytes)."""
    import llvmlite.binding as llvm

    module = llvm.parse_assembly("define void @a() noinline { ret void }\n"
                                 "define void @b() { ret void }\n")
    assert [patches.has_noinline(f) for f in module.functions] == [True, False]


COMPLIANT_LINKED = """
import simcore
from simcore.startup import patches
from simcore.runner import warm_up
warm_up(simcore.load_config(overrides=["model.contact_model=compliant", "solver.dt=1e-6"]))
print(",".join(patches.LINKED), ",".join(patches.LINK_FAILED) or "-")
"""


@pytest.mark.slow
@pytest.mark.skipif(not patches.enabled("numba_link_only"),
                    reason="start-up patch numba_link_only is off")
def test_the_compliant_loop_is_linked(tmp_path):
    """With an empty cache the compliant model's time loop and the step kernels it compiles
    are linked, none falls back."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", COMPLIANT_LINKED], env=env, check=True,
                         capture_output=True, text=True).stdout.split()
    linked, failed = out
    assert failed == "-"
    assert {"integrate_compliant_chunk", "compliant_smooth_step"} <= set(linked.split(","))
