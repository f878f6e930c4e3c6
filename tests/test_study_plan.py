"""The registry of swept parameters, sweep validation, and the study's plan (runs, compliant
twins, cost, batches, size limit, fingerprints): simcore.config.parameters, simcore.study.plan."""

from __future__ import annotations

import copy
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import simcore
from simcore.config import load_schema
from simcore.config.limits import hertz_contact_time
from simcore.config.parameters import (
    BASE_AXES,
    MAX_NAME,
    build_registry,
    registry,
    run_name,
    udunits,
)
from simcore.study import plan


def _study(*overrides, sweep=None):
    """The default study's configuration with ``overrides``; ``sweep`` added to its sweep."""
    with warnings.catch_warnings():
        # read as one run, the base file's clearance beside a class is warned of; a study
        # does not warn of its base settings (test_a_clearance_the_user_gives_beside_a_...)
        warnings.filterwarnings("ignore", "model.clearance = .* is given and replaced")
        cfg = simcore.load_config("config/config.yaml", overrides=list(overrides))
    if sweep:
        cfg["sweep"].update(sweep)
    return simcore.validate_config(cfg)


# --- the registry ---------------------------------------------------------------------------

def test_registry_holds_every_numeric_or_enumerated_key_of_the_three_sections():
    schema = load_schema()
    params = registry()
    for section in ("model", "solver", "analysis"):
        for key, node in schema["properties"][section]["properties"].items():
            sweepable = node.get("type") in ("number", "integer", "boolean") \
                or "enum" in node or node.get("type") == ["number", "null"] or "oneOf" in node
            assert (f"{section}.{key}" in params) == sweepable, (section, key)
    assert "analysis.force_levels" not in params  # a list is not an axis
    assert [params[k].name for k in BASE_AXES] == ["clearance", "mu", "omega0", "e_N"]
    assert params["solver.dt"].name == "solver_dt" and params["solver.dt"].units == "s"
    assert params["model.contact_model"].name == "model"


def test_a_key_added_to_the_schema_is_an_axis_without_code():
    schema = copy.deepcopy(load_schema())
    schema["properties"]["model"]["properties"]["pin_stiffness"] = {
        "type": "number", "minimum": 0, "default": 1.0,
        "description": "stiffness of a new pin [N/m^1.5], made up for this test"}
    schema["properties"]["solver"]["properties"]["scheme"] = {
        "type": "string", "enum": ["a", "b/c"], "default": "a", "description": "a: one; b/c: two"}
    params = build_registry(schema)
    pin = params["model.pin_stiffness"]
    assert (pin.name, pin.units, pin.long_name) == ("pin_stiffness", "N m-1.5",
                                                     "stiffness of a new pin")
    scheme = params["solver.scheme"]
    assert scheme.kind == "category" and scheme.categories == ("a", "b/c")
    assert scheme.name == "solver_scheme" and scheme.long_name == "scheme"
    assert scheme.token("b/c") == "solver_scheme~b%2Fc"  # no path separator in a file name


@pytest.mark.parametrize("text, units", [
    ("m", "m"), ("-", "1"), ("rad/s", "rad s-1"), ("N s/m", "N s m-1"), ("m/s^2", "m s-2"),
    ("kg m^2", "kg m2"), ("Pa", "Pa"), ("revolutions", "1"), ("N/m^1.5", "N m-1.5"),
])
def test_units_in_udunits_form(text, units):
    assert udunits(text) == units


def test_every_registered_unit_is_written_in_udunits_form():
    for param in registry().values():
        if param.kind == "category":
            assert param.units is None and param.categories
        else:
            assert param.units and "/" not in param.units and "^" not in param.units, param


# --- the sweep section ----------------------------------------------------------------------

@pytest.mark.parametrize("sweep, words", [
    ({"model.bogus": [1.0]}, "sweep.model.bogus: unknown key"),
    ({"bogus": [1.0]}, "sweep.bogus: unknown key"),
    ({"model.cage_stiffness": [-1.0]}, "sweep.model.cage_stiffness.0: -1.0 is not allowed"),
    ({"model.drive": ["fast"]}, "sweep.model.drive.0: 'fast' is not allowed"),
    ({"n_balls": [8.5]}, "sweep.n_balls.0"),
    ({"solver.dt": []}, "sweep.solver.dt"),
    ({"analysis.force_levels": [[1.0]]},
     "sweep.analysis.force_levels: not allowed as a sweep axis"),
])
def test_a_bad_sweep_key_or_value_is_refused_in_one_line(sweep, words):
    with pytest.raises(simcore.ConfigError) as err:
        simcore.validate_config({"sweep": sweep})
    assert words in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("sweep, words", [
    ({"clearance": [1e-4], "model.clearance": [2e-4]}, "the same key as"),
    ({"model.contact_model": ["compliant"]}, "study.models"),
    ({"solver.output_dt": [1e-4]}, "the study sets it"),
    ({"mu": [0.01, 0.0100000000001]}, "the same value twice"),
])
def test_a_sweep_the_study_cannot_run_is_refused_before_any_run(sweep, words):
    cfg = simcore.validate_config({"sweep": sweep})
    with pytest.raises(simcore.ConfigError) as err:
        plan.study_axes(cfg)
    assert words in str(err.value)


