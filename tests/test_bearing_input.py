"""A bearing from its data: ``model.bearing`` (a catalogue entry) and ``model.clearance_class``
(ISO 5753-1) resolved into the model's radii, masses and clearance, explicit values winning;
the bearing's geometry from one place."""

from __future__ import annotations

import math
from importlib import resources

import numpy as np
import pytest
import yaml

import simcore
from simcore.config import ConfigError, load_config, load_schema
from simcore.model import bearing as bearing_module
from simcore.model.bearing import BearingGeometry, resolve_model
from simcore.model.mechanism import crank_slider


def _row(bore_mm):
    """The ISO 5753-1 row of a bore, read from the data file here."""
    rows = yaml.safe_load(resources.files("simcore").joinpath(
        "data", "clearance_iso5753.yaml").read_text())["rows"]
    return next(r for r in rows if r["over"] < bore_mm <= r["incl"])


def test_the_paper_bearing_is_the_default_model_to_the_bit():
    defaults = {k: v["default"] for k, v in load_schema()["properties"]["model"]["properties"]
                .items() if "default" in v}
    resolved = load_config()["model"]
    assert resolved["bearing"] == "6012-paper"
    for key, value in defaults.items():
        assert resolved[key] == value, key  # the entry's values are the defaults exactly
    explicit = load_config(overrides=["model.bearing=6012-paper"])["model"]
    assert explicit == resolved


@pytest.mark.parametrize("clearance_class", ["C2", "CN", "C3", "C4"])
def test_clearance_class_is_half_the_middle_of_its_iso_range(clearance_class):
    lo, hi = _row(60.0)[clearance_class]  # the paper's 6012 has a 60 mm bore
    with pytest.warns(UserWarning, match=r"model\.clearance = 0\.001 is given and replaced by "
                      f"model\\.clearance_class = '{clearance_class}'"):
        cfg = load_config(overrides=[f"model.clearance_class={clearance_class}",
                                     "model.clearance=0.001"])  # the class wins, said
    assert cfg["model"]["clearance"] == pytest.approx(0.5 * 0.5 * (lo + hi) * 1e-6, rel=1e-12)


def test_unknown_classes_and_entries_and_an_entry_without_its_balls_are_refused(monkeypatch):
    with pytest.raises(ConfigError, match=r"^model\.clearance_class: 'C7' is not allowed") as no:
        load_config(overrides=["model.clearance_class=C7"])
    # the allowed values as a YAML file or --set writes them: each one is accepted as written
    offered = str(no.value).split("allowed: one of ", 1)[1].split(", ")
    assert "null" in offered and "None" not in offered
    for value in offered:
        load_config(overrides=[f"model.clearance_class={value.strip(chr(39))}"])
    with pytest.raises(ConfigError, match=r"^model\.bearing: 'x' is not allowed; allowed: "):
        load_config(overrides=["model.bearing=x"])
    entries = dict(bearing_module.catalogue())
    entries["9999"] = dict(entries["6205"], D_w=None, Z=None,
                           sources=dict(entries["6205"]["sources"], D_w="none", Z="none"))
    monkeypatch.setattr(bearing_module, "catalogue", lambda: entries)
    with pytest.raises(ConfigError, match=r"^model\.bearing: '9999' has no D_w \(none\); "
                                          r"allowed: an entry with it, or model\.ball_radius"):
        load_config(overrides=["model.bearing=9999"])  # YAML's number 9999 names the entry
    cfg = load_config(overrides=["model.bearing=9999", "model.ball_radius=0.004",
                                 "model.n_balls=9"])["model"]
    assert cfg["inner_radius"] == pytest.approx(0.5 * entries["6205"]["D_pw"] * 1e-3 - 0.004)


