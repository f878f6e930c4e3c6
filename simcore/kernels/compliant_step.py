"""The compliant (Hertz) step: the generalized-alpha smooth stage with the contact forces as
smooth forces (exact tangents in the Newton matrix, :mod:`.hertz`), then a projection that
removes the joints' drift (positions and velocities, mass metric); and its time loop with output
sampling (every ``every`` steps: the peak force, the impulse, the deepest indentation of the
interval).

Onset of a contact in discrete time: a contact open at the end of a step (g_N >= 0) carries as
its onset speed the approach speed of that state, v_pre = max(-vn, v_pre_min); the value is
frozen at the first step that ends closed and kept while the contact stays closed. The error
against the speed at the exact crossing is at most the change of vn over one step.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .generalized_alpha import alpha_coefficients, smooth_step, smooth_work, step_work
from .hertz import elastic_energy
from .jit import kernel
from .joints import bilateral, joint_row_count
from .linalg import gauss_solve
from .springs import total_energy

#: Work arrays of :func:`integrate_compliant_chunk` (:func:`compliant_work`): the step's
#: (:func:`~.generalized_alpha.step_work`), the smooth stage's and the contacts' (11, nc) rows
#: of FN, FT, gap, vn, vt and tangential Jacobian entries.
CompliantWork = namedtuple("CompliantWork", ["step", "smooth", "contacts"])


def compliant_work(n, nbil, nc):
    """Every work array of :func:`integrate_compliant_chunk` for n coordinates, nbil joint
    rows and nc contacts, made once per run in Python."""
    return CompliantWork(step=step_work(n), smooth=smooth_work(n, nbil),
                         contacts=np.zeros((11, nc)))


COMPLIANT_STAGE_SMOOTH = 0
COMPLIANT_STAGE_POSITION = 1
COMPLIANT_STAGE_VELOCITY = 2


@kernel
def project_joints(q_t, v_t, t1, h, tol, max_iter, ma, q1, v1):
    """Remove the joints' drift: q1 = q_t + M^-1 G^T nu with g(q1) = 0 (Newton, |g|/h <= tol;
    no iteration when the drift is already within it), then v1 = v_t + M^-1 G^T mu with
    G(q1) v1 + dg/dt = 0. Returns (iterations, converged)."""
    n = q_t.shape[0]
    m = joint_row_count(ma.jt_type)
    for i in range(n):
        q1[i] = q_t[i]
        v1[i] = v_t[i]
    if m == 0:
        return 0, True
    g = np.zeros(m)
    G = np.zeros((m, n))
    gm = np.zeros(m)
    dgdt = np.zeros(m)
    MG = np.zeros((n, m))
    S = np.zeros((m, m))
    rhs = np.zeros((m, 1))
    target = tol * h
    iters = 0
    ok = False
    for it in range(max_iter + 1):
        bilateral(q1, v_t, t1, ma, g, G, gm, dgdt)
        res = 0.0
        for r in range(m):
            res = max(res, abs(g[r]))
        for i in range(n):
            for r in range(m):
                MG[i, r] = G[r, i] / ma.mdiag[i]
        for r in range(m):
            for c in range(m):
                s = 0.0
                for i in range(n):
                    s += G[r, i] * MG[i, c]
                S[r, c] = s
        if res <= target:
            ok = True
            break
        if it == max_iter:
            break
        iters += 1
        for r in range(m):
            rhs[r, 0] = -g[r]
        dnu = gauss_solve(S, rhs)
        for i in range(n):
            for r in range(m):
                q1[i] += MG[i, r] * dnu[r, 0]
    # velocities, with the rows at q1 (those of the last evaluation)
    for r in range(m):
        c = dgdt[r]
        for i in range(n):
            c += G[r, i] * v_t[i]
        rhs[r, 0] = -c
    mu = gauss_solve(S, rhs)
    for i in range(n):
        for r in range(m):
            v1[i] += MG[i, r] * mu[r, 0]
    return iters, ok


@kernel
def integrate_compliant_chunk(k0, k1, every, st, ma, state, cs, out, work):
    """Advance steps k0 .. k1-1 of the compliant model (state at t0 + k0 h on entry).

    Every ``every`` steps the output row (k + 1) // every is written: q, v, energy (kinetic,
    gravitational, springs and the contacts' elastic energy) and drive torque at that instant;
    per contact the largest normal force of the interval ``F_N`` [N], the friction force at that
    peak ``F_T`` [N], the impulses ``Lambda_N``, ``Lambda_T`` [N s] (trapezoidal rule on the
    step-end forces), the smallest gap ``gap_N`` [m], the normal velocity at the start
    (``vn_pre``) and at the end (``vn_post``) of the interval [m/s]; the largest iteration
    counts and whether every step converged.

    Parameters
    ----------
    st : StepSettings
    ma : ModelArrays
    state : StepState
        q, v, acc, vdot, lam_s used (lam_b, lamN, lamT unused; vn, vt: end of the last step).
    cs : CompliantState
    out : CompliantOutputs

    Returns
    -------
    int
        First step that did not converge, or -1.
    """
    h = st.h
    tol = st.tol
    max_iter = st.max_iter
    q = state.q
    v = state.v
    acc = state.acc
    vdot = state.vdot
    lam_s = state.lam_s
    n = q.shape[0]
    nc = ma.ct_type.shape[0]
    coef = alpha_coefficients(st.rho_inf)
    q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, q1, v1 = work.step
    cwork = work.contacts
    sw = work.smooth
    first_bad = -1
    for k in range(k0, k1):
        t1 = st.t0 + (k + 1) * h
        # onset speeds of the contacts open at the start of the step
        for j in range(nc):
            if cs.closed[j] == 0:
                cs.v_pre[j] = max(-cs.vn[j], st.v_pre_min)
        it_s, ok_s = smooth_step(q, v, acc, vdot, lam_s, t1, h, coef, tol, max_iter, ma,
                                 q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, sw, cs.v_pre,
                                 st.v_reg, cwork)
        it_p, ok_p = project_joints(q_t, v_t, t1, h, tol, max_iter, ma, q1, v1)
        for i in range(n):
            q[i] = q1[i]
            v[i] = v1[i]
            acc[i] = acc1[i]
            vdot[i] = vdot1[i]
        # contact forces of the step: those of the converged smooth stage (the joint
        # projection moves the state by the joints' drift only, far below the indentations)
        for j in range(nc):
            FN_old = cs.FN[j]
            FT_old = cs.FT[j]
            cs.FN[j] = cwork[0, j]
            cs.FT[j] = cwork[1, j]
            cs.gap[j] = cwork[2, j]
            cs.vn[j] = cwork[3, j]
            cs.vt[j] = cwork[4, j]
            cs.closed[j] = 1 if cs.gap[j] < 0.0 else 0
            cs.LN[j] += 0.5 * h * (FN_old + cs.FN[j])
            cs.LT[j] += 0.5 * h * (FT_old + cs.FT[j])
            if cs.FN[j] > cs.FN_max[j]:
                cs.FN_max[j] = cs.FN[j]
                cs.FT_at_max[j] = cs.FT[j]
            if cs.gap[j] < cs.gap_min[j]:
                cs.gap_min[j] = cs.gap[j]
        cs.it_max[COMPLIANT_STAGE_SMOOTH] = max(cs.it_max[COMPLIANT_STAGE_SMOOTH], it_s)
        cs.it_max[COMPLIANT_STAGE_POSITION] = max(cs.it_max[COMPLIANT_STAGE_POSITION], it_p)
        ok = ok_s and ok_p
        if not ok:
            cs.ok[0] = 0
            if first_bad < 0:
                first_bad = k
        if (k + 1) % every == 0:
            row = (k + 1) // every
            out.q[row] = q
            out.v[row] = v
            for j in range(nc):
                out.F_N[row, j] = cs.FN_max[j]
                out.F_T[row, j] = cs.FT_at_max[j]
                out.Lambda_N[row, j] = cs.LN[j]
                out.Lambda_T[row, j] = cs.LT[j]
                out.gap_N[row, j] = cs.gap_min[j]
                out.vn_pre[row, j] = cs.vn_start[j]
                out.vn_post[row, j] = cs.vn[j]
                cs.FN_max[j] = 0.0
                cs.FT_at_max[j] = 0.0
                cs.LN[j] = 0.0
                cs.LT[j] = 0.0
                cs.gap_min[j] = np.inf
                cs.vn_start[j] = cs.vn[j]
            out.energy[row] = total_energy(q, v, ma) + elastic_energy(q, ma)
            for s in range(3):
                out.iterations[row, s] = cs.it_max[s]
                cs.it_max[s] = 0
            out.converged[row] = cs.ok[0]
            cs.ok[0] = 1
            if st.drive_row >= 0:
                out.drive_torque[row] = lam_s[st.drive_row]
    return first_bad
