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

from .bodies import BLOCKS_NEWTON, clear_pair_blocks, fill_pair_blocks
from .generalized_alpha import (
    alpha_coefficients,
    alpha_predict,
    smooth_residual,
    smooth_work,
    step_work,
)
from .hertz import contact_forces_into, elastic_energy_into, hertz_work
from .jit import kernel, loop_kernel, step_kernel
from .joints import bilateral, joint_row_count, joint_support
from .linalg import (
    GENERAL,
    block_factor,
    block_solve,
    copy_matrix,
    copy_vector,
    lu_factor,
    lu_solve,
)
from .springs import WITH_TANGENTS, smooth_forces_into, total_energy

#: Work arrays of :func:`integrate_compliant_chunk` (:func:`compliant_work`): the step's
#: (:func:`~.generalized_alpha.step_work`), the smooth stage's (:func:`~.generalized_alpha.
#: smooth_work`), the contacts' (11, nc) rows of FN, FT, gap, vn, vt and tangential Jacobian
#: entries, the Hertz law's (:func:`~.hertz.hertz_work`), the joint projection's
#: (:data:`ProjectionWork`) and the friction branches' (:data:`BranchWork`).
CompliantWork = namedtuple("CompliantWork", ["step", "smooth", "contacts", "hertz",
                                             "projection", "branches"])

#: Work arrays of :func:`project_joints_into`: joint rows g, G (m x n), their velocity terms,
#: the rows' supports (cols (m x 6), ncols), S = G M^-1 G^T and its LU pivots, a right-hand
#: side (m).
ProjectionWork = namedtuple("ProjectionWork", ["g", "G", "gm", "dgdt", "cols", "ncols", "S",
                                               "rhs", "piv"])

#: Work arrays of the Newton solve (:func:`newton_solve`) and the friction branches
#: (:func:`compliant_smooth_step`): the modified Newton matrix and residual, each contact's
#: branch in the tangent and as assumed, a copy of the residual (n), the joint rows' half
#: solves W, Z (m x n) and where each starts (m); what the factors of the last Newton step
#: (``fac``, ``S``, ``piv`` of the smooth work) were made with, for the next steps' updates
#: (:func:`chord_solve`): the joint rows G_f (m x n) and the coefficient c_f (1); ``reuse``
#: (2): whether those factors may serve (0: no) and whether the last step converged (then its
#: start accelerations ``vdot_old`` (n) extrapolate the next step's first iterate).
BranchWork = namedtuple("BranchWork", ["J2", "r2", "current", "assumed", "r0", "W", "Z",
                                       "first_w", "first_z", "G_f", "c_f", "reuse",
                                       "vdot_old"])


def projection_work(n, m):
    """:data:`ProjectionWork` for n coordinates and m joint rows."""
    return ProjectionWork(g=np.zeros(m), G=np.zeros((m, n)), gm=np.zeros(m), dgdt=np.zeros(m),
                          cols=np.zeros((m, 6), dtype=np.int64),
                          ncols=np.zeros(m, dtype=np.int64), S=np.zeros((m, m)),
                          rhs=np.zeros(m), piv=np.zeros(m, dtype=np.int64))


def compliant_work(n, nbil, nc):
    """Every work array of :func:`integrate_compliant_chunk` for n coordinates, nbil joint
    rows and nc contacts, made once per run in Python."""
    return CompliantWork(step=step_work(n), smooth=smooth_work(n, nbil),
                         contacts=np.zeros((11, nc)), hertz=hertz_work(),
                         projection=projection_work(n, nbil),
                         branches=BranchWork(J2=np.zeros((n, n)), r2=np.zeros(n + nbil),
                                             current=np.zeros(nc, dtype=np.int64),
                                             assumed=np.zeros(nc, dtype=np.int64),
                                             r0=np.zeros(n), W=np.zeros((nbil, n)),
                                             Z=np.zeros((nbil, n)),
                                             first_w=np.zeros(nbil, dtype=np.int64),
                                             first_z=np.zeros(nbil, dtype=np.int64),
                                             G_f=np.zeros((nbil, n)), c_f=np.zeros(1),
                                             reuse=np.zeros(2, dtype=np.int64),
                                             vdot_old=np.zeros(n)))


