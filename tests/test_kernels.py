"""Every Numba kernel is called once with the types the driver uses, so typing errors show up
here and not in the middle of a sweep; each call is also checked against a known answer."""

import numpy as np
import pytest

from simcore import kernels as nb
from simcore.config import load_config
from simcore.kernels.bodies import body_point_cached, trig_cache
from simcore.kernels.contact import (
    contact_hessian_into,
    contact_rows_cached,
    contact_velocities_into,
)
from simcore.kernels.hertz import FN_ROW, FT_ROW, VT_ROW, contact_records
from simcore.kernels.joints import bilateral_cached
from simcore.kernels.springs import smooth_forces_into, spring_damping_into
from simcore.model import SolverSettings
from simcore.model.mechanism import ball_on_plane, crank_slider, pinched_balls


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
    m = nb.joint_row_count(arr.jt_type)
    n = q.size
    g, G, gam, dgdt = np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)
    nb.bilateral(q, v, 0.0, arr, g, G, gam, dgdt)
    eps = 1e-7
    for i in range(n):
        dq = q.copy()
        dq[i] += eps
        g2 = np.zeros(m)
        nb.bilateral(dq, v, 0.0, arr, g2,
                     np.zeros((m, n)), np.zeros(m), np.zeros(m))
        np.testing.assert_allclose((g2 - g) / eps, G[:, i], atol=1e-6)
    # every joint row's non-zeros lie in its support: the columns of the joint's bodies
    cols, ncols = np.zeros((m, 6), dtype=np.int64), np.zeros(m, dtype=np.int64)
    nb.joint_support(arr.jt_type, arr.jt_body, cols, ncols)
    row = 0
    for j, kind in enumerate(arr.jt_type):
        bodies = [b for b in arr.jt_body[j] if b >= 0]
        expected = sorted(3 * b + a for b in bodies for a in range(3))
        for r in range(row, row + (1 if kind == nb.JOINT_ANGLE else 2)):
            assert sorted(cols[r, :ncols[r]]) == expected
            assert set(np.flatnonzero(G[r])) <= set(expected)
        row += 1 if kind == nb.JOINT_ANGLE else 2
    assert row == m


def test_contact_rows_match_finite_differences(bearing):
    model, _, arr = bearing
    q, v = model.initial_state()
    q = q + 1e-4 * np.cos(np.arange(q.size))
    wN, wT = np.zeros(6), np.zeros(6)
    eps = 1e-8
    for k in range(arr.ct_type.size):
        nb.contact_rows(q, k, arr.ct_type, arr.ct_body, arr.ct_geom, wN, wT)
        row = np.zeros(q.size)
        nb.scatter_row(row, wN, arr.ct_body[k, 0], arr.ct_body[k, 1])
        fd = np.zeros(q.size)
        for i in range(q.size):  # central: the rings' guard has centres 1e-4 m apart
            gaps = []
            for step in (eps, -eps):
                dq = q.copy()
                dq[i] += step
                gaps.append(nb.contact_rows(dq, k, arr.ct_type, arr.ct_body, arr.ct_geom,
                                            np.zeros(6), np.zeros(6)))
            fd[i] = (gaps[0] - gaps[1]) / (2 * eps)
        np.testing.assert_allclose(fd, row, atol=1e-6)
        assert nb.row_dot(wN, arr.ct_body[k, 0], arr.ct_body[k, 1], v) == pytest.approx(
            row @ v)
        # the row's support holds every non-zero, and the placed row is the scattered one
        cols = np.zeros((2, 6), dtype=np.int64)
        m = nb.pair_support(arr.ct_body[k, 0], arr.ct_body[k, 1], cols, 1)
        assert set(np.flatnonzero(row)) <= set(cols[1, :m]) and len(set(cols[1, :m])) == m
        placed = np.zeros((3, q.size))
        nb.place_row(placed, 2, wN, arr.ct_body[k, 0], arr.ct_body[k, 1])
        np.testing.assert_array_equal(placed[2], row)
        assert nb.support_dot(placed, 2, cols, 1, m, v) == pytest.approx(row @ v, rel=1e-14)


