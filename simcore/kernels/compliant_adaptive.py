"""Adaptive steps for the compliant model: the step of :mod:`.compliant_step` with its size
chosen by a local error estimate, shortened where a contact closes, and landing on the output
grid.

Error estimate. For the generalized-alpha scheme the acceleration variable a_n approximates
the true acceleration at t_n + (alpha_m - alpha_f) h, and the position update
q_{n+1} = q_n + h v_n + h^2 ((1/2 - beta) a_n + beta a_{n+1}) then differs from the Taylor
series of the exact motion by h^3 q''' (beta - 1/6 + (alpha_m - alpha_f) / 2) + O(h^4). With
h q''' ~ a_{n+1} - a_n this gives the local error of a step (Zienkiewicz and Xie's estimator
for Newmark's scheme, beta - 1/6, extended to generalized-alpha as in Geradin and Cardona)::

    e = h^2 |beta - 1/6 + (alpha_m - alpha_f) / 2| (a_{n+1} - a_n)        [m, rad]

(1/3 at rho_inf = 0, 1/12 at rho_inf = 1). Per body the translation error and the angle error
times the body's radius of gyration form one length, sqrt(e_x^2 + e_y^2 + (r_g e_phi)^2) [m];
the largest over the bodies, over ``err_tol`` [m], is the step's error ratio. A step with a ratio
above one is rejected; the next size is h * 0.9 ratio^(-1/3) (the error is of order h^3), at
most twice and at least a fifth of h.

Step sizes and the Newton factors. A chord iterate reuses the factors of the last Newton
matrix (:func:`~.compliant_step.compliant_smooth_step`), which depend on h: a step that keeps
its size keeps them serving. So a step grows only when the estimate allows at least
``keep_growth`` times the current size (``solver.adaptive_keep_growth``, default 1.5), and
otherwise keeps it exactly. The price: a kept size can sit up to keep_growth / 0.9 times below
the one the tolerance allows, and where in that band it sits depends on the run's history.

Changes of size. a_n - v'_n is (alpha_m - alpha_f) h v''(t_n) to leading order: with a new
size h' the step starts from a_n* = v'_n + (h'/h)(a_n - v'_n), which keeps the scheme second
order across the change (Arnold and Bruls' correction), and the first Newton iterate is
extrapolated over h'/h.

Onset of a contact. A contact that closes in a step longer than the Hertz contact time of its
own approach speed over ``onset_steps`` (:func:`onset_step`) must end the step at most one such
onset step's depth inside (approach speed times onset step), else the step is redone, ending at
the crossing estimated from the gaps at its start and end (no shorter than the onset step).
Before a step, an open contact that approaches and would close within it shortens the step to
end at its predicted closing (no shorter than its onset step), so that most onsets need no
redone step. The onset speed of a contact that closes in a step (the v_pre of its damping
term) is its approach speed where its gap crosses zero, from the gaps and normal velocities at
the step's ends (:func:`~.compliant_step.settle_onset_speeds`; the step is redone with it), as
a fixed step's: the last open state may lie a long step before a slow closing.

Steps land on the output grid (every ``out_dt``): the rest of an interval is cut into equal
steps no longer than the planned one, so that a steady plan gives steps of one size. There the
outputs are those of the fixed step (:func:`~.compliant_step.write_sample`): per interval the
largest force, the friction at it, the impulses by the trapezoidal rule over the interval's
steps, the smallest gap.
"""

from __future__ import annotations

import numpy as np

from .compliant_step import (
    clear_onsets,
    commit_step,
    compliant_step_into,
    restore_step_start,
    save_step_start,
    settle_onset_speeds,
    start_accelerations,
    write_sample,
)
from .contact import contact_rows_cached
from .generalized_alpha import alpha_coefficients
from .hertz import hertz_impact_time
from .jit import loop_kernel, step_kernel

