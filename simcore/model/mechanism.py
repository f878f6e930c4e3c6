"""Scenes built on :class:`simcore.model.Model`: the SKF-6012 crank-slider of the source paper
and the closed-form validation cases (bouncing ball, spinning ball, ball in a ring, pinched
ball).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..config import check_section
from .bearing import BearingGeometry, race_grooves
from .builder import Model
from .integrity import BearingChecks


@dataclass
class BearingLayout:
    """Derived geometry and indices of the crank-slider model (all lengths in metres).

    The model's contacts are the 2 n ball-race contacts (balls 0..n-1 on the inner race, then
    on the outer race), then the guard contacts (:func:`add_guard_contacts`), named in
    ``guards``."""

    crank: int
    rod: int
    slider: int
    balls: list
    crank_pin: tuple      # inner-race centre in the crank's body frame
    rod_big_end: tuple    # outer-race centre in the rod's body frame
    outer_radius: float
    pitch_radius: float
    cage_speed: float     # initial cage angular velocity [rad/s]
    ball_spin: float      # initial ball spin [rad/s]
    guards: tuple = ()    # names of the guard contacts, after the ball-race contacts
    land_gap: float = 0.0  # journal offset at which the rings' lands meet [m]

    @property
    def n_race_contacts(self) -> int:
        """Number of ball-race contacts (the first contacts of the model)."""
        return 2 * len(self.balls)


def _combine(parts):
    """Mass, centre of mass (along a body axis) and Izz of rigidly joined parts.

    ``parts``: iterable of (mass [kg], position along the axis [m], own Izz [kg m^2])."""
    mass = sum(p[0] for p in parts)
    com = sum(p[0] * p[1] for p in parts) / mass
    izz = sum(p[2] + p[0] * (p[1] - com) ** 2 for p in parts)
    return mass, com, izz


@dataclass(frozen=True)
class BearingSpec:
    """The pieces of the ball bearing, as the ``model`` section gives them (SI units).

    Both scenes with a bearing (:func:`crank_slider`, :func:`bearing_alone`) build it from
    this one description with :func:`add_bearing`."""

    inner_radius: float     # r_A, inner race contact radius [m]
    ball_radius: float      # r_B [m]
    clearance: float        # g = r_C - r_A - 2 r_B [m]
    n_balls: int
    ball_mass: float        # [kg]
    ball_inertia: float     # [kg m^2]
    mu: float               # ball-race friction [-]
    e_N: float              # normal restitution [-]
    e_T: float              # tangential restitution [-]
    cage_stiffness: float   # [N/m]
    cage_damping: float     # [N s/m]
    # groove radii of the inner and the outer race [m] (elliptical contacts); None: in-plane
    groove_radii: tuple[float, float] | None = None

    @classmethod
    def from_model(cls, model: dict) -> BearingSpec:
        """The bearing of a validated ``model`` section."""
        keys = ("inner_radius", "ball_radius", "clearance", "ball_mass", "ball_inertia", "mu",
                "e_N", "e_T", "cage_stiffness", "cage_damping")
        return cls(n_balls=int(model["n_balls"]), groove_radii=race_grooves(model),
                   **{k: float(model[k]) for k in keys})

    @property
    def geometry(self) -> BearingGeometry:
        """The bearing's radii (:class:`simcore.model.bearing.BearingGeometry`)."""
        return BearingGeometry(self.inner_radius, self.ball_radius, self.clearance,
                               self.n_balls)

    @property
    def outer_radius(self) -> float:
        """r_C = r_A + 2 r_B + g [m]."""
        return self.geometry.outer_radius

    @property
    def pitch_radius(self) -> float:
        """Radius of the ball centres with the rings concentric, r_A + r_B + g/2 [m]."""
        return self.geometry.pitch_radius


