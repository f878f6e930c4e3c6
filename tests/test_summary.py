"""The study summary on small synthetic files: steady window, counts per revolution against a
hand-counted series, per-race peaks, absolute force levels, failed points, CF attributes."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from analysis.summary import category_codes, steady_window, summarize
from simcore.io import write_netcdf

DT = 1.0e-3
T_END = 3.0


def _theta(t):
    """A crank that slows down (free drive): 1.5 rev/s at the start, decelerating."""
    return 2.0 * np.pi * (1.5 * t - 0.1 * t**2)


# The hand-made impact series: (time [s], race, kind, F_max [N]).
# The crank has turned 1 revolution at t = 0.69926 s (1.5 t - 0.1 t^2 = 1), i.e. at the sample
# t = 0.700 s; from there to 3 s it turns 3.6 - 1.001 = 2.599 revolutions.
SERIES = [
    (0.200, "outer", "simple", 5000.0),     # start-up
    (0.690, "inner", "simple", 800.0),      # start-up (before 0.700 s)
    (0.900, "outer", "simple", 150.0),
    (1.300, "outer", "persistent", 1200.0),
    (1.800, "inner", "simple", 90.0),
    (2.200, "outer", "simple", np.nan),     # no approach: an impact without a force
    (2.500, "outer", "pinch", 2000.0),
    (2.950, "inner", "persistent", 101.0),
]
STEADY_REVS = 2.599


def _point(clearance, mu=0.0):
    return {"clearance": clearance, "mu": mu, "omega0": 9.42, "e_N": 0.9}


def _run(path, point, failed=False):
    if failed:
        ds = xr.Dataset(coords=point, attrs={"failed": 1, "error": "did not converge"})
    else:
        t = np.round(np.arange(0.0, T_END + DT / 2, DT), 12)
        lam = np.zeros((t.size, 2))
        lam[5, 1] = 2e-3
        iterations = np.tile([2, 3, 1], (t.size, 1))
        iterations[0] = 0
        iterations[7] = [3, 5, 2]
        converged = np.ones(t.size, dtype="i1")
        converged[10] = 0
        ds = xr.Dataset(
            {
                "Lambda_N": (("time", "contact"), lam),
                "iterations": (("time", "stage"), iterations),
                "converged": ("time", converged),
                "crank_angle": ("time", _theta(t)),
            },
            coords={"time": t, "contact": [0, 1], "stage": ["smooth", "position", "velocity"],
                    **point},
            attrs={"wall_time_s": 1.5},
        )
    ds.to_netcdf(path)


def _impacts(path, point, new_format=True, failed=False, series=SERIES):
    if failed:
        xr.Dataset(coords=point, attrs={"failed": 1}).to_netcdf(path)
        return
    time, race, kind, force = (np.array(c) for c in zip(*series, strict=True))
    data = {"time": ("impact", time.astype(float)), "F_max": ("impact", force.astype(float))}
    if new_format:  # integer categories (codes in a different order than the summary's)
        race_names, kind_names = ["outer", "inner"], ["multi", "pinch", "persistent", "simple"]
        data["race"] = ("impact", np.array([race_names.index(r) for r in race], "i1"),
                        {"flag_values": np.arange(2, dtype="i1"),
                         "flag_meanings": " ".join(race_names)})
        data["kind"] = ("impact", np.array([kind_names.index(k) for k in kind], "i1"),
                        {"flag_values": np.arange(4, dtype="i1"),
                         "flag_meanings": " ".join(kind_names)})
        data["p_max"] = ("impact", force.astype(float) * 1e5)
        flags = np.zeros(time.size, "i4")
        if series is SERIES:
            flags[3] = 4  # the 1200 N impact is flagged
            flags[0] = 1  # a start-up impact: not in the steady window
        data["flags"] = ("impact", flags)
    else:  # an older table: strings, no p_max, no flags
        data["race"] = ("impact", race.astype(str))
        data["kind"] = ("impact", kind.astype(str))
    xr.Dataset(data, coords=point, attrs={"zero_threshold": 2e-7}).to_netcdf(path)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """A 2 x 2 grid: new-format table, old-format table, a failed run, an empty table."""
    tmp = tmp_path_factory.mktemp("summary")
    runs, impacts = [], []
    for clearance in (1e-4, 4e-4):
        for mu in (0.0, 0.01):
            point = _point(clearance, mu)
            name = f"c{clearance}_m{mu}.nc"
            failed = clearance == 4e-4 and mu == 0.01
            _run(tmp / f"run_{name}", point, failed=failed)
            if clearance == 4e-4 and mu == 0.0:
                _impacts(tmp / f"imp_{name}", point, series=[(0.1, "inner", "simple", 10.0)])
            else:
                _impacts(tmp / f"imp_{name}", point, new_format=(mu == 0.0), failed=failed)
            runs.append(tmp / f"run_{name}")
            impacts.append(tmp / f"imp_{name}")
    s = summarize(runs, impacts, scheduler="synchronous", settle=1.0,
                  force_levels=[1000.0, 100.0], settings={"settle": 1.0, "zero_tol": 1e-4})
    path = write_netcdf(s, tmp / "summary.nc")
    return s, path


NEW, OLD = _point(1e-4, 0.0), _point(1e-4, 0.01)
EMPTY, FAILED = _point(4e-4, 0.0), _point(4e-4, 0.01)


def test_steady_window_of_a_slowing_crank():
    t = np.round(np.arange(0.0, T_END + DT / 2, DT), 12)
    t_settle, revs = steady_window(t, _theta(t), 1.0)
    assert t_settle == pytest.approx(0.700)
    assert revs == pytest.approx(STEADY_REVS, rel=1e-12)
    assert steady_window(t, _theta(t), 0.0) == (0.0, pytest.approx(3.6))
    assert steady_window(t, _theta(t), 5.0) == (T_END, 0.0)  # never turns 5 revolutions


def test_steady_window_constant_drive():
    omega, dt = 50.0, 1e-4
    t = np.arange(0, 4000) * dt
    t_settle, revs = steady_window(t, 0.3 + omega * t, 2.0)
    # 2 revolutions = 0.251327 s: the first sample at or after it
    assert t_settle == pytest.approx(np.ceil(4 * np.pi / omega / dt) * dt)
    assert revs == pytest.approx(omega * (t[-1] - t_settle) / (2 * np.pi))


def test_counts_per_revolution_against_the_hand_counted_series(study):
    s, _ = study
    for point in (NEW, OLD):
        at = s.sel(point)
        assert float(at["settle_time"]) == pytest.approx(0.700)
        assert float(at["revolutions"]) == pytest.approx(STEADY_REVS)
        # steady window, counted by hand from SERIES: outer 2 simple (0.9, 2.2 s), 1 persistent,
        # 1 pinch; inner 1 simple (1.8 s), 1 persistent (2.95 s)
        n = at["n_impacts"].transpose("race", "kind").values
        np.testing.assert_array_equal(n, [[1, 1, 0, 0], [2, 1, 1, 0]])
        np.testing.assert_allclose(at["impacts_per_rev"].sel(race=1, kind=0), 2 / 2.599)
        np.testing.assert_allclose(at["impacts_per_rev"].sel(race=0, kind=0), 1 / 2.599)
        # levels sorted: 100 N, 1000 N; outer 150, 1200, 2000 N; inner 101 N (90 N is below)
        np.testing.assert_array_equal(at["level"], [100.0, 1000.0])
        np.testing.assert_array_equal(at["n_above"].transpose("race", "level"), [[1, 0], [3, 2]])
        np.testing.assert_allclose(at["above_per_rev"].sel(race=1), np.array([3, 2]) / 2.599)
        np.testing.assert_array_equal(at["peak_force"], [101.0, 2000.0])
        np.testing.assert_array_equal(at["top3_force"], [2000.0, 1200.0, 150.0])
        assert float(at["startup_peak_force"]) == 5000.0
        assert float(at["zero_threshold"]) == 2e-7


def test_columns_that_an_older_table_lacks_are_missing(study):
    s, _ = study
    np.testing.assert_array_equal(s["p_max"].sel(NEW), [101e5, 2000e5])
    assert float(s["n_flagged"].sel(NEW)) == 1.0  # the start-up flag does not count
    np.testing.assert_array_equal(s["peak_force_flagged"].sel(NEW), [0.0, 0.0])
    assert bool(s["p_max"].sel(OLD).isnull().all())
    assert bool(s["n_flagged"].sel(OLD).isnull())


def test_run_numbers_failed_and_empty_points(study):
    s, _ = study
    assert s["peak_force"].dims == ("clearance", "mu", "omega0", "e_N", "race")
    np.testing.assert_array_equal(s["iter_max"].sel(NEW), [3, 5, 2])
    assert float(s["converged_fraction"].sel(NEW)) == pytest.approx(1 - 1 / 3000)
    assert float(s["max_Lambda_N"].sel(NEW)) == 2e-3
    # only a start-up impact: no steady impact (zero counts, no peak), a start-up peak
    assert float(s["n_impacts"].sel(EMPTY).sum()) == 0.0
    assert bool(s["peak_force"].sel(EMPTY).isnull().all())
    assert float(s["startup_peak_force"].sel(EMPTY)) == 10.0
    # the failed point: flagged, and missing (NaN) everywhere else, not zero
    assert float(s["failed"].sel(FAILED)) == 1.0 and int(s["failed"].sum()) == 1
    for name in s.data_vars:
        if name != "failed":
            assert bool(s[name].sel(FAILED).isnull().all()), name
    assert s.attrs["n_failed"] == 1


def test_summary_file_is_cf_style(study):
    _, path = study
    import netCDF4

    with netCDF4.Dataset(path) as nc:
        assert nc.getncattr("Conventions") == "CF-1.10"
        assert "summary of 4 runs" in nc.getncattr("history")
        for name, var in nc.variables.items():
            assert var.dtype != str and var.dtype.kind != "S", f"{name} is a string variable"
            attrs = var.ncattrs()
            assert "units" in attrs and "long_name" in attrs, name
            if name in nc.dimensions:
                assert "_FillValue" not in attrs, f"coordinate {name} has a fill value"
        assert nc.variables["race"].getncattr("flag_meanings") == "inner outer"
        assert nc.variables["kind"].getncattr("flag_meanings") == "simple persistent pinch multi"
        assert list(nc.variables["race"][:]) == [0, 1]
    with xr.open_dataset(path) as ds:
        assert ds["peak_force"].sel(NEW).values.tolist() == [101.0, 2000.0]


def test_category_codes():
    np.testing.assert_array_equal(category_codes(["outer", "inner", "x"]), [1, 0, -1])
    np.testing.assert_array_equal(category_codes(np.array([0, 1, 2]), "outer inner"), [1, 0, -1])
    np.testing.assert_array_equal(category_codes(np.array([0.0, np.nan])), [0, -1])


def test_bad_arguments():
    with pytest.raises(ValueError, match="settle"):
        summarize(["a"], ["b"], settle=-1)
    with pytest.raises(ValueError, match="force_levels"):
        summarize(["a"], ["b"], force_levels=[0.0])
