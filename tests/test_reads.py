"""What a study reads back from its run files (analysis.reads) against what the readers do.

The lists are checked by running the readers: a run file that holds exactly a model's needs
gives the summary numbers of the run in memory and the reference figures; without any one of
them a number goes missing or a figure fails. So a list can be neither too short nor hold a
variable nothing reads.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import simcore
from analysis.reads import FIGURE_READS, check_keep, keep_needs, run_setting
from simcore.io.variables import DEFAULT_KEEP, study_coords
from simcore.study import plan

MODELS = ("nonsmooth", "compliant")


def _study_config():
    return simcore.load_config("config/config.yaml", overrides=[
        "study.revolutions=0.5", "analysis.settle=0.5", "analysis.zoom_top=0",
        "sweep.clearance=[1e-4]", "sweep.mu=[0.01]", "sweep.omega0=[100]", "sweep.e_N=[0.9]"])


@pytest.fixture(scope="module")
def study_runs():
    """{model: (run in memory, its table, its analysis settings)} of one short grid point at a
    small clearance (a steady window of 0.5 revolutions after 0.5)."""
    from analysis.study_tables import impact_table

    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for run in plan.plan_runs(_study_config()):
            ds = simcore.io.keep_variables(simcore.run(run.config), run.keep(DEFAULT_KEEP))
            settings = dict(run.config["analysis"])
            out[run.model] = (ds, impact_table(ds, settings, dict(run.point)), settings)
    return out


def _only(ds, names):
    return ds.drop_vars([v for v in ds.data_vars if v not in names])


def _lost_numbers(ds, table, settings, full):
    """The summary numbers of ``full`` that ``ds`` does not give (or an error's name)."""
    from analysis.summary import point_numbers

    try:
        numbers = point_numbers(ds, table, settings)
    except (KeyError, ValueError) as exc:
        return [type(exc).__name__]
    return [k for k, v in full.items() if k != "model"
            and np.any(np.isfinite(v) & ~np.isfinite(numbers.get(k, np.nan)))]


def _figures_fail(ds, table, settings, tmp_path) -> bool:
    """Whether a reference figure fails or is left out for a missing variable."""
    from analysis.figures import plot_reference, plot_run

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            plot_run(ds, table, tmp_path, settings["zero_tol"], settings["zero_floor"])
            plot_reference(ds, table, tmp_path, settle=settings["settle"],
                           force_levels=settings["force_levels"], zero_tol=settings["zero_tol"],
                           zero_floor=settings["zero_floor"])
        except KeyError:
            return True
    return any("skipped" in str(w.message) for w in caught)  # a figure left out


@pytest.mark.parametrize("model", MODELS)
def test_a_file_with_exactly_the_needs_serves_every_reader(study_runs, model, tmp_path):
    from analysis.summary import point_numbers

    ds, table, settings = study_runs[model]
    needs = keep_needs([model])
    full = point_numbers(ds, table, settings)
    if model == "compliant":  # (the rating life is among the numbers checked)
        assert np.isfinite(full["L10"])
    kept = _only(ds, needs)
    assert _lost_numbers(kept, table, settings, full) == []
    if model == "nonsmooth":
        assert not _figures_fail(kept, table, settings, tmp_path)
    for name in needs:  # each one is read: without it a number or a figure is lost
        less = kept.drop_vars(name)
        lost = _lost_numbers(less, table, settings, full)
        # (the figures are drawn only where no number is lost: either loss is enough)
        assert lost or (model == "nonsmooth" and name in FIGURE_READS and _figures_fail(
            less, table, settings, tmp_path / name)), name


def test_the_default_keep_holds_what_a_study_reads():
    check_keep(DEFAULT_KEEP, MODELS)
    check_keep(DEFAULT_KEEP, ["nonsmooth"])
    assert "F_N" not in keep_needs(["nonsmooth"])
    assert not set(keep_needs(MODELS)) & set(plan.TWIN_DROPS)  # what twins never write


@pytest.mark.parametrize("name", sorted(keep_needs(MODELS)))
def test_a_keep_without_a_needed_variable_is_refused_naming_it(name):
    keep = [v for v in DEFAULT_KEEP if v != name]
    with pytest.raises(simcore.ConfigError, match=rf"^study\.keep lacks '{name}' \(the "):
        check_keep(keep, MODELS)


@pytest.mark.parametrize("model", MODELS)
def test_run_setting_reads_back_every_model_setting_of_the_run(study_runs, model):
    """Every scalar model setting a run was made with comes back from its file as configured,
    with the coordinates a study gives its runs (the swept ones from the point; a swept
    category, the bearing, as its int8 code), and a setting the file lacks is refused naming
    it."""
    run = next(r for r in plan.plan_runs(_study_config()) if r.model == model)
    point = dict(run.point) | {"model.bearing": run.config["model"]["bearing"]}
    ds = study_coords(study_runs[model][0], point, list(point))
    assert ds["bearing"].dtype == np.int8  # what a study writes, not the name
    settings = {k: v for k, v in run.config["model"].items()
                if isinstance(v, (bool, int, float, str))}
    assert {"clearance", "mu", "omega0", "e_N", "ball_radius", "bearing"} <= set(settings)
    for key, value in settings.items():
        got = run_setting(ds, key)
        assert (got == pytest.approx(value)) if isinstance(value, float) else got == value, key
    for key, value in run.point.items():  # {"model.clearance": ...}
        assert float(run_setting(ds, key.removeprefix("model."))) == pytest.approx(value), key
    assert run_setting(ds, "no_such_setting", None) is None
    with pytest.raises(ValueError, match="'model.no_such_setting'"):
        run_setting(ds, "no_such_setting")


def test_run_setting_of_a_file_without_attributes_reads_its_coordinates(study_runs):
    """A file that lost its attributes (e.g. combined with ``combine_attrs="drop"``) still
    gives a swept number from its coordinate, but not a category's code as its name."""
    ds = study_coords(study_runs["nonsmooth"][0], {"model.clearance": 1e-4,
                                                   "model.bearing": "6012-paper"},
                      ["model.clearance", "model.bearing"])
    ds.attrs = {}
    assert run_setting(ds, "clearance") == pytest.approx(1e-4)
    assert run_setting(ds, "bearing", None) is None