def test_an_integer_axis_takes_whole_numbers_only():
    n_balls = registry()["model.n_balls"]
    assert n_balls.plain(8.0) == 8 and n_balls.plain(np.int64(9)) == 9
    for value in (8.5, np.float64(8.25)):
        with pytest.raises(ValueError, match=r"^sweep\.model\.n_balls: 8\.\d+ is not allowed; "
                                             "allowed: a whole number"):
            n_balls.plain(value)


def test_axes_are_the_four_parameters_then_the_swept_keys_in_registry_order():
    cfg = _study(sweep={"solver.dt": [1e-4, 5e-5], "cage_stiffness": [1e4, 1e5],
                        "drive": ["free", "constant"]})
    axes = plan.study_axes(cfg)
    assert list(axes)[:4] == list(BASE_AXES)
    order = list(registry())
    assert list(axes)[4:] == sorted(list(axes)[4:], key=order.index)
    assert axes["model.cage_stiffness"] == [1e4, 1e5] and axes["model.drive"] == ["free",
                                                                                  "constant"]
    assert plan.grid_size(axes) == 3 * 3 * 3 * 3 * 2 * 2 * 2


# --- file names -----------------------------------------------------------------------------

def test_file_names_carry_no_float_noise_and_are_unique_for_any_key():
    noisy = {"model.clearance": 4e-4, "model.mu": 0.30000000000000004,
             "model.omega0": 50.00000000000001, "model.e_N": 0.9}
    assert run_name(noisy) == "clearance~0.0004_mu~0.3_omega0~50.0_e_N~0.9"
    cfg = _study(sweep={"cage_stiffness": [1e4, 1e5], "drive": ["free", "constant"],
                        "n_balls": [8, 9], "analysis.r_eff": ["concave", "paper"]})
    names = [run_name(p) for p in plan.grid(plan.study_axes(cfg))]
    assert len(set(names)) == len(names)
    assert all(set(n) <= set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789"
                             "._~+-%") for n in names)
    assert "cage_stiffness~100000.0" in names[-1] and "n_balls~9" in names[-1]


def test_a_sweep_key_with_dots_can_be_set_from_the_command_line():
    cfg = simcore.load_config(overrides=["sweep.model.cage_stiffness=[1.0e+4, 1.0e+5]"])
    assert cfg["sweep"] == {"model.cage_stiffness": [1e4, 1e5]}


def test_a_long_name_is_shortened_and_stays_unique():
    params = [k for k, p in registry().items() if p.kind == "number" and k.startswith("model")]
    point_a = {key: 1.0 + i for i, key in enumerate(params)}
    point_b = dict(point_a, **{params[-1]: 99.0})
    a, b = run_name(point_a), run_name(point_b)
    assert len(a) <= MAX_NAME and len(b) <= MAX_NAME and a != b


def test_every_axis_has_a_long_name_short_enough_for_a_figure_label():
    """An axis' long_name labels the study's figures and its coordinates (CF): a title in the
    schema where the description is long, each distinct, none a paragraph."""
    names = {key: p.long_name for key, p in registry().items()}
    assert all(0 < len(name) <= 50 for name in names.values()), {
        key: name for key, name in names.items() if not 0 < len(name) <= 50}
    assert len(set(names.values())) == len(names)


# --- coordinates of the files ---------------------------------------------------------------

def test_category_coordinates_are_codes_that_combine_by_coords(tmp_path):
    from simcore.io import parameter_coords

    files = []
    for i, drive in enumerate(["free", "constant"]):
        coords = parameter_coords({"model.drive": drive, "cage_stiffness": 1e5,
                                   "model.contact_model": "compliant"})
        ds = xr.Dataset({"x": ("t", np.arange(3.0) + i)}, coords=coords)
        files.append(tmp_path / f"{i}.nc")
        simcore.write_netcdf(ds, files[-1])
    with xr.open_mfdataset(files, combine="by_coords", data_vars="all") as both:
        assert list(both["drive"].values) == [0, 1]
        assert both["drive"].attrs["flag_meanings"] == "free constant"
        assert both["drive"].dtype == np.int8
        assert both["cage_stiffness"].attrs["units"] == "N m-1"
        assert int(both["model"].values[0]) == 1
        np.testing.assert_array_equal(both["x"].sel(drive=1).squeeze(), [1.0, 2.0, 3.0])


