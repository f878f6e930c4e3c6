"""Generalized-alpha time integration: the coefficients and the consistent initial acceleration
(both contact models), and the nonsmooth model's smooth stage (Newton on the accelerations with
smooth forces and bilateral joints at velocity level; the compliant model's is in
:mod:`.compliant_step`)."""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .bodies import BLOCKS_NEWTON, fill_pair_blocks, trig_cache
from .jit import entry_step_kernel, step_kernel
from .joints import bilateral_cached
from .linalg import (
    block_factor_work,
    copy_vector,
    saddle_point_solve_into,
)
from .springs import FORCES_ONLY, WITH_TANGENTS, smooth_forces_into

#: ``contacts`` flags of :func:`newton_matrix_into`: whether the contacts' body-pair blocks
#: are written too (the compliant model's stage) or the springs' alone (NumPy booleans, as
#: :data:`~.springs.WITH_TANGENTS`).
WITH_CONTACT_BLOCKS = np.bool_(True)
SPRING_BLOCKS_ONLY = np.bool_(False)

#: Smallest force scale of a smooth stage's residual [N] (its tolerance is ``tol`` times the
#: scale): a mechanism at rest without gravity has forces of rounding size only (1e-24 N),
#: which the relative tolerance would judge against themselves, never converging. 1e-6 N is
#: 1e-4 of the weight of the smallest ball of the catalogue's bearings (6.35 mm, 10 mN); a
#: mechanism with any load has a scale far above it, so its steps are unchanged.
FORCE_SCALE_FLOOR = 1e-6

#: Work arrays of :func:`smooth_step` (made by :func:`smooth_work`, once per run):
#: the joint rows g, G, their velocity terms gm, dgdt, the Newton matrix J and right-hand side
#: rhs, the factor of J and the Schur-complement arrays JG, S, piv, the spring forces' work
#: rows fw, iw (:func:`~.springs.smooth_forces_into`), and for the compliant model's stage
#: (:func:`~.compliant_step.compliant_smooth_step`) its previous iterate (vdot_prev, lam_prev)
#: for its backtracking and its Newton step (sol); ``trig``, the bodies' sines and cosines
#: cached by angle (:func:`~.bodies.body_point_cached`) for the joint rows.
SmoothWork = namedtuple("SmoothWork", ["g", "G", "gm", "dgdt", "J", "rhs", "fac", "JG", "S",
                                       "piv", "vdot_prev", "lam_prev", "sol", "fw", "iw", "trig"])


#: Work arrays of a step shared by both time loops (:func:`step_work`): the smooth stage's
#: predicted q~ [m, rad], v~ [m/s, rad/s], the end-of-step accelerations a, v' (``acc1``,
#: ``vdot1``), the force f [N, N m] and its Jacobians K = -df/dq, C = -df/dv, K_s (n x n) at
#: (q~, v~), and the end-of-step q, v.
StepWork = namedtuple("StepWork", ["q_t", "v_t", "acc1", "vdot1", "f_t", "K_t", "C_t", "Ks_t",
                                   "q1", "v1"])


def step_work(n):
    """:data:`StepWork` for n coordinates, made once per run in Python."""
    return StepWork(np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n),
                    np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n)), np.zeros(n),
                    np.zeros(n))


