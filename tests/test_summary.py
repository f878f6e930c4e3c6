"""The study summary on small synthetic files: steady window, counts per revolution and the
per-revolution peaks against hand-counted series of both models, per-race peaks, absolute force
levels, the method check between the models, failed points, CF attributes."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from hertz_exact import exact_ellipse

from analysis.summary import (
    COMPLIANT,
    NONSMOOTH,
    SteadyWindow,
    category_codes,
    steady_window,
    summarize,
)
from analysis.synthetic import PAPER_MODEL, make_compliant_run
from simcore.io import write_netcdf
from simcore.io.variables import LABEL_LENGTH

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
            attrs={"wall_time_s": 1.5, "solver.dt": DT},
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


# The compliant twin of the point NEW (omega0 = 9.42 rad/s: one revolution in 0.667 s):
# (contact, first sample time [s], forces of the samples) on 2 balls, contacts 0-1 inner, 2-3 outer
C_DT = 1.0e-3
C_PULSES = [
    (2, 0.200, [1000.0, 3000.0, 800.0]),    # start-up
    (2, 0.999, [500.0, 1900.0, 700.0]),     # steady revolution 0
    (3, 1.500, [300.0, 800.0]),             # revolution 1
    (3, 2.500, [1200.0]),                   # revolution 2
]


def _compliant_forces():
    t = np.round(np.arange(0.0, T_END + C_DT / 2, C_DT), 12)
    force = np.zeros((t.size, 4))
    for contact, start, values in C_PULSES:
        k = int(round(start / C_DT))
        force[k:k + len(values), contact] = values
    # one long inner episode across the boundary of revolutions 0 and 1 (t = 1.334 s)
    force[int(round(1.2 / C_DT)):int(round(1.6 / C_DT)) + 1, 0] = 200.0
    force[int(round(1.3 / C_DT)), 0] = 400.0
    return t, force


def _hertz(force, race, clearance):
    """p_max [Pa] and K [N m-1.5] of Hertz point contact on the paper's radii (E = 2.1e9 Pa)."""
    E, nu = PAPER_MODEL["model.youngs_modulus"], PAPER_MODEL["model.poisson_ratio"]
    r_b, r_a = PAPER_MODEL["model.ball_radius"], PAPER_MODEL["model.inner_radius"]
    r_c = r_a + 2 * r_b + clearance
    E_star = E / (2 * (1 - nu**2))
    R = r_b * r_a / (r_a + r_b) if race == "inner" else r_b * r_c / (r_c - r_b)
    a = (3 * force * R / (4 * E_star)) ** (1 / 3)
    return 3 * force / (2 * np.pi * a**2), 4 / 3 * E_star * np.sqrt(R)


def _groove_hertz(force, race, clearance, conformity):
    """p_max [Pa] of the elliptical contact of a ball in a groove of radius conformity times
    the ball's diameter, on the paper's radii, from Hertz's solution (SciPy's elliptic
    integrals, ``hertz_exact.exact_ellipse``)."""
    E, nu = PAPER_MODEL["model.youngs_modulus"], PAPER_MODEL["model.poisson_ratio"]
    r_b, r_a = PAPER_MODEL["model.ball_radius"], PAPER_MODEL["model.inner_radius"]
    r_c = r_a + 2 * r_b + clearance
    R_x = r_b * r_a / (r_a + r_b) if race == "inner" else r_b * r_c / (r_c - r_b)
    r_g = 2 * conformity * r_b
    R_y = r_b * r_g / (r_g - r_b)
    return exact_ellipse(R_x, R_y, E / (2 * (1 - nu**2)), force)[4]


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """A 2 x 2 grid: new-format table, old-format table, a failed run, an empty table; compliant
    twins at NEW (hand-built forces) and EMPTY (failed)."""
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
    _, force = _compliant_forces()
    twin = make_compliant_run(force, output_dt=C_DT, omega0=9.42, clearance=1e-4, mu=0.0)
    write_netcdf(twin, tmp / "twin_new.nc")
    write_netcdf(make_compliant_run(force, omega0=9.42, clearance=4e-4, mu=0.0, failed=True),
                 tmp / "twin_empty.nc")
    s = summarize({"nonsmooth": runs, "compliant": [tmp / "twin_empty.nc", tmp / "twin_new.nc"]},
                  {"nonsmooth": impacts}, scheduler="synchronous", settle=1.0,
                  force_levels=[1000.0, 100.0],
                  settings={"settle": 1.0, "zero_tol": 1e-4, "zoom_adaptive": True})
    path = write_netcdf(s, tmp / "summary.nc")  # (a boolean setting too: netCDF has none)
    return s, path