# --- the runs of a study --------------------------------------------------------------------

def test_the_compliant_twin_resolves_the_hertz_contact_and_samples_the_nonsmooth_steps():
    cfg = _study()
    runs = plan.plan_runs(cfg)
    assert len(runs) == 81 * 2
    for ns, twin in zip(runs[::2], runs[1::2], strict=True):
        assert (ns.model, twin.model) == ("nonsmooth", "compliant") and ns.name == twin.name
        a, b = ns.config, twin.config
        assert b["model"]["contact_model"] == "compliant"
        assert {k: v for k, v in a["model"].items() if k != "contact_model"} == \
            {k: v for k, v in b["model"].items() if k != "contact_model"}
        assert b["solver"]["t_end"] == a["solver"]["t_end"]
        assert b["solver"]["output_dt"] == a["solver"]["dt"]
        per_output = b["solver"]["output_dt"] / b["solver"]["dt"]
        assert abs(per_output - round(per_output)) < 1e-9
        n = cfg["analysis"]["zoom_steps_per_contact"]
        t_contact = hertz_contact_time(b["model"])
        assert t_contact / (n + 1) < b["solver"]["dt"] <= t_contact / n * (1 + 1e-12) or \
            b["solver"]["dt"] == a["solver"]["dt"]
        # the run lasts (settle + revolutions) turns at its speed, whole steps
        turns = (cfg["analysis"]["settle"] + cfg["study"]["revolutions"])
        t_turns = turns * 2 * math.pi / a["model"]["omega0"]
        assert t_turns <= a["solver"]["t_end"] < t_turns + a["solver"]["dt"] * (1 + 1e-9)


def test_the_twin_writes_a_smaller_set_of_variables():
    from simcore.io import DEFAULT_KEEP

    run = plan.plan_runs(_study())[1]
    keep = run.keep(DEFAULT_KEEP)
    # the restart velocities only a zoom reads are left out; the positions its life reads stay
    assert "F_N" in keep and "Lambda_N" in keep and "position" in keep and "angle" in keep
    assert "velocity" not in keep and "angular_velocity" not in keep and "vn_free" not in keep


def test_estimate_grows_with_the_steps_of_each_model():
    cfg = _study()
    run = plan.plan_runs(cfg)[0].config
    longer = copy.deepcopy(run)
    longer["solver"]["t_end"] = 2 * run["solver"]["t_end"]
    steps = run["solver"]["t_end"] / run["solver"]["dt"]
    delta = plan.estimate_seconds(longer) - plan.estimate_seconds(run)
    assert delta == pytest.approx(steps * plan.COST.nonsmooth_step)
    twin = plan.twin_config(run)
    assert plan.estimate_seconds(twin) > plan.estimate_seconds(run)  # 200 steps per output


def test_point_estimates_add_up_to_the_planned_runs():
    cfg = _study()
    axes = plan.study_axes(cfg)
    runs = plan.plan_runs(cfg, axes)
    total = sum(plan.point_seconds(cfg, p, cfg["study"]["models"]) for p in plan.grid(axes))
    assert total == pytest.approx(sum(run.seconds for run in runs), rel=1e-12)


@pytest.mark.parametrize("batch_seconds", [0.5, 5.0, 30.0, 1e4])
def test_batches_hold_every_run_once_with_nearly_equal_work(batch_seconds):
    runs = plan.plan_runs(_study())
    jobs = plan.batches(runs, batch_seconds)
    members = [id(run) for job in jobs for run in job]
    assert sorted(members) == sorted(id(run) for run in runs)
    total = sum(run.seconds for run in runs)
    assert len(jobs) == min(len(runs), max(math.ceil(total / batch_seconds), plan.MIN_JOBS))
    loads = [sum(run.seconds for run in job) for job in jobs]
    # greedy longest-first: no job exceeds the mean by more than the longest run
    assert max(loads) <= total / len(jobs) + max(run.seconds for run in runs) + 1e-9
    assert loads == sorted(loads, reverse=True)


