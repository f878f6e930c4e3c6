"""Adaptive steps of the compliant model against closed forms and against fixed steps.

Undamped Hertz impacts (F_max = K^(2/5) (5 m v^2 / 4)^(3/5), contact time 2.943 delta_max / v)
with steps chosen by the error estimate; an impact that begins inside a long step; the largest
force per race in a window of a steady bearing against a fine fixed step; a step that would
need less than solver.dt_min; the configuration keys and the run file's records.
"""

import copy
import math
import re
import warnings

import numpy as np
import pytest

import simcore
from simcore import kernels as nb
from simcore.config import ConfigError, load_config
from simcore.config.limits import check_run
from simcore.model import SolverError, SolverSettings
from simcore.model.mechanism import ball_in_ring, ball_on_plane, crank_slider

E_STEEL = 2.1e11


def _hertz(m, v, K):
    delta = (5.0 * m * v * v / (4.0 * K)) ** 0.4
    return K ** 0.4 * (5.0 * m * v * v / 4.0) ** 0.6, delta, 2.943 * delta / v


def _crossing(t0, t1, g0, g1, d0, d1):
    """Root in (t0, t1) of the cubic Hermite interpolant of a gap with values g and rates d at
    both ends (bisection on the cubic)."""
    h = t1 - t0

    def gap(s):
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        return h00 * g0 + h10 * h * d0 + h01 * g1 + h11 * h * d1

    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if (gap(mid) > 0.0) == (g0 > 0.0):
            lo = mid
        else:
            hi = mid
    return t0 + 0.5 * (lo + hi) * h


def _contact_time(model, traj):
    """Contact time of the first episode of contact 0 from the gap at the output rows (the
    state at each row's end: the gap of the contact element and its normal velocity there),
    its two zero crossings placed by cubic Hermite interpolation between rows."""
    arr = model.arrays()
    wN, wT = np.zeros(6), np.zeros(6)
    gap = np.array([nb.contact_rows(q, 0, arr.ct_type, arr.ct_body, arr.ct_geom, wN, wT)
                    for q in traj.q])
    vn = traj.vn_post[:, 0]
    closed = np.flatnonzero(gap < 0.0)
    a, b = closed[0], closed[0]
    while gap[b + 1] < 0.0:
        b += 1
    t = traj.time
    start = _crossing(t[a - 1], t[a], gap[a - 1], gap[a], vn[a - 1], vn[a])
    end = _crossing(t[b], t[b + 1], gap[b], gap[b + 1], vn[b], vn[b + 1])
    return end - start


def _adaptive(dt_max, t_end, **kw):
    kw.setdefault("rho_inf", 1.0)
    kw.setdefault("tol", 1e-8)
    return SolverSettings(dt_max, t_end, contact_model="compliant", adaptive=True, **kw)


def test_adaptive_undamped_impact_on_a_plane():
    """Steps of up to 2 us (output every 2 us) choose their size from the error estimate:
    F_max within 0.5 %, indentation within 0.5 %, contact time within 1 % (crossings placed by
    Hermite interpolation of the gap at the rows), rebound = impact speed within 0.1 %."""
    v, m, R = 1.0, 0.0327, 0.01
    model = ball_on_plane(radius=R, mass=m, height=R + 3e-5, e_N=1.0, gravity=0.0,
                          speed=(0.0, -v), youngs_modulus=E_STEEL)
    traj = model.simulate(_adaptive(2e-6, 2e-4))
    K = model.arrays().ct_hertz[0, 0]
    F_exact, delta, t_c = _hertz(m, v, K)
    assert traj.F_N.max() == pytest.approx(F_exact, rel=5e-3)
    assert -traj.gap_N.min() == pytest.approx(delta, rel=5e-3)
    assert _contact_time(model, traj) == pytest.approx(t_c, rel=1e-2)
    assert traj.vn_post[-1, 0] == pytest.approx(v, rel=1e-3)
    rec = traj.extras["adaptive"]
    assert rec["n_steps_accepted"] >= 100 and rec["dt_smallest_s"] < 2e-6