NEW, OLD = _point(1e-4, 0.0), _point(1e-4, 0.01)
EMPTY, FAILED = _point(4e-4, 0.0), _point(4e-4, 0.01)
PAPER = {"model": NONSMOOTH}
TWIN = {"model": COMPLIANT}


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
        at = s.sel(point).sel(PAPER)
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
    assert float(s["zero_threshold"].sel(NEW)) == 2e-7


def test_peak_per_revolution_of_the_paper_method(study):
    """theta = 2 pi (1.5 t - 0.1 t^2), settle 1: 2.6 steady revolutions, the tail of 0.6 is a
    revolution of its own; revolution k ends where 1.5 t - 0.1 t^2 = 2 + k: t = 1.4792 s,
    2.3765 s. Outer: 150 and 1200 N in revolution 0, none in 1 (the 2.2 s impact has no
    force), 2000 N in 2: median 1200 N. Inner: 90 N in 1, 101 N in 2, none in 0: median 90 N."""
    s, _ = study
    at = s.sel(NEW).sel(PAPER)
    np.testing.assert_array_equal(at["peak_force_rev_median"], [90.0, 1200.0])
    # spread (largest - smallest) / median: inner (101 - 0) / 90, outer (2000 - 0) / 1200
    np.testing.assert_allclose(at["peak_force_rev_spread"], [101.0 / 90.0, 2000.0 / 1200.0],
                               rtol=1e-15)


def test_spread_over_revolutions_is_missing_without_two_revolutions_or_a_median():
    """Three revolutions (turned 0..3 over t = 0..3 s): outer 100, 300, 200 N, spread
    (300 - 100) / 200; inner 50 N in the first alone, median 0 N, no spread. One revolution:
    no spread."""
    from analysis.summary import impact_numbers

    t = np.array([0.5, 1.5, 2.5, 0.5])
    race = np.array([1, 1, 1, 0])
    force = np.array([100.0, 300.0, 200.0, 50.0])
    args = dict(time=t, race=race, kind=np.zeros(4, np.int64), f_max=force, p_max=None,
                flags=None, levels=[100.0])
    grid = np.linspace(0.0, 3.0, 31)
    three = impact_numbers(**args, window=SteadyWindow(0.0, 3.0, grid, grid))
    np.testing.assert_array_equal(three["peak_force_rev_median"], [0.0, 200.0])
    assert np.isnan(three["peak_force_rev_spread"][0])
    assert three["peak_force_rev_spread"][1] == pytest.approx(1.0, rel=1e-15)
    one = impact_numbers(**args, window=SteadyWindow(0.0, 1.0, grid, grid / 3.0))
    assert np.isnan(one["peak_force_rev_spread"]).all()


def test_top3_of_the_paper_method_ranks_events_not_rows():
    """Rows of one event (a persistent contact: one stretch of load) give one rank, with their
    largest force; the counts above the levels still count rows."""
    from analysis.summary import impact_numbers

    t = np.array([0.5, 0.6, 0.7, 1.5, 2.5, 2.6])
    force = np.array([900.0, 950.0, 940.0, 300.0, 200.0, 100.0])
    events = np.array([1, 1, 1, 2, 3, 4])
    args = dict(time=t, race=np.ones(6, np.int64), kind=np.zeros(6, np.int64), f_max=force,
                p_max=None, flags=None, levels=[150.0])
    grid = np.linspace(0.0, 3.0, 31)
    window = SteadyWindow(0.0, 3.0, grid, grid)
    rows = impact_numbers(**args, window=window)
    np.testing.assert_array_equal(rows["top3_force"], [950.0, 940.0, 900.0])
    by_event = impact_numbers(**args, window=window, events=events)
    np.testing.assert_array_equal(by_event["top3_force"], [950.0, 300.0, 200.0])
    np.testing.assert_array_equal(by_event["n_above"], rows["n_above"])