#: An iterate of the reused factors (:func:`compliant_smooth_step`) counts as converged once
#: its residual is within this fraction of the tolerance: then the zooms' F_max_zoom agree with
#: those of Newton alone to 1.2e-6 (docs/compliant.md) ...
CHORD_TIGHTENING = 0.01
#: ... and Newton takes over once such an iterate reduces the scaled residual by less than this
#: factor.
CHORD_CONTRACTION = 0.1

COMPLIANT_STAGE_SMOOTH = 0
COMPLIANT_STAGE_POSITION = 1
COMPLIANT_STAGE_VELOCITY = 2


@kernel
def project_joints(q_t, v_t, t1, h, tol, max_iter, ma, q1, v1):
    """:func:`project_joints_into` with work arrays of its own (for calls outside the time
    loop). Returns (iterations, converged)."""
    n = q_t.shape[0]
    m = joint_row_count(ma.jt_type)
    pw = ProjectionWork(np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m),
                        np.zeros((m, 6), dtype=np.int64), np.zeros(m, dtype=np.int64),
                        np.zeros((m, m)), np.zeros(m), np.zeros(m, dtype=np.int64))
    return project_joints_into(q_t, v_t, t1, h, tol, max_iter, ma, q1, v1, pw)


@step_kernel
def project_joints_into(q_t, v_t, t1, h, tol, max_iter, ma, q1, v1, pw):
    """Remove the joints' drift: q1 = q_t + M^-1 G^T nu with g(q1) = 0 (Newton, |g|/h <= tol;
    no iteration when the drift is already within it), then v1 = v_t + M^-1 G^T mu with
    G(q1) v1 + dg/dt = 0. ``pw``: :data:`ProjectionWork`. Each S = G M^-1 G^T is factorised
    once (LU), the last one serves the velocities too. Returns (iterations, converged)."""
    n = q_t.shape[0]
    m = joint_row_count(ma.jt_type)
    for i in range(n):
        q1[i] = q_t[i]
        v1[i] = v_t[i]
    if m == 0:
        return 0, True
    g = pw.g
    G = pw.G
    gm = pw.gm
    dgdt = pw.dgdt
    cols = pw.cols
    ncols = pw.ncols
    S = pw.S
    rhs = pw.rhs
    piv = pw.piv
    mdiag = ma.mdiag
    # each joint row touches its two bodies' columns only (G is zero elsewhere)
    joint_support(ma.jt_type, ma.jt_body, cols, ncols)
    target = tol * h
    iters = 0
    ok = False
    for it in range(max_iter + 1):
        bilateral(q1, v_t, t1, ma, g, G, gm, dgdt)
        res = 0.0
        for r in range(m):
            res = max(res, abs(g[r]))
        for r in range(m):
            for c in range(m):
                s = 0.0
                for t in range(ncols[r]):
                    i = cols[r, t]
                    s += G[r, i] * G[c, i] / mdiag[i]
                S[r, c] = s
        lu_factor(S, m, piv)
        if res <= target:
            ok = True
            break
        if it == max_iter:
            break
        iters += 1
        for r in range(m):
            rhs[r] = -g[r]
        lu_solve(S, m, piv, rhs)
        for r in range(m):
            for t in range(ncols[r]):
                i = cols[r, t]
                q1[i] += G[r, i] / mdiag[i] * rhs[r]
    # velocities, with the rows at q1 (those of the last evaluation, S factorised above)
    for r in range(m):
        c = dgdt[r]
        for t in range(ncols[r]):
            i = cols[r, t]
            c += G[r, i] * v_t[i]
        rhs[r] = -c
    lu_solve(S, m, piv, rhs)
    for r in range(m):
        for t in range(ncols[r]):
            i = cols[r, t]
            v1[i] += G[r, i] / mdiag[i] * rhs[r]
    return iters, ok


@step_kernel
def _branch(x):
    """Friction branch of a scaled slip x = v_T / v_reg: 0 inside the band, else its sign."""
    if abs(x) < 1.0:
        return 0
    return 1 if x > 0.0 else -1