def test_adaptive_undamped_ball_inside_a_ring():
    """The concave element, steps of up to 10 us before and after the impact."""
    v, m, ring, r = 1.0, 2.7e-3, 0.05, 0.0055
    model = ball_in_ring(ring_radius=ring, radius=r, speed=(0.0, v), e_N=1.0, mass=m,
                         start=(0.0, ring - r - 5e-5), youngs_modulus=E_STEEL)
    traj = model.simulate(_adaptive(1e-5, 3e-4, output_every=1))
    K = model.arrays().ct_hertz[0, 0]
    F_exact, delta, t_c = _hertz(m, v, K)
    assert traj.F_N.max() == pytest.approx(F_exact, rel=5e-3)
    assert -traj.gap_N.min() == pytest.approx(delta, rel=5e-3)
    # the contact time from rows 10 us apart (the crossings by Hermite interpolation)
    assert _contact_time(model, traj) == pytest.approx(t_c, rel=1e-2)
    rec = traj.extras["adaptive"]
    # many fewer steps than a fixed step that resolves the contact (t_c / 40) would take
    assert rec["n_steps_accepted"] < 0.5 * 3e-4 / (t_c / 40)


def test_impact_inside_a_long_step_is_found():
    """A ball reaches the plane 37 us into a run whose steps may be 100 us long (output every
    100 us): the step that would jump over the onset is cut at the predicted closing and the
    impact resolved, its peak force within 0.5 % of Hertz's."""
    v, m, R = 1.0, 0.0327, 0.01
    model = ball_on_plane(radius=R, mass=m, height=R + 37e-6, e_N=1.0, gravity=0.0,
                          speed=(0.0, -v), youngs_modulus=E_STEEL)
    traj = model.simulate(SolverSettings(1e-4, 4e-4, contact_model="compliant", adaptive=True))
    K = model.arrays().ct_hertz[0, 0]
    F_exact, _, t_c = _hertz(m, v, K)
    assert traj.F_N.max() == pytest.approx(F_exact, rel=5e-3)
    assert traj.F_N[1, 0] > 0.0  # in the first 100 us interval
    rec = traj.extras["adaptive"]
    assert rec["dt_smallest_s"] < t_c / 10
    assert int(traj.converged.min()) == 1


def _steady_state(name_overrides, t_lead, dt=1e-6):
    cfg = load_config(overrides=[*name_overrides, "model.youngs_modulus=2.1e11",
                                 "model.drive=constant", "model.contact_model=compliant"])
    model = crank_slider(cfg["model"])[0]
    lead = model.simulate(SolverSettings(dt, t_lead, contact_model="compliant",
                                         output_every=10))
    v_pre = lead.extras["compliant_state"].v_pre.copy()
    return model, (lead.q[-1], lead.v[-1], float(lead.time[-1]), v_pre)