def test_top3_of_a_synthetic_run_holds_one_force_per_stretch_of_load():
    """Through point_numbers: each of the paper method's top3 forces comes from another
    stretch of load (the contact's impulse above the zero threshold on consecutive steps,
    found here by a loop over the samples), and each is its stretch's largest force."""
    from analysis import extract_impacts
    from analysis.summary import point_numbers
    from analysis.synthetic import make_run_dataset

    run = make_run_dataset(n_steps=600)
    # a persistent contact: ball 3 on the outer race loaded over steps 100-179 with a varying
    # impulse and an approach, which the filter gives many rows of forces above the rest
    steps = np.arange(100, 180)
    run["Lambda_N"].values[steps, 11] = 5e-2 * (1.0 + 0.5 * np.sin(0.7 * steps))
    run["vn_free"].values[steps, 11] = -0.05
    imp = extract_impacts(run)
    top = point_numbers(run, imp, {"settle": 0.0})["top3_force"]
    rows = np.sort(imp["F_max"].values[np.isfinite(imp["F_max"].values)])[::-1][:3]
    assert (imp["contact"].values[np.isin(imp["F_max"].values, rows)] == 11).all()
    lam = run["Lambda_N"].transpose("contact", "time").values
    time = run["time"].values
    threshold = imp.attrs["zero_threshold"]
    best = {}  # (contact, first step of the stretch): its largest force
    for row in range(imp.sizes["impact"]):
        c, f = int(imp["contact"][row]), float(imp["F_max"][row])
        k = int(np.argmin(np.abs(time - float(imp["time"][row]))))
        start = k
        while start > 0 and lam[c, start - 1] > threshold:
            start -= 1
        if np.isfinite(f) and lam[c, k] > threshold:
            best[(c, start)] = max(best.get((c, start), 0.0), f)
    assert len(best) >= 3 and np.isfinite(top).all()
    np.testing.assert_array_equal(top, sorted(best.values(), reverse=True)[:3])


def test_revolution_peak_table_against_hand_placed_samples():
    """Three revolutions (turned 0..3 over t = 0..3 s), start-up to t = 0.2 s: each
    revolution's largest force per race, the start-up's, non-finite and unknown-race samples
    left out, 0 where a race has no force in a revolution."""
    from analysis.summary import revolution_peak_table

    t = np.array([0.1, 0.5, 0.7, 1.5, 2.2, 2.9, 2.5, 1.2, 0.9])
    race = np.array([1, 1, 1, 1, 1, 0, 0, -1, 0])
    force = np.array([900.0, 100.0, 150.0, 300.0, 200.0, 40.0, 60.0, 999.0, np.nan])
    grid = np.linspace(0.0, 3.0, 31)
    table = revolution_peak_table(SteadyWindow(0.2, 3.0, grid, grid), t, race, force)
    np.testing.assert_array_equal(table, [[0.0, 150.0], [0.0, 300.0], [60.0, 200.0]])
    unknown = revolution_peak_table(SteadyWindow(0.2, np.nan), t, race, force)
    assert unknown.shape == (0, 2)


def test_compliant_twin_against_its_hand_built_forces(study):
    """omega0 = 9.42 rad/s, settle 1: the revolutions of the steady window end at turned = 2, 3
    and the run's end (the tail of 0.498 revolution joins the third): t = 1.334, 2.001 s."""
    s, _ = study
    at = s.sel(NEW).sel(TWIN)
    t, force = _compliant_forces()
    theta = 9.42 * t
    settle_time, revolutions = steady_window(t, theta, 1.0)
    assert float(at["settle_time"]) == settle_time and float(at["revolutions"]) == revolutions
    # per revolution, outer: 1900, 800, 1200 N; inner: 400, 200 (the long episode), 0 N
    np.testing.assert_array_equal(at["peak_force"], [400.0, 1900.0])
    np.testing.assert_array_equal(at["peak_force_rev_median"], [200.0, 1200.0])
    np.testing.assert_allclose(at["peak_force_rev_spread"], [400.0 / 200.0, 1100.0 / 1200.0],
                               rtol=1e-15)
    assert float(at["startup_peak_force"]) == 3000.0
    # episodes of the steady window: outer 1900, 800, 1200 N; inner one of 400 N
    np.testing.assert_array_equal(at["top3_force"], [1900.0, 1200.0, 800.0])
    np.testing.assert_array_equal(at["n_above"].transpose("race", "level"), [[1, 0], [3, 2]])
    np.testing.assert_allclose(at["above_per_rev"].sel(race=1), np.array([3, 2]) / revolutions)
    for r, race in enumerate(("inner", "outer")):
        expected, _ = _hertz(float(at["peak_force"][r]), race, 1e-4)
        assert float(at["p_max"][r]) == pytest.approx(expected, rel=1e-12)