def test_a_study_larger_than_max_runs_stops_with_its_count_and_estimate():
    cfg = _study("study.max_runs=11", sweep={"clearance": [1e-4, 2e-4, 3e-4], "mu": [0.0, 0.01],
                                             "omega0": [50.0], "e_N": [0.9]})
    axes = plan.study_axes(cfg)
    with pytest.raises(simcore.ConfigError) as err:
        plan.check_size(cfg, axes, cores=2)
    text = str(err.value)
    assert text.startswith("study.max_runs: ") and "= 12 runs" in text and "estimated" in text
    assert "at most study.max_runs = 11" in text and "\n" not in text
    cfg["study"]["max_runs"] = 12
    assert "= 12 runs" in plan.check_size(cfg, axes, cores=2)


def test_the_size_line_counts_the_summary_and_figures_after_the_runs():
    """The jobs after the simulations: the summary (a start and each run), then the grid's
    figures (a pairs figure per quantity from three swept axes: 3 pairs of 3 axes, 6 of 4)
    beside the reference run's on a second core, one after the other on one core."""
    cost = plan.Cost(summary_job=1.0, summary_per_run=0.5, grid_figures=3.0, per_axis_pair=2.0,
                     reference_figures=10.0)
    assert plan.downstream_seconds(4, 2, 2, cost) == 1.0 + 2.0 + 10.0
    assert plan.downstream_seconds(4, 2, 1, cost) == 1.0 + 2.0 + 3.0 + 10.0
    assert plan.downstream_seconds(4, 3, 2, cost) == 1.0 + 2.0 + max(3.0 + 3 * 2.0, 10.0)
    assert plan.downstream_seconds(4, 4, 2, cost) == 1.0 + 2.0 + 3.0 + 6 * 2.0
    # only axes with more than one value are swept: omega0 and e_N hold one here
    cfg = _study(sweep={"clearance": [1e-4, 2e-4], "mu": [0.0, 0.01], "omega0": [50.0],
                        "e_N": [0.9]})
    _, line = plan.size_line(cfg, plan.study_axes(cfg), 2, cost)
    assert line.endswith(f"then {plan.duration(1.0 + 8 * 0.5 + 10.0)} for the summary and "
                         "figures"), line


def test_every_run_is_checked_before_any_job():
    cfg = _study("model.cage_damping=0.0", sweep={"cage_stiffness": [1e5, 1e9]})
    with pytest.raises(simcore.ConfigError) as err:
        plan.check_runs(plan.plan_runs(cfg))
    assert "cage_stiffness=1000000000.0" in str(err.value) and "solver.dt" in str(err.value)


def test_a_swept_key_the_twins_set_themselves_is_named():
    """Swept solver.rho_inf: the twins take analysis.twin_rho_inf whatever its value, so their
    points along that axis are one run; the plan says so, and not where they follow it."""
    sweep = {"solver.rho_inf": [0.0, 0.5]}
    runs = plan.plan_runs(_study(sweep=sweep))
    twins = [r for r in runs if r.model == "compliant"]
    assert {r.config["solver"]["rho_inf"] for r in twins} == {0.5}  # one run, twice
    messages = [m for m in plan.check_runs(runs) if m.startswith("sweep.solver.rho_inf")]
    assert len(messages) == 1 and "analysis.twin_rho_inf: null" in messages[0], messages
    follow = plan.plan_runs(_study("analysis.twin_rho_inf=null", sweep=sweep))
    assert {r.config["solver"]["rho_inf"] for r in follow if r.model == "compliant"} == {0.0, 0.5}
    assert not [m for m in plan.check_runs(follow) if m.startswith("sweep.")]


def test_a_swept_key_no_run_reads_is_named():
    """A setting only the summary reads makes identical runs along its axis, as does a twin
    setting for the nonsmooth runs: the plan says so, naming the models; a swept setting the
    runs read (analysis.settle) is not named."""
    sweep = {"analysis.life_load_rating": [2e4, 3e4], "analysis.twin_rho_inf": [0.5, 0.6],
             "analysis.settle": [0.5, 1.0]}
    messages = [m for m in plan.check_runs(plan.plan_runs(_study(sweep=sweep)))
                if m.startswith("sweep.")]
    assert sorted(m.split(":")[0] + " " + m.split()[2] for m in messages) == [
        "sweep.analysis.life_load_rating compliant", "sweep.analysis.life_load_rating nonsmooth",
        "sweep.analysis.twin_rho_inf nonsmooth"], messages
    assert all("one run, made once per value" in m for m in messages)


# --- skipping what is done ------------------------------------------------------------------

