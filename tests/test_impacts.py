"""Impact tables of a run (SPEC sections 7 and 9) and the command line."""

import numpy as np
import pytest
import xarray as xr

from analysis import extract_impacts, hertz_stiffness, peak_force, split_impulses, top_forces
from analysis.__main__ import main
from analysis.synthetic import make_run_dataset
from simcore.io import write_netcdf

COLUMNS = ("contact", "ball", "race", "time", "kind", "impulse", "v_pre", "m_eff", "F_static",
           "F_max", "delta_max", "contact_time")


@pytest.fixture(scope="module")
def run():
    return make_run_dataset(n_steps=600)


@pytest.fixture(scope="module")
def impacts(run):
    return extract_impacts(run)


def test_table_layout(impacts, run):
    assert set(impacts.dims) == {"impact"}
    for name in COLUMNS:
        assert name in impacts
        assert impacts[name].dims == ("impact",)
    for name in ("clearance", "mu", "omega0", "e_N"):
        assert float(impacts[name]) == float(run[name])
    for key in ("zero_threshold", "zero_tol", "zero_floor", "r_eff", "v_min", "E", "nu",
                "n_simple", "n_persistent", "n_no_approach"):
        assert key in impacts.attrs
    t = impacts["time"].values
    assert (np.diff(t) >= 0).all()


def test_counts_match_filter(impacts, run):
    lam = run["Lambda_N"].values.T
    fi, s, fisuv = split_impulses(lam, 1e-4)
    thr = 1e-4 * lam.max()
    assert impacts.attrs["zero_threshold"] == pytest.approx(thr)
    assert impacts.attrs["n_simple"] == int((fi > thr).sum())
    assert impacts.attrs["n_persistent"] == int((fisuv > thr).sum())
    assert impacts.sizes["impact"] == impacts.attrs["n_simple"] + impacts.attrs["n_persistent"]
    kinds = impacts["kind"].values.astype(str)
    assert (kinds == "simple").sum() == impacts.attrs["n_simple"]


def test_hand_built_contact(impacts, run):
    one = impacts.isel(impact=np.flatnonzero(impacts["contact"].values == 8))
    h = run.attrs["solver.dt"]
    steps = np.rint(one["time"].values / h).astype(int).tolist()
    assert steps == [50, 150, 220]
    assert one["kind"].values.astype(str).tolist() == ["simple", "persistent", "persistent"]
    assert set(one["race"].values.astype(str)) == {"outer"}
    e = 0.9
    # simple impact: m_eff and F_max as peak_force gives them, F_static = 0
    r0 = one.isel(impact=0)
    assert float(r0.F_static) == 0.0
    assert float(r0.m_eff) == pytest.approx(1e-3 / ((1 + e) * 0.3))
    assert float(r0.F_max) == pytest.approx(peak_force(1e-3, 0.3, e, float(r0.K)), rel=1e-12)
    # persistent impact: F_static = Λ_S / h with Λ_S the mean of the neighbours
    lam = run["Lambda_N"].values[:, 8]
    r1 = one.isel(impact=1)
    assert float(r1.F_static) == pytest.approx(0.5 * (lam[149] + lam[151]) / h, rel=1e-9)
    assert float(r1.impulse) == pytest.approx(lam[150] - 0.5 * (lam[149] + lam[151]), rel=1e-9)
    assert float(r1.F_max) > float(r1.F_static)
    # no approach (v_pre = 1e-4 <= v_min): kept, flagged, no force, no infinities
    r2 = one.isel(impact=2)
    assert int(r2.approach) == 0
    for name in ("F_max", "m_eff", "delta_max", "contact_time"):
        assert np.isnan(float(r2[name]))
    assert np.isfinite(float(r2.F_static)) and float(r2.F_static) > 0
    assert impacts.attrs["n_no_approach"] >= 1


