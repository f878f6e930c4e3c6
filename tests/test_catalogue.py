"""Bearing catalogue and ISO 5753-1 clearance classes: rows transcribed here from the cited pages,
the table's invariants, the mapping of an entry to the model, and the one-line refusals."""

import math

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
)

# transcribed from http://en.shjfbearing.com/news/eventsPage/2525 (deep-groove radial clearance
# table), micrometres: (bore [mm], class, min, max)
ROWS = [(60.0, "C3", 23, 43), (60.0, "CN", 8, 28), (25.0, "C4", 23, 41), (45.0, "C5", 45, 73),
        (12.0, "C2", 0, 9), (90.0, "C3", 30, 58), (40.0, "CN", 6, 20), (70.0, "C5", 65, 105)]


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


def test_clearance_refusals_name_the_key():
    with pytest.raises(ValueError, match="model.clearance_class: 'C7' is not allowed"):
        clearance_range(60.0, "C7")
    with pytest.raises(ValueError, match="model.clearance_class: C5 is not available"):
        clearance_range(60.0, "C5")
    with pytest.raises(ValueError, match="bore 500 mm is outside"):
        clearance_range(500.0, "CN")


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


def test_every_entry_cites_every_value():
    for name, entry in catalogue().items():
        for key in ENTRY_KEYS:
            assert key in entry, (name, key)
            assert entry["sources"].get(key), (name, key)
        if entry["D_pw"] is not None:
            assert entry["d"] < entry["D_pw"] < entry["D"], name
        if entry.get("C") is not None:
            assert entry["C0"] > 0 and entry["C"] > 0


def test_entry_without_balls_is_refused_naming_the_key():
    with pytest.raises(ValueError, match="'6205' has no D_w"):
        model_geometry("6205")
    with pytest.raises(ValueError, match="model.bearing: 'x' is not allowed; allowed: 6012"):
        model_geometry("x")
