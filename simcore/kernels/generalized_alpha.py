"""Generalized-alpha time integration shared by both contact models: the coefficients, the
consistent initial acceleration and the smooth stage (Newton on the accelerations with smooth
forces and bilateral joints at velocity level)."""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .bodies import BLOCKS_NEWTON, clear_pair_blocks, fill_pair_blocks
from .hertz import contact_forces
from .jit import kernel, step_kernel
from .joints import bilateral, joint_row_count
from .linalg import (
    block_factor_work,
    copy_vector,
    gauss_solve,
    saddle_point_solve,
    saddle_point_solve_into,
    solve_mass_like,
)
from .springs import smooth_forces, smooth_forces_into

#: Work arrays of :func:`smooth_step` (made by :func:`smooth_work`, once per run):
#: the joint rows g, G, their velocity terms gm, dgdt, the Newton matrix J and right-hand side
#: rhs, the factor of J and the Schur-complement arrays JG, S, piv, and the compliant stage's
#: previous iterate (vdot_prev, lam_prev) for its backtracking and its Newton step (sol), and
#: the spring forces' work rows fw, iw (:func:`~.springs.smooth_forces_into`).
SmoothWork = namedtuple("SmoothWork", ["g", "G", "gm", "dgdt", "J", "rhs", "fac", "JG", "S",
                                       "piv", "vdot_prev", "lam_prev", "sol", "fw", "iw"])


def step_work(n):
    """Work arrays of a step shared by both time loops, made once per run in Python: the smooth
    stage's predicted q~, v~, accelerations a, v', force f and its Jacobians K, C, K_s (n x n),
    and the end-of-step q, v."""
    return (np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n),
            np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n)), np.zeros(n), np.zeros(n))


def smooth_work(n, m):
    """Work arrays of :func:`smooth_step` for n coordinates and m joint rows (made once per
    run in Python)."""
    return SmoothWork(g=np.zeros(m), G=np.zeros((m, n)), gm=np.zeros(m), dgdt=np.zeros(m),
                      J=np.zeros((n, n)), rhs=np.zeros(n + m), fac=block_factor_work(n),
                      JG=np.zeros((m, n)), S=np.zeros((m, m)), piv=np.zeros(m, dtype=np.int64),
                      vdot_prev=np.zeros(n), lam_prev=np.zeros(m), sol=np.zeros(n + m),
                      fw=np.zeros((3, 6)), iw=np.zeros((2, 6), dtype=np.int64))


@step_kernel
def alpha_coefficients(rho_inf):
    """(alpha_m, alpha_f, gamma, beta) of generalized-alpha for a spectral radius rho_inf."""
    am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
    af = rho_inf / (rho_inf + 1.0)
    gam = 0.5 + af - am
    beta = 0.25 * (gam + 0.5) ** 2
    return am, af, gam, beta


@kernel
def initial_acceleration(q, v, t, ma, vdot, lam, v_pre, v_reg):
    """Smooth acceleration at t = 0 from M vdot = f + G^T lam, G vdot + gamma = 0. With onset
    speeds ``v_pre`` (compliant contacts; ``None`` for the nonsmooth model, whose contact
    code is then not compiled) the Hertz contact forces are part of f."""
    mdiag = ma.mdiag
    jt_type = ma.jt_type
    n = q.shape[0]
    m = joint_row_count(jt_type)
    f = np.zeros(n)
    M = np.zeros((n, n))  # no tangents asked of the forces: M stands in for K, C, K_s
    smooth_forces(q, v, ma, f, M, M, M, False)
    if v_pre is not None:
        nc = ma.ct_type.shape[0]
        w = np.zeros((5, nc))
        contact_forces(q, v, ma, v_pre, v_reg, f, M, M, False, w[0], w[1], w[2], w[3], w[4],
                       np.zeros((6, nc)))
    g = np.zeros(m)
    G = np.zeros((m, n))
    gam = np.zeros(m)
    dgdt = np.zeros(m)
    bilateral(q, v, t, ma, g, G, gam, dgdt)
    # [M, -G^T; G, 0] [vdot; lam] = [f; -gamma], by the solver of the smooth stage's steps
    # (so that a run compiles no other dense solver)
    rhs = np.zeros(n + m)
    for i in range(n):
        M[i, i] = mdiag[i]
        rhs[i] = f[i]
    for r in range(m):
        rhs[n + r] = -gam[r]
    saddle_point_solve(M, G, 1.0, rhs)
    copy_vector(vdot, rhs, n)
    copy_vector(lam, rhs[n:], m)


