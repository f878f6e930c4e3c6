"""Bearing catalogue and ISO 5753-1 clearance classes: rows transcribed here from the cited
tables, the table's invariants, the catalogue's ratings against ISO 281 and ISO 76, the ball
counts against the published defect frequencies, the derivation of the ball sets that no source
gives, the steel rings against closed forms and the catalogue's bearing masses, the mapping of
an entry to the model, and the one-line refusals."""

import math

import numpy as np
import pytest

from simcore.config import load_config
from simcore.model.bearing import (
    CLEARANCE_CLASSES,
    ENTRY_KEYS,
    STEEL_DENSITY,
    catalogue,
    clearance_range,
    clearance_table,
    model_clearance,
    model_geometry,
    ring_masses,
)

# transcribed from NSK "Rolling Bearings" CAT. No. E1102e, table 9.9 (p. A89), micrometres:
# (bore [mm], class, min, max); the last four are cells that some web reproductions print
# differently
ROWS = [(60.0, "C3", 23, 43), (60.0, "CN", 8, 28), (25.0, "C4", 23, 41), (45.0, "C5", 45, 73),
        (12.0, "C2", 0, 9), (90.0, "C3", 30, 58), (40.0, "CN", 6, 20), (70.0, "C5", 65, 105),
        (20.0, "C3", 13, 28), (20.0, "C5", 28, 48), (60.0, "C5", 55, 90), (110.0, "C4", 61, 97)]

# ISO 281:2007, f_c of single-row radial ball bearings at D_w cos(alpha)/D_pw = 0.01 ... 0.40
# (the data file's reference [FC]); ISO 281's factor b_m of radial ball bearings
FC_GAMMA = np.arange(1, 41) * 0.01
FC = [29.1, 35.8, 40.3, 43.8, 46.7, 49.1, 51.1, 52.8, 54.3, 55.5, 56.6, 57.5, 58.2, 58.8, 59.3,
      59.6, 59.8, 59.9, 60.0, 59.9, 59.8, 59.6, 59.3, 59.0, 58.6, 58.2, 57.7, 57.1, 56.6, 56.0,
      55.3, 54.6, 53.9, 53.2, 52.4, 51.7, 50.9, 50.0, 49.2, 48.4]
B_M = 1.3
# Catalogue C and C0 carry three significant figures and f_0 one decimal (<= 0.5 % each); the
# f_c table three figures: a rating within 1 % of the formula agrees.
RATING_TOL = 0.01

# standard ball diameters [mm], 3/16 in to 18 mm, from NSK E1102e pp. B344-B345 (the data
# file's derivation searches them)
STANDARD_BALLS = [4.7625, 5.0, 5.5, 5.55625, 5.95312, 6.0, 6.35, 6.5, 6.74688, 7.0, 7.14375,
                  7.5, 7.9375, 8.0, 8.5, 8.73125, 9.0, 9.525, 10.0, 10.31875, 11.0, 11.1125,
                  11.5, 11.90625, 12.0, 12.7, 13.0, 13.49375, 14.0, 14.2875, 15.0, 15.08125,
                  15.875, 16.0, 16.66875, 17.0, 17.4625, 18.0]

# CWRU Bearing Data Center, bearing information: defect frequencies as multiples of the running
# speed (inner ring BPFI, outer ring BPFO, cage FTF) of its SKF 6205-2RS and 6203-2RS
CWRU_MULTIPLES = {"6205": (5.4152, 3.5848, 0.39828), "6203": (4.9469, 3.0530, 0.3817)}


def rated():
    """Names of the entries with a load rating."""
    return [n for n, e in catalogue().items() if e.get("C") is not None]


def iso281_c(z, d_w, d_pw):
    """ISO 281 basic dynamic radial load rating of a single-row radial ball bearing at contact
    angle 0, D_w <= 25.4 mm [N] (lengths in mm)."""
    return B_M * np.interp(d_w / d_pw, FC_GAMMA, FC) * z ** (2 / 3) * d_w**1.8


def ball_sets_fitting(entry):
    """Every (Z, D_w) of standard balls that fits on the pitch circle (d + D)/2 and gives the
    entry's C and C0 within RATING_TOL: the data file's derivation."""
    d_pw = 0.5 * (entry["d"] + entry["D"])
    return [(z, d_w) for d_w in STANDARD_BALLS for z in range(5, 30)
            if z * d_w < math.pi * d_pw
            and abs(iso281_c(z, d_w, d_pw) / entry["C"] - 1) < RATING_TOL
            and abs(entry["f_0"] * z * d_w**2 / entry["C0"] - 1) < RATING_TOL]