def test_stiffness_per_race_and_r_eff(run):
    a = run.attrs
    r_b, r_a = a["model.ball_radius"], a["model.inner_radius"]
    r_c = r_a + 2 * r_b + float(run.clearance)
    E, nu = a["model.youngs_modulus"], a["model.poisson_ratio"]
    conc = extract_impacts(run, r_eff="concave")
    pap = extract_impacts(run, r_eff="paper")
    outer = conc["race"].values.astype(str) == "outer"
    np.testing.assert_allclose(conc["K"].values[outer],
                               hertz_stiffness(r_b, r_c, E, nu, E, nu, concave=True))
    np.testing.assert_allclose(pap["K"].values[outer],
                               hertz_stiffness(r_b, r_c, E, nu, E, nu, concave=False))
    np.testing.assert_allclose(conc["K"].values[~outer],
                               hertz_stiffness(r_b, r_a, E, nu, E, nu))
    ok = outer & np.isfinite(conc["F_max"].values)
    # the concave (correct) form is stiffer: larger peak forces, F ∝ K^{2/5} for simple impacts
    assert (conc["F_max"].values[ok] > pap["F_max"].values[ok]).all()
    simple = ok & (conc["kind"].values.astype(str) == "simple")
    ratio = conc["F_max"].values[simple] / pap["F_max"].values[simple]
    np.testing.assert_allclose(ratio, (conc.attrs["K_outer"] / pap.attrs["K_outer"]) ** 0.4,
                               rtol=1e-6)


def test_netcdf_round_trip(impacts, tmp_path):
    path = write_netcdf(impacts, tmp_path / "imp.nc")
    with xr.open_dataset(path) as back:
        assert back["kind"].values.astype(str).tolist() == \
            impacts["kind"].values.astype(str).tolist()
        np.testing.assert_array_equal(back["F_max"].values, impacts["F_max"].values)
        assert float(back["clearance"]) == float(impacts["clearance"])
        assert back.attrs["r_eff"] == "concave"


def test_empty_table(run, tmp_path):
    quiet = run.copy()
    quiet["Lambda_N"] = xr.zeros_like(run["Lambda_N"])
    imp = extract_impacts(quiet)
    assert imp.sizes["impact"] == 0
    assert imp.attrs["n_simple"] == imp.attrs["n_persistent"] == 0
    write_netcdf(imp, tmp_path / "empty.nc")
    with xr.open_dataset(tmp_path / "empty.nc") as back:
        assert back.sizes["impact"] == 0
        assert "F_max" in back
    assert top_forces(imp).sizes["impact"] == 0


def test_top_forces(impacts):
    top = top_forces(impacts, n=3)
    f = top["F_max"].values
    assert len(f) == 3 and (np.diff(f) <= 0).all()
    assert set(top["race"].values.astype(str)) == {"outer"}
    outer = impacts["race"].values.astype(str) == "outer"
    assert f[0] == np.nanmax(impacts["F_max"].values[outer])


def test_bad_settings(run):
    with pytest.raises(ValueError, match="v_min"):
        extract_impacts(run, v_min=0.0)
    with pytest.raises(ValueError, match="r_eff"):
        extract_impacts(run, r_eff="convex")
    bare = run.copy()
    bare.attrs = {k: v for k, v in run.attrs.items() if k != "model.youngs_modulus"}
    with pytest.raises(ValueError, match="youngs_modulus"):
        extract_impacts(bare)
    with pytest.raises(ValueError, match="vn_pre"):
        extract_impacts(run.drop_vars("vn_pre"))


def test_cli(run, tmp_path, capsys):
    rpath = write_netcdf(run, tmp_path / "run.nc")
    out = tmp_path / "imp.nc"
    assert main(["impacts", str(rpath), "--out", str(out)]) == 0
    with xr.open_dataset(out) as back:
        assert back.sizes["impact"] > 0
    assert main(["top-forces", str(rpath)]) == 0
    text = capsys.readouterr().out
    assert "r_eff = concave" in text and "r_eff = paper" in text and "3.66" in text
    assert main(["filter", str(rpath), "--out", str(tmp_path / "f.nc")]) == 0
    assert main(["impacts", str(tmp_path / "missing.nc"), "--out", str(out)]) == 2


def test_zero_restitution_run_keeps_its_impacts_without_forces():
    """e_N = 0 is a valid run (plastic impacts) but outside the Flores law: impacts are listed,
    F_max is missing, nothing raises (a study batch with e_N = 0 must not fail)."""
    import simcore

    ds = simcore.run(simcore.load_config(overrides=["model.e_N=0", "solver.t_end=0.01"]))
    imp = extract_impacts(ds)
    assert imp.sizes["impact"] > 0
    assert np.all(np.isnan(imp["F_max"].values))