@kernel
def smooth_step(q, v, acc, vdot, lam, t1, h, coef, tol, max_iter, ma, q_t, v_t, acc1, vdot1,
                f_t, K_t, C_t, Ks_t, sw, v_pre, v_reg, cwork):
    """Generalized-alpha prediction with smooth forces and bilateral joints (velocity level).

    Newton on ``vdot1``; fills q_t, v_t, acc1, vdot1, lam and the forces/tangents at (q_t, v_t).
    ``sw``: :func:`smooth_work`. With ``cwork`` an (11, nc) array (compliant model) the Hertz
    contact forces (onset speeds ``v_pre``, friction regularisation ``v_reg``) are smooth
    forces too, with their tangents in the Newton matrix, and ``cwork`` receives FN, FT, gap,
    vn, vt and the 6 tangential Jacobian entries of the contacts at (q_t, v_t). The nonsmooth
    model passes ``cwork = None``: Numba then prunes the compliant branches at compile time.

    Regularised friction is piecewise linear in the slip (slope mu F / v_reg inside the band
    |v_T| < v_reg, flat outside), and one step changes a slip by far more than v_reg at the
    bearing's forces: plain Newton then jumps from one slip direction to the other and back.
    Each Newton step therefore solves its linear model with each contact's friction branch
    (band, slipping +, slipping -) chosen consistently with the slip the step predicts, by an
    active-set loop like the one for stick/slip in the nonsmooth velocity problem.
    Returns (iterations, converged).
    """
    am, af, gam, beta = coef
    mdiag = ma.mdiag
    n = q.shape[0]
    m = lam.shape[0]
    ca = (1.0 - af) / (1.0 - am)
    g = sw.g
    G = sw.G
    gm = sw.gm
    dgdt = sw.dgdt
    J = sw.J
    rhs = sw.rhs
    copy_vector(vdot1, vdot, n)
    iters = 0
    converged = False
    # compliant: backtracking safeguard (see below)
    merit_prev = np.inf
    vdot_prev = sw.vdot_prev
    lam_prev = sw.lam_prev
    if cwork is not None:
        copy_vector(vdot_prev, vdot1, n)
        copy_vector(lam_prev, lam, m)
    halvings = 0
    for it in range(max_iter + 1):
        for i in range(n):
            acc1[i] = ((1.0 - af) * vdot1[i] + af * vdot[i] - am * acc[i]) / (1.0 - am)
            q_t[i] = q[i] + h * v[i] + h * h * (0.5 - beta) * acc[i] + h * h * beta * acc1[i]
            v_t[i] = v[i] + h * (1.0 - gam) * acc[i] + h * gam * acc1[i]
        if cwork is not None:
            # the contacts' tangents are added in their body pairs' blocks: clear those first
            # (smooth_forces clears the springs' own)
            clear_pair_blocks(K_t, ma.ct_body)
            clear_pair_blocks(C_t, ma.ct_body)
        smooth_forces_into(q_t, v_t, ma, f_t, K_t, C_t, Ks_t, True, sw.fw, sw.iw)
        if cwork is not None:
            contact_forces(q_t, v_t, ma, v_pre, v_reg, f_t, K_t, C_t, True, cwork[0], cwork[1],
                           cwork[2], cwork[3], cwork[4], cwork[5:11])
        bilateral(q_t, v_t, t1, ma, g, G, gm, dgdt)
        scale = 1e-300
        if cwork is not None:
            # contact forces and the loads they balance cancel in f_t: the force scale of the
            # residual is that of the largest contact force
            for k in range(cwork.shape[1]):
                scale = max(scale, cwork[0, k])
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
        if cwork is not None:
            # the normal force is clipped at zero where the damping term would pull: across
            # that kink Newton can alternate between two iterates; a step that does not
            # reduce the scaled residual is halved back towards the previous iterate
            merit = max(res_f / (tol * scale), res_c / tol)
            if merit > (1.0 - 1e-4) * merit_prev and halvings < 10:
                halvings += 1
                for i in range(n):
                    vdot1[i] = 0.5 * (vdot1[i] + vdot_prev[i])
                for r in range(m):
                    lam[r] = 0.5 * (lam[r] + lam_prev[r])
                continue
            halvings = 0
            merit_prev = merit
            copy_vector(vdot_prev, vdot1, n)
            copy_vector(lam_prev, lam, m)
        # Newton step on [J, -G^T; c G, 0] by the Schur complement of the joints: J is
        # diagonal but for the bodies joined by springs, so only that block is factorised
        # K_t and C_t are zero outside the springs' (and the compliant contacts') body-pair
        # blocks, and so is J but for its diagonal, from the start
        fill_pair_blocks(J, C_t, K_t, h, gam, beta, ca, ma.sp_body, BLOCKS_NEWTON)
        if cwork is not None:
            fill_pair_blocks(J, C_t, K_t, h, gam, beta, ca, ma.ct_body, BLOCKS_NEWTON)
        for i in range(n):
            J[i, i] = (C_t[i, i] * h * gam + K_t[i, i] * h * h * beta) * ca + mdiag[i]
        if cwork is not None:
            # the step by the same block solver as the nonsmooth model's, on a copy of the
            # residual (the friction branches may solve again with a modified one)
            sol = sw.sol
            copy_vector(sol, rhs, n + m)
            saddle_point_solve_into(J, G, h * gam * ca, sol, sw.fac, sw.JG, sw.S, sw.piv)
            dv, dlam = _friction_branches(J, rhs, G, h * gam * ca, sol[:n], sol[n:], ma, v_reg,
                                          cwork)
            for r in range(m):
                lam[r] += dlam[r]
            for i in range(n):
                vdot1[i] += dv[i]
        else:
            saddle_point_solve_into(J, G, h * gam * ca, rhs, sw.fac, sw.JG, sw.S, sw.piv)
            for r in range(m):
                lam[r] += rhs[n + r]
            for i in range(n):
                vdot1[i] += rhs[i]
    return iters, converged