@step_kernel
def _evaluate(q_t, v_t, t1, ma, v_pre, v_reg, f_t, K_t, C_t, Ks_t, tangent, sw, cwork, hw):
    """Forces (and with ``tangent`` their tangents) and joint rows at (q_t, v_t)."""
    if tangent:
        # the contacts' tangents are added in their body pairs' blocks: clear those first
        # (smooth_forces_into clears the springs' own)
        clear_pair_blocks(K_t, ma.ct_body)
        clear_pair_blocks(C_t, ma.ct_body)
    smooth_forces_into(q_t, v_t, ma, f_t, K_t, C_t, Ks_t, tangent, sw.fw, sw.iw)
    contact_forces_into(q_t, v_t, ma, v_pre, v_reg, f_t, K_t, C_t, tangent, cwork[0],
                        cwork[1], cwork[2], cwork[3], cwork[4], cwork[5:11], hw)
    bilateral(q_t, v_t, t1, ma, sw.g, sw.G, sw.gm, sw.dgdt)


@step_kernel
def compliant_smooth_step(q, v, acc, vdot, lam, t1, h, coef, tol, max_iter, ma, q_t, v_t,
                          acc1, vdot1, f_t, K_t, C_t, Ks_t, sw, v_pre, v_reg, cwork, hw, bw):
    """The generalized-alpha stage of a compliant step: Newton on ``vdot1`` with the springs'
    and the Hertz contacts' forces and their exact tangents, joints at velocity level. The
    scheme of :func:`~.generalized_alpha.smooth_step` (the nonsmooth model's) with the contact
    forces in it, written for the time loop: no array allocated (``sw``, ``hw``, ``bw``: work
    arrays), the tangents evaluated only where a Newton step needs them (an iterate that
    converges, the last of almost every step, gets its forces alone), the Newton step and its
    friction-branch re-solves by the block solver of :mod:`.linalg`.

    Friction is piecewise linear in the slip (slope mu F / v_reg inside the band
    |v_T| < v_reg, flat outside): each Newton step is solved with each contact's branch chosen
    consistently with the slip the step predicts (:func:`_friction_branches`). The normal force
    is clipped at zero where the damping term would pull: a step that does not reduce the
    scaled residual is halved back towards the previous iterate. ``cwork`` (11, nc) receives
    FN, FT, gap, vn, vt and the tangential Jacobian entries at the last (q_t, v_t).

    Reused factors (a chord iteration): a step after a converged one first iterates with the
    factors of the last Newton matrix (``sw.fac``, ``sw.S``, ``sw.piv``, made with the joint
    rows ``bw.G_f``), without tangents or a factorisation (:func:`chord_solve`). At the
    zooms' steps (tens per Hertz contact time) the Newton matrix is the mass matrix to a few
    per mille, and changes by less from one step to the next, so these iterates contract by
    about a hundred each. Their iterate counts as converged only within
    :data:`CHORD_TIGHTENING` of the tolerance (a Newton iterate, quadratic, lands there after
    its step); an update that would change a friction branch, or a contraction weaker than
    :data:`CHORD_CONTRACTION`, hands over to Newton, whose factors then serve the next steps.
    The first iterate is the accelerations extrapolated linearly from the last two steps
    (``bw.vdot_old``). Returns (iterations, converged)."""
    am, af, gam, beta = coef
    mdiag = ma.mdiag
    n = q.shape[0]
    m = lam.shape[0]
    ca = (1.0 - af) / (1.0 - am)
    G = sw.G
    dgdt = sw.dgdt
    J = sw.J
    rhs = sw.rhs
    sol = sw.sol
    # first iterate: the accelerations extrapolated linearly from the last two steps (where
    # the last step converged; else the last step's)
    extrapolate = bw.reuse[1] == 1
    for i in range(n):
        vdot1[i] = 2.0 * vdot[i] - bw.vdot_old[i] if extrapolate else vdot[i]
        bw.vdot_old[i] = vdot[i]
    iters = 0
    converged = False
    merit_prev = np.inf
    vdot_prev = sw.vdot_prev
    lam_prev = sw.lam_prev
    copy_vector(vdot_prev, vdot1, n)
    copy_vector(lam_prev, lam, m)
    halvings = 0
    cv = h * gam * ca
    # the updates may use the last step's Newton factors (see the docstring)
    chord = bw.reuse[0] == 1 and bw.c_f[0] == cv
    for it in range(max_iter + 1):
        alpha_predict(q, v, acc, vdot, vdot1, h, coef, acc1, q_t, v_t)
        # the predictor (it = 0) practically never satisfies the tolerance: its tangents are
        # evaluated with it, unless its update reuses the last factors; a later iterate first
        # gets its forces alone
        tangent = it == 0 and not chord
        _evaluate(q_t, v_t, t1, ma, v_pre, v_reg, f_t, K_t, C_t, Ks_t, tangent, sw, cwork, hw)
        # contact forces and the loads they balance cancel in f_t: the force scale of the
        # residual is that of the largest contact force
        scale = 1e-300
        for k in range(cwork.shape[1]):
            scale = max(scale, cwork[0, k])
        res_f, res_c, scale = smooth_residual(mdiag, vdot1, f_t, G, lam, dgdt, v_t, rhs, scale)
        # an iterate of the reused factors converges only linearly: it must be well inside
        # the tolerance, where a Newton iterate (quadratic) lands after its step
        limit = CHORD_TIGHTENING if chord and it > 0 else 1.0
        if res_f <= limit * tol * scale and res_c <= limit * tol:
            converged = True
            break
        if it == max_iter:
            break
        iters += 1
        merit = max(res_f / (tol * scale), res_c / tol)
        if chord and it > 0 and merit > CHORD_CONTRACTION * merit_prev:
            chord = False  # the old factors no longer fit: Newton from here ...
            if merit > merit_prev:  # ... or, where their update made it worse, from before it
                copy_vector(vdot1, vdot_prev, n)
                copy_vector(lam, lam_prev, m)
                merit_prev = np.inf
                continue
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
        if chord:
            copy_vector(sol, rhs, n + m)
            chord_solve(sw.fac, bw.G_f, cv, sw.S, sw.piv, sol, bw.r0)
            if _branches_hold(sol, cv, ma, v_reg, cwork):
                for r in range(m):
                    lam[r] += sol[n + r]
                for i in range(n):
                    vdot1[i] += sol[i]
                continue
            chord = False
        if not tangent:  # the same forces again, now with their tangents
            _evaluate(q_t, v_t, t1, ma, v_pre, v_reg, f_t, K_t, C_t, Ks_t, WITH_TANGENTS, sw, cwork,
                      hw)
        # Newton step on [J, -G^T; c G, 0]: J is diagonal but for the bodies joined by
        # springs and loaded contacts (their body-pair blocks)
        fill_pair_blocks(J, C_t, K_t, h, gam, beta, ca, ma.sp_body, BLOCKS_NEWTON)
        fill_pair_blocks(J, C_t, K_t, h, gam, beta, ca, ma.ct_body, BLOCKS_NEWTON)
        for i in range(n):
            J[i, i] = (C_t[i, i] * h * gam + K_t[i, i] * h * h * beta) * ca + mdiag[i]
        copy_vector(sol, rhs, n + m)
        newton_solve(J, G, cv, sol, sw.fac, sw.S, sw.piv, bw)
        _friction_branches(J, rhs, G, cv, sol, ma, v_reg, cwork, sw, bw)
        # the factors now in sw.fac, sw.S, sw.piv (those of the last solve, with the friction
        # branches it settled on) and the joint rows they were made with
        copy_matrix(bw.G_f, G, m, n)
        bw.c_f[0] = cv
        bw.reuse[0] = 1
        for r in range(m):
            lam[r] += sol[n + r]
        for i in range(n):
            vdot1[i] += sol[i]
    if not converged:  # a failed step's factors serve no other
        bw.reuse[0] = 0
    bw.reuse[1] = 1 if converged else 0
    return iters, converged