# the default rho_inf and the study's twins', each at the default band; and a narrower band
@pytest.mark.parametrize("rho_inf, keep", [(0.0, 1.5), (0.5, 1.5), (0.5, 1.1)])
def test_adaptive_window_of_a_steady_bearing_matches_fixed_steps(rho_inf, keep):
    """The small-clearance point (2e-5 m, mu 0.01, 100 rad/s, e_N 0.7) with steel, restarted
    from the state (and the contacts' onset speeds) after a quarter revolution of fixed steps:
    over the next 2 ms (balls loaded between both races) the largest force per race with
    adaptive steps is within 1 % of a fixed step of 0.25 us, with several times fewer steps,
    at either band where a step keeps its size (solver.adaptive_keep_growth), which changes
    the steps taken."""
    model, (q0, v0, t0, v_pre) = _steady_state(
        ["model.clearance=2e-5", "model.mu=0.01", "model.omega0=100.0", "model.e_N=0.7"],
        0.25 * 2 * math.pi / 100.0)
    window, n = 2e-3, 8
    start = dict(q0=q0, v0=v0, t0=t0, v_pre0=v_pre)
    fixed = model.simulate(SolverSettings(2.5e-7, window, contact_model="compliant",
                                          output_every=40), **start)
    def adaptive_run(keep_growth):
        return model.simulate(SolverSettings(1e-5, window, contact_model="compliant",
                                             adaptive=True, rho_inf=rho_inf,
                                             adaptive_keep_growth=keep_growth), **start)

    adaptive = adaptive_run(keep)
    for race in (slice(0, n), slice(n, 2 * n)):
        ref = fixed.F_N[1:, race].max()
        assert ref > 100.0  # loaded
        assert adaptive.F_N[1:, race].max() == pytest.approx(ref, rel=1e-2)
    steps = adaptive.extras["adaptive"]["n_steps_accepted"]
    assert steps < 8000 / 3
    if keep != 1.5:
        assert steps != adaptive_run(1.5).extras["adaptive"]["n_steps_accepted"]


def test_a_step_below_dt_min_is_an_error_or_a_flag():
    """An error tolerance no step of at least dt_min can meet: on_nonconvergence = error
    stops with one line naming solver.dt_min; warn goes on with the interval flagged and the
    steps counted."""
    v, m, R = 1.0, 0.0327, 0.01
    model = ball_on_plane(radius=R, mass=m, height=R + 5e-6, e_N=1.0, gravity=0.0,
                          speed=(0.0, -v), youngs_modulus=E_STEEL)
    strict = dict(adaptive_tol=1e-16, dt_min=1e-6)
    with pytest.raises(SolverError, match="solver.dt_min"):
        model.simulate(_adaptive(1e-6, 1e-4, **strict))
    with pytest.warns(RuntimeWarning, match="solver.dt_min"):
        traj = model.simulate(_adaptive(1e-6, 1e-4, on_nonconvergence="warn", **strict))
    assert traj.extras["adaptive"]["n_steps_below_dt_min"] > 0
    assert int(traj.converged.min()) == 0


def test_adaptive_settings_are_checked():
    with pytest.raises(ValueError, match="solver.adaptive"):
        SolverSettings(1e-5, 1e-3, adaptive=True)  # nonsmooth
    with pytest.raises(ValueError, match="solver.dt_min"):
        SolverSettings(1e-5, 1e-3, contact_model="compliant", adaptive=True, dt_min=2e-5)
    with pytest.raises(ValueError, match="solver.adaptive_tol"):
        SolverSettings(1e-5, 1e-3, contact_model="compliant", adaptive=True, adaptive_tol=0.0)
    for keep in (0.9, 2.5, float("nan")):
        with pytest.raises(ValueError, match=r"solver.adaptive_keep_growth.*allowed"):
            SolverSettings(1e-5, 1e-3, contact_model="compliant", adaptive=True,
                           adaptive_keep_growth=keep)


@pytest.mark.parametrize("overrides, key", [
    (["solver.adaptive=true"], "solver.adaptive"),
    (["model.contact_model=compliant", "solver.adaptive=true", "solver.dt=1e-6",
      "solver.dt_min=1e-5"], "solver.dt_min"),
    (["model.contact_model=compliant", "solver.adaptive=true", "solver.adaptive_tol=0"],
     "solver.adaptive_tol"),
    (["model.contact_model=compliant", "solver.adaptive=true",
      "solver.adaptive_keep_growth=2.5"], "solver.adaptive_keep_growth"),
])
def test_adaptive_config_keys_are_checked(overrides, key):
    with pytest.raises(ConfigError, match=key):
        load_config(overrides=overrides)