#: a step's size changes at most by these factors from one step to the next ...
GROWTH_MAX = 2.0
SHRINK_MIN = 0.2
#: ... aiming at this fraction of the tolerance (the error is of order h^3)
SAFETY = 0.9
#: a step keeps its planned size while the estimate allows between KEEP_LOW and
#: AdaptiveSettings.keep_growth of it (see the module docstring)
KEEP_LOW = 0.95
#: a smooth stage that does not converge is redone at this fraction of its size
FAILED_SHRINK = 0.25
#: a step is redone at most this many times for the onset speeds of its closing contacts
MAX_ONSET_REDOS = 3

#: ``counts`` entries of :data:`~.bundles.AdaptiveState`. NumPy integers, not Python ones:
#: Numba types a Python constant argument as a literal and compiles a specialisation of the
#: callee (:func:`_reject`) per value.
ACCEPTED = np.int64(0)
REJECTED_ERROR = np.int64(1)
REJECTED_ONSET = np.int64(2)
REJECTED_NEWTON = np.int64(3)
BELOW_DT_MIN = np.int64(4)


@step_kernel
def error_constant(coef):
    """|beta - 1/6 + (alpha_m - alpha_f) / 2| of the local error estimate [-]."""
    am, af, gam, beta = coef
    return abs(beta - 1.0 / 6.0 + 0.5 * (am - af))