def test_groove_pressure_is_hertz_at_the_peak_with_the_life_conformities(study):
    """p_max_groove: the elliptical contact of a real groove (conformities 0.52 inner, 0.53
    outer, analysis.life_conformity's default) at each race's steady peak; below the in-plane
    p_max, whose sphere contact is far less conforming. A run without the model's radii (the
    hand-made nonsmooth files) has none."""
    s, _ = study
    at = s.sel(NEW).sel(TWIN)
    for r, (race, f) in enumerate((("inner", 0.52), ("outer", 0.53))):
        expected = _groove_hertz(float(at["peak_force"][r]), race, 1e-4, f)
        assert float(at["p_max_groove"][r]) == pytest.approx(expected, rel=1e-9)
        assert float(at["p_max_groove"][r]) < float(at["p_max"][r])
    assert s["p_max_groove"].attrs["units"] == "Pa"
    assert bool(s["p_max_groove"].sel(NEW).sel(PAPER).isnull().all())


def test_method_ratio_and_the_method_check(study):
    """Outer: 2000 N (paper) against 1900 N (twin), within method_tol = 0.2: the impact's own
    flag (none) stands. Inner: 101 against 400 N: flagged by the check."""
    s, _ = study
    at = s.sel(NEW)
    np.testing.assert_allclose(at["method_ratio"], [101.0 / 400.0, 2000.0 / 1900.0])
    np.testing.assert_array_equal(at["peak_force_flagged"], [1.0, 0.0])
    assert s.attrs["method_tol"] == 0.2
    # no twin (OLD) or a failed twin (EMPTY): no ratio, the flags of the impacts alone
    assert bool(s["method_ratio"].sel(OLD).isnull().all())
    assert bool(s["method_ratio"].sel(EMPTY).isnull().all())


def test_static_deflection_ratio_is_the_series_hertz_deflection_over_the_clearance(study):
    s, _ = study
    _, K_in = _hertz(1.0, "inner", 1e-4)
    _, K_out = _hertz(1.0, "outer", 1e-4)
    K = (K_in ** (-2 / 3) + K_out ** (-2 / 3)) ** -1.5
    expected = (1900.0 / K) ** (2 / 3) / 1e-4  # the twin's largest steady force
    assert float(s["static_deflection_ratio"].sel(NEW)) == pytest.approx(expected, rel=1e-12)


def test_columns_that_an_older_table_lacks_are_missing(study):
    s, _ = study
    np.testing.assert_array_equal(s["p_max"].sel(NEW).sel(PAPER), [101e5, 2000e5])
    assert float(s["n_flagged"].sel(NEW)) == 1.0  # the start-up flag does not count
    assert bool(s["p_max"].sel(OLD).sel(PAPER).isnull().all())
    assert bool(s["n_flagged"].sel(OLD).isnull())
    assert bool(s["peak_force_flagged"].sel(OLD).isnull().all())


def test_run_numbers_failed_and_empty_points(study):
    s, _ = study
    assert s["peak_force"].dims == ("clearance", "mu", "omega0", "e_N", "model", "race")
    assert s["n_impacts"].dims == ("clearance", "mu", "omega0", "e_N", "race", "kind")
    np.testing.assert_array_equal(s["iter_max"].sel(NEW).sel(PAPER), [3, 5, 2])
    assert float(s["converged_fraction"].sel(NEW).sel(PAPER)) == pytest.approx(1 - 1 / 3000)
    assert float(s["max_Lambda_N"].sel(NEW).sel(PAPER)) == 2e-3
    assert float(s["time_steps"].sel(NEW).sel(PAPER)) == round(T_END / DT)
    # only a start-up impact: no steady impact (zero counts, no peak), a start-up peak
    assert float(s["n_impacts"].sel(EMPTY).sum()) == 0.0
    assert bool(s["peak_force"].sel(EMPTY).sel(PAPER).isnull().all())
    assert float(s["startup_peak_force"].sel(EMPTY).sel(PAPER)) == 10.0
    # the failed twin at EMPTY: its model is missing there, the paper's numbers stay
    assert float(s["failed"].sel(EMPTY).sel(TWIN)) == 1.0
    assert bool(s["startup_peak_force"].sel(EMPTY).sel(TWIN).isnull())
    # the failed point: flagged, and missing (NaN) everywhere else, not zero
    assert float(s["failed"].sel(FAILED).sel(PAPER)) == 1.0
    assert int((s["failed"] > 0).sum()) == 2
    for name in s.data_vars:
        if name != "failed":
            value = s[name].sel(FAILED)
            value = value.sel(PAPER) if "model" in value.dims else value
            assert bool(value.isnull().all()), name
    # points without a twin: the compliant model is missing, not failed
    assert bool(s["failed"].sel(OLD).sel(TWIN).isnull())
    assert s.attrs["n_failed"] == 2 and s.attrs["n_runs"] == 6