def add_bearing(m: Model, spec: BearingSpec, inner: tuple, outer: tuple, centre: tuple,
                phase: float = 0.0, centre_velocity: tuple = (0.0, 0.0), cage_speed: float = 0.0,
                spin: float = 0.0, ball0_shift: float = 0.0) -> list[int]:
    """Add the balls, their contacts with both races and the cage to ``m``.

    Parameters
    ----------
    m : Model
        The model to add to.
    spec : BearingSpec
        The bearing.
    inner, outer : tuple (body, (x, y))
        The body that carries each race (-1: the ground) and the race centre in that body's
        frame [m].
    centre : tuple
        World position of both race centres at the start (rings concentric) [m].
    phase : float
        Angle of ball 0 on the pitch circle [rad]; the others follow at 2 pi / n_balls.
    centre_velocity : tuple
        Velocity of the bearing centre at the start [m/s]; every ball moves with it, plus
    cage_speed : float
        the cage's rotation about the centre [rad/s], and
    spin : float
        each ball's own rotation [rad/s].
    ball0_shift : float
        Ball 0 starts this arc length further along the pitch circle [m] (a perturbation of
        the start; the cage's rest lengths stay those of the even spacing).

    Returns
    -------
    list of int
        The balls' body indices. Added in this order: the balls (``ball0`` ...), their contacts
        with the inner race (``ballk-inner``), then with the outer race (``ballk-outer``), then
        the cage springs between neighbours (closed ring, rest length the chord
        2 R_p sin(pi/n) of the pitch circle R_p).
    """
    n = spec.n_balls
    pitch = spec.pitch_radius
    balls = []
    for k in range(n):
        ang = phase + 2.0 * np.pi * k / n + (ball0_shift / pitch if k == 0 else 0.0)
        cx, cy = np.cos(ang), np.sin(ang)
        balls.append(m.add_body(
            f"ball{k}", spec.ball_mass, spec.ball_inertia,
            q0=(centre[0] + pitch * cx, centre[1] + pitch * cy, 0.0),
            v0=(centre_velocity[0] - cage_speed * pitch * cy,
                centre_velocity[1] + cage_speed * pitch * cx, spin)))
    law = dict(mu=spec.mu, e_N=spec.e_N, e_T=spec.e_T)
    groove_in, groove_out = spec.groove_radii or (None, None)
    for k, b in enumerate(balls):
        m.add_contact("outside", inner[0], inner[1], spec.inner_radius, b, (0.0, 0.0),
                      spec.ball_radius, name=f"ball{k}-inner", groove_radius=groove_in, **law)
    for k, b in enumerate(balls):
        m.add_contact("inside", outer[0], outer[1], spec.outer_radius, b, (0.0, 0.0),
                      spec.ball_radius, name=f"ball{k}-outer", groove_radius=groove_out, **law)
    chord = spec.geometry.cage_chord
    for k in range(n):
        m.add_spring(balls[k], (0.0, 0.0), balls[(k + 1) % n], (0.0, 0.0),
                     spec.cage_stiffness, spec.cage_damping, rest_length=chord)
    return balls


