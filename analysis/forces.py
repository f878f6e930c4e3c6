"""From an impulse to a peak contact force: Hertz stiffness and the Flores et al. (2011) law.

docs/forces.md. The contact force during an impact is

    F = K δ^{3/2} (1 + D δ̇),   D = 8 (1 - e_N) / (5 e_N v_pre),

with K the Hertz stiffness [N/m^1.5], δ the indentation [m] and v_pre the approach speed [m/s]. A
single degree of freedom of mass m_eff = Λ / ((1 + e_N) v_pre) is driven through the impact:

    m_eff δ̈ = F_s - F(δ, δ̇),   δ(0) = δ_s = (F_s / K)^{2/3},   δ̇(0) = v_pre,

with F_s = 0 for a simple impact and F_s = Λ_S / h for an impact on persistent contact.

Scaling. With δ* = (5 m v²/(4K))^{2/5}, F* = K δ*^{3/2}, t* = δ*/v and x = δ/δ*, u = δ̇/v the
problem becomes  x' = u,  u' = (5/4) (f_s - x^{3/2} (1 + c u)),  c = 8 (1 - e_N)/(5 e_N),
f_s = F_s/F*, x(0) = f_s^{2/3}, u(0) = 1: it depends on e_N and f_s only. For e_N = 1 and f_s = 0,
x_max = 1 and F_max = F* exactly (the closed form in docs/forces.md). The scaled problem is
integrated with an adaptive Dormand-Prince 5(4) scheme compiled with Numba (rtol 1e-9), with
events located (regula falsi, Illinois, to 2^-44 of a step) for the force peak (dF/dt = 0), the
largest indentation (δ̇ = 0) and the end of the impact (F back to F_s, i.e. separation when
F_s = 0); a stiff case (more than
200,000 explicit steps) is handed to ``solve_ivp`` with LSODA. Results are cached per
(e_N, f_s), so all simple impacts of a run cost one integration per e_N.

Choices
-------
* e_N must be in (0, 1]: the Flores damping D ∝ (1 - e_N)/e_N is singular at e_N = 0, which is
  refused with a ValueError.
* The force cannot pull: F is clipped at 0 (it could turn negative during restitution when
  c |u| > 1, i.e. for e_N < 8/13 with a fast rebound).
* For an impact on persistent contact the impact "ends" when the contact force first falls back
  to the static force F_s (for e_N = 1 that is the return to the static indentation δ_s; with
  damping it comes while δ > δ_s, during restitution); the rebound speed is δ̇ there. If that
  never happens within 1000 t*, contact_time and v_rebound are NaN. (F_s -> 0 gives separation.)
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np
from numba import njit

from ._checks import poisson_ratio, positive

__all__ = [
    "effective_radius",
    "hertz_stiffness",
    "peak_force",
    "peak_forces",
    "PeakForce",
    "flores_damping",
    "closed_form_elastic",
]

# Tolerances of the scaled integration. The inputs (the impulse and approach speed of the
# nonsmooth solver, tol 1e-5) carry relative errors above 1e-6; at rtol 1e-9 the forces and
# indentations of a steady study run's 1,543 impacts differ from those at 1e-11 by at most
# 3e-10 and the contact times by 5e-6 (relative), at 0.46 of the cost (docs/forces.md).
_RTOL = 1e-9
_ATOL = 1e-11
_TAU_MAX = 1000.0
_METHOD = "LSODA"


def _restitution(e_N) -> float:
    try:
        e_N = float(e_N)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"e_N must be a number in (0, 1], got {e_N!r}") from exc
    if not math.isfinite(e_N) or not (0.0 < e_N <= 1.0):
        raise ValueError(
            f"e_N must be in (0, 1], got {e_N!r} (the Flores damping is singular at e_N = 0)"
        )
    return e_N


def effective_radius(r1, r2, concave=False) -> float:
    """Effective radius of curvature of two spheres in contact [m].

    Parameters
    ----------
    r1, r2 : float
        Radii [m] (for ``concave``, r1 is the ball and r2 the race it sits inside, or vice
        versa: the order does not matter).
    concave : bool
        False: convex-convex contact (ball on the inner race), R = r1 r2 / (r1 + r2).
        True: ball inside a concave race (outer race), R = r1 r2 / |r2 - r1|.

    Returns
    -------
    float
        R_eff [m].
    """
    r1 = positive("r1", r1)
    r2 = positive("r2", r2)
    if concave:
        if r1 == r2:
            raise ValueError("r1 and r2 must differ for a concave contact (R_eff is infinite)")
        return r1 * r2 / abs(r2 - r1)
    return r1 * r2 / (r1 + r2)


def hertz_stiffness(r1, r2, E1, nu1, E2, nu2, concave=False) -> float:
    """Hertz stiffness of a sphere-sphere contact [N/m^1.5].

    K = 4 / (3 (σ1 + σ2)) √R_eff, σ_r = (1 - ν_r²)/E_r (the paper's eq. 4).

    Parameters
    ----------
    r1, r2 : float
        Radii of the two bodies [m].
    E1, E2 : float
        Young's moduli [Pa].
    nu1, nu2 : float
        Poisson ratios [-].
    concave : bool
        Use the concave effective radius r1 r2/|r2 - r1| (a ball inside the outer race) instead of
        the convex r1 r2/(r1 + r2). The paper prints the convex form for both races; pass
        ``concave=False`` with the outer-race radius to reproduce it.

    Returns
    -------
    float
        K [N/m^1.5].
    """
    E1 = positive("E1", E1)
    E2 = positive("E2", E2)
    nu1 = poisson_ratio("nu1", nu1)
    nu2 = poisson_ratio("nu2", nu2)
    from simcore.model.hertz import contact_modulus, stiffness

    return stiffness(effective_radius(r1, r2, concave), contact_modulus(E1, nu1, E2, nu2))


def flores_damping(K, e_N, v_pre) -> float:
    """Flores et al. (2011) hysteresis damping factor D = 8 K (1 - e_N)/(5 e_N v_pre) [N s/m^2.5].

    Parameters
    ----------
    K : float
        Hertz stiffness [N/m^1.5].
    e_N : float
        Normal restitution coefficient, in (0, 1].
    v_pre : float
        Approach speed [m/s], > 0.

    Returns
    -------
    float
        D [N s/m^2.5]; the force is F = K δ^{3/2} + D δ^{3/2} δ̇.
    """
    K = positive("K", K)
    e_N = _restitution(e_N)
    v_pre = positive("v_pre", v_pre)
    return 8.0 * K * (1.0 - e_N) / (5.0 * e_N * v_pre)


def closed_form_elastic(m_eff, v_pre, K):
    """Closed form of the elastic (e_N = 1) Hertz impact.

    Parameters
    ----------
    m_eff : float
        Effective mass [kg].
    v_pre : float
        Approach speed [m/s].
    K : float
        Hertz stiffness [N/m^1.5].

    Returns
    -------
    F_max, delta_max, contact_time : float
        Peak force [N] K δ_max^{3/2}, largest indentation [m] (5 m v²/(4K))^{2/5} and contact time
        [s] 2 ∫_0^1 dx/√(1 - x^{5/2}) · δ_max/v ≈ 2.9433 δ_max/v.
    """
    m_eff = positive("m_eff", m_eff)
    v_pre = positive("v_pre", v_pre)
    K = positive("K", K)
    dmax = (5.0 * m_eff * v_pre**2 / (4.0 * K)) ** 0.4
    # 2 ∫_0^1 (1 - x^{5/2})^{-1/2} dx = 2 * (2/5) B(2/5, 1/2)
    beta = math.gamma(0.4) * math.gamma(0.5) / math.gamma(0.9)
    return K * dmax**1.5, dmax, 2.0 * 0.4 * beta * dmax / v_pre


@dataclass(frozen=True)
class PeakForce:
    """Result of :func:`peak_force` with ``details=True``.

    Attributes
    ----------
    F_max : float
        Largest contact force during the impact [N].
    delta_max : float
        Largest indentation [m] (total, including the static one).
    contact_time : float
        Duration of the impact [s]: to separation (simple impact) or until the force is back
        to F_static (impact on persistent contact); NaN if that never happens (module notes).
    v_rebound : float
        Speed at the end of the impact [m/s] (> 0 moving apart); NaN as contact_time.
    m_eff : float
        Effective mass Λ/((1 + e_N) v_pre) [kg].
    delta_static : float
        Static indentation (F_s/K)^{2/3} [m].
    t_peak : float
        Time of the force peak after the start of the impact [s].
    contact_steps : float
        contact_time / h (NaN without h): how many solver steps the Hertz contact lasts.
    """

    F_max: float
    delta_max: float
    contact_time: float
    v_rebound: float
    m_eff: float
    delta_static: float
    t_peak: float
    contact_steps: float

    def as_dict(self) -> dict:
        """The result as a plain dict."""
        return asdict(self)


# ---------------------------------------------------------------------------------------------
# Dormand-Prince 5(4) on the scaled impact, in Numba: ~100 times cheaper than solve_ivp, whose
# per-step Python overhead made the impacts on persistent contact (one integration each, f_s
# varies) the slowest part of a study. Stiff cases (a heavily damped, heavily preloaded contact
# that needs very many explicit steps) go to LSODA, see _scaled_impact.
# ---------------------------------------------------------------------------------------------
_DP_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
_DP_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [1 / 5, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3 / 40, 9 / 40, 0.0, 0.0, 0.0, 0.0],
    [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0, 0.0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0, 0.0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0.0],
    [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84],
])
_DP_B = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0.0])
_DP_E = _DP_B - np.array([5179 / 57600, 0.0, 7571 / 16695, 393 / 640, -92097 / 339200,
                          187 / 2100, 1 / 40])


@njit(cache=True)
def _scaled_force(x, u, c):
    xp = x if x > 0.0 else 0.0
    f = xp * math.sqrt(xp) * (1.0 + c * u)
    return f if f > 0.0 else 0.0


@njit(cache=True)
def _dp_step(x, u, h, f_s, c, out, kx, ku):
    """One Dormand-Prince step of x' = u, u' = 5/4 (f_s - F): fills out = (x, u, err_x, err_u);
    kx, ku: work arrays of 7 stages."""
    for i in range(7):
        xi = x
        ui = u
        for j in range(i):
            xi += h * _DP_A[i, j] * kx[j]
            ui += h * _DP_A[i, j] * ku[j]
        kx[i] = ui
        ku[i] = 1.25 * (f_s - _scaled_force(xi, ui, c))
    xn = x
    un = u
    ex = 0.0
    eu = 0.0
    for i in range(7):
        xn += h * _DP_B[i] * kx[i]
        un += h * _DP_B[i] * ku[i]
        ex += h * _DP_E[i] * kx[i]
        eu += h * _DP_E[i] * ku[i]
    out[0] = xn
    out[1] = un
    out[2] = ex
    out[3] = eu


@njit(cache=True)
def _impact_events(x, u, f_s, c):
    """(dF/dtau, u, end function) at a state; the end function crosses 0 upwards at the end."""
    xp = x if x > 0.0 else 0.0
    du = 1.25 * (f_s - _scaled_force(x, u, c))
    dfdt = 1.5 * math.sqrt(xp) * u * (1.0 + c * u) + xp * math.sqrt(xp) * c * du
    end = f_s - _scaled_force(x, u, c) if f_s > 0.0 else -x
    return dfdt, u, end


@njit(cache=True)
def _locate(x, u, h, f_s, c, which, g_lo, g_hi, out, kx, ku):
    """The fraction of the step at which event ``which`` changes sign, between 0 (where it is
    ``g_lo``) and 1 (``g_hi``, of the other sign), and the state there (out, kx, ku: work
    arrays of :func:`_dp_step`).

    The bracket is narrowed to 2^-44 (6e-14) of the step, far inside the integration's
    tolerance (rtol 1e-9), by regula falsi with the Illinois modification (the end kept twice
    in a row has its value halved, so both ends close in) and a bisection wherever an
    iteration fails to halve the bracket: some 10 evaluations of the step instead of
    bisection's 44. Returned is the end past the change, as bisection returns it."""
    lo = 0.0
    hi = 1.0
    kept = 0  # which end the last secant step kept: -1 lo, 1 hi (0: none, or a bisection)
    bisect = False
    for _ in range(200):
        width = hi - lo
        if width <= 2.0 ** -44:
            break
        mid = 0.5 * (lo + hi)
        if not bisect:
            secant = (lo * g_hi - hi * g_lo) / (g_hi - g_lo)
            if lo < secant < hi:
                mid = secant
        _dp_step(x, u, mid * h, f_s, c, out, kx, ku)
        g = _impact_events(out[0], out[1], f_s, c)[which]
        if (g > 0.0) == (g_lo > 0.0):
            lo = mid
            g_lo = g
            if kept == 1 and not bisect:
                g_hi *= 0.5
            kept = 0 if bisect else 1
        else:
            hi = mid
            g_hi = g
            if kept == -1 and not bisect:
                g_lo *= 0.5
            kept = 0 if bisect else -1
        # a secant step that did not halve the bracket is followed by a bisection
        bisect = not bisect and hi - lo > 0.5 * width
    _dp_step(x, u, hi * h, f_s, c, out, kx, ku)
    return hi, out[0], out[1]


@njit(cache=True)
def scaled_impact_kernel(c, f_s, rtol, atol, tau_max, max_steps):
    """Integrate the scaled impact to its end.

    Returns (f_max, x_max, tau_end, u_end, tau_peak, ok); ok is False when the step budget ran
    out (a stiff case) and the caller should use an implicit integrator.
    """
    x = f_s ** (2.0 / 3.0)
    u = 1.0
    tau = 0.0
    h = 1e-6
    f_max = _scaled_force(x, u, c)
    tau_peak = 0.0
    x_max = x
    out = np.zeros(4)
    kx = np.zeros(7)
    ku = np.zeros(7)
    g_prev = _impact_events(x, u, f_s, c)
    started = f_s > 0.0  # a simple impact starts at x = 0 exactly: its end test waits for x > 0
    for _ in range(max_steps):
        if tau >= tau_max:
            break
        h = min(h, 0.25, tau_max - tau)
        _dp_step(x, u, h, f_s, c, out, kx, ku)
        sc_x = atol + rtol * max(abs(x), abs(out[0]))
        sc_u = atol + rtol * max(abs(u), abs(out[1]))
        err = max(abs(out[2]) / sc_x, abs(out[3]) / sc_u)
        if err > 1.0:
            h *= max(0.2, 0.9 * err ** -0.2)
            continue
        xn = out[0]
        un = out[1]
        g_new = _impact_events(xn, un, f_s, c)
        # force peak: dF/dtau from + to -
        if g_prev[0] > 0.0 and g_new[0] <= 0.0:
            th, xe, ue = _locate(x, u, h, f_s, c, 0, g_prev[0], g_new[0], out, kx, ku)
            fe = _scaled_force(xe, ue, c)
            if fe > f_max:
                f_max = fe
                tau_peak = tau + th * h
        # largest indentation: u from + to -
        if g_prev[1] > 0.0 and g_new[1] <= 0.0:
            th, xe, ue = _locate(x, u, h, f_s, c, 1, g_prev[1], g_new[1], out, kx, ku)
            x_max = max(x_max, xe)
        # end of the impact
        if started and g_prev[2] < 0.0 and g_new[2] >= 0.0:
            th, xe, ue = _locate(x, u, h, f_s, c, 2, g_prev[2], g_new[2], out, kx, ku)
            return f_max, x_max, tau + th * h, ue, tau_peak, True
        fn = _scaled_force(xn, un, c)
        if fn > f_max:
            f_max = fn
            tau_peak = tau + h
        x_max = max(x_max, xn)
        if not started and xn > 0.0:
            started = True
        x = xn
        u = un
        tau += h
        g_prev = g_new
        h *= min(5.0, 0.9 * err ** -0.2) if err > 0.0 else 5.0
    ok = tau >= tau_max
    return f_max, x_max, math.nan, math.nan, tau_peak, ok


@njit(cache=True)
def scaled_impacts_kernel(c, f_s, rtol, atol, tau_max, max_steps):
    """:func:`scaled_impact_kernel` for each of the scaled static forces ``f_s`` (one call for a
    whole impact table instead of one Python call per impact).

    Returns (results, ok): results[i] = (f_max, x_max, tau_end, u_end, tau_peak) of f_s[i];
    ok[i] is False where the step budget ran out (the caller uses an implicit integrator there).
    """
    n = f_s.size
    results = np.empty((n, 5))
    ok = np.empty(n, dtype=np.bool_)
    for i in range(n):
        f_max, x_max, tau_end, u_end, tau_peak, good = scaled_impact_kernel(
            c, f_s[i], rtol, atol, tau_max, max_steps)
        results[i, 0] = f_max
        results[i, 1] = x_max
        results[i, 2] = tau_end
        results[i, 3] = u_end
        results[i, 4] = tau_peak
        ok[i] = good
    return results, ok


def _force_scaled(x, u, c):
    xp = x if x > 0.0 else 0.0
    f = xp * math.sqrt(xp) * (1.0 + c * u)
    return f if f > 0.0 else 0.0


_MAX_EXPLICIT_STEPS = 200_000


@lru_cache(maxsize=4096)
def _scaled_impact(e_N: float, f_s: float):
    """Integrate the scaled impact; returns (f_max, x_max, tau_end, u_end, tau_peak).

    Dormand-Prince in Numba first; where it would need more than _MAX_EXPLICIT_STEPS steps
    (stiff: strong damping under a large preload) LSODA takes over."""
    c = 8.0 * (1.0 - e_N) / (5.0 * e_N)
    f_max, x_max, tau_end, u_end, tau_peak, ok = scaled_impact_kernel(
        c, f_s, _RTOL, _ATOL, _TAU_MAX, _MAX_EXPLICIT_STEPS)
    if ok:
        return f_max, x_max, tau_end, u_end, tau_peak
    return _scaled_impact_lsoda(e_N, f_s)


def _scaled_impact_lsoda(e_N: float, f_s: float):
    """The scaled impact with solve_ivp (LSODA, stiff-capable): the fallback of _scaled_impact.

    SciPy's integrators are imported here, for the rare stiff case: importing them with this
    module cost every study job about 0.4 s."""
    from scipy.integrate import solve_ivp

    c = 8.0 * (1.0 - e_N) / (5.0 * e_N)
    x0 = f_s ** (2.0 / 3.0)

    def rhs(_t, y):
        x, u = y
        return (u, 1.25 * (f_s - _force_scaled(x, u, c)))

    def jac(_t, y):
        x, u = y
        xp = x if x > 0.0 else 0.0
        g = 1.0 + c * u
        if xp * math.sqrt(xp) * g <= 0.0:
            return [[0.0, 1.0], [0.0, 0.0]]
        return [[0.0, 1.0], [-1.25 * 1.5 * math.sqrt(xp) * g, -1.25 * xp * math.sqrt(xp) * c]]

    def ev_peak(_t, y):  # dF/dtau, from + to -
        x, u = y
        xp = x if x > 0.0 else 0.0
        du = 1.25 * (f_s - _force_scaled(x, u, c))
        return 1.5 * math.sqrt(xp) * u * (1.0 + c * u) + xp * math.sqrt(xp) * c * du

    ev_peak.direction = -1

    def ev_xmax(_t, y):
        return y[1]

    ev_xmax.direction = -1

    if f_s > 0.0:
        def ev_end(_t, y):  # acceleration back to 0 from below: F falls back to F_s
            return f_s - _force_scaled(y[0], y[1], c)

        ev_end.direction = 1
    else:
        def ev_end(_t, y):  # separation
            return y[0]

        ev_end.direction = -1
    ev_end.terminal = True

    sol = solve_ivp(rhs, (0.0, _TAU_MAX), [x0, 1.0], method=_METHOD, jac=jac,
                    events=(ev_peak, ev_xmax, ev_end), rtol=_RTOL, atol=_ATOL,
                    first_step=1e-6, max_step=0.25)
    if sol.status < 0:  # pragma: no cover - integrator failure
        raise RuntimeError(f"impact integration failed: {sol.message}")
    # candidates for the peak force: events and every accepted step
    cands = [(_force_scaled(x, u, c), t) for t, (x, u) in zip(sol.t, sol.y.T, strict=True)]
    for t, y in zip(sol.t_events[0], sol.y_events[0], strict=True):
        cands.append((_force_scaled(y[0], y[1], c), t))
    f_max, tau_peak = max(cands)
    x_max = float(np.max(sol.y[0]))
    for y in sol.y_events[1]:
        x_max = max(x_max, float(y[0]))
    if len(sol.t_events[2]):
        tau_end = float(sol.t_events[2][0])
        u_end = float(sol.y_events[2][0][1])
    else:
        tau_end = math.nan
        u_end = math.nan
    return f_max, x_max, tau_end, u_end, tau_peak


def peak_force(impulse, v_pre, e_N, K, F_static=0.0, h=None, details=False):
    """Peak Flores contact force of one impact.

    Parameters
    ----------
    impulse : float
        Impulse carried by the impact [N s] (Λ_FI for a simple impact, Λ_FIsuv for an impact on
        persistent contact), > 0.
    v_pre : float
        Approach speed [m/s] (−``vn_pre`` at the impact step), > 0.
    e_N : float
        Normal restitution coefficient, in (0, 1] (e_N = 0 is refused: D ∝ (1 - e_N)/e_N).
    K : float
        Hertz stiffness [N/m^1.5] (:func:`hertz_stiffness`).
    F_static : float
        Static force already carried by the contact [N], F_s = Λ_S/h for an impact on persistent
        contact; 0 for a simple impact. >= 0.
    h : float, optional
        The run's time step [s]; only used to report ``contact_steps`` with ``details``.
    details : bool
        Return a :class:`PeakForce` instead of the bare force.

    Returns
    -------
    float or PeakForce
        F_max [N], or the full result.

    Raises
    ------
    ValueError
        For NaN, infinite or non-positive ``impulse``, ``v_pre``, ``K``, negative ``F_static``,
        ``e_N`` outside (0, 1] or a non-positive ``h``.

    Notes
    -----
    m_eff = impulse / ((1 + e_N) v_pre). The scaled problem (module docstring) is integrated to
    the end of the impact; relative accuracy about 1e-9 on F_max.
    """
    impulse = positive("impulse", impulse)
    v_pre = positive("v_pre", v_pre)
    e_N = _restitution(e_N)
    K = positive("K", K)
    F_static = positive("F_static", F_static, allow_zero=True)
    if h is not None:
        h = positive("h", h)
    scales = _impact_scales(impulse, v_pre, e_N, K)
    scaled = _scaled_impact(e_N, F_static / scales[2])
    if not details:
        return scaled[0] * scales[2]
    return PeakForce(**_unscaled(scaled, scales, v_pre, K, F_static, h))


def _impact_scales(impulse, v_pre, e_N, K):
    """The scales of an impact (module docstring), for numbers or arrays alike: effective mass
    m_eff = impulse / ((1 + e_N) v_pre) [kg], indentation d* [m], force F* [N], time t* [s]."""
    m_eff = impulse / ((1.0 + e_N) * v_pre)
    d_star = (5.0 * m_eff * v_pre**2 / (4.0 * K)) ** 0.4
    return m_eff, d_star, K * d_star**1.5, d_star / v_pre


def _unscaled(scaled, scales, v_pre, K, F_static, h):
    """The fields of :class:`PeakForce` from the scaled impact (f_max, x_max, tau_end, u_end,
    tau_peak) and :func:`_impact_scales`, for numbers or arrays alike."""
    f_max, x_max, tau_end, u_end, tau_peak = scaled
    m_eff, d_star, f_star, t_star = scales
    contact_time = tau_end * t_star
    return {
        "F_max": f_max * f_star,
        "delta_max": x_max * d_star,
        "contact_time": contact_time,
        "v_rebound": -u_end * v_pre,
        "m_eff": m_eff,
        "delta_static": (F_static / K) ** (2.0 / 3.0),
        "t_peak": tau_peak * t_star,
        "contact_steps": contact_time / h if h is not None else contact_time * math.nan,
    }


def peak_forces(impulse, v_pre, e_N, K, F_static=None, h=None) -> dict:
    """:func:`peak_force` with ``details=True`` for many impacts of one restitution at once.

    Parameters
    ----------
    impulse, v_pre, K : array_like
        Impulses [N s], approach speeds [m/s] and Hertz stiffnesses [N/m^1.5] of the impacts,
        each > 0 and finite.
    e_N : float
        Normal restitution coefficient, in (0, 1].
    F_static : array_like, optional
        Static forces [N] (>= 0; default 0: simple impacts).
    h : float, optional
        The run's time step [s], for ``contact_steps``.

    Returns
    -------
    dict of numpy.ndarray
        The fields of :class:`PeakForce`, one entry per impact: the numbers of
        :func:`peak_force` impact by impact, to rounding (NumPy's vectorised powers may differ
        from Python's in the last bit, which moves a force by about 1e-15 and a contact time by
        about 1e-12 relative, inside the integration's tolerance). The scaled problem is
        integrated once per distinct scaled static force, by one compiled loop.

    Raises
    ------
    ValueError
        As :func:`peak_force`, naming the first bad value.
    """
    impulse = np.asarray(impulse, dtype=float).ravel()
    v_pre = np.asarray(v_pre, dtype=float).ravel()
    K = np.asarray(K, dtype=float).ravel()
    F_static = (np.zeros(impulse.size) if F_static is None
                else np.asarray(F_static, dtype=float).ravel())
    e_N = _restitution(e_N)
    if h is not None:
        h = positive("h", h)
    for name, values in (("impulse", impulse), ("v_pre", v_pre), ("K", K)):
        bad = ~(np.isfinite(values) & (values > 0))
        if bad.any():
            positive(name, values[np.flatnonzero(bad)[0]])
    bad = ~(np.isfinite(F_static) & (F_static >= 0))
    if bad.any():
        positive("F_static", F_static[np.flatnonzero(bad)[0]], allow_zero=True)
    # the arithmetic of peak_force, element by element
    scales = _impact_scales(impulse, v_pre, e_N, K)
    distinct, where = np.unique(F_static / scales[2], return_inverse=True)
    c = 8.0 * (1.0 - e_N) / (5.0 * e_N)
    scaled, ok = scaled_impacts_kernel(c, distinct, _RTOL, _ATOL, _TAU_MAX,
                                       _MAX_EXPLICIT_STEPS)
    for i in np.flatnonzero(~ok):  # stiff: LSODA, as _scaled_impact does
        scaled[i] = _scaled_impact_lsoda(e_N, float(distinct[i]))
    return _unscaled(scaled[where.ravel()].T, scales, v_pre, K, F_static, h)
