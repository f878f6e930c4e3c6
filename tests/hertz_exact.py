"""Hertz's exact elliptical contact, computed in the tests with SciPy: the reference the
model's and the analysis' elliptical contacts are held against."""

from __future__ import annotations

import math

from scipy.optimize import brentq
from scipy.special import ellipe, ellipk


def exact_ellipse(Rx, Ry, Es, F):
    """(k, a, b, delta, p_max) of the elliptical contact of reduced radii Rx <= Ry [m] and
    contact modulus Es [Pa] under the force F [N]: the ellipticity k from the transcendental
    equation k^2 = (2 K - E (1 + Rd)) / (E (1 - Rd)), Rd = R (1/Rx - 1/Ry), with SciPy's complete
    elliptic integrals of m = 1 - 1/k^2, then the semi-axes, the approach and the largest
    pressure."""
    R = 1 / (1 / Rx + 1 / Ry)
    Rd = R * (1 / Rx - 1 / Ry)

    def eq(k):
        m = 1 - 1 / k**2
        return k**2 - (2 * ellipk(m) - ellipe(m) * (1 + Rd)) / (ellipe(m) * (1 - Rd))

    k = brentq(eq, 1.0 + 1e-12, 200.0, xtol=1e-14)
    m = 1 - 1 / k**2
    Ep = 2 * Es
    E2, F1 = ellipe(m), ellipk(m)
    a = (6 * k**2 * E2 * F * R / (math.pi * Ep)) ** (1 / 3)
    b = (6 * E2 * F * R / (math.pi * k * Ep)) ** (1 / 3)
    d = F1 * (4.5 / (E2 * R) * (F / (math.pi * k * Ep)) ** 2) ** (1 / 3)
    return k, a, b, d, 3 * F / (2 * math.pi * a * b)
