"""The impact table a study job makes from the run it just simulated (in memory), against the
table made from the written run file; the empty table of a failed run."""

import numpy as np
import pytest

import analysis
import simcore
from analysis.study_tables import impact_table
from simcore.config import load_config
from simcore.io import failed_run_dataset, open_run
from simcore.io.variables import LABEL_LENGTH
from simcore.study import plan

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
    memory = impact_table(run_ds, SETTINGS, POINT, source=str(path))
    assert memory.attrs["run_file"] == str(path)
    from_file = analysis.extract_impacts(open_run(path))
    # the same impacts, found from Lambda_N (float64 in the file) ...
    np.testing.assert_array_equal(memory["time"].values, from_file["time"].values)
    np.testing.assert_array_equal(memory["contact"].values, from_file["contact"].values)
    np.testing.assert_allclose(memory["impulse"].values, from_file["impulse"].values, rtol=1e-12)
    # ... with v_pre from vn_free, stored as float32 in the file
    np.testing.assert_allclose(memory["v_pre"].values, from_file["v_pre"].values, rtol=1e-6)
    assert memory.attrs["failed"] == 0
    assert np.isfinite(memory["F_max_zoom"].values).sum() == 2
    for name, var in memory.variables.items():  # the zoom's columns too: a label each
        assert 0 < len(var.attrs["long_name"]) <= LABEL_LENGTH, name
    for key, value in POINT.items():
        assert memory[key].item() == value and memory[key].attrs["units"]


def test_failed_run_gives_an_empty_table():
    cfg = load_config()
    table = impact_table(failed_run_dataset(cfg, "run x failed: SolverError: boom"), SETTINGS,
                         POINT, source="runs/x.nc")
    assert table.attrs["failed"] == 1 and "boom" in table.attrs["error"]
    assert table.attrs["run_file"] == "runs/x.nc"
    assert "impact" not in table.sizes and table["clearance"].item() == 4e-4


def test_zoom_step_setting_reaches_the_table(run_ds):
    """analysis.zoom_steps_per_contact (schema default 40) sets a fixed-step zoom's step
    (analysis.zoom_adaptive: false): twice the steps, half the step."""
    from simcore.config.limits import hertz_contact_time

    default = simcore.validate_config({})["analysis"]["zoom_steps_per_contact"]
    assert default == 40
    tables = {n: impact_table(run_ds, dict(SETTINGS, zoom_top=1, zoom_steps_per_contact=n,
                                           zoom_adaptive=False), POINT)
              for n in (20, 40)}
    steps = {n: np.nanmax(t["dt_zoom"].values) for n, t in tables.items()}
    model = simcore.validate_config(
        {"model": {k.split(".", 1)[1]: v for k, v in run_ds.attrs.items()
                   if k.startswith("model.")}})["model"]
    assert steps[20] == pytest.approx(hertz_contact_time(model) / 20)
    assert steps[20] == pytest.approx(2.0 * steps[40])
    assert tables[20].attrs["zoom_adaptive"] == 0
    assert simcore.validate_config({})["analysis"]["zoom_adaptive"] is True
    with pytest.raises(simcore.ConfigError, match="analysis.zoom_adaptive"):
        load_config(overrides=["analysis.zoom_adaptive=3"])
    with pytest.raises(simcore.ConfigError, match="analysis.zoom_steps_per_contact"):
        load_config(overrides=["analysis.zoom_steps_per_contact=2"])


@pytest.fixture(scope="module")
def compliant_ds():
    return simcore.run(load_config(overrides=[
        "solver.t_end=0.004", "model.contact_model=compliant", "solver.dt=2e-6",
        "solver.output_dt=1e-4", "model.drive=constant",
        "solver.max_indentation=0.2"]))  # (the paper's modulus indents 0.105 r_B at 3 ms)


