"""Bearing catalogue and ISO 5753-1 clearance classes: from a catalogue entry to the model's
radii and masses (docs/life.md, "From a catalogue entry to the model").

Data files (each value with its source): ``simcore/data/bearings.yaml`` and
``simcore/data/clearance_iso5753.yaml``.
"""

from __future__ import annotations

import math
from functools import lru_cache
from importlib import resources

import yaml

STEEL_DENSITY = 7850.0  # [kg/m^3] balls of an entry that gives no ball mass
CLEARANCE_CLASSES = ("C2", "CN", "C3", "C4", "C5")
ENTRY_KEYS = ("d", "D", "B", "D_w", "Z", "D_pw", "f_i", "f_e", "C", "C0")
MASS_KEYS = ("ball_mass", "ball_inertia", "inner_mass", "inner_inertia", "outer_mass",
             "outer_inertia")


def _data(name):
    return yaml.safe_load(resources.files("simcore").joinpath("data", name).read_text())


@lru_cache(maxsize=1)
def catalogue() -> dict:
    """Every catalogue entry, by name, as in ``bearings.yaml`` (lengths in mm, ratings in N)."""
    return {str(name): entry for name, entry in _data("bearings.yaml").items()}


def bearing(name: str) -> dict:
    """One catalogue entry; an unknown name is refused with the names allowed."""
    entries = catalogue()
    if name not in entries:
        raise ValueError(f"model.bearing: {name!r} is not allowed; allowed: "
                         + ", ".join(sorted(entries)))
    return entries[name]


def model_geometry(name: str) -> dict:
    """The ``model`` keys that a catalogue entry fixes (SI units).

    Mapping (docs/life.md): ``ball_radius`` = D_w / 2; ``inner_radius`` = (D_pw - D_w) / 2, the
    race contact radius r_A of the ball on the pitch circle; ``n_balls`` = Z; the ball's mass
    and inertia as the entry gives them, else a steel sphere (7,850 kg/m^3, m = rho pi D_w^3 / 6,
    I = m D_w^2 / 10); race masses and inertias only where the entry gives them (otherwise the
    model's own values stay). The clearance is not part of an entry (``clearance_class``).

    Raises
    ------
    ValueError
        One line naming the entry's missing key, for an entry without D_w, Z or D_pw.
    """
    entry = bearing(name)
    for key in ("D_w", "Z", "D_pw"):
        if entry.get(key) is None:
            raise ValueError(f"model.bearing: {name!r} has no {key} ({entry['sources'][key]}); "
                             "allowed: an entry with D_w, Z and D_pw, or model.ball_radius, "
                             "model.inner_radius and model.n_balls given explicitly")
    d_w = entry["D_w"] * 1e-3
    d_pw = entry["D_pw"] * 1e-3
    out = {"ball_radius": 0.5 * d_w, "inner_radius": 0.5 * (d_pw - d_w), "n_balls": int(entry["Z"])}
    mass = entry.get("ball_mass")
    if mass is None:
        mass = STEEL_DENSITY * math.pi * d_w**3 / 6.0
    out["ball_mass"] = mass
    inertia = entry.get("ball_inertia")
    out["ball_inertia"] = mass * d_w**2 / 10.0 if inertia is None else inertia
    for key in MASS_KEYS[2:]:
        if entry.get(key) is not None:
            out[key] = entry[key]
    return out


@lru_cache(maxsize=1)
def clearance_table() -> list:
    """Rows of the ISO 5753-1 deep-groove table: dicts with ``over``, ``incl`` [mm] and each
    class's [min, max] [um] or None."""
    return _data("clearance_iso5753.yaml")["rows"]


def clearance_range(bore: float, clearance_class: str) -> tuple[float, float, float]:
    """ISO 5753-1 radial internal clearance of a deep-groove ball bearing [m].

    Parameters
    ----------
    bore : float
        Bore diameter d [mm].
    clearance_class : {"C2", "CN", "C3", "C4", "C5"}

    Returns
    -------
    (min, max, middle) : tuple of float
        The class's range and its middle [m], as ISO 5753-1 defines radial internal clearance:
        the total radial play of one ring against the other. The model's clearance g (the play
        of one ball, rings concentric) is half of it: :func:`model_clearance`.
    """
    if clearance_class not in CLEARANCE_CLASSES:
        raise ValueError(f"model.clearance_class: {clearance_class!r} is not allowed; allowed: "
                         + ", ".join(CLEARANCE_CLASSES))
    rows = clearance_table()
    d = float(bore)
    for row in rows:
        if row["over"] < d <= row["incl"]:
            cell = row[clearance_class]
            if cell is None:
                raise ValueError(f"model.clearance_class: {clearance_class} is not available for "
                                 f"bore {d:g} mm (row {row['over']}-{row['incl']} mm; see "
                                 "simcore/data/clearance_iso5753.yaml); allowed there: "
                                 + ", ".join(c for c in CLEARANCE_CLASSES if row[c] is not None))
            lo, hi = cell[0] * 1e-6, cell[1] * 1e-6
            return lo, hi, 0.5 * (lo + hi)
    raise ValueError(f"model.bearing: bore {d:g} mm is outside the clearance table; allowed: "
                     f"{rows[0]['over']} < d <= {rows[-1]['incl']} mm")


def model_clearance(bore: float, clearance_class: str) -> float:
    """The model's clearance g [m] for a class: half the middle of its ISO range."""
    return 0.5 * clearance_range(bore, clearance_class)[2]
