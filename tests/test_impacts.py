"""Impact tables of a run (docs/forces.md), kinds, flags and the command line."""

import math

import numpy as np
import pytest
import xarray as xr
from scipy.integrate import solve_ivp

import analysis
from analysis import (
    FLAG,
    KIND,
    RACE,
    closed_form_elastic,
    extract_impacts,
    hertz_stiffness,
    peak_force,
    series_stiffness,
    split_impulses,
    top_forces,
)
from analysis.__main__ import main
from analysis.contact_stress import contact_modulus
from analysis.synthetic import make_pinch_dataset, make_run_dataset
from simcore.io import with_category_names, write_netcdf
from simcore.io.variables import LABEL_LENGTH

COLUMNS = ("contact", "ball", "race", "time", "kind", "impulse", "v_pre", "m_eff", "K",
           "F_static", "F_max", "delta_max", "contact_radius", "p_max", "contact_time",
           "contact_time_steps", "flags", "trusted")
UDUNITS_USED = {"s", "N s", "m s-1", "kg", "N", "N2 m-3", "m", "Pa", "1", "rad s-1"}


@pytest.fixture(scope="module")
def run():
    return make_run_dataset(n_steps=600)


@pytest.fixture(scope="module")
def impacts(run):
    return extract_impacts(run)


@pytest.fixture(scope="module")
def lone(run):
    """The synthetic run with only the hand-built contact 8 (ball 0, outer race) left."""
    ds = run.copy(deep=True)
    lam = ds["Lambda_N"].values
    keep = lam[:, 8].copy()
    lam[:] = 0.0
    lam[:, 8] = keep
    return ds


def test_table_layout_and_cf(impacts, run):
    assert set(impacts.dims) == {"impact"}
    for name in COLUMNS:
        assert name in impacts and impacts[name].dims == ("impact",)
    assert impacts.attrs["Conventions"] == "CF-1.10" and impacts.attrs["history"]
    for name, var in impacts.variables.items():
        assert var.dtype.kind in "fiu", f"{name} is not numeric"
        if var.dtype.kind == "f":
            assert var.attrs.get("units") in UDUNITS_USED, name
        assert 0 < len(var.attrs["long_name"]) <= LABEL_LENGTH, name  # a plot's axis label
    for name in ("kind", "race", "trusted"):
        assert len(impacts[name].attrs["flag_values"]) == len(
            impacts[name].attrs["flag_meanings"].split())
    assert impacts["kind"].attrs["flag_meanings"].split()[:4] == [
        "simple", "persistent", "pinch", "multi"]
    assert set(impacts["flags"].attrs["flag_meanings"].split()) >= {
        "no_approach", "e_N_zero", "contact_long", "not_converged_dt"}
    for name in ("clearance", "mu", "omega0", "e_N"):
        assert impacts[name].ndim == 0 and float(impacts[name]) == float(run[name])
        assert impacts[name].attrs["units"] in UDUNITS_USED and impacts[name].attrs["long_name"]
    assert impacts.attrs["v_pre_source"].startswith("vn_free")
    assert (np.diff(impacts["time"].values) >= 0).all()
    K = np.sqrt(impacts["K"].values)
    outer = impacts["race"].values == RACE["outer"]
    simple_outer = outer & (impacts["kind"].values != KIND["pinch"])
    np.testing.assert_allclose(K[simple_outer], impacts.attrs["K_outer"])


def test_counts_match_filter(impacts, run):
    lam = run["Lambda_N"].values.T
    fi, s, fisuv = split_impulses(lam, 1e-4)
    thr = 1e-4 * lam.max()
    assert impacts.attrs["zero_threshold"] == pytest.approx(thr)
    assert impacts.attrs["n_simple"] == int((fi > thr).sum())
    assert impacts.attrs["n_persistent"] == int((fisuv > thr).sum())
    assert impacts.sizes["impact"] == impacts.attrs["n_simple"] + impacts.attrs["n_persistent"]
    kinds = impacts["kind"].values
    assert (kinds == KIND["pinch"]).sum() == impacts.attrs["n_pinch"]
    assert (kinds == KIND["multi"]).sum() == impacts.attrs["n_multi"]