def test_stability_limits_use_the_smallest_adaptive_step():
    """A compliant run with steel at dt = 1e-4 s cannot resolve a contact; with adaptive steps
    the limit applies to dt_min (the error control shortens the step), and a dt_min above it
    is refused naming solver.dt_min."""
    base = ["model.contact_model=compliant", "model.youngs_modulus=2.1e11", "solver.dt=1e-4"]
    with pytest.raises(ConfigError, match="solver.dt:"):
        check_run(load_config(overrides=base))
    assert check_run(load_config(overrides=[*base, "solver.adaptive=true"])) == []
    with pytest.raises(ConfigError, match="solver.dt_min"):
        check_run(load_config(overrides=[*base, "solver.adaptive=true",
                                         "solver.dt_min=5e-5"]))


def test_run_file_records_the_adaptive_steps():
    cfg = load_config(overrides=["model.contact_model=compliant", "solver.adaptive=true",
                                 "solver.dt=1e-5", "solver.t_end=2e-3"])
    ds = simcore.run(cfg)
    assert ds.attrs["solver.adaptive"] in (1, True)
    assert ds.attrs["n_steps_accepted"] >= 200  # at least one step per output interval
    assert ds.attrs["n_steps_rejected"] >= 0
    assert 0.0 < ds.attrs["dt_smallest_s"] <= 1e-5
    assert ds.attrs["n_steps_below_dt_min"] == 0
    assert ds.sizes["time"] == 201
    # the steps of each output interval: none before the first row, at least one in each
    # interval, all of them the accepted steps; a step is at most dt, at least the smallest
    steps = ds["steps"].values
    assert steps.dtype == np.int32 and steps[0] == 0 and np.all(steps[1:] >= 1)
    assert int(steps.sum()) == ds.attrs["n_steps_accepted"]
    assert np.all(steps[1:] <= math.ceil(1e-5 / ds.attrs["dt_smallest_s"]))
    assert ds["steps"].attrs["units"] == "1"
    # the command line's summary counts the steps taken, not the output rows
    from simcore.cli import summary_lines

    first, spread = summary_lines(ds)[:2]
    assert first.startswith(f"steps: {ds.attrs['n_steps_accepted']} adaptive "
                            f"({ds.attrs['n_steps_rejected']} redone)")
    assert f"largest {steps.max()} (interval ending at t = " in spread


def test_a_fixed_step_run_file_has_no_steps_variable():
    ds = simcore.run(load_config(overrides=["model.contact_model=compliant", "solver.dt=1e-5",
                                            "solver.t_end=2e-4"]))
    assert "steps" not in ds and "n_steps_accepted" not in ds.attrs


def test_coarse_output_of_a_driven_compliant_run_passes_the_energy_audit():
    """The drive's work over an output interval of many steps is the torque averaged over the
    interval (its torque impulse over its length) times the rate and the interval, not the
    torque at the row's instant: a driven compliant run with 1 ms output rows (1,000 steps
    each) is not flagged for energy it did not make, nor is an adaptive one."""
    cfg = load_config(overrides=["model.youngs_modulus=2.1e11", "model.clearance=2e-5",
                                 "model.omega0=100.0", "model.drive=constant"])
    model = crank_slider(cfg["model"])[0]
    traj = model.simulate(SolverSettings(1e-6, 0.006, contact_model="compliant",
                                         output_every=1000))
    assert int(traj.converged.min()) == 1
    audit = traj.extras["energy_audit"]
    assert np.all(audit.error <= audit.tolerance)
    traj = model.simulate(SolverSettings(1e-5, 0.006, contact_model="compliant",
                                         output_every=100, adaptive=True))
    assert int(traj.converged.min()) == 1


def test_error_constant_of_the_scheme():
    """beta - 1/6 + (alpha_m - alpha_f)/2: Zienkiewicz-Xie's 1/12 for the trapezoidal rule
    (rho_inf = 1), 1/3 at rho_inf = 0 (alpha_m = -1, alpha_f = 0, beta = 1), 1/9 at the study
    twins' 0.5 (alpha_m = 0, alpha_f = 1/3, beta = 4/9)."""
    from simcore.kernels.compliant_adaptive import error_constant

    assert error_constant(nb.alpha_coefficients(1.0)) == pytest.approx(1.0 / 12.0)
    assert error_constant(nb.alpha_coefficients(0.0)) == pytest.approx(1.0 / 3.0)
    assert error_constant(nb.alpha_coefficients(0.5)) == pytest.approx(1.0 / 9.0)