def test_a_run_is_finished_only_when_both_files_carry_its_fingerprint(tmp_path):
    from simcore.study.repair import finished, repair_outputs

    cfg = _study()
    run = plan.plan_runs(cfg)[0]
    keep = run.keep(cfg["study"]["keep"])
    axes = plan.study_axes(cfg)
    print_ = plan.fingerprint(run, keep, axes)
    other = copy.deepcopy(run)
    other.config["solver"]["tol"] = 2e-5
    assert plan.fingerprint(other, keep, axes) != print_
    paths = [tmp_path / "run.nc", tmp_path / "table.nc"]
    assert not finished(*paths, print_)
    for path in paths:
        simcore.write_netcdf(xr.Dataset(attrs={"study_fingerprint": print_}), path)
    assert finished(*paths, print_) and not finished(*paths, plan.fingerprint(other, keep, axes))
    marker = tmp_path / "b0001.json"
    marker.write_text("{}")
    paths[1].unlink()
    lines = repair_outputs([paths[0]], [paths[1]], tmp_path / "summary.nc",
                           batches={marker: paths})
    assert not marker.exists() and any("b0001.json" in line for line in lines)


def test_settings_no_run_file_reads_leave_the_fingerprint_as_it_is():
    """A twin's settings (its configuration holds what they set) and the settings only the
    summary reads do not make a run again; a setting of the impact table
    (analysis.method_tol) does."""
    cfg = _study()
    keep, axes = cfg["study"]["keep"], plan.study_axes(cfg)
    for run in plan.plan_runs(cfg)[:2]:
        base = plan.fingerprint(run, keep, axes)
        for key, value in (("twin_rho_inf", 0.9), ("twin_tol_clearance", 1e-3),
                           ("force_levels", [1.0]), ("life_load_rating", 1e4),
                           ("life_conformity", [0.51, 0.54])):
            other = copy.deepcopy(run)
            other.config["analysis"][key] = value
            assert plan.fingerprint(other, keep, axes) == base, key
        other = copy.deepcopy(run)
        other.config["analysis"]["method_tol"] = 0.3
        assert plan.fingerprint(other, keep, axes) != base
    twins = plan.plan_runs(_study("analysis.twin_rho_inf=0.9"))
    assert {r.model for r in twins} == {"nonsmooth", "compliant"}
    for before, after in zip(plan.plan_runs(cfg), twins, strict=True):
        same = plan.fingerprint(before, keep, axes) == plan.fingerprint(after, keep, axes)
        assert same == (before.model == "nonsmooth"), before.model  # the twin's rho_inf moved


def test_a_run_made_by_other_code_is_not_finished(monkeypatch):
    """The fingerprint holds the digest of the code that makes the files: a run made before an
    edit of the model or the analysis is made again."""
    cfg = _study()
    run = plan.plan_runs(cfg)[0]
    keep, axes = run.keep(cfg["study"]["keep"]), plan.study_axes(cfg)
    print_ = plan.fingerprint(run, keep, axes)
    monkeypatch.setattr(plan, "code_digest", lambda: "another code")
    assert plan.fingerprint(run, keep, axes) != print_


@pytest.fixture
def digest_cache(tmp_path, monkeypatch):
    """The digest cache of these tests, in their own folder: the installation's stays as it is."""
    cache = tmp_path / "cache" / "digests.json"
    monkeypatch.setattr(plan, "DIGEST_CACHE", cache)
    return cache


def test_the_code_digest_follows_the_sources_that_make_a_run(tmp_path, digest_cache):
    """Every module of simcore and analysis counts, but for those that make no number of a
    run's files (the start-up patches, the command lines, the figures); this installation's
    own tree is among those digested."""
    for name in ("simcore/model/hertz.py", "simcore/startup/patches.py", "analysis/impacts.py",
                 "analysis/figures.py"):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text("x = 1\n")
    before = plan.source_digest(tmp_path)
    for name, counts in (("simcore/model/hertz.py", True), ("analysis/impacts.py", True),
                         ("simcore/startup/patches.py", False), ("analysis/figures.py", False)):
        (tmp_path / name).write_text("x = 2\n")
        assert (plan.source_digest(tmp_path) != before) == counts, name
        before = plan.source_digest(tmp_path)
    (tmp_path / "simcore" / "model" / "bearing.py").write_text("")  # a new module counts
    assert plan.source_digest(tmp_path) != before
    root = Path(plan.__file__).resolve().parents[2]
    assert plan.code_digest() == plan.source_digest(root) != plan.source_digest(tmp_path)


@pytest.mark.parametrize("twin_rho", ["0.5", "0.8", "null"])
def test_the_twin_takes_its_own_spectral_radius_or_the_runs(twin_rho):
    cfg = _study("solver.rho_inf=0.2", f"analysis.twin_rho_inf={twin_rho}")
    run = plan.plan_runs(cfg)[0].config
    twin = plan.twin_config(run)
    assert run["solver"]["rho_inf"] == 0.2  # the nonsmooth run keeps its own
    assert twin["solver"]["rho_inf"] == (0.2 if twin_rho == "null" else float(twin_rho))


