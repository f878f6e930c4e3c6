"""Figures of a run and of the study: files are written, degenerate inputs are handled."""

import warnings

import numpy as np
import pytest
import xarray as xr

from analysis import extract_impacts
from analysis.figures import plot_run, plot_study, run_label
from analysis.synthetic import make_run_dataset


@pytest.fixture(scope="module")
def run():
    return make_run_dataset(n_steps=400)


def test_plot_run(run, tmp_path):
    paths = plot_run(run, extract_impacts(run), tmp_path, prefix="case")
    assert [p.name for p in paths] == ["case_lambda.png", "case_orbit.png", "case_slider.png"]
    for p in paths:
        assert p.stat().st_size > 10_000


def test_plot_run_without_journal_or_impacts(run, tmp_path):
    ds = run.drop_vars(["journal_x", "journal_y"])
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        paths = plot_run(ds, None, tmp_path, prefix="x")
    assert [p.name for p in paths] == ["x_lambda.png", "x_slider.png"]
    assert any("orbit" in str(x.message) for x in w)
    quiet = ds.copy()
    quiet["Lambda_N"] = xr.zeros_like(ds["Lambda_N"])
    with pytest.warns(UserWarning, match="orbit"):
        assert plot_run(quiet, None, tmp_path, prefix="q")[0].exists()


def test_run_label(run):
    assert run_label(run) == "g = 400 µm, μ = 0.01, ω0 = 50 rad/s, e_N = 0.9"


def _summary(shape, fill=None):
    coords = {"clearance": [2e-4, 4e-4, 6e-4][: shape[0]], "mu": [0.0, 0.01, 0.1][: shape[1]],
              "omega0": [50.0], "e_N": [0.7, 0.9][: shape[2]], "rank": [1, 2, 3]}
    dims = ("clearance", "mu", "omega0", "e_N")
    sh = (shape[0], shape[1], 1, shape[2])
    rng = np.random.default_rng(0)
    pf = rng.uniform(1e3, 5e3, sh) if fill is None else np.full(sh, fill)
    ds = xr.Dataset(
        {
            "peak_force": (dims, pf, {"units": "N"}),
            "top3_force": (dims + ("rank",), np.repeat(pf[..., None], 3, -1), {"units": "N"}),
            "n_simple": (dims, np.full(sh, 10.0) if fill is None else np.full(sh, fill)),
            "n_persistent": (dims, np.full(sh, 4.0) if fill is None else np.full(sh, fill)),
            "failed": (dims, np.zeros(sh)),
        },
        coords=coords,
    )
    return ds


def test_plot_study(tmp_path):
    ds = _summary((3, 3, 2))
    ds["peak_force"][0, 1, 0, 0] = np.nan  # a failed run
    paths = plot_study(ds, tmp_path)
    assert sorted(p.name for p in paths) == ["study_clearance.png", "study_e_N.png",
                                             "study_mu.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)


def test_plot_study_all_nan_and_single(tmp_path):
    paths = plot_study(_summary((3, 1, 1), fill=np.nan), tmp_path / "nan")
    assert [p.name for p in paths] == ["study_clearance.png"]
    paths = plot_study(_summary((1, 1, 1)), tmp_path / "one")
    assert [p.name for p in paths] == ["study_single.png"]