@step_kernel
def newton_solve(J, G, c, rhs, fac, S, piv, bw):
    """Solve [J, -G^T; c G, 0] [x; y] = rhs in place (``rhs[:n]`` becomes x, ``rhs[n:]`` y)
    by the Schur complement S = c G J^-1 G^T of the m joint rows, J factorised on its coupled
    block (:func:`~.linalg.block_factor`, LU: P J_c = L U).

    The same solution as :func:`~.linalg.saddle_point_solve_into` with less work: that one
    solves J for each joint row in full (J^-1 G^T, m solves) to form S and to update x. Here
    S's coupled part is g_a^T J_c^-1 g_b = (U^-T g_a) . (L^-1 P g_b), two forward
    substitutions per row that each start at the row's first non-zero (the joint rows touch
    the crank and the rod, which the loaded contacts couple to every ball and the factor
    orders last), and x = J^-1 (r + G^T y), a second full solve (:func:`chord_solve`, which
    the factors left in ``fac``, ``S`` and ``piv`` also serve later). ``S`` (m x m), ``piv``
    (m), ``bw``: :data:`BranchWork` (r0, W, Z, first_w, first_z)."""
    n = J.shape[0]
    m = G.shape[0]
    block_factor(J, n, fac, GENERAL)
    if m > 0:
        _schur_factor(G, c, fac, S, piv, bw)
    chord_solve(fac, G, c, S, piv, rhs, bw.r0)