def test_summary_file_is_cf_style(study):
    _, path = study
    import netCDF4

    with netCDF4.Dataset(path) as nc:
        assert nc.getncattr("Conventions") == "CF-1.10"
        assert "summary of 6 runs" in nc.getncattr("history")
        for name, var in nc.variables.items():
            assert var.dtype != str and var.dtype.kind != "S", f"{name} is a string variable"
            attrs = var.ncattrs()
            assert "units" in attrs and "long_name" in attrs, name
            # a label a plot's axis can show; what it leaves out is the comment
            assert len(var.long_name) <= LABEL_LENGTH, (name, var.long_name)
            if "comment" in attrs:
                assert len(var.comment) > len(var.long_name), name
            if name in nc.dimensions:
                assert "_FillValue" not in attrs, f"coordinate {name} has a fill value"
        assert nc.variables["race"].getncattr("flag_meanings") == "inner outer"
        assert nc.variables["kind"].getncattr("flag_meanings") == "simple persistent pinch multi"
        assert nc.variables["model"].getncattr("flag_meanings") == "nonsmooth compliant"
        assert list(nc.variables["model"].getncattr("flag_values")) == [0, 1]
        assert nc.variables["model"].dtype == np.int8
        assert list(nc.variables["race"][:]) == [0, 1]
        assert nc.variables["clearance"].getncattr("units") == "m"
    with xr.open_dataset(path) as ds:
        assert ds["peak_force"].sel(NEW).sel(PAPER).values.tolist() == [101.0, 2000.0]


def test_category_codes():
    np.testing.assert_array_equal(category_codes(["outer", "inner", "x"]), [1, 0, -1])
    np.testing.assert_array_equal(category_codes(np.array([0, 1, 2]), "outer inner"), [1, 0, -1])
    np.testing.assert_array_equal(category_codes(np.array([0.0, np.nan])), [0, -1])


def test_bad_arguments():
    with pytest.raises(ValueError, match="settle"):
        summarize(["a"], ["b"], settle=-1)
    with pytest.raises(ValueError, match="force_levels"):
        summarize(["a"], ["b"], force_levels=[0.0])
    with pytest.raises(ValueError, match="method_tol"):
        summarize(["a"], ["b"], method_tol=0.0)


def _hertz_pulse_peak(m, v, K, e_N):
    """Largest force of a compliant impact, m delta'' = -K delta^1.5 (1 + chi delta'/v) with
    the Flores chi = 8 (1 - e_N)/(5 e_N), integrated here (independent of analysis.forces)."""
    from scipy.integrate import solve_ivp

    chi = 8.0 * (1.0 - e_N) / (5.0 * e_N)

    def force(d, dd):
        return np.where(d > 0, K * np.maximum(d, 0) ** 1.5 * (1.0 + chi * dd / v), 0.0)

    def rhs(_, y):
        return [y[1], -force(y[0], y[1]) / m]

    def separated(_, y):
        return y[0]
    separated.terminal, separated.direction = True, -1
    t_end = 10 * 2.94 * (5 * m * v**2 / (4 * K)) ** 0.4 / v
    sol = solve_ivp(rhs, (0.0, t_end), [1e-30, v], method="LSODA", rtol=1e-11, atol=1e-20,
                    events=separated, dense_output=True)
    tt = np.linspace(0.0, sol.t[-1], 200001)
    d, dd = sol.sol(tt)
    return float(np.max(force(d, dd)))