def test_plane_contact_and_velocities():
    model = ball_on_plane(radius=0.1, height=0.5, spin=2.0)
    arr = model.arrays()
    q, v = model.initial_state()
    v[0] = 0.3
    gap, vn, vt = np.zeros(1), np.zeros(1), np.zeros(1)
    nb.contact_velocities(q, v, arr, gap, vn, vt)
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
    nb.smooth_forces(q, v, arr, f, K, C,
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
        nb.smooth_forces(dq, v, arr, f2,
                         np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n)), False)
        np.testing.assert_allclose(-(f2 - f) / eps, K[:, i], rtol=1e-4, atol=1e-2)
        # C = -df/dv, and the velocity jump's damping matrix alone is the same C
        dv = v.copy()
        dv[i] += eps
        f3 = np.zeros(n)
        nb.smooth_forces(q, dv, arr, f3, K, K, K, False)
        np.testing.assert_allclose(-(f3 - f) / eps, C[:, i], rtol=1e-4, atol=1e-2)
    C_alone = np.zeros((n, n))
    nb.spring_damping(q, v, arr, C_alone)
    np.testing.assert_allclose(C_alone, C, rtol=1e-14, atol=0.0)
    # the tangents live in the springs' body-pair blocks, the only entries that get cleared
    mask = np.zeros((n, n), dtype=bool)
    for bi, bj in arr.sp_body:
        cols = [3 * b + a for b in (bi, bj) if b >= 0 for a in range(3)]
        mask[np.ix_(cols, cols)] = True
    assert not K[~mask].any() and not C[~mask].any() and not Ks[~mask].any()
    junk = np.full((n, n), 7.0)
    nb.clear_pair_blocks(junk, arr.sp_body)
    np.testing.assert_array_equal(junk == 0.0, mask)
    scaled = np.full((n, n), 7.0)
    nb.scale_pair_blocks(scaled, Ks, 0.5, arr.sp_body)
    np.testing.assert_array_equal(scaled, np.where(mask, 0.5 * Ks, 7.0))
    newton = np.full((n, n), 7.0)
    h, gam, beta, ca = 1e-4, 1.5, 1.0, 0.5
    nb.fill_pair_blocks(newton, C, K, h, gam, beta, ca, arr.sp_body, 2)
    np.testing.assert_allclose(newton, np.where(mask, (C * h * gam + K * h * h * beta) * ca, 7.0),
                               rtol=1e-15, atol=0.0)
    # a second evaluation into the filled matrices gives the same tangents
    K2, C2, Ks2 = K.copy(), C.copy(), Ks.copy()
    nb.smooth_forces(q, v, arr, np.zeros(n), K2, C2, Ks2, True)
    np.testing.assert_array_equal(K2, K)
    np.testing.assert_array_equal(C2, C)
    np.testing.assert_array_equal(Ks2, Ks)
    energy = nb.total_energy(q, v, arr)
    assert np.isfinite(energy)


def test_initial_acceleration_of_free_fall():
    model = ball_on_plane()
    arr = model.arrays()
    q, v = model.initial_state()
    vdot, lam = np.zeros(3), np.zeros(0)
    nb.initial_acceleration(q, v, 0.0, arr, np.zeros(3), vdot, lam, nb.smooth_work(3, 0))
    np.testing.assert_allclose(vdot, [0.0, -9.81, 0.0])


def test_initial_acceleration_solves_the_saddle_point_system(bearing):
    """vdot and the joint multipliers against numpy's dense solve of
    [M, -G^T; G, 0] [vdot; lam] = [f + f_extra; -gamma], with f and the joint rows from the
    allocating kernels and an arbitrary extra force (the compliant model's contact forces)."""
    model, _, arr = bearing
    q, v = model.initial_state()
    rng = np.random.default_rng(7)
    v = v + rng.normal(0.0, 0.5, v.size)
    n, m = q.size, model.constraint_rows()
    f_extra = rng.normal(0.0, 10.0, n)
    f = np.zeros(n)
    scratch = np.zeros((n, n))
    nb.smooth_forces(q, v, arr, f, scratch, scratch, scratch, False)
    g, G, gam, dgdt = np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)
    nb.bilateral(q, v, 0.25, arr, g, G, gam, dgdt)
    big = np.zeros((n + m, n + m))
    big[:n, :n] = np.diag(arr.mdiag)
    big[:n, n:] = -G.T
    big[n:, :n] = G
    expected = np.linalg.solve(big, np.concatenate([f + f_extra, -gam]))
    vdot, lam = np.zeros(n), np.zeros(m)
    nb.initial_acceleration(q, v, 0.25, arr, f_extra, vdot, lam, nb.smooth_work(n, m))
    scale = np.abs(expected).max()
    np.testing.assert_allclose(vdot, expected[:n], rtol=0, atol=1e-11 * scale)
    np.testing.assert_allclose(lam, expected[n:], rtol=0, atol=1e-11 * scale)


