"""Validation scenes against closed-form solutions (docs/model.md, contact elements and laws)."""

import numpy as np
import pytest

from simcore.model import SolverSettings
from simcore.model.mechanism import ball_in_ring, ball_on_plane, pinched_balls

G = 9.81


def _impacts(traj, threshold=1e-6):
    lam = traj.lambda_N[:, 0]
    return np.nonzero(lam > threshold)[0]


def test_bouncing_ball_impact_times_and_rebound():
    h, e_N, tol = 1e-3, 0.5, 1e-5
    model = ball_on_plane(radius=0.1, mass=1.0, height=1.0, e_N=e_N)
    traj = model.simulate(SolverSettings(h, 1.2, tol=tol))
    # closed form: fall of 0.9 m, then flights of 2 e^k v1 / g
    v1 = np.sqrt(2 * G * 0.9)
    t_exact = np.cumsum([v1 / G, 2 * e_N * v1 / G, 2 * e_N**2 * v1 / G])
    v_exact = v1 * e_N ** np.arange(3)
    idx = _impacts(traj)[:3]
    assert len(idx) == 3
    # an impact is resolved in the step whose predicted position first penetrates: within one
    # step of the exact time, plus the O(h) restitution drift accumulated by earlier bounces
    assert traj.time[idx[0]] - t_exact[0] >= 0.0
    assert np.all(np.abs(traj.time[idx] - t_exact) <= 2 * h), traj.time[idx] - t_exact
    # Newton's law on the step's velocities: exact ratio; against the exact impact speed the
    # pre-impact velocity taken at the start of the step costs at most g h
    ratio = traj.vn_post[idx, 0] / -traj.vn_pre[idx, 0]
    np.testing.assert_allclose(ratio, e_N, rtol=1e-4)
    # the flight between bounces conserves energy, so the impact speed of bounce k is the
    # rebound speed of bounce k-1 (v1 for the first); the step's start velocity lags it by < g h
    rebound = traj.vn_post[idx, 0]
    impact = np.concatenate([[v1], rebound[:-1]])
    assert np.all(np.abs(rebound - e_N * impact) <= e_N * G * h + 1e-5), rebound - e_N * impact
    # against the exact bounce sequence the lags add up: bounce k inherits e_N times the error
    # of bounce k-1
    drift = e_N * G * h * np.cumsum(e_N ** np.arange(3)) + 1e-5
    assert np.all(np.abs(rebound - e_N * v_exact) <= drift)
    # no penetration beyond the position tolerance
    assert traj.gap_N.min() >= -tol * h
    assert traj.converged.all()


@pytest.mark.parametrize("spin, x_roll, w_roll", [(50.0, -1.4286, 14.286),
                                                 (10.0, -0.2857, 2.857)])
def test_spinning_ball_rolls(spin, x_roll, w_roll):
    m, R, mu = 1.0, 0.1, 0.2
    theta = 0.4 * m * R**2
    model = ball_on_plane(radius=R, mass=m, height=1.0, spin=spin, mu=mu, e_N=0.0)
    traj = model.simulate(SolverSettings(1e-3, 1.2))
    xdot, w = traj.v[:, 0], traj.v[:, 2]
    # closed form: rolling speed from conservation of angular momentum about the contact point
    assert w_roll == pytest.approx(theta * spin / (theta + m * R**2), rel=1e-4)
    np.testing.assert_allclose(xdot[-1], x_roll, rtol=1e-3)
    np.testing.assert_allclose(w[-1], w_roll, rtol=1e-3)
    # the invariant Theta w - m R xdot = Theta w0 holds at every step (contact phase included)
    np.testing.assert_allclose(theta * w - m * R * xdot, theta * spin, rtol=1e-9)
    first = _impacts(traj)[0]
    if spin == 50.0:
        # slides at impact: friction impulse mu P_N, P_N = m v_impact
        P_N = traj.lambda_N[first, 0]
        assert abs(traj.lambda_T[first, 0]) == pytest.approx(mu * P_N, rel=1e-6)
        # sliding phase: rolling sets in near t = 0.728 s (friction decelerates at mu g)
        v_imp = np.sqrt(2 * G * 0.9)
        t_hit = v_imp / G
        slip0 = 0.0 + R * spin - mu * v_imp * (1 / m + R**2 / theta) * m
        t_roll = t_hit + slip0 / (mu * G * (1 + m * R**2 / theta))
        slip = xdot + R * w
        rolling = np.nonzero(np.abs(slip) < 1e-6)[0]
        rolling = rolling[traj.time[rolling] > t_hit]
        assert abs(traj.time[rolling[0]] - t_roll) <= 2e-3, (traj.time[rolling[0]], t_roll)
    else:
        # sticks at once: rolling right after the impact step
        assert abs(xdot[first] + R * w[first]) < 1e-6
        np.testing.assert_allclose(xdot[first], x_roll, rtol=1e-3)