def test_an_entry_and_its_class_and_explicit_values_winning():
    entry = bearing_module.catalogue()["6205"]
    cfg = load_config(overrides=["model.bearing=6205", "model.clearance_class=CN"])["model"]
    d_w, d_pw = entry["D_w"] * 1e-3, entry["D_pw"] * 1e-3
    assert cfg["ball_radius"] == 0.5 * d_w and cfg["n_balls"] == entry["Z"]
    assert cfg["inner_radius"] == pytest.approx(0.5 * (d_pw - d_w), rel=1e-14)
    mass = 7850.0 * math.pi * d_w**3 / 6.0  # a steel ball
    assert cfg["ball_mass"] == pytest.approx(mass) and cfg["ball_inertia"] == pytest.approx(
        mass * d_w**2 / 10.0)
    lo, hi = _row(entry["d"])["CN"]
    assert cfg["clearance"] == pytest.approx(0.25 * (lo + hi) * 1e-6)
    # the rings: the entry's own steel rings, not the paper's 8 g ones
    rings = bearing_module.ring_masses(entry, d_w)
    assert {key: cfg[key] for key in rings} == rings and rings["inner_mass"] > 0.04
    # an explicit ball: on the entry's pitch circle, a steel ball of its own size
    with pytest.warns(UserWarning, match="overrides") as caught:
        mine = load_config(overrides=["model.bearing=6205", "model.ball_radius=0.004",
                                      "model.n_balls=10"])["model"]
    assert sorted(str(w.message).split(" = ")[0] for w in caught) == [
        "model.ball_radius", "model.n_balls"]
    assert mine["n_balls"] == 10 and mine["ball_radius"] == 0.004
    assert mine["inner_radius"] == pytest.approx(0.5 * d_pw - 0.004, rel=1e-14)
    assert mine["ball_mass"] == pytest.approx(7850.0 * math.pi * 0.008**3 / 6.0)


def test_resolve_model_is_what_a_study_applies_per_grid_point():
    base = load_config()["model"]
    point = dict(base, clearance_class="C4")
    resolved = resolve_model(point, explicit=base.keys())
    assert resolved["clearance"] == load_config(
        overrides=["model.clearance_class=C4"])["model"]["clearance"]
    assert point["clearance"] == base["clearance"]  # the input is not changed


def test_a_bearing_sweep_gives_each_grid_point_its_bearing_and_its_class_clearance():
    """Bearings x clearance classes: each run has its entry's ball count and radii (read from
    the catalogue file here, not through the resolver) and the clearance of its class for its
    own bore (the ISO 5753-1 table read here); the clearance is not an axis, and the summary's
    shared model settings leave out what differs between the bearings."""
    from simcore.model.bearing import SET_BY_ENTRY
    from simcore.study import plan

    raw = yaml.safe_load(resources.files("simcore").joinpath("data", "bearings.yaml")
                         .read_text())
    cfg = simcore.validate_config({"sweep": {"bearing": ["6205", "6212"],
                                             "clearance_class": ["CN", "C4"]},
                                   "study": {"revolutions": 1.0}})
    axes = plan.study_axes(cfg)
    assert "model.clearance" not in axes
    assert axes["model.bearing"] == ["6205", "6212"]
    runs = plan.plan_runs(cfg, axes)
    assert len(runs) == 8
    seen = set()
    for run in runs:
        model = run.config["model"]
        entry = raw[model["bearing"]]
        lo, hi = _row(entry["d"])[model["clearance_class"]]
        assert model["n_balls"] == entry["Z"]
        assert model["ball_radius"] == pytest.approx(0.5e-3 * entry["D_w"], rel=1e-12)
        assert model["inner_radius"] == pytest.approx(0.5e-3 * (entry["D_pw"] - entry["D_w"]),
                                                      rel=1e-12)
        assert model["clearance"] == pytest.approx(0.25e-6 * (lo + hi), rel=1e-9)
        seen.add((model["bearing"], model["clearance_class"], run.model))
    assert len(seen) == 8 and raw["6205"]["Z"] != raw["6212"]["Z"]
    assert plan.check_runs(runs) == []
    shared = plan.shared_model(cfg, axes)
    assert not {"bearing", "clearance_class", "clearance", *SET_BY_ENTRY} & set(shared)
    assert shared["youngs_modulus"] == cfg["model"]["youngs_modulus"]