@pytest.mark.parametrize("per_clearance", ["null", "0", "5e-5"])
def test_the_twins_tolerance_grows_with_the_clearance_above_the_solvers(per_clearance):
    cfg = _study("sweep.clearance=[2e-5, 4e-4]", "solver.adaptive_tol=1.5e-9",
                 f"analysis.twin_tol_clearance={per_clearance}")
    twin_clearances = set()
    for run in plan.plan_runs(cfg):
        if run.model != "compliant":
            assert run.config["solver"]["adaptive_tol"] == 1.5e-9  # (a nonsmooth run's own)
            continue
        clearance = run.config["model"]["clearance"]
        twin_clearances.add(clearance)
        share = 0.0 if per_clearance == "null" else float(per_clearance)
        # 5e-5 of 2e-5 m is 1e-9 m, below the solver's 1.5e-9 m; of 4e-4 m, 2e-8 m
        expected = 2e-8 if share and clearance == 4e-4 else 1.5e-9
        assert run.config["solver"]["adaptive_tol"] == pytest.approx(expected, rel=1e-12)
    assert twin_clearances == {2e-5, 4e-4}  # both clearances' twins were checked


def test_the_twin_takes_error_controlled_steps_at_most_the_output_step():
    run = plan.plan_runs(_study())[0].config
    twin = plan.twin_config(run)
    assert twin["solver"]["adaptive"] is True
    assert twin["solver"]["dt"] == twin["solver"]["output_dt"] == run["solver"]["dt"]
    fixed = plan.twin_step(twin["model"], twin["analysis"], run["solver"]["dt"])
    steps = run["solver"]["t_end"] / fixed
    cost = plan.COST
    assert plan.estimate_seconds(twin) == pytest.approx(
        cost.per_run + cost.adaptive_share * steps * cost.compliant_step, rel=1e-12)
    # the point's estimate before its runs are planned is the sum of its runs' estimates
    point = plan.plan_runs(_study())[0].point
    assert plan.point_seconds(_study(), point, ["nonsmooth", "compliant"]) == pytest.approx(
        plan.estimate_seconds(run) + plan.estimate_seconds(twin), rel=1e-12)


def test_a_swept_clearance_class_replaces_the_clearance_axis_even_beside_a_clearance_list():
    """The default study's clearance list (merged under a smaller file) is not an axis beside a
    swept class; each run's clearance is its class's (half the ISO 5753-1 middle for the bore)."""
    from simcore.model.bearing import resolve_model

    cfg = _study("model.bearing=6012", sweep={"model.clearance_class": ["CN", "C3", "C4"]})
    assert len(cfg["sweep"]["clearance"]) > 1  # the default study's list is still there
    axes = plan.study_axes(cfg)
    assert "model.clearance" not in axes and axes["model.clearance_class"] == ["CN", "C3", "C4"]
    runs = [run for run in plan.plan_runs(cfg) if run.model == "nonsmooth"]
    assert len(runs) == 3 * math.prod(len(v) for k, v in axes.items()
                                      if k != "model.clearance_class")
    by_class = {}
    for run in runs:
        model = run.config["model"]
        by_class.setdefault(model["clearance_class"], set()).add(model["clearance"])
    for name, clearances in by_class.items():
        alone = dict(cfg["model"], clearance_class=name)
        assert clearances == {resolve_model(alone, alone.keys())["clearance"]}
    (cn,), (c3,), (c4,) = by_class["CN"], by_class["C3"], by_class["C4"]
    assert cn < c3 < c4


def test_a_fixed_clearance_class_replaces_a_swept_clearance_list():
    """With the class set but not swept, each run's clearance is the class's (validate_config
    sets it): a clearance list beside would label every point with a value it did not run at,
    so the clearance axis holds the class's clearance alone, and each run's configuration and
    label agree with it."""
    from simcore.model.bearing import resolve_model

    cfg = _study("model.bearing=6012", "model.clearance_class=C3")
    assert len(cfg["sweep"]["clearance"]) > 1  # the default study's list is still there
    alone = dict(cfg["model"])
    c3 = resolve_model(alone, alone.keys())["clearance"]
    axes = plan.study_axes(cfg)
    assert axes["model.clearance"] == [c3]
    for run in plan.plan_runs(cfg):
        assert run.point["model.clearance"] == c3
        # as the simulate job sees it, after validating the run's configuration again
        assert simcore.validate_config(run.config)["model"]["clearance"] == c3


