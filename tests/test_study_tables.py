"""The impact table a study job makes from the run it just simulated (in memory), against the
table made from the written run file; the empty table of a failed run."""

import numpy as np
import pytest

import analysis
import simcore
from analysis.study_tables import impact_table
from simcore.config import load_config
from simcore.io import failed_run_dataset, open_run

SETTINGS = {"zero_tol": 1e-4, "zero_floor": 1e-12, "r_eff": "concave", "v_min": 1e-3,
            "zoom_top": 2}
POINT = {"clearance": 4e-4, "mu": 0.01, "omega0": 50.0, "e_N": 0.9}


@pytest.fixture(scope="module")
def run_ds():
    return simcore.run(load_config(overrides=["solver.t_end=0.004"]))


def test_table_from_memory_matches_the_table_from_the_file(run_ds, tmp_path):
    path = tmp_path / "run.nc"
    keep = simcore.validate_config({})["study"]["keep"]
    simcore.write_netcdf(run_ds, path, keep=keep)
    memory = impact_table(run_ds, SETTINGS, POINT)
    from_file = analysis.extract_impacts(open_run(path))
    # the same impacts, found from Lambda_N (float64 in the file) ...
    np.testing.assert_array_equal(memory["time"].values, from_file["time"].values)
    np.testing.assert_array_equal(memory["contact"].values, from_file["contact"].values)
    np.testing.assert_allclose(memory["impulse"].values, from_file["impulse"].values, rtol=1e-12)
    # ... with v_pre from vn_free, stored as float32 in the file
    np.testing.assert_allclose(memory["v_pre"].values, from_file["v_pre"].values, rtol=1e-6)
    assert memory.attrs["failed"] == 0
    assert np.isfinite(memory["F_max_zoom"].values).sum() == 2
    for key, value in POINT.items():
        assert memory[key].item() == value and memory[key].attrs["units"]


def test_failed_run_gives_an_empty_table():
    cfg = load_config()
    table = impact_table(failed_run_dataset(cfg, "run x failed: SolverError: boom"), SETTINGS,
                         POINT, source="runs/x.nc")
    assert table.attrs["failed"] == 1 and "boom" in table.attrs["error"]
    assert "impact" not in table.sizes and table["clearance"].item() == 4e-4


def test_zoom_step_setting_reaches_the_table(run_ds):
    """analysis.zoom_steps_per_contact (schema default 40) sets the zoom's step: twice the steps,
    half the step."""
    from simcore.limits import hertz_contact_time

    default = simcore.validate_config({})["analysis"]["zoom_steps_per_contact"]
    assert default == 40
    tables = {n: impact_table(run_ds, dict(SETTINGS, zoom_top=1, zoom_steps_per_contact=n), POINT)
              for n in (20, 40)}
    steps = {n: np.nanmax(t["dt_zoom"].values) for n, t in tables.items()}
    model = simcore.validate_config(
        {"model": {k.split(".", 1)[1]: v for k, v in run_ds.attrs.items()
                   if k.startswith("model.")}})["model"]
    assert steps[20] == pytest.approx(hertz_contact_time(model) / 20)
    assert steps[20] == pytest.approx(2.0 * steps[40])
    with pytest.raises(simcore.ConfigError, match="analysis.zoom_steps_per_contact"):
        load_config(overrides=["analysis.zoom_steps_per_contact=2"])