def crank_slider(model: dict) -> tuple[Model, BearingLayout]:
    """The crank-slider whose crank-rod joint is a ball bearing with radial clearance.

    Parameters
    ----------
    model : dict
        The ``model`` section of a validated configuration (SI units; docs/model.md); each
        value is checked against its key's range in the schema (a section changed by hand
        after :func:`simcore.config.load_config` too), an unknown key is refused.

    Returns
    -------
    Model, BearingLayout

    Notes
    -----
    Inner race A is rigidly joined to the crank at the pin and outer race C to the rod's big
    end: their masses and inertias are merged into those bodies (parallel-axis theorem), so
    each body's reference point is the combined centre of mass. The bearing is the only link
    between crank and rod. Initial state (docs/model.md): crank and rod along +x, bearing
    centred, balls evenly spaced on the pitch circle from angle 0 (ball 0 moved along it by
    ``ball0_shift``), crank speed omega0, the rod and slider from the ideal slider-crank, and
    each ball given the cage rotation and spin with zero slip at both races as the contact
    element measures it (at r_A and r_C).
    """
    model = check_section("model", model)  # (a section changed by hand, too)
    L1, L2 = model["crank_length"], model["rod_length"]
    w0 = model["omega0"]
    spec = BearingSpec.from_model(model)
    m = Model(gravity=model["gravity"], youngs_modulus=model["youngs_modulus"],
              poisson_ratio=model["poisson_ratio"])

    # crank + inner race, about the combined centre of mass on the crank axis
    mc, sc, ic = _combine([(model["crank_mass"], 0.5 * L1, model["crank_inertia"]),
                           (model["inner_mass"], L1, model["inner_inertia"])])
    crank = m.add_body("crank", mc, ic, q0=(sc, 0.0, 0.0), v0=(0.0, w0 * sc, w0))
    # rod + outer race, measured from the big end
    w_rod = -w0 * L1 / L2
    mr, sr, ir = _combine([(model["rod_mass"], 0.5 * L2, model["rod_inertia"]),
                           (model["outer_mass"], 0.0, model["outer_inertia"])])
    rod = m.add_body("rod", mr, ir, q0=(L1 + sr, 0.0, 0.0),
                     v0=(0.0, w0 * L1 + w_rod * sr, w_rod))
    slider = m.add_body("slider", model["slider_mass"], model["slider_inertia"],
                        q0=(L1 + L2, 0.0, 0.0))

    m.add_revolute(crank, (-sc, 0.0), -1, (0.0, 0.0))
    m.add_revolute(rod, (L2 - sr, 0.0), slider, (0.0, 0.0))
    m.add_prismatic(slider, (0.0, 0.0), origin=(0.0, 0.0), angle=0.0, phi=0.0)
    if model["drive"] == "constant":
        m.add_prescribed_rotation(crank, 0.0, w0)

    # balls: zero slip at both races, measured at r_A and r_C (docs/model.md)
    vA, vC = w0 * spec.inner_radius, w_rod * spec.outer_radius  # race speeds about the pin
    cage = 0.5 * (vA + vC) / spec.pitch_radius
    spin = 0.5 * (vC - vA) / spec.ball_radius
    pin = (L1 - sc, 0.0)
    big_end = (-sr, 0.0)
    balls = add_bearing(m, spec, (crank, pin), (rod, big_end), (L1, 0.0),
                        centre_velocity=(0.0, w0 * L1), cage_speed=cage, spin=spin,
                        ball0_shift=model.get("ball0_shift", 0.0))
    geometry = spec.geometry
    guards = ()
    if model.get("guard_contacts", True):
        guards = add_guard_contacts(m, geometry, balls, (crank, pin), (rod, big_end),
                                    dict(mu=spec.mu, e_N=spec.e_N, e_T=spec.e_T))
    layout = BearingLayout(crank, rod, slider, balls, pin, big_end, spec.outer_radius,
                           spec.pitch_radius, cage, spin, guards=guards,
                           land_gap=geometry.land_gap)
    m.checks.extend(BearingChecks(crank, rod, slider, tuple(balls), pin, big_end,
                                  spec.ball_radius, geometry.land_gap, L1, L2).all())
    return m, layout