def test_stage_kernels_on_a_pinched_ball():
    """smooth_step, position_step, velocity_step, solve_velocity_problem, integrate_chunk."""
    model = pinched_balls(n_balls=1, load=10.0)
    traj = model.simulate(SolverSettings(1e-4, 2e-3))  # drives integrate_chunk and the three stages
    assert traj.converged.all()
    # the velocity problem alone: one frictionless contact, approaching at 1 m/s, e_N = 0.5
    D = np.array([[2.0]])
    c = np.array([-1.0 + 0.5 * -1.0])
    lam = np.zeros(1)
    its, ok = nb.solve_velocity_problem(D, c, np.array([1]), np.zeros(1), np.zeros(1,
                                        dtype=np.int64), lam, 1e-12, 20, 0.0)
    assert ok and lam[0] == pytest.approx(0.75)  # xi = 2 lam - 1.5 = 0


def test_small_geometry_and_algebra_kernels():
    assert nb.unit_direction(3.0, 4.0) == pytest.approx((5.0, 0.6, 0.8))
    assert nb.unit_direction(0.0, 0.0) == (0.0, 1.0, 0.0)
    P = np.array(nb.pair_point_jacobians(0.0, 0.5, -1.0, 0.0))
    # d(c_j - c_i)/dphi_i = -(e_z x a_i) = (0.5, 0) for a_i = (0, 0.5)
    np.testing.assert_allclose(P[:, 2], [0.5, 0.0])
    np.testing.assert_allclose(P[:, 5], [0.0, -1.0])
    # the row of u.(c_j - c_i) is u^T P, scaled by the sign
    w = np.zeros(6)
    nb.store6(w, nb.point_pair_row(0.6, 0.8, 0.0, 0.5, -1.0, 0.0, -2.0))
    np.testing.assert_allclose(w, -2.0 * (np.array([0.6, 0.8]) @ P), rtol=1e-15)
    # transverse form along n = x: only the y components count
    assert nb.transverse_form(*P[:, 1], *P[:, 1], 1.0, 0.0) == pytest.approx(1.0)
    assert nb.transverse_form(*P[:, 0], *P[:, 0], 1.0, 0.0) == pytest.approx(0.0)
    # against the matrix product P^T (I - n n^T) P for a slanted n
    nx, ny = 0.6, 0.8
    full = P.T @ (np.eye(2) - np.outer([nx, ny], [nx, ny])) @ P
    assert nb.transverse_form(*P[:, 2], *P[:, 5], nx, ny) == pytest.approx(full[2, 5])


def test_contact_hessian_matches_finite_differences(bearing):
    model, _, arr = bearing
    q, _ = model.initial_state()
    q = q + 1e-4 * np.cos(np.arange(q.size))
    eps = 1e-6
    for k in (0, 9):  # an inner (outside) and an outer (inside) element
        H = np.zeros((6, 6))
        nb.contact_hessian(q, k, arr, H)
        ia, ib = arr.ct_body[k]
        dofs = [3 * ia + a for a in range(3)] + [3 * ib + a for a in range(3)]
        for c, dof in enumerate(dofs):
            rows = []
            for sign in (1.0, -1.0):
                dq = q.copy()
                dq[dof] += sign * eps
                wN = np.zeros(6)
                nb.contact_rows(dq, k, arr.ct_type, arr.ct_body, arr.ct_geom, wN,
                                np.zeros(6))
                rows.append(wN.copy())
            np.testing.assert_allclose((rows[0] - rows[1]) / (2 * eps), H[:, c], atol=1e-5)


