"""Ball-race contacts in grooves (model.contact_geometry groove): the elliptical Hertz stiffness
against Hertz's exact solution, its circular limit, an undamped impact in a grooved ring against
the closed form, the configuration keys, and the analysis taking the run's own grooves.

Hertz's exact elliptical contact (Johnson, Contact Mechanics, §3.5), computed here with SciPy's
complete elliptic integrals K(e), E(e) of the eccentricity e of the contact ellipse (semi-axes
a >= b, b = a sqrt(1 - e^2), a across the groove): the gap x^2/(2 R_x) + y^2/(2 R_y) fixes e by

    R_y / R_x = ((a/b)^2 E - K) / (K - E),

the load P the size a^3 = 3 P R_y (K - E) / (pi E* e^2), and the approach is
delta = p0 b K / E* with p0 = 3 P / (2 pi a b); so K_Hertz = P / delta^(3/2).
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

import simcore
from simcore.cli import bearing_line
from simcore.config import ConfigError, load_config
from simcore.model import SolverSettings
from simcore.model.bearing import race_grooves
from simcore.model.builder import Model
from simcore.model.hertz import (
    complete_elliptic_integrals,
    contact_modulus,
    effective_radius,
    ellipse_constants,
    ellipse_stiffness,
    elliptical_stiffness,
    hamrock_brewe_constants,
    hertz_stiffness,
    stiffness,
)
from simcore.model.mechanism import ball_in_ring, crank_slider

E_STEEL, NU = 2.1e11, 0.3


def exact_stiffness(r_x, r_y, e_star, load=1.0):
    """K [N m^-1.5] of Hertz's exact elliptical contact (module docstring), r_y > r_x."""
    alpha = r_y / r_x

    def shape(m):  # m = e^2
        k, e = ellipk(m), ellipe(m)
        return (e / (1.0 - m) - k) / (k - e) - alpha

    m = brentq(shape, 1e-12, 1.0 - 1e-15, xtol=1e-17)
    k, e = ellipk(m), ellipe(m)
    a = (3.0 * load * r_y * (k - e) / (math.pi * e_star * m)) ** (1.0 / 3.0)
    b = a * math.sqrt(1.0 - m)
    delta = 3.0 * load / (2.0 * math.pi * a * b) * b * k / e_star
    return load / delta**1.5


@pytest.mark.parametrize("alpha", [1.001, 1.5, 3.2, 15.5, 30.0, 100.0, 1000.0, 1e5])
def test_elliptical_stiffness_is_hertz_exact(alpha):
    """The model's elliptical K against the exact solution of this module (SciPy's elliptic
    integrals, a root in e^2): to 1e-9 from nearly circular to very slender ellipses. The
    radii may come in either order (alpha < 1: the ellipse turned by a right angle)."""
    e_star = contact_modulus(E_STEEL, NU)
    r_x = 5e-3
    K = elliptical_stiffness(r_x, alpha * r_x, e_star)
    assert K == pytest.approx(exact_stiffness(r_x, alpha * r_x, e_star), rel=1e-9)
    assert elliptical_stiffness(alpha * r_x, r_x, e_star) == pytest.approx(K, rel=1e-12)


@pytest.mark.parametrize("eps", [1e-14, 1e-10, 1e-6, 9.9e-5, 1.01e-4, 1e-3])
def test_a_nearly_circular_contact_has_the_ellipticity_of_its_series(eps):
    """Near a circle alpha = 1 + 3 m / 4 + 21 m^2 / 32 (m = e^2, from the series of K(m) and
    E(m)), so k = 1 + 2 eps / 3 - eps^2 / 9 + O(eps^3) with eps = alpha - 1: the model's
    ellipticity on both sides of its switch from that series to the bisection (where the ratio
    of elliptic integrals cancels), and K the circular one to O(eps^2)."""
    k = ellipse_constants(1.0 + eps)[0]
    assert k == pytest.approx(1.0 + 2.0 * eps / 3.0 - eps * eps / 9.0, rel=0, abs=eps**3 + 1e-15)
    r_x = 5e-3
    K = elliptical_stiffness(r_x, r_x * (1.0 + eps), 1e11)
    assert K == pytest.approx(stiffness(r_x * (1.0 + eps) / (1.0 + eps / 2.0), 1e11),
                              rel=eps * eps + 1e-15)