def add_guard_contacts(m: Model, geometry: BearingGeometry, balls, inner: tuple, outer: tuple,
                       law: dict) -> tuple:
    """Add the contacts that keep a bearing together to ``m`` (docs/model.md, "Guard
    contacts"): each ball against its next neighbour (sphere on sphere, ``outside``) and the
    inner ring inside the outer ring (``inside``, the rings' lands, closing at the journal
    offset :attr:`~simcore.model.bearing.BearingGeometry.land_gap`).

    Parameters
    ----------
    m : Model
        The model, with the balls and both races' bodies.
    geometry : BearingGeometry
        The bearing.
    balls : sequence of int
        The balls' body indices, in order around the pitch circle.
    inner, outer : tuple (body, (x, y))
        The body carrying each ring and the ring's centre in that body's frame [m].
    law : dict
        ``mu``, ``e_N``, ``e_T`` of the guard contacts (the ball-race contacts' own: the same
        steel on steel, the same lubricant).

    Returns
    -------
    tuple of str
        The names of the contacts added, in order: ``ballk-ballk+1`` for k = 0 .. n-1 (the
        last ``ball(n-1)-ball0``), then ``rings``.
    """
    n = len(balls)
    names = []
    for k in range(n):
        name = f"ball{k}-ball{(k + 1) % n}"
        m.add_contact("outside", balls[k], (0.0, 0.0), geometry.ball_radius, balls[(k + 1) % n],
                      (0.0, 0.0), geometry.ball_radius, name=name, **law)
        names.append(name)
    m.add_contact("inside", outer[0], outer[1], geometry.outer_land_radius, inner[0], inner[1],
                  geometry.inner_land_radius, name="rings", **law)
    names.append("rings")
    return tuple(names)


def bearing_alone(model: dict, load: float, phase: float = 0.0,
                  fixed: str = "inner") -> tuple[Model, list[int]]:
    """The bearing of :func:`crank_slider` on its own, one race fixed, the other loaded.

    Parameters
    ----------
    model : dict
        The ``model`` section of a validated configuration: the bearing's radii, balls, cage
        and contact laws, the material and ``gravity`` (> 0) are read from it; each value is
        checked against its key's range in the schema, as by :func:`crank_slider`.
    load : float
        Radial load [N], > 0: the free race is a body of mass ``load / gravity`` hanging on the
        balls, so its weight is the load (its inertia is the race's, ``outer_inertia`` or
        ``inner_inertia``). The balls keep their own weight.
    phase : float
        Angle of ball 0 [rad]. The free race moves along -y, so with ``fixed = "inner"`` the
        balls near +y carry the load (load angle pi/2 of the inner race relative to the outer):
        ``phase = pi/2`` puts a ball under the load, ``pi/2 + pi/n_balls`` two balls astride it.
    fixed : {"inner", "outer"}
        The race held by the ground; the other one may translate (its rotation is held at 0 by
        a prescribed rotation of rate 0).

    Returns
    -------
    Model, list of int
        The model (free race body 0, named ``"outer"`` or ``"inner"``) and the balls' indices.
        Start: rings concentric at the origin, everything at rest.
    """
    if fixed not in ("inner", "outer"):
        raise ValueError(f"fixed: {fixed!r} is not allowed; allowed: 'inner', 'outer'")
    model = check_section("model", model)
    gravity = float(model["gravity"])
    if gravity <= 0.0 or not load > 0.0:
        raise ValueError(f"load: {load!r} with model.gravity = {gravity!r} is not allowed; "
                         "allowed: load > 0 and gravity > 0 (the load is the free race's weight)")
    spec = BearingSpec.from_model(model)
    m = Model(gravity=gravity, youngs_modulus=model["youngs_modulus"],
              poisson_ratio=model["poisson_ratio"])
    free = "outer" if fixed == "inner" else "inner"
    body = m.add_body(free, load / gravity, model[f"{free}_inertia"])
    m.add_prescribed_rotation(body, 0.0, 0.0)
    races = {free: (body, (0.0, 0.0)), fixed: (-1, (0.0, 0.0))}
    balls = add_bearing(m, spec, races["inner"], races["outer"], (0.0, 0.0), phase=phase)
    return m, balls