def test_a_results_folder_is_refused_where_the_study_would_harm_or_fail(tmp_path):
    """study.results_dir: no wildcard braces, no file on its path, and a figures/ folder (which
    the study replaces as a whole) with only what a study's figures job writes."""
    for folder in ("results/{x}", "a}b"):
        with pytest.raises(simcore.ConfigError, match=r"^study\.results_dir: .*\{ and \}"):
            plan.check_results_dir(folder)
    (tmp_path / "file").write_text("")
    with pytest.raises(simcore.ConfigError, match=r"^study\.results_dir: .* is a file"):
        plan.check_results_dir(str(tmp_path / "file" / "results"))
    figures = tmp_path / "res" / "figures"
    figures.mkdir(parents=True)
    plan.check_results_dir(str(tmp_path / "res"))
    (figures / "study_mu.png").write_text("")
    (figures / "summary_table.csv").write_text("")
    plan.check_results_dir(str(tmp_path / "res"))  # its own figures: replaced on a re-run
    for foreign in ("a_notes.txt", "study_mu.pdf", "sub"):
        path = figures / foreign
        path.mkdir() if foreign == "sub" else path.write_text("")
        with pytest.raises(simcore.ConfigError) as err:
            plan.check_results_dir(str(tmp_path / "res"))
        assert str(err.value).startswith(f"study.results_dir: '{tmp_path / 'res'}' is not "
                                         "allowed") and f"{path} is not" in str(err.value)
        path.rmdir() if foreign == "sub" else path.unlink()
    (figures / "reference_x.png").symlink_to(tmp_path / "file")
    with pytest.raises(simcore.ConfigError, match="reference_x.png is not"):
        plan.check_results_dir(str(tmp_path / "res"))


@pytest.mark.parametrize("files, command_line, warned", [
    (["config/smoke.yaml"], {"model": {"clearance_class": "C3"}},
     ["sweep.clearance = [0.0001, 0.0004] is given and replaced by model.clearance_class = "
      "'C3' (1.65e-05 m for bearing '6012-paper')"]),
    (["config/smoke.yaml"], {"model": {"clearance": "1e-4"},
                             "sweep": {"clearance_class": ["CN", "C3"]}},
     ["model.clearance = 0.0001 is given and replaced by sweep.clearance_class (each run "
      "takes its class's clearance", "sweep.clearance = [0.0001, 0.0004] is given"]),
    # the base settings' clearance and list, merged under the study's own file: not given
    (["config/smoke_bearings.yaml"], {}, []),
    ([], {"model": {"clearance_class": "C3"}}, []),
])
def test_a_clearance_the_user_gives_beside_a_clearance_class_is_named(files, command_line,
                                                                      warned):
    """A clearance class sets each run's clearance: a model.clearance or a clearance list the
    study's files or command line give beside it (not the base config/config.yaml's) is
    named in a warning line with the class's key, before any job."""
    from simcore.config import read_study_config, replaced_clearance

    given = read_study_config(["config/config.yaml", *files], command_line)
    full = simcore.validate_config(given)
    lines = replaced_clearance(given, full, base=read_study_config(["config/config.yaml"]))
    assert len(lines) == len(warned), lines
    for line, start in zip(lines, warned, strict=True):
        assert line.startswith(start) and line.endswith("; leave one of them out"), line


def test_a_study_without_nonsmooth_runs_is_refused_naming_the_key():
    """The twins and the reference run's figures are made from the nonsmooth runs: a study of
    compliant runs alone stops before any job; the order of the models does not matter."""
    with pytest.raises(simcore.ConfigError, match=r"^study\.models: \['compliant'\] is not"):
        plan.study_axes(_study("study.models=[compliant]"))
    runs = plan.plan_runs(_study("study.models=[compliant, nonsmooth]"))
    assert {run.model for run in runs} == {"nonsmooth", "compliant"}


def test_a_study_whose_runs_end_in_their_start_up_is_refused():
    """With study.revolutions null and a constant drive, a run of 0.05 s at 100 rad/s turns
    0.8 revolutions, not more than analysis.settle (1): its summary would hold nothing steady,
    so the study stops before any job, naming the keys."""
    cfg = _study("study.revolutions=null", "solver.t_end=0.05", sweep={"omega0": [100.0]})
    with pytest.raises(simcore.ConfigError, match=r"solver\.t_end: 0\.05 s is 0\.796 crank "
                                                   r"revolutions, not more than analysis\.settle"):
        plan.check_runs(plan.plan_runs(cfg))
    longer = _study("study.revolutions=null", "solver.t_end=0.07", sweep={"omega0": [100.0]})
    plan.check_runs(plan.plan_runs(longer))  # (1.11 revolutions)


