"""Hertz's law of two elastic spheres, the one source of the contact stiffness used by the
model, its limits and the analysis; and the hysteresis damping factor of the compliant law.

Two spheres (or a sphere and a plane) of contact modulus E* pressed together by F indent by
delta with F = K delta^(3/2), K = (4/3) E* sqrt(R_eff):

- contact modulus E* = 1 / ((1 - nu_1^2)/E_1 + (1 - nu_2^2)/E_2), E / (2 (1 - nu^2)) for two
  bodies of the same material;
- effective radius of the model's contact elements (:data:`ELEMENT_KINDS`): ``plane``
  R_eff = r_b (a sphere on a plane), ``outside`` r_a r_b / (r_a + r_b) (sphere on sphere,
  convex), ``inside`` r_a r_b / (r_a - r_b) (sphere b inside the hollow sphere a, concave).

A ball in the groove of a real race is curved across the groove too (groove radius r_g, larger
than the ball's): the contact is an ellipse. With R_x the effective radius in the plane (as
above) and 1/R_y = 1/r_b - 1/r_g across the groove, alpha = R_y / R_x, Hertz's solution
(:func:`ellipse_constants`) sets the ellipse's eccentricity e (ellipticity k = 1/sqrt(1 - e^2),
semi-major over semi-minor axis) by

    alpha = (E(e) / (1 - e^2) - K(e)) / (K(e) - E(e)),

E and K the complete elliptic integrals of the second and first kind (Johnson, *Contact
Mechanics*, 4.2), and with 1/R = 1/R_x + 1/R_y the stiffness is
K = pi k 2 E* sqrt(2 E R / 9) / K(e)^(3/2) (:func:`elliptical_stiffness`; alpha = 1 gives the
circular contact's K). Hamrock & Brewe's (1983) closed forms k = alpha^(2/pi),
E = 1 + (pi/2 - 1)/alpha, K = pi/2 + (pi/2 - 1) ln alpha (:func:`hamrock_brewe_constants`)
approximate these within 4 % up to alpha 30 but 6.5 % at 100 (a conformity of 0.506 on the
6012's inner race); the analysis offers them for comparison with published examples.

The Numba kernels receive K per contact in ``ModelArrays.ct_hertz``
(:meth:`simcore.model.Model.arrays`); ``analysis.hertz_stiffness`` keeps its own signature
(two materials, a ``concave`` flag) and calls :func:`contact_modulus` and :func:`stiffness`
here: for one material it gives the model's K to the last digit.
"""

from __future__ import annotations

import math
from functools import lru_cache

#: Damping laws of the compliant contact model (:func:`damping_factor`).
DAMPING_LAWS = ("flores", "hunt_crossley", "lankarani_nikravesh")

#: Contact elements whose effective radius :func:`effective_radius` knows.
ELEMENT_KINDS = ("plane", "outside", "inside")


def contact_modulus(youngs_modulus: float, poisson_ratio: float,
                    youngs_modulus_2: float | None = None,
                    poisson_ratio_2: float | None = None) -> float:
    """Contact modulus E* [Pa] of two bodies.

    Parameters
    ----------
    youngs_modulus, poisson_ratio : float
        E_1 [Pa] and nu_1 [-] of the first body.
    youngs_modulus_2, poisson_ratio_2 : float, optional
        E_2 [Pa] and nu_2 [-] of the second body; default: the first body's material, for
        which E* = E / (2 (1 - nu^2)).

    Returns
    -------
    float
        E* [Pa].
    """
    e2 = youngs_modulus if youngs_modulus_2 is None else youngs_modulus_2
    nu2 = poisson_ratio if poisson_ratio_2 is None else poisson_ratio_2
    if e2 == youngs_modulus and nu2 == poisson_ratio:  # one material: the model's own digits
        return youngs_modulus / (2.0 * (1.0 - poisson_ratio**2))
    return 1.0 / ((1.0 - poisson_ratio**2) / youngs_modulus + (1.0 - nu2**2) / e2)


def effective_radius(kind: str, radius_a: float, radius_b: float) -> float:
    """Effective radius of curvature R_eff [m] of a contact element.

    Parameters
    ----------
    kind : {"plane", "outside", "inside"}
        The element (:data:`ELEMENT_KINDS`).
    radius_a : float
        Radius of the surface body a [m] (unused for a plane); for ``inside`` the hollow
        sphere's radius, larger than ``radius_b``.
    radius_b : float
        Radius of the sphere b [m].
    """
    if kind == "plane":
        return radius_b
    if kind == "outside":
        return radius_a * radius_b / (radius_a + radius_b)
    if kind == "inside":
        return radius_a * radius_b / (radius_a - radius_b)
    raise ValueError(f"contact kind {kind!r} is not allowed; allowed: "
                     + ", ".join(ELEMENT_KINDS))