@pytest.mark.parametrize("bore, cls, lo, hi", ROWS)
def test_clearance_rows_from_the_cited_source(bore, cls, lo, hi):
    got = clearance_range(bore, cls)
    assert got[:2] == pytest.approx((lo * 1e-6, hi * 1e-6), rel=1e-12)
    assert got[2] == pytest.approx(0.5 * (lo + hi) * 1e-6, rel=1e-12)
    assert model_clearance(bore, cls) == pytest.approx(0.25 * (lo + hi) * 1e-6, rel=1e-12)


def test_clearance_table_invariants():
    """Rows join without gap or overlap; within a row min <= max and both grow from C2 to C5;
    from row to row (larger bores) every class's min and max do not shrink."""
    rows = clearance_table()
    for a, b in zip(rows, rows[1:], strict=False):
        assert a["incl"] == b["over"] and a["over"] < a["incl"]
    for row in rows:
        cells = [row[c] for c in CLEARANCE_CLASSES if row[c] is not None]
        for lo, hi in cells:
            assert 0 <= lo < hi
        for (lo1, hi1), (lo2, hi2) in zip(cells, cells[1:], strict=False):
            assert lo1 < lo2 and hi1 < hi2
    for cls in CLEARANCE_CLASSES:
        cells = [r[cls] for r in rows if r[cls] is not None]
        for (lo1, hi1), (lo2, hi2) in zip(cells, cells[1:], strict=False):
            assert lo1 <= lo2 and hi1 <= hi2


@pytest.mark.parametrize("name", ["bearings.yaml", "clearance_iso5753.yaml"])
def test_package_data_read_alike_by_both_yaml_parsers(name):
    """The data's reader (libyaml's parser where PyYAML has it) gives what PyYAML's pure-Python
    safe loader gives, value for value and in the same order."""
    from importlib import resources

    import yaml

    from simcore.model.bearing import DATA_LOADER, _data

    text = resources.files("simcore").joinpath("data", name).read_text()
    reference = yaml.load(text, Loader=yaml.SafeLoader)  # noqa: S506
    read = _data(name)
    assert read == reference and repr(read) == repr(reference)
    if getattr(yaml, "__with_libyaml__", False):
        assert DATA_LOADER is yaml.CSafeLoader


def test_clearance_refusals_name_the_key():
    with pytest.raises(ValueError, match="model.clearance_class: 'C7' is not allowed"):
        clearance_range(60.0, "C7")
    with pytest.raises(ValueError, match="model.clearance_class: C5 is not available"):
        clearance_range(5.0, "C5")
    with pytest.raises(ValueError, match="bore 500 mm is outside"):
        clearance_range(500.0, "CN")


def test_ratings_agree_with_iso281_and_iso76():
    """Every rated entry's C is ISO 281's C = b_m f_c Z^(2/3) D_w^1.8 and its C0 is
    f_0 Z D_w^2 within RATING_TOL: for 6203 and 6205 this checks CWRU's balls against NSK's
    ratings, two independent sources."""
    names = rated()
    assert {"6203", "6205", "6010", "6012", "6212"} <= set(names)
    for name in names:
        e = catalogue()[name]
        assert iso281_c(e["Z"], e["D_w"], e["D_pw"]) / e["C"] == pytest.approx(1, abs=RATING_TOL)
        assert e["f_0"] * e["Z"] * e["D_w"] ** 2 / e["C0"] == pytest.approx(1, abs=RATING_TOL)


@pytest.mark.parametrize("name", sorted(CWRU_MULTIPLES))
def test_cwru_defect_frequencies_pin_the_balls(name):
    """BPFI + BPFO = Z and (BPFI - BPFO)/Z = D_w/D_pw = 1 - 2 FTF for rolling without slip:
    the published multiples agree with the entry's Z, D_w and D_pw (read from other columns of
    the same page)."""
    bpfi, bpfo, ftf = CWRU_MULTIPLES[name]
    e = catalogue()[name]
    assert bpfi + bpfo == pytest.approx(e["Z"], abs=1e-3)
    gamma = e["D_w"] / e["D_pw"]
    assert (bpfi - bpfo) / (bpfi + bpfo) == pytest.approx(gamma, rel=1e-3)
    assert 1 - 2 * ftf == pytest.approx(gamma, rel=1e-3)


