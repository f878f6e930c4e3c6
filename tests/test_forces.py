"""Hertz stiffness and Flores peak forces (docs/forces.md) against closed forms and invariants."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq, minimize_scalar

from analysis import closed_form_elastic, flores_damping, hertz_stiffness, peak_force

E, NU = 2.1e9, 0.3
R_B, R_A = 0.0055, 0.033745
R_C = R_A + 2 * R_B + 4e-4
K_IN = hertz_stiffness(R_B, R_A, E, NU, E, NU)


def test_hertz_stiffness_formula_and_forms():
    sigma = 2 * (1 - NU**2) / E
    convex = 4 / (3 * sigma) * math.sqrt(R_B * R_A / (R_B + R_A))
    assert K_IN == pytest.approx(convex, rel=1e-14)
    concave = hertz_stiffness(R_B, R_C, E, NU, E, NU, concave=True)
    assert concave == pytest.approx(4 / (3 * sigma) * math.sqrt(R_B * R_C / (R_C - R_B)),
                                    rel=1e-14)
    # a ball in a concave race is stiffer than on a convex one of the same radius
    assert concave > hertz_stiffness(R_B, R_C, E, NU, E, NU, concave=False)
    # symmetric in the two bodies
    assert hertz_stiffness(R_C, R_B, E, NU, E, NU, concave=True) == pytest.approx(concave)
    assert hertz_stiffness(R_B, R_A, 2e11, 0.3, 7e10, 0.33) == pytest.approx(
        hertz_stiffness(R_A, R_B, 7e10, 0.33, 2e11, 0.3))


@pytest.mark.parametrize("args,name", [
    ((0.0, R_A, E, NU, E, NU), "r1"), ((R_B, -1.0, E, NU, E, NU), "r2"),
    ((R_B, R_A, np.nan, NU, E, NU), "E1"), ((R_B, R_A, E, 0.6, E, NU), "nu1"),
    ((R_B, R_A, E, NU, 0.0, NU), "E2"), ((R_B, R_A, E, NU, E, np.nan), "nu2"),
])
def test_hertz_stiffness_bad_inputs(args, name):
    with pytest.raises(ValueError, match=name):
        hertz_stiffness(*args)


def test_concave_equal_radii_raises():
    with pytest.raises(ValueError, match="differ"):
        hertz_stiffness(R_B, R_B, E, NU, E, NU, concave=True)


@pytest.mark.parametrize("m,v,K", [(1.0, 1.0, K_IN), (2.7e-3, 0.3, K_IN), (4.0, 0.01, 1e10),
                                   (1e-3, 5.0, 1e6)])
def test_elastic_matches_closed_form(m, v, K):
    # closed form of the Flores impact, written here independently of the package
    dmax = (5 * m * v**2 / (4 * K)) ** 0.4
    fmax = K * dmax**1.5
    r = peak_force(2 * m * v, v, 1.0, K, details=True)
    assert r.F_max == pytest.approx(fmax, rel=1e-6)  # the issue asks 0.1 %; we get ~1e-10
    assert r.delta_max == pytest.approx(dmax, rel=1e-6)
    assert r.m_eff == pytest.approx(m, rel=1e-14)
    assert r.v_rebound == pytest.approx(v, rel=1e-6)  # elastic: no energy lost
    # contact time 2 ∫0^1 dx/sqrt(1 - x^{5/2}) δmax/v, by quadrature
    from scipy.integrate import quad
    tc = 2 * quad(lambda x: 1 / math.sqrt(1 - x**2.5), 0, 1, limit=200)[0] * dmax / v
    assert r.contact_time == pytest.approx(tc, rel=1e-6)
    assert closed_form_elastic(m, v, K)[2] == pytest.approx(tc, rel=1e-9)


def test_contact_time_of_order_2ms_with_paper_modulus():
    """About 2 ms for m_eff = 1 kg, v_pre = 1 m/s with E = 2.1e9 Pa."""
    r = peak_force(2.0, 1.0, 1.0, K_IN, details=True, h=1e-4)
    assert 1.5e-3 < r.contact_time < 2.5e-3
    assert r.contact_steps == pytest.approx(r.contact_time / 1e-4)


def _phase_plane(e):
    """Independent analytic phase-plane solution of the scaled simple Flores impact.

    u du/dx = -(5/4) x^{3/2} (1 + c u)  =>  x^{5/2} = 2 (G(1) - G(u)), G(u) = u/c - ln(1+cu)/c².
    Returns (u_rebound, f_max) with f = x^{3/2} (1 + c u) in units of K δ*^{3/2}.
    """
    c = 8 * (1 - e) / (5 * e)

    def G(u):
        return u / c - math.log1p(c * u) / c**2

    def x_of(u):
        return max(2 * (G(1.0) - G(u)), 0.0) ** 0.4

    u_r = brentq(lambda u: G(u) - G(1.0), -1.0 + 1e-12, -1e-9, xtol=1e-15, rtol=1e-15)
    res = minimize_scalar(lambda u: -(x_of(u) ** 1.5) * (1 + c * u), bounds=(0.0, 1.0),
                          method="bounded", options={"xatol": 1e-12})
    return u_r, -res.fun


@pytest.mark.parametrize("e", [0.95, 0.9, 0.8, 0.7])
def test_damped_simple_impact_matches_phase_plane(e):
    m, v = 0.5, 0.4
    u_r, f_max = _phase_plane(e)
    r = peak_force((1 + e) * m * v, v, e, K_IN, details=True)
    f_star = K_IN * (5 * m * v**2 / (4 * K_IN)) ** 0.6
    assert r.F_max == pytest.approx(f_max * f_star, rel=1e-6)
    assert r.v_rebound == pytest.approx(-u_r * v, rel=1e-6)


def test_rebound_ratio_e09():
    """Flores et al.: the law returns a rebound speed close to, not exactly, e_N v_pre."""
    r = peak_force(1.9e-3, 0.1, 0.9, K_IN, details=True)
    assert r.v_rebound / 0.1 == pytest.approx(0.894, abs=1e-3)


def test_persistent_limit_equals_simple():
    args = (1e-3, 0.2, 0.9, K_IN)
    simple = peak_force(*args, details=True)
    tiny = peak_force(*args, F_static=1e-9 * simple.F_max, details=True)
    assert tiny.F_max == pytest.approx(simple.F_max, rel=1e-5)
    assert tiny.delta_max == pytest.approx(simple.delta_max, rel=1e-5)
    assert tiny.contact_time == pytest.approx(simple.contact_time, rel=1e-4)


@pytest.mark.parametrize("fs_ratio", [0.1, 1.0, 5.0])
def test_persistent_elastic_energy_balance(fs_ratio):
    """e_N = 1 on a preloaded contact: ½ m v² = ∫_{δs}^{δmax} (K δ^{3/2} - F_s) dδ, rebound = v."""
    m, v = 0.3, 0.5
    F_s = fs_ratio * closed_form_elastic(m, v, K_IN)[0]
    r = peak_force(2 * m * v, v, 1.0, K_IN, F_static=F_s, details=True)
    ds, dm = r.delta_static, r.delta_max
    assert ds == pytest.approx((F_s / K_IN) ** (2 / 3), rel=1e-12)
    work = 0.4 * K_IN * (dm**2.5 - ds**2.5) - F_s * (dm - ds)
    assert work == pytest.approx(0.5 * m * v**2, rel=1e-6)
    assert r.F_max == pytest.approx(K_IN * dm**1.5, rel=1e-6)
    assert r.v_rebound == pytest.approx(v, rel=1e-6)


def test_preload_raises_the_peak():
    args = (1e-3, 0.2, 0.9, K_IN)
    f0 = peak_force(*args)
    fs = [peak_force(*args, F_static=F) for F in (1.0, 10.0, 100.0)]
    assert f0 < fs[0] < fs[1] < fs[2]
    assert fs[2] > 100.0


@settings(max_examples=25, deadline=None)
@given(st.floats(1e-3, 10.0), st.floats(1e-2, 10.0), st.floats(0.5, 1.0))
def test_scaling_law(m, v, e):
    """Simple impacts: F_max ∝ m^{3/5} v^{6/5} K^{2/5} at fixed e_N (dimensional analysis)."""
    f1 = peak_force((1 + e) * m * v, v, e, K_IN)
    f2 = peak_force((1 + e) * 2 * m * 3 * v, 3 * v, e, 4 * K_IN)
    assert f2 / f1 == pytest.approx(2**0.6 * 3**1.2 * 4**0.4, rel=1e-6)


def test_flores_damping():
    assert flores_damping(2.0, 0.8, 0.5) == pytest.approx(8 * 2.0 * 0.2 / (5 * 0.8 * 0.5))
    assert flores_damping(2.0, 1.0, 0.5) == 0.0


@pytest.mark.parametrize("kw,name", [
    ({"impulse": 0.0}, "impulse"), ({"impulse": np.nan}, "impulse"),
    ({"v_pre": -1.0}, "v_pre"), ({"v_pre": np.nan}, "v_pre"), ({"v_pre": 0.0}, "v_pre"),
    ({"e_N": 0.0}, "e_N"), ({"e_N": 1.2}, "e_N"), ({"e_N": np.nan}, "e_N"),
    ({"K": 0.0}, "K"), ({"K": np.inf}, "K"), ({"F_static": -1.0}, "F_static"),
    ({"F_static": np.nan}, "F_static"), ({"h": 0.0}, "h"),
])
def test_peak_force_bad_inputs(kw, name):
    args = {"impulse": 1e-3, "v_pre": 0.1, "e_N": 0.9, "K": K_IN, **kw}
    with pytest.raises(ValueError, match=name):
        peak_force(**args)


@pytest.mark.parametrize("e_N", [0.5, 0.9, 1.0])
@pytest.mark.parametrize("f_s", [0.0, 0.01, 1.0, 100.0])
def test_numba_impact_kernel_matches_lsoda(e_N, f_s):
    """The compiled Dormand-Prince integration and the stiff LSODA fallback agree."""
    from analysis.forces import _scaled_impact_lsoda, scaled_impact_kernel

    c = 8.0 * (1.0 - e_N) / (5.0 * e_N)
    *fast, ok = scaled_impact_kernel(c, f_s, 1e-11, 1e-13, 1000.0, 200_000)
    assert ok
    ref = _scaled_impact_lsoda(e_N, f_s)
    np.testing.assert_allclose(fast[:4], ref[:4], rtol=1e-6, atol=1e-9)


def test_stiff_impact_goes_to_the_implicit_integrator():
    from analysis.forces import _scaled_impact, scaled_impact_kernel

    c = 8.0 * (1.0 - 0.5) / (5.0 * 0.5)
    *_, ok = scaled_impact_kernel(c, 1e4, 1e-11, 1e-13, 1000.0, 200_000)
    assert not ok  # the explicit budget runs out ...
    f_max, x_max, tau_end, u_end, _ = _scaled_impact(0.5, 1e4)
    assert np.isfinite(tau_end) and f_max >= 1e4  # ... and LSODA finishes the impact


def test_peak_forces_of_a_table_match_peak_force_impact_by_impact():
    """The batched Flores forces (one compiled loop, one integration per distinct scaled static
    force) against the scalar path, simple and persistent impacts mixed, repeated values too."""
    from analysis.forces import peak_forces

    rng = np.random.default_rng(3)
    n = 40
    impulse = rng.uniform(1e-4, 1e-2, n)
    v_pre = rng.uniform(0.01, 1.0, n)
    K = np.where(rng.random(n) < 0.5, K_IN, 2.0 * K_IN)
    F_static = np.where(rng.random(n) < 0.4, 0.0, rng.uniform(0.1, 500.0, n))
    impulse[5:8], v_pre[5:8], K[5:8], F_static[5:8] = impulse[4], v_pre[4], K[4], F_static[4]
    got = peak_forces(impulse, v_pre, 0.8, K, F_static=F_static, h=1e-4)
    for i in range(n):
        one = peak_force(impulse[i], v_pre[i], 0.8, K[i], F_static=F_static[i], h=1e-4,
                         details=True)
        for name, value in one.as_dict().items():
            assert got[name][i] == pytest.approx(value, rel=1e-10, nan_ok=True), (name, i)
    with pytest.raises(ValueError, match="v_pre"):
        peak_forces(impulse, -v_pre, 0.8, K)
    with pytest.raises(ValueError, match="F_static"):
        peak_forces(impulse, v_pre, 0.8, K, F_static=-F_static - 1.0)
