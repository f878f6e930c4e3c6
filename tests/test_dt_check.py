"""Step-size check (python -m analysis dt-check): matching, flags, config rebuilt from a run."""

import numpy as np
import pytest
import xarray as xr

from analysis import FLAG, extract_impacts
from analysis.__main__ import main
from analysis.dt_check import compare_impacts, config_from_run
from analysis.synthetic import make_pinch_dataset
from simcore.io import write_netcdf


def _fine_copy(ds, scale_impulse=1.0, shift_steps=1):
    """The same pinch 'at dt/2': same impacts, one fine step later, impulses scaled."""
    fine = make_pinch_dataset(dt=ds.attrs["solver.dt"] / 2, n_steps=80, step=40 + shift_steps,
                              e_N=0.9)
    fine["Lambda_N"] = fine["Lambda_N"] * scale_impulse
    return fine


@pytest.mark.parametrize("scale,moved", [(1.05, False), (1.25, True)])
def test_compare_flags_impacts_that_move(scale, moved):
    coarse = extract_impacts(make_pinch_dataset(e_N=0.9))
    fine = extract_impacts(_fine_copy(make_pinch_dataset(e_N=0.9), scale))
    flagged, matches = compare_impacts(coarse, fine, n=2, tol=0.1)
    assert len(matches) == 2
    for m in matches:
        assert m["match"] is not None
        assert m["impulse_rel"] == pytest.approx(scale - 1, rel=1e-9)
        assert m["v_pre_rel"] == pytest.approx(0.0, abs=1e-12)
        # F_max ∝ (Λ v)^{3/5} at a fixed v: the force moves by scale^{3/5}
        assert m["F_max_rel"] == pytest.approx(scale**0.6 - 1, rel=1e-6)
        assert m["moved"] is moved
    bits = flagged["flags"].values & FLAG["not_converged_dt"]
    assert (bits != 0).sum() == (2 if moved else 0)
    assert flagged.attrs["dt_check"] == 1 and flagged.attrs["dt_check_tol"] == 0.1
    if moved:
        assert (flagged["trusted"].values == 0).all()


def test_compare_without_a_match_flags():
    coarse = extract_impacts(make_pinch_dataset(e_N=0.9))
    fine = extract_impacts(_fine_copy(make_pinch_dataset(e_N=0.9), shift_steps=30))
    flagged, matches = compare_impacts(coarse, fine, n=2, tol=0.1)
    assert all(m["match"] is None for m in matches)
    assert (flagged["flags"].values & FLAG["not_converged_dt"]).all()


def test_compare_bad_settings():
    t = extract_impacts(make_pinch_dataset())
    with pytest.raises(ValueError, match="tol"):
        compare_impacts(t, t, tol=0)
    with pytest.raises(ValueError, match="n must"):
        compare_impacts(t, t, n=0)


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    import simcore

    ds = simcore.run(simcore.load_config(overrides=["solver.t_end=0.003"]))
    return write_netcdf(ds, tmp_path_factory.mktemp("dt") / "run.nc"), ds


def test_config_rebuilt_from_run_file(short_run):
    import simcore

    path, _ = short_run
    with xr.open_dataset(path) as ds:
        cfg = config_from_run(ds.load(), {"solver.dt": 5e-5})
    ref = simcore.load_config(overrides=["solver.t_end=0.003"])
    assert cfg["model"] == ref["model"]
    assert cfg["solver"] == {**ref["solver"], "dt": 5e-5}
    with pytest.raises(ValueError, match="model"):
        config_from_run(xr.Dataset(attrs={"title": "x"}))


def test_cli_dt_check_on_a_run(short_run, tmp_path, capsys):
    """The first pinch (ball 4, 1.5 ms) at dt = 1e-4 against 5e-5: impulse, approach speed and
    force within 10 %, and the command prints the table and writes the flagged table."""
    path, _ = short_run
    out = tmp_path / "flagged.nc"
    assert main(["dt-check", str(path), "--t-check", "0.002", "-n", "2", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "dt-check: dt = 0.0001 s against 5e-05 s" in text and "pinch" in text
    with xr.open_dataset(out) as back:
        assert back.attrs["dt_check"] == 1
        top = int(np.nanargmax(back["F_max"].values))
        assert int(back["ball"].values[top]) == 4
        assert back["time"].values[top] == pytest.approx(1.5e-3)
        assert not back["flags"].values[top] & FLAG["not_converged_dt"]
    assert main(["dt-check", str(path), "--tol", "-1"]) == 2
    assert "--tol" in capsys.readouterr().err