@pytest.mark.parametrize("name", rated())
def test_ball_set_derivation_is_unique_and_recovers_the_sourced_ones(name):
    """The search of the data file finds exactly one ball set: the entry's own for a derived
    entry, and for 6203 and 6205 (balls from CWRU, not derived) CWRU's count with the standard
    ball next to CWRU's diameter."""
    e = catalogue()[name]
    (z, d_w), = ball_sets_fitting(e)
    assert z == e["Z"]
    assert d_w == pytest.approx(e["D_w"], abs=0.01)
    derived = e["sources"]["Z"].startswith("derived")
    assert derived == (name not in CWRU_MULTIPLES)


def test_6012_paper_maps_to_the_model_defaults():
    """The paper's bearing as modelled gives today's default radii, ball count and masses (to
    the last digit of a double)."""
    defaults = load_config()["model"]
    geometry = model_geometry("6012-paper")
    for key, value in geometry.items():
        assert value == pytest.approx(defaults[key], rel=1e-14), key


def test_steel_ball_from_the_diameter(monkeypatch):
    """An entry without a ball mass gets a steel sphere: m = rho pi D^3 / 6, I = 2/5 m r^2."""
    from simcore.model import bearing as module

    entry = {k: v for k, v in catalogue()["6012-paper"].items()
             if k not in ("ball_mass", "ball_inertia")}
    monkeypatch.setattr(module, "catalogue", lambda: {"steel": entry})
    geometry = module.model_geometry("steel")
    m = STEEL_DENSITY * 4 / 3 * math.pi * 0.0055**3
    assert geometry["ball_mass"] == pytest.approx(m, rel=1e-12)
    assert geometry["ball_inertia"] == pytest.approx(0.4 * m * 0.0055**2, rel=1e-12)


def test_groove_of_full_depth_is_a_revolved_half_disc():
    """Cut at its own radius, the groove is a half disc revolved about the axis: volume by
    Pappus, and the integral of r^2 from the half disc's moments about its centre c
    (A = pi rho^2/2; integrals of x, x^2, x^3 over it -2/3 rho^3, pi rho^4/8, -4/15 rho^5 on the
    inner ring's side, the signs of the odd ones flipped on the outer's)."""
    from simcore.model.bearing import _groove

    rho, bottom = 4.2e-3, 30e-3
    for towards in (+1.0, -1.0):
        c = bottom + towards * rho
        area = 0.5 * math.pi * rho**2
        m1, m2, m3 = -towards * 2 / 3 * rho**3, math.pi * rho**4 / 8, -towards * 4 / 15 * rho**5
        volume, moment = _groove(bottom, rho, rho, towards)
        assert volume == pytest.approx(2 * math.pi * (c * area + m1), rel=1e-10)
        assert moment == pytest.approx(
            2 * math.pi * (c**3 * area + 3 * c**2 * m1 + 3 * c * m2 + m3), rel=1e-10)


def test_rings_without_shoulders_are_hollow_cylinders(monkeypatch):
    """With no land above the groove bottom each ring is the hollow cylinder between its bore
    (outside) and the groove bottom: m = rho pi B (b^2 - a^2), I = m (a^2 + b^2) / 2."""
    from simcore.model import bearing as module

    monkeypatch.setattr(module, "SHOULDER_FRACTION", 0.0)
    entry = catalogue()["6205"]
    d_w, width = entry["D_w"] * 1e-3, entry["B"] * 1e-3
    radii = {"inner": (0.5 * entry["d"], 0.5 * (entry["D_pw"] - entry["D_w"])),
             "outer": (0.5 * (entry["D_pw"] + entry["D_w"]), 0.5 * entry["D"])}
    rings = module.ring_masses(entry, d_w)
    for race, (a, b) in radii.items():
        a, b = a * 1e-3, b * 1e-3
        mass = STEEL_DENSITY * math.pi * width * (b**2 - a**2)
        assert rings[f"{race}_mass"] == pytest.approx(mass, rel=1e-12)
        assert rings[f"{race}_inertia"] == pytest.approx(0.5 * mass * (a**2 + b**2), rel=1e-12)


