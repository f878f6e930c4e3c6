"""The compliant model of the bearing alone, run to rest under a constant radial load, against
the static load distribution of a ball ring (analysis.load_distribution, derived and tested
against closed forms in tests/test_load_distribution.py).

Scene (simcore.model.mechanism.bearing_alone): the inner race is the ground, the outer race a
free body (rotation held) whose weight is the load; eight balls with the cage springs, damped
Hertz contacts (e_N = 0.5) with the paper's friction mu = 0.01. The load pushes the outer race
down, so the balls near +y carry it: a ball at pi/2 puts it under the load, balls at
pi/2 +- pi/8 straddle it.

What separates the two, and the tolerances:
- the distribution is first order in delta_r / R_pitch (the two contact normals of a ball are
  taken collinear, along the ball's nominal angle); at E = 2.1e9 Pa and 1 kN, delta_r is
  0.6-1.0 mm against R_pitch = 39 mm. The compliant runs show the neglected terms move the
  largest ball load by 0.02-0.05 % against the nominal angles (measured at dt = 2e-5 s and
  1e-5 s: the same to 1e-7);
- each ball's two contact forces differ by the pull of the cage springs (the balls next to the
  load line spread by up to 1 degree) and the ball's weight: 0.1-0.5 % of the largest load at
  2.1e9 Pa, 0.05 % with steel; the ball load compared is the mean of the two.
Bound: 1 % of the largest ball load at E = 2.1e9 Pa, 0.2 % with steel.
With mu = 0 the straddling pair at 0.4 mm and 2.1e9 Pa is not at rest after 0.3 s (the cage
creeps off the symmetric position, which is unstable without friction); the paper's mu holds
it, and at rest the regularised friction force is zero, so it does not carry load.
"""

import numpy as np
import pytest

from analysis.load_distribution import ball_loads, ball_stiffness
from simcore.config import load_config
from simcore.model.mechanism import bearing_alone

LOAD = 1000.0  # [N]
CASES = {  # E [Pa]: (dt [s], duration [s], tolerance on the ball loads / Q_max)
    2.1e9: (2e-5, 0.3, 1e-2),
    2.1e11: (1e-5, 0.1, 2e-3),
}


def _settle(E, clearance, straddle):
    model = load_config(overrides=[f"model.youngs_modulus={E}", f"model.clearance={clearance}",
                                   "model.e_N=0.5"])["model"]
    Z = model["n_balls"]
    phase = np.pi / 2 + (np.pi / Z if straddle else 0.0)
    m, balls = bearing_alone(model, LOAD, phase)
    dt, duration, tol = CASES[E]
    every = int(round(1e-3 / dt))
    run = m.simulate(dt, duration, contact_model="compliant", output_every=every)
    K_s = ball_stiffness(model["ball_radius"], model["inner_radius"], clearance, E,
                         model["poisson_ratio"])[2]
    reference = ball_loads(LOAD, phase + 2 * np.pi * np.arange(Z) / Z, clearance, K_s,
                           load_angle=np.pi / 2)
    return run, Z, reference, tol


def _check(run, Z, reference, tol):
    assert run.converged.all()
    F_in, F_out = run.F_N[-1, :Z], run.F_N[-1, Z:]
    # at rest: the largest load moved by less than 1e-3 over the last fifth of the run
    tail = run.F_N[int(0.8 * len(run.time)):, Z:].max(axis=1)
    assert np.ptp(tail) < 1e-3 * reference.q_max
    q_max = reference.q_max
    np.testing.assert_allclose(0.5 * (F_in + F_out), reference.Q, rtol=0, atol=tol * q_max)
    np.testing.assert_allclose(F_out, reference.Q, rtol=0, atol=tol * q_max)
    # the outer race sank by delta_r (it is the free body, index 0, moving along -y)
    assert -run.q[-1, 1] == pytest.approx(reference.delta_r, rel=tol)


@pytest.mark.parametrize("E, clearance, straddle", [(2.1e9, 1e-5, False), (2.1e11, 4e-4, True)])
def test_bearing_alone_settles_on_the_load_distribution(E, clearance, straddle):
    _check(*_settle(E, clearance, straddle))


@pytest.mark.slow
@pytest.mark.parametrize("straddle", [False, True])
@pytest.mark.parametrize("clearance", [1e-5, 4e-4])
@pytest.mark.parametrize("E", [2.1e9, 2.1e11])
def test_bearing_alone_every_case(E, clearance, straddle):
    """Small (10 um: three or four balls share the load at 2.1e9 Pa) and large (0.4 mm: two,
    one with steel) clearance, both moduli, a ball under the load and two astride it."""
    run, Z, reference, tol = _settle(E, clearance, straddle)
    _check(run, Z, reference, tol)


def test_bearing_alone_bad_input():
    model = load_config()["model"]
    with pytest.raises(ValueError, match="fixed"):
        bearing_alone(model, LOAD, fixed="cage")
    with pytest.raises(ValueError, match="load"):
        bearing_alone(model, -1.0)