@step_kernel
def error_ratio(acc_n, acc1, h, c_e, weight, err_tol):
    """The step's local error over the tolerance: the largest over the bodies of
    |h^2 c_e (a_{n+1} - a_n)| with each angle weighted by ``weight`` [m/rad] (the body's
    radius of gyration), over ``err_tol`` [m]. NaN for a non-finite step."""
    worst = 0.0
    for b in range(acc1.shape[0] // 3):
        s = 0.0
        for a in range(3):
            i = 3 * b + a
            e = (acc1[i] - acc_n[i]) * weight[i]
            s += e * e
        worst = max(worst, np.sqrt(s))
        if not np.isfinite(s):
            return np.nan
    return h * h * c_e * worst / err_tol


@step_kernel
def onset_step(k, q, ma, speed, onset_steps, hw, trig):
    """The step that resolves the onset of contact ``k`` at approach speed ``speed`` [m/s]:
    its undamped Hertz contact time (:func:`~.hertz.hertz_impact_time`) over ``onset_steps``
    [s]. m is the contact's effective mass 1 / (w_N M^-1 w_N^T) at ``q``
    (its normal row through the two bodies' masses, the joints left out), K its Hertz
    stiffness."""
    contact_rows_cached(q, k, ma.ct_type, ma.ct_body, ma.ct_geom, hw.wN, hw.wT, trig)
    inv_m = 0.0
    for s in range(2):
        body = ma.ct_body[k, s]
        if body < 0:
            continue
        for a in range(3):
            w = hw.wN[3 * s + a]
            inv_m += w * w / ma.mdiag[3 * body + a]
    return hertz_impact_time(inv_m, ma.ct_hertz[k, 0], speed) / onset_steps


@step_kernel
def onset_cap(h, q, cs, ma, v_pre_min, onset_steps, hw, trig):
    """The step size at most ``h`` [s] that ends where an approaching open contact is
    predicted to close (its gap over its approach speed, from the end of the last step), but
    no shorter than that contact's onset step (:func:`onset_step`)."""
    for k in range(cs.closed.shape[0]):
        if cs.closed[k] != 0 or not cs.vn[k] < 0.0:
            continue
        t_close = cs.gap[k] / -cs.vn[k]
        if t_close >= h:
            continue
        h_on = onset_step(k, q, ma, max(-cs.vn[k], v_pre_min), onset_steps, hw, trig)
        h = min(h, max(t_close, h_on))
    return h


@step_kernel
def onset_retry(h, q, cs, cwork, ma, onset_steps, hw, trig):
    """0 when the step of size ``h`` [s] from the state ``q`` resolves the onset of every
    contact that closed in it, else the size to redo it with [s]: a contact that closed in a
    step longer than its onset step (:func:`onset_step`, at its onset speed ``cs.v_pre``) and
    ends it deeper than its approach speed times that onset step asks for the crossing
    estimated from its gaps at the start and the end of the step (linear in between), no
    shorter than its onset step."""
    retry = h
    for k in range(cs.closed.shape[0]):
        depth = -cwork[2, k]
        if cs.closed[k] != 0 or not depth > 0.0:
            continue
        h_on = onset_step(k, q, ma, cs.v_pre[k], onset_steps, hw, trig)
        if h <= h_on or depth <= cs.v_pre[k] * h_on:
            continue
        g0 = max(cs.gap[k], 0.0)
        retry = min(retry, max(h * g0 / (g0 + depth), h_on))
    return retry if retry < h else 0.0


@step_kernel
def _attempt(t, h, coef, st, ma, state, cs, work, aw):
    """One step of size ``h`` [s] from time ``t`` [s], its end left in the work arrays (the
    state is unchanged but for ``lam_s`` and the smooth stage's records, which
    :func:`~.compliant_step.restore_step_start` restores): the start accelerations corrected
    to the step's size and the step of :func:`~.compliant_step.compliant_step_into`. Returns
    its (smooth iterations, projection iterations, converged)."""
    ratio = h / aw.h[1]
    rw = work.retry
    start_accelerations(state, ratio, rw.acc_c)
    save_step_start(state, work)
    it_s, ok_s, it_p, ok_p = compliant_step_into(state, rw.acc_c, t + h, h, ratio, coef, st,
                                                 ma, cs, work, True)
    return it_s, it_p, ok_s and ok_p


@step_kernel
def _accept(t, h, its, flagged, st, state, cs, work, aw):
    """Take the step of :func:`_attempt` from time ``t`` [s], of size ``h`` [s] and
    (smooth, projection) iterations ``its`` (:func:`~.compliant_step.commit_step`), counted
    as accepted and, where ``flagged`` (it needed less than dt_min), as such with its end
    time the first flagged one's if none was before."""
    if flagged:
        aw.counts[BELOW_DT_MIN] += 1
        if aw.t_flag[0] < 0.0:
            aw.t_flag[0] = t + h
    commit_step(h, state, cs, work, its[0], its[1], not flagged, st.drive_row, True)
    aw.counts[ACCEPTED] += 1
    aw.h_min[0] = min(aw.h_min[0], h)
    aw.h[1] = h


@step_kernel
def _reject(reason, h_next, ad, state, work, aw):
    """Reject the step of :func:`_attempt` for ``reason`` (a ``counts`` entry of
    :data:`~.bundles.AdaptiveState`): undo it (:func:`~.compliant_step.restore_step_start`),
    forget its onset speeds and plan the next attempt at ``h_next`` [s], no shorter than
    ``ad.dt_min``."""
    aw.counts[reason] += 1
    restore_step_start(state, work)
    clear_onsets(work.onset)
    aw.h[0] = max(h_next, ad.dt_min)


@step_kernel
def _next_size(h, h_plan, err, grid_cut, ad, dt_max):
    """The size of the step after an accepted one of size ``h`` [s] with error ratio ``err``:
    h 0.9 err^(-1/3), within [SHRINK_MIN, GROWTH_MAX] of h and [dt_min, dt_max]; but the
    planned size ``h_plan`` [s] stays while that is between KEEP_LOW and ``ad.keep_growth``
    of it, or when the output grid (``grid_cut``), not the error, made this step shorter than
    planned."""
    factor = GROWTH_MAX if err <= 0.0 else min(GROWTH_MAX, SAFETY * err ** (-1.0 / 3.0))
    new = h * max(factor, SHRINK_MIN)
    if KEEP_LOW * h_plan <= new < ad.keep_growth * h_plan or (
            grid_cut and factor >= 1.0 and new < h_plan):
        new = h_plan
    return min(max(new, ad.dt_min), dt_max)


@loop_kernel
def integrate_compliant_adaptive(row0, row1, st, ad, ma, state, cs, out, work, aw):
    """Advance the compliant model over the output intervals ending at rows row0 + 1 .. row1
    (state at t0 + row0 out_dt on entry) with steps of adaptive size (see the module
    docstring): at most ``st.h``, at least ``ad.dt_min`` unless the output grid cuts one
    shorter; a step that needs less than dt_min is taken at dt_min and flagged (``converged``
    0 in its interval), as is a step whose smooth stage did not converge at dt_min.

    Parameters
    ----------
    st : StepSettings
        h is the largest step [s].
    ad : AdaptiveSettings
    ma : ModelArrays
    state : StepState
    cs : CompliantState
    out : CompliantOutputs
    work : CompliantWork
    aw : AdaptiveState

    Returns
    -------
    int
        The first row whose interval holds a flagged step, or -1.
    """
    coef = alpha_coefficients(st.rho_inf)
    c_e = error_constant(coef)
    trig = work.smooth.trig
    first_bad = -1
    redos = 0
    for row in range(row0, row1):
        t_start = st.t0 + row * ad.out_dt
        t = t_start
        t_stop = st.t0 + (row + 1) * ad.out_dt
        steps = 0
        while t < t_stop:
            h_cap = onset_cap(aw.h[0], state.q, cs, ma, st.v_pre_min, ad.onset_steps,
                              work.hertz, trig)
            # the plan the next size starts from: the onset step where one cut it
            h_plan = aw.h[0] if h_cap == aw.h[0] else h_cap
            # the rest of the interval in equal steps of at most h_cap: steps of one size,
            # interval after interval, keep the Newton factors serving
            remaining = t_stop - t
            pieces = np.ceil(remaining / h_cap * (1.0 - 1e-9))
            last = pieces <= 1.0
            h = remaining if last else remaining / pieces
            it_s, it_p, ok = _attempt(t, h, coef, st, ma, state, cs, work, aw)
            err = error_ratio(work.retry.acc_c, work.step[2], h, c_e, aw.weight, ad.err_tol)
            floor = h <= ad.dt_min * (1.0 + 1e-9)
            if not ok and not floor:
                _reject(REJECTED_NEWTON, FAILED_SHRINK * h, ad, state, work, aw)
                continue
            if ok and not err <= 1.0 and not floor:
                shrink = SAFETY * err ** (-1.0 / 3.0) if np.isfinite(err) else SHRINK_MIN
                _reject(REJECTED_ERROR, max(shrink, SHRINK_MIN) * h, ad, state, work, aw)
                continue
            retry = onset_retry(h, state.q, cs, work.contacts, ma, ad.onset_steps, work.hertz,
                                trig)
            if retry > 0.0 and not floor:
                _reject(REJECTED_ONSET, retry, ad, state, work, aw)
                continue
            if redos < MAX_ONSET_REDOS and not settle_onset_speeds(h, ma, cs, work,
                                                                   st.v_pre_min):
                redos += 1
                aw.counts[REJECTED_ONSET] += 1
                restore_step_start(state, work)
                continue  # the same step, with the onset speeds at the crossings
            redos = 0
            clear_onsets(work.onset)
            flagged = not ok or not err <= 1.0  # (needed less than dt_min: taken at dt_min)
            _accept(t, h, (it_s, it_p), flagged, st, state, cs, work, aw)
            steps += 1
            aw.h[0] = _next_size(h, h_plan, err, h < h_cap, ad, st.h)
            t = t_stop if last else t + h
            if flagged and first_bad < 0:
                first_bad = row + 1
            if not np.isfinite(err) and flagged:
                return first_bad  # a non-finite state: the driver reports it
        write_sample(row + 1, state, cs, out, ma, st.drive_row, trig, t_stop - t_start)
        aw.row_steps[row + 1] = steps
    return first_bad