def test_summary_from_the_numbers_stored_in_the_tables_equals_the_one_from_the_files(
        run_ds, compliant_ds, tmp_path):
    """One reduction: the numbers a simulate job stores in each table (from the run in memory)
    are those the summary computes from the written files when a table has none."""
    import xarray as xr

    from analysis.summary import summarize

    settings = dict(SETTINGS, zoom_top=0, settle=0.01, force_levels=[100.0, 1000.0])
    keep = simcore.validate_config({})["study"]["keep"]
    failed_point = dict(POINT, clearance=1e-4)
    failed_cfg = load_config(overrides=["model.clearance=1e-4"])
    files = {"runs": [], "stored": [], "plain": []}
    twin_keep = [name for name in keep if name not in plan.TWIN_DROPS]  # (as a study writes it)
    for label, point, ds in (("a", POINT, run_ds),
                             ("b", failed_point, failed_run_dataset(failed_cfg, "failed: boom")),
                             ("c", POINT, compliant_ds)):
        simcore.write_netcdf(ds, tmp_path / f"run{label}.nc",
                             keep=twin_keep if label == "c" else keep)
        table = impact_table(ds, settings, point)
        assert table.attrs["summary_failed"] == (1.0 if label == "b" else 0.0)
        simcore.write_netcdf(table, tmp_path / f"stored{label}.nc")
        table.attrs = {k: v for k, v in table.attrs.items() if not k.startswith("summary_")}
        simcore.write_netcdf(table, tmp_path / f"plain{label}.nc")
        for kind in files:
            files[kind].append(tmp_path / f"{'run' if kind == 'runs' else kind}{label}.nc")
    kw = {"scheduler": "synchronous", "settings": settings}
    from_files = summarize({"nonsmooth": files["runs"][:2], "compliant": files["runs"][2:]},
                           {"nonsmooth": files["plain"][:2]}, **kw)
    missing = [tmp_path / "missing.nc"] * 3  # no run file is read
    from_tables = summarize({"nonsmooth": missing[:2], "compliant": missing[2:]},
                            {"nonsmooth": files["stored"][:2], "compliant": files["stored"][2:]},
                            **kw)
    for ds in (from_files, from_tables):
        ds.attrs.pop("history")
    xr.testing.assert_identical(from_files, from_tables)
    assert int((from_tables["failed"] > 0).sum()) == 1
    assert np.isfinite(from_tables["max_Lambda_N"].sel(clearance=4e-4)).all()
    assert np.isfinite(from_tables["peak_force"].sel(clearance=4e-4)).any()
    assert np.isfinite(from_files["L10"].sel(clearance=4e-4)).all()  # (from the twin's file)
    # a table whose stored numbers lack one of the model's variables (written before it
    # existed): its run file is read again
    for label in ("a", "c"):
        with xr.open_dataset(tmp_path / f"stored{label}.nc") as ds:
            older = ds.load()
        del older.attrs["summary_peak_force_rev_spread"]
        simcore.write_netcdf(older, tmp_path / f"older{label}.nc")
    older = [tmp_path / "oldera.nc", files["stored"][1], tmp_path / "olderc.nc"]
    with pytest.raises(FileNotFoundError):
        summarize({"nonsmooth": missing[:2], "compliant": missing[2:]},
                  {"nonsmooth": older[:2], "compliant": older[2:]}, **kw)
    from_older = summarize({"nonsmooth": files["runs"][:2], "compliant": files["runs"][2:]},
                           {"nonsmooth": older[:2], "compliant": older[2:]}, **kw)
    from_older.attrs.pop("history")
    xr.testing.assert_identical(from_files, from_older)
    # other settings than the stored ones: the files are read again
    other = summarize(files["runs"][:2], files["stored"][:2], **dict(kw, settings=dict(
        settings, settle=0.0)))
    assert float(other["settle_time"].sel(clearance=4e-4, model=0).item()) == 0.0


#: analysis settings before and after a change of every setting only the summary reads
SUMMARY_OLD = dict(SETTINGS, zoom_top=0, settle=0.0, force_levels=[100.0, 1000.0],
                   life_conformity=None, life_load_rating=None)
SUMMARY_NEW = dict(SUMMARY_OLD, force_levels=[50.0, 500.0, 5000.0], life_conformity=[0.51, 0.54],
                   life_load_rating=20000.0)


def _study_keeps():
    """The variables a study keeps of a nonsmooth run and of a compliant twin."""
    keep = simcore.validate_config({})["study"]["keep"]
    return keep, [name for name in keep if name not in plan.TWIN_DROPS]


def _assert_summary_from_tables_is_the_one_from_files(runs, tables, plain, settings):
    """The summary of a nonsmooth run and a twin (``runs``) with ``settings`` from ``tables``
    equals the one from ``plain`` (the same tables without stored numbers: computed from the
    run files); the new settings reach it."""
    import xarray as xr

    from analysis.summary import summarize

    kw = {"scheduler": "synchronous", "settings": settings}
    reused = summarize({"nonsmooth": runs[:1], "compliant": runs[1:]},
                       {"nonsmooth": tables[:1], "compliant": tables[1:]}, **kw)
    from_files = summarize({"nonsmooth": runs[:1], "compliant": runs[1:]},
                           {"nonsmooth": plain[:1], "compliant": plain[1:]}, **kw)
    for ds in (reused, from_files):
        ds.attrs.pop("history")
    xr.testing.assert_identical(reused, from_files)
    assert reused.sizes["level"] == len(settings["force_levels"])
    assert float(reused["load_rating"].max()) == settings["life_load_rating"]