def test_hand_built_contact(lone):
    imp = extract_impacts(lone)
    h = lone.attrs["solver.dt"]
    assert np.rint(imp["time"].values / h).astype(int).tolist() == [50, 150, 220]
    assert imp["kind"].values.tolist() == [KIND["simple"], KIND["persistent"],
                                           KIND["persistent"]]
    assert set(imp["race"].values.tolist()) == {RACE["outer"]}
    e = 0.9
    r0 = imp.isel(impact=0)
    assert float(r0.F_static) == 0.0
    assert float(r0.m_eff) == pytest.approx(1e-3 / ((1 + e) * 0.3))
    K = math.sqrt(float(r0.K))
    assert float(r0.F_max) == pytest.approx(peak_force(1e-3, 0.3, e, K), rel=1e-12)
    lam = lone["Lambda_N"].values[:, 8]
    r1 = imp.isel(impact=1)
    assert float(r1.F_static) == pytest.approx(0.5 * (lam[149] + lam[151]) / h, rel=1e-9)
    assert float(r1.impulse) == pytest.approx(lam[150] - 0.5 * (lam[149] + lam[151]), rel=1e-9)
    assert float(r1.F_max) > float(r1.F_static)
    # the stresses follow from F_max by Hertz (concave outer race)
    r_b, r_c = imp.attrs["ball_radius"], imp.attrs["outer_radius"]
    R = r_b * r_c / (r_c - r_b)
    Es = contact_modulus(imp.attrs["E"], imp.attrs["nu"])
    for r in (r0, r1):
        a = (3 * float(r.F_max) * R / (4 * Es)) ** (1 / 3)
        assert float(r.contact_radius) == pytest.approx(a, rel=1e-12)
        assert float(r.delta_max) == pytest.approx(a * a / R, rel=1e-12)
        assert float(r.p_max) == pytest.approx(3 * float(r.F_max) / (2 * math.pi * a * a),
                                               rel=1e-12)
        assert float(r.contact_time_steps) == pytest.approx(float(r.contact_time) / h)


def test_flag_no_approach(lone):
    imp = extract_impacts(lone)
    r2 = imp.isel(impact=2)  # v_pre = 1e-4 <= v_min
    assert int(r2.approach) == 0 and int(r2.flags) & FLAG["no_approach"]
    assert int(r2.trusted) == 0
    for name in ("F_max", "m_eff", "delta_max", "contact_time", "p_max", "contact_radius"):
        assert np.isnan(float(r2[name]))
    assert np.isfinite(float(r2.F_static)) and float(r2.F_static) > 0


def test_flag_contact_long_threshold(lone):
    """The simple impact at step 50 (m_eff, v_pre known) lasts t_c (Flores, e_N = 0.9): flagged
    exactly when t_c/dt exceeds the setting."""
    h = lone.attrs["solver.dt"]
    K = math.sqrt(float(extract_impacts(lone)["K"].values[0]))
    tc = peak_force(1e-3, 0.3, 0.9, K, details=True).contact_time
    # cross-check the order of magnitude with the elastic closed form
    assert tc == pytest.approx(closed_form_elastic(1e-3 / (1.9 * 0.3), 0.3, K)[2], rel=0.1)
    below = extract_impacts(lone, contact_long_ratio=1.01 * tc / h).isel(impact=0)
    above = extract_impacts(lone, contact_long_ratio=0.99 * tc / h).isel(impact=0)
    assert int(below.flags) & FLAG["contact_long"] == 0 and int(below.trusted) == 1
    assert int(above.flags) & FLAG["contact_long"] and int(above.trusted) == 0
    assert above.attrs["n_flagged"] >= 1


