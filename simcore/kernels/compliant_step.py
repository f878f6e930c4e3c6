"""The compliant (Hertz) step: the generalized-alpha smooth stage with the contact forces as
smooth forces (exact tangents in the Newton matrix, :mod:`.hertz`), then a projection that
removes the joints' drift (positions and velocities, mass metric); and its time loop with output
sampling (every ``every`` steps: the peak force, the impulse, the deepest indentation of the
interval).

Onset of a contact in discrete time: a contact open at the end of a step (g_N >= 0) carries as
its onset speed the approach speed of that state, v_pre = max(-vn, v_pre_min), into the next
step. Once a step ends with it closed, its onset speed becomes its approach speed where its gap
crossed zero (from the cubic through the gaps and normal velocities at the step's ends,
:func:`onset_speeds_at_crossings`) and is kept while it stays closed; the closing step itself,
where the indentation is at most a step's travel, keeps the last open state's. Without that
(``solver.onset_speed: last_open``) the last open state's speed is kept, an error of the change
of vn over one step, first order in the step. (Adaptive steps take the step again with the
crossing's speed: :func:`settle_onset_speeds`.)
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .bodies import clear_pair_blocks, row_dot
from .bundles import STAGE_POSITION, STAGE_SMOOTH
from .contact import CONTACT_PLANE, contact_gap_cached, contact_rows_cached
from .generalized_alpha import (
    FORCE_SCALE_FLOOR,
    WITH_CONTACT_BLOCKS,
    alpha_coefficients,
    alpha_predict,
    apply_update,
    joint_coefficient,
    newton_matrix_into,
    smooth_work,
    step_work,
)
from .hertz import (
    FN_ROW,
    FT_ROW,
    GAP_ROW,
    VN_ROW,
    VT_ROW,
    WT_ROW,
    ContactLaw,
    contact_forces_into,
    contact_records,
    elastic_energy_into,
    hertz_work,
    open_contact_velocities_into,
)
from .jit import inline_kernel, kernel, loop_kernel, step_kernel
from .joints import bilateral_cached, joint_row_count, joint_support
from .linalg import (
    GENERAL,
    add_transposed_product,
    block_factor,
    block_solve,
    cholesky_solve,
    copy_matrix,
    copy_vector,
    lu_factor,
    lu_solve,
)
from .springs import WITH_TANGENTS, smooth_forces_into, total_energy

#: Work arrays of :func:`integrate_compliant_chunk` (:func:`compliant_work`): the step's
#: (:func:`~.generalized_alpha.step_work`), the smooth stage's
#: (:func:`~.generalized_alpha.smooth_work`), the contacts' records
#: (:func:`~.hertz.contact_records`: FN, FT, gap, vn, vt and tangential Jacobian entries), the
#: Hertz law's (:func:`~.hertz.hertz_work`), the joint projection's (:data:`ProjectionWork`)
#: and the friction branches' (:data:`BranchWork`); ``onset`` (nc) an onset speed to use for
#: a contact that closes in the step instead of the approach speed of the last state (NaN:
#: none; see :func:`settle_onset_speeds`); ``retry`` (:data:`RetryWork`) the work of a step
#: taken again (a fixed step's retry, an adaptive step's rejection).
CompliantWork = namedtuple("CompliantWork", ["step", "smooth", "contacts", "hertz",
                                             "projection", "branches", "onset", "retry"])

#: Work of a step taken again (the fixed loop's retries, :func:`_retry_in_substeps`, and the
#: adaptive loop's rejected steps): the start accelerations corrected to another step size
#: (``acc_c``, n), what the step changes before it is kept (:func:`save_step_start`: the
#: joint multipliers ``lam_save`` (m), the start accelerations the first iterate is
#: extrapolated from ``vdot_old_save`` (n) and whether the last step converged
#: ``reuse_save`` (1)) and, for the fixed loop, the size of the last step taken (``h_last``,
#: 1; 0 before the first) [s].
RetryWork = namedtuple("RetryWork", ["acc_c", "lam_save", "vdot_old_save", "reuse_save",
                                     "h_last"])

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
#: (3): whether those factors may serve (0: no), whether the last step converged (then its
#: start accelerations ``vdot_old`` (n) extrapolate the next step's first iterate) and
#: whether the explicit inverse of those factors (:func:`chord_operator`: ``inv_t`` (n x n,
#: the transposed inverse of J's coupled block in its leading k x k), ``jg`` (m x n, J^-1
#: G^T by rows), ``s_inv`` (m x m, S^-1)) is made; the joint rows' supports in ascending
#: order (``jcols`` (m x 6), ``jncols`` (m)) and the joints' reaction G^T lambda (``react``,
#: n) of the residual (:func:`_residual`); ``xc`` (n): work; ``stats`` (2): the Newton steps
#: and the chord iterates taken so far (a record of the cost); the open contacts a step's
#: iterates need not evaluate (:func:`_skip_far_open`): ``q_ref``, ``v_ref`` (n) and ``g_ref``
#: (nc) the state and the gaps they are measured from (the last step's result, or this step's
#: first iterate while ``ready[1]`` is 0), ``skip`` (nc), ``lever`` (2 x nc) the distance of
#: each contact's point from its body's reference point [m], ``moved`` (nc) how far a contact's
#: gap may have moved since ``g_ref`` was evaluated (0 where it is the reference state's own;
#: a contact skipped at a step's result keeps its older gap and adds that step's ``reach``,
#: the bound :func:`_skip_far_open` computed) [m]; ``stale`` (nc): the open contacts
#: whose velocities the last step left out (their onset speed, should they close, comes from
#: the reference state: :func:`_lazy_onset_speeds`); ``ready`` (2): whether ``jcols``,
#: ``jncols`` and ``lever`` are made (:func:`_prepare`) and whether the reference is the last
#: step's result.
BranchWork = namedtuple("BranchWork", ["J2", "r2", "current", "assumed", "r0", "W", "Z",
                                       "first_w", "first_z", "G_f", "c_f", "reuse",
                                       "vdot_old", "jcols", "jncols", "react", "inv_t", "jg",
                                       "s_inv", "xc", "stats", "q_ref", "v_ref", "g_ref",
                                       "skip", "lever", "moved", "reach", "stale", "ready"])


#: Joint rows g [m, rad], G (m x n) and dg/dt [m/s, rad/s] at the state a joint projection
#: starts from (:func:`project_joints_into`).
JointRows = namedtuple("JointRows", ["g", "G", "dgdt"])


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
                         contacts=contact_records(nc), hertz=hertz_work(),
                         projection=projection_work(n, nbil), onset=np.full(nc, np.nan),
                         retry=RetryWork(acc_c=np.zeros(n), lam_save=np.zeros(nbil),
                                         vdot_old_save=np.zeros(n),
                                         reuse_save=np.zeros(1, dtype=np.int64),
                                         h_last=np.zeros(1)),
                         branches=BranchWork(J2=np.zeros((n, n)), r2=np.zeros(n + nbil),
                                             current=np.zeros(nc, dtype=np.int64),
                                             assumed=np.zeros(nc, dtype=np.int64),
                                             r0=np.zeros(n), W=np.zeros((nbil, n)),
                                             Z=np.zeros((nbil, n)),
                                             first_w=np.zeros(nbil, dtype=np.int64),
                                             first_z=np.zeros(nbil, dtype=np.int64),
                                             G_f=np.zeros((nbil, n)), c_f=np.zeros(1),
                                             reuse=np.zeros(3, dtype=np.int64),
                                             vdot_old=np.zeros(n),
                                             jcols=np.zeros((nbil, 6), dtype=np.int64),
                                             jncols=np.zeros(nbil, dtype=np.int64),
                                             react=np.zeros(n), inv_t=np.zeros((n, n)),
                                             jg=np.zeros((nbil, n)),
                                             s_inv=np.zeros((nbil, nbil)), xc=np.zeros(n),
                                             stats=np.zeros(2, dtype=np.int64),
                                             q_ref=np.zeros(n), v_ref=np.zeros(n),
                                             g_ref=np.zeros(nc),
                                             skip=np.zeros(nc, dtype=np.bool_),
                                             lever=np.zeros((2, nc)),
                                             moved=np.zeros(nc), reach=np.zeros(nc),
                                             stale=np.zeros(nc, dtype=np.bool_),
                                             ready=np.zeros(2, dtype=np.int64)))


#: An iterate of the reused factors (:func:`compliant_smooth_step`) counts as converged once
#: its residual is within this fraction of the tolerance: then the zooms' F_max_zoom agree with
#: those of Newton alone to 1.2e-6 (docs/compliant.md) ...
CHORD_TIGHTENING = 0.01
#: ... and Newton takes over once such an iterate reduces the scaled residual by less than this
#: factor.
CHORD_CONTRACTION = 0.1



@kernel
def project_joints(q_t, v_t, t1, h, tol, max_iter, ma, q1, v1):
    """:func:`project_joints_into` with work arrays of its own (for calls outside the time
    loop). Returns (iterations, converged)."""
    n = q_t.shape[0]
    m = joint_row_count(ma.jt_type)
    pw = ProjectionWork(np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m),
                        np.zeros((m, 6), dtype=np.int64), np.zeros(m, dtype=np.int64),
                        np.zeros((m, m)), np.zeros(m), np.zeros(m, dtype=np.int64))
    bilateral_cached(q_t, v_t, t1, ma, pw.g, pw.G, pw.gm, pw.dgdt, None)
    return project_joints_into(q_t, v_t, t1, h, tol, max_iter, ma, q1, v1, pw, None,
                               JointRows(pw.g, pw.G, pw.dgdt))


@step_kernel
def project_joints_into(q_t, v_t, t1, h, tol, max_iter, ma, q1, v1, pw, trig, rows0):
    """Remove the joints' drift: q1 = q_t + M^-1 G^T nu with g(q1) = 0 (Newton, |g|/h <= tol;
    no iteration when the drift is already within it), then v1 = v_t + M^-1 G^T mu with
    G(q1) v1 + dg/dt = 0. ``pw``: :data:`ProjectionWork`; ``trig``: the bodies' sines and
    cosines (:func:`~.bodies.body_point_cached`, or None); ``rows0``: :data:`JointRows`, the
    joint rows at (q_t, v_t, t1) (the smooth stage's last evaluation). Each S = G M^-1 G^T is
    factorised once (LU), the last one serves the velocities too. Returns (iterations,
    converged)."""
    n = q_t.shape[0]
    m = joint_row_count(ma.jt_type)
    for i in range(n):
        q1[i] = q_t[i]
        v1[i] = v_t[i]
    if m == 0:
        return 0, True
    g = rows0.g
    G = rows0.G
    dgdt = rows0.dgdt
    cols = pw.cols
    ncols = pw.ncols
    S = pw.S
    rhs = pw.rhs
    piv = pw.piv
    mdiag = ma.mdiag
    # each joint row touches its two bodies' columns only (G is zero elsewhere); those
    # columns are made once per work array (every row has at least one)
    if ncols[0] == 0:
        _joint_columns(ma, cols, ncols)
    target = tol * h
    iters = 0
    ok = False
    for it in range(max_iter + 1):
        if it > 0:
            g = pw.g
            G = pw.G
            dgdt = pw.dgdt
            bilateral_cached(q1, v_t, t1, ma, g, G, pw.gm, dgdt, trig)
        res = 0.0
        for r in range(m):
            res = max(res, abs(g[r]))
        # S is symmetric: the same sums (the supports in ascending order, a zero term adds
        # nothing) give S[c, r] and S[r, c]
        for r in range(m):
            for c in range(r, m):
                s = 0.0
                for t in range(ncols[r]):
                    i = cols[r, t]
                    if G[c, i] != 0.0:  # (a zero term adds nothing: the same sum, no division)
                        s += G[r, i] * G[c, i] / mdiag[i]
                S[r, c] = s
                S[c, r] = s
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
def _joint_columns(ma, cols, ncols):
    """The support of every joint row (:func:`~.joints.joint_support`), each in ascending
    order: the order in which a loop over all columns visits them, so that a sum over a
    support is the same number as that loop's."""
    joint_support(ma.jt_type, ma.jt_body, cols, ncols)
    for r in range(ncols.shape[0]):
        for a in range(1, ncols[r]):
            c = cols[r, a]
            b = a
            while b > 0 and cols[r, b - 1] > c:
                cols[r, b] = cols[r, b - 1]
                b -= 1
            cols[r, b] = c


@step_kernel
def _prepare(ma, bw):
    """Once per run (``bw.ready``): the joint rows' supports (:func:`_joint_columns`) and each
    contact's levers, the distances of its two points from their bodies' reference points."""
    if bw.ready[0] == 1:
        return
    _joint_columns(ma, bw.jcols, bw.jncols)
    for k in range(ma.ct_type.shape[0]):
        for s in range(2):
            px = ma.ct_geom[k, 2 * s]
            py = ma.ct_geom[k, 2 * s + 1]
            bw.lever[s, k] = np.sqrt(px * px + py * py)
    bw.ready[0] = 1


@step_kernel
def _skip_far_open(q_t, ma, bw):
    """Mark the contacts that are open at the iterate ``q_t`` because they were open at the
    reference state (``bw.q_ref``, gaps ``bw.g_ref``: the last step's result, less
    ``bw.moved`` where a gap is older) by more than the bodies have moved since: a sphere
    element's gap changes by at most the motion of its two points, each at most |dx| + |dy| +
    lever |dphi| of its body (a plane turning with its body is always evaluated). Such a
    contact has no force at this iterate, whatever its exact gap. The bound on how far its gap
    may have moved since ``g_ref`` goes to ``bw.reach`` (:func:`commit_step` keeps it where the
    step's result skips the contact)."""
    for k in range(ma.ct_type.shape[0]):
        g0 = bw.g_ref[k]
        skip = g0 > 0.0 and not (ma.ct_type[k] == CONTACT_PLANE and ma.ct_body[k, 0] >= 0)
        if skip:
            # (1e-12: round-off of the gaps, far below any indentation)
            reach = 1e-12 + bw.moved[k]
            for s in range(2):
                b = ma.ct_body[k, s]
                if b >= 0:
                    reach += (abs(q_t[3 * b] - bw.q_ref[3 * b])
                              + abs(q_t[3 * b + 1] - bw.q_ref[3 * b + 1])
                              + bw.lever[s, k] * abs(q_t[3 * b + 2] - bw.q_ref[3 * b + 2]))
            skip = g0 > reach
            bw.reach[k] = reach
        bw.skip[k] = skip


@step_kernel
def _lazy_onset_speeds(q_t, ma, v_pre, v_pre_min, bw, hw, trig):
    """The onset speed of each contact that the iterate ``q_t`` closes although it was open,
    with its velocities left out, at the last step's result (``bw.stale``): the approach speed
    there, max(-vn, v_pre_min), from the reference state (``bw.q_ref``, ``bw.v_ref``), the same
    number the step would have computed at its start (:func:`compliant_step_into`)."""
    for k in range(ma.ct_type.shape[0]):
        if not bw.stale[k] or bw.skip[k]:
            continue
        if contact_gap_cached(q_t, k, ma.ct_type, ma.ct_body, ma.ct_geom, trig) < 0.0:
            ia = ma.ct_body[k, 0]
            ib = ma.ct_body[k, 1]
            contact_rows_cached(bw.q_ref, k, ma.ct_type, ma.ct_body, ma.ct_geom, hw.wN, hw.wT,
                                trig)
            v_pre[k] = max(-row_dot(hw.wN, ia, ib, bw.v_ref), v_pre_min)
            bw.stale[k] = False


@step_kernel
def finish_contacts(q_t, v_t, ma, cwork, bw, hw, trig, velocities):
    """The contacts at a step's result (q_t, v_t) beyond what its last iterate evaluated: with
    ``velocities``, the gaps and the normal and tangential velocities of every open contact
    (:func:`~.hertz.open_contact_velocities_into`, the skipped ones included: their records
    hold the positive gap of an earlier evaluation). Without, nothing: a contact the last
    iterate skipped keeps its older gap with the bound on how far it has moved since
    (``bw.moved``, :func:`commit_step`), and the open contacts become ``bw.stale``. The gap of
    a far open contact is thus evaluated where a step's iterates need it, or at an output
    row; a step's forces are the same either way (a skipped contact is open, and has none)."""
    if velocities:
        open_contact_velocities_into(q_t, v_t, ma, cwork, hw, trig)


@inline_kernel
def _residual(mdiag, vdot1, f_t, G, lam, dgdt, v_t, rhs, scale, cols, ncols, react):
    """:func:`~.generalized_alpha.smooth_residual` over the joint rows' supports (``cols``,
    ``ncols`` from :func:`_joint_columns`; G is zero elsewhere): the same numbers, the same
    sums in the same order without their zero terms. ``react`` (n): work."""
    n = vdot1.shape[0]
    m = lam.shape[0]
    for i in range(n):
        react[i] = 0.0
    for r in range(m):
        for t in range(ncols[r]):
            i = cols[r, t]
            react[i] += G[r, i] * lam[r]
    res_f = 0.0
    for i in range(n):
        rhs[i] = -(mdiag[i] * vdot1[i] - f_t[i] - react[i])
        res_f = max(res_f, abs(rhs[i]))
        scale = max(scale, abs(f_t[i]), abs(mdiag[i] * vdot1[i]), abs(react[i]))
    res_c = 0.0
    for r in range(m):
        c = dgdt[r]
        for t in range(ncols[r]):
            i = cols[r, t]
            c += G[r, i] * v_t[i]
        rhs[n + r] = -c
        res_c = max(res_c, abs(c))
    return res_f, res_c, scale


@step_kernel
def _branch(x):
    """Friction branch of a scaled slip x = v_T / v_reg: 0 inside the band, else its sign."""
    if abs(x) < 1.0:
        return 0
    return 1 if x > 0.0 else -1


@inline_kernel
def _evaluate(t1, ma, law, tangent, work):
    """Forces (and with ``tangent`` their tangents) and joint rows at the iterate (q_t, v_t) of
    ``work.step``; of the open contacts only their gaps, none of those marked in
    ``work.branches.skip`` (:func:`~.hertz.contact_forces_into`; ``law``:
    :data:`~.hertz.ContactLaw`)."""
    q_t, v_t, _, _, f_t, K_t, C_t, Ks_t, _, _ = work.step
    sw = work.smooth
    if tangent:
        # the contacts' tangents are added in their body pairs' blocks: clear those first
        # (smooth_forces_into clears the springs' own)
        clear_pair_blocks(K_t, ma.ct_body)
        clear_pair_blocks(C_t, ma.ct_body)
    smooth_forces_into(q_t, v_t, ma, f_t, K_t, C_t, Ks_t, tangent, sw.fw, sw.iw)
    contact_forces_into(q_t, v_t, ma, law, f_t, K_t, C_t, tangent, work.contacts, work.hertz,
                        sw.trig, work.branches.skip)
    bilateral_cached(q_t, v_t, t1, ma, sw.g, sw.G, sw.gm, sw.dgdt, sw.trig)


@inline_kernel
def _evaluate_iterate(it, t1, ma, law, tangent, v_pre_min, work):
    """:func:`_evaluate` at iterate ``it`` of a step, with the open contacts that cannot have
    closed since the last step's result (or, for a first step, since this one's first
    iterate, which then becomes the reference) left out (:func:`_skip_far_open`) and the
    onset speeds of those that closed with their velocities left out
    (:func:`_lazy_onset_speeds`)."""
    q_t = work.step.q_t
    bw = work.branches
    first = it == 0 and bw.ready[1] == 0
    if first:
        for k in range(bw.skip.shape[0]):
            bw.skip[k] = False
            bw.moved[k] = 0.0
    else:
        _skip_far_open(q_t, ma, bw)
    _lazy_onset_speeds(q_t, ma, law.v_pre, v_pre_min, bw, work.hertz, work.smooth.trig)
    _evaluate(t1, ma, law, tangent, work)
    if first:
        copy_vector(bw.q_ref, q_t, q_t.shape[0])
        copy_vector(bw.g_ref, work.contacts[GAP_ROW], bw.g_ref.shape[0])


@inline_kernel
def _stage_residual(ma, lam, work):
    """:func:`_residual` of the iterate (``work.step``: vdot1, f_t, v_t; ``lam``) into
    ``work.smooth.rhs``: (largest force entry, largest constraint entry, force scale).
    Contact forces and the loads they balance cancel in f_t: the force scale of the residual
    is at least that of the largest contact force."""
    sw = work.smooth
    bw = work.branches
    scale = FORCE_SCALE_FLOOR
    for k in range(work.contacts.shape[1]):
        scale = max(scale, work.contacts[FN_ROW, k])
    return _residual(ma.mdiag, work.step.vdot1, work.step.f_t, sw.G, lam, sw.dgdt,
                     work.step.v_t, sw.rhs, scale, bw.jcols, bw.jncols, bw.react)


@step_kernel
def _first_iterate(vdot, vdot1, ratio, bw):
    """The first iterate of a step's accelerations ``vdot1``: those of the last step ``vdot``
    extrapolated linearly from the step before (``bw.vdot_old``, where the last step
    converged; else ``vdot`` itself) over ``ratio`` = h over the last step's size (1 for a
    fixed step); ``vdot`` becomes ``bw.vdot_old``."""
    extrapolate = bw.reuse[1] == 1
    for i in range(vdot.shape[0]):
        if not extrapolate:
            vdot1[i] = vdot[i]
        elif ratio == 1.0:
            vdot1[i] = 2.0 * vdot[i] - bw.vdot_old[i]
        else:  # a step of another size than the last one (adaptive steps)
            vdot1[i] = vdot[i] + ratio * (vdot[i] - bw.vdot_old[i])
        bw.vdot_old[i] = vdot[i]


@inline_kernel
def _save_iterate(vdot1, lam, sw):
    """Keep the iterate (``vdot1``, ``lam``) as the previous one (``sw.vdot_prev``,
    ``sw.lam_prev``), that a later iterate may go back to."""
    copy_vector(sw.vdot_prev, vdot1, vdot1.shape[0])
    copy_vector(sw.lam_prev, lam, lam.shape[0])


@inline_kernel
def _halve_back(vdot1, lam, sw):
    """Halve the iterate (``vdot1``, ``lam``) back towards the previous one (``sw.vdot_prev``,
    ``sw.lam_prev``)."""
    for i in range(vdot1.shape[0]):
        vdot1[i] = 0.5 * (vdot1[i] + sw.vdot_prev[i])
    for r in range(lam.shape[0]):
        lam[r] = 0.5 * (lam[r] + sw.lam_prev[r])


@inline_kernel
def _chord_iterate(cv, ma, v_reg, work, lam, vdot1):
    """An update of the iterate (``vdot1``, ``lam``) with reused factors (a chord iteration):
    the factors of the last Newton matrix (``sw.fac``, ``sw.S``, ``sw.piv``, made with the
    joint rows ``bw.G_f`` and the coefficient ``bw.c_f``), without tangents or a
    factorisation, as products with their explicit inverse (:func:`chord_operator`, made when
    first needed; :func:`chord_apply`), the joints' rows of the residual scaled by the ratio of
    that coefficient to this step's ``cv`` (factors made at another step size serve too).
    Returns False, the iterate left as it is, where the update would change a friction branch
    (:func:`_branches_hold`).

    At the zooms' steps (tens per Hertz contact time) the Newton matrix is the mass matrix to
    a few per mille and changes by less from one step to the next, so these iterates contract
    by about a hundred each; converging only linearly, their iterate must be well inside the
    tolerance (:data:`CHORD_TIGHTENING`), where a Newton iterate, quadratic, lands after its
    step."""
    sw = work.smooth
    bw = work.branches
    sol = sw.sol
    copy_vector(sol, sw.rhs, sol.shape[0])
    if bw.reuse[2] == 0:
        chord_operator(sw.fac, bw.G_f, bw.c_f[0], sw.S, sw.piv, bw)
        bw.reuse[2] = 1
    chord_apply(sw.fac, bw.G_f, bw.c_f[0], bw.c_f[0] / cv, bw, sol)
    bw.stats[1] += 1
    if not _branches_hold(sol, cv, ma, v_reg, work.contacts):
        return False
    apply_update(sol, lam, vdot1)
    return True


@step_kernel
def _newton_iterate(h, coef, cv, ma, v_reg, work, lam, vdot1):
    """A Newton update of the iterate (``vdot1``, ``lam``) on [J, -G^T; cv G, 0] with the
    tangents at the iterate (``work.step``): J is diagonal but for the bodies joined by
    springs and loaded contacts (their body-pair blocks). Friction is piecewise linear in the
    slip (slope mu F / v_reg inside the band |v_T| < v_reg, flat outside): the step is solved
    with each contact's branch chosen consistently with the slip it predicts
    (:func:`_friction_branches`). Its factors stay in ``sw.fac``, ``sw.S``, ``sw.piv`` (those
    of the last solve, with the friction branches it settled on) for the next chord
    iterates, with the joint rows and the coefficient they were made with."""
    sw = work.smooth
    bw = work.branches
    J = sw.J
    G = sw.G
    sol = sw.sol
    n = vdot1.shape[0]
    m = lam.shape[0]
    newton_matrix_into(J, work.step.K_t, work.step.C_t, h, coef, ma, WITH_CONTACT_BLOCKS)
    copy_vector(sol, sw.rhs, n + m)
    newton_solve(J, G, cv, sol, sw.fac, sw.S, sw.piv, bw)
    bw.stats[0] += 1
    _friction_branches(J, sw.rhs, G, cv, sol, ma, v_reg, work.contacts, sw, bw)
    copy_matrix(bw.G_f, G, m, n)
    bw.c_f[0] = cv
    bw.reuse[0] = 1
    bw.reuse[2] = 0  # (their explicit inverse is made when a chord iterate needs it)
    apply_update(sol, lam, vdot1)


@step_kernel
def compliant_smooth_step(state, acc, t1, h, ratio, coef, st, ma, v_pre, work):
    """The generalized-alpha stage of a compliant step of size ``h`` [s] ending at ``t1`` [s]
    from ``state`` (StepState: q, v, vdot, and lam_s, updated in place) with the start
    accelerations ``acc``: Newton on ``work.step.vdot1`` with the springs' and the Hertz
    contacts' forces and their exact tangents (onset speeds ``v_pre`` [m/s], updated where a
    contact closes), joints at velocity level; ``st``: StepSettings (tol, max_iter, v_reg,
    v_pre_min). The scheme of :func:`~.generalized_alpha.smooth_step` with the contact forces
    in it, written for the time loop: no array allocated (``work``: :data:`CompliantWork`),
    the tangents evaluated only where a Newton step needs them (an iterate that converges, the
    last of almost every step, gets its forces alone). The normal force is clipped at zero
    where the damping term would pull: a step that does not reduce the scaled residual is
    halved back towards the previous iterate. ``work.contacts`` receives the contacts' records
    (:func:`~.hertz.contact_records`) at the last (q_t, v_t).

    A step after a converged one first iterates with the last Newton factors
    (:func:`_chord_iterate`), its iterate converged only within :data:`CHORD_TIGHTENING` of
    the tolerance; a friction branch that would change, or a contraction weaker than
    :data:`CHORD_CONTRACTION`, hands over to Newton (:func:`_newton_iterate`). The first
    iterate is extrapolated from the last two steps (:func:`_first_iterate`). Returns
    (iterations, converged)."""
    lam = state.lam_s
    vdot1 = work.step.vdot1
    sw = work.smooth
    bw = work.branches
    law = ContactLaw(v_pre, st.v_reg)
    tol = st.tol
    _first_iterate(state.vdot, vdot1, ratio, bw)
    iters = 0
    converged = False
    merit_prev = np.inf
    _save_iterate(vdot1, lam, sw)
    halvings = 0
    cv = joint_coefficient(h, coef)
    _prepare(ma, bw)
    chord = bw.reuse[0] == 1  # the updates may use the last step's Newton factors
    for it in range(st.max_iter + 1):
        alpha_predict(state.q, state.v, acc, state.vdot, vdot1, h, coef, work.step.acc1,
                      work.step.q_t, work.step.v_t)
        # the predictor (it = 0) practically never satisfies the tolerance: its tangents are
        # evaluated with it, unless its update reuses the last factors; a later iterate first
        # gets its forces alone
        tangent = it == 0 and not chord
        _evaluate_iterate(it, t1, ma, law, tangent, st.v_pre_min, work)
        res_f, res_c, scale = _stage_residual(ma, lam, work)
        limit = CHORD_TIGHTENING if chord and it > 0 else 1.0
        if res_f <= limit * tol * scale and res_c <= limit * tol:
            converged = True
            break
        if it == st.max_iter:
            break
        iters += 1
        merit = max(res_f / (tol * scale), res_c / tol)
        if chord and it > 0 and merit > CHORD_CONTRACTION * merit_prev:
            chord = False  # the old factors no longer fit: Newton from here ...
            if merit > merit_prev:  # ... or, where their update made it worse, from before it
                copy_vector(vdot1, sw.vdot_prev, vdot1.shape[0])
                copy_vector(lam, sw.lam_prev, lam.shape[0])
                merit_prev = np.inf
                continue
        if merit > (1.0 - 1e-4) * merit_prev and halvings < 10:
            halvings += 1
            _halve_back(vdot1, lam, sw)
            continue
        halvings = 0
        merit_prev = merit
        _save_iterate(vdot1, lam, sw)
        if chord:
            if _chord_iterate(cv, ma, st.v_reg, work, lam, vdot1):
                continue
            chord = False
        if not tangent:  # the same forces again, now with their tangents
            _evaluate(t1, ma, law, WITH_TANGENTS, work)
        _newton_iterate(h, coef, cv, ma, st.v_reg, work, lam, vdot1)
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
    add_transposed_product(x, r0, G, y)  # x = r + G^T y
    block_solve(fac, n, x)


@step_kernel
def chord_operator(fac, G, c, S, piv, bw):
    """The explicit inverse of the factors a Newton step left (:func:`newton_solve`: the LU
    of J's coupled block in ``fac``, that of S = c G J^-1 G^T in ``S``, ``piv``) for
    :func:`chord_apply`: the transposed inverse of the coupled block (``bw.inv_t``, k
    solves), J^-1 G^T (``bw.jg``, by rows) and S^-1 (``bw.s_inv``).

    A chord iterate applies the same matrix many times (a Newton step's factors serve the
    next hundred steps or so): as products with these inverses it costs a quarter of the two
    triangular solves per block of :func:`chord_solve`, whose long chains of dependent
    additions cannot overlap, and it vectorises. The result is the same to round-off."""
    n = bw.r0.shape[0]
    m = G.shape[0]
    k = fac.info[0]
    tmp = fac.tmp
    inv_t = bw.inv_t
    for j in range(k):
        for a in range(k):
            tmp[a] = 0.0
        tmp[j] = 1.0
        if fac.info[1] == 0:
            cholesky_solve(fac.B, k, tmp)
        else:
            lu_solve(fac.B, k, fac.piv, tmp)
        for a in range(k):
            inv_t[j, a] = tmp[a]
    jg = bw.jg
    for a in range(m):
        for i in range(n):
            jg[a, i] = G[a, i]
        block_solve(fac, n, jg[a])
    e = bw.xc
    for b in range(m):
        for a in range(m):
            e[a] = 0.0
        e[b] = 1.0
        lu_solve(S, m, piv, e)
        for a in range(m):
            bw.s_inv[a, b] = e[a]


@inline_kernel
def chord_apply(fac, G, c, c_ratio, bw, rhs):
    """Solve [J, -G^T; c G, 0] [x; y] = rhs in place with the inverses of
    :func:`chord_operator` (made from the factors of this J, G and c): x0 = J^-1 r,
    y = S^-1 (r_m - c G x0), x = x0 + J^-1 G^T y, with r_m scaled by ``c_ratio`` (c over the
    current step's coefficient: a step of another size keeps its joints' velocity rows
    exact). The products run over the joint rows' supports (``bw.jcols``)."""
    n = bw.r0.shape[0]
    m = G.shape[0]
    k = fac.info[0]
    idx = fac.idx
    dinv = fac.dinv
    inv_t = bw.inv_t
    xc = bw.xc
    for a in range(k):
        xc[a] = 0.0
    for j in range(k):  # (columns of the inverse: contiguous, no reduction, vectorised)
        rj = rhs[idx[j]]
        if rj != 0.0:
            for a in range(k):
                xc[a] += inv_t[j, a] * rj
    for i in range(n):
        rhs[i] *= dinv[i]
    for a in range(k):
        rhs[idx[a]] = xc[a]
    if m == 0:
        return
    t = bw.r0
    for a in range(m):
        gx = 0.0
        for p in range(bw.jncols[a]):
            i = bw.jcols[a, p]
            gx += G[a, i] * rhs[i]
        t[a] = rhs[n + a] * c_ratio - c * gx
    for a in range(m):
        s = 0.0
        for b in range(m):
            s += bw.s_inv[a, b] * t[b]
        rhs[n + a] = s
    for a in range(m):
        ya = rhs[n + a]
        for i in range(n):
            rhs[i] += bw.jg[a, i] * ya


@step_kernel
def _predicted_branch(k, sol, cv, ma, v_reg, cwork):
    """Friction branch of contact k at the slip a Newton step ``sol`` predicts: v_T + cv dv_T
    (``cwork``: the contacts' records, :func:`~.hertz.contact_records`, at the iterate)."""
    ia = ma.ct_body[k, 0]
    ib = ma.ct_body[k, 1]
    dvt = 0.0
    for a in range(3):
        if ia >= 0:
            dvt += cwork[WT_ROW + a, k] * sol[3 * ia + a]
        if ib >= 0:
            dvt += cwork[WT_ROW + 3 + a, k] * sol[3 * ib + a]
    return _branch((cwork[VT_ROW, k] + cv * dvt) / v_reg)


@step_kernel
def _branches_hold(sol, cv, ma, v_reg, cwork):
    """Whether every loaded contact with friction stays on its friction branch over the step
    ``sol`` (then the friction law is linear along it, as a Newton matrix assumes)."""
    for k in range(ma.ct_type.shape[0]):
        if cwork[FN_ROW, k] <= 0.0 or ma.ct_law[k, 0] <= 0.0:
            continue
        if _predicted_branch(k, sol, cv, ma, v_reg, cwork) != _branch(cwork[VT_ROW, k] / v_reg):
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
    FN = cwork[FN_ROW]
    FT = cwork[FT_ROW]
    vt = cwork[VT_ROW]
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
                r2[ra] += (ft_model - FT[k]) * cwork[WT_ROW + a, k]
                for c in range(6):
                    bc = ia if c < 3 else ib
                    if bc < 0:
                        continue
                    J2[ra, 3 * bc + c % 3] += (coeff * cwork[WT_ROW + a, k]
                                               * cwork[WT_ROW + c, k])
        copy_vector(sol, r2, n + m)
        newton_solve(J2, G, cv, sol, sw.fac, sw.S, sw.piv, bw)


@step_kernel
def start_accelerations(state, ratio, acc_c):
    """The start accelerations of a step ``ratio`` times as long as the last one into
    ``acc_c``: a_n* = v'_n + ratio (a_n - v'_n), which keeps the generalized-alpha scheme second
    order across a change of the step's size (a_n - v'_n is (alpha_m - alpha_f) h v''(t_n) to
    leading order; Arnold and Bruls' correction)."""
    for i in range(acc_c.shape[0]):
        a = state.acc[i]
        acc_c[i] = a if ratio == 1.0 else state.vdot[i] + ratio * (a - state.vdot[i])


@step_kernel
def compliant_step_into(state, acc, t1, h, ratio, coef, st, ma, cs, work, velocities):
    """One compliant step of size ``h`` [s] ending at ``t1`` [s] from ``state`` (StepState: q,
    v, vdot, lam_s) with the start accelerations ``acc``: onset speeds of the open contacts
    (the approach speed of the last state, or where ``work.onset`` holds one, that), the
    smooth stage (:func:`compliant_smooth_step`, its first iterate extrapolated over
    ``ratio`` = h over the last step), the contacts at its result (:func:`finish_contacts`;
    the open ones' velocities only with ``velocities``) and the joint projection. The step's
    end state is left in ``work.step`` (q1, v1, acc1, vdot1; ``state.lam_s`` is updated in
    place), its contact quantities in ``work.contacts``. Returns (smooth iterations,
    converged, projection iterations, converged)."""
    sw = work.smooth
    bw = work.branches
    # onset speeds of the contacts open at the start of the step (of those whose velocities the
    # last step left out, when they close: _lazy_onset_speeds)
    for j in range(ma.ct_type.shape[0]):
        if cs.closed[j] == 0:
            if not np.isnan(work.onset[j]):
                cs.v_pre[j] = work.onset[j]
            elif not bw.stale[j]:
                cs.v_pre[j] = max(-cs.vn[j], st.v_pre_min)
    it_s, ok_s = compliant_smooth_step(state, acc, t1, h, ratio, coef, st, ma, cs.v_pre, work)
    q_t = work.step.q_t
    v_t = work.step.v_t
    finish_contacts(q_t, v_t, ma, work.contacts, bw, work.hertz, sw.trig, velocities)
    it_p, ok_p = project_joints_into(q_t, v_t, t1, h, st.tol, st.max_iter, ma, work.step.q1,
                                     work.step.v1, work.projection, sw.trig,
                                     JointRows(sw.g, sw.G, sw.dgdt))
    return it_s, ok_s, it_p, ok_p


@step_kernel
def commit_step(h, state, cs, work, it_s, it_p, ok, drive_row, velocities):
    """Take the step of :func:`compliant_step_into` (size ``h`` [s]; ``velocities``: whether
    it computed the open contacts' velocities): its end state becomes the state, and its
    contact forces (those of the converged smooth stage: the joint projection moves the state
    by the joints' drift only, far below the indentations) are added to the output interval's
    records (largest force and the friction at it, impulses by the trapezoidal rule, smallest
    gap, the drive's torque impulse [N m s]) with its iteration counts and convergence. The
    smooth stage's result becomes the reference of the next step's contacts
    (:func:`_skip_far_open`, :func:`_lazy_onset_speeds`); a contact it skipped (without
    ``velocities``, see :func:`finish_contacts`) keeps its older gap, which the interval's
    smallest gap leaves out, and the bound on how far that has moved (``bw.moved``)."""
    q_t, v_t, acc1, vdot1, _, _, _, _, q1, v1 = work.step
    cwork = work.contacts
    bw = work.branches
    for i in range(q1.shape[0]):
        state.q[i] = q1[i]
        state.v[i] = v1[i]
        state.acc[i] = acc1[i]
        state.vdot[i] = vdot1[i]
        bw.q_ref[i] = q_t[i]
        bw.v_ref[i] = v_t[i]
    bw.ready[1] = 1
    for j in range(cs.FN.shape[0]):
        FN_old = cs.FN[j]
        FT_old = cs.FT[j]
        cs.FN[j] = cwork[FN_ROW, j]
        cs.FT[j] = cwork[FT_ROW, j]
        cs.gap[j] = cwork[GAP_ROW, j]
        cs.vn[j] = cwork[VN_ROW, j]
        cs.vt[j] = cwork[VT_ROW, j]
        cs.closed[j] = 1 if cs.gap[j] < 0.0 else 0
        bw.stale[j] = not velocities and cs.closed[j] == 0
        cs.LN[j] += 0.5 * h * (FN_old + cs.FN[j])
        cs.LT[j] += 0.5 * h * (FT_old + cs.FT[j])
        if cs.FN[j] > cs.FN_max[j]:
            cs.FN_max[j] = cs.FN[j]
            cs.FT_at_max[j] = cs.FT[j]
        if bw.skip[j] and not velocities:  # an older gap (open, see finish_contacts)
            bw.moved[j] = bw.reach[j]
            continue
        bw.g_ref[j] = cs.gap[j]
        bw.moved[j] = 0.0
        if cs.gap[j] < cs.gap_min[j]:
            cs.gap_min[j] = cs.gap[j]
    if drive_row >= 0:
        cs.drive_impulse[0] += h * state.lam_s[drive_row]
    cs.it_max[STAGE_SMOOTH] = max(cs.it_max[STAGE_SMOOTH], it_s)
    cs.it_max[STAGE_POSITION] = max(cs.it_max[STAGE_POSITION], it_p)
    if not ok:
        cs.ok[0] = 0


@step_kernel
def write_sample(row, state, cs, out, ma, drive_row, trig, duration):
    """Write output row ``row`` at the end of its interval of ``duration`` [s] (q, v, energy:
    kinetic, gravitational, springs and the contacts' elastic energy; the drive torque averaged
    over the interval, its torque impulse over its length; the interval's records of
    :func:`commit_step`) and start the next interval's records."""
    q = state.q
    v = state.v
    for i in range(q.shape[0]):  # (an array assignment would need reference counting)
        out.q[row, i] = q[i]
        out.v[row, i] = v[i]
    for j in range(cs.FN.shape[0]):
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
    out.energy[row] = total_energy(q, v, ma) + elastic_energy_into(q, ma, trig)
    for s in range(3):
        out.iterations[row, s] = cs.it_max[s]
        cs.it_max[s] = 0
    out.converged[row] = cs.ok[0]
    cs.ok[0] = 1
    if drive_row >= 0:
        out.drive_torque[row] = cs.drive_impulse[0] / duration
    cs.drive_impulse[0] = 0.0


@step_kernel
def crossing_speed(g0, g1, vn0, vn1, h):
    """Normal velocity [m/s] where a gap that is ``g0`` >= 0 at the start of a step of size
    ``h`` [s] and ``g1`` < 0 at its end (rates ``vn0``, ``vn1`` [m/s]) crosses zero: the root of
    its cubic Hermite interpolant (bisection) and the interpolant's rate there."""
    d0 = h * vn0
    d1 = h * vn1
    lo = 0.0
    hi = 1.0
    for _ in range(50):
        s = 0.5 * (lo + hi)
        g = ((2.0 * s - 3.0) * s * s + 1.0) * g0 + ((s - 2.0) * s + 1.0) * s * d0 \
            + (3.0 - 2.0 * s) * s * s * g1 + (s - 1.0) * s * s * d1
        if g > 0.0:
            lo = s
        else:
            hi = s
    s = 0.5 * (lo + hi)
    rate = (6.0 * s * s - 6.0 * s) * g0 + (3.0 * s * s - 4.0 * s + 1.0) * d0 \
        + (6.0 * s - 6.0 * s * s) * g1 + (3.0 * s * s - 2.0 * s) * d1
    return rate / h


@step_kernel
def _start_gap_and_speed(k, ma, cs, bw, hw, trig):
    """Gap [m] and normal velocity [m/s] of contact ``k`` at the start of the step: at the last
    step's result (``bw.q_ref``, ``bw.v_ref``: the numbers its records hold where it computed
    the open contacts' velocities, which a fixed step leaves out between output rows), or at a
    run's first step its records."""
    if bw.ready[1] == 0:
        return cs.gap[k], cs.vn[k]
    g0 = contact_rows_cached(bw.q_ref, k, ma.ct_type, ma.ct_body, ma.ct_geom, hw.wN, hw.wT,
                             trig)
    return g0, row_dot(hw.wN, ma.ct_body[k, 0], ma.ct_body[k, 1], bw.v_ref)


@step_kernel
def _crossing_onset_speed(k, h, ma, cs, work, v_pre_min):
    """The approach speed [m/s] of contact ``k``, open at the start of the step of size ``h``
    [s] and closed at its end (its result in ``work.contacts``), where its gap crossed zero
    (:func:`crossing_speed`, from the gaps and normal velocities at the step's ends), at
    least ``v_pre_min``."""
    cwork = work.contacts
    g0, vn0 = _start_gap_and_speed(k, ma, cs, work.branches, work.hertz, work.smooth.trig)
    return max(-crossing_speed(max(g0, 0.0), cwork[GAP_ROW, k], vn0, cwork[VN_ROW, k], h),
               v_pre_min)


@step_kernel
def settle_onset_speeds(h, ma, cs, work, v_pre_min):
    """Whether the onset speed of every contact that closed in the step of size ``h`` [s] (of
    :func:`compliant_step_into`, its result in ``work.contacts``) is its approach speed where
    its gap crossed zero (:func:`_crossing_onset_speed`), to 1e-3; those that are not get it
    in ``work.onset`` for the step to be taken again with (adaptive steps: the last open state
    may lie a long step before a slow closing)."""
    settled = True
    for k in range(cs.closed.shape[0]):
        if cs.closed[k] != 0 or not work.contacts[GAP_ROW, k] < 0.0:
            continue
        speed = _crossing_onset_speed(k, h, ma, cs, work, v_pre_min)
        if abs(speed - cs.v_pre[k]) > 1e-3 * speed:
            work.onset[k] = speed
            settled = False
    return settled


@step_kernel
def onset_speeds_at_crossings(h, ma, cs, work, v_pre_min):
    """Give each contact that closed in the step of size ``h`` [s] (of
    :func:`compliant_step_into`, not yet committed) its approach speed at the crossing
    (:func:`_crossing_onset_speed`) as its onset speed from the next step on (fixed steps:
    the step itself took the approach speed of the last open state, where its indentation,
    at most a step's travel, carries little force)."""
    for k in range(cs.closed.shape[0]):
        if cs.closed[k] == 0 and work.contacts[GAP_ROW, k] < 0.0:
            cs.v_pre[k] = _crossing_onset_speed(k, h, ma, cs, work, v_pre_min)


@step_kernel
def clear_onsets(onset):
    """No onset speed given (NaN) for any contact."""
    for k in range(onset.shape[0]):
        onset[k] = np.nan


@step_kernel
def save_step_start(state, work):
    """Keep what :func:`compliant_step_into` changes before its step is committed (the joint
    multipliers, the smooth stage's start accelerations and whether the last step converged)
    in ``work.retry``, for :func:`restore_step_start`."""
    rw = work.retry
    bw = work.branches
    copy_vector(rw.lam_save, state.lam_s, state.lam_s.shape[0])
    copy_vector(rw.vdot_old_save, bw.vdot_old, bw.vdot_old.shape[0])
    rw.reuse_save[0] = bw.reuse[1]


@step_kernel
def restore_step_start(state, work):
    """Undo what a step not committed changed (:func:`save_step_start`)."""
    rw = work.retry
    bw = work.branches
    copy_vector(state.lam_s, rw.lam_save, state.lam_s.shape[0])
    copy_vector(bw.vdot_old, rw.vdot_old_save, bw.vdot_old.shape[0])
    bw.reuse[1] = rw.reuse_save[0]


@step_kernel
def _retry_in_substeps(t1, h, h_before, max_halvings, onset_at_crossing, coef, st, ma, state,
                       cs, work, sample):
    """Take the step of size ``h`` [s] ending at ``t1`` [s], which did not converge whole, again
    from its start as 2, 4, ... 2^``max_halvings`` substeps: a substep that does not converge is
    taken again as two of half its size, the substeps after it keep that size, and one that
    fails at h / 2^max_halvings is committed as not converged. ``h_before`` [s] is the size of
    the step before, whose accelerations the state holds; ``sample``: whether the step ends at
    an output row (the last substep then computes the open contacts' velocities);
    ``onset_at_crossing``: as :func:`integrate_compliant_chunk`'s. Each
    substep is committed as a step (:func:`commit_step`): the interval's records hold the
    largest force of the substeps, their impulses and iteration counts. Returns (whether every
    substep converged, the halvings taken, the size of the last substep [s])."""
    rw = work.retry
    restore_step_start(state, work)  # the start's multipliers, not the failed iterate's
    level = 1
    n = 2
    done = 0
    h_last = h_before
    all_ok = True
    while done < n:
        hs = h / n
        last = done == n - 1
        ratio = hs / h_last
        start_accelerations(state, ratio, rw.acc_c)
        save_step_start(state, work)
        t_end = t1 if last else t1 - h + (done + 1) * hs
        it_s, ok_s, it_p, ok_p = compliant_step_into(state, rw.acc_c, t_end, hs, ratio, coef, st,
                                                     ma, cs, work, sample and last)
        ok = ok_s and ok_p
        if not ok and level < max_halvings:
            restore_step_start(state, work)
            level += 1
            n *= 2
            done *= 2
            continue
        if ok and onset_at_crossing:
            onset_speeds_at_crossings(hs, ma, cs, work, st.v_pre_min)
        commit_step(hs, state, cs, work, it_s, it_p, ok, st.drive_row, sample and last)
        all_ok = all_ok and ok
        h_last = hs
        done += 1
    return all_ok, level, h_last


@loop_kernel
def integrate_compliant_chunk(k0, k1, every, max_halvings, onset_at_crossing, st, ma, state,
                              cs, out, work):
    """Advance steps k0 .. k1-1 of the compliant model by the fixed step ``st.h`` (state at
    t0 + k0 h on entry). With ``onset_at_crossing``, a contact that closes in a step takes its
    approach speed at the crossing as its onset speed from the next step on
    (:func:`onset_speeds_at_crossings`; otherwise it keeps that of the last open state). A
    step whose smooth stage or joint projection does not converge is taken again from its
    start as 2, 4, ... 2^``max_halvings`` substeps (:func:`_retry_in_substeps`;
    ``out.halvings`` of its interval records the halvings), and the step after the substeps
    starts from accelerations corrected to its size
    (:func:`start_accelerations`).

    Every ``every`` steps the output row (k + 1) // every is written (:func:`write_sample`):
    q, v, energy (kinetic, gravitational, springs and the contacts' elastic energy) at that
    instant, the drive torque averaged over the interval (its torque impulse over the
    interval's length, so that torque x drive rate x interval is the drive's work, which the
    energy audit subtracts; at ``every`` = 1 the step's torque); per contact the largest normal
    force of the interval ``F_N`` [N], the friction force at that peak ``F_T`` [N], the
    impulses ``Lambda_N``, ``Lambda_T`` [N s] (trapezoidal rule on the step-end forces), the
    smallest gap ``gap_N`` [m], the normal velocity at the start (``vn_pre``) and at the end
    (``vn_post``) of the interval [m/s]; the largest iteration counts and whether every step
    converged.

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
    coef = alpha_coefficients(st.rho_inf)
    first_bad = -1
    rw = work.retry
    h_last = rw.h_last[0] if rw.h_last[0] > 0.0 else h
    for k in range(k0, k1):
        t1 = st.t0 + (k + 1) * h
        # the open contacts' velocities are needed at the output rows only (elsewhere an
        # onset speed is computed when its contact closes)
        sample = (k + 1) % every == 0
        acc = state.acc
        if h_last != h:  # the step after a retried one's substeps
            start_accelerations(state, h / h_last, rw.acc_c)
            acc = rw.acc_c
        if max_halvings > 0:
            save_step_start(state, work)
        it_s, ok_s, it_p, ok_p = compliant_step_into(state, acc, t1, h, h / h_last, coef, st,
                                                     ma, cs, work, sample)
        ok = ok_s and ok_p
        if ok and onset_at_crossing:
            onset_speeds_at_crossings(h, ma, cs, work, st.v_pre_min)
        if ok or max_halvings == 0:
            commit_step(h, state, cs, work, it_s, it_p, ok, st.drive_row, sample)
            h_last = h
        else:
            ok, level, h_last = _retry_in_substeps(t1, h, h_last, max_halvings,
                                                   onset_at_crossing, coef, st, ma, state, cs,
                                                   work, sample)
            row = k // every + 1
            out.halvings[row] = max(out.halvings[row], level)
        if not ok and first_bad < 0:
            first_bad = k
        if sample:
            write_sample((k + 1) // every, state, cs, out, ma, st.drive_row, work.smooth.trig,
                         every * h)
    rw.h_last[0] = h_last
    return first_bad
