"""Figures of a run and of the study: files are written, degenerate inputs are handled."""

import warnings

import numpy as np
import pytest
import xarray as xr

from analysis import extract_impacts
from analysis.figures import plot_reference, plot_run, plot_study, run_label
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


def _summary(shape, fill=None, failed_at=None):
    """A summary with the layout of analysis.summary.summarize over a grid of ``shape``."""
    values = {"clearance": [2e-5, 1e-4, 4e-4], "mu": [0.0, 0.01, 0.05], "omega0": [25.0, 50.0],
              "e_N": [0.7, 0.9]}
    dims = ("clearance", "mu", "omega0", "e_N")
    coords = {d: values[d][:n] for d, n in zip(dims, shape, strict=True)}
    coords.update(race=np.array([0, 1], "i1"), kind=np.arange(4, dtype="i1"),
                  level=[100.0, 1000.0], rank=[1, 2, 3], stage=np.arange(3, dtype="i1"))
    rng = np.random.default_rng(0)

    def var(*extra):
        sh = tuple(shape) + tuple(len(coords[e]) for e in extra)
        data = rng.uniform(1e2, 5e3, sh) if fill is None else np.full(sh, fill)
        return (dims + extra, data)

    ds = xr.Dataset(
        {"peak_force": var("race"), "p_max": var("race"), "startup_peak_force": var(),
         "above_per_rev": var("race", "level"), "impacts_per_rev": var("race", "kind"),
         "iter_max": var("stage"), "failed": (dims, np.zeros(shape))},
        coords=coords, attrs={"settle_revolutions": 1.0})
    if failed_at is not None:
        ds["failed"][failed_at] = 1.0
        for name in ds.data_vars:
            if name != "failed":
                ds[name][failed_at] = np.nan
    return ds


QUANTITIES = ["peak_force_outer", "peak_force_inner", "p_max_outer", "p_max_inner",
              "startup_peak_force", "above_100N_per_rev", "above_1000N_per_rev",
              "impacts_per_rev"]


def test_plot_study_shows_every_point_of_four_swept_parameters(tmp_path):
    ds = _summary((3, 3, 2, 2), failed_at=(0, 1, 0, 1))
    paths = plot_study(ds, tmp_path)
    names = sorted(p.name for p in paths)
    assert names == sorted([f"study_{q}.png" for q in QUANTITIES]
                           + [f"pairs_{q}.png" for q in QUANTITIES])
    assert all(p.stat().st_size > 20_000 for p in paths)


def test_plot_study_two_one_and_no_swept_parameters(tmp_path):
    paths = plot_study(_summary((2, 3, 1, 1)), tmp_path / "two")
    assert sorted(p.name for p in paths) == sorted(f"study_{q}.png" for q in QUANTITIES)
    paths = plot_study(_summary((3, 1, 1, 1), fill=np.nan), tmp_path / "nan")
    # p_max all missing (older impact tables): no p_max figures
    assert sorted(p.name for p in paths) == sorted(
        f"study_{q}.png" for q in QUANTITIES if not q.startswith("p_max"))
    paths = plot_study(_summary((1, 1, 1, 1)), tmp_path / "one")
    assert [p.name for p in paths] == ["study_single.png"]


def test_plot_reference(run, tmp_path):
    paths = plot_reference(run, extract_impacts(run), tmp_path, settle=0.05)
    assert [p.name for p in paths] == [f"reference_{n}.png" for n in (
        "force_angle", "ball_load", "exceedance", "force_speed", "iterations")]
    assert all(p.stat().st_size > 20_000 for p in paths)


def test_study_figures_command_on_a_summary_file(tmp_path):
    """The command reads a summary written to netCDF (integer stage/race/kind coordinates)."""
    from analysis.__main__ import main
    from simcore.io import write_netcdf

    path = write_netcdf(_summary((2, 2, 1, 1)), tmp_path / "summary.nc")
    assert main(["study-figures", str(path)]) == 0
    assert (tmp_path / "figures" / "study_peak_force_outer.png").exists()
    assert (tmp_path / "figures" / "summary_table.csv").exists()


def test_plot_study_parts_share_the_figures(tmp_path):
    """part=(i, n) draws every n-th quantity: the parts together are the whole set, once."""
    ds = _summary((2, 2, 2, 2))
    whole = {p.name for p in plot_study(ds, tmp_path / "all")}
    parts = [{p.name for p in plot_study(ds, tmp_path / f"p{i}", part=(i, 2))} for i in (0, 1)]
    assert parts[0] and parts[1] and not parts[0] & parts[1]
    assert parts[0] | parts[1] == whole
    assert plot_study(_summary((1, 1, 1, 1)), tmp_path / "one", part=(1, 2)) == []
    with pytest.raises(ValueError, match="part"):
        plot_study(ds, tmp_path, part=(2, 2))