def _pressed_bearing(mu):
    """The bearing with every ball pushed 2 um into the inner race, small random velocities."""
    cfg = load_config(overrides=["model.youngs_modulus=2.1e11", f"model.mu={mu}"])
    model, layout = crank_slider(cfg["model"])
    arr = model.arrays()
    q, v = model.initial_state()
    pin = np.array([cfg["model"]["crank_length"], 0.0])
    for b in layout.balls:
        c = q[3 * b:3 * b + 2] - pin
        c *= 1.0 - (0.5 * cfg["model"]["clearance"] + 2e-6) / np.hypot(*c)
        q[3 * b:3 * b + 2] = pin + c
    v = v + 1e-3 * np.sin(np.arange(v.size))
    return model, arr, q, v


def _forces(arr, q, v, v_pre, v_reg, tangent=False):
    n, nc = q.size, arr.ct_type.size
    f, K, C = np.zeros(n), np.zeros((n, n)), np.zeros((n, n))
    rec = contact_records(nc)
    nb.contact_forces(q, v, arr, v_pre, v_reg, f, K, C, tangent, rec)
    return f, K, C, rec[FN_ROW], rec[FT_ROW], rec[VT_ROW]


def test_hertz_normal_force_and_its_derivatives():
    K, chi, v_pre = 1e10, 0.2, 0.5
    for delta, rate in ((1e-6, 0.1), (2e-5, -0.3)):
        F, dd, ddot = nb.normal_force(delta, rate, K, chi, v_pre)
        assert F == pytest.approx(K * delta**1.5 * (1 + chi * rate / v_pre))
        eps = 1e-6
        assert dd == pytest.approx((nb.normal_force(delta * (1 + eps), rate, K, chi, v_pre)[0]
                                    - F) / (delta * eps), rel=1e-5)
        assert ddot == pytest.approx((nb.normal_force(delta, rate + eps, K, chi, v_pre)[0]
                                      - F) / eps, rel=1e-5)
    # open, or pulling (damping larger than the elastic part): no force
    assert nb.normal_force(-1e-6, 0.0, K, chi, v_pre) == (0.0, 0.0, 0.0)
    assert nb.normal_force(1e-6, -10.0, K, chi, v_pre) == (0.0, 0.0, 0.0)


def test_compliant_tangents_match_finite_differences():
    """Without friction K = -df/dq and C = -df/dv are exact (normal stiffness, damping and the
    sphere elements' geometric term); with friction on saturated slips C is exact."""
    model, arr, q, v = _pressed_bearing(mu=0.0)
    nc = arr.ct_type.size
    v_pre = np.full(nc, 0.3)
    f, K, C, FN, _, _ = _forces(arr, q, v, v_pre, 1e-4, tangent=True)
    assert np.count_nonzero(FN) == 8  # the eight inner contacts
    for i in range(q.size):
        for which, M, h in (("q", K, 1e-10), ("v", C, 1e-6)):
            xp, xm = q.copy(), q.copy()
            vp, vm = v.copy(), v.copy()
            if which == "q":
                xp[i] += h
                xm[i] -= h
            else:
                vp[i] += h
                vm[i] -= h
            fd = -(_forces(arr, xp, vp, v_pre, 1e-4)[0] - _forces(arr, xm, vm, v_pre, 1e-4)[0])
            np.testing.assert_allclose(fd / (2 * h), M[:, i], rtol=1e-4,
                                       atol=1e-6 * np.abs(M).max())
    model, arr, q, v = _pressed_bearing(mu=0.1)
    f, K, C, FN, FT, vt = _forces(arr, q, v, v_pre, 1e-6, tangent=True)
    closed = FN > 0
    assert np.all(np.abs(vt[closed]) > 1e-6)  # saturated
    np.testing.assert_allclose(np.abs(FT[closed]), 0.1 * FN[closed], rtol=1e-12)
    for i in range(q.size):
        vp, vm = v.copy(), v.copy()
        vp[i] += 1e-9
        vm[i] -= 1e-9
        fd = -(_forces(arr, q, vp, v_pre, 1e-6)[0] - _forces(arr, q, vm, v_pre, 1e-6)[0])
        np.testing.assert_allclose(fd / 2e-9, C[:, i], rtol=1e-4, atol=1e-6 * np.abs(C).max())


