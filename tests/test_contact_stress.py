"""Hertz contact stresses (circular) and Hamrock-Brewe elliptical contacts against closed forms,
the exact elliptic-integral Hertz solution and a published worked example."""

import math

import numpy as np
import pytest
from hertz_exact import exact_ellipse

from analysis import hertz_stiffness
from analysis.contact_stress import (
    contact_modulus,
    contact_stress,
    elliptical_contact,
    groove_radii,
    hertz_circular,
)

E, NU = 2.1e11, 0.3
R_B, R_A = 0.0055, 0.033745
R_C = R_A + 2 * R_B + 4e-4


def test_contact_modulus():
    assert contact_modulus(E, NU) == pytest.approx(E / (2 * (1 - NU**2)), rel=1e-14)
    assert contact_modulus(2e11, 0.3, 7e10, 0.33) == pytest.approx(
        1 / ((1 - 0.09) / 2e11 + (1 - 0.33**2) / 7e10), rel=1e-14)
    with pytest.raises(ValueError, match="nu1"):
        contact_modulus(E, 0.7)


@pytest.mark.parametrize("race", ["inner", "outer"])
@pytest.mark.parametrize("F", [1.0, 1e3, 5e4])
def test_sphere_on_sphere_and_in_sphere_satisfy_hertz(race, F):
    """F = K δ^{3/2} with the K of hertz_stiffness; p_max = 3F/(2πa²); a² = R δ; the mean
    pressure F/(πa²) is 2/3 of p_max; and the indentation from the gap geometry: the surfaces of
    two spheres at distance r from the axis separate by r²/(2R), so at r = a the Hertz
    displacement field (p_max π/(4E*))(2a² - r²)/a summed with the gap equals δ."""
    r_race = R_A if race == "inner" else R_C
    concave = race == "outer"
    R = r_race * R_B / (abs(r_race - R_B) if concave else (r_race + R_B))
    Es = contact_modulus(E, NU)
    out = contact_stress(F, R_B, r_race, race, E, NU)
    a, d, p = out["contact_radius"], out["delta"], out["p_max"]
    K = hertz_stiffness(R_B, r_race, E, NU, E, NU, concave=concave)
    assert out["K"] == pytest.approx(K, rel=1e-12)
    assert F == pytest.approx(K * d**1.5, rel=1e-12)
    assert p == pytest.approx(3 * F / (2 * math.pi * a**2), rel=1e-12)
    assert a**2 == pytest.approx(R * d, rel=1e-12)
    # surface displacement of the Hertz pressure at r = a, plus the initial gap a²/(2R), = δ
    u_a = p * math.pi / (4 * Es) * a  # (p π/(4E*)) (2a² - a²)/a
    assert u_a + a**2 / (2 * R) == pytest.approx(d, rel=1e-12)
    # pressure integral: ∫ p_max √(1 - r²/a²) 2πr dr = (2/3) p_max π a² = F
    assert 2 / 3 * p * math.pi * a**2 == pytest.approx(F, rel=1e-12)


def test_circular_vectorised_nan_and_zero():
    a, d, p = hertz_circular(np.array([0.0, np.nan, 100.0]), 5e-3, 1e11)
    assert a[0] == 0 and d[0] == 0 and p[0] == 0
    assert np.isnan(a[1]) and np.isnan(p[1])
    assert p[2] > 0
    with pytest.raises(ValueError, match="F must be >= 0"):
        hertz_circular(-1.0, 5e-3, 1e11)


def test_elliptical_reduces_to_circular_at_equal_radii():
    """α = 1: k = 1, Ɛ = F = π/2; semi-axes, indentation, p_max and K equal the circular ones."""
    Es = contact_modulus(E, NU)
    Rx = 4e-3
    ell = elliptical_contact(Rx, Rx, Es)
    assert ell.k == 1.0 and ell.E2 == pytest.approx(math.pi / 2) and ell.F1 == pytest.approx(
        math.pi / 2)
    for F in (10.0, 3e3):
        a_y, b_x, d, p = ell.at(F)
        a, dc, pc = hertz_circular(F, Rx, Es)
        assert a_y == pytest.approx(a, rel=1e-12) and b_x == pytest.approx(a, rel=1e-12)
        assert d == pytest.approx(dc, rel=1e-12) and p == pytest.approx(pc, rel=1e-12)
    assert ell.K == pytest.approx(4 / 3 * Es * math.sqrt(Rx), rel=1e-12)


def test_outer_groove_as_wide_as_the_race_is_the_in_plane_contact():
    """Stated limit: conformity f = r_C/(2 r_B) makes the groove a spherical cavity of the race's
    radius, i.e. the simulation's sphere-in-sphere contact."""
    f = R_C / (2 * R_B)
    ell = contact_stress(2e3, R_B, R_C, "outer", E, NU, conformity=f)
    circ = contact_stress(2e3, R_B, R_C, "outer", E, NU)
    for key in ("contact_radius", "semi_minor", "delta", "p_max", "K"):
        assert ell[key] == pytest.approx(circ[key], rel=1e-12)