@pytest.mark.parametrize("m", [0.0, 1e-12, 1e-6, 0.3, 0.9, 0.999999, 1.0 - 1e-12])
def test_complete_elliptic_integrals_against_scipy(m):
    """The model's arithmetic-geometric mean against SciPy's K(m) and E(m)."""
    k1, e2 = complete_elliptic_integrals(m)
    assert k1 == pytest.approx(ellipk(m), rel=1e-14)
    assert e2 == pytest.approx(ellipe(m), rel=1e-14)


@pytest.mark.parametrize("alpha, tol", [(1.5, 0.03), (2.0, 0.04), (3.2, 0.04), (5.0, 0.04),
                                        (10.0, 0.03), (15.5, 0.015), (30.0, 0.015),
                                        (100.0, 0.07), (1000.0, 0.25)])
def test_hamrock_brewe_against_hertz_exact(alpha, tol):
    """Hamrock & Brewe's closed forms (the analysis' ``fit="1983"``) against the exact
    solution: within 3.9 % from alpha 1 to 30, the most near 3.2 (a deep-groove race of
    conformity 0.52-0.53 has 15 to 30: within 1.3 % there), 6.5 % at 100 (conformity 0.506)
    and 23 % at 1000, as their docstring says."""
    e_star = contact_modulus(E_STEEL, NU)
    r_x, r_y = 5e-3, alpha * 5e-3
    K = ellipse_stiffness(*hamrock_brewe_constants(alpha), 1.0 / (1.0 / r_x + 1.0 / r_y),
                          e_star)
    assert K == pytest.approx(exact_stiffness(r_x, r_y, e_star), rel=tol)


def test_the_exact_solution_of_the_test_has_the_circular_limit():
    """Nearly equal radii: the circular contact of their mean curvature."""
    e_star = contact_modulus(E_STEEL, NU)
    r_x, r_y = 5e-3, 5.005e-3
    assert exact_stiffness(r_x, r_y, e_star) == pytest.approx(
        stiffness(2 * r_x * r_y / (r_x + r_y), e_star), rel=1e-5)


def test_a_groove_of_the_rings_own_radius_is_the_in_plane_contact():
    """A ball in a groove whose radius is the ring's own (a spherical cavity) has equal radii
    both ways: the elliptical K is the circular one to rounding."""
    r_ring, r_b = 0.0445, 0.0055
    plane = hertz_stiffness("inside", r_ring, r_b, E_STEEL, NU)
    assert hertz_stiffness("inside", r_ring, r_b, E_STEEL, NU, r_ring) == pytest.approx(
        plane, rel=1e-12)


def test_the_crank_sliders_race_contacts_take_the_groove_stiffness():
    """Every ball-race contact gets its race's elliptical K (Hertz's exact, to 1e-9); the
    guard contacts stay circular."""
    model = load_config(overrides=["model.contact_geometry=groove"])["model"]
    m, _ = crank_slider(model)
    grooved = m.arrays(compliant=True).ct_hertz[:, 0]
    plain = crank_slider(load_config()["model"])[0].arrays(compliant=True).ct_hertz[:, 0]
    Z = model["n_balls"]
    e_star = contact_modulus(model["youngs_modulus"], model["poisson_ratio"])
    r_b, r_a = model["ball_radius"], model["inner_radius"]
    r_c = r_a + 2 * r_b + model["clearance"]
    for race, k_slice, r_x, f in (("inner", slice(0, Z), effective_radius("outside", r_a, r_b),
                                   model["inner_conformity"]),
                                  ("outer", slice(Z, 2 * Z), effective_radius("inside", r_c, r_b),
                                   model["outer_conformity"])):
        r_g = 2 * f * r_b
        exact = exact_stiffness(r_x, r_b * r_g / (r_g - r_b), e_star)
        np.testing.assert_allclose(grooved[k_slice], exact, rtol=1e-9, err_msg=race)
    np.testing.assert_array_equal(grooved[2 * Z:], plain[2 * Z:])