def test_contact_elastic_energy_is_the_potential_of_the_undamped_force():
    model, arr, q, v = _pressed_bearing(mu=0.0)
    nc = arr.ct_type.size
    arr = arr._replace(ct_hertz=np.column_stack([arr.ct_hertz[:, 0], np.zeros(nc)]))
    v_pre = np.full(nc, 0.3)
    f = _forces(arr, q, v, v_pre, 1e-4)[0]
    f_gravity = np.zeros(q.size)
    nb.smooth_forces(q, v, arr._replace(sp_body=np.zeros((0, 2), np.int64),
                                        sp_geom=np.zeros((0, 7))), f_gravity,
                     np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), False)
    assert nb.elastic_energy(q, arr) > 0.0
    for i in range(q.size):
        dq = np.zeros(q.size)
        dq[i] = 1e-10
        grad = (nb.elastic_energy(q + dq, arr) - nb.elastic_energy(q - dq, arr)) / 2e-10
        assert grad == pytest.approx(-(f[i]), rel=1e-4, abs=1e-6 * np.abs(f).max())


def test_project_joints_restores_positions_and_velocities(bearing):
    model, _, arr = bearing
    q, v = model.initial_state()
    q_t = q + 1e-6 * np.cos(np.arange(q.size))
    v_t = v + 1e-3 * np.sin(np.arange(q.size))
    q1, v1 = np.zeros(q.size), np.zeros(q.size)
    its, ok = nb.project_joints(q_t, v_t, 0.0, 1e-4, 1e-5, 20, arr, q1, v1)
    assert ok and its >= 1
    m = nb.joint_row_count(arr.jt_type)
    g, G, gam, dgdt = np.zeros(m), np.zeros((m, q.size)), np.zeros(m), np.zeros(m)
    nb.bilateral(q1, v1, 0.0, arr, g, G, gam, dgdt)
    assert np.abs(g).max() <= 1e-9
    np.testing.assert_allclose(G @ v1 + dgdt, 0.0, atol=1e-12)


def test_cached_sines_and_cosines_give_the_uncached_numbers(bearing):
    """body_point_cached reuses a body's cos/sin while its angle is the same number and
    recomputes them when it changes; the cached kernels (joints, contacts, contact
    velocities) return exactly what the plain ones do, on a cold and on a warm cache."""
    model, _, arr = bearing
    q, v = model.initial_state()
    q = q + 1e-3 * np.sin(np.arange(q.size))
    v = v + np.cos(np.arange(v.size))
    n = q.size
    trig = trig_cache(n // 3)
    assert np.isnan(trig).all()
    # the cache is read while the angle matches: a planted value shows it is used
    qb = np.array([1.0, 2.0, 0.3])
    plain = nb.body_point(qb, 0, 0.5, 0.2)
    assert body_point_cached(qb, 0, 0.5, 0.2, trig) == plain
    assert tuple(trig[0]) == (0.3, np.cos(0.3), np.sin(0.3))
    trig[0, 1] = 2.0
    assert body_point_cached(qb, 0, 0.5, 0.0, trig)[2] == 1.0  # 2 cos * 0.5
    qb[2] = 0.4  # a new angle: computed afresh
    assert body_point_cached(qb, 0, 0.5, 0.2, trig) == nb.body_point(qb, 0, 0.5, 0.2)
    # the step's kernels, cold and warm cache
    trig = trig_cache(n // 3)
    m = nb.joint_row_count(arr.jt_type)
    nc = arr.ct_type.size
    for _ in range(2):
        ref = [np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)]
        out = [np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)]
        nb.bilateral(q, v, 0.1, arr, *ref)
        bilateral_cached(q, v, 0.1, arr, *out, trig)
        for a, b in zip(ref, out, strict=True):
            assert np.array_equal(a, b)
        for k in range(nc):
            wN, wT, wN2, wT2 = np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(6)
            g = nb.contact_rows(q, k, arr.ct_type, arr.ct_body, arr.ct_geom, wN, wT)
            g2 = contact_rows_cached(q, k, arr.ct_type, arr.ct_body, arr.ct_geom, wN2, wT2,
                                        trig)
            assert g == g2 and np.array_equal(wN, wN2) and np.array_equal(wT, wT2)
        ref = [np.zeros(nc), np.zeros(nc), np.zeros(nc)]
        out = [np.zeros(nc), np.zeros(nc), np.zeros(nc)]
        nb.contact_velocities(q, v, arr, *ref)
        contact_velocities_into(q, v, arr, *out, np.zeros(6), np.zeros(6), trig)
        for a, b in zip(ref, out, strict=True):
            assert np.array_equal(a, b)