@pytest.mark.parametrize("race", ["inner", "outer"])
@pytest.mark.parametrize("f", [0.515, 0.52, 0.53, 0.57, 1.0])
def test_hamrock_brewe_againstexact_ellipse(race, f):
    """The 1983 approximations against the exact solution, for the SKF 6012 geometry:
    ellipticity within 4 %, semi-axes, indentation and p_max within 3 % (measured: k up to
    3.8 % low near α = 7-10, p_max up to 1.6 % high)."""
    Es = contact_modulus(E, NU)
    r_race = R_A if race == "inner" else R_C
    Rx, Ry = groove_radii(R_B, r_race, f, race)
    ell = elliptical_contact(Rx, Ry, Es, fit="1983")
    F = 2.0e3
    k, a, b, d, p = exact_ellipse(Rx, Ry, Es, F)
    a_y, b_x, dd, pp = ell.at(F)
    assert ell.k == pytest.approx(k, rel=0.04)
    assert a_y == pytest.approx(a, rel=0.03) and b_x == pytest.approx(b, rel=0.03)
    assert dd == pytest.approx(d, rel=0.03) and pp == pytest.approx(p, rel=0.03)
    assert F == pytest.approx(ell.K * dd**1.5, rel=1e-12)


@pytest.mark.parametrize("race", ["inner", "outer"])
@pytest.mark.parametrize("f", [0.5005, 0.506, 0.515, 0.52, 0.53, 0.57, 1.0, 8.0])
def test_the_default_isexact_ellipse(race, f):
    """The default contact (the model's constants) against this module's exact solution (a
    root in the ellipticity, SciPy's elliptic integrals): ellipticity, semi-axes, indentation
    and p_max to 1e-9, from a nearly closed groove (alpha ~ 1000) to one flatter than the
    outer race (f = 8, alpha < 1: the ellipse's long axis along the rolling direction)."""
    Es = contact_modulus(E, NU)
    r_race = R_A if race == "inner" else R_C
    Rx, Ry = groove_radii(R_B, r_race, f, race)
    ell = elliptical_contact(Rx, Ry, Es)
    F = 2.0e3
    k, a, b, d, p = exact_ellipse(min(Rx, Ry), max(Rx, Ry), Es, F)
    a_y, b_x, dd, pp = ell.at(F)
    assert ell.k == pytest.approx(k, rel=1e-9)
    assert a_y == pytest.approx(a, rel=1e-9) and b_x == pytest.approx(b, rel=1e-9)
    assert dd == pytest.approx(d, rel=1e-9) and pp == pytest.approx(p, rel=1e-9)


def test_published_worked_example_6206():
    """Worked example of eng-tools.dev, "A2 Hertz contact" (Series A, bearing 6206), which uses
    the Brewe-Hamrock closed forms: ball 9.525 mm, inner groove radius 4.89 mm, pitch diameter
    46.0 mm, 9 balls, contact angle 0, E = 210 GPa, ν = 0.3, radial load 1000 N on the most
    loaded ball with Stribeck's share 5 F_r/Z. Published: E* = 115.4 GPa, R_eq = 3.700 mm,
    k = 12.19, a x b = 1.368 x 0.112 mm, p_0 = 1728 MPa. Compared at the printed precision
    (half a unit of the last printed digit)."""
    d_ball, r_groove, d_pitch = 9.525e-3, 4.89e-3, 46.0e-3
    r_b = d_ball / 2
    r_inner_track = (d_pitch - d_ball) / 2
    F = 5 * 1000.0 / 9
    Es = contact_modulus(210e9, 0.3)
    Rx, Ry = groove_radii(r_b, r_inner_track, r_groove / d_ball, "inner")
    ell = elliptical_contact(Rx, Ry, Es, fit="1977")
    a_y, b_x, _, p = ell.at(F)
    assert Es / 1e9 == pytest.approx(115.4, abs=0.05)
    assert ell.R * 1e3 == pytest.approx(3.700, abs=0.0005)
    assert ell.k == pytest.approx(12.19, abs=0.005)
    assert a_y * 1e3 == pytest.approx(1.368, abs=0.0005)
    assert b_x * 1e3 == pytest.approx(0.112, abs=0.0005)
    assert p / 1e6 == pytest.approx(1728, abs=0.5)


def test_bad_settings():
    with pytest.raises(ValueError, match="groove_conformity"):
        groove_radii(R_B, R_A, 0.5, "inner")
    with pytest.raises(ValueError, match="race"):
        groove_radii(R_B, R_A, 0.52, "middle")
    with pytest.raises(ValueError, match="fit"):
        elliptical_contact(1e-3, 2e-2, 1e11, fit="1990")
