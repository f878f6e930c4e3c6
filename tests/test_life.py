"""Rating lives against closed forms: ISO 281's (C/P)^3 and its cubic-mean equivalent load, the
Lundberg-Palmgren derivation of C from the raceway capacities, the life of a load carried by one
ball, and the raceway-element counting of reference_life_history against the classical
rotating/stationary equivalent loads."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from analysis.life import (
    basic_rating_life,
    bearing_capacity_lp,
    combine_races,
    equivalent_load,
    life_hours,
    raceway_capacity,
    reference_cycles_per_revolution,
    reference_life_history,
    reference_life_static,
    revolution_weights,
    static_load_rating,
)
from analysis.load_distribution import ball_loads, ball_stiffness, ring_angles

# a 6205-like geometry: D_w = 7.938 mm, D_pw = 39.04 mm, f_i = 0.52, f_e = 0.53
D_W, D_PW, F_I, F_E = 7.938e-3, 39.04e-3, 0.52, 0.53


def _capacities(Z):
    return (raceway_capacity(D_W, D_PW, F_I, Z, "inner"),
            raceway_capacity(D_W, D_PW, F_E, Z, "outer"))


def test_iso281_constant_load_gives_c_over_p_cubed():
    """A constant radial load (at zero clearance or any other: ISO 281 does not see it) over a
    window at any speed history: P is that load and L10 = (C/P)^3 exactly."""
    t = np.linspace(0.0, 0.3, 301)
    speed = 50.0 + 20.0 * np.sin(7.0 * t)
    F = np.full_like(t, 2345.6)
    P = equivalent_load(F, revolution_weights(t, speed))
    assert P == pytest.approx(2345.6, rel=1e-14)
    assert basic_rating_life(30700.0, P) == pytest.approx((30700.0 / 2345.6) ** 3, rel=1e-13)
    assert basic_rating_life(30700.0, 0.0) == np.inf


def test_equivalent_load_is_the_revolution_weighted_cubic_mean():
    """Two load levels F1, F2 held for N1, N2 revolutions: P = ((F1^3 N1 + F2^3 N2)/(N1 + N2))^(1/3)
    (ISO 281's equivalent load of a varying load). Built as a history: F1 for 1 s at 10 rad/s,
    F2 for 1 s at 30 rad/s, so N2 = 3 N1."""
    t = np.linspace(0.0, 2.0, 2001)
    first = t < 1.0
    F = np.where(first, 1000.0, 3000.0)
    speed = np.where(first, 10.0, 30.0)
    w = revolution_weights(t, speed)
    # the trapezoid weights count the revolutions: 10/(2 pi) + 30/(2 pi) (the sample at t = 1 s
    # takes half of each side)
    assert w.sum() == pytest.approx(40.0 / (2 * np.pi), rel=1e-3)
    expected = ((1000.0**3 * 1.0 + 3000.0**3 * 3.0) / 4.0) ** (1 / 3)
    assert equivalent_load(F, w) == pytest.approx(expected, rel=2e-3)


def test_life_hours():
    """10^6 revolutions at 1500 rpm (50 pi rad/s) take 10^6 / 1500 / 60 h."""
    assert life_hours(1.0, 50.0 * np.pi) == pytest.approx(1e6 / 1500.0 / 60.0, rel=1e-14)
    assert life_hours(2.0, -50.0 * np.pi) == pytest.approx(2e6 / 1500.0 / 60.0, rel=1e-14)


def test_zero_clearance_integrals_of_lundberg_palmgren():
    """Harris's integrals of a zero-clearance ring (half the raceway loaded): J_r = 0.2288,
    J_1 = 0.5625, J_2 = 0.5875, so J_r/J_1 = 0.407 and J_2/J_1 = 1.044: the constants of
    C = 0.407 Z Q_ci (1 + (1.04 Q_ci/Q_ce)^(10/3))^(-0.3) (and 0.407 x 98.1 = 39.9, the constant
    of ISO 281's f_c)."""
    mean = lambda p: quad(lambda x: np.cos(x) ** p, -np.pi / 2, np.pi / 2)[0] / (2 * np.pi)  # noqa: E731
    J_r, J_1, J_2 = mean(2.5), mean(4.5) ** (1 / 3), mean(5.0) ** 0.3
    assert (J_r, J_1, J_2) == pytest.approx((0.2288, 0.5625, 0.5875), abs=6e-4)
    assert J_r / J_1 == pytest.approx(0.407, abs=5e-4)
    assert J_2 / J_1 == pytest.approx(1.044, abs=1e-3)
    assert 0.407 * 98.1 == pytest.approx(39.9, abs=0.05)
    q_i, q_e = 3000.0, 5000.0
    assert bearing_capacity_lp(q_i, q_e, 9) == pytest.approx(
        J_r / J_1 * 9 * q_i * (1 + (J_2 / J_1 * q_i / q_e) ** (10 / 3)) ** -0.3, rel=1e-9)


@pytest.mark.parametrize("Z, tol", [(400, 2e-3), (4000, 2e-4)])
def test_reference_life_at_zero_clearance_follows_lundberg_palmgren(Z, tol):
    """Zero clearance, constant radial load, inner ring rotating: the reference rating life from
    the ball loads tends to (C/F_r)^3 with Lundberg-Palmgren's C built from the same raceway
    capacities, as Z grows (their derivation replaces the sums over balls by integrals)."""
    Q_ci, Q_ce = _capacities(Z)
    F = 5000.0
    K_s = ball_stiffness(D_W / 2, D_PW / 2 - D_W / 2, 0.0, 2.1e11, 0.3)[2]
    Q = ball_loads(F, ring_angles(Z), 0.0, K_s).Q
    life = reference_life_static(Q, Q_ci, Q_ce, rotating="inner")
    C = bearing_capacity_lp(Q_ci, Q_ce, Z)
    assert life.L10r == pytest.approx((C / F) ** 3, rel=tol)


def test_reference_life_with_few_balls_and_lp_c_against_catalogue():
    """With 9 balls the sums over balls are not the integrals: L10r (F/C_LP)^3 is 0.989 (ball
    under the load) and 1.010 (two astride), and the LP rating with
    ISO 281:2007's b_m = 1.3 comes within 4 % of the 6205's catalogue C (14.0 kN NSK,
    14.8 kN SKF)."""
    Z = 9
    Q_ci, Q_ce = _capacities(Z)
    C = bearing_capacity_lp(Q_ci, Q_ce, Z)
    assert 14.0e3 * 0.96 < C < 14.8e3 * 1.04
    K_s = ball_stiffness(D_W / 2, D_PW / 2 - D_W / 2, 0.0, 2.1e11, 0.3)[2]
    F = 3000.0
    for phase in (0.0, np.pi / Z):
        Q = ball_loads(F, ring_angles(Z, phase), 0.0, K_s).Q
        ratio = reference_life_static(Q, Q_ci, Q_ce).L10r * (F / C) ** 3
        assert 0.98 < ratio < 1.02


def test_static_load_rating_from_its_definition_against_the_catalogue():
    """ISO 76's C0 from its definition (Stribeck's most loaded ball 5 C0 / Z presses the more
    stressed groove with 4,200 MPa; conformities 0.52 and 0.53, bearing steel) comes within 2 %
    of the published C0 of every catalogue entry that gives one; C0 grows as the cube of the
    pressure."""
    from simcore.model.bearing import catalogue

    checked = 0
    for name, entry in catalogue().items():
        if entry.get("C0") is None or entry.get("D_w") is None:
            continue
        args = (entry["D_w"] * 1e-3, entry["D_pw"] * 1e-3, entry["Z"],
                entry.get("f_i") or 0.52, entry.get("f_e") or 0.53)
        C0 = static_load_rating(*args)
        assert 0.98 < C0 / entry["C0"] < 1.02, (name, C0, entry["C0"])
        assert static_load_rating(*args, pressure=2.1e9) == pytest.approx(C0 / 8, rel=1e-12)
        checked += 1
    assert checked >= 3


def test_one_ball_carrying_the_load_shortens_the_life_as_predicted():
    """At a clearance large against the deflection one ball carries F_r: Q_e = F (1/Z)^(1/3) on
    the rotating raceway and F (1/Z)^(3/10) on the stationary one, so L_i = Z (Q_ci/F)^3 and
    L_e = Z^0.9 (Q_ce/F)^3; at zero clearance Q_j = Q_max cos^1.5 psi_j with
    Q_max = F / sum cos^2.5. Both in closed form here; the life falls with the clearance."""
    Z = 9
    Q_ci, Q_ce = _capacities(Z)
    F = 3000.0
    K_s = ball_stiffness(D_W / 2, D_PW / 2 - D_W / 2, 1e-3, 2.1e11, 0.3)[2]
    distribution = ball_loads(F, ring_angles(Z), 1e-3, K_s)
    assert distribution.n_loaded == 1
    one = reference_life_static(distribution.Q, Q_ci, Q_ce)
    L_i, L_e = Z * (Q_ci / F) ** 3, Z**0.9 * (Q_ce / F) ** 3
    assert one.L_inner == pytest.approx(L_i, rel=1e-10)
    assert one.L_outer == pytest.approx(L_e, rel=1e-10)
    assert one.L10r == pytest.approx((L_i ** (-10 / 9) + L_e ** (-10 / 9)) ** -0.9, rel=1e-10)
    c = np.cos(ring_angles(Z))
    c = np.where(c > 0, c, 0.0)
    Q0 = F / np.sum(c**2.5) * c**1.5
    L0_i = (Q_ci / np.mean(Q0**3) ** (1 / 3)) ** 3
    L0_e = (Q_ce / np.mean(Q0 ** (10 / 3)) ** 0.3) ** 3
    zero = reference_life_static(ball_loads(F, ring_angles(Z), 0.0, K_s).Q, Q_ci, Q_ce)
    assert zero.L10r == pytest.approx(combine_races(L0_i, L0_e), rel=1e-9)
    assert one.L10r / zero.L10r == pytest.approx(combine_races(L_i, L_e)
                                                 / combine_races(L0_i, L0_e), rel=1e-9)
    lives = [reference_life_static(ball_loads(F, ring_angles(Z), g, K_s).Q, Q_ci, Q_ce).L10r
             for g in (0.0, 2e-6, 5e-6, 1e-5, 3e-5, 1e-4, 1e-3)]
    assert all(a >= b for a, b in zip(lives, lives[1:], strict=False))
    assert lives[-1] < 0.5 * lives[0]


def test_history_counting_reproduces_rotating_and_stationary_rings():
    """A steady radial load, the outer ring still, the inner ring turning, pure rolling (cage at
    (1 - gamma)/2 of the inner ring's speed), zero clearance, 40 balls. Counting the balls that
    roll over each raceway element gives the inner raceway the cubic mean of the ball loads and
    the outer raceway (each point under its own load) Q_max J_2, J_2 = 0.5875 the integral of
    the stationary ring."""
    Z = 40
    Q_ci, Q_ce = _capacities(Z)
    F = 8000.0
    K_s = ball_stiffness(D_W / 2, D_PW / 2 - D_W / 2, 0.0, 2.1e11, 0.3)[2]
    gamma = D_W / D_PW
    revs = 3.0
    t = np.linspace(0.0, revs, 3001)  # inner ring turns (1 rev per unit time)
    cage = 2 * np.pi * (1 - gamma) / 2 * t
    psi = ring_angles(Z)[None, :] + cage[:, None]  # ball angles in the outer (still) ring
    Q = np.array([ball_loads(F, p, 0.0, K_s).Q for p in psi])
    u_i = reference_cycles_per_revolution(D_W, D_PW, Z, "inner")
    u_e = reference_cycles_per_revolution(D_W, D_PW, Z, "outer")
    L_i, q_i = reference_life_history(Q, psi - 2 * np.pi * t[:, None], revs, Q_ci, u_i)
    L_e, q_e = reference_life_history(Q, psi, revs, Q_ce, u_e)
    assert q_i == pytest.approx(np.mean(Q**3) ** (1 / 3), rel=3e-3)
    mean = lambda p: quad(lambda x: np.cos(x) ** p, -np.pi / 2, np.pi / 2)[0] / (2 * np.pi)  # noqa: E731
    q_max = F / (Z * mean(2.5))
    assert q_e == pytest.approx(q_max * mean(5.0) ** 0.3, rel=5e-3)
    assert L_i == pytest.approx((Q_ci / q_i) ** 3, rel=1e-12)
    static = reference_life_static(Q[0], Q_ci, Q_ce)
    assert L_i == pytest.approx(static.L_inner, rel=1e-2)
    assert L_e == pytest.approx(static.L_outer, rel=2e-2)


def test_bad_input_names_the_key():
    with pytest.raises(ValueError, match="race"):
        raceway_capacity(D_W, D_PW, 0.52, 9, "cage")
    with pytest.raises(ValueError, match="conformity"):
        raceway_capacity(D_W, D_PW, 0.5, 9, "inner")
    with pytest.raises(ValueError, match="C"):
        basic_rating_life(0.0, 1.0)
    with pytest.raises(ValueError, match="weights"):
        equivalent_load([1.0, 2.0], [0.0, 0.0])
    with pytest.raises(ValueError, match="revolutions"):
        reference_life_history(np.ones((3, 2)), np.zeros((3, 2)), 0.0, 1.0, 1.0)
    assert math.isinf(combine_races(np.inf, np.inf))