@step_kernel
def _schur_factor(G, c, fac, S, piv, bw):
    """S = c G J^-1 G^T from the factor of J (``fac``, LU), factorised in place (LU, ``piv``):
    see :func:`newton_solve`."""
    n = G.shape[1]
    m = G.shape[0]
    k = fac.info[0]
    if fac.info[1] != 1 and k > 0:  # (block_factor gives LU for an unsymmetric J)
        raise np.linalg.LinAlgError("newton_solve needs an LU factor")
    idx = fac.idx
    B = fac.B
    fp = fac.piv
    dinv = fac.dinv
    W = bw.W
    Z = bw.Z
    first_w = bw.first_w
    first_z = bw.first_z
    for a in range(m):
        # W[a] = U^-T g_a (U^T is lower triangular, diagonal U[i, i])
        fw = k
        for p in range(k):
            W[a, p] = G[a, idx[p]]
            if fw == k and W[a, p] != 0.0:
                fw = p
        for i in range(fw, k):
            s = W[a, i]
            for p in range(fw, i):
                s -= B[p, i] * W[a, p]
            W[a, i] = s / B[i, i]
        first_w[a] = fw
        # Z[a] = L^-1 P g_a (L unit lower triangular)
        for p in range(k):
            Z[a, p] = G[a, idx[p]]
        for j in range(k):
            t = fp[j]
            if t != j:
                tmp = Z[a, j]
                Z[a, j] = Z[a, t]
                Z[a, t] = tmp
        fz = k
        for p in range(k):
            if Z[a, p] != 0.0:
                fz = p
                break
        for i in range(fz, k):
            s = Z[a, i]
            for p in range(fz, i):
                s -= B[i, p] * Z[a, p]
            Z[a, i] = s
        first_z[a] = fz
    # coupled part from W, Z; the others from the inverse diagonal, zero on the coupled
    # indices
    for a in range(m):
        for b in range(m):
            s = 0.0
            for p in range(max(first_w[a], first_z[b]), k):
                s += W[a, p] * Z[b, p]
            for i in range(n):
                if G[a, i] != 0.0:
                    s += G[a, i] * dinv[i] * G[b, i]
            S[a, b] = c * s
    lu_factor(S, m, piv)


@step_kernel
def chord_solve(fac, G, c, S, piv, rhs, r0):
    """Solve [J, -G^T; c G, 0] [x; y] = rhs in place with factors already made: ``fac`` of J
    (:func:`~.linalg.block_factor`) and the LU of S = c G J^-1 G^T in ``S``, ``piv``
    (:func:`newton_solve`): x0 = J^-1 r, S y = r_m - c G x0, x = J^-1 (r + G^T y). ``r0``
    (n): work."""
    n = r0.shape[0]
    m = G.shape[0]
    for i in range(n):
        r0[i] = rhs[i]
    x = rhs[:n]
    block_solve(fac, n, x)  # x = J^-1 r
    if m == 0:
        return
    y = rhs[n:]
    for a in range(m):
        gx = 0.0
        for i in range(n):
            gx += G[a, i] * x[i]
        y[a] -= c * gx
    lu_solve(S, m, piv, y)
    for i in range(n):
        s = r0[i]
        for a in range(m):
            s += G[a, i] * y[a]
        x[i] = s
    block_solve(fac, n, x)


@step_kernel
def _predicted_branch(k, sol, cv, ma, v_reg, cwork):
    """Friction branch of contact k at the slip a Newton step ``sol`` predicts: v_T + cv dv_T
    (``cwork``: its slip and tangential Jacobian entries at the iterate)."""
    ia = ma.ct_body[k, 0]
    ib = ma.ct_body[k, 1]
    dvt = 0.0
    for a in range(3):
        if ia >= 0:
            dvt += cwork[5 + a, k] * sol[3 * ia + a]
        if ib >= 0:
            dvt += cwork[8 + a, k] * sol[3 * ib + a]
    return _branch((cwork[4, k] + cv * dvt) / v_reg)