def test_work_array_kernels_give_the_allocating_kernels_numbers(bearing):
    """smooth_forces_into, spring_damping_into and contact_hessian_into (work rows handed in)
    return exactly what smooth_forces, spring_damping and contact_hessian return."""
    model, _, arr = bearing
    q, v = model.initial_state()
    q = q + 1e-3 * np.sin(np.arange(q.size))
    v = v + np.cos(np.arange(v.size))
    n = q.size
    fw, iw = np.zeros((3, 6)), np.zeros((2, 6), dtype=np.int64)
    ref = [np.zeros(n)] + [np.zeros((n, n)) for _ in range(3)]
    out = [np.zeros(n)] + [np.zeros((n, n)) for _ in range(3)]
    nb.smooth_forces(q, v, arr, *ref, True)
    smooth_forces_into(q, v, arr, *out, True, fw, iw)
    for a, b in zip(ref, out, strict=True):
        assert np.array_equal(a, b)
    assert np.abs(ref[1]).max() > 0.0  # the springs have tangents here
    C, C2 = np.zeros((n, n)), np.zeros((n, n))
    nb.spring_damping(q, v, arr, C)
    spring_damping_into(q, v, arr, C2, fw, iw)
    assert np.array_equal(C, C2) and np.abs(C).max() > 0.0
    for k in range(arr.ct_type.size):
        H, H2 = np.zeros((6, 6)), np.zeros((6, 6))
        nb.contact_hessian(q, k, arr, H)
        contact_hessian_into(q, k, arr, H2, np.zeros((2, 6)))
        assert np.array_equal(H, H2) and np.abs(H).max() > 0.0


def _loaded_compliant_step():
    """A state of the compliant model with loaded balls (a compliant zoom of a paper-case run
    after the first pinch) and a function that takes one smooth stage of a step from it with
    given work arrays: step(work, tol, max_iter) -> (iterations, converged, vdot1, lam, q_t,
    v_t, K_t-free outputs...), as a dict."""
    import simcore
    from simcore.io import generalized
    from simcore.kernels.bundles import StepSettings
    from simcore.kernels.compliant_step import compliant_smooth_step
    from simcore.kernels.generalized_alpha import alpha_coefficients
    from simcore.model.mechanism import crank_slider

    run = simcore.run(simcore.load_config(overrides=["solver.t_end=0.002"]))
    model, _ = crank_slider(simcore.load_config()["model"])
    i = int(np.searchsorted(run.time.values, 0.0015))
    g = generalized(run)
    q0 = g["q"].isel(time=i).values.ravel()
    v0 = g["v"].isel(time=i).values.ravel()
    h = 3e-6
    traj = model.simulate(SolverSettings(h, 300 * h, contact_model="compliant", output_every=300),
                                         q0=q0, v0=v0, t0=0.0015)
    st, cs = traj.extras["step_state"], traj.extras["compliant_state"]
    assert (cs.gap < 0.0).sum() >= 2  # loaded contacts
    arr = model.arrays(compliant=True)
    coef = alpha_coefficients(0.0)
    v_reg, t1 = 1e-4, 0.0015 + h

    def step(w, tol, max_iter=50):
        lam = st.lam_s.copy()
        q, v, acc, vdot, v_pre = (st.q.copy(), st.v.copy(), st.acc.copy(), st.vdot.copy(),
                                  cs.v_pre.copy())
        state = st._replace(q=q, v=v, acc=acc, vdot=vdot, lam_s=lam)
        settings = StepSettings(h=h, rho_inf=0.0, tol=tol, max_iter=max_iter, eta=1.0,
                                drive_row=-1, t0=0.0015, v_reg=v_reg, v_pre_min=1e-3)
        q_t, v_t, acc1, vdot1 = w.step.q_t, w.step.v_t, w.step.acc1, w.step.vdot1
        its, ok = compliant_smooth_step(state, acc, t1, h, 1.0, coef, settings, arr, v_pre, w)
        return dict(its=its, ok=ok, q=q, v=v, acc=acc, vdot=vdot, v_pre=v_pre, lam=lam,
                    q_t=q_t.copy(), v_t=v_t.copy(), acc1=acc1.copy(), vdot1=vdot1.copy(),
                    FN=w.contacts[FN_ROW].copy())

    return step, arr, h, coef, v_reg, t1, (st.q.size, st.lam_s.size, cs.gap.size)