def test_an_isolated_impact_whose_twin_agrees_is_not_flagged(tmp_path):
    """One ball (m = 2.7 g) hits the outer race at 1 m/s, steel: the paper's Flores force of the
    impact table against a compliant twin whose F_N is the Hertz pulse integrated here. The
    method ratio is 1 (to the integration's accuracy) and nothing is flagged."""
    from analysis import peak_force
    from analysis.synthetic import make_run_dataset

    m, v, e_N, E, clearance = 2.7e-3, 1.0, 0.9, 2.1e11, 4e-4
    _, K_paper = _hertz(1.0, "outer", clearance)
    K = K_paper * 100.0  # E = 2.1e11 instead of the paper's 2.1e9: K goes as E
    point = {"clearance": clearance, "mu": 0.01, "omega0": 50.0, "e_N": e_N}
    run = make_run_dataset(n_steps=2000, clearance=clearance, omega0=50.0, e_N=e_N)
    run.attrs["model.youngs_modulus"] = E
    write_netcdf(run, tmp_path / "run.nc")
    F_paper = peak_force((1.0 + e_N) * m * v, v, e_N, K)
    xr.Dataset({"time": ("impact", [0.05]), "race": ("impact", np.array([1], "i1")),
                "kind": ("impact", np.array([0], "i1")), "F_max": ("impact", [F_paper]),
                "flags": ("impact", np.array([0], "i4"))},
               coords=point).to_netcdf(tmp_path / "impacts.nc")
    force = np.zeros((2001, 16))
    force[500, 8] = _hertz_pulse_peak(m, v, K, e_N)  # within one output interval (30 us)
    write_netcdf(make_compliant_run(force, output_dt=1e-4, omega0=50.0, clearance=clearance,
                                    e_N=e_N, youngs_modulus=E), tmp_path / "twin.nc")
    s = summarize({"nonsmooth": [tmp_path / "run.nc"], "compliant": [tmp_path / "twin.nc"]},
                  {"nonsmooth": [tmp_path / "impacts.nc"]}, scheduler="synchronous").sel(point)
    assert float(s["method_ratio"].sel(race=1)) == pytest.approx(1.0, abs=1e-4)
    assert float(s["peak_force_flagged"].sel(race=1)) == 0.0
    # the same impact against a twin that carries 1.5 times the force: flagged
    force[500, 8] *= 1.5
    write_netcdf(make_compliant_run(force, output_dt=1e-4, omega0=50.0, clearance=clearance,
                                    e_N=e_N, youngs_modulus=E), tmp_path / "twin.nc")
    s = summarize({"nonsmooth": [tmp_path / "run.nc"], "compliant": [tmp_path / "twin.nc"]},
                  {"nonsmooth": [tmp_path / "impacts.nc"]}, scheduler="synchronous").sel(point)
    assert float(s["method_ratio"].sel(race=1)) == pytest.approx(1 / 1.5, rel=1e-4)
    assert float(s["peak_force_flagged"].sel(race=1)) == 1.0


def test_the_models_and_axes_of_the_summary(study, tmp_path):
    """A plain list of runs is a nonsmooth-only study (model = [0]); ``axes`` orders the grid
    and names its axes (a file without one of them is refused in one line)."""
    s, _ = study
    runs = [tmp_path / "run.nc"]
    tables = [tmp_path / "imp.nc"]
    _run(runs[0], NEW)
    _impacts(tables[0], NEW)
    alone = summarize(runs, tables, scheduler="synchronous", settle=1.0)
    assert alone["model"].values.tolist() == [0]
    assert bool(alone["method_ratio"].isnull().all())
    ordered = summarize(runs, tables, scheduler="synchronous", settle=1.0,
                        axes=["e_N", "mu", "clearance", "omega0"])
    assert ordered["peak_force"].dims == ("e_N", "mu", "clearance", "omega0", "model", "race")
    xr.testing.assert_equal(ordered["peak_force"].transpose(*alone["peak_force"].dims),
                            alone["peak_force"])
    with pytest.raises(ValueError, match="scalar coordinate cage_stiffness is missing"):
        summarize(runs, tables, scheduler="synchronous", axes=["clearance", "cage_stiffness"])
    with pytest.raises(ValueError, match="model 'rigid'"):
        summarize({"rigid": runs}, tables)


def test_summary_table_shows_both_models_and_their_ratio(study):
    from analysis.summary import summary_table

    s, _ = study
    table = summary_table(s).set_index("quantity")
    outer = s["peak_force"].isel(race=1)
    for model, code in (("nonsmooth", 0), ("compliant", 1)):
        row = table.loc[f"steady peak force, outer race, {model}"]
        values = outer.sel(model=code).values / 1e3
        assert float(row["max"]) == pytest.approx(np.nanmax(values), rel=1e-3)
    ratio = table.loc["method ratio (nonsmooth / compliant peak), outer race"]
    assert float(ratio["max"]) == pytest.approx(2000.0 / 1900.0, rel=1e-3)
    # NEW: inner flagged by the check, outer clean; OLD has no flags, EMPTY no steady peak
    assert table.loc["nonsmooth peak forces flagged (flag or method check)", "max"] == "1 of 2"
    one = summary_table(s, model="compliant")
    assert not one["quantity"].str.contains("nonsmooth, |method ratio").any()