@pytest.mark.parametrize("keep", [1.0, 1.1, 1.5, 2.0])
def test_next_step_size_keeps_the_plan_inside_its_band(keep):
    """After a step of the planned size h with error ratio r the next size is h 0.9 r^(-1/3)
    (within [0.2, 2] h), except that the plan stays while that lies in [0.95, keep) h; a step
    cut short by the output grid returns to the plan unless its error asks for less."""
    from simcore.kernels.compliant_adaptive import _next_size

    h, dt_max = 1e-6, 1.0
    ad = nb.AdaptiveSettings(1e-4, 1e-12, 1e-9, 40.0, keep)
    for growth in np.linspace(0.1, 2.4, 47) + 0.013:  # off the band's edges (rounding)
        ratio = (0.9 / growth) ** 3  # the ratio whose estimate allows growth h
        wanted = h * min(max(growth, 0.2), 2.0)
        kept = 0.95 <= growth < keep
        assert _next_size(h, h, ratio, False, ad, dt_max) == pytest.approx(
            h if kept else wanted, rel=1e-12), growth
    assert _next_size(h, h, 0.0, False, ad, dt_max) == pytest.approx(2.0 * h)  # no error
    short = 0.3 * h  # cut by the output grid with a small error: back to the plan
    assert _next_size(short, h, 0.5, True, ad, dt_max) == pytest.approx(h, rel=1e-12)
    assert _next_size(short, h, 2.0, True, ad, dt_max) == pytest.approx(
        short * 0.9 * 2.0 ** (-1.0 / 3.0), rel=1e-12)
    assert _next_size(h, h, 1e-6, False, ad, 1.5 * h) == pytest.approx(1.5 * h)  # dt_max


def test_crossing_speed_of_a_quadratic_gap():
    """A gap g0 + v0 t + a t^2 / 2 (its cubic Hermite interpolant is itself) crosses zero at
    the root of the quadratic, with speed v0 + a t."""
    from simcore.kernels.compliant_step import crossing_speed

    g0, v0, a, h = 2e-8, -0.01, -4e3, 3e-6
    g1, v1 = g0 + v0 * h + 0.5 * a * h * h, v0 + a * h
    t = (-v0 - math.sqrt(v0 * v0 - 2.0 * a * g0)) / a
    assert g1 < 0.0 < t < h
    assert crossing_speed(g0, g1, v0, v1, h) == pytest.approx(v0 + a * t, rel=1e-9)


def _onset_case(gap0, gap1, speed):
    """A ball (mass m) on the ground plane: its model arrays, a compliant state with the
    contact open at ``gap0`` [m] and approaching at ``speed`` [m/s], contact work rows with the
    step's end gap ``gap1``."""
    m, R = 0.0327, 0.01
    model = ball_on_plane(radius=R, mass=m, height=R + gap0, e_N=1.0, gravity=0.0,
                          speed=(0.0, -speed), youngs_modulus=E_STEEL)
    arr = model.arrays()
    q, _ = model.initial_state()
    one = lambda x: np.array([x], dtype=np.float64)  # noqa: E731
    cs = nb.CompliantState(
        v_pre=one(speed), closed=np.zeros(1, np.int8), FN=one(0.0), FT=one(0.0),
        gap=one(gap0), vn=one(-speed), vt=one(0.0), FN_max=one(0.0), FT_at_max=one(0.0),
        LN=one(0.0), LT=one(0.0), gap_min=one(np.inf), vn_start=one(-speed),
        it_max=np.zeros(3, np.int64), ok=np.ones(1, np.int8), drive_impulse=one(0.0))
    cwork = np.zeros((11, 1))
    cwork[2, 0] = gap1
    K = arr.ct_hertz[0, 0]
    delta = (5.0 * m * speed**2 / (4.0 * K)) ** 0.4
    return arr, q, cs, cwork, 2.94 * delta / speed