def test_ball_in_ring_keeps_speed_and_never_penetrates():
    h, tol = 1e-4, 1e-5
    model = ball_in_ring(ring_radius=0.05, radius=0.005, speed=(1.0, 0.37), e_N=1.0)
    traj = model.simulate(SolverSettings(h, 0.5, tol=tol))
    n_bounces = len(_impacts(traj, 1e-9))
    assert n_bounces >= 5
    speed = np.hypot(traj.v[:, 0], traj.v[:, 1])
    v0 = np.hypot(1.0, 0.37)
    # each elastic bounce keeps the speed up to the turn of the normal within one step,
    # O((v h / R)^2) relative
    assert np.max(np.abs(speed - v0)) <= 1e-3 * v0
    assert traj.gap_N.min() >= -tol * h
    assert traj.converged.all()


@pytest.mark.parametrize("n_balls", [1, 3])
def test_pinched_balls_converge_and_carry_the_load(n_balls):
    h, tol, load = 1e-4, 1e-5, 50.0
    model = pinched_balls(n_balls=n_balls, load=load)
    traj = model.simulate(SolverSettings(h, 0.02, tol=tol))
    assert traj.converged.all()
    assert traj.gap_N.min() >= -tol * h
    # balance of the outer race: the upward impulses from the balls carry its weight
    weight = model.mass[0] * G
    nc = traj.lambda_N.shape[1]
    outer = np.arange(1, nc, 2)
    # vertical component of each outer contact impulse: the ball pushes the race along -n
    q = traj.q[-1]
    up = 0.0
    for k, c in enumerate(outer):
        bx, by = q[3 * (k + 1)], q[3 * (k + 1) + 1]
        ox, oy = q[0], q[1]
        n_y = (by - oy) / np.hypot(bx - ox, by - oy)
        up += n_y * traj.lambda_N[-1, c]  # impulse on the race: +Lambda_N n
    assert up / h == pytest.approx(weight, rel=1e-3)
    # and the outer race does not move: the balls hold it
    assert np.max(np.abs(traj.v[-50:, 1])) < 1e-6


def test_vn_free_is_the_velocity_before_the_jump():
    """vn_free = G_N(q_{n+1}) v~_{n+1}: for a frictionless ball on a fixed plane the jump of the
    normal velocity is Lambda_N / m exactly, and without impulse nothing jumps (gravity is the
    same force at q~ and q_{n+1})."""
    m, h = 2.0, 1e-3
    traj = ball_on_plane(radius=0.1, mass=m, height=0.5, e_N=0.7).simulate(SolverSettings(h, 0.8))
    jump = traj.vn_post[1:, 0] - traj.vn_free[1:, 0]
    np.testing.assert_allclose(jump, traj.lambda_N[1:, 0] / m, atol=1e-12)
    hits = _impacts(traj)
    assert len(hits) >= 2
    # before the jump of an impact step the ball approaches; after it, it separates
    assert np.all(traj.vn_free[hits, 0] < 0.0) and np.all(traj.vn_post[hits, 0] > 0.0)
    # t = 0: no jump yet, the initial normal velocity
    assert traj.vn_free[0, 0] == traj.vn_pre[0, 0]


@pytest.mark.parametrize("solver", [
    ["model.contact_model=nonsmooth", "solver.t_end=0.005"],
    ["model.contact_model=compliant", "model.youngs_modulus=2.1e11", "solver.dt=1e-6",
     "solver.t_end=0.0005"],
    ["model.contact_model=compliant", "model.youngs_modulus=2.1e11", "solver.adaptive=true",
     "solver.dt=1e-5", "solver.t_end=0.003"]], ids=["nonsmooth", "compliant", "adaptive"])
def test_the_mechanism_at_rest_without_gravity_stays_at_rest(solver):
    """No gravity, no drive speed: no force acts, so nothing moves. Every step converges (the
    smooth stage's forces are rounding, judged against its force scale's floor, not against
    themselves), and the positions stay where they started."""
    import simcore

    cfg = simcore.load_config(overrides=solver + ["model.gravity=0", "model.omega0=0",
                                                  "model.drive=free"])
    ds = simcore.run(cfg)  # on_nonconvergence = error: a failed step would stop it
    assert int(ds["converged"].min()) == 1
    assert ds.attrs.get("n_retried_steps", 0) == 0
    position = ds["position"].values
    assert np.abs(position - position[0]).max() < 1e-12  # [m]
    assert float(np.abs(ds["Lambda_N"]).max()) == 0.0