def smooth_work(n, m):
    """Work arrays of :func:`smooth_step` for n coordinates and m joint rows (made once per
    run in Python)."""
    return SmoothWork(g=np.zeros(m), G=np.zeros((m, n)), gm=np.zeros(m), dgdt=np.zeros(m),
                      J=np.zeros((n, n)), rhs=np.zeros(n + m), fac=block_factor_work(n),
                      JG=np.zeros((m, n)), S=np.zeros((m, m)), piv=np.zeros(m, dtype=np.int64),
                      vdot_prev=np.zeros(n), lam_prev=np.zeros(m), sol=np.zeros(n + m),
                      fw=np.zeros((3, 6)), iw=np.zeros((2, 6), dtype=np.int64),
                      trig=trig_cache(n // 3))


@step_kernel
def alpha_coefficients(rho_inf):
    """(alpha_m, alpha_f, gamma, beta) of generalized-alpha for a spectral radius rho_inf."""
    am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
    af = rho_inf / (rho_inf + 1.0)
    gam = 0.5 + af - am
    beta = 0.25 * (gam + 0.5) ** 2
    return am, af, gam, beta


@step_kernel
def joint_coefficient(h, coef):
    """The coefficient c of the joint rows in the smooth stage's Newton system [J, -G^T; c G, 0]
    for a step ``h`` [s]: the velocity's change per change of the iterate vdot1, h gamma (1 -
    alpha_f) / (1 - alpha_m) (``coef``: :func:`alpha_coefficients`) [s]."""
    am, af, gam, _ = coef
    return h * gam * ((1.0 - af) / (1.0 - am))


@entry_step_kernel
def initial_acceleration(q, v, t, ma, f_extra, vdot, lam, sw):
    """Smooth acceleration at time ``t`` [s] from M vdot = f + f_extra + G^T lam,
    G vdot + gamma = 0 (the consistent start of generalized-alpha, both contact models).

    Parameters
    ----------
    q, v : ndarray
        Coordinates [m, rad] and velocities [m/s, rad/s].
    f_extra : ndarray
        Forces added to gravity and the springs [N, N m]: the compliant model's Hertz contact
        forces at the start, zeros for the nonsmooth model.
    vdot, lam : ndarray
        Receive the accelerations [m/s^2, rad/s^2] and the joint multipliers [N, N m].
    sw : SmoothWork
        Work arrays (:func:`smooth_work`); the same kernels and types as the time loop's
        smooth stage, so that a run compiles nothing else for its start.
    """
    mdiag = ma.mdiag
    n = q.shape[0]
    m = sw.g.shape[0]
    J = sw.J
    rhs = sw.rhs
    # no tangents are asked of the forces (J only stands in for K, C, K_s); the Newton
    # matrix is then M itself
    smooth_forces_into(q, v, ma, rhs, J, J, J, FORCES_ONLY, sw.fw, sw.iw)
    bilateral_cached(q, v, t, ma, sw.g, sw.G, sw.gm, sw.dgdt, sw.trig)
    # [M, -G^T; G, 0] [vdot; lam] = [f; -gamma], by the solver of the smooth stage's steps
    for i in range(n):
        for j in range(n):
            J[i, j] = 0.0
        J[i, i] = mdiag[i]
        rhs[i] += f_extra[i]
    for r in range(m):
        rhs[n + r] = -sw.gm[r]
    saddle_point_solve_into(J, sw.G, 1.0, rhs, sw.fac, sw.JG, sw.S, sw.piv)
    copy_vector(vdot, rhs, n)
    for r in range(m):
        lam[r] = rhs[n + r]


@step_kernel
def alpha_predict(q, v, acc, vdot, vdot1, h, coef, acc1, q_t, v_t):
    """The generalized-alpha update of an iterate ``vdot1`` of the end-of-step accelerations:
    a_{n+1} = ((1 - af) v'_{n+1} + af v'_n - am a_n) / (1 - am), q~ = q + h v + h^2 ((1/2 -
    beta) a_n + beta a_{n+1}), v~ = v + h ((1 - gam) a_n + gam a_{n+1}), into ``acc1``, ``q_t``,
    ``v_t``. ``coef``: :func:`alpha_coefficients`."""
    am, af, gam, beta = coef
    for i in range(q.shape[0]):
        acc1[i] = ((1.0 - af) * vdot1[i] + af * vdot[i] - am * acc[i]) / (1.0 - am)
        q_t[i] = q[i] + h * v[i] + h * h * (0.5 - beta) * acc[i] + h * h * beta * acc1[i]
        v_t[i] = v[i] + h * (1.0 - gam) * acc[i] + h * gam * acc1[i]


@step_kernel
def smooth_residual(mdiag, vdot1, f_t, G, lam, dgdt, v_t, rhs, scale):
    """Residual of a smooth stage's iterate, as its Newton right-hand side: ``rhs[:n]`` =
    -(M v' - f - G^T lambda) [N, N m], ``rhs[n:]`` = -(G v~ + dg/dt) [m/s, rad/s]. Returns
    (largest force entry, largest constraint entry, force scale): the scale is the largest of
    ``scale`` (the caller's, e.g. its largest contact force) and of |f|, |M v'|, |G^T lambda|
    over the coordinates."""
    n = vdot1.shape[0]
    m = lam.shape[0]
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
    return res_f, res_c, scale


@step_kernel
def newton_matrix_into(J, K_t, C_t, h, coef, ma, contacts):
    """The smooth stage's Newton matrix J = M + (C h gamma + K h^2 beta) (1 - alpha_f) /
    (1 - alpha_m) from the tangents ``K_t``, ``C_t`` (``coef``: :func:`alpha_coefficients`).
    J is diagonal but for the body pairs of the springs and, with ``contacts``
    (:data:`WITH_CONTACT_BLOCKS`), of the contacts: only those blocks and the diagonal are
    written (K_t and C_t are zero outside them, and so is J from the start)."""
    am, af, gam, beta = coef
    ca = (1.0 - af) / (1.0 - am)
    mdiag = ma.mdiag
    fill_pair_blocks(J, C_t, K_t, h, gam, beta, ca, ma.sp_body, BLOCKS_NEWTON)
    if contacts:
        fill_pair_blocks(J, C_t, K_t, h, gam, beta, ca, ma.ct_body, BLOCKS_NEWTON)
    for i in range(J.shape[0]):
        J[i, i] = (C_t[i, i] * h * gam + K_t[i, i] * h * h * beta) * ca + mdiag[i]


@step_kernel
def apply_update(sol, lam, vdot1):
    """Add a Newton (or chord) update ``sol`` = [d v'; d lambda] to the iterate (``vdot1``,
    ``lam``) in place."""
    n = vdot1.shape[0]
    for r in range(lam.shape[0]):
        lam[r] += sol[n + r]
    for i in range(n):
        vdot1[i] += sol[i]


@step_kernel
def smooth_step(q, v, acc, vdot, lam, t1, h, coef, st, ma, stw, sw):
    """Generalized-alpha prediction with smooth forces and bilateral joints (velocity level):
    the smooth stage of the nonsmooth model's step (the compliant model's, with the Hertz
    forces in it, is :func:`~.compliant_step.compliant_smooth_step`).

    Newton on ``stw.vdot1`` from the state (q, v, acc, vdot) of the step's start, with the
    tolerance ``st.tol`` and at most ``st.max_iter`` iterations (``st``: StepSettings); fills
    the step work ``stw`` (:data:`StepWork`: q_t, v_t, acc1, vdot1 and the forces/tangents at
    (q_t, v_t)) and the joint multipliers ``lam``. ``sw``: :func:`smooth_work`. Returns
    (iterations, converged).
    """
    c_joints = joint_coefficient(h, coef)
    n = q.shape[0]
    tol = st.tol
    max_iter = st.max_iter
    q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, _, _ = stw
    copy_vector(vdot1, vdot, n)
    iters = 0
    converged = False
    for it in range(max_iter + 1):
        alpha_predict(q, v, acc, vdot, vdot1, h, coef, acc1, q_t, v_t)
        smooth_forces_into(q_t, v_t, ma, f_t, K_t, C_t, Ks_t, WITH_TANGENTS, sw.fw, sw.iw)
        bilateral_cached(q_t, v_t, t1, ma, sw.g, sw.G, sw.gm, sw.dgdt, sw.trig)
        res_f, res_c, scale = smooth_residual(ma.mdiag, vdot1, f_t, sw.G, lam, sw.dgdt, v_t,
                                              sw.rhs, FORCE_SCALE_FLOOR)
        if res_f <= tol * scale and res_c <= tol:
            converged = True
            break
        if it == max_iter:
            break
        iters += 1
        # Newton step on [J, -G^T; c G, 0] by the Schur complement of the joints: J is
        # diagonal but for the bodies joined by springs, so only that block is factorised
        newton_matrix_into(sw.J, K_t, C_t, h, coef, ma, SPRING_BLOCKS_ONLY)
        saddle_point_solve_into(sw.J, sw.G, c_joints, sw.rhs, sw.fac, sw.JG, sw.S, sw.piv)
        apply_update(sw.rhs, lam, vdot1)
    return iters, converged