def test_settings_only_the_summary_reads_change_no_table_and_reach_the_summary(
        run_ds, compliant_ds, tmp_path):
    """simcore.study.plan.SUMMARY_ONLY_SETTINGS (which a study's run fingerprint leaves out): other
    values change no variable of an impact table, only its stored summary numbers; and a
    summary made with the new values from tables stored with the old ones equals the summary
    computed from the run files, so reusing the runs loses nothing."""
    import xarray as xr

    from simcore.study.plan import SUMMARY_ONLY_SETTINGS

    old, new = SUMMARY_OLD, SUMMARY_NEW
    assert {key for key in new if new[key] != old[key]} == set(SUMMARY_ONLY_SETTINGS)
    keep, twin_keep = _study_keeps()
    runs, stored, plain_files = [], [], []
    for label, ds, kept in (("a", run_ds, keep), ("c", compliant_ds, twin_keep)):
        tables = {name: impact_table(ds, s, POINT) for name, s in (("old", old), ("new", new))}
        plain = {name: t.copy() for name, t in tables.items()}
        for t in plain.values():
            t.attrs = {k: v for k, v in t.attrs.items() if not k.startswith("summary_")}
        xr.testing.assert_identical(plain["old"], plain["new"])
        assert tables["old"].attrs["summary_settings"] != tables["new"].attrs["summary_settings"]
        runs.append(tmp_path / f"run{label}.nc")
        stored.append(tmp_path / f"stored{label}.nc")
        simcore.write_netcdf(ds, runs[-1], keep=kept)
        simcore.write_netcdf(tables["old"], stored[-1])
        plain_files.append(tmp_path / f"plain{label}.nc")
        simcore.write_netcdf(plain["new"], plain_files[-1])
    _assert_summary_from_tables_is_the_one_from_files(runs, stored, plain_files, new)


def test_a_kept_run_gets_new_summary_only_settings_in_its_files_and_nothing_else(
        run_ds, compliant_ds, tmp_path):
    """analysis.study_tables.refresh_summary_settings, what a study does to a run it keeps
    after a setting only the summary reads changed: the run file's analysis.<key> attributes
    become the new values, the table's stored numbers those of the new settings (so the
    summary reads no run file, and equals the one computed from the files), every variable and
    every other attribute as they were; a second call finds nothing to do."""
    import xarray as xr

    from analysis.study_tables import refresh_summary_settings
    from analysis.summary import stored_numbers

    old, new = SUMMARY_OLD, SUMMARY_NEW
    keep, twin_keep = _study_keeps()
    runs, tables, plain = [], [], []
    for label, ds, kept in (("a", run_ds, keep), ("c", compliant_ds, twin_keep)):
        table = impact_table(ds, old, POINT)
        runs.append(tmp_path / f"run{label}.nc")
        tables.append(tmp_path / f"table{label}.nc")
        simcore.write_netcdf(ds, runs[-1], keep=kept)
        simcore.write_netcdf(table, tables[-1])
        table.attrs = {k: v for k, v in table.attrs.items() if not k.startswith("summary_")}
        plain.append(tmp_path / f"plain{label}.nc")
        simcore.write_netcdf(table, plain[-1])
    before = {path: xr.load_dataset(path) for path in runs + tables}
    changed = {"analysis.force_levels", "analysis.life_conformity",
               "analysis.life_load_rating"}
    for run, table in zip(runs, tables, strict=True):
        assert refresh_summary_settings(run, table, {"analysis": new})
        assert not refresh_summary_settings(run, table, {"analysis": new})
        after = xr.load_dataset(run)
        np.testing.assert_array_equal(after.attrs["analysis.force_levels"], [50, 500, 5000])
        np.testing.assert_array_equal(after.attrs["analysis.life_conformity"], [0.51, 0.54])
        assert after.attrs["analysis.life_load_rating"] == 20000.0
        assert {k: str(v) for k, v in after.attrs.items() if k not in changed} == \
            {k: str(v) for k, v in before[run].attrs.items() if k not in changed}
        after.attrs, before[run].attrs = {}, {}
        xr.testing.assert_identical(after, before[run])
        stored = xr.load_dataset(table)
        assert stored_numbers(stored.attrs, new) is not None
        assert stored_numbers(before[table].attrs, new) is None
        for ds in (stored, before[table]):
            ds.attrs = {k: v for k, v in ds.attrs.items() if not k.startswith("summary_")}
        xr.testing.assert_identical(stored, before[table])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        p.name for p in runs + tables + plain)  # no temporary file left
    _assert_summary_from_tables_is_the_one_from_files(runs, tables, plain, new)