def test_onset_step_and_the_redone_step():
    """The onset step is the Hertz contact time of the contact's approach speed (effective
    mass: the ball's, the plane is the ground) over onset_steps. A step longer than it that
    ends deeper than speed x onset step is redone ending at the linearly estimated crossing;
    one that ends shallower is kept."""
    from simcore.kernels.compliant_adaptive import onset_retry, onset_step
    from simcore.kernels.hertz import hertz_work

    v, n_on = 0.8, 40.0
    arr, q, cs, cwork, t_h = _onset_case(5e-6, -3e-6, v)
    hw = hertz_work()
    h_on = onset_step(0, q, arr, v, n_on, hw, None)
    assert h_on == pytest.approx(t_h / n_on, rel=1e-12)
    h = 1e-5
    assert onset_retry(h, q, cs, cwork, arr, n_on, hw, None) == pytest.approx(
        max(h * 5e-6 / 8e-6, h_on), rel=1e-12)
    cwork[2, 0] = -0.5 * v * h_on  # shallower than one onset step's depth: kept
    assert onset_retry(h, q, cs, cwork, arr, n_on, hw, None) == 0.0
    cwork[2, 0] = -3e-6  # deep, but the step no longer than an onset step: kept
    assert onset_retry(h_on, q, cs, cwork, arr, n_on, hw, None) == 0.0


def test_adaptive_zoom_matches_the_fixed_zoom():
    """A compliant zoom (the paper's case, E = 2.1e9 Pa, on the largest impulse of its first
    4 ms) with adaptive steps of at most 10 us gives the largest contact force of the fixed
    1 us zoom within 1 %, in fewer steps."""
    run = simcore.run(load_config(overrides=["solver.t_end=0.004"]))
    lam = run["Lambda_N"].values
    t = float(run.time[np.unravel_index(int(np.argmax(lam)), lam.shape)[0]])
    fixed = simcore.zoom(run, t, window=5e-4, dt=1e-6, until_released=False, adaptive=False)
    adaptive = simcore.zoom(run, t, window=5e-4, dt=1e-5, output_dt=1e-5,
                            until_released=False)  # (adaptive: the default)
    assert adaptive.attrs["solver.adaptive"] in (1, True)
    assert fixed.attrs["solver.adaptive"] in (0, False)
    ref = float(fixed["F_N"].max())
    assert ref > 100.0
    assert float(adaptive["F_N"].max()) == pytest.approx(ref, rel=1e-2)
    assert adaptive.attrs["n_steps_accepted"] < 500


def _twin_of(point, *overrides):
    """The default study's compliant twin (simcore.study.plan.twin_config) of one grid point
    (clearance [m], mu, omega0 [rad/s], e_N), 1 + 3 revolutions."""
    from simcore.study import plan

    clearance, mu, omega0, e_n = point
    cfg = simcore.load_config("config/config.yaml", overrides=[
        f"sweep.clearance=[{clearance}]", f"sweep.mu=[{mu}]", f"sweep.omega0=[{omega0}]",
        f"sweep.e_N=[{e_n}]", *overrides])
    return next(r.config for r in plan.plan_runs(cfg) if r.model == "compliant")


def _steady_peak_per_race(ds, settle=1.0):
    """The study's steady peak force per race of a compliant run [N] (inner, outer: the summary's
    ``peak_force``, after ``settle`` crank revolutions)."""
    from analysis.summary import SteadyWindow, compliant_numbers

    window = SteadyWindow.of_run(ds, settle)
    return [float(f) for f in compliant_numbers(ds, window, [], None)["peak_force"]]