@pytest.mark.parametrize("adaptive", [False, True])
def test_undamped_impact_in_a_grooved_ring(adaptive):
    """F_max = K^(2/5) (5 m v^2 / 4)^(3/5) within 0.5 % and the rebound speed within 0.1 %,
    with K from this module's exact solution (alpha = 15.7)."""
    v, m, ring, r = 1.0, 2.7e-3, 0.05, 0.0055
    r_g = 2 * 0.53 * r
    model = ball_in_ring(ring_radius=ring, radius=r, speed=(0.0, v), e_N=1.0, mass=m,
                         start=(0.0, ring - r - 5e-5), youngs_modulus=E_STEEL, groove_radius=r_g)
    K = exact_stiffness(effective_radius("inside", ring, r), r * r_g / (r_g - r),
                        contact_modulus(E_STEEL, NU))
    F_exact = K**0.4 * (5.0 * m * v * v / 4.0) ** 0.6
    settings = (SolverSettings(1e-5, 3e-4, contact_model="compliant", adaptive=True, tol=1e-8,
                               rho_inf=1.0, output_every=1) if adaptive else
                SolverSettings(5e-8, 3e-4, contact_model="compliant", rho_inf=1.0,
                               output_every=20))
    traj = model.simulate(settings)
    assert traj.F_N.max() == pytest.approx(F_exact, rel=0.005)
    assert traj.vn_post[-1, 0] == pytest.approx(v, rel=1e-3)


def test_groove_radius_must_hold_the_ball():
    m = Model()
    b = m.add_body("ball", 1.0, 1.0)
    with pytest.raises(ValueError, match="groove_radius: 0.005 is not allowed; allowed: larger "
                                         "than radius_b"):
        m.add_contact("inside", -1, (0.0, 0.0), 0.05, b, (0.0, 0.0), 0.005, groove_radius=0.005)


@pytest.mark.parametrize("override, key", [
    ("model.contact_geometry=grooved", "model.contact_geometry"),
    ("model.inner_conformity=0.5", "model.inner_conformity"),
    ("model.outer_conformity=1.2", "model.outer_conformity"),
])
def test_bad_groove_settings_are_refused_naming_the_key(override, key):
    with pytest.raises(ConfigError, match=key):
        load_config(overrides=[override])


def test_conformities_come_from_the_catalogue_unless_given(monkeypatch):
    """A real entry's f_i, f_e set the model's conformities; explicit values win; the
    paper's bearing (no grooves in the source) takes the defaults."""
    from simcore.model import bearing

    entry = dict(bearing.bearing("6012"), f_i=0.515, f_e=0.525)
    catalogue = dict(bearing.catalogue(), **{"6012": entry})
    monkeypatch.setattr(bearing, "catalogue", lambda: catalogue)
    model = load_config(overrides=["model.bearing=6012", "model.contact_geometry=groove"])["model"]
    assert (model["inner_conformity"], model["outer_conformity"]) == (0.515, 0.525)
    assert race_grooves(model) == pytest.approx((0.515 * 2 * model["ball_radius"],
                                                 0.525 * 2 * model["ball_radius"]))
    model = load_config(overrides=["model.bearing=6012", "model.outer_conformity=0.56"])["model"]
    assert (model["inner_conformity"], model["outer_conformity"]) == (0.515, 0.56)
    assert race_grooves(model) is None  # contact_geometry plane
    model = load_config()["model"]
    assert (model["inner_conformity"], model["outer_conformity"]) == (0.52, 0.53)


def test_the_analysis_takes_the_runs_own_grooves():
    """A run with grooved contacts: the force extraction's stiffnesses are the model's, the
    rating life's conformities the run's; analysis.groove_conformity still overrides both."""
    from analysis.impacts import run_geometry
    from analysis.run_life import conformities

    cfg = load_config(overrides=["model.contact_geometry=groove", "model.inner_conformity=0.51",
                                 "model.outer_conformity=0.54", "solver.t_end=2e-4"])
    ds = simcore.run(cfg)
    m, _ = crank_slider(cfg["model"])
    K = m.arrays(compliant=True).ct_hertz[:, 0]
    Z = cfg["model"]["n_balls"]
    geo = run_geometry(ds)
    assert geo["K_inner"] == pytest.approx(K[0], rel=1e-12)
    assert geo["K_outer"] == pytest.approx(K[Z], rel=1e-12)
    assert conformities(ds, {}) == (0.51, 0.54)
    assert conformities(ds, {"life_conformity": [0.52, 0.53]}) == (0.52, 0.53)
    override = run_geometry(ds, groove_conformity=0.6)
    assert override["K_inner"] < geo["K_inner"]
    plane = simcore.run(load_config(overrides=["solver.t_end=2e-4"]))
    assert run_geometry(plane)["K_inner"] == pytest.approx(
        crank_slider(load_config()["model"])[0].arrays().ct_hertz[0, 0], rel=1e-12)
    # what python -m simcore run prints about the bearing
    assert "balls in grooves (conformities 0.51 inner, 0.54 outer)" in bearing_line(ds)
    assert "groove" not in bearing_line(plane)