@pytest.mark.parametrize("e_N", [0.7, 0.9, 1.0])
def test_flag_peak_at_onset_on_a_loaded_contact(lone, e_N):
    """A contact carrying a steady 0.1 N s a step takes a small and a large impact. The Flores
    force starts at F_s (1 + c), c = 8 (1 - e_N)/(5 e_N) (the damping on the whole static
    indentation): the small impact's peak is that start, whatever its impulse, and is flagged;
    the large one rises above it and is not; without damping (e_N = 1) nothing is flagged."""
    ds = lone.copy(deep=True)
    ds = ds.assign_coords(e_N=e_N)
    ds.attrs["model.e_N"] = e_N
    lam, vn = ds["Lambda_N"].values, ds["vn_free"].values
    lam[:, 8] = 0.0
    lam[100:400, 8] = 0.1
    vn[:, 8] = 0.0
    for k, bump, speed in ((200, 1e-3, 0.05), (300, 2.0, 1.0)):
        lam[k, 8] += bump
        vn[k, 8] = -speed
    imp = extract_impacts(ds)
    h = ds.attrs["solver.dt"]
    rows = imp.isel(impact=np.flatnonzero(np.isin(np.rint(imp["time"].values / h), [200, 300])))
    assert rows.sizes["impact"] == 2
    small, large = rows.isel(impact=0), rows.isel(impact=1)
    start = 0.1 / h * (1.0 + 8.0 * (1.0 - e_N) / (5.0 * e_N))
    assert float(small.F_static) == pytest.approx(0.1 / h, rel=1e-9)
    bit = FLAG["peak_at_onset"]
    if e_N < 1.0:
        assert float(small.F_max) == pytest.approx(start, rel=1e-12)
        assert int(small.flags) & bit and int(small.trusted) == 0
    else:
        assert float(small.F_max) > start and not int(small.flags) & bit
    assert float(large.F_max) > 1.05 * start and not int(large.flags) & bit
    assert "peak_at_onset" in imp["flags"].attrs["flag_meanings"].split()


def test_flag_e_N_zero(run):
    zero = run.assign_coords(e_N=0.0)
    zero.attrs["model.e_N"] = 0.0
    imp = extract_impacts(zero)
    assert imp.sizes["impact"] > 0
    assert (imp["flags"].values & FLAG["e_N_zero"]).all()
    assert np.isnan(imp["F_max"].values).all() and (imp["trusted"].values == 0).all()


def test_flag_solver_unconverged(lone):
    ds = lone.copy(deep=True)
    ds["converged"].values[150] = 0
    imp = extract_impacts(ds)
    flags = imp["flags"].values
    assert flags[1] & FLAG["solver_unconverged"] and not flags[0] & FLAG["solver_unconverged"]


def test_vn_pre_fallback_is_recorded(run):
    imp = extract_impacts(run.drop_vars("vn_free"))
    assert imp.attrs["v_pre_source"].startswith("vn_pre")
    assert "no vn_free" in imp.attrs["v_pre_source"]
    with pytest.raises(ValueError, match="vn_free"):
        extract_impacts(run.drop_vars(["vn_free", "vn_pre"]))


@pytest.mark.parametrize("offset", [0, 1, -1])
def test_synthetic_pinch_gives_the_series_stiffness_closed_form(offset):
    """Two races pressed together through one ball: approach V = v_in + v_out, reduced mass of the
    two races, two Hertz contacts in series. With e_N = 1 the peak force is the closed form
    K_s^{2/5} (5 μ V²/4)^{3/5}, K_s = (K_in^{-2/3} + K_out^{-2/3})^{-3/2}."""
    ds = make_pinch_dataset(v_inner=0.35, v_outer=0.15, m_crank=2.0, m_rod=3.0, e_N=1.0,
                            second_step_offset=offset)
    imp = extract_impacts(ds)
    pinch = imp.isel(impact=np.flatnonzero(imp["kind"].values == KIND["pinch"]))
    assert pinch.sizes["impact"] == 2
    assert sorted(pinch["race"].values.tolist()) == [0, 1]
    a = ds.attrs
    r_b, r_a = a["model.ball_radius"], a["model.inner_radius"]
    r_c = r_a + 2 * r_b + 4e-4
    E, nu = a["model.youngs_modulus"], a["model.poisson_ratio"]
    K_in = hertz_stiffness(r_b, r_a, E, nu, E, nu)
    K_out = hertz_stiffness(r_b, r_c, E, nu, E, nu, concave=True)
    K_s = (K_in ** (-2 / 3) + K_out ** (-2 / 3)) ** (-1.5)
    assert series_stiffness(K_in, K_out) == pytest.approx(K_s, rel=1e-14)
    mu, V = a["pinch_reduced_mass"], a["pinch_speed"]
    F_closed = K_s**0.4 * (1.25 * mu * V**2) ** 0.6
    for i in range(2):
        r = pinch.isel(impact=i)
        assert float(r.v_pre) == pytest.approx(V, rel=1e-12)
        assert float(r.m_eff) == pytest.approx(mu, rel=1e-12)
        assert math.sqrt(float(r.K)) == pytest.approx(K_s, rel=1e-12)
        assert float(r.F_max) == pytest.approx(F_closed, rel=1e-6)
        # each contact is indented by its own Hertz law under the common force
        Kc = K_in if int(r.race) == 0 else K_out
        assert float(r.delta_max) == pytest.approx((F_closed / Kc) ** (2 / 3), rel=1e-6)
    # the outer contact alone would overestimate the force by (K_out/K_s)^{2/5}
    assert (K_out / K_s) ** 0.4 > 1.4