def test_summary_table_gives_the_lives_and_where_the_shortest_is():
    """Rating lives and the static safety factor of the compliant twins are rows of the table,
    with the grid point of their smallest value (the one to read) beside the largest's."""
    from analysis.summary import summary_table

    grid = {"mu": [0.0, 0.01], "omega0": [50.0, 100.0, 200.0]}
    rng = np.random.default_rng(3)
    life = rng.uniform(100.0, 5000.0, (2, 3))
    coords = {**grid, "model": np.array([0, 1], np.int8)}
    s = xr.Dataset({"failed": (("mu", "omega0", "model"), np.zeros((2, 3, 2))),
                    "L10h": (("mu", "omega0"), life), "L10rh": (("mu", "omega0"), 0.7 * life),
                    "static_safety_factor": (("mu", "omega0"), 3000.0 / life)}, coords=coords)
    table = summary_table(s).set_index("quantity")
    row = table.loc["rating life L10 (ISO 281), compliant"]
    i, j = np.unravel_index(np.argmin(life), life.shape)
    assert float(row["min"]) == pytest.approx(life.min(), rel=1e-3)
    assert row["smallest at"] == f"mu={grid['mu'][i]:g}, omega0={grid['omega0'][j]:g}"
    s0 = table.loc["static safety factor s0 = C0 / P0 (ISO 76), compliant"]
    assert s0["largest at"] == row["smallest at"]  # s0 falls as the life rises here
    assert "reference rating life L10r (ball loads), compliant" in table.index
    assert not summary_table(s, model="nonsmooth")["quantity"].str.contains("life").any()


@pytest.mark.parametrize("turned, expected", [(2.4, 2), (2.6, 3), (3.0, 3), (0.3, 1), (0.0, 0)])
def test_revolutions_of_the_window_and_the_short_tail(turned, expected):
    """A last piece shorter than half a revolution joins the revolution before it; a window
    shorter than one revolution is one revolution; an empty window has none."""
    from analysis.summary import SteadyWindow

    t = np.linspace(0.0, 1.0, 1001)
    window = SteadyWindow(0.0, turned, t, turned * t)
    assert window.n_revolutions == expected
    if expected:
        position = turned * t[1:]  # revolutions turned at the samples
        index = window.revolution(t[1:])
        assert index.min() == 0 and index.max() == expected - 1
        step = turned * (t[1] - t[0])
        for k in range(1, expected):  # revolution k starts where the crank has turned k
            first = position[index == k].min()
            assert k <= first < k + step
        assert position[index == expected - 1].max() == pytest.approx(turned)


def test_the_summary_file_keeps_the_analysis_settings_booleans_as_integers(study):
    _, path = study
    with xr.open_dataset(path) as stored:
        assert stored.attrs["analysis_zoom_adaptive"] == 1
        assert stored.attrs["analysis_zero_tol"] == 1e-4


def test_a_swept_analysis_key_is_read_from_each_run(tmp_path):
    """Two twins with the same force history, made with settle 0.5 and 2 revolutions (a swept
    ``analysis.settle``): with ``own_settings=["settle"]`` each point's steady window starts
    where its own run says, so the 5 kN force at 1.19 revolutions is steady at 0.5 and
    start-up at 2; with the study's one value (1) both would read it as steady."""
    omega0, dt = 50.0, 1e-4
    force = np.full((5001, 16), 100.0)
    force[1500, 8] = 5000.0  # t = 0.15 s: 1.19 revolutions
    files = []
    for settle in (0.5, 2.0):
        run = make_compliant_run(force, output_dt=dt, omega0=omega0)
        run = run.assign_coords(analysis_settle=("analysis_settle", [settle]))
        run.attrs["analysis.settle"] = settle
        files.append(write_netcdf(run, tmp_path / f"twin_{settle}.nc"))
    axes = ["clearance", "mu", "omega0", "e_N", "analysis_settle"]
    common = dict(scheduler="synchronous", settings={"settle": 1.0}, models=["compliant"],
                  axes=axes)
    own = summarize({"compliant": files}, {}, own_settings=["settle"], **common)
    peak = own["peak_force"].sel(model=COMPLIANT, race=1).squeeze()
    assert float(peak.sel(analysis_settle=0.5)) == 5000.0
    assert float(peak.sel(analysis_settle=2.0)) == 100.0
    rev = 2 * np.pi / omega0
    np.testing.assert_allclose(own["settle_time"].squeeze().values, [0.5 * rev, 2 * rev],
                               atol=dt)
    shared = summarize({"compliant": files}, {}, **common)
    assert (shared["peak_force"].sel(model=COMPLIANT, race=1) == 5000.0).all()
    # the swept setting is an axis, not a global attribute that would state one value for all
    assert "settle_revolutions" not in own.attrs and "analysis_settle" not in own.attrs
    assert shared.attrs["settle_revolutions"] == 1.0 and shared.attrs["analysis_settle"] == 1.0


