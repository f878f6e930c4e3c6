"""The decoupled nonsmooth generalized-alpha step and its time loop: after the smooth stage
(:mod:`.generalized_alpha`), a position correction (:mod:`.position_correction`: joints and
unilateral contacts) and a velocity jump (:mod:`.velocity_jump`: Newton's impact law and
Coulomb friction).

A step whose sub-problems do not all converge, or that creates energy (the energy audit's
criterion, :mod:`simcore.model.audit`), is taken again from the same state as 2, then 4, ...
substeps, at most 2^max_halvings (:func:`integrate_chunk`); the run then goes on at h. The
velocity jump of a retried step may take :data:`RETRY_VELOCITY_ITERATIONS` times max_iter
iterations, and Newton again after its Gauss-Seidel fallback: its frictional impact problem
does not get easier with a smaller step (its impulses do not shrink with it), more iterations
and a solver that finishes where the fallback stalls do. The outputs keep one row per step:
the impulses of a subdivided step are the sums of its substeps'.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .bodies import trig_cache
from .bundles import STAGE_POSITION, STAGE_SMOOTH, STAGE_VELOCITY, StepSettings, StepState
from .contact import contact_velocities_into
from .generalized_alpha import alpha_coefficients, smooth_step, smooth_work, step_work
from .jit import loop_kernel, stage
from .linalg import copy_vector
from .position_correction import PositionWork, position_step, position_work
from .springs import energy_scale_term, total_energy
from .velocity_jump import (
    VelocityWork,
    _solve_velocity_problem,
    solve_velocity_problem,
    velocity_step,
    velocity_work,
)

__all__ = ["RETRY_VELOCITY_ITERATIONS", "STAGE_POSITION", "STAGE_SMOOTH", "STAGE_VELOCITY",
           "NonsmoothWork", "PositionWork", "RetrySettings", "RetryWork", "VelocityWork",
           "integrate_chunk", "loop_stage_calls", "nonsmooth_work", "position_step",
           "solve_velocity_problem", "velocity_step"]


#: The velocity jump of a retried step's substeps may take this many times
#: ``StepSettings.max_iter`` Newton iterations (and Gauss-Seidel sweeps of its fallback); the
#: smooth stage and the position correction keep the cap (a higher one costs much in the
#: position correction of a crowded ring, docs/reliability.md, section 7).
RETRY_VELOCITY_ITERATIONS = 4

#: Settings of the retries of :func:`integrate_chunk`: ``max_halvings`` (a failed step is
#: taken again as 2, 4, ... 2^max_halvings substeps; 0: never), and the energy audit's
#: per-step criterion that makes a step fail (:class:`simcore.model.audit.EnergyAudit`; its
#: window of steps that gain together flags without a retry): a step fails
#: when (E[k+1] - E[k]) - drive_torque[k+1] drive_rate h > energy_tol S_k + energy_floor, S_k
#: the largest :func:`~.springs.energy_scale_term` of rows j <= k, with ``energy_tol`` [-],
#: ``energy_floor`` [J], ``drive_rate`` the prescribed crank speed [rad/s] (0 without one).
RetrySettings = namedtuple("RetrySettings", ["max_halvings", "energy_tol", "energy_floor",
                                             "drive_rate"])

#: What a retried step starts from: the state at the start of the step (``start``, a
#: :class:`~.bundles.StepState` of copies) and the position correction's multipliers ``nu_c``,
#: ``nu_b``; per contact the largest normal impulse of the step's substeps so far
#: (``lam_best``, which picks the substep whose ``vn_free`` is kept); and the energy audit's
#: scale, S_k of :data:`RetrySettings` up to the current step (``energy_scale``, one entry,
#: carried from chunk to chunk).
RetryWork = namedtuple("RetryWork", ["start", "nu_c", "nu_b", "lam_best", "energy_scale"])

#: All work arrays of :func:`integrate_chunk` (:func:`nonsmooth_work`): the step's
#: (:func:`~.generalized_alpha.step_work`), the smooth stage's, the position correction's,
#: the velocity jump's, the contacts' (multipliers nu_N, gaps, normal and tangential
#: velocities after the step and normal velocities before the jump, one entry per contact)
#: and the retries' (:data:`RetryWork`).
NonsmoothWork = namedtuple("NonsmoothWork", ["step", "smooth", "position", "velocity",
                                             "contact", "retry"])


def nonsmooth_work(n, nbil, nc):
    """Every work array of :func:`integrate_chunk` for n coordinates, nbil joint rows and nc
    contacts, made once per run (the position correction and the velocity jump share one
    sine/cosine cache: the jump's rows are at the position correction's last configuration)."""
    trig = trig_cache(n // 3)
    start = StepState(np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(nbil),
                      np.zeros(nbil), np.zeros(nc), np.zeros(nc), np.zeros(nc), np.zeros(nc))
    return NonsmoothWork(step=step_work(n), smooth=smooth_work(n, nbil),
                         position=position_work(n, nbil, nc, trig),
                         velocity=velocity_work(n, nbil, nc, trig),
                         contact=(np.zeros(nc), np.zeros(nc), np.zeros(nc), np.zeros(nc),
                                  np.zeros(nc)),
                         retry=RetryWork(start=start, nu_c=np.zeros(nc), nu_b=np.zeros(nbil),
                                         lam_best=np.zeros(nc), energy_scale=np.zeros(1)))


def loop_stage_calls(st, ma, state, work):
    """The calls :func:`integrate_chunk` makes to its three stages, as (kernel, arguments) by
    stage name ("smooth", "position", "velocity"; and "velocity_solver", the velocity jump's
    call of :func:`~.velocity_jump._solve_velocity_problem`): the loop's own objects, so that
    each can be compiled for the loop's argument types ahead of the loop
    (:mod:`simcore.startup.parallel_compile`). Plain Python; keep it in step with the loop's
    calls (``tests/test_parallel_compile.py`` checks that the types are the loop's)."""
    q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, q1, v1 = work.step
    nu_c, gap = work.contact[0], work.contact[1]
    h = st.h
    t1 = st.t0 + h
    coef = alpha_coefficients.py_func(st.rho_inf)  # (the Python function: nothing compiled)
    jr, jp = work.velocity.rows, work.velocity.problem
    return {
        "smooth": (smooth_step, (state.q, state.v, state.acc, state.vdot, state.lam_s, t1, h,
                                 coef, st, ma, work.step, work.smooth)),
        "position": (position_step, (q_t, t1, h, st, ma, Ks_t, q1, nu_c, gap,
                                     work.position)),
        "velocity": (velocity_step, (q1, v_t, t1, h, st, ma, f_t, nu_c, gap, state, v1,
                                     work.velocity)),
        # the velocity jump's contact problem (the jump calls it with slices of these arrays,
        # of the same types)
        "velocity_solver": (_solve_velocity_problem, (jp.Dc, jp.cc, jr.kind, jr.mu_row,
                                                      jp.pair_c, jp.lam_c, st.tol, st.max_iter,
                                                      st.eta, st.newton_after_fallback,
                                                      work.velocity.solver)),
    }


@stage
def _copy_step_state(dst, src):
    """Copy every array of the :class:`~.bundles.StepState` ``src`` into ``dst`` (its arrays
    are all of one type, so the bundle is indexed like a tuple)."""
    for a in range(len(src)):
        copy_vector(dst[a], src[a], src[a].shape[0])


@stage
def _save_step_start(state, rw, nu_c, nu_b):
    """Keep the state at the start of a step, with the position correction's multipliers
    ``nu_c``, ``nu_b`` (its warm start), in ``rw`` (:data:`RetryWork`) for a retry."""
    _copy_step_state(rw.start, state)
    copy_vector(rw.nu_c, nu_c, nu_c.shape[0])
    copy_vector(rw.nu_b, nu_b, nu_b.shape[0])


@stage
def _restore_step_start(state, rw, nu_c, nu_b):
    """Put back what :func:`_save_step_start` kept."""
    _copy_step_state(state, rw.start)
    copy_vector(nu_c, rw.nu_c, nu_c.shape[0])
    copy_vector(nu_b, rw.nu_b, nu_b.shape[0])


@stage
def _normal_velocities_before_jump(v_t, GN, cols, ncols, nbil, vn_free):
    """vn_free = G_N(q1) v~, from the position correction's contact rows ``GN`` at q1 (their
    supports in ``cols``/``ncols`` after ``nbil`` joint rows; written out: a call of
    support_dot costs more than its six products)."""
    for j in range(vn_free.shape[0]):
        s = 0.0
        for t in range(ncols[nbil + j]):
            i = cols[nbil + j, t]
            s += GN[j, i] * v_t[i]
        vn_free[j] = s


@stage
def _accept_substep(state, step):
    """The step's q, v and accelerations (``step``: the arrays of
    :func:`~.generalized_alpha.step_work`) become the state."""
    q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, q1, v1 = step
    q = state.q
    v = state.v
    acc = state.acc
    vdot = state.vdot
    for i in range(q.shape[0]):
        q[i] = q1[i]
        v[i] = v1[i]
        acc[i] = acc1[i]
        vdot[i] = vdot1[i]


@stage
def _record_substep(k, j, n_sub, hs, its, st, state, out, contact, lam_best):
    """Write substep ``j`` of ``n_sub`` (of hs [s]) of step ``k`` into output row k+1, and make
    its contact velocities (``contact``, see :data:`NonsmoothWork`) the next substep's
    pre-impact velocities; ``its``: the substep's iterations (smooth, position, velocity).

    The first substep (j = 0) sets the row; the others add their impulses (Lambda_N, Lambda_T,
    the drive's impulse), keep the largest iteration count of each stage and the ``vn_free`` of
    the substep with the largest Lambda_N of each contact (``lam_best``); ``vn_pre`` stays that
    of the step's start; q, v, nu_N, gap_N and vn_post are the last substep's (the loop writes
    the energy at the last one). The drive torque is the step's mean, the drive's impulse over
    h."""
    row = k + 1
    nu_c, gap, vn, vt, vn_free = contact
    lamN = state.lamN
    lamT = state.lamT
    vn_prev = state.vn
    vt_prev = state.vt
    last = j == n_sub - 1
    for c in range(nu_c.shape[0]):
        if j == 0:
            out.lambda_N[row, c] = lamN[c]
            out.lambda_T[row, c] = lamT[c]
            out.vn_pre[row, c] = vn_prev[c]
            out.vn_free[row, c] = vn_free[c]
            lam_best[c] = lamN[c]
        else:
            out.lambda_N[row, c] += lamN[c]
            out.lambda_T[row, c] += lamT[c]
            if lamN[c] > lam_best[c]:
                lam_best[c] = lamN[c]
                out.vn_free[row, c] = vn_free[c]
        out.nu_N[row, c] = nu_c[c]
        out.gap_N[row, c] = gap[c]
        out.vn_post[row, c] = vn[c]
        vn_prev[c] = vn[c]
        vt_prev[c] = vt[c]
    it_s, it_p, it_v = its
    iters = out.iterations[row]
    if j == 0:
        iters[STAGE_SMOOTH] = it_s
        iters[STAGE_POSITION] = it_p
        iters[STAGE_VELOCITY] = it_v
    else:
        iters[STAGE_SMOOTH] = max(iters[STAGE_SMOOTH], it_s)
        iters[STAGE_POSITION] = max(iters[STAGE_POSITION], it_p)
        iters[STAGE_VELOCITY] = max(iters[STAGE_VELOCITY], it_v)
    dr = st.drive_row
    if dr >= 0:
        torque = state.lam_s[dr] + state.lam_b[dr] / hs
        if j == 0:
            out.drive_torque[row] = torque
        else:
            out.drive_torque[row] += torque
            if last:
                out.drive_torque[row] *= 1.0 / n_sub  # (exact: n_sub is a power of 2)
    if last:
        n = state.q.shape[0]
        copy_vector(out.q[row], state.q, n)
        copy_vector(out.v[row], state.v, n)


@stage
def _update_energy_scale(k, energy, q, ma, scale):
    """The energy audit's scale up to step k, ``scale[0]`` = max_{j <= k} of
    :func:`~.springs.energy_scale_term` of row j (NaN once an energy was NaN, as NumPy's
    maximum gives it)."""
    e = energy_scale_term(energy[k], q[k], ma)
    if not (scale[0] >= e or scale[0] != scale[0]):
        scale[0] = e


@stage
def _creates_energy(k, h, rs, out, scale):
    """Whether step k (output row k+1) created energy by the audit's per-step criterion
    (:data:`RetrySettings`; ``scale[0]``: the energy scale up to step k), computed as
    :meth:`simcore.model.audit.EnergyAudit.check` computes a step's own gain, operation for
    operation, so that both judge it alike (the audit's window of steps is not retried)."""
    err = (out.energy[k + 1] - out.energy[k]) - out.drive_torque[k + 1] * rs.drive_rate * h
    tol = rs.energy_tol * scale[0] + rs.energy_floor
    return not (err <= tol)


# (over 80 lines: 33 of them the docstring; the loop itself is the retry of one step and
# reads best whole)
@loop_kernel
def integrate_chunk(k0, k1, st, ma, state, out, work, rs):
    """Advance steps k0 .. k1-1 (state at time k0*h on entry, at k1*h on exit), writing the
    outputs of each step at index k+1.

    A step whose sub-problems do not all converge, or which creates energy by the audit's
    per-step criterion, is taken again from its start as 2 substeps of h/2, then 4 of h/4, ... up to
    2^rs.max_halvings (a level stops at its first failing substep, except the last level,
    which is taken to the end whatever happens: its step is flagged). Each substep is a whole
    step of the scheme (its pre-impact velocities those at the substep's start).

    Parameters
    ----------
    st : StepSettings
        h [s], rho_inf, tol, max_iter, eta, drive_row.
    ma : ModelArrays
        The model.
    state : StepState
        Updated in place.
    out : ChunkOutputs
        ``out.vn_free`` receives the normal relative velocity just before the jump of the step,
        G_N(q_{n+1}) v~_{n+1}: the smooth-step velocity seen by the contact rows at the
        corrected position [m/s]; ``out.halvings`` the times each step was halved (0: taken
        whole); what the other rows hold for a subdivided step: :func:`_record_substep`.
    work : NonsmoothWork
        Work arrays (:func:`nonsmooth_work`), reused from chunk to chunk.
    rs : RetrySettings
        When a step is retried.

    Returns
    -------
    int
        The index of the first step whose sub-problems did not all converge at its smallest
        substep, or -1.
    """
    h = st.h
    coef = alpha_coefficients(st.rho_inf)
    q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, q1, v1 = work.step
    contact = work.contact
    nu_c, gap, vn_free = contact[0], contact[1], contact[4]
    pwk = work.position
    nu_b = pwk.nu_b
    rw = work.retry
    st_retry = StepSettings(st.h, st.rho_inf, st.tol, RETRY_VELOCITY_ITERATIONS * st.max_iter,
                            st.eta, st.drive_row, st.t0, st.v_reg, st.v_pre_min, 1)
    first_bad = -1
    for k in range(k0, k1):
        _update_energy_scale(k, out.energy, out.q, ma, rw.energy_scale)
        if rs.max_halvings > 0:
            _save_step_start(state, rw, nu_c, nu_b)
        halvings = 0
        while True:
            # the step as n_sub substeps of hs (the whole step first); the last ends exactly
            # at (k + 1) h
            n_sub = 1 << halvings
            hs = h / n_sub
            final = halvings >= rs.max_halvings
            st_v = st if halvings == 0 else st_retry
            ok = True
            for j in range(n_sub):
                t1 = st.t0 + ((k + 1) * h if j == n_sub - 1 else k * h + (j + 1) * hs)
                it_s, ok_s = smooth_step(state.q, state.v, state.acc, state.vdot, state.lam_s,
                                         t1, hs, coef, st, ma, work.step, work.smooth)
                it_p, ok_p = position_step(q_t, t1, hs, st, ma, Ks_t, q1, nu_c, gap, pwk)
                _normal_velocities_before_jump(v_t, pwk.GN, pwk.metric.cols,
                                               pwk.metric.ncols, nu_b.shape[0], vn_free)
                it_v, ok_v = velocity_step(q1, v_t, t1, hs, st_v, ma, f_t, nu_c, gap, state,
                                           v1, work.velocity)
                _accept_substep(state, work.step)
                contact_velocities_into(state.q, state.v, ma, gap, contact[2], contact[3],
                                        pwk.scratch.wN, pwk.scratch.wT, pwk.scratch.trig)
                _record_substep(k, j, n_sub, hs, (it_s, it_p, it_v), st, state, out, contact,
                                rw.lam_best)
                ok = ok and ok_s and ok_p and ok_v
                if not (ok or final):
                    break  # (this level has failed)
            if ok or final:
                out.energy[k + 1] = total_energy(state.q, state.v, ma)
                if final or not _creates_energy(k, h, rs, out, rw.energy_scale):
                    break
            # the step failed: take it again from its start with twice as many substeps
            halvings += 1
            _restore_step_start(state, rw, nu_c, nu_b)
        out.converged[k + 1] = 1 if ok else 0
        out.halvings[k + 1] = halvings
        if not ok and first_bad < 0:
            first_bad = k
    return first_bad
