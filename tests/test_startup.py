"""A new process's first run: what it imports and what it loads, with the results unchanged.

The start-up patches (:mod:`simcore.startup.patches`, docs/performance.md) save time by not
importing what a run does not use: SciPy's ``scipy.linalg`` package (Numba's BLAS check is
served by the ``cython_blas`` module alone, ``scipy_blas``) and ``dask.array`` (the run's dataset
is built from xarray Variables made on the fast path, ``fast_dataset``). The run file is written
without the question to dask's scheduler that imports ``distributed`` (``netcdf_store``), and
xarray learns dask's array type only once ``dask.array`` is imported (``xarray_dask_type``).
These tests check that the patches give the same objects and files as the ordinary way, and
that ``BEARINGSIM_STARTUP_PATCHES=0`` turns them off.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

import simcore
from simcore import kernels as nb
from simcore.io import dataset_of_arrays, parameter_coords, write_netcdf
from simcore.model import SolverSettings
from simcore.model.mechanism import ball_in_ring, ball_on_plane, crank_slider, pinched_balls
from simcore.startup import patches

ROOT = Path(__file__).resolve().parents[1]


def _patched(*names):
    """Skip a test of what the start-up patches ``names`` do when they are switched off."""
    return pytest.mark.skipif(not all(patches.enabled(n) for n in names),
                              reason=f"start-up patches {', '.join(names)} switched off")

FRESH_PROCESS = r"""
import json, sys
import numpy as np
import simcore
xarray_before = "xarray" in sys.modules
ds = simcore.run(simcore.load_config(overrides=["solver.t_end=2e-4"]))
from numba.np import arraymath
out = {"xarray_before": xarray_before, "dataset_type": type(ds).__module__,
       "scipy_linalg": "scipy.linalg" in sys.modules,
       "dask_array": "dask.array" in sys.modules,
       "dask": "dask" in sys.modules,
       "have_blas": bool(arraymath._HAVE_BLAS),
       "steps": int(ds.sizes["time"]) - 1}
simcore.write_netcdf(ds, sys.argv[1])
out["distributed"] = "distributed" in sys.modules
out["dask_array_after_write"] = "dask.array" in sys.modules
import scipy.linalg
import scipy.linalg.cython_blas
out["attribute"] = scipy.linalg.cython_blas is sys.modules["scipy.linalg.cython_blas"]
from numba import njit

@njit
def product(a, b):
    return a @ b  # BLAS through the preloaded module

a = np.arange(9.0).reshape(3, 3)
out["product_error"] = float(np.abs(product(a, a) - a @ a).max())
print(json.dumps(out))
"""


@_patched("scipy_blas", "fast_dataset", "netcdf_store", "xarray_dask_type")
def test_first_run_imports_neither_scipy_linalg_nor_dask_nor_distributed(tmp_path):
    env = dict(os.environ, NUMBA_NUM_THREADS="1",
               PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-c", FRESH_PROCESS, str(tmp_path / "run.nc")],
                          capture_output=True, text=True, env=env, cwd=ROOT, timeout=600)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["steps"] == 2
    # xarray was imported during the run (in the background, simcore.runner.import_meanwhile)
    assert not out["xarray_before"] and out["dataset_type"].startswith("xarray")
    assert not out["scipy_linalg"], "Numba's BLAS check imported the scipy.linalg package"
    assert not out["dask_array"], "building the run's dataset imported dask.array"
    assert not out["dask"], "building the run's dataset imported dask"
    assert not out["distributed"], "writing the run file imported distributed"
    assert not out["dask_array_after_write"], "writing the run file imported dask.array"
    assert out["have_blas"], "Numba must still see BLAS"
    # imported later the ordinary way, scipy.linalg carries the preloaded module
    assert out["attribute"]
    # and a kernel that uses BLAS compiles and computes A A
    assert out["product_error"] == 0.0


DASK_STAND_IN = r"""
import json, sys
import simcore.io
from simcore.startup import patches
from xarray.namedarray.pycompat import array_type, mod_version
import xarray as xr
out = {"deferred": patches.dask_array_type_deferred(), "before": list(array_type("dask")),
       "imported": "dask.array" in sys.modules}
import dask
import dask.array as da
v = xr.Variable(("x",), da.ones(4, chunks=2))
out.update(after=array_type("dask") == (da.Array,), chunks=list(v.chunks[0]),
           version=str(mod_version("dask")) == dask.__version__,
           lazy=xr.Dataset({"a": v}).a.chunks is not None)