def test_rings_and_balls_weigh_what_the_catalogue_prints_less_a_cage():
    """The steel rings (cross-sections from the entry's dimensions, the model's shoulder height
    and the groove conformities) and the steel balls of every entry that prints its bearing's
    mass weigh 90 to 105 % of it: what is left is the cage, a few per cent of a deep-groove
    bearing, give or take the rings' simplified section (no chamfers). Each ring lies between
    its hollow cylinder up to the groove bottom and the one up to the pitch circle."""
    entries = {name: e for name, e in catalogue().items() if e.get("mass") is not None}
    assert len(entries) == len(rated())
    for name, entry in entries.items():
        model = model_geometry(name)
        rings = ring_masses(entry, entry["D_w"] * 1e-3)
        assert {k: model[k] for k in rings} == rings, name
        share = (rings["inner_mass"] + rings["outer_mass"]
                 + entry["Z"] * model["ball_mass"]) / entry["mass"]
        assert 0.9 <= share <= 1.05, (name, share)
        width, pitch, d_w = entry["B"], entry["D_pw"], entry["D_w"]
        for race, bore, bottom in (("inner", entry["d"], pitch - d_w),
                                   ("outer", entry["D"], pitch + d_w)):
            low, high = (_cylinder_mass(bore, edge, width) for edge in (bottom, pitch))
            assert low < rings[f"{race}_mass"] < high, name


def _cylinder_mass(d1, d2, width):
    """Mass [kg] of a steel hollow cylinder between the diameters d1, d2 [mm], width [mm]."""
    return STEEL_DENSITY * math.pi * width * abs(d2**2 - d1**2) / 4 * 1e-9


def test_an_entry_without_conformities_keeps_the_models_race_masses(monkeypatch):
    from simcore.model import bearing as module

    entry = dict(catalogue()["6205"], f_i=None)
    monkeypatch.setattr(module, "catalogue", lambda: {"6205": entry})
    assert module.ring_masses(entry, 8e-3) == {}
    assert not {"inner_mass", "outer_inertia"} & set(module.model_geometry("6205"))


def test_every_entry_cites_every_value_and_builds_a_ring():
    for name, entry in catalogue().items():
        for key in ENTRY_KEYS + tuple(k for k in entry if k not in ("description", "sources")):
            assert key in entry, (name, key)
            assert entry["sources"].get(key), (name, key)
        assert entry["d"] < entry["D_pw"] < entry["D"], name
        assert entry["Z"] * entry["D_w"] < math.pi * entry["D_pw"], name  # the balls fit
        assert model_geometry(name)["n_balls"] == entry["Z"]


def test_entry_without_balls_is_refused_naming_the_key(monkeypatch):
    from simcore.model import bearing as module

    entry = dict(catalogue()["6012"], D_w=None)
    monkeypatch.setattr(module, "catalogue", lambda: {"6012": entry})
    with pytest.raises(ValueError, match="'6012' has no D_w"):
        module.model_geometry("6012")
    with pytest.raises(ValueError, match="model.bearing: 'x' is not allowed; allowed: 6012"):
        module.model_geometry("x")


def test_a_study_naming_a_bearing_gets_its_ball_count_and_radii(tmp_path):
    """A study file that names a catalogue bearing, merged over the study's
    config/config.yaml as Snakemake merges them, plans every run with the entry's Z balls of
    diameter D_w (the real 6012: 14 balls, not the paper's 8)."""
    from simcore.config import read_study_config, validate_config
    from simcore.model.bearing import bearing
    from simcore.study import plan

    mine = tmp_path / "mine.yaml"
    mine.write_text('model:\n  bearing: "6012"\nsweep:\n  clearance_class: [CN, C4]\n'
                    "  mu: [0.01]\n  omega0: [100.0]\n  e_N: [0.9]\n")
    cfg = validate_config(read_study_config(["config/config.yaml", mine]))
    entry = bearing("6012")
    runs = plan.plan_runs(cfg)
    assert len(runs) == 4
    for run in runs:
        model = run.config["model"]
        assert model["n_balls"] == entry["Z"] == 14
        assert model["ball_radius"] == pytest.approx(0.5e-3 * entry["D_w"], rel=1e-12)


def test_a_ball_count_given_beside_a_named_bearing_is_kept_with_a_warning():
    with pytest.warns(UserWarning, match=r"model\.n_balls = 8 is given and overrides the 14 "):
        cfg = load_config(overrides=["model.bearing=6012", "model.n_balls=8"])
    assert cfg["model"]["n_balls"] == 8
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_config(overrides=["model.bearing=6012"])["model"]["n_balls"] == 14
        assert load_config(overrides=["model.n_balls=6"])["model"]["n_balls"] == 6