def test_series_pinch_against_three_body_integration():
    """Independent check of the series law: integrate crank race, ball and rod race with the two
    Hertz contacts (elastic), a ball 1e-5 of the reduced mass; the peak contact force agrees with
    the series-stiffness closed form to 1e-3."""
    E, nu, r_b, r_a = 2.1e9, 0.3, 0.0055, 0.033745
    r_c = r_a + 2 * r_b + 4e-4
    K_in = hertz_stiffness(r_b, r_a, E, nu, E, nu)
    K_out = hertz_stiffness(r_b, r_c, E, nu, E, nu, concave=True)
    m1, m2, V = 2.0, 3.0, 0.5
    mu = m1 * m2 / (m1 + m2)
    mb = 1e-5 * mu

    def rhs(_t, y):
        x1, xb, x2, v1, vb, v2 = y
        d_in = max(x1 - xb, 0.0)
        d_out = max(xb - x2, 0.0)
        f_in = K_in * d_in**1.5
        f_out = K_out * d_out**1.5
        return [v1, vb, v2, -f_in / m1, (f_in - f_out) / mb, f_out / m2]

    # crank race moving at +V * m2/(m1+m2), rod race at -V * m1/(m1+m2), ball between them
    y0 = [0.0, 0.0, 0.0, V * m2 / (m1 + m2), 0.0, -V * m1 / (m1 + m2)]
    sol = solve_ivp(rhs, (0, 0.02), y0, method="LSODA", rtol=1e-10, atol=1e-14, max_step=2e-6)
    d_total = (sol.y[0] - sol.y[2]).max()
    f_closed = series_stiffness(K_in, K_out) ** 0.4 * (1.25 * mu * V**2) ** 0.6
    f_sim = K_out * np.clip(sol.y[1] - sol.y[2], 0, None).max() ** 1.5
    assert f_sim == pytest.approx(f_closed, rel=1e-3)
    assert d_total == pytest.approx((1.25 * mu * V**2 / series_stiffness(K_in, K_out)) ** 0.4,
                                    rel=1e-3)


def test_pinch_on_a_loaded_ball_and_rattle():
    """A loaded pinched ball keeps the common static force; alternating small impulses (a ball
    rattling between the races) are single-ball impacts, not pinches."""
    ds = make_pinch_dataset(static_force=50.0, e_N=1.0)
    imp = extract_impacts(ds)
    p = imp.isel(impact=np.flatnonzero(imp["kind"].values == KIND["pinch"]))
    assert p.sizes["impact"] == 2
    np.testing.assert_allclose(p["F_static"].values, 50.0, rtol=1e-9)
    np.testing.assert_allclose(p["impulse"].values, ds.attrs["pinch_impulse"], rtol=1e-9)
    # rattle: ball 0 hits the inner race, then the outer race one step later, at its own 2 m/s
    rat = make_pinch_dataset(e_N=0.9)
    lam = rat["Lambda_N"].values
    vn = rat["vn_free"].values
    lam[:] = 0.0
    vn[:] = 0.0
    m_ball = rat.attrs["model.ball_mass"]
    lam[20, 0] = 1.9 * m_ball * 2.0
    vn[20, 0] = -2.0
    lam[21, 3] = 1.9 * m_ball * 2.0
    vn[21, 3] = -2.0
    imp = extract_impacts(rat)
    assert imp.sizes["impact"] == 2
    assert (imp["kind"].values == KIND["simple"]).all()
    np.testing.assert_allclose(imp["m_eff"].values, m_ball, rtol=1e-12)


