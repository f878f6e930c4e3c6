"""Generalized-alpha time integration shared by both contact models: the coefficients, the
consistent initial acceleration and the smooth stage (Newton on the accelerations with smooth
forces and bilateral joints at velocity level)."""

from __future__ import annotations

import numpy as np
from numba import njit

from .joints import bilateral, joint_row_count
from .linalg import copy_vector, saddle_point_solve, solve_dense
from .springs import smooth_forces


@njit(cache=True)
def alpha_coefficients(rho_inf):
    """(alpha_m, alpha_f, gamma, beta) of generalized-alpha for a spectral radius rho_inf."""
    am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
    af = rho_inf / (rho_inf + 1.0)
    gam = 0.5 + af - am
    beta = 0.25 * (gam + 0.5) ** 2
    return am, af, gam, beta


@njit(cache=True)
def initial_acceleration(q, v, t, ma, vdot, lam):
    """Smooth acceleration at t = 0 from M vdot = f + G^T lam, G vdot + gamma = 0."""
    mdiag = ma.mdiag
    jt_type = ma.jt_type
    n = q.shape[0]
    m = joint_row_count(jt_type)
    f = np.zeros(n)
    K = np.zeros((n, n))
    smooth_forces(q, v, ma, f, K, K, K, False)
    g = np.zeros(m)
    G = np.zeros((m, n))
    gam = np.zeros(m)
    dgdt = np.zeros(m)
    bilateral(q, v, t, ma, g, G, gam, dgdt)
    A = np.zeros((n + m, n + m))
    rhs = np.zeros(n + m)
    for i in range(n):
        A[i, i] = mdiag[i]
        rhs[i] = f[i]
    for r in range(m):
        for i in range(n):
            A[i, n + r] = -G[r, i]
            A[n + r, i] = G[r, i]
        rhs[n + r] = -gam[r]
    x = solve_dense(A, rhs)
    copy_vector(vdot, x, n)
    copy_vector(lam, x[n:], m)


@njit(cache=True)
def smooth_step(q, v, acc, vdot, lam, t1, h, coef, tol, max_iter, ma, q_t, v_t, acc1, vdot1,
                f_t, K_t, C_t, Ks_t):
    """Generalized-alpha prediction with smooth forces and bilateral joints (velocity level).

    Newton on ``vdot1``; fills q_t, v_t, acc1, vdot1, lam and the forces/tangents at (q_t, v_t).
    Returns (iterations, converged).
    """
    am, af, gam, beta = coef
    mdiag = ma.mdiag
    n = q.shape[0]
    m = lam.shape[0]
    ca = (1.0 - af) / (1.0 - am)
    g = np.zeros(m)
    G = np.zeros((m, n))
    gm = np.zeros(m)
    dgdt = np.zeros(m)
    J = np.zeros((n, n))
    rhs = np.zeros(n + m)
    copy_vector(vdot1, vdot, n)
    iters = 0
    converged = False
    for it in range(max_iter + 1):
        for i in range(n):
            acc1[i] = ((1.0 - af) * vdot1[i] + af * vdot[i] - am * acc[i]) / (1.0 - am)
            q_t[i] = q[i] + h * v[i] + h * h * (0.5 - beta) * acc[i] + h * h * beta * acc1[i]
            v_t[i] = v[i] + h * (1.0 - gam) * acc[i] + h * gam * acc1[i]
        smooth_forces(q_t, v_t, ma, f_t, K_t, C_t, Ks_t, True)
        bilateral(q_t, v_t, t1, ma, g, G, gm, dgdt)
        scale = 1e-300
        res_f = 0.0
        for i in range(n):
            react = 0.0
            for r in range(m):
                react += G[r, i] * lam[r]
            rhs[i] = -(mdiag[i] * vdot1[i] - f_t[i] - react)
            res_f = max(res_f, abs(rhs[i]))
            scale = max(scale, abs(f_t[i]), abs(mdiag[i] * vdot1[i]), abs(react))
        res_c = 0.0
        for r in range(m):
            c = dgdt[r]
            for i in range(n):
                c += G[r, i] * v_t[i]
            rhs[n + r] = -c
            res_c = max(res_c, abs(c))
        if res_f <= tol * scale and res_c <= tol:
            converged = True
            break
        if it == max_iter:
            break
        iters += 1
        # Newton step on [J, -G^T; c G, 0] by the Schur complement of the joints: J is
        # diagonal but for the bodies joined by springs, so only that block is factorised
        for i in range(n):
            for j in range(n):
                J[i, j] = (C_t[i, j] * h * gam + K_t[i, j] * h * h * beta) * ca
            J[i, i] += mdiag[i]
        saddle_point_solve(J, G, h * gam * ca, rhs)
        for r in range(m):
            lam[r] += rhs[n + r]
        for i in range(n):
            vdot1[i] += rhs[i]
    return iters, converged
