"""The bearing: its geometry from one place (race radii, pitch circle, cage chord, the rings'
lands), the bearing catalogue and the ISO 5753-1 clearance classes (docs/model.md, "The
bearing"; docs/life.md, "From a catalogue entry to the model").

Geometry. The model's bearing is planar: balls of radius r_B between an inner race of radius r_A
(the groove bottom of the inner ring) and an outer race of radius r_C (the groove bottom of the
outer ring), with the radial clearance g = r_C - r_A - 2 r_B as the input. Every radius the
model, its limits, its integrity checks and the analysis need is computed by
:class:`BearingGeometry`.

The **lands** are the cylindrical shoulders of the rings beside the grooves: the inner ring's
land at r_A + h, the outer ring's at r_C - h, with h the shoulder height (groove depth). When
the balls bunch on one side (a soft cage) nothing else keeps the inner ring inside the outer
one; in a real deep-groove bearing the lands then meet. Their radial distance with the rings
concentric,

    land gap = (r_C - h) - (r_A + h) = g + 2 r_B - 2 h,

is the journal offset at which the ring guard contact of the model closes
(:func:`simcore.model.mechanism.add_guard_contacts`).

Catalogue. Data files (each value with its source): ``simcore/data/bearings.yaml`` and
``simcore/data/clearance_iso5753.yaml``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Any, Iterable, Mapping

import yaml

STEEL_DENSITY = 7850.0  # [kg/m^3] balls of an entry that gives no ball mass
CLEARANCE_CLASSES = ("C2", "CN", "C3", "C4", "C5")
ENTRY_KEYS = ("d", "D", "B", "D_w", "Z", "D_pw", "f_i", "f_e", "C", "C0")
MASS_KEYS = ("ball_mass", "ball_inertia", "inner_mass", "inner_inertia", "outer_mass",
             "outer_inertia")


#: The package data's YAML reader: libyaml's (PyYAML's C parser, with the same safe
#: constructors and resolver) where PyYAML has it, ten times faster than the pure-Python one
#: on the catalogue (about 4 against 37 ms, a first run's start).
DATA_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def _data(name):
    text = resources.files("simcore").joinpath("data", name).read_text()
    return yaml.load(text, Loader=DATA_LOADER)  # noqa: S506  (a safe loader)


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
    """The ``model`` keys that a catalogue entry fixes (SI units): :func:`catalogue_values`
    with nothing given explicitly.

    Mapping (docs/life.md): ``ball_radius`` = D_w / 2; ``inner_radius`` = (D_pw - D_w) / 2, the
    race contact radius r_A of the ball on the pitch circle; ``n_balls`` = Z; the ball's mass
    and inertia as the entry gives them, else a steel sphere (7,850 kg/m^3, m = rho pi D_w^3 / 6,
    I = m D_w^2 / 10); the race masses and inertias as the entry gives them, else those of its
    steel rings (:func:`ring_masses`), else none (the model's own values stay); the groove
    conformities ``inner_conformity``, ``outer_conformity`` = f_i, f_e where the entry gives
    them. The clearance is not part of an entry (``clearance_class``).

    Raises
    ------
    ValueError
        One line naming the entry's missing key, for an entry without D_w, Z or D_pw.
    """
    return catalogue_values(name, {})


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


#: what each model key the catalogue can fix needs of an entry
_NEEDS = {"ball_radius": ("D_w",), "n_balls": ("Z",), "inner_radius": ("D_pw", "D_w")}
#: the groove conformity keys of the model and the entry's values they take
CONFORMITY_KEYS = {"inner_conformity": "f_i", "outer_conformity": "f_e"}
#: the ``model`` keys a catalogue entry sets (:func:`catalogue_values`)
SET_BY_ENTRY = (*_NEEDS, *MASS_KEYS, *CONFORMITY_KEYS)


def catalogue_values(name: str, explicit: Mapping[str, Any]) -> dict:
    """The ``model`` keys that the catalogue entry ``name`` fixes and ``explicit`` does not
    give (SI units): the mapping of :func:`model_geometry`, the explicit values entering it
    where they stand for the entry's (an explicit ball radius: the inner race radius
    D_pw / 2 - r_B puts the ball's centre on the entry's pitch circle, and a steel ball's mass
    follows from it) and standing in for what the entry lacks.

    Parameters
    ----------
    name : str
        Catalogue entry (``model.bearing``).
    explicit : mapping
        The model values given explicitly (they win over the entry's).

    Returns
    -------
    dict
        Values for the keys of ``model_geometry`` not in ``explicit``: the radii and the ball
        count from D_w, D_pw, Z; the ball's mass and inertia as the entry gives them, else a
        steel sphere of the ball's diameter (the explicit ``ball_radius`` when given); the
        race masses and inertias as the entry gives them, else those of its steel rings
        (:func:`ring_masses`, with that ball's groove), else none; the groove conformities
        ``inner_conformity``, ``outer_conformity`` as the entry's f_i, f_e, else none.

    Raises
    ------
    ValueError
        One line naming ``model.bearing``, the entry's missing value and the keys that can
        stand in for it.
    """
    entry = bearing(name)
    values: dict[str, Any] = {}
    for key, needs in _NEEDS.items():
        if key in explicit:
            continue
        missing = [n for n in needs if entry.get(n) is None
                   and not (n == "D_w" and "ball_radius" in explicit)]
        if missing:
            raise ValueError(
                f"model.bearing: {name!r} has no {missing[0]} ({entry['sources'][missing[0]]}); "
                f"allowed: an entry with it, or model.{key} given explicitly")
    # the ball the model gets: an explicit radius wins over the entry's D_w wherever it enters
    d_w = (2.0 * float(explicit["ball_radius"]) if "ball_radius" in explicit
           else entry["D_w"] * 1e-3)
    if "ball_radius" not in explicit:
        values["ball_radius"] = 0.5 * d_w
    if "inner_radius" not in explicit:
        values["inner_radius"] = 0.5 * (entry["D_pw"] * 1e-3 - d_w)
    if "n_balls" not in explicit:
        values["n_balls"] = int(entry["Z"])
    mass = explicit.get("ball_mass", entry.get("ball_mass"))
    if mass is None:
        mass = STEEL_DENSITY * math.pi * d_w**3 / 6.0
    if "ball_mass" not in explicit:
        values["ball_mass"] = mass
    if "ball_inertia" not in explicit:
        inertia = entry.get("ball_inertia")
        values["ball_inertia"] = mass * d_w**2 / 10.0 if inertia is None else inertia
    rings = ring_masses(entry, d_w)
    for key in MASS_KEYS[2:]:
        value = entry[key] if entry.get(key) is not None else rings.get(key)
        if key not in explicit and value is not None:
            values[key] = value
    for key, field in CONFORMITY_KEYS.items():
        if key not in explicit and entry.get(field) is not None:
            values[key] = float(entry[field])
    return values


def _warn_overridden(model: Mapping[str, Any], explicit: set) -> None:
    """Warn where a named catalogue bearing's ball count or radii are given explicitly with
    other values: a configuration file merged under the user's (a study's config/config.yaml)
    would otherwise change the bearing without a word."""
    try:
        own = model_geometry(model["bearing"])
    except ValueError:  # an entry that lacks D_w, Z or D_pw: explicit values stand in, unchecked
        return
    for key in ("n_balls", "ball_radius", "inner_radius"):
        value = own[key]
        if key in explicit and not math.isclose(float(model[key]), float(value),
                                                rel_tol=1e-9):
            warnings.warn(f"model.{key} = {model[key]:g} is given and overrides the "
                          f"{value:g} of bearing {model['bearing']!r} (catalogue); leave it out "
                          "to take the catalogue's", UserWarning, stacklevel=4)


def resolve_model(model: Mapping[str, Any], explicit: Iterable[str]) -> dict:
    """A ``model`` section with its bearing resolved: the catalogue entry ``model.bearing``
    fixes the radii, ball count, masses and conformities not in ``explicit``, and
    ``model.clearance_class`` (when not None) the clearance (half the middle of the class's
    ISO 5753-1 range for the entry's bore), whatever ``model.clearance`` says.

    This is what :func:`simcore.config.validate_config` applies, the keys of the ``model``
    section it was given being ``explicit``; a study that sweeps ``model.bearing`` or
    ``model.clearance_class`` resolves each grid point with it
    (:func:`simcore.study.plan.resolve_point`).

    Parameters
    ----------
    model : mapping
        A complete ``model`` section (defaults filled), with ``bearing`` and
        ``clearance_class``.
    explicit : iterable of str
        The keys of ``model`` the user gave.

    Returns
    -------
    dict
        A new ``model`` section.

    Raises
    ------
    ValueError
        One line naming ``model.bearing`` or ``model.clearance_class``.
    """
    from ..config.parameters import tidy

    explicit = set(explicit)
    out = dict(model)
    if "bearing" in explicit:
        _warn_overridden(out, explicit)
    out.update(catalogue_values(out["bearing"], {k: out[k] for k in explicit if k in out}))
    if out.get("clearance_class") is not None:
        # (to 10 digits, as a study's grid point has it: simcore.study.plan.resolve_point)
        out["clearance"] = tidy(model_clearance(bearing(out["bearing"])["d"],
                                                out["clearance_class"]))
    return out


# ------------------------------------------------------------------------------------------
# geometry
# ------------------------------------------------------------------------------------------
#: Shoulder height of each ring over the ball diameter [-] (groove depth). Deep-groove rings:
#: the inner ring of a 6312 (catalogue shoulder diameter d1 = 81.86 mm, pitch diameter
#: 95 mm, balls of 22.225 mm) has 0.20; docs/model.md gives the reasoning.
SHOULDER_FRACTION = 0.2


def ring_masses(entry: Mapping[str, Any], ball_diameter: float) -> dict:
    """Masses and polar inertias of a catalogue bearing's two steel rings (SI units).

    Each ring's cross-section is a rectangle of the bearing's width B from its bore (outside)
    diameter to its land, the shoulder :data:`SHOULDER_FRACTION` D_w above the groove bottom,
    less the groove: a circle of radius f D_w (the entry's conformity) touching the groove
    bottom, cut at the land. Groove bottoms at (D_pw -+ D_w) / 2; steel of
    :data:`STEEL_DENSITY`; chamfers, seal grooves and the cage left out. The inertia is about
    the bearing's axis, the ring's own centre (docs/life.md checks the masses against the
    catalogue's bearing masses).

    Parameters
    ----------
    entry : mapping
        Catalogue entry: ``d``, ``D``, ``B``, ``D_pw`` [mm], ``f_i``, ``f_e`` [-].
    ball_diameter : float
        D_w of the balls the rings carry [m].

    Returns
    -------
    dict
        ``inner_mass``, ``outer_mass`` [kg], ``inner_inertia``, ``outer_inertia`` [kg m^2];
        empty when the entry lacks one of the values above.
    """
    if any(entry.get(key) is None for key in ("d", "D", "B", "D_pw", "f_i", "f_e")):
        return {}
    width, pitch = entry["B"] * 1e-3, entry["D_pw"] * 1e-3
    depth = SHOULDER_FRACTION * ball_diameter
    inner_bottom, outer_bottom = 0.5 * (pitch - ball_diameter), 0.5 * (pitch + ball_diameter)
    rings = {"inner": (_annulus(0.5 * entry["d"] * 1e-3, inner_bottom + depth, width),
                       _groove(inner_bottom, depth, entry["f_i"] * ball_diameter, +1.0)),
             "outer": (_annulus(outer_bottom - depth, 0.5 * entry["D"] * 1e-3, width),
                       _groove(outer_bottom, depth, entry["f_e"] * ball_diameter, -1.0))}
    out = {}
    for race, ((volume, moment), (void, void_moment)) in rings.items():
        out[f"{race}_mass"] = STEEL_DENSITY * (volume - void)
        out[f"{race}_inertia"] = STEEL_DENSITY * (moment - void_moment)
    return out


def _annulus(r_in: float, r_out: float, width: float) -> tuple[float, float]:
    """Volume [m^3] and integral of r^2 over the volume [m^5] of a hollow cylinder."""
    return (math.pi * width * (r_out**2 - r_in**2),
            0.5 * math.pi * width * (r_out**4 - r_in**4))


def _groove(bottom: float, depth: float, radius: float, towards: float) -> tuple[float, float]:
    """Volume [m^3] and integral of r^2 over the volume [m^5] of a ring groove: the circle of
    ``radius`` touching the radius ``bottom``, centred on the side ``towards`` (+1: outwards,
    the inner ring's; -1: inwards), revolved about the axis and cut ``depth`` from the bottom."""
    from scipy.integrate import quad

    centre = bottom + towards * radius

    def chord(r):  # the groove's axial width at radius r
        return 2.0 * math.sqrt(max(radius**2 - (r - centre) ** 2, 0.0))

    lo, hi = sorted((bottom, bottom + towards * depth))
    volume = quad(lambda r: 2.0 * math.pi * r * chord(r), lo, hi, epsabs=0.0, epsrel=1e-12)[0]
    moment = quad(lambda r: 2.0 * math.pi * r**3 * chord(r), lo, hi, epsabs=0.0,
                  epsrel=1e-12)[0]
    return volume, moment


@dataclass(frozen=True)
class BearingGeometry:
    """Radii of the planar bearing [m].

    Parameters
    ----------
    inner_radius : float
        r_A, inner race (groove bottom) radius [m].
    ball_radius : float
        r_B [m].
    clearance : float
        Radial clearance g = r_C - r_A - 2 r_B [m].
    n_balls : int
        Number of balls.
    shoulder_fraction : float
        Shoulder height of each ring over the ball diameter [-] (:data:`SHOULDER_FRACTION`).
    """

    inner_radius: float
    ball_radius: float
    clearance: float
    n_balls: int
    shoulder_fraction: float = SHOULDER_FRACTION

    @classmethod
    def from_model(cls, model: dict) -> BearingGeometry:
        """The geometry of a ``model`` section (keys ``inner_radius``, ``ball_radius``,
        ``clearance``, ``n_balls``)."""
        return cls(float(model["inner_radius"]), float(model["ball_radius"]),
                   float(model["clearance"]), int(model["n_balls"]))

    @property
    def outer_radius(self) -> float:
        """r_C = r_A + 2 r_B + g [m]."""
        return self.inner_radius + 2.0 * self.ball_radius + self.clearance

    @property
    def pitch_radius(self) -> float:
        """Radius of the ball centres with the rings concentric, r_A + r_B + g/2 [m]."""
        return self.inner_radius + self.ball_radius + 0.5 * self.clearance

    @property
    def cage_chord(self) -> float:
        """Distance of neighbouring ball centres evenly spaced on the pitch circle,
        2 R_p sin(pi / n) [m] (the cage springs' rest length)."""
        return 2.0 * self.pitch_radius * math.sin(math.pi / self.n_balls)

    @property
    def shoulder_height(self) -> float:
        """h, height of each ring's land above its groove bottom [m]."""
        return self.shoulder_fraction * 2.0 * self.ball_radius

    @property
    def inner_land_radius(self) -> float:
        """Radius of the inner ring's land, r_A + h [m]."""
        return self.inner_radius + self.shoulder_height

    @property
    def outer_land_radius(self) -> float:
        """Radius of the outer ring's land, r_C - h [m]."""
        return self.outer_radius - self.shoulder_height

    @property
    def land_gap(self) -> float:
        """Journal offset at which the lands meet, g + 2 r_B - 2 h [m]."""
        return self.outer_land_radius - self.inner_land_radius

    def balls_fit(self) -> bool:
        """True when n balls evenly spaced on the pitch circle do not overlap."""
        return self.cage_chord > 2.0 * self.ball_radius

    def max_balls(self) -> int:
        """Most balls that fit evenly spaced on the pitch circle without overlapping."""
        return int(math.pi / math.asin(min(1.0, self.ball_radius / self.pitch_radius)))


def race_grooves(model: Mapping[str, Any]) -> tuple[float, float] | None:
    """Groove radii of the inner and the outer race, f_i D_w and f_e D_w [m], where
    ``model.contact_geometry`` is ``groove`` (elliptical ball-race contacts); None for the
    in-plane contacts of ``plane``.

    Parameters
    ----------
    model : mapping
        A validated ``model`` section (``contact_geometry``, ``ball_radius``,
        ``inner_conformity``, ``outer_conformity``).
    """
    if model.get("contact_geometry", "plane") != "groove":
        return None
    d_w = 2.0 * float(model["ball_radius"])
    return (float(model["inner_conformity"]) * d_w, float(model["outer_conformity"]) * d_w)