@pytest.mark.slow
def test_study_twin_whole_run_matches_converged_fixed_steps():
    """The study's twin of the small-clearance point (2e-5 m, mu 0.01, 100 rad/s, e_N 0.7;
    steel, constant drive): over its whole run (the start-up revolution, whose impacts decide
    how the balls share the load, and three steady ones) its steady peak force per race (the
    summary's peak_force) is within 1 % of the same twin with fixed steps of a twentieth of
    the Hertz contact time (simcore.study.plan.twin_step) and with fixed steps twice as long,
    and it stays there with its largest step (the output step) cut from 1e-4 s to 2e-5 s."""
    from simcore.study import plan

    point = (2e-5, 0.01, 100.0, 0.7)
    twin = _twin_of(point)
    adaptive = _steady_peak_per_race(simcore.run(twin))
    shorter = _steady_peak_per_race(simcore.run(_twin_of(point, "solver.dt=2e-5")))
    out_dt = twin["solver"]["output_dt"]
    for n in (20, 10):
        fixed_cfg = copy.deepcopy(twin)
        dt = plan.twin_step(twin["model"], dict(twin["analysis"], zoom_steps_per_contact=n),
                            out_dt)
        fixed_cfg["solver"].update(adaptive=False, dt=dt)
        fixed = _steady_peak_per_race(simcore.run(fixed_cfg))
        assert min(fixed) > 1000.0  # the balls carry the load
        assert adaptive == pytest.approx(fixed, rel=1e-2)
        assert shorter == pytest.approx(fixed, rel=1e-2)


#: the grooved study point (4e-4 m, mu 0.01, 25 rad/s, e_N 1, steel, constant drive) whose
#: twin's energy error grows with its tolerance (docs/compliant.md, "Energy and the tolerance")
GROOVE_POINT_E1 = [
    "model.contact_model=compliant", "model.contact_geometry=groove", "model.clearance=4e-4",
    "model.mu=0.01", "model.omega0=25.0", "model.e_N=1.0", "model.drive=constant",
    "model.cage_stiffness=1e5", "model.cage_damping=1e3", "model.youngs_modulus=2.1e11",
    "model.poisson_ratio=0.3"]


def _groove_point_e1():
    return crank_slider(load_config(overrides=GROOVE_POINT_E1)["model"])[0]


def _twin_settings(tol, retries, **changes):
    # energy_tol 0.0035: the window gain at 1e-8 m (0.081 J) is 1.4 times what it allows, at
    # 1e-9 m (0.036 J) 0.6 times
    return SolverSettings(1e-4, 0.02, contact_model="compliant", adaptive=True, rho_inf=0.5,
                          adaptive_tol=tol, adaptive_retries=retries, energy_tol=0.0035,
                          **changes)


