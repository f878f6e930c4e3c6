"""Scenes built on :class:`simcore.model.Model`: the SKF-6012 crank-slider of the source paper
and the closed-form validation cases (bouncing ball, spinning ball, ball in a ring, pinched
ball).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .builder import Model


@dataclass
class BearingLayout:
    """Derived geometry and indices of the crank-slider model (all lengths in metres)."""

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


def _combine(parts):
    """Mass, centre of mass (along a body axis) and Izz of rigidly joined parts.

    ``parts``: iterable of (mass [kg], position along the axis [m], own Izz [kg m^2])."""
    mass = sum(p[0] for p in parts)
    com = sum(p[0] * p[1] for p in parts) / mass
    izz = sum(p[2] + p[0] * (p[1] - com) ** 2 for p in parts)
    return mass, com, izz


def crank_slider(model: dict) -> tuple[Model, BearingLayout]:
    """The crank-slider whose crank-rod joint is a ball bearing with radial clearance.

    Parameters
    ----------
    model : dict
        The ``model`` section of a validated configuration (SI units; docs/model.md).

    Returns
    -------
    Model, BearingLayout

    Notes
    -----
    Inner race A is rigidly joined to the crank at the pin and outer race C to the rod's big
    end: their masses and inertias are merged into those bodies (parallel-axis theorem), so
    each body's reference point is the combined centre of mass. The bearing is the only link
    between crank and rod. Initial state (docs/model.md): crank and rod along +x, bearing
    centred, balls evenly spaced on the pitch circle from angle 0, crank speed omega0, the rod
    and slider from the ideal slider-crank, and each ball given the cage rotation and spin with
    zero slip at both races as the contact element measures it (at r_A and r_C).
    """
    L1, L2 = model["crank_length"], model["rod_length"]
    w0 = model["omega0"]
    rA, rB, g = model["inner_radius"], model["ball_radius"], model["clearance"]
    rC = rA + 2.0 * rB + g
    n = int(model["n_balls"])
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
    pitch = rA + rB + 0.5 * g
    vA, vC = w0 * rA, w_rod * rC                  # race surface speeds about the pin
    cage = 0.5 * (vA + vC) / pitch
    spin = 0.5 * (vC - vA) / rB
    pin_v = (0.0, w0 * L1)
    balls = []
    for k in range(n):
        ang = 2.0 * np.pi * k / n
        cx, cy = np.cos(ang), np.sin(ang)
        balls.append(m.add_body(
            f"ball{k}", model["ball_mass"], model["ball_inertia"],
            q0=(L1 + pitch * cx, pitch * cy, 0.0),
            v0=(pin_v[0] - cage * pitch * cy, pin_v[1] + cage * pitch * cx, spin)))
    pin = (L1 - sc, 0.0)
    big_end = (-sr, 0.0)
    common = dict(mu=model["mu"], e_N=model["e_N"], e_T=model["e_T"])
    for k, b in enumerate(balls):
        m.add_contact("outside", crank, pin, rA, b, (0.0, 0.0), rB, name=f"ball{k}-inner",
                      **common)
    for k, b in enumerate(balls):
        m.add_contact("inside", rod, big_end, rC, b, (0.0, 0.0), rB, name=f"ball{k}-outer",
                      **common)
    chord = 2.0 * pitch * np.sin(np.pi / n)
    for k in range(n):
        m.add_spring(balls[k], (0.0, 0.0), balls[(k + 1) % n], (0.0, 0.0),
                     model["cage_stiffness"], model["cage_damping"], rest_length=chord)
    layout = BearingLayout(crank, rod, slider, balls, pin, big_end, rC, pitch, cage, spin)
    return m, layout


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
                 poisson_ratio=0.3) -> Model:
    """A ball moving inside a fixed ring (the sphere-in-sphere element), starting at ``start``
    (default: the centre) [m] with velocity ``speed`` [m/s]."""
    m = Model(gravity=gravity, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio)
    b = m.add_body("ball", mass, 0.4 * mass * radius**2, q0=(start[0], start[1], 0.0),
                   v0=(speed[0], speed[1], 0.0))
    m.add_contact("inside", -1, (0.0, 0.0), ring_radius, b, (0.0, 0.0), radius, mu=mu, e_N=e_N,
                  name="ball-ring")
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
    rC = inner_radius + 2.0 * ball_radius
    pitch = inner_radius + ball_radius
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
