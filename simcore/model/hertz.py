"""The Hertz contact of two bodies of one material, and the hysteresis damping of the compliant
law: the one place these formulas are written (the model's contact elements, the stability
limits and the analysis of impacts all call them)."""

from __future__ import annotations

import numpy as np

DAMPING_LAWS = ("flores", "hunt_crossley", "lankarani_nikravesh")


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


def hertz_stiffness(kind: str, radius_a: float, radius_b: float, youngs_modulus: float,
                    poisson_ratio: float) -> float:
    """Hertz stiffness K = (4/3) E* sqrt(R_eff) [N m^-1.5] of a contact element, both bodies of
    the same material: E* = E / (2 (1 - nu^2)); R_eff = r_b on a plane, r_a r_b / (r_a + r_b)
    for a sphere on a sphere (convex), r_a r_b / (r_a - r_b) for a sphere inside a ring of
    radius r_a (concave)."""
    e_star = youngs_modulus / (2.0 * (1.0 - poisson_ratio**2))
    if kind == "plane":
        r_eff = radius_b
    elif kind == "outside":
        r_eff = radius_a * radius_b / (radius_a + radius_b)
    elif kind == "inside":
        r_eff = radius_a * radius_b / (radius_a - radius_b)
    else:
        raise ValueError(f"contact kind {kind!r} is not allowed; allowed: plane, outside, "
                         "inside")
    return 4.0 / 3.0 * e_star * np.sqrt(r_eff)