def test_an_adaptive_run_that_creates_energy_is_run_again_at_a_tenth_of_its_tolerance():
    """At 1e-8 m the run's steps create energy together (the energy audit's window); with one
    retry it is run again at 1e-9 m and gives that run's numbers exactly, recording the retry.
    A tolerance still too loose after its retries stops the run or is flagged as before."""
    model = _groove_point_e1()
    with pytest.raises(SolverError, match="energy audit: steps"):
        model.simulate(_twin_settings(1e-8, 0))
    tight = model.simulate(_twin_settings(1e-9, 0))
    retried = model.simulate(_twin_settings(1e-8, 1))
    assert int(retried.converged.min()) == 1
    records = retried.extras["adaptive"]
    assert records["n_tolerance_retries"] == 1 and records["adaptive_tol_used"] == 1e-9
    assert tight.extras["adaptive"]["n_tolerance_retries"] == 0
    np.testing.assert_array_equal(retried.F_N, tight.F_N)
    # the steps of both tries: the first try's are those of the same run flagged, summed up
    # to a row at or after the audit's first failure (where the try stopped)
    assert tight.extras["adaptive"]["n_steps_all_tries"] == tight.extras["adaptive"][
        "n_steps_accepted"]
    with pytest.warns(RuntimeWarning, match="energy audit: steps"):
        loose = model.simulate(_twin_settings(1e-8, 0, on_nonconvergence="warn"))
    first_try = records["n_steps_all_tries"] - records["n_steps_accepted"]
    summed = np.cumsum(loose.extras["adaptive"]["row_steps"])
    failed_row = int(np.flatnonzero(loose.converged == 0)[0])
    assert first_try in summed[failed_row:]
    np.testing.assert_array_equal(retried.energy, tight.energy)
    again = ("run again 1 time(s) after the energy audit failed, solver.adaptive_tol now "
             "1e-08 m (solver.adaptive_retries = 1)")
    with pytest.raises(SolverError, match="energy audit: steps") as stopped:
        model.simulate(_twin_settings(1e-7, 1))
    assert again in str(stopped.value)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        flagged = model.simulate(_twin_settings(1e-7, 1, on_nonconvergence="warn"))
    # one warning, of the last try: the first try's failure is not reported
    assert len(said) == 1 and str(said[0].message).startswith("energy audit: steps")
    assert again in str(said[0].message)
    assert int(flagged.converged.min()) == 0
    records = flagged.extras["adaptive"]
    assert records["n_tolerance_retries"] == 1 and records["adaptive_tol_used"] == 1e-8


def test_a_run_whose_first_failure_is_not_the_energy_audit_is_not_run_again():
    """An indentation beyond the allowed range (here 1e-4 of the ball's radius) before the
    steps create energy is not the tolerance's doing: the run is not run again."""
    model = _groove_point_e1()
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        traj = model.simulate(_twin_settings(1e-8, 1, on_nonconvergence="warn",
                                             max_indentation=1e-4))
    messages = [str(w.message) for w in said]
    indented = [re.match(r"integrity check 'indentation' failed at step (\d+)", m)
                for m in messages]
    created = [re.match(r"energy audit: steps \d+ to (\d+)", m) for m in messages]
    first_indented = min(int(m.group(1)) for m in indented if m)
    first_created = min(int(m.group(1)) for m in created if m)
    assert first_indented < first_created  # the audit fails, but not first
    assert traj.extras["adaptive"]["n_tolerance_retries"] == 0


def test_run_file_and_summary_record_a_run_again_at_a_smaller_tolerance():
    from simcore.cli import summary_lines

    cfg = load_config(overrides=[*GROOVE_POINT_E1, "solver.adaptive=true", "solver.dt=1e-4",
                                 "solver.t_end=0.02", "solver.rho_inf=0.5",
                                 "solver.adaptive_tol=1e-8", "solver.energy_tol=0.0035"])
    ds = simcore.run(cfg)
    assert ds.attrs["n_tolerance_retries"] == 1 and ds.attrs["adaptive_tol_used"] == 1e-9
    assert ds.attrs["n_steps_all_tries"] > ds.attrs["n_steps_accepted"] == ds["steps"].sum()
    assert ds.attrs["solver.adaptive_tol"] == 1e-8 and ds.attrs["n_energy_gain_steps"] == 0
    assert ("run again 1 time(s) after the energy audit failed: solver.adaptive_tol 1e-08 -> "
            "1e-09 m") in summary_lines(ds)


def test_adaptive_retries_are_checked():
    for bad in (-1, 4, 1.5, True):
        with pytest.raises(ValueError, match="solver.adaptive_retries"):
            SolverSettings(1e-5, 1e-3, contact_model="compliant", adaptive=True,
                           adaptive_retries=bad)
        with pytest.raises(ValueError, match="solver.adaptive_retries"):  # (fixed steps too)
            SolverSettings(1e-5, 1e-3, adaptive_retries=bad)
    with pytest.raises(ConfigError, match="solver.adaptive_retries"):
        load_config(overrides=["solver.adaptive_retries=4"])