#: the eccentricity solve of :func:`ellipse_constants` stops at this relative width of ln k ...
ELLIPSE_RTOL = 1e-14
#: ... and below this alpha - 1 takes its series, k = 1 + 2 (alpha - 1) / 3 - (alpha - 1)^2 / 9
#: (its error, O((alpha - 1)^3), under 1e-12; the bisection's there about 1e-12 too)
NEARLY_CIRCULAR = 1e-4


def complete_elliptic_integrals(m: float) -> tuple[float, float]:
    """Complete elliptic integrals of the first and second kind, K(m) and E(m) [-], of the
    parameter m = e^2 in [0, 1), by the arithmetic-geometric mean (Abramowitz & Stegun 17.6):
    exact to rounding, without importing SciPy (a grooved model is built at every run's
    start, and ``scipy.special`` costs a run 0.2-0.3 s to import; the tests hold these
    against it)."""
    a, b = 1.0, math.sqrt(1.0 - m)
    c2_sum, weight = 0.5 * m, 0.5  # sum of 2^(n - 1) c_n^2, c_0^2 = m
    for _ in range(40):  # converges quadratically: a handful of rounds to rounding
        if a - b <= 4e-16 * a:
            break
        c = 0.5 * (a - b)
        a, b = 0.5 * (a + b), math.sqrt(a * b)
        weight *= 2.0
        c2_sum += weight * c * c
    k1 = math.pi / (2.0 * a)
    return k1, k1 * (1.0 - c2_sum)


@lru_cache(maxsize=64)
def ellipse_constants(alpha: float) -> tuple[float, float, float]:
    """Hertz's elliptical contact of radius ratio ``alpha``: its ellipticity and complete
    elliptic integrals, from the eccentricity that solves
    alpha = (E / (1 - e^2) - K) / (K - E) (bisection on ln k, to :data:`ELLIPSE_RTOL`; the
    series k = 1 + 2 (alpha - 1) / 3 - (alpha - 1)^2 / 9 within :data:`NEARLY_CIRCULAR` of a
    circle).

    Parameters
    ----------
    alpha : float
        Radius ratio R_y / R_x of the two principal directions [-], >= 1.

    Returns
    -------
    k, E, F : float
        Ellipticity (semi-major over semi-minor axis) 1 / sqrt(1 - e^2), complete elliptic
        integrals of the second kind E(e) and of the first kind K(e) [-].
    """
    if not alpha >= 1.0:
        raise ValueError(f"alpha {alpha!r} must be >= 1 (the larger radius over the smaller)")

    def ratio(log_k):  # alpha of the ellipse of ellipticity exp(log_k), growing with it
        m = -math.expm1(-2.0 * log_k)  # e^2 = 1 - 1/k^2, exact for k near 1
        k1, e2 = complete_elliptic_integrals(m)
        return (e2 / (1.0 - m) - k1) / (k1 - e2)

    if alpha - 1.0 < NEARLY_CIRCULAR:
        # ratio() cancels there (its two differences are O(e^2)); from the series of K and E,
        # alpha = 1 + 3 e^2 / 4 + 21 e^4 / 32 + O(e^6)
        eps = alpha - 1.0
        log_k = math.log1p(2.0 / 3.0 * eps - eps * eps / 9.0)
    else:
        lo, hi = 0.0, math.log(alpha) + 1.0  # k <= e alpha: k grows as alpha^0.64
        while hi - lo > ELLIPSE_RTOL * hi:
            mid = 0.5 * (lo + hi)
            if ratio(mid) < alpha:
                lo = mid
            else:
                hi = mid
        log_k = 0.5 * (lo + hi)
    k1, e2 = complete_elliptic_integrals(-math.expm1(-2.0 * log_k))
    return math.exp(log_k), e2, k1


def hamrock_brewe_constants(alpha: float) -> tuple[float, float, float]:
    """Hamrock & Brewe (1983) closed forms of (k, E, F) of :func:`ellipse_constants`:
    alpha^(2/pi), 1 + (pi/2 - 1)/alpha and pi/2 + (pi/2 - 1) ln alpha [-] (within 4 % of
    Hertz's up to alpha 30; 6.5 % at 100, 23 % at 1000)."""
    q = math.pi / 2.0 - 1.0
    return (alpha ** (2.0 / math.pi), 1.0 + q / alpha, math.pi / 2.0 + q * math.log(alpha))