# ------------------------------------------------------------------------------------------
# validation scenes (closed-form checks)
# ------------------------------------------------------------------------------------------
def ball_on_plane(radius=0.1, mass=1.0, height=1.0, spin=0.0, mu=0.0, e_N=0.5, e_T=0.0,
                  gravity=9.81, inertia=None, speed=(0.0, 0.0), youngs_modulus=2.1e11,
                  poisson_ratio=0.3) -> Model:
    """A ball (centre at ``height`` [m]) released above the ground plane y = 0 with velocity
    ``speed`` [m/s] and an initial spin [rad/s]. Inertia default: solid sphere 0.4 m R^2.
    ``youngs_modulus`` [Pa] and ``poisson_ratio`` matter for the compliant contact model."""
    m = Model(gravity=gravity, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio)
    inertia = 0.4 * mass * radius**2 if inertia is None else inertia
    b = m.add_body("ball", mass, inertia, q0=(0.0, height, 0.0), v0=(speed[0], speed[1], spin))
    m.add_contact("plane", -1, (0.0, 0.0), np.pi / 2, b, (0.0, 0.0), radius, mu=mu, e_N=e_N,
                  e_T=e_T, name="ball-ground")
    return m


def ball_in_ring(ring_radius=0.05, radius=0.005, speed=(1.0, 0.37), e_N=1.0, mu=0.0,
                 gravity=0.0, mass=2.7e-3, start=(0.0, 0.0), youngs_modulus=2.1e11,
                 poisson_ratio=0.3, groove_radius=None) -> Model:
    """A ball moving inside a fixed ring (the sphere-in-sphere element), starting at ``start``
    (default: the centre) [m] with velocity ``speed`` [m/s]; with ``groove_radius`` [m] the
    ring is grooved across the plane (an elliptical contact)."""
    m = Model(gravity=gravity, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio)
    b = m.add_body("ball", mass, 0.4 * mass * radius**2, q0=(start[0], start[1], 0.0),
                   v0=(speed[0], speed[1], 0.0))
    m.add_contact("inside", -1, (0.0, 0.0), ring_radius, b, (0.0, 0.0), radius, mu=mu, e_N=e_N,
                  name="ball-ring", groove_radius=groove_radius)
    return m


def pinched_balls(n_balls=3, load=50.0, inner_radius=0.033745, ball_radius=0.0055,
                  e_N=0.0, mu=0.1, outer_mass=0.1, ball_mass=2.7e-3) -> Model:
    """Balls pinched between a fixed inner race and an outer race pressed down onto them.

    The inner race is the ground; the outer race (zero clearance) may only translate
    vertically (prismatic joint) and carries a weight ``load`` [N] plus its own. The balls sit
    at the top of the inner race, where the descending outer race presses them on it, spread
    over +-20 degrees around +y. Every ball touches
    both races: with more than one ball the contact rows are redundant (the outer race has one
    degree of freedom and 2 n contacts act on it through the balls).
    """
    gravity = 9.81
    m = Model(gravity=gravity)
    geometry = BearingGeometry(inner_radius, ball_radius, 0.0, n_balls)  # zero clearance
    rC, pitch = geometry.outer_radius, geometry.pitch_radius
    outer = m.add_body("outer", outer_mass + load / gravity, 1e-4, q0=(0.0, 0.0, 0.0))
    m.add_prismatic(outer, (0.0, 0.0), origin=(0.0, 0.0), angle=np.pi / 2, phi=0.0)
    spread = np.radians(20.0)
    angles = [np.pi / 2] if n_balls == 1 else list(
        np.pi / 2 + np.linspace(-spread, spread, n_balls))
    for k, a in enumerate(angles):
        b = m.add_body(f"ball{k}", ball_mass, 0.4 * ball_mass * ball_radius**2,
                       q0=(pitch * np.cos(a), pitch * np.sin(a), 0.0))
        m.add_contact("outside", -1, (0.0, 0.0), inner_radius, b, (0.0, 0.0), ball_radius,
                      mu=mu, e_N=e_N, name=f"ball{k}-inner")
        m.add_contact("inside", outer, (0.0, 0.0), rC, b, (0.0, 0.0), ball_radius, mu=mu,
                      e_N=e_N, name=f"ball{k}-outer")
    return m