@kernel
def _newton_direction_compliant(J, rhs, G, cv):
    """As :func:`_newton_direction`, with the hand-written solves of :mod:`.linalg`: one
    elimination of the coupled block for the residual and the joint columns together."""
    n = J.shape[0]
    m = G.shape[0]
    B = np.empty((n, m + 1))
    for i in range(n):
        B[i, 0] = rhs[i]
        for r in range(m):
            B[i, 1 + r] = G[r, i]
    X = solve_mass_like(J, B)
    dv = X[:, 0].copy()
    dlam = np.zeros(m)
    if m > 0:
        S = np.empty((m, m))
        b = np.empty((m, 1))
        for r in range(m):
            gd = 0.0
            for i in range(n):
                gd += G[r, i] * dv[i]
            b[r, 0] = rhs[n + r] - cv * gd
            for c in range(m):
                s = 0.0
                for i in range(n):
                    s += G[r, i] * X[i, 1 + c]
                S[r, c] = cv * s
        dlam = gauss_solve(S, b)[:, 0].copy()
        for i in range(n):
            for c in range(m):
                dv[i] += X[i, 1 + c] * dlam[c]
    return dv, dlam


@kernel
def _branch(x):
    """Friction branch of a scaled slip x = v_T / v_reg: 0 inside the band, else its sign."""
    if abs(x) < 1.0:
        return 0
    return 1 if x > 0.0 else -1


@kernel
def _friction_branches(J, rhs, G, cv, dv, dlam, ma, v_reg, cwork):
    """Re-solve the Newton step with each contact's friction on the branch its predicted slip
    falls on (slope mu F / v_reg in the band, 0 outside, with the model's value shifted to that
    branch's line), until the branches agree with the prediction. Returns (dv, dlam)."""
    nc = ma.ct_type.shape[0]
    FN = cwork[0]
    FT = cwork[1]
    vt = cwork[4]
    current = np.zeros(nc, dtype=np.int64)
    assumed = np.zeros(nc, dtype=np.int64)
    for k in range(nc):
        current[k] = _branch(vt[k] / v_reg)
        assumed[k] = current[k]
    for _pass in range(2 * nc + 2):
        changed = False
        for k in range(nc):
            mu = ma.ct_law[k, 0]
            if FN[k] <= 0.0 or mu <= 0.0:
                continue
            ia = ma.ct_body[k, 0]
            ib = ma.ct_body[k, 1]
            dvt = 0.0
            for a in range(3):
                if ia >= 0:
                    dvt += cwork[5 + a, k] * dv[3 * ia + a]
                if ib >= 0:
                    dvt += cwork[8 + a, k] * dv[3 * ib + a]
            predicted = _branch((vt[k] + cv * dvt) / v_reg)
            if predicted != assumed[k]:
                # the residual is monotone in the slip: a slipping branch whose step lands
                # elsewhere has its root on the band side, so go to the band first
                assumed[k] = 0 if assumed[k] != 0 else predicted
                changed = True
        if not changed:
            break
        J2 = J.copy()
        r2 = rhs.copy()
        for k in range(nc):
            if assumed[k] == current[k]:
                continue
            mu = ma.ct_law[k, 0]
            x = vt[k] / v_reg
            slope_used = 1.0 / v_reg if current[k] == 0 else 0.0
            slope_new = 1.0 / v_reg if assumed[k] == 0 else 0.0
            coeff = cv * mu * FN[k] * (slope_new - slope_used)
            ft_model = -mu * FN[k] * (x if assumed[k] == 0 else float(assumed[k]))
            ia = ma.ct_body[k, 0]
            ib = ma.ct_body[k, 1]
            for a in range(6):
                ba = ia if a < 3 else ib
                if ba < 0:
                    continue
                ra = 3 * ba + a % 3
                r2[ra] += (ft_model - FT[k]) * cwork[5 + a, k]
                for c in range(6):
                    bc = ia if c < 3 else ib
                    if bc < 0:
                        continue
                    J2[ra, 3 * bc + c % 3] += coeff * cwork[5 + a, k] * cwork[5 + c, k]
        dv, dlam = _newton_direction_compliant(J2, r2, G, cv)
    return dv, dlam