def test_multi_kind():
    ds = make_pinch_dataset(e_N=0.9)
    lam = ds["Lambda_N"].values
    vn = ds["vn_free"].values
    lam[:] = 0.0
    vn[:] = 0.0
    lam[20, 4] = 0.05  # ball 1 on the outer race
    vn[20, 4] = -0.2
    lam[20, 5] = 0.02  # ball 2 on the outer race, same step
    vn[20, 5] = -0.1
    imp = extract_impacts(ds)
    assert (imp["kind"].values == KIND["multi"]).all() and imp.sizes["impact"] == 2
    np.testing.assert_allclose(imp["v_pre"].values, [0.2, 0.1])


def test_groove_conformity_gives_the_elliptical_contact(lone):
    circ = extract_impacts(lone)
    ell = extract_impacts(lone, groove_conformity=0.52)
    ok = np.isfinite(circ["F_max"].values)
    # a conforming groove is stiffer: larger K and F_max, an elongated contact
    assert (ell["K"].values > circ["K"].values).all()
    assert (ell["F_max"].values[ok] > circ["F_max"].values[ok]).all()
    assert (ell["contact_radius"].values[ok] > ell["contact_semi_minor"].values[ok]).all()
    p = ell["p_max"].values[ok]
    F = ell["F_max"].values[ok]
    np.testing.assert_allclose(
        p, 3 * F / (2 * np.pi * ell["contact_radius"].values[ok]
                    * ell["contact_semi_minor"].values[ok]), rtol=1e-12)
    assert ell.attrs["groove_conformity"] == 0.52
    with pytest.raises(ValueError, match="groove_conformity"):
        extract_impacts(lone, groove_conformity=0.4)


def test_stiffness_per_race_and_r_eff(lone):
    conc = extract_impacts(lone, r_eff="concave")
    pap = extract_impacts(lone, r_eff="paper")
    ok = np.isfinite(conc["F_max"].values)
    assert (conc["F_max"].values[ok] > pap["F_max"].values[ok]).all()
    ratio = conc["F_max"].values[0] / pap["F_max"].values[0]
    assert ratio == pytest.approx((conc.attrs["K_outer"] / pap.attrs["K_outer"]) ** 0.4,
                                  rel=1e-6)


def test_netcdf_round_trip(impacts, tmp_path):
    path = write_netcdf(impacts, tmp_path / "imp.nc")
    with xr.open_dataset(path) as back:
        np.testing.assert_array_equal(back["kind"].values, impacts["kind"].values)
        np.testing.assert_array_equal(back["F_max"].values, impacts["F_max"].values)
        assert back["clearance"].item() == impacts["clearance"].item()
        assert back["clearance"].attrs["units"] == "m"
        assert back.attrs["r_eff"] == "concave"
        assert back["flags"].attrs["flag_meanings"] == impacts["flags"].attrs["flag_meanings"]
        # read by names: a row's race and kind are its codes' names, the bit mask stays
        named = with_category_names(back)
        for column, codes in (("race", RACE), ("kind", KIND)):
            by_code = {v: k for k, v in codes.items()}
            assert named[column].values.tolist() == [by_code[int(c)]
                                                     for c in back[column].values]
        outer = int((back["race"] == RACE["outer"]).sum())
        assert 0 < outer < back.sizes["impact"]
        assert int((named["race"] == "outer").sum()) == outer
        np.testing.assert_array_equal(named["flags"].values, back["flags"].values)


def test_empty_table(run, tmp_path):
    quiet = run.copy()
    quiet["Lambda_N"] = xr.zeros_like(run["Lambda_N"])
    imp = extract_impacts(quiet)
    assert imp.sizes["impact"] == 0
    assert imp.attrs["n_simple"] == imp.attrs["n_persistent"] == 0
    write_netcdf(imp, tmp_path / "empty.nc")
    with xr.open_dataset(tmp_path / "empty.nc") as back:
        assert back.sizes["impact"] == 0 and "F_max" in back
    assert top_forces(imp).sizes["impact"] == 0
    assert top_forces(imp, events=analysis.loaded_stretches(quiet, imp)).sizes["impact"] == 0


