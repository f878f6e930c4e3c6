"""Every Numba kernel is called once with the types the driver uses, so typing errors show up
here and not in the middle of a sweep; each call is also checked against a known answer."""

import numpy as np
import pytest

from simcore import integrator as nb
from simcore.config import load_config
from simcore.mechanism import ball_on_plane, crank_slider, pinched_balls


@pytest.fixture(scope="module")
def bearing():
    model, layout = crank_slider(load_config()["model"])
    return model, layout, model.arrays()


def test_body_point_and_omega():
    q = np.array([1.0, 2.0, np.pi / 2])
    x, y, ax, ay = nb.body_point(q, 0, 1.0, 0.0)
    assert (x, y) == pytest.approx((1.0, 3.0)) and (ax, ay) == pytest.approx((0.0, 1.0))
    assert nb.body_point(q, -1, 4.0, 5.0) == (4.0, 5.0, 0.0, 0.0)
    assert nb.body_omega(np.array([0.0, 0.0, 3.0]), 0) == 3.0
    assert nb.body_omega(q, -1) == 0.0


def test_alpha_coefficients():
    assert nb.alpha_coefficients(0.0) == pytest.approx((-1.0, 0.0, 1.5, 1.0))
    assert nb.alpha_coefficients(1.0) == pytest.approx((0.5, 0.5, 0.5, 0.25))


def test_bilateral_jacobian_matches_finite_differences(bearing):
    model, _, arr = bearing
    q, v = model.initial_state()
    q = q + 1e-3 * np.sin(np.arange(q.size))
    m = nb.joint_row_count(arr["jt_type"])
    n = q.size
    g, G, gam, dgdt = np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)
    nb.bilateral(q, v, 0.0, arr["jt_type"], arr["jt_body"], arr["jt_geom"], g, G, gam, dgdt)
    eps = 1e-7
    for i in range(n):
        dq = q.copy()
        dq[i] += eps
        g2 = np.zeros(m)
        nb.bilateral(dq, v, 0.0, arr["jt_type"], arr["jt_body"], arr["jt_geom"], g2,
                     np.zeros((m, n)), np.zeros(m), np.zeros(m))
        np.testing.assert_allclose((g2 - g) / eps, G[:, i], atol=1e-6)


def test_contact_rows_match_finite_differences(bearing):
    model, _, arr = bearing
    q, v = model.initial_state()
    q = q + 1e-4 * np.cos(np.arange(q.size))
    wN, wT = np.zeros(6), np.zeros(6)
    eps = 1e-8
    for k in range(arr["ct_type"].size):
        g = nb.contact_rows(q, k, arr["ct_type"], arr["ct_body"], arr["ct_geom"], wN, wT)
        row = np.zeros(q.size)
        nb._scatter_row(row, wN, arr["ct_body"][k, 0], arr["ct_body"][k, 1])
        fd = np.zeros(q.size)
        for i in range(q.size):
            dq = q.copy()
            dq[i] += eps
            fd[i] = (nb.contact_rows(dq, k, arr["ct_type"], arr["ct_body"], arr["ct_geom"],
                                     np.zeros(6), np.zeros(6)) - g) / eps
        np.testing.assert_allclose(fd, row, atol=1e-6)
        assert nb._row_dot(wN, arr["ct_body"][k, 0], arr["ct_body"][k, 1], v) == pytest.approx(
            row @ v)


def test_plane_contact_and_velocities():
    model = ball_on_plane(radius=0.1, height=0.5, spin=2.0)
    arr = model.arrays()
    q, v = model.initial_state()
    v[0] = 0.3
    gap, vn, vt = np.zeros(1), np.zeros(1), np.zeros(1)
    nb.contact_velocities(q, v, arr["ct_type"], arr["ct_body"], arr["ct_geom"], gap, vn, vt)
    assert gap[0] == pytest.approx(0.4)
    assert vn[0] == pytest.approx(0.0)
    # t = e_z x n = (-1, 0); contact point velocity x: 0.3 + omega R
    assert vt[0] == pytest.approx(-(0.3 + 2.0 * 0.1))


def test_smooth_forces_tangents_match_finite_differences(bearing):
    model, _, arr = bearing
    q, v = model.initial_state()
    q = q + 1e-4 * np.sin(3 * np.arange(q.size))
    n = q.size
    f, K, C, Ks = np.zeros(n), np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    nb.smooth_forces(q, v, arr["mass"], arr["gvec"], arr["sp_body"], arr["sp_geom"], f, K, C,
                     Ks, True)
    # the metric part is symmetric positive semi-definite
    np.testing.assert_allclose(Ks, Ks.T, atol=1e-9)
    assert np.linalg.eigvalsh(Ks).min() >= -1e-6 * np.abs(Ks).max()
    np.testing.assert_allclose(C, C.T, atol=1e-9)
    # springs point at ball centres: no lever arms, so K is the exact tangent
    eps = 1e-7
    for i in range(n):
        dq = q.copy()
        dq[i] += eps
        f2 = np.zeros(n)
        nb.smooth_forces(dq, v, arr["mass"], arr["gvec"], arr["sp_body"], arr["sp_geom"], f2,
                         np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n)), False)
        np.testing.assert_allclose(-(f2 - f) / eps, K[:, i], rtol=1e-4, atol=1e-2)
    energy = nb.total_energy(q, v, arr["mdiag"], arr["mass"], arr["gvec"], arr["sp_body"],
                             arr["sp_geom"])
    assert np.isfinite(energy)


def test_initial_acceleration_of_free_fall():
    model = ball_on_plane()
    arr = model.arrays()
    q, v = model.initial_state()
    vdot, lam = np.zeros(3), np.zeros(0)
    nb.initial_acceleration(q, v, 0.0, arr["mdiag"], arr["mass"], arr["gvec"], arr["sp_body"],
                            arr["sp_geom"], arr["jt_type"], arr["jt_body"], arr["jt_geom"],
                            vdot, lam)
    np.testing.assert_allclose(vdot, [0.0, -9.81, 0.0])


def test_stage_kernels_on_a_pinched_ball():
    """smooth_step, position_step, velocity_step, solve_velocity_problem, integrate_chunk."""
    model = pinched_balls(n_balls=1, load=10.0)
    traj = model.simulate(1e-4, 2e-3)  # drives integrate_chunk and the three stages
    assert traj.converged.all()
    # the velocity problem alone: one frictionless contact, approaching at 1 m/s, e_N = 0.5
    D = np.array([[2.0]])
    c = np.array([-1.0 + 0.5 * -1.0])
    lam = np.zeros(1)
    its, ok = nb.solve_velocity_problem(D, c, np.array([1]), np.zeros(1), np.zeros(1,
                                        dtype=np.int64), lam, 1e-12, 20, 0.0)
    assert ok and lam[0] == pytest.approx(0.75)  # xi = 2 lam - 1.5 = 0