def elliptical_stiffness(r_x: float, r_y: float, e_star: float) -> float:
    """Hertz stiffness K [N m^-1.5] of an elliptical contact.

    F = K delta^(3/2) with K = pi k E' sqrt(2 E R / 9) / F^(3/2), E' = 2 E*,
    1/R = 1/R_x + 1/R_y and k, E, F of :func:`ellipse_constants` at alpha = R_y / R_x.

    Parameters
    ----------
    r_x, r_y : float
        Effective radii in the rolling direction and across it [m] (in either order: K is
        symmetric in them, and the constants are taken at alpha = larger / smaller).
    e_star : float
        Contact modulus E* [Pa].
    """
    r_x, r_y = min(r_x, r_y), max(r_x, r_y)  # (alpha >= 1)
    k, e2, f1 = ellipse_constants(r_y / r_x)
    return ellipse_stiffness(k, e2, f1, 1.0 / (1.0 / r_x + 1.0 / r_y), e_star)


def ellipse_stiffness(k: float, e2: float, f1: float, r: float, e_star: float) -> float:
    """K = pi k E' sqrt(2 E R / 9) / F^(3/2) [N m^-1.5], E' = 2 E*, of an elliptical contact
    of ellipticity ``k``, elliptic integrals ``e2`` (second kind) and ``f1`` (first kind) [-],
    curvature-sum radius ``r`` [m] and contact modulus ``e_star`` [Pa]."""
    return math.pi * k * 2.0 * e_star * math.sqrt(2.0 * e2 * r / 9.0) / f1**1.5


def groove_cross_radius(ball_radius: float, groove_radius: float) -> float:
    """Effective radius across a race groove, r_b r_g / (r_g - r_b) [m].

    Parameters
    ----------
    ball_radius : float
        r_b [m].
    groove_radius : float
        Groove radius r_g [m], larger than ``ball_radius`` (f D_w, f the conformity).
    """
    if not groove_radius > ball_radius:
        raise ValueError(f"groove radius {groove_radius!r} m must be larger than the ball's "
                         f"radius {ball_radius!r} m (conformity > 0.5)")
    return ball_radius * groove_radius / (groove_radius - ball_radius)


def stiffness(r_eff: float, e_star: float) -> float:
    """Hertz stiffness K = (4/3) E* sqrt(R_eff) [N m^-1.5] from the effective radius [m] and
    the contact modulus [Pa]."""
    return 4.0 / 3.0 * e_star * math.sqrt(r_eff)


def hertz_stiffness(kind: str, radius_a: float, radius_b: float, youngs_modulus: float,
                    poisson_ratio: float, groove_radius: float | None = None) -> float:
    """Hertz stiffness K [N m^-1.5] of a contact element, both bodies of the same material.

    Parameters
    ----------
    kind : {"plane", "outside", "inside"}
        The element (see :func:`effective_radius`).
    radius_a, radius_b : float
        Radii of body a (surface) and sphere b [m].
    youngs_modulus : float
        E [Pa].
    poisson_ratio : float
        nu [-].
    groove_radius : float, optional
        Radius of a groove across the surface a [m] (larger than ``radius_b``): the elliptical
        contact of a ball in its race's groove (:func:`elliptical_stiffness`); None: the
        circular contact of the sphere in the plane of the element.
    """
    r_x = effective_radius(kind, radius_a, radius_b)
    e_star = contact_modulus(youngs_modulus, poisson_ratio)
    if groove_radius is None:
        return stiffness(r_x, e_star)
    return elliptical_stiffness(r_x, groove_cross_radius(radius_b, groove_radius), e_star)


def deflection(force: float, stiffness_K: float) -> float:
    """Indentation delta = (F / K)^(2/3) [m] of a Hertz contact of stiffness K [N m^-1.5]
    under the force F [N] (0 for F <= 0)."""
    return (force / stiffness_K) ** (2.0 / 3.0) if force > 0.0 else 0.0


def damping_factor(e_N: float, law: str = "flores") -> float:
    """Hysteresis damping factor chi of F = K delta^1.5 (1 + chi delta_dot / v_pre) [-].

    flores: 8 (1 - e) / (5 e); hunt_crossley: 3 (1 - e) / 2; lankarani_nikravesh:
    3 (1 - e^2) / 4. The Flores law is undefined for e = 0 (refused)."""
    e = float(e_N)
    if law == "flores":
        if e <= 0.0:
            raise ValueError("model.e_N: 0 is not allowed with model.damping_law = flores "
                             "(chi = 8 (1 - e) / (5 e) is infinite); allowed: (0, 1], or "
                             "damping_law hunt_crossley or lankarani_nikravesh")
        return 8.0 * (1.0 - e) / (5.0 * e)
    if law == "hunt_crossley":
        return 1.5 * (1.0 - e)
    if law == "lankarani_nikravesh":
        return 0.75 * (1.0 - e * e)
    raise ValueError(f"model.damping_law: {law!r} is not allowed; allowed: "
                     + ", ".join(DAMPING_LAWS))