def test_top_forces(impacts):
    top = top_forces(impacts, n=3)
    f = top["F_max"].values
    assert len(f) == 3 and (np.diff(f) <= 0).all()
    assert set(top["race"].values.tolist()) == {RACE["outer"]}
    outer = impacts["race"].values == RACE["outer"]
    assert f[0] == np.nanmax(impacts["F_max"].values[outer])


def test_top_forces_of_events_count_a_loaded_stretch_once():
    """Rows of one contact inside one stretch of load (its impulse above the zero threshold on
    consecutive steps) are one event: only its largest force ranks. A stretch broken by one
    unloaded step is two events; rows of another contact are others."""
    time = np.arange(12) * 1e-4
    lam = np.zeros((12, 2))
    lam[1:6, 0] = 1.0  # contact 0: one stretch, steps 1-5 ...
    lam[7:9, 0] = 1.0  # ... and another, steps 7-8
    lam[2:4, 1] = 1.0  # contact 1: steps 2-3
    run_ds = xr.Dataset({"Lambda_N": (("time", "contact"), lam)},
                        coords={"time": time, "contact": [0, 1]})
    rows = [(0, 1, 5.0), (0, 3, 9.0), (0, 5, 8.0), (1, 2, 7.0), (0, 7, 6.0), (0, 8, 4.0),
            (1, 11, 3.0)]  # (contact, step, F_max); the last one outside any stretch
    table = xr.Dataset({"contact": ("impact", [r[0] for r in rows]),
                        "time": ("impact", time[[r[1] for r in rows]]),
                        "F_max": ("impact", [r[2] for r in rows]),
                        "race": ("impact", [RACE["outer"]] * len(rows))},
                       attrs={"zero_threshold": 0.5})
    events = analysis.loaded_stretches(run_ds, table)
    assert events[0] == events[1] == events[2] and events[4] == events[5]
    assert len(set(events[[0, 3, 4, 6]].tolist())) == 4
    every = top_forces(table, n=7)["F_max"].values
    assert every.tolist() == [9.0, 8.0, 7.0, 6.0, 5.0, 4.0, 3.0]
    distinct = top_forces(table, n=7, events=events)["F_max"].values
    assert distinct.tolist() == [9.0, 7.0, 6.0, 3.0]


def test_bad_settings(run):
    with pytest.raises(ValueError, match="v_min"):
        extract_impacts(run, v_min=0.0)
    with pytest.raises(ValueError, match="r_eff"):
        extract_impacts(run, r_eff="convex")
    with pytest.raises(ValueError, match="contact_long_ratio"):
        extract_impacts(run, contact_long_ratio=-1)
    bare = run.copy()
    bare.attrs = {k: v for k, v in run.attrs.items() if k != "model.youngs_modulus"}
    with pytest.raises(ValueError, match="youngs_modulus"):
        extract_impacts(bare)


def test_cli(run, tmp_path, capsys):
    rpath = write_netcdf(run, tmp_path / "run.nc")
    out = tmp_path / "imp.nc"
    assert main(["impacts", str(rpath), "--out", str(out), "--groove-conformity", "0.52"]) == 0
    with xr.open_dataset(out) as back:
        assert back.sizes["impact"] > 0 and back.attrs["groove_conformity"] == 0.52
        assert back.attrs["run_file"] == str(rpath)  # the table names what it was made from
    assert main(["top-forces", str(rpath)]) == 0
    text = capsys.readouterr().out
    assert "r_eff = concave" in text and "r_eff = paper" in text and "3.66" in text
    assert "p_max" in text
    assert main(["top-forces", str(rpath), "--every-row", "-n", "5"]) == 0
    assert capsys.readouterr().out.count("\n   5 ") == 2  # rank 5, for both R_eff
    assert main(["filter", str(rpath), "--out", str(tmp_path / "f.nc")]) == 0
    capsys.readouterr()
    # a file that is not a run: one line naming the argument, no output written
    text = tmp_path / "run.yaml"
    text.write_text("model: {}\n")
    for given, says in ((tmp_path / "missing.nc", "does not exist"), (tmp_path, "is a folder"),
                        (text, "is not a netCDF file"), (out, "is an impact table")):
        assert main(["impacts", str(given), "--out", str(tmp_path / "y.nc")]) == 2
        assert main(["top-forces", str(given)]) == 2
        lines = capsys.readouterr().err.splitlines()
        assert len(lines) == 2 and all(line.startswith(f"error: RUN: {given} {says}")
                                       for line in lines), lines
    assert not (tmp_path / "y.nc").exists()
    bad = tmp_path / "bad.nc"
    assert main(["impacts", str(rpath), "--out", str(bad), "--groove-conformity", "0.3"]) == 2
    assert not bad.exists()
    assert "--groove-conformity" in capsys.readouterr().err  # checked before any work


