"""Contact stresses and deformations of a ball on a race (Hertz's circles and ellipses).

Circular point contact (the simulation's in-plane sphere contact, model.contact_geometry plane)
-------------------------------------------------------------------------------------------
For two spheres pressed together by a force F [N], with effective radius R [m] (convex:
R = r1 r2/(r1 + r2); a ball inside a concave race: R = r1 r2/(r2 - r1)) and contact modulus
E* = 1/((1 - ν1²)/E1 + (1 - ν2²)/E2) [Pa], Hertz's solution gives

    a = (3 F R / (4 E*))^{1/3}       contact radius [m]
    δ = a² / R                         indentation (approach of the two centres) [m]
    p_max = 3 F / (2 π a²)             largest contact pressure, at the centre [Pa]

and F = (4/3) E* √R δ^{3/2} = K δ^{3/2}: the K of :func:`analysis.hertz_stiffness`.

Elliptical point contact of a grooved race
------------------------------------------
A real deep-groove race is curved across the groove too: groove radius r_g = f D (D = 2 r_B the
ball diameter, f the *conformity*, typically 0.52). The ball then touches the race on an ellipse.
With x along the rolling direction and y across the groove, the reduced radii are

    1/R_x = 1/r_B ± 1/r_race      (+ inner race, convex; - outer race, concave)
    1/R_y = 1/r_B - 1/r_g          (the groove is concave)
    1/R = 1/R_x + 1/R_y,   α = R_y / R_x  (> 1 in a ball bearing),

(R is the curvature-sum radius: for a circular contact, R_x = R_y, it is half the effective
radius of the sphere formulas above). Hertz's solution sets the ellipse by its eccentricity e,

    α = (Ɛ / (1 - e²) - F_1) / (F_1 - Ɛ)
    k = 1 / √(1 - e²)          ellipticity, semi-major / semi-minor axis
    Ɛ = E(e), F_1 = K(e)       complete elliptic integrals of the second and first kind

solved by :func:`simcore.model.hertz.ellipse_constants`, the model's own (default
``fit="exact"``). Hamrock & Brewe's (1983, J. Lubr. Technol. 105:171) closed forms k = α^{2/π},
Ɛ = 1 + (π/2 - 1)/α, F_1 = π/2 + (π/2 - 1) ln α (``fit="1983"``, within 4 % up to α = 30) and
the older curve fits of Brewe & Hamrock 1977, k = 1.0339 α^0.6360, Ɛ = 1.0003 + 0.5968/α,
F_1 = 1.5277 + 0.6023 ln α (``fit="1977"``) are there to reproduce published examples.
With E' = 2 E*:

    a_y = (6 k² Ɛ F R / (π E'))^{1/3}      semi-major axis (across the groove) [m]
    b_x = (6 Ɛ F R / (π k E'))^{1/3}        semi-minor axis (rolling direction) [m]
    δ = F_1 (9/(2 Ɛ R) (F/(π k E'))²)^{1/3}  indentation [m]
    p_max = 3 F / (2 π a_y b_x)              [Pa]

so δ ∝ F^{2/3} and F = K δ^{3/2} with K = π k E' √(2 Ɛ R / 9) / F_1^{3/2}.

At α = 1 (no groove curvature difference) these reduce to the circular contact exactly:
k = 1, Ɛ = F_1 = π/2 and a_y = b_x, δ, p_max are those of the circular contact with effective
radius R_x (checked by the tests). For the outer race that limit is a groove whose radius equals
the race radius, f = r_C/(2 r_B): a ball inside a spherical cavity, the simulation's in-plane
sphere-in-sphere contact. (For the inner race the in-plane contact would need a convex crown
across the race, not a groove.) A large conformity f → ∞ (flat groove floor) gives R_y → r_B,
close to circular for a race much larger than the ball.

Every function here is vectorised over F (NaN in, NaN out) and checks its settings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simcore.model.hertz import (
    ellipse_constants,
    ellipse_stiffness,
    groove_cross_radius,
    hamrock_brewe_constants,
)

from ._checks import poisson_ratio, positive
from .forces import effective_radius

__all__ = [
    "contact_modulus",
    "hertz_circular",
    "groove_radii",
    "EllipticalContact",
    "elliptical_contact",
    "contact_stress",
]

def contact_modulus(E1, nu1, E2=None, nu2=None) -> float:
    """Contact modulus E* = 1/((1 - ν1²)/E1 + (1 - ν2²)/E2) [Pa].

    Parameters
    ----------
    E1, E2 : float
        Young's moduli [Pa]; E2 defaults to E1.
    nu1, nu2 : float
        Poisson ratios [-]; nu2 defaults to nu1.

    Returns
    -------
    float
        E* [Pa].
    """
    E1 = positive("E1", E1)
    nu1 = poisson_ratio("nu1", nu1)
    E2 = E1 if E2 is None else positive("E2", E2)
    nu2 = nu1 if nu2 is None else poisson_ratio("nu2", nu2)
    return 1.0 / ((1.0 - nu1**2) / E1 + (1.0 - nu2**2) / E2)


def _forces(F):
    arr = np.asarray(F, dtype=float)
    if np.any(arr[np.isfinite(arr)] < 0.0):
        raise ValueError("F must be >= 0 (a contact force cannot pull)")
    return arr


def hertz_circular(F, R_eff, E_star):
    """Hertz circular point contact under the force F.

    Parameters
    ----------
    F : float or array_like
        Normal force [N], >= 0 (NaN passes through).
    R_eff : float
        Effective radius of curvature [m] (:func:`analysis.effective_radius`).
    E_star : float
        Contact modulus [Pa] (:func:`contact_modulus`).

    Returns
    -------
    a, delta, p_max : ndarray or float
        Contact radius [m], indentation [m], largest pressure [Pa] (0 at F = 0).
    """
    R_eff = positive("R_eff", R_eff)
    E_star = positive("E_star", E_star)
    F = _forces(F)
    a = np.cbrt(3.0 * F * R_eff / (4.0 * E_star))
    delta = a**2 / R_eff
    with np.errstate(invalid="ignore", divide="ignore"):
        p = np.where(a > 0.0, 3.0 * F / (2.0 * math.pi * np.where(a > 0.0, a, 1.0) ** 2), 0.0)
    p = np.where(np.isfinite(F), p, np.nan)
    if np.ndim(a) == 0:
        return float(a), float(delta), float(p)
    return a, delta, p


def groove_radii(ball_radius, race_radius, conformity, race="inner"):
    """Reduced radii R_x (rolling direction) and R_y (across the groove) of a ball on a race.

    Parameters
    ----------
    ball_radius : float
        r_B [m].
    race_radius : float
        Radius of the race's rolling track [m] (the inner race's outer radius, or the outer
        race's inner radius).
    conformity : float
        Groove radius over ball diameter, f = r_g / (2 r_B) [-], > 0.5.
    race : {"inner", "outer"}
        Convex (inner) or concave (outer) rolling track.

    Returns
    -------
    R_x, R_y : float
        [m].
    """
    r_b = positive("ball_radius", ball_radius)
    r_r = positive("race_radius", race_radius)
    f = positive("groove_conformity", conformity)
    if f <= 0.5:
        raise ValueError(f"groove_conformity must be > 0.5 (groove wider than the ball), got {f!r}")
    if race not in ("inner", "outer"):
        raise ValueError(f"race must be 'inner' or 'outer', got {race!r}")
    R_x = effective_radius(r_b, r_r, concave=(race == "outer"))
    return R_x, groove_cross_radius(r_b, 2.0 * f * r_b)


@dataclass(frozen=True)
class EllipticalContact:
    """Geometry constants of an elliptical Hertz contact (independent of the force).

    Attributes
    ----------
    R_x, R_y, R : float
        Reduced radii [m]: rolling direction, across the groove, 1/R = 1/R_x + 1/R_y.
    alpha : float
        Radius ratio R_y/R_x [-].
    k, E2, F1 : float
        Ellipticity and the complete elliptic integrals of the second and first kind [-].
    E_prime : float
        2 E* [Pa].
    K : float
        Stiffness of F = K δ^{3/2} [N m-1.5].
    """

    R_x: float
    R_y: float
    R: float
    alpha: float
    k: float
    E2: float
    F1: float
    E_prime: float
    K: float

    def at(self, F):
        """Semi-axes, indentation and largest pressure under the force F.

        Parameters
        ----------
        F : float or array_like
            Normal force [N], >= 0 (NaN passes through).

        Returns
        -------
        a_y, b_x, delta, p_max : ndarray or float
            Semi-major (across the groove; along the rolling direction where alpha < 1 with
            the exact solution) and semi-minor axes [m], indentation [m], largest pressure
            [Pa].
        """
        F = _forces(F)
        a_y = np.cbrt(6.0 * self.k**2 * self.E2 * F * self.R / (math.pi * self.E_prime))
        b_x = np.cbrt(6.0 * self.E2 * F * self.R / (math.pi * self.k * self.E_prime))
        delta = self.F1 * np.cbrt(4.5 / (self.E2 * self.R)
                                  * (F / (math.pi * self.k * self.E_prime)) ** 2)
        with np.errstate(invalid="ignore", divide="ignore"):
            ab = a_y * b_x
            p = np.where(ab > 0.0, 3.0 * F / (2.0 * math.pi * np.where(ab > 0.0, ab, 1.0)), 0.0)
        p = np.where(np.isfinite(F), p, np.nan)
        if np.ndim(a_y) == 0:
            return float(a_y), float(b_x), float(delta), float(p)
        return a_y, b_x, delta, p


def elliptical_contact(R_x, R_y, E_star, fit="exact") -> EllipticalContact:
    """Elliptical Hertz contact constants for reduced radii R_x, R_y.

    Parameters
    ----------
    R_x, R_y : float
        Reduced radii in the rolling direction and across it [m] (:func:`groove_radii`).
    E_star : float
        Contact modulus [Pa].
    fit : {"exact", "1983", "1977"}
        Hertz's solution (the model's contact stiffness); Hamrock & Brewe (1983)
        k = α^{2/π}, Ɛ = 1 + (π/2-1)/α, F = π/2 + (π/2-1) ln α; or the Brewe & Hamrock
        (1977) curve fits k = 1.0339 α^0.636, Ɛ = 1.0003 + 0.5968/α,
        F = 1.5277 + 0.6023 ln α (meant for α >= 1).

    Returns
    -------
    EllipticalContact
    """
    R_x = positive("R_x", R_x)
    R_y = positive("R_y", R_y)
    E_star = positive("E_star", E_star)
    alpha = R_y / R_x
    if fit == "exact":  # (alpha < 1, a groove flatter than the race: the same ellipse turned)
        k, E2, F1 = ellipse_constants(max(alpha, 1.0 / alpha))
    elif fit == "1983":
        k, E2, F1 = hamrock_brewe_constants(alpha)
    elif fit == "1977":
        k = 1.0339 * alpha**0.6360
        E2 = 1.0003 + 0.5968 / alpha
        F1 = 1.5277 + 0.6023 * math.log(alpha)
    else:
        raise ValueError(f"fit must be 'exact', '1983' or '1977', got {fit!r}")
    R = 1.0 / (1.0 / R_x + 1.0 / R_y)
    E_prime = 2.0 * E_star
    K = ellipse_stiffness(k, E2, F1, R, E_star)
    return EllipticalContact(R_x=R_x, R_y=R_y, R=R, alpha=alpha, k=k, E2=E2, F1=F1,
                             E_prime=E_prime, K=K)


def contact_stress(F, ball_radius, race_radius, race, E, nu, conformity=None, r_eff="concave"):
    """Contact size, indentation and largest pressure of a ball on a race under the force F.

    Parameters
    ----------
    F : float or array_like
        Normal force [N] (NaN passes through).
    ball_radius, race_radius : float
        [m].
    race : {"inner", "outer"}
        Which race (convex or concave track).
    E, nu : float
        Young's modulus [Pa] and Poisson ratio [-] of ball and race (same material).
    conformity : float or None
        Groove conformity f (e.g. 0.52) for the elliptical contact; None for the in-plane
        sphere contact (circular Hertz contact).
    r_eff : {"concave", "paper"}
        Effective radius of the outer race in the circular case (``"paper"``: the convex form the
        paper prints).

    Returns
    -------
    dict
        ``contact_radius`` [m] (the circle's radius, or the semi-major axis of the ellipse),
        ``semi_minor`` [m] (equal to contact_radius when circular), ``delta`` [m], ``p_max``
        [Pa] and ``K`` [N m-1.5], the stiffness of the contact model used.
    """
    E_star = contact_modulus(E, nu)
    if conformity is None:
        concave = race == "outer" and r_eff == "concave"
        R = effective_radius(ball_radius, race_radius, concave=concave)
        a, delta, p = hertz_circular(F, R, E_star)
        from simcore.model.hertz import stiffness

        K = stiffness(R, E_star)
        return {"contact_radius": a, "semi_minor": a, "delta": delta, "p_max": p, "K": K}
    R_x, R_y = groove_radii(ball_radius, race_radius, conformity, race)
    ell = elliptical_contact(R_x, R_y, E_star)
    a_y, b_x, delta, p = ell.at(F)
    return {"contact_radius": a_y, "semi_minor": b_x, "delta": delta, "p_max": p, "K": ell.K}
