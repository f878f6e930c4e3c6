"""Rating life of a ball bearing: ISO 281's basic rating life and a reference rating life from
the internal load distribution (Lundberg-Palmgren, in the spirit of ISO/TS 16281).

docs/life.md gives the formulas, their sources and the choices made for the planar model.

Units: forces in N, lengths of the rating formulas in mm (as the standards write them; the
functions here take metres and convert), lives in millions of revolutions (10^6 rev) of one ring
relative to the other, hours at a given speed.

ISO 281 basic rating life
-------------------------
L10 = (C / P)^3 for ball bearings, C the basic dynamic load rating, P the dynamic equivalent load.
For a load that varies, P is the cubic mean of the load weighted by the revolutions made under it,
P = (sum F_i^3 N_i / sum N_i)^(1/3) (:func:`equivalent_load`).

Lundberg-Palmgren raceway capacities and the reference rating life
------------------------------------------------------------------
Basic dynamic capacity of a raceway, point contact, contact angle 0 (gamma = D_w / D_pw; upper
signs inner race, lower signs outer race; N and mm):

    Q_c = 98.1 (2f / (2f - 1))^0.41 (1 -+ gamma)^1.39 / (1 +- gamma)^(1/3) gamma^0.3
          D_w^1.8 Z^(-1/3)                                                       (LP)

times ``rating_factor`` (default 1.3, ISO 281:2007's b_m for radial ball bearings). A raceway
whose every point sees the same load cycle (the ring rotates relative to the load) has the
equivalent ball load Q_e = (1/Z sum Q_j^3)^(1/3); one whose points each see their own load (the
ring stands still relative to the load) Q_e = (1/Z sum Q_j^(10/3))^(3/10). The raceway lives
L = (Q_c / Q_e)^3 combine over both races with the Weibull slope e = 10/9:

    L10r = (L_i^(-e) + L_e^(-e))^(-1/e).

:func:`reference_life_history` generalises both equivalent loads to any motion (the oscillating
outer race of a crank-rod big end): every raceway element counts the balls that roll over it and
their loads (Palmgren-Miner within the element), and the elements' Weibull survivals multiply.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._checks import positive

__all__ = ["LIFE_EXPONENT", "WEIBULL_SLOPE", "RATING_FACTOR", "equivalent_load",
           "revolution_weights", "basic_rating_life", "life_hours", "raceway_capacity",
           "reference_cycles_per_revolution", "bearing_capacity_lp", "RacewayLife",
           "reference_life_static", "reference_life_history", "combine_races",
           "STATIC_PRESSURE", "static_load_rating"]

LIFE_EXPONENT = 3.0          # p of L10 = (C/P)^p, ball bearings (ISO 281)
WEIBULL_SLOPE = 10.0 / 9.0   # e of the Lundberg-Palmgren survival, ball bearings
RATING_FACTOR = 1.3          # b_m of ISO 281:2007, radial ball bearings
LP_CONSTANT = 98.1           # Lundberg-Palmgren raceway constant, point contact [N, mm]
RACES = ("inner", "outer")
#: contact pressure at the centre of the most heavily loaded contact on which ISO 76 bases the
#: basic static load rating C0 of a ball bearing (self-aligning ones excepted) [Pa]
STATIC_PRESSURE = 4.2e9
#: Stribeck's share of the most heavily loaded ball, Q_max = 5 F_r / Z, as ISO 76 takes it [-]
STRIBECK_FACTOR = 5.0
#: bearing steel, for the static rating whatever the simulated material [Pa], [-]
STEEL_E, STEEL_NU = 2.08e11, 0.3


def _race(race):
    if race not in RACES:
        raise ValueError(f"race: {race!r} is not allowed; allowed: 'inner', 'outer'")
    return race


# -- ISO 281 ----------------------------------------------------------------------------------
def equivalent_load(load, weights=None, p: float = LIFE_EXPONENT) -> float:
    """Dynamic equivalent load of a varying load, P = (sum w_i F_i^p / sum w_i)^(1/p) [N].

    Parameters
    ----------
    load : array_like
        Radial load samples F_i [N] (magnitudes; the sign is dropped).
    weights : array_like, optional
        Revolutions made under each sample (:func:`revolution_weights`); default: equal.
    p : float
        Life exponent (3 for ball bearings).
    """
    F = np.abs(np.asarray(load, dtype=float)).ravel()
    if F.size == 0 or not np.all(np.isfinite(F)):
        raise ValueError("load: allowed: a non-empty array of finite forces [N]")
    w = np.ones_like(F) if weights is None else np.asarray(weights, dtype=float).ravel()
    if w.shape != F.shape or np.any(w < 0.0) or not w.sum() > 0.0:
        raise ValueError("weights: allowed: one weight >= 0 per load sample, not all zero")
    return float((np.sum(w * F**p) / np.sum(w)) ** (1.0 / p))


def revolution_weights(time, speed) -> np.ndarray:
    """Revolutions made under each sample of a history [rev].

    Sample k stands for the half intervals on either side of it (trapezoidal rule), so a
    constant speed weights the interior samples by dt and the two ends by dt/2.

    Parameters
    ----------
    time : array_like
        Sample times [s], increasing.
    speed : float or array_like
        Relative angular speed of the rings at each sample [rad/s] (its magnitude counts).
    """
    t = np.asarray(time, dtype=float)
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0.0):
        raise ValueError("time: allowed: at least two increasing sample times [s]")
    w = np.abs(np.broadcast_to(np.asarray(speed, dtype=float), t.shape))
    half = 0.5 * np.diff(t)
    dt = np.zeros_like(t)
    dt[:-1] += half
    dt[1:] += half
    return w * dt / (2.0 * np.pi)


def basic_rating_life(C: float, P: float) -> float:
    """ISO 281 basic rating life of a ball bearing, L10 = (C / P)^3 [10^6 rev].

    Parameters
    ----------
    C : float
        Basic dynamic load rating [N].
    P : float
        Dynamic equivalent load [N] (0 gives an infinite life).
    """
    C = positive("C", C)
    P = positive("P", P, allow_zero=True)
    return np.inf if P == 0.0 else (C / P) ** LIFE_EXPONENT


def life_hours(L10: float, speed: float) -> float:
    """A life in 10^6 revolutions as hours at the relative speed ``speed`` [rad/s]."""
    speed = positive("speed", abs(float(speed)))
    return float(L10) * 1e6 / (speed / (2.0 * np.pi)) / 3600.0


# -- static load rating (ISO 76) ------------------------------------------------------------------
def static_load_rating(ball_diameter: float, pitch_diameter: float, n_balls: int,
                       conformity_inner: float, conformity_outer: float,
                       pressure: float = STATIC_PRESSURE) -> float:
    """Basic static radial load rating C0 of a deep-groove ball bearing [N], from its
    definition in ISO 76: the radial load under which the most heavily loaded ball,
    Q_max = 5 C0 / Z (Stribeck), presses the more stressed raceway with ``pressure`` at the
    centre of its contact. The contacts are elliptical Hertz contacts of the grooves
    (:func:`analysis.contact_stress.elliptical_contact`) in bearing steel (E = 208 GPa,
    nu = 0.3); their pressure grows as Q^(1/3).

    Parameters
    ----------
    ball_diameter, pitch_diameter : float
        D_w, D_pw [m].
    n_balls : int
        Z.
    conformity_inner, conformity_outer : float
        Groove radius over ball diameter of each race [-], > 0.5.
    pressure : float
        [Pa] (default 4,200 MPa, ISO 76's for ball bearings).
    """
    from .contact_stress import contact_modulus, elliptical_contact, groove_radii

    r_b = positive("ball_diameter", ball_diameter) / 2.0
    r_p = positive("pitch_diameter", pitch_diameter) / 2.0
    pressure = positive("pressure", pressure)
    if not r_p > r_b:
        raise ValueError("ball_diameter / pitch_diameter: allowed: in (0, 1)")
    Z = int(n_balls)
    if Z < 1:
        raise ValueError(f"n_balls: {n_balls!r} is not allowed; allowed: >= 1")
    E_star = contact_modulus(STEEL_E, STEEL_NU)
    ball_load = np.inf
    for race, r_race, f in (("inner", r_p - r_b, conformity_inner),
                            ("outer", r_p + r_b, conformity_outer)):
        contact = elliptical_contact(*groove_radii(r_b, r_race, f, race), E_star)
        p_1N = float(contact.at(1.0)[3])  # the pressure under 1 N [Pa]
        ball_load = min(ball_load, (pressure / p_1N) ** 3)
    return Z * ball_load / STRIBECK_FACTOR


# -- Lundberg-Palmgren raceway capacities -------------------------------------------------------
def raceway_capacity(ball_diameter: float, pitch_diameter: float, conformity: float,
                     n_balls: int, race: str, rating_factor: float = RATING_FACTOR) -> float:
    """Basic dynamic capacity Q_c of a raceway, eq. (LP) of the module docstring [N].

    Parameters
    ----------
    ball_diameter : float
        D_w [m].
    pitch_diameter : float
        D_pw [m].
    conformity : float
        Groove radius over ball diameter f of this race [-], > 0.5.
    n_balls : int
        Z.
    race : {"inner", "outer"}
    rating_factor : float
        Factor on the Lundberg-Palmgren value (default 1.3, ISO 281:2007's b_m).

    Returns
    -------
    float
        The ball load [N] that this raceway survives, with 90 % reliability, for 10^6
        revolutions when it rotates relative to the load (one stress cycle per ball passing,
        :func:`reference_cycles_per_revolution`).
    """
    D = positive("ball_diameter", ball_diameter) * 1e3
    gamma = D / (positive("pitch_diameter", pitch_diameter) * 1e3)
    f = float(conformity)
    if not 0.5 < f < 1.0:
        raise ValueError(f"conformity: {conformity!r} is not allowed; allowed: in (0.5, 1)")
    if not 0.0 < gamma < 1.0:
        raise ValueError("ball_diameter / pitch_diameter: allowed: in (0, 1)")
    Z = int(n_balls)
    if Z < 1:
        raise ValueError(f"n_balls: {n_balls!r} is not allowed; allowed: >= 1")
    s = 1.0 if _race(race) == "inner" else -1.0
    return (positive("rating_factor", rating_factor) * LP_CONSTANT
            * (2.0 * f / (2.0 * f - 1.0)) ** 0.41
            * (1.0 - s * gamma) ** 1.39 / (1.0 + s * gamma) ** (1.0 / 3.0)
            * gamma**0.3 * D**1.8 * Z ** (-1.0 / 3.0))


def reference_cycles_per_revolution(ball_diameter: float, pitch_diameter: float, n_balls: int,
                                    race: str) -> float:
    """Balls rolling over a point of the raceway per relative revolution of the rings, pure
    rolling, contact angle 0: Z (1 + gamma)/2 inner race, Z (1 - gamma)/2 outer race [-].

    This is the cycle count behind Q_c's factor (1 +- gamma)^(-1/3) Z^(-1/3)."""
    gamma = positive("ball_diameter", ball_diameter) / positive("pitch_diameter",
                                                                  pitch_diameter)
    s = 1.0 if _race(race) == "inner" else -1.0
    return int(n_balls) * (1.0 + s * gamma) / 2.0


def bearing_capacity_lp(Q_ci: float, Q_ce: float, n_balls: int) -> float:
    """Lundberg-Palmgren's basic dynamic load rating of a radial ball bearing from its raceway
    capacities, C = 0.407 Z Q_ci (1 + (1.044 Q_ci / Q_ce)^(10/3))^(-0.3) [N].

    0.407 = J_r/J_1 and 1.044 = J_2/J_1 are the load-distribution integrals of a zero-clearance
    ring (J_r = 0.2288, J_1 = 0.5625, J_2 = 0.5875) computed here exactly; the inner ring rotates.
    """
    J_r, J_1, J_2 = _zero_clearance_integrals()
    ratio = J_2 / J_1 * Q_ci / Q_ce
    return int(n_balls) * J_r / J_1 * Q_ci * (1.0 + ratio ** (10.0 / 3.0)) ** -0.3


def _zero_clearance_integrals():
    """J_r = (1/2pi) int cos^(5/2), J_1 = ((1/2pi) int cos^(9/2))^(1/3) (cube mean of cos^(3/2)),
    J_2 = ((1/2pi) int cos^5)^(3/10), over the loaded half |psi| < pi/2."""
    from scipy.special import beta

    def mean_cos(power):  # (1/2pi) int_{-pi/2}^{pi/2} cos^power = B(1/2, (power+1)/2) / (2 pi)
        return beta(0.5, 0.5 * (power + 1.0)) / (2.0 * np.pi)

    return mean_cos(2.5), mean_cos(4.5) ** (1.0 / 3.0), mean_cos(5.0) ** 0.3


# -- reference rating life ----------------------------------------------------------------------
@dataclass(frozen=True)
class RacewayLife:
    """Lives of both raceways and of the bearing [10^6 rev], and the equivalent ball loads.

    Attributes
    ----------
    L_inner, L_outer, L10r : float
        Raceway lives and their Weibull combination (:func:`combine_races`) [10^6 rev].
    Q_e_inner, Q_e_outer : float
        Equivalent ball loads: the constant ball load, rolling over every point of the raceway
        as the reference kinematics do, that gives the same raceway life [N].
    """

    L_inner: float
    L_outer: float
    L10r: float
    Q_e_inner: float
    Q_e_outer: float


def combine_races(L_inner: float, L_outer: float, e: float = WEIBULL_SLOPE) -> float:
    """L10r = (L_i^(-e) + L_e^(-e))^(-1/e): both raceways must survive [10^6 rev]."""
    inv = sum(0.0 if np.isinf(L) else float(L) ** -e for L in (L_inner, L_outer))
    return np.inf if inv == 0.0 else inv ** (-1.0 / e)


def _life(Q_c, Q_e):
    return np.inf if Q_e == 0.0 else (Q_c / Q_e) ** LIFE_EXPONENT


def reference_life_static(ball_load, Q_ci: float, Q_ce: float,
                          rotating: str = "inner") -> RacewayLife:
    """Reference rating life of a static load distribution (one ring rotates relative to it).

    Parameters
    ----------
    ball_load : array_like, shape (Z,)
        Ball loads Q_j [N] (:func:`analysis.load_distribution.ball_loads`).
    Q_ci, Q_ce : float
        Raceway capacities [N] (:func:`raceway_capacity`).
    rotating : {"inner", "outer"}
        The ring that rotates relative to the load: its raceway takes the cubic mean
        (1/Z sum Q^3)^(1/3), the other one the (1/Z sum Q^(10/3))^(3/10) mean.
    """
    Q = np.asarray(ball_load, dtype=float)
    if Q.ndim != 1 or Q.size == 0 or np.any(Q < 0.0) or not np.all(np.isfinite(Q)):
        raise ValueError("ball_load: allowed: a 1-D array of finite loads >= 0 [N]")
    rotating_mean = np.mean(Q**3) ** (1.0 / 3.0)
    stationary_mean = np.mean(Q ** (3.0 * WEIBULL_SLOPE)) ** (1.0 / (3.0 * WEIBULL_SLOPE))
    if _race(rotating) == "inner":
        q_i, q_e = rotating_mean, stationary_mean
    else:
        q_i, q_e = stationary_mean, rotating_mean
    L_i, L_e = _life(Q_ci, q_i), _life(Q_ce, q_e)
    return RacewayLife(L_i, L_e, combine_races(L_i, L_e), float(q_i), float(q_e))


def _element_load_sums(ball_load, ball_angle, n_elements):
    """Sum of Q^3 of the balls rolling over each of ``n_elements`` equal raceway elements, and
    their number; a ball passes an element when its angle crosses the element's centre (either
    way), with the load interpolated linearly in angle at the crossing."""
    width = 2.0 * np.pi / n_elements
    sums = np.zeros(n_elements)
    counts = np.zeros(n_elements)
    for j in range(ball_angle.shape[1]):
        a = np.unwrap(ball_angle[:, j]) / width - 0.5  # element centres at integers
        q = ball_load[:, j]
        lo, hi = np.minimum(a[:-1], a[1:]), np.maximum(a[:-1], a[1:])
        first, last = np.floor(lo) + 1.0, np.floor(hi)  # centres crossed in (lo, hi]
        n = (last - first + 1.0).astype(np.int64)
        k = np.repeat(np.arange(a.size - 1), np.maximum(n, 0))
        if k.size == 0:
            continue
        offset = np.arange(k.size) - np.repeat(np.cumsum(np.maximum(n, 0)) - np.maximum(n, 0),
                                               np.maximum(n, 0))
        centre = first[k] + offset
        span = a[k + 1] - a[k]
        frac = np.where(span != 0.0, (centre - a[k]) / np.where(span != 0.0, span, 1.0), 0.0)
        load = q[k] + frac * (q[k + 1] - q[k])
        element = np.mod(centre, n_elements).astype(np.int64)
        np.add.at(sums, element, load**3)
        np.add.at(counts, element, 1.0)
    return sums, counts


def reference_life_history(ball_load, ball_angle, revolutions: float, Q_c: float,
                           cycles_per_revolution: float, n_elements: int = 720) -> tuple:
    """Life of one raceway [10^6 rev] from the ball loads and positions over a window.

    Parameters
    ----------
    ball_load : array_like, shape (n, Z)
        Load of each ball on this raceway at each sample [N].
    ball_angle : array_like, shape (n, Z)
        Angle of each ball in the raceway's own (rotating) frame [rad].
    revolutions : float
        Revolutions of one ring relative to the other over the window [rev], > 0: the life is
        counted in those.
    Q_c : float
        Raceway capacity [N] (:func:`raceway_capacity`).
    cycles_per_revolution : float
        Over-rollings of a raceway point per revolution in Q_c's reference kinematics
        (:func:`reference_cycles_per_revolution`).
    n_elements : int
        Raceway elements (equal arcs) over which the damage is counted.

    Returns
    -------
    L : float
        Raceway life [10^6 rev] (inf when nothing loaded it).
    Q_e : float
        Equivalent ball load [N]: the Q of (Q_c / Q)^3 = L.

    Notes
    -----
    Element b collects D_b = sum_passes (Q / Q_c)^3 / (u 10^6), its share of the raceway's life
    consumed over the window (Palmgren-Miner; u = ``cycles_per_revolution``); the raceway
    survives W windows with probability S, ln(1/S) = ln(1/0.9) W^e mean_b(D_b^e) (the elements'
    Weibull survivals multiply, each weighted by its share of the raceway), so
    L = revolutions W_10 / 10^6 with W_10 = mean_b(D_b^e)^(-1/e). A raceway rotating relative to
    a steady load gives (Q_c / Q_e)^3 with Q_e the cubic mean of the ball loads; a stationary
    one, the (10/3)-mean over its circumference.
    """
    Q = np.asarray(ball_load, dtype=float)
    psi = np.asarray(ball_angle, dtype=float)
    if Q.ndim != 2 or psi.shape != Q.shape or Q.shape[0] < 2:
        raise ValueError("ball_load, ball_angle: allowed: two arrays of the same shape "
                         "(n >= 2 samples, Z balls)")
    if np.any(Q < 0.0) or not np.all(np.isfinite(Q)) or not np.all(np.isfinite(psi)):
        raise ValueError("ball_load, ball_angle: allowed: finite values, loads >= 0")
    R_w = positive("revolutions", revolutions)
    Q_c = positive("Q_c", Q_c)
    u = positive("cycles_per_revolution", cycles_per_revolution)
    sums, _ = _element_load_sums(Q, psi, int(n_elements))
    damage = sums / (Q_c**3 * u * 1e6)
    e = WEIBULL_SLOPE
    consumed = np.mean(damage**e) ** (1.0 / e)
    if consumed == 0.0:
        return np.inf, 0.0
    L = R_w / consumed / 1e6
    return float(L), float(Q_c / L ** (1.0 / LIFE_EXPONENT))