def test_cli_of_a_compliant_run(tmp_path, capsys):
    """A compliant run's table is its contact episodes (each stretch of contact's largest F_N,
    the file's own forces); the paper's method, which reads impulses, refuses it."""
    import simcore

    rpath = write_netcdf(simcore.run(simcore.load_config(overrides=[
        "model.contact_model=compliant", "model.youngs_modulus=2.1e11", "solver.adaptive=true",
        "solver.dt=1e-5", "solver.t_end=0.004"])), tmp_path / "hertz.nc")
    out = tmp_path / "episodes.nc"
    assert main(["impacts", str(rpath), "--out", str(out)]) == 0
    assert "contact episodes of a compliant run" in capsys.readouterr().out
    with xr.open_dataset(out) as table, xr.open_dataset(rpath) as run:
        assert table.sizes["impact"] > 0 and table.attrs["run_file"] == str(rpath)
        F = run["F_N"].values
        assert float(table["F_max"].max()) == pytest.approx(float(F.max()), rel=1e-6)
        for row in range(table.sizes["impact"]):  # each peak is the run's force there
            k = int(table["contact"][row])
            i = int(np.searchsorted(run["time"].values, float(table["time"][row])))
            assert F[i, k] == pytest.approx(float(table["F_max"][row]), rel=1e-6)
    assert main(["impacts", str(rpath), "--out", str(tmp_path / "x.nc"), "--zero-tol",
                 "1e-3"]) == 2
    assert capsys.readouterr().err.startswith("error: --zero-tol: not used on a compliant run")
    for command in ("top-forces", "filter", "dt-check", "figures"):
        extra = {"filter": ["--out", str(tmp_path / "f.nc")],
                 "figures": ["--outdir", str(tmp_path / "figs")]}.get(command, [])
        assert main([command, str(rpath), *extra]) == 2, command
        err = capsys.readouterr().err
        assert "compliant run" in err and f"allowed for {command}" in err, err
    assert not (tmp_path / "f.nc").exists() and not (tmp_path / "figs").exists()


def test_paper_style_line_says_why_an_impulse_has_no_force(run, lone):
    """The paper's way lists the largest impulses of one contact whatever their force: one
    without a Flores force names its flags instead of printing nan."""
    from analysis.__main__ import format_top_forces

    zero = run.assign_coords(e_N=0.0)
    zero.attrs["model.e_N"] = 0.0
    line = [s for s in format_top_forces(zero).splitlines() if "paper-style" in s][0]
    assert "nan" not in line and line.count("no force (") == line.count("e_N_zero") == 3
    imp = extract_impacts(lone)
    slow = imp.isel(impact=2)  # v_pre below v_min: no approach (test_flag_no_approach)
    text = format_top_forces(lone, n=imp.sizes["impact"])
    assert f"no force (no_approach, t = {float(slow.time):.4f} s)" in text
    assert f"{float(imp.F_max[0]) / 1e3:.4g} kN (t = {float(imp.time[0]):.4f} s)" in text


def test_zero_restitution_run_keeps_its_impacts_without_forces():
    """e_N = 0 is a valid run (plastic impacts) but outside the Flores law: impacts are listed,
    F_max is missing and flagged e_N_zero, nothing raises."""
    import simcore

    ds = simcore.run(simcore.load_config(overrides=["model.e_N=0", "solver.t_end=0.01"]))
    imp = extract_impacts(ds)
    assert imp.sizes["impact"] > 0
    assert np.all(np.isnan(imp["F_max"].values))
    assert (imp["flags"].values & FLAG["e_N_zero"]).all()