def _stage_residuals(r, arr, h, coef, v_reg, t1, n, m, nc):
    """Check the scheme's update formulas and the contact forces a smooth stage reports at its
    result ``r`` (from the plain kernels); return its equilibrium residual over the force scale
    and its joints' velocity residual [m/s]."""
    from simcore.kernels.hertz import contact_forces
    from simcore.kernels.joints import bilateral
    from simcore.kernels.springs import smooth_forces

    am, af, gam, beta = coef
    q, v, acc, vdot, q_t, v_t = r["q"], r["v"], r["acc"], r["vdot"], r["q_t"], r["v_t"]
    a1 = ((1.0 - af) * r["vdot1"] + af * vdot - am * acc) / (1.0 - am)
    np.testing.assert_allclose(r["acc1"], a1, rtol=1e-12, atol=1e-12 * np.abs(a1).max())
    np.testing.assert_allclose(q_t, q + h * v + h * h * ((0.5 - beta) * acc + beta * a1),
                               rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(v_t, v + h * ((1.0 - gam) * acc + gam * a1), rtol=1e-12,
                               atol=1e-12 * np.abs(v_t).max())
    f = np.zeros(n)
    M = np.zeros((n, n))
    smooth_forces(q_t, v_t, arr, f, M, M, M, False)
    rec = contact_records(nc)
    contact_forces(q_t, v_t, arr, r["v_pre"], v_reg, f, M, M, False, rec)
    FN = rec[FN_ROW]
    assert (FN > 0.0).sum() >= 2
    np.testing.assert_allclose(r["FN"], FN, rtol=1e-12, atol=1e-9 * FN.max())
    gj, G, gm, dgdt = np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)
    bilateral(q_t, v_t, t1, arr, gj, G, gm, dgdt)
    residual = arr.mdiag * r["vdot1"] - f - G.T @ r["lam"]
    scale = max(np.abs(f).max(), np.abs(arr.mdiag * r["vdot1"]).max(), FN.max())
    return np.abs(residual).max() / scale, np.abs(G @ v_t + dgdt).max()


def test_compliant_smooth_stage_solves_its_equations():
    """The compliant time loop's smooth stage (no allocation, tangents only where a Newton step
    needs them, block solver in the friction branches), one step from a state with loaded balls
    (a compliant zoom of a paper-case run after the first pinch), checked at its result against
    the equations it solves, evaluated again with the plain kernels: the generalized-alpha
    update of q~, v~ from the accelerations, equilibrium M v' = f(q~, v~) + Hertz forces
    + G^T lambda, the joints' velocity constraint G v~ + dg/dt = 0, and the contact forces it
    reports."""
    from simcore.kernels.compliant_step import compliant_work

    step, arr, h, coef, v_reg, t1, (n, m, nc) = _loaded_compliant_step()
    tol = 1e-10
    r = step(compliant_work(n, m, nc), tol)
    assert r["ok"] and r["its"] >= 1
    res_f, res_c = _stage_residuals(r, arr, h, coef, v_reg, t1, n, m, nc)
    assert res_f <= 10 * tol, res_f
    assert res_c <= 10 * tol