def test_a_bearing_sweep_with_one_class_gives_the_clearance_of_each_bearing():
    """A class set, bearings swept: the class's clearance differs by bore, so it is not the
    one-value clearance axis of a single bearing."""
    from simcore.study import plan

    cfg = simcore.validate_config({"model": {"clearance_class": "C3"},
                                   "sweep": {"bearing": ["6203", "6012"]}})
    axes = plan.study_axes(cfg)
    assert "model.clearance" not in axes
    assert plan.determiners(axes) == {"model.clearance": ("model.bearing",)}
    clearance = {run.config["model"]["bearing"]: run.config["model"]["clearance"]
                 for run in plan.plan_runs(cfg, axes)}
    for name, bore in (("6203", 17.0), ("6012", 60.0)):
        lo, hi = _row(bore)["C3"]
        assert clearance[name] == pytest.approx(0.25e-6 * (lo + hi), rel=1e-9)
    # without a class every bearing runs at each swept clearance
    free = simcore.validate_config({"sweep": {"bearing": ["6203", "6012"],
                                              "clearance": [1e-5, 2e-5]}})
    assert plan.study_axes(free)["model.clearance"] == [1e-5, 2e-5]
    assert plan.determiners(plan.study_axes(free)) == {}


@pytest.mark.parametrize("name", ["6012", "6205"])
def test_catalogue_bearings_run_the_papers_case(name):
    cfg = load_config(overrides=[f"model.bearing={name}", "model.clearance_class=C3",
                                 "solver.t_end=0.01"])
    ds = simcore.run(cfg)
    entry = bearing_module.catalogue()[name]
    assert int(ds["converged"].min()) == 1 and ds.attrs["integrity_violations"] == "none"
    assert ds.attrs["model.bearing"] == name and ds.sizes["contact"] == 2 * entry["Z"]
    assert ds.attrs["outer_radius"] == pytest.approx(
        cfg["model"]["inner_radius"] + entry["D_w"] * 1e-3 + cfg["model"]["clearance"],
        rel=1e-12)


def test_bearing_geometry_is_the_one_the_model_is_built_with():
    model = load_config(overrides=["model.n_balls=11", "model.clearance=1e-4"])["model"]
    geometry = BearingGeometry.from_model(model)
    m, layout = crank_slider(model)
    r_a, r_b, g = model["inner_radius"], model["ball_radius"], model["clearance"]
    assert geometry.outer_radius == layout.outer_radius == r_a + 2 * r_b + g
    assert geometry.pitch_radius == layout.pitch_radius == r_a + r_b + g / 2
    rest = [s[2][6] for s in m.springs]
    np.testing.assert_array_equal(rest, geometry.cage_chord)
    assert geometry.cage_chord == pytest.approx(2 * (r_a + r_b + g / 2) * np.sin(np.pi / 11))
    assert geometry.land_gap == pytest.approx(g + 2 * r_b * (1 - 2 * 0.2))
    # the most balls that fit: the largest n with a chord 2 R_p sin(pi / n) above 2 r_B
    fits = [n for n in range(3, 65) if 2 * (r_a + r_b + g / 2) * np.sin(np.pi / n) > 2 * r_b]
    assert geometry.max_balls() == max(fits) == 22
    assert BearingGeometry(r_a, r_b, g, 22).balls_fit()
    assert not BearingGeometry(r_a, r_b, g, 23).balls_fit()


def test_one_hertz_stiffness_for_the_model_and_the_analysis():
    from analysis import hertz_stiffness as analysis_stiffness
    from simcore.model.hertz import hertz_stiffness

    r_a, r_b, r_c, E, nu = 0.033745, 0.0055, 0.045145, 2.1e9, 0.3
    assert analysis_stiffness(r_b, r_a, E, nu, E, nu) == hertz_stiffness("outside", r_a, r_b, E,
                                                                         nu)
    assert analysis_stiffness(r_b, r_c, E, nu, E, nu, concave=True) == hertz_stiffness(
        "inside", r_c, r_b, E, nu)
    # the closed form, for two materials: K = 4 / (3 (s1 + s2)) sqrt(R), s = (1 - nu^2) / E
    K = analysis_stiffness(r_b, r_a, 2.1e11, 0.3, 7e10, 0.33)
    sigma = (1 - 0.3**2) / 2.1e11 + (1 - 0.33**2) / 7e10
    assert K == pytest.approx(4 / (3 * sigma) * math.sqrt(r_a * r_b / (r_a + r_b)), rel=1e-14)
