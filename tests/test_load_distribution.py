"""Static load distribution of a ball ring against closed forms (Stribeck's zero-clearance ring,
one ball at large clearance, two straddling balls) and its invariants (equilibrium, rotation,
monotonicity in the clearance)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import gamma

from analysis.contact_stress import contact_modulus, hertz_circular
from analysis.load_distribution import (
    ball_loads,
    ball_loads_history,
    ball_stiffness,
    ring_angles,
    stribeck_factor,
)

R_B, R_A = 0.0055, 0.033745
E, NU = 2.1e11, 0.3
K_S = ball_stiffness(R_B, R_A, 1e-5, E, NU)[2]


def test_series_stiffness_is_the_sum_of_both_hertz_indentations():
    """At a ball load Q, the two contacts' Hertz indentations (delta = a^2/R with
    a = (3 Q R / (4 E*))^(1/3)) add up to (Q/K_s)^(2/3)."""
    g = 1e-4
    r_c = R_A + 2 * R_B + g
    Q = 750.0
    E_star = contact_modulus(E, NU)
    d_in = hertz_circular(Q, R_A * R_B / (R_A + R_B), E_star)[1]
    d_out = hertz_circular(Q, r_c * R_B / (r_c - R_B), E_star)[1]
    k_in, k_out, k_s = ball_stiffness(R_B, R_A, g, E, NU)
    assert (Q / k_s) ** (2 / 3) == pytest.approx(d_in + d_out, rel=1e-12)
    assert (Q / k_in) ** (2 / 3) == pytest.approx(d_in, rel=1e-12)
    assert (Q / k_out) ** (2 / 3) == pytest.approx(d_out, rel=1e-12)


@pytest.mark.parametrize("Z", [8, 9, 14])
def test_zero_clearance_is_stribecks_ring(Z):
    """g = 0: delta_j = delta_r cos psi_j, so Q_j = K_s delta_r^1.5 cos^1.5 psi_j on the loaded
    half, F_r = K_s delta_r^1.5 sum cos^2.5: delta_r and every Q_j in closed form."""
    F = 2000.0
    psi = ring_angles(Z)
    d = ball_loads(F, psi, 0.0, K_S)
    c = np.cos(psi)
    s = np.sum(np.where(c > 0, c, 0.0) ** 2.5)
    delta_r = (F / (K_S * s)) ** (2 / 3)
    assert d.delta_r == pytest.approx(delta_r, rel=1e-12)
    np.testing.assert_allclose(d.Q, K_S * (delta_r * np.maximum(c, 0)) ** 1.5, rtol=1e-11,
                               atol=1e-9)
    assert d.q_max * Z / F == pytest.approx(Z / s, rel=1e-11)
    assert stribeck_factor(Z) == pytest.approx(Z / s, rel=1e-12)


def test_stribeck_factor_tends_to_4_37():
    """For large Z the sum becomes Z/(2 pi) times int_{-pi/2}^{pi/2} cos^2.5 = sqrt(pi)
    Gamma(7/4)/Gamma(9/4): Z Q_max/F_r -> 2 sqrt(pi) Gamma(9/4)/Gamma(7/4) = 4.3701 (Stribeck's
    4.37, e.g. NSK's technical report on bearing load distribution, Q_max = 4.37 F_r/(Z cos a))."""
    limit = 2.0 * math.sqrt(math.pi) * gamma(9 / 4) / gamma(7 / 4)
    assert limit == pytest.approx(4.37, abs=5e-3)
    for Z in (400, 4001):
        assert stribeck_factor(Z) == pytest.approx(limit, rel=2e-4)
        assert stribeck_factor(Z, straddle=True) == pytest.approx(limit, rel=2e-4)
    # with few balls the load between two balls gives the smaller peak (8 balls: 3.90 against
    # 4.35 with a ball under the load)
    for Z in (8, 9, 14):
        assert stribeck_factor(Z, straddle=True) < stribeck_factor(Z)


def test_large_clearance_one_ball_carries_the_load():
    """Only the ball under the load closes while its deflection (F/K_s)^(2/3) stays below
    g (1/cos(2 pi/Z) - 1): then Q = F_r on it, 0 elsewhere, delta_r = g + (F_r/K_s)^(2/3)."""
    F, Z = 1500.0, 8
    d1 = (F / K_S) ** (2 / 3)
    g = 1.01 * d1 / (1 / math.cos(2 * math.pi / Z) - 1)
    d = ball_loads(F, ring_angles(Z), g, K_S)
    assert d.n_loaded == 1
    assert d.Q[0] == pytest.approx(F, rel=1e-12)
    assert d.delta_r == pytest.approx(g + d1, rel=1e-12)
    # just below that clearance the neighbours take a share
    d = ball_loads(F, ring_angles(Z), 0.95 * g, K_S)
    assert d.n_loaded == 3 and d.Q[0] < F


def test_large_clearance_straddling_balls_share_equally():
    """Load between two balls at +-pi/Z: each carries F_r / (2 cos(pi/Z)); delta_r cos(pi/Z) =
    g + (Q/K_s)^(2/3)."""
    F, Z, g = 1500.0, 8, 2e-4
    d = ball_loads(F, ring_angles(Z, np.pi / Z), g, K_S)
    c = math.cos(math.pi / Z)
    Q = F / (2 * c)
    assert d.n_loaded == 2
    np.testing.assert_allclose(np.sort(d.Q)[-2:], [Q, Q], rtol=1e-11)
    assert d.delta_r * c == pytest.approx(g + (Q / K_S) ** (2 / 3), rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(F=st.floats(1e-2, 1e5), g=st.floats(0.0, 1e-3), Z=st.integers(3, 20),
       phase=st.floats(-np.pi, np.pi), load=st.floats(-np.pi, np.pi))
def test_equilibrium_and_rotation_invariance(F, g, Z, phase, load):
    """sum Q_j cos(psi_j - psi_L) = F_r; every Q_j = K_s max(delta_r cos - g, 0)^1.5; turning
    the balls and the load together changes nothing."""
    psi = ring_angles(Z, phase)
    if np.cos(psi - load).max() < 1e-6:
        return
    d = ball_loads(F, psi, g, K_S, load)
    c = np.cos(psi - load)
    assert np.sum(d.Q * c) == pytest.approx(F, rel=1e-9)
    np.testing.assert_allclose(d.Q, K_S * np.maximum(d.delta_r * c - g, 0) ** 1.5,
                               rtol=1e-12, atol=0)
    turned = ball_loads(F, psi + 0.7, g, K_S, load + 0.7)
    np.testing.assert_allclose(turned.Q, d.Q, rtol=1e-9, atol=1e-9 * F)


def test_larger_clearance_fewer_balls_larger_peak():
    """At a fixed load, a larger clearance loads fewer balls and raises the largest ball load,
    from Stribeck's value at g = 0 up to F_r at large g."""
    F, Z = 1000.0, 8
    q_prev, n_prev = 0.0, Z
    for g in [0.0, 1e-7, 1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 1e-3]:
        d = ball_loads(F, ring_angles(Z), g, K_S)
        assert d.q_max >= q_prev
        assert d.n_loaded <= n_prev
        q_prev, n_prev = d.q_max, d.n_loaded
    assert q_prev == pytest.approx(F, rel=1e-12)


def test_history_matches_single_calls_and_load_angle():
    """ball_loads_history takes load vectors: their direction is the load angle."""
    rng = np.random.default_rng(3)
    force = rng.normal(size=(5, 2)) * 800.0
    psi = ring_angles(8, 0.3)
    Q, dr = ball_loads_history(force, psi, 2e-5, K_S)
    for k in range(5):
        one = ball_loads(np.hypot(*force[k]), psi, 2e-5, K_S, np.arctan2(force[k, 1], force[k, 0]))
        np.testing.assert_allclose(Q[k], one.Q, rtol=1e-12)
        assert dr[k] == one.delta_r


def test_zero_load_and_bad_input():
    d = ball_loads(0.0, ring_angles(8), 1e-5, K_S)
    assert d.delta_r == 0.0 and not d.Q.any()
    with pytest.raises(ValueError, match="F_r"):
        ball_loads(-1.0, ring_angles(8), 1e-5, K_S)
    with pytest.raises(ValueError, match="clearance"):
        ball_loads(1.0, ring_angles(8), -1e-5, K_S)
    with pytest.raises(ValueError, match="K_s"):
        ball_loads(1.0, ring_angles(8), 1e-5, 0.0)
    with pytest.raises(ValueError, match="ball_angles"):
        ball_loads(1.0, [np.pi], 1e-5, K_S)
    with pytest.raises(ValueError, match="n_balls"):
        ring_angles(0)
