"""Static load distribution of a ball ring under a radial load (Stribeck; Sjövall).

A ring of Z balls at angles psi_j [rad] sits between an inner and an outer race with radial
clearance g [m], the model's clearance: the free play of one ball when the rings are concentric,
g = r_C - r_A - 2 r_B (docs/model.md). A radial load F_r [N] displaces the inner ring by delta_r
[m] relative to the outer ring, towards the load angle psi_L. To first order in delta_r / R_pitch
ball j is then compressed by

    delta_j = delta_r cos(psi_j - psi_L) - g                                   (1)

(positive: both contacts closed and indented; negative: the ball has play). Each ball is two Hertz
contacts in series (inner convex, outer concave), so its load is

    Q_j = K_s max(delta_j, 0)^(3/2),   K_s = (K_in^(-2/3) + K_out^(-2/3))^(-3/2)   (2)

and the equilibrium of the ring along the load,

    F_r = sum_j Q_j cos(psi_j - psi_L),                                        (3)

fixes delta_r. The right side of (3) is continuous and nondecreasing in delta_r, zero up to
delta_r = g / max_j cos(psi_j - psi_L) and strictly increasing after it, so the root is unique and
bracketed (see :func:`ball_loads`); it is found with Brent's method. The transverse balance
(sum Q_j sin(psi_j - psi_L) = 0) holds for a ring symmetric about the load line; otherwise the
displacement would also turn sideways, a second-order effect this one-dimensional model leaves
out (docs/life.md).

At zero clearance with a ball under the load, Q_max = F_r / sum_{cos > 0} cos^(5/2)(psi_j - psi_L):
Stribeck's Q_max -> 4.370 F_r / Z for large Z (:func:`stribeck_factor`). At a clearance large
against the deflection, one ball (the one nearest the load line) carries F_r / cos of its angle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from ._checks import positive
from .forces import hertz_stiffness
from .impacts import series_stiffness

__all__ = ["LoadDistribution", "ball_loads", "ball_stiffness", "ring_angles", "stribeck_factor",
           "ball_loads_history"]


@dataclass(frozen=True)
class LoadDistribution:
    """Result of :func:`ball_loads`.

    Attributes
    ----------
    delta_r : float
        Radial displacement of the inner ring relative to the outer ring, along the load [m].
    Q : numpy.ndarray
        Load of every ball [N], in the order of the angles given.
    compression : numpy.ndarray
        delta_j of eq. (1) [m] (negative: the ball's play left).
    load_angle : float
        Direction psi_L of the load [rad].
    """

    delta_r: float
    Q: np.ndarray
    compression: np.ndarray
    load_angle: float

    @property
    def q_max(self) -> float:
        """Largest ball load [N]."""
        return float(self.Q.max())

    @property
    def n_loaded(self) -> int:
        """Number of balls that carry load."""
        return int(np.count_nonzero(self.Q > 0.0))


def ring_angles(n_balls: int, phase: float = 0.0) -> np.ndarray:
    """Angles of ``n_balls`` evenly spaced balls, the first at ``phase`` [rad]."""
    n = int(n_balls)
    if n < 1:
        raise ValueError(f"n_balls: {n_balls!r} is not allowed; allowed: an integer >= 1")
    return float(phase) + 2.0 * np.pi * np.arange(n) / n


def ball_stiffness(ball_radius: float, inner_radius: float, clearance: float,
                   youngs_modulus: float, poisson_ratio: float) -> tuple[float, float, float]:
    """Hertz stiffnesses of one ball of the model's bearing [N m^-1.5].

    Parameters
    ----------
    ball_radius : float
        r_B [m].
    inner_radius : float
        Inner race contact radius r_A [m].
    clearance : float
        Radial clearance g [m]; the outer race radius is r_C = r_A + 2 r_B + g.
    youngs_modulus : float
        E of balls and races [Pa].
    poisson_ratio : float
        nu of balls and races [-].

    Returns
    -------
    K_in, K_out, K_s : float
        Inner (convex sphere on sphere), outer (ball inside the race, concave) and the two in
        series (eq. 2 of the module docstring), as the simulation's in-plane contact elements
        use them (``model.contact_geometry: plane``; the grooves' K: ``run_geometry`` of
        :mod:`analysis.impacts`).
    """
    r_b = positive("ball_radius", ball_radius)
    r_a = positive("inner_radius", inner_radius)
    g = positive("clearance", clearance, allow_zero=True)
    r_c = r_a + 2.0 * r_b + g
    E = youngs_modulus
    nu = poisson_ratio
    k_in = hertz_stiffness(r_b, r_a, E, nu, E, nu, concave=False)
    k_out = hertz_stiffness(r_b, r_c, E, nu, E, nu, concave=True)
    return k_in, k_out, series_stiffness(k_in, k_out)


def _ring_force(delta_r, cos_j, clearance, K_s):
    compression = delta_r * cos_j - clearance
    return K_s * np.sum(np.maximum(compression, 0.0) ** 1.5 * cos_j)


def ball_loads(F_r: float, ball_angles, clearance: float, K_s: float,
               load_angle: float = 0.0) -> LoadDistribution:
    """Ball loads of a ring under the radial load ``F_r`` (eqs. 1 to 3 of the module docstring).

    Parameters
    ----------
    F_r : float
        Radial load [N], >= 0 (0 gives no load and delta_r = 0).
    ball_angles : array_like
        Angles psi_j of the ball centres [rad], in the frame of ``load_angle``.
    clearance : float
        Radial clearance g of the model (the play of one ball, rings concentric) [m], >= 0.
    K_s : float
        Stiffness of one ball, both contacts in series [N m^-1.5] (:func:`ball_stiffness`).
    load_angle : float
        Direction psi_L [rad] towards which the load pushes the inner ring (relative to the outer
        ring): the balls near psi_L carry it.

    Returns
    -------
    LoadDistribution

    Notes
    -----
    The root of eq. (3) is bracketed by delta_lo = g / c_max (no ball loaded yet) and
    delta_hi = (g + (F_r / (K_s c_max))^(2/3)) / c_max, where the ball nearest the load alone
    already carries F_r (c_max = max_j cos(psi_j - psi_L) > 0); Brent's method then converges to
    the relative tolerance of the floating-point numbers.
    """
    F_r = positive("F_r", F_r, allow_zero=True)
    g = positive("clearance", clearance, allow_zero=True)
    K_s = positive("K_s", K_s)
    psi = np.atleast_1d(np.asarray(ball_angles, dtype=float))
    if psi.ndim != 1 or psi.size == 0 or not np.all(np.isfinite(psi)):
        raise ValueError("ball_angles: allowed: a non-empty 1-D array of finite angles [rad]")
    cos_j = np.cos(psi - float(load_angle))
    c_max = float(cos_j.max())
    if F_r == 0.0:
        return LoadDistribution(0.0, np.zeros_like(psi), -g * np.ones_like(psi),
                                float(load_angle))
    if c_max <= 1e-12:
        raise ValueError("ball_angles: no ball lies within 90 degrees of the load direction; "
                         "allowed: a ring with a ball on the loaded side")
    lo = g / c_max
    # 1e-9 above the bound: f(hi) > F_r strictly, whatever the rounding of the one-ball case
    hi = (g + (F_r / (K_s * c_max)) ** (2.0 / 3.0)) / c_max * (1.0 + 1e-9)
    delta_r = brentq(lambda d: _ring_force(d, cos_j, g, K_s) - F_r, lo, hi,
                     xtol=1e-15 * hi, rtol=4.0 * np.finfo(float).eps, maxiter=200)
    compression = delta_r * cos_j - g
    Q = K_s * np.maximum(compression, 0.0) ** 1.5
    return LoadDistribution(float(delta_r), Q, compression, float(load_angle))


def ball_loads_history(force, ball_angles, clearance: float, K_s: float):
    """Ball loads for a sequence of load vectors and ring positions.

    Parameters
    ----------
    force : array_like, shape (n, 2)
        Load vectors (F_x, F_y) [N] in the frame of the ball angles; their direction is the
        load angle psi_L of each sample.
    ball_angles : array_like, shape (n, Z) or (Z,)
        Ball angles [rad] at each sample (or fixed).
    clearance, K_s : float
        As in :func:`ball_loads`.

    Returns
    -------
    Q : numpy.ndarray, shape (n, Z)
        Ball loads [N].
    delta_r : numpy.ndarray, shape (n,)
        Displacement of the inner ring along each load [m].
    """
    force = np.asarray(force, dtype=float)
    if force.ndim != 2 or force.shape[1] != 2:
        raise ValueError(f"force: shape {force.shape} is not allowed; allowed: (n, 2)")
    n = force.shape[0]
    psi = np.asarray(ball_angles, dtype=float)
    psi = np.broadcast_to(psi, (n, psi.shape[-1]))
    Q = np.zeros(psi.shape)
    delta_r = np.zeros(n)
    for k in range(n):
        F = float(np.hypot(force[k, 0], force[k, 1]))
        dist = ball_loads(F, psi[k], clearance, K_s, np.arctan2(force[k, 1], force[k, 0]))
        Q[k] = dist.Q
        delta_r[k] = dist.delta_r
    return Q, delta_r


def stribeck_factor(n_balls: int, straddle: bool = False) -> float:
    """Z Q_max / F_r of a ring at zero clearance (Stribeck's factor; ~4.37 for large Z).

    At g = 0, delta_j = delta_r cos psi_j, so Q_j = Q_max cos^(3/2) psi_j on the loaded half and
    F_r = Q_max sum cos^(5/2) psi_j: Z Q_max / F_r = Z / sum_{cos psi_j > 0} cos^(5/2) psi_j.

    Parameters
    ----------
    n_balls : int
        Z.
    straddle : bool
        False: a ball under the load (psi_j = 2 pi j / Z); True: the load between two balls
        (psi_j = pi (2 j + 1) / Z); Q_max is then the load of the two balls nearest the load.
    """
    psi = ring_angles(n_balls, np.pi / n_balls if straddle else 0.0)
    c = np.cos(psi)
    c = c[c > 0.0]
    return float(n_balls * c.max() ** 1.5 / np.sum(c**2.5))
