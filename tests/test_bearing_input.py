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
    cfg = load_config(overrides=[f"model.clearance_class={clearance_class}",
                                 "model.clearance=0.001"])  # the class wins
    assert cfg["model"]["clearance"] == pytest.approx(0.5 * 0.5 * (lo + hi) * 1e-6, rel=1e-12)


def test_a_class_missing_from_the_table_and_an_unknown_entry_are_refused():
    with pytest.raises(ConfigError, match=r"^model\.clearance_class: C5 is not available"):
        load_config(overrides=["model.clearance_class=C5"])  # the table's cell is left out
    with pytest.raises(ConfigError, match=r"^model\.clearance_class: 'C7' is not allowed"):
        load_config(overrides=["model.clearance_class=C7"])
    with pytest.raises(ConfigError, match=r"^model\.bearing: 'x' is not allowed; allowed: "):
        load_config(overrides=["model.bearing=x"])
    with pytest.raises(ConfigError, match=r"^model\.bearing: '6205' has no D_w"):
        load_config(overrides=["model.bearing=6205"])  # YAML's number 6205 names the entry


def test_explicit_values_win_and_stand_in_for_what_an_entry_lacks():
    cfg = load_config(overrides=["model.bearing=6205", "model.ball_radius=0.004",
                                 "model.n_balls=9", "model.clearance_class=CN"])["model"]
    d_w = 0.008
    assert cfg["ball_radius"] == 0.004 and cfg["n_balls"] == 9
    assert cfg["inner_radius"] == pytest.approx(0.5 * (38.5e-3 - d_w))  # the entry's D_pw
    mass = 7850.0 * math.pi * d_w**3 / 6.0  # a steel ball of the explicit diameter
    assert cfg["ball_mass"] == pytest.approx(mass) and cfg["ball_inertia"] == pytest.approx(
        mass * d_w**2 / 10.0)
    lo, hi = _row(25.0)["CN"]
    assert cfg["clearance"] == pytest.approx(0.25 * (lo + hi) * 1e-6)
    # the paper's masses stay where the entry gives none
    assert cfg["inner_mass"] == 8e-3 and cfg["outer_inertia"] == 6.523e-6


def test_resolve_model_is_what_a_study_applies_per_grid_point():
    base = load_config()["model"]
    point = dict(base, clearance_class="C4")
    resolved = resolve_model(point, explicit=base.keys())
    assert resolved["clearance"] == load_config(
        overrides=["model.clearance_class=C4"])["model"]["clearance"]
    assert point["clearance"] == base["clearance"]  # the input is not changed


def test_another_catalogue_bearing_runs_the_papers_case():
    cfg = load_config(overrides=["model.bearing=6205", "model.ball_radius=0.004",
                                 "model.n_balls=9", "model.clearance_class=C3",
                                 "solver.t_end=0.01"])
    ds = simcore.run(cfg)
    assert int(ds["converged"].min()) == 1 and ds.attrs["integrity_violations"] == "none"
    assert ds.attrs["model.bearing"] == "6205" and ds.sizes["contact"] == 18
    assert ds.attrs["outer_radius"] == pytest.approx(
        cfg["model"]["inner_radius"] + 0.008 + cfg["model"]["clearance"], rel=1e-12)


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