@step_kernel
def _branches_hold(sol, cv, ma, v_reg, cwork):
    """Whether every loaded contact with friction stays on its friction branch over the step
    ``sol`` (then the friction law is linear along it, as a Newton matrix assumes)."""
    for k in range(ma.ct_type.shape[0]):
        if cwork[0, k] <= 0.0 or ma.ct_law[k, 0] <= 0.0:
            continue
        if _predicted_branch(k, sol, cv, ma, v_reg, cwork) != _branch(cwork[4, k] / v_reg):
            return False
    return True


@step_kernel
def _friction_branches(J, rhs, G, cv, sol, ma, v_reg, cwork, sw, bw):
    """Re-solve the Newton step ``sol`` (in place) with each contact's friction on the branch
    its predicted slip falls on (slope mu F / v_reg in the band, 0 outside, with the model's
    value shifted to that branch's line), until the branches agree with the prediction; the
    residual is monotone in the slip, so a slipping branch whose step lands elsewhere goes to
    the band first."""
    n = J.shape[0]
    m = G.shape[0]
    nc = ma.ct_type.shape[0]
    FN = cwork[0]
    FT = cwork[1]
    vt = cwork[4]
    current = bw.current
    assumed = bw.assumed
    J2 = bw.J2
    r2 = bw.r2
    for k in range(nc):
        current[k] = _branch(vt[k] / v_reg)
        assumed[k] = current[k]
    for _pass in range(2 * nc + 2):
        changed = False
        for k in range(nc):
            mu = ma.ct_law[k, 0]
            if FN[k] <= 0.0 or mu <= 0.0:
                continue
            predicted = _predicted_branch(k, sol, cv, ma, v_reg, cwork)
            if predicted != assumed[k]:
                assumed[k] = 0 if assumed[k] != 0 else predicted
                changed = True
        if not changed:
            return
        copy_matrix(J2, J, n, n)
        copy_vector(r2, rhs, n + m)
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
        copy_vector(sol, r2, n + m)
        newton_solve(J2, G, cv, sol, sw.fac, sw.S, sw.piv, bw)


@loop_kernel
def integrate_compliant_chunk(k0, k1, every, st, ma, state, cs, out, work):
    """Advance steps k0 .. k1-1 of the compliant model (state at t0 + k0 h on entry).

    Every ``every`` steps the output row (k + 1) // every is written: q, v, energy (kinetic,
    gravitational, springs and the contacts' elastic energy) at that instant, the drive torque
    averaged over the interval's steps (so that torque x drive rate x interval is the drive's
    work, which the energy audit subtracts; at ``every`` = 1 the step's torque);
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
    hw = work.hertz
    pw = work.projection
    bw = work.branches
    first_bad = -1
    torque_sum = 0.0  # drive torque summed over the interval (k0 starts an interval)
    for k in range(k0, k1):
        t1 = st.t0 + (k + 1) * h
        # onset speeds of the contacts open at the start of the step
        for j in range(nc):
            if cs.closed[j] == 0:
                cs.v_pre[j] = max(-cs.vn[j], st.v_pre_min)
        it_s, ok_s = compliant_smooth_step(q, v, acc, vdot, lam_s, t1, h, coef, tol, max_iter,
                                           ma, q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, sw,
                                           cs.v_pre, st.v_reg, cwork, hw, bw)
        it_p, ok_p = project_joints_into(q_t, v_t, t1, h, tol, max_iter, ma, q1, v1, pw)
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
        if st.drive_row >= 0:
            torque_sum += lam_s[st.drive_row]
        if (k + 1) % every == 0:
            row = (k + 1) // every
            for i in range(n):  # (an array assignment would need reference counting)
                out.q[row, i] = q[i]
                out.v[row, i] = v[i]
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
            out.energy[row] = total_energy(q, v, ma) + elastic_energy_into(q, ma, hw.wN, hw.wT)
            for s in range(3):
                out.iterations[row, s] = cs.it_max[s]
                cs.it_max[s] = 0
            out.converged[row] = cs.ok[0]
            cs.ok[0] = 1
            if st.drive_row >= 0:
                out.drive_torque[row] = torque_sum / every
            torque_sum = 0.0
    return first_bad