def test_figure_settings_are_checked_on_the_grid_before_any_job():
    """study.figure_axes naming only axes of one value, or an axis both drawn and held, is
    refused naming the key; otherwise the swept named axes come back in order."""
    sizes = {"clearance": 2, "mu": 2, "omega0": 1, "e_N": 1}
    assert plan.check_figure_settings(sizes, ["mu", "omega0", "clearance"]) == ["mu",
                                                                                "clearance"]
    assert plan.check_figure_settings(sizes) == []
    with pytest.raises(simcore.ConfigError, match=r"^study\.figure_axes: .*more than one value"):
        plan.check_figure_settings(sizes, ["omega0", "e_N"])
    with pytest.raises(simcore.ConfigError, match=r"^study\.figure_axes: .*study\.figure_fixed"):
        plan.check_figure_settings(sizes, ["clearance", "mu"], {"mu": 0.0})
    with pytest.raises(simcore.ConfigError, match=r"^study\.figure_axes: 'speed' is not"):
        plan.check_figure_settings(sizes, ["speed"])


def test_the_sweep_of_config_readme_is_a_valid_grid():
    """The example ``sweep:`` block of config/README.md, as a user would paste it over the
    default study's: it validates and plans one run per grid point and model."""
    import re

    import yaml

    text = (Path(__file__).resolve().parents[1] / "config" / "README.md").read_text()
    example = yaml.safe_load(re.search(r"```yaml\n(.*?)```", text, re.S).group(1))["sweep"]
    cfg = simcore.load_config("config/config.yaml")
    cfg["sweep"] = example
    runs = plan.plan_runs(simcore.validate_config(cfg))
    points = math.prod(len(values) for values in example.values())
    assert len(runs) == points * len(cfg["study"]["models"])
    assert set(runs[0].point) == {f"model.{key}" if key in ("clearance", "mu") else key
                                  for key in example} | {"model.omega0", "model.e_N"}


MODULE = b'''"""A module."""
import math

#: a constant
SCALE = 2.0


def area(r):
    """The area [m^2] of a disc of radius r [m]."""
    return math.pi * r ** 2 * SCALE  # why: both faces
'''


def _digest_of(tmp_path, source: bytes) -> str:
    (tmp_path / "simcore").mkdir(exist_ok=True)
    (tmp_path / "simcore" / "geometry.py").write_bytes(source)
    return plan.source_digest(tmp_path)


@pytest.mark.parametrize("edit, same", [
    ((b'"""A module."""', b'"""Another module."""'), True),
    ((b"The area [m^2]", b"The area of both faces [m^2]"), True),
    ((b"# why: both faces", b"# two faces"), True),
    ((b"#: a constant\n", b""), True),
    ((b"return math.pi", b"return  math.pi"), True),
    ((b"\n\n\ndef area", b"\n\ndef area"), True),
    ((b"SCALE = 2.0", b"SCALE = 2.5"), False),
    ((b"r ** 2", b"r ** 3"), False),
    ((b"import math\n", b"import math\nNAME = 'disc'\n"), False),
])
def test_the_code_digest_ignores_comments_docstrings_and_layout(tmp_path, digest_cache, edit,
                                                               same):
    """An edit of what a module says about itself (comments, docstrings, blank lines, spaces)
    keeps the digest, so a study is not made again for it; an edit of what it computes, or a
    string that is not a docstring, changes it."""
    before = _digest_of(tmp_path, MODULE)
    assert MODULE.count(edit[0]) == 1
    assert (_digest_of(tmp_path, MODULE.replace(*edit)) == before) == same


def test_the_code_digest_cache_gives_what_parsing_gives(tmp_path, monkeypatch, digest_cache):
    """The digest looked up in the cache equals the one computed without it; a cache that is
    missing, unreadable or of other sources is computed again, not trusted."""
    cache = digest_cache
    fresh = _digest_of(tmp_path, MODULE)
    assert cache.exists() and list(json.loads(cache.read_text()).values()) == [fresh]
    with monkeypatch.context() as m:  # the same sources again: looked up, not parsed
        m.setattr(plan, "code_text", lambda *_: pytest.fail("parsed again"))
        assert _digest_of(tmp_path, MODULE) == fresh
    cache.write_text("{not json")
    assert _digest_of(tmp_path, MODULE) == fresh
    other = _digest_of(tmp_path, MODULE.replace(b"2.0", b"3.0"))
    assert other != fresh and _digest_of(tmp_path, MODULE) == fresh
    assert len(json.loads(cache.read_text())) == 2