print(json.dumps(out))
"""


@_patched("xarray_dask_type")
def test_xarray_sees_dask_arrays_with_the_deferred_type():
    """The start-up patch's stand-in for xarray's record of dask: no dask.array import until it is
    imported, and then xarray recognises dask arrays as it does without the stand-in."""
    proc = subprocess.run([sys.executable, "-c", DASK_STAND_IN], capture_output=True,
                          text=True, cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out == {"deferred": True, "before": [], "imported": False, "after": True,
                   "chunks": [2, 2], "version": True, "lazy": True}


def test_import_meanwhile_imports_and_leaves_a_failure_to_the_caller():
    from simcore.runner import import_meanwhile

    assert import_meanwhile("json") is None  # imported already: no thread
    name = "simcore_test_no_such_module"
    thread = import_meanwhile(name)
    thread.join(timeout=60)
    assert not thread.is_alive() and name not in sys.modules
    with pytest.raises(ModuleNotFoundError, match=name):
        __import__(name)  # the caller's own import reports the failure
    thread = import_meanwhile("colorsys")  # a small module nothing here imports
    if thread is not None:
        thread.join(timeout=60)
    assert "colorsys" in sys.modules


def _paper_model(**over):
    model = simcore.load_config()["model"]
    model.update(over)
    return crank_slider(model)[0]


@pytest.mark.parametrize("scene", [_paper_model, ball_on_plane, ball_in_ring, pinched_balls])
def test_constraint_rows_counts_what_the_kernel_counts(scene):
    model = scene()
    assert model.constraint_rows() == nb.joint_row_count(model.arrays().jt_type)


@pytest.mark.parametrize("drive, rows", [("free", 6), ("constant", 7)])
def test_crank_slider_constraint_rows_by_hand(drive, rows):
    # two revolute joints (crank on the ground, rod on the slider) and the slider's prismatic
    # joint, two rows each; the constant-speed drive adds its one prescribed angle
    assert _paper_model(drive=drive).constraint_rows() == rows


def _parts():
    rng = np.random.default_rng(3)
    attrs = {"units": "m", "long_name": "a length"}
    data = {
        "x": (("time", "contact"), rng.normal(size=(5, 4)), dict(attrs)),
        "it": (("time", "stage"), rng.integers(0, 9, size=(5, 3)).astype(np.int32),
               {"units": "1", "long_name": "iterations"}),
        "ok": (("time",), np.ones(5, np.int8), {"units": "1", "long_name": "flag",
                                                 "flag_values": np.array([0, 1], np.int8)}),
    }
    coords = {
        "time": ("time", np.arange(5) * 1e-4, {"units": "s", "long_name": "time"}),
        "contact": ("contact", np.arange(4), {"units": "1", "long_name": "contact"}),
        "race": ("contact", np.array(["inner", "inner", "outer", "outer"]),
                 {"long_name": "race"}),
        "stage": ("stage", np.array(["smooth", "position", "velocity"]),
                  {"long_name": "stage"}),
    }
    coords.update(parameter_coords({"clearance": 4e-4, "mu": 0.01}))
    coords.update({f"{k}_scalar": v for k, v in
                   parameter_coords({"e_N": 0.9}, length_one=False).items()})
    return data, coords, {"title": "t", "n": 3}


def test_dataset_of_arrays_is_the_ordinary_dataset(tmp_path):
    data, coords, attrs = _parts()
    fast = dataset_of_arrays(data, coords, attrs)
    plain = xr.Dataset(data, coords=coords, attrs=attrs)
    assert fast.identical(plain)
    for name in list(plain.variables):
        assert fast[name].dtype == plain[name].dtype, name
        assert fast[name].dims == plain[name].dims, name
    assert list(fast.variables) == list(plain.variables)
    assert set(fast.xindexes) == set(plain.xindexes) == {"time", "contact", "stage",
                                                        "clearance", "mu"}
    for name in plain.xindexes:
        assert type(fast[name].variable) is type(plain[name].variable), name
        assert fast.indexes[name].equals(plain.indexes[name])
        assert fast.indexes[name].dtype == plain.indexes[name].dtype
        assert fast.xindexes[name].coord_dtype == plain.xindexes[name].coord_dtype
    # and the files hold the same variables, types and values
    paths = [write_netcdf(ds, tmp_path / f"{i}.nc") for i, ds in enumerate((fast, plain))]
    with netCDF4.Dataset(paths[0]) as a, netCDF4.Dataset(paths[1]) as b:
        assert set(a.variables) == set(b.variables)
        for name in a.variables:
            va, vb = a.variables[name], b.variables[name]
            assert va.dtype == vb.dtype and va.dimensions == vb.dimensions, name
            assert {k: va.getncattr(k) for k in va.ncattrs()}.keys() == set(vb.ncattrs())
            np.testing.assert_array_equal(va[...], vb[...])


def test_dataset_of_arrays_leaves_object_values_to_xarray():
    data = {"x": (("a",), np.array([None, 1], dtype=object))}
    coords = {"a": ("a", np.array([1.5, 2.5]))}
    fast = dataset_of_arrays(data, coords, {})
    assert fast.identical(xr.Dataset(data, coords=coords))
    assert fast["x"].dtype == object


def _file_contents(path):
    """Everything a netCDF file holds, but its HDF5 layout: dimensions (with unlimited), global
    attributes, and per variable its dimensions, type, filters, chunking, attributes and the
    bytes of its values."""
    def attrs(obj):
        # repr: a NaN _FillValue equals itself as text
        return {k: repr(np.asarray(obj.getncattr(k)).tolist()) for k in obj.ncattrs()}

    with netCDF4.Dataset(path) as nc:
        out = {"dims": {k: (len(d), d.isunlimited()) for k, d in nc.dimensions.items()},
               "attrs": attrs(nc), "vars": {}}
        for name, var in nc.variables.items():
            var.set_auto_maskandscale(False)
            out["vars"][name] = (var.dimensions, str(var.dtype), var.filters(), var.chunking(),
                                 attrs(var), np.asarray(var[...]).tobytes())
    return out


def test_run_file_is_the_file_to_netcdf_writes(tmp_path):
    from simcore.io import netcdf_encoding, to_netcdf4

    cfg = simcore.load_config(overrides=["solver.t_end=2e-3"])
    ds = simcore.run(cfg)
    encoding = netcdf_encoding(ds)
    assert encoding["Lambda_N"]["zlib"] and encoding["time"]["_FillValue"] is None
    to_netcdf4(ds, tmp_path / "fast.nc", encoding)
    ds.to_netcdf(tmp_path / "plain.nc", engine="netcdf4", encoding=encoding)
    fast, plain = _file_contents(tmp_path / "fast.nc"), _file_contents(tmp_path / "plain.nc")
    assert fast == plain
    assert fast["vars"]["race"][1] == "|S1"  # labels as character arrays
    assert fast["vars"]["Lambda_N"][2]["zlib"]
    # and xarray reads them back alike
    with xr.open_dataset(tmp_path / "fast.nc") as a, xr.open_dataset(tmp_path / "plain.nc") as b:
        assert a.identical(b)


def test_unusual_datasets_go_through_to_netcdf(tmp_path):
    from simcore.io import to_netcdf4

    ds = xr.Dataset({"x": (("t",), np.arange(3.0))})
    ds.encoding["unlimited_dims"] = {"t"}
    to_netcdf4(ds, tmp_path / "u.nc", {})
    assert _file_contents(tmp_path / "u.nc")["dims"]["t"] == (3, True)
    bad = xr.Dataset({"x": (("t",), np.arange(3.0))}, attrs={"flag": None})
    with pytest.raises(TypeError, match="Invalid value for attr 'flag'"):
        to_netcdf4(bad, tmp_path / "bad.nc", {})


def test_collector_runs_again_after_the_first_run_and_the_command(tmp_path):
    import gc

    import simcore.cli

    assert gc.isenabled()
    simcore.run(simcore.load_config(overrides=["solver.t_end=2e-4"]))
    assert gc.isenabled()
    assert simcore.cli.main(["run", "--quiet", "--set", "solver.t_end=2e-4",
                             "--out", str(tmp_path / "r.nc")]) == 0
    assert gc.isenabled()
    # also when the command fails (bad input: exit code 2, no file)
    assert simcore.cli.main(["run", "--quiet", "--set", "solver.dt=-1",
                             "--out", str(tmp_path / "bad.nc")]) == 2
    assert gc.isenabled() and not (tmp_path / "bad.nc").exists()
    # a collector switched off by the caller stays off
    gc.disable()
    try:
        simcore.cli.main(["run", "--quiet", "--set", "solver.dt=-1",
                          "--out", str(tmp_path / "bad.nc")])
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_runs_in_threads_give_the_serial_results():
    # the kernels release the interpreter lock, so that runs in threads integrate in parallel:
    # each run's arrays are its own, and the threads' runs equal the serial ones bit for bit
    from concurrent.futures import ThreadPoolExecutor

    def one(mu):
        model = _paper_model(mu=mu)
        return model.simulate(SolverSettings(1e-4, 3e-3))

    serial = [one(mu) for mu in (0.0, 0.05)]
    with ThreadPoolExecutor(2) as pool:
        threaded = list(pool.map(one, (0.0, 0.05)))
    assert not np.array_equal(serial[0].q, serial[1].q)  # two different runs
    for a, b in zip(serial, threaded, strict=True):
        for name in ("q", "v", "lambda_N", "lambda_T", "gap_N", "iterations"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_every_kernel_releases_the_interpreter_lock():
    from numba.core.registry import CPUDispatcher

    kernels = [obj for obj in vars(nb).values() if isinstance(obj, CPUDispatcher)]
    assert len(kernels) > 20
    held = [k.py_func.__name__ for k in kernels if not k.targetoptions.get("nogil")]
    assert not held, f"kernels compiled without nogil: {held}"


def test_a_long_warm_up_says_that_it_compiles(monkeypatch):
    import io
    import time

    from simcore import runner as simulate

    def slow(model, cfg, **kwargs):  # stands for a compilation
        time.sleep(0.5)

    monkeypatch.setattr(simulate, "_simulate", slow)
    monkeypatch.setattr(simulate, "COMPILE_NOTICE_AFTER", 0.05)
    monkeypatch.setattr(simulate, "_warm", set())
    stream = io.StringIO()
    seconds = simulate.warm_up(notify=stream)
    lines = stream.getvalue().splitlines()
    assert seconds >= 0.5
    assert len(lines) == 2, lines
    assert lines[0].startswith("simcore: compiling the simulation kernels")
    assert lines[1] == f"simcore: kernels compiled in {seconds:.0f} s"
    # a quick load (the cache) says nothing; and without a stream nothing is said at all
    monkeypatch.setattr(simulate, "COMPILE_NOTICE_AFTER", 5.0)
    monkeypatch.setattr(simulate, "_warm", set())
    stream = io.StringIO()
    simulate.warm_up(notify=stream)
    assert stream.getvalue() == ""
    monkeypatch.setattr(simulate, "COMPILE_NOTICE_AFTER", 0.05)
    monkeypatch.setattr(simulate, "_warm", set())
    assert simulate.warm_up() >= 0.5


def test_warm_up_is_once_per_time_loop_fixed_and_adaptive_apart(monkeypatch):
    """The adaptive compliant loop is its own kernels: warming the fixed-step loop does not
    count for it (its loading would fall into the first adaptive run's wall time)."""
    from simcore import runner

    loops = []
    monkeypatch.setattr(runner, "_simulate",
                        lambda model, cfg, **kw: loops.append(cfg["solver"]["adaptive"]))
    monkeypatch.setattr(runner, "_warm", set())
    fixed = ["model.contact_model=compliant", "model.youngs_modulus=2.1e11", "solver.dt=1e-6"]
    runner.warm_up(simcore.load_config(overrides=fixed))
    runner.warm_up(simcore.load_config(overrides=fixed))  # (warm already)
    runner.warm_up(simcore.load_config(overrides=fixed + ["solver.adaptive=true"]))
    assert loops == [False, True]


AT_EXIT = r"""
import atexit, gc, sys
atexit.register(lambda: print("frozen", gc.get_freeze_count() > 0))  # runs after simcore's
import simcore
simcore.run(simcore.load_config(overrides=["solver.t_end=2e-4"]))
"""


@pytest.mark.parametrize("freeze", [True, False])
def test_the_first_run_freezes_the_heap_at_exit_unless_switched_off(freeze):
    """The interpreter's shut-down skips the objects alive at exit: frozen by the handler the
    first run registers (start-up patch gc_freeze), not with the patches switched off."""
    env = dict(os.environ, BEARINGSIM_STARTUP_PATCHES="1" if freeze else "0")
    proc = subprocess.run([sys.executable, "-c", AT_EXIT], capture_output=True, text=True,
                          cwd=ROOT, timeout=600, env=env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == f"frozen {freeze}"


SAME_FILE = r"""
import json, sys
import simcore
from simcore.startup import patches
ds = simcore.run(simcore.load_config(overrides=["solver.t_end=0.01"]))
for key in ("history", "wall_time_s", "compile_time_s"):
    ds.attrs[key] = 0
simcore.write_netcdf(ds, sys.argv[1])
print(json.dumps({"installed": patches.INSTALLED, "modules": sorted(sys.modules)}))
"""


def test_the_patches_change_no_byte_of_the_run_file(tmp_path):
    """The paper case's first 10 ms written by a new process with every start-up patch and
    with none (BEARINGSIM_STARTUP_PATCHES=1 and 0): the same file, byte for byte (but the
    time attributes); switched off, no patch is installed and the modules the patches keep out
    (scipy.linalg, dask.array) are imported the ordinary way."""
    out = {}
    for switch in ("1", "0"):
        env = dict(os.environ, BEARINGSIM_STARTUP_PATCHES=switch)
        proc = subprocess.run([sys.executable, "-c", SAME_FILE, str(tmp_path / f"{switch}.nc")],
                              capture_output=True, text=True, cwd=ROOT, timeout=600, env=env)
        assert proc.returncode == 0, proc.stderr
        out[switch] = json.loads(proc.stdout.strip().splitlines()[-1])
    assert (tmp_path / "1.nc").read_bytes() == (tmp_path / "0.nc").read_bytes()
    assert all(out["1"]["installed"].values()) and not any(out["0"]["installed"].values())
    assert set(out["1"]["installed"]) == set(patches.PATCHES)
    for module in ("scipy.linalg", "dask.array"):
        assert module not in out["1"]["modules"] and module in out["0"]["modules"], module


def test_a_bad_switch_value_is_refused_in_one_line():
    env = dict(os.environ, BEARINGSIM_STARTUP_PATCHES="scipy_blas,numba")
    proc = subprocess.run([sys.executable, "-c", "import simcore"], capture_output=True,
                          text=True, cwd=ROOT, timeout=300, env=env)
    assert proc.returncode != 0
    last = proc.stderr.strip().splitlines()[-1]
    assert last == ("ValueError: BEARINGSIM_STARTUP_PATCHES: 'numba' is not allowed; allowed: "
                    "0, 1 or a comma-separated list of " + ", ".join(patches.PATCHES))


@_patched("numba_internal_kernels")
def test_an_internal_kernel_has_no_python_entry_and_still_answers_python():
    """A kernel that only kernels call is compiled without a Python entry (its compiled
    library has no wrapper symbol); a call from Python goes to a twin with one and gives what
    the Python function gives; the kernels a run calls from Python keep their entry."""
    from numba import typeof

    from simcore.kernels.bodies import body_omega

    v = np.array([0.3, 0.5, -1.5, 2.0, -1.0, 4.0])
    args = (v, 1)
    sig = tuple(typeof(a) for a in args)
    body_omega.compile(sig)
    compiled = body_omega.overloads[sig]
    assert compiled.library.get_pointer_to_function(
        compiled.fndesc.llvm_cpython_wrapper_name) == 0
    assert body_omega(*args) == body_omega.py_func(*args) == 4.0
    assert body_omega.python_twin() is body_omega.python_twin()
    for entry in (nb.integrate_chunk, nb.initial_acceleration, nb.total_energy,
                  nb.contact_velocities_into, nb.body_point):
        assert not hasattr(entry, "python_twin"), entry


NO_TWINS = r"""
import simcore, sys
from numba.core.dispatcher import Dispatcher
from simcore import kernels
for over in ([], ["model.contact_model=compliant", "solver.dt=1e-6", "solver.output_dt=1e-5"],
             ["model.contact_model=compliant", "solver.adaptive=true", "solver.dt=1e-5",
              "solver.output_dt=1e-5"]):
    simcore.run(simcore.load_config(overrides=["solver.t_end=2e-3", *over]))
twins = sorted({f"{m.__name__}.{name}" for m in list(sys.modules.values())
                if m is not None and m.__name__.startswith("simcore.kernels")
                for name, d in vars(m).items()
                if isinstance(d, Dispatcher) and getattr(d, "_twin", None) is not None})
print(",".join(twins) or "-")
"""


@_patched("numba_internal_kernels")
def test_runs_call_no_internal_kernel_from_python():
    """Nonsmooth, compliant and adaptive runs call only entry kernels from Python: no internal
    kernel's twin is made (it would compile a second time what the cache holds)."""
    proc = subprocess.run([sys.executable, "-c", NO_TWINS], capture_output=True, text=True,
                          cwd=ROOT, timeout=900)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == "-"


def test_the_cache_folder_is_named_by_the_internal_kernels_patch(tmp_path):
    """Kernels without a Python entry and kernels with one never share a cache folder: with
    the patch off, a user's NUMBA_CACHE_DIR gets a subfolder."""
    code = "from simcore import kernels; print(kernels.CACHE_DIR)"
    folders = {}
    for switch in ("1", "0"):
        env = dict(os.environ, BEARINGSIM_STARTUP_PATCHES=switch, NUMBA_CACHE_DIR=str(tmp_path))
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              cwd=ROOT, timeout=300, env=env)
        assert proc.returncode == 0, proc.stderr
        folders[switch] = proc.stdout.strip().splitlines()[-1]
    assert folders == {"1": str(tmp_path), "0": str(tmp_path / "python-entries")}