def test_compliant_smooth_stage_reuses_the_last_factors():
    """A step that follows a converged one iterates with that step's Newton factors (no
    tangents, no factorisation) and still solves its equations, to CHORD_TIGHTENING of the
    tolerance: given factors that are 0.2 % off (as an earlier state's are), it leaves them as
    they are and meets the equations, checked by the plain kernels, to that fraction of the
    tolerance; a step that does not converge leaves no factors to reuse."""
    from simcore.kernels.compliant_step import CHORD_TIGHTENING, compliant_work

    step, arr, h, coef, v_reg, t1, (n, m, nc) = _loaded_compliant_step()
    tol = 1e-7
    w = compliant_work(n, m, nc)
    newton = step(w, tol)  # fresh work arrays: Newton, which leaves its factors
    assert newton["ok"] and w.branches.reuse[0] == 1
    k = w.smooth.fac.info[0]
    assert k > 0 and w.smooth.fac.info[1] == 1  # an LU factor of the coupled block
    B = w.smooth.fac.B
    B[:k, :k] += np.triu(B[:k, :k]) * 0.002  # U -> 1.002 U: the factor of 1.002 J_c
    kept = B[:k, :k].copy()
    w.branches.vdot_old[:] = newton["vdot"]  # (no extrapolation: the same start as Newton's)
    chord = step(w, tol)
    assert chord["ok"]
    np.testing.assert_array_equal(B[:k, :k], kept)  # iterated with the factors it was given
    res_f, res_c = _stage_residuals(chord, arr, h, coef, v_reg, t1, n, m, nc)
    assert res_f <= 10 * CHORD_TIGHTENING * tol, res_f
    assert res_c <= 10 * CHORD_TIGHTENING * tol
    failed = step(w, tol, max_iter=0)
    assert not failed["ok"] and w.branches.reuse[0] == 0


def test_smooth_residual_against_numpy():
    from simcore.kernels.generalized_alpha import smooth_residual

    rng = np.random.default_rng(7)
    n, m = 9, 4
    mdiag, vdot1, f, v_t = (rng.normal(size=n) for _ in range(4))
    G, lam, dgdt = rng.normal(size=(m, n)), rng.normal(size=m), rng.normal(size=m)
    rhs = np.zeros(n + m)
    res_f, res_c, scale = smooth_residual(mdiag, vdot1, f, G, lam, dgdt, v_t, rhs, 1e-300)
    force = -(mdiag * vdot1 - f - G.T @ lam)
    constraint = -(G @ v_t + dgdt)
    np.testing.assert_allclose(rhs, np.r_[force, constraint], rtol=1e-13, atol=1e-13)
    assert res_f == pytest.approx(np.abs(force).max(), rel=1e-13)
    assert res_c == pytest.approx(np.abs(constraint).max(), rel=1e-13)
    largest = max(np.abs(f).max(), np.abs(mdiag * vdot1).max(), np.abs(G.T @ lam).max())
    assert scale == pytest.approx(largest, rel=1e-13)
    # a larger scale of the caller's (its largest contact force) stays
    assert smooth_residual(mdiag, vdot1, f, G, lam, dgdt, v_t, rhs, 1e6)[2] == 1e6


def test_alpha_predict_against_the_scheme():
    from simcore.kernels.generalized_alpha import alpha_coefficients, alpha_predict

    rng = np.random.default_rng(3)
    q, v, acc, vdot, vdot1 = (rng.normal(size=7) for _ in range(5))
    h = 1e-3
    coef = alpha_coefficients(0.5)
    am, af, gam, beta = coef
    acc1, q_t, v_t = np.zeros(7), np.zeros(7), np.zeros(7)
    alpha_predict(q, v, acc, vdot, vdot1, h, coef, acc1, q_t, v_t)
    a1 = ((1 - af) * vdot1 + af * vdot - am * acc) / (1 - am)
    np.testing.assert_allclose(acc1, a1, rtol=1e-14)
    np.testing.assert_allclose(q_t, q + h * v + h * h * ((0.5 - beta) * acc + beta * a1),
                               rtol=1e-14)
    np.testing.assert_allclose(v_t, v + h * ((1 - gam) * acc + gam * a1), rtol=1e-14)