def test_the_table_names_a_category_axis_by_its_name_not_its_code():
    """"largest at" of the summary table: a category axis (codes with ``flag_values`` /
    ``flag_meanings``, as a swept clearance class) by name, a number as a number."""
    from analysis.summary import _where

    cls = xr.DataArray(np.array([0, 1, 2], np.int8), dims="clearance_class",
                       attrs={"flag_values": np.array([0, 1, 2], np.int8),
                              "flag_meanings": "CN C3 C4"})
    da = xr.DataArray([[1.0, 5.0, 2.0]], dims=("mu", "clearance_class"),
                      coords={"mu": [0.01], "clearance_class": cls})
    assert _where(da) == "mu=0.01, clearance_class=C3"


def test_numbers_stored_by_other_analysis_code_are_computed_again(monkeypatch):
    """A table's stored numbers carry the digest of the analysis code that computed them; after
    an edit of the analysis (another digest) they are not reused."""
    from analysis import summary as module

    numbers = {"model": NONSMOOTH, "failed": 0.0}
    for name, (_, scope, _, _) in module._VARIABLES.items():
        if scope in ("model", "nonsmooth"):
            numbers.setdefault(name, 1.0)
    attrs = module.stored_attributes(numbers, {"settle": 1.0})
    assert module.stored_numbers(attrs, {"settle": 1.0}) is not None
    monkeypatch.setattr(module, "_code_fingerprint", lambda: "edited")
    assert module.stored_numbers(attrs, {"settle": 1.0}) is None


def test_the_clearance_of_a_swept_class_is_a_coordinate_along_the_class_axis():
    """A class sweep's summary has no clearance axis but the clearance of each class [m]
    along the class axis, read from the runs."""
    from analysis.summary import _assemble, _parameters

    axes = ["mu", "clearance_class"]
    entries = []
    for code, clearance in ((3, 2.6e-5), (1, 9e-6)):
        table = xr.Dataset(coords={"mu": 0.01, "clearance_class": np.int8(code),
                                   "clearance": clearance, "e_N": 0.9})
        entries.append((_parameters(table, axes), {"model": 0}))
    assert set(entries[0][0]) == {"mu", "clearance_class", "clearance"}
    summary = _assemble(entries, np.array([100.0]), [0], axes)
    assert "clearance" not in summary.dims and summary["clearance"].dims == ("clearance_class",)
    np.testing.assert_array_equal(summary["clearance_class"].values, [1, 3])
    np.testing.assert_array_equal(summary["clearance"].values, [9e-6, 2.6e-5])


def test_axis_attributes_come_from_the_registry_where_it_knows_the_parameter(tmp_path):
    """Run files are reused while their run's fingerprint holds, so their coordinates may
    carry the units and long names of an older version: the summary takes them from the
    registry of swept parameters where it knows the parameter, and from the files where it
    does not (a coordinate of the user's own)."""
    from simcore.config.parameters import parameter

    force = np.full((2001, 16), 100.0)
    files = []
    for value in (1.0, 2.0):
        run = make_compliant_run(force, output_dt=1e-4, omega0=50.0)
        run["clearance"].attrs.update(units="mm", long_name="an older name of the clearance")
        run = run.assign_coords(my_axis=("my_axis", [value], {"units": "s",
                                                              "long_name": "my own axis"}))
        files.append(write_netcdf(run, tmp_path / f"twin_{value}.nc"))
    s = summarize({"compliant": files}, {}, scheduler="synchronous", settings={"settle": 1.0},
                  models=["compliant"], axes=["clearance", "mu", "omega0", "e_N", "my_axis"])
    known = parameter("clearance")
    assert (s["clearance"].attrs["units"], s["clearance"].attrs["long_name"]) == (
        known.units, known.long_name) != ("mm", "an older name of the clearance")
    assert (s["my_axis"].attrs["units"], s["my_axis"].attrs["long_name"]) == ("s", "my own axis")
