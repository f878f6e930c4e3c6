"""The position correction of the nonsmooth step: after the smooth stage, the smallest
displacement U (in the metric M + h^2 K_s) that restores the joints and closes every
penetration, with multipliers nu on the joint rows and the contacts.

:func:`position_step` reads as its stages: :func:`_prepare_position` (metric, supports, warm
start, rows at the predicted configuration), then per semismooth Newton iteration
:func:`_guess_active_set`, :func:`_factor_newton_matrix`, :func:`_linearise`,
:func:`_pivot_active_set` (the linearised problem's exact active set),
:func:`_newton_point`, :func:`_position_line_search` and :func:`_take_position_step`.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .bodies import pair_support, place_row, scale_pair_blocks, trig_cache
from .contact import contact_hessian_into, contact_rows_cached
from .jit import stage, step_kernel
from .joints import bilateral_cached, joint_support
from .linalg import (
    SYMMETRIC,
    block_factor,
    block_factor_work,
    block_gram_entry,
    block_gram_rows,
    block_solve,
    copy_matrix,
    copy_vector,
    lu_factor,
    lu_solve,
)

#: An iterate of the position correction: the correction U, the joint and contact multipliers
#: nu_b, nu_c, and what the rows give at q = q~ + U: joint residuals gb and Jacobian Gb,
#: gaps and normal rows GN, and the metric's product AU = A U. The current iterate is built
#: in :func:`position_step` from the caller's q, nu_c, gap and the work arrays; the line
#: search's trial iterate is ``PositionWork.trial``.
PositionIterate = namedtuple("PositionIterate", ["U", "nu_b", "nu_c", "q", "gb", "Gb", "gap",
                                                 "GN", "AU"])

#: What a residual needs besides the iterate: the metric A = M + h^2 K_s (``Ap``) and its
#: factor ``facA``, the rows' supports ``cols``/``ncols`` (joints first, then contacts), the
#: contacts' Delassus scaling ``r_c`` (0 until first needed) from their rows at the predicted
#: configuration ``GN0`` (with a substitution row ``ys``), and the equilibrium residual ``eq``.
PositionMetric = namedtuple("PositionMetric", ["Ap", "facA", "cols", "ncols", "r_c", "GN0",
                                               "ys", "eq"])

#: Scratch of the rows' evaluation: the joints' velocity terms ``gm``, ``dgdt`` (not needed
#: here), a contact's rows ``wN``, ``wT``, the bodies' sine/cosine cache ``trig``.
RowScratch = namedtuple("RowScratch", ["gm", "dgdt", "wN", "wT", "trig"])

#: The linearised problem of a Newton iteration: its matrix H = A - sum nu_k d2g_k (``Hm``,
#: factor ``facH``; ``Hloc``, ``P`` for a contact's Hessian), all rows ``Gall`` (joints, then
#: contacts) and their right-hand sides ``ball``, H^-1 A U (``HAU``), the ``active`` contacts,
#: the rows in play ``rows``, their Delassus entries ``Dall`` (formed once per iteration:
#: ``have``, ``Y``, ``first``), the system ``Dbuf`` with pivots ``piv``, its solution ``sol`` and
#: x = H^-1 G^T sol.
LinearisedProblem = namedtuple("LinearisedProblem", [
    "Hm", "facH", "Hloc", "P", "Gall", "ball", "HAU", "active", "rows", "Dall", "have", "Y",
    "first", "Dbuf", "piv", "sol", "x"])

#: The Newton point of an iteration: correction and multipliers.
NewtonPoint = namedtuple("NewtonPoint", ["U", "nu_b", "nu_c"])

#: Work arrays of the position correction (:func:`position_work`): the ``metric``
#: (:data:`PositionMetric`), the rows' ``scratch`` (:data:`RowScratch`), the linearised problem
#: ``lin`` (:data:`LinearisedProblem`), the current iterate's own arrays (``U``, ``nu_b``,
#: ``gb``, ``Gb``, ``GN``, ``AU``), the line search's ``trial`` (:data:`PositionIterate`) and
#: the Newton point ``new`` (:data:`NewtonPoint`).
PositionWork = namedtuple("PositionWork", ["metric", "scratch", "lin", "U", "nu_b", "gb", "Gb",
                                           "GN", "AU", "trial", "new"])

#: Most active-set pivots of one Newton iteration, per contact squared (Murty's rule is finite;
#: this is a guard).
PIVOTS_PER_CONTACT2 = 8
#: Backtracking trials of the line search (step halved each time).
LINE_SEARCH_TRIALS = 12


def _iterate_arrays(n, nbil, nc):
    """A :data:`PositionIterate` of zeros (made in Python)."""
    return PositionIterate(U=np.zeros(n), nu_b=np.zeros(nbil), nu_c=np.zeros(nc), q=np.zeros(n),
                           gb=np.zeros(nbil), Gb=np.zeros((nbil, n)), gap=np.zeros(nc),
                           GN=np.zeros((nc, n)), AU=np.zeros(n))


def position_work(n, nbil, nc, trig=None):
    """Work arrays of :func:`position_step` (made once per run, in Python: allocating them in
    a kernel would compile some forty array constructors into every time loop). ``trig``: the
    bodies' sine/cosine cache (:func:`~.bodies.trig_cache`), shared with the velocity jump."""
    mt = nbil + nc
    metric = PositionMetric(Ap=np.zeros((n, n)), facA=block_factor_work(n),
                            cols=np.zeros((mt, 6), dtype=np.int64),
                            ncols=np.zeros(mt, dtype=np.int64), r_c=np.zeros(nc),
                            GN0=np.zeros((nc, n)), ys=np.zeros((1, n)), eq=np.zeros(n))
    scratch = RowScratch(gm=np.zeros(nbil), dgdt=np.zeros(nbil), wN=np.zeros(6),
                         wT=np.zeros(6), trig=trig_cache(n // 3) if trig is None else trig)
    lin = LinearisedProblem(
        Hm=np.zeros((n, n)), facH=block_factor_work(n), Hloc=np.zeros((6, 6)),
        P=np.zeros((2, 6)), Gall=np.zeros((mt, n)), ball=np.zeros(mt), HAU=np.zeros(n),
        active=np.zeros(nc, dtype=np.bool_), rows=np.zeros(mt, dtype=np.int64),
        Dall=np.zeros((mt, mt)), have=np.zeros(mt, dtype=np.bool_), Y=np.zeros((mt, n)),
        first=np.zeros(mt, dtype=np.int64), Dbuf=np.zeros((mt, mt)),
        piv=np.zeros(mt, dtype=np.int64), sol=np.zeros(mt), x=np.zeros(n))
    return PositionWork(metric=metric, scratch=scratch, lin=lin, U=np.zeros(n),
                        nu_b=np.zeros(nbil), gb=np.zeros(nbil), Gb=np.zeros((nbil, n)),
                        GN=np.zeros((nc, n)), AU=np.zeros(n),
                        trial=_iterate_arrays(n, nbil, nc),
                        new=NewtonPoint(U=np.zeros(n), nu_b=np.zeros(nbil), nu_c=np.zeros(nc)))


@step_kernel
def _position_rows(q_t, t1, ma, it, scratch):
    """Joint and contact rows of the iterate ``it`` at it.q = q_t + it.U: joint residuals gb,
    Jacobian Gb, gaps and normal rows GN (only the six entries of each contact's bodies are
    written: the others are zero from the start and stay so)."""
    ct_body = ma.ct_body
    q1 = it.q
    gap = it.gap
    trig = scratch.trig
    wN = scratch.wN
    for i in range(q_t.shape[0]):
        q1[i] = q_t[i] + it.U[i]
    bilateral_cached(q1, it.U, t1, ma, it.gb, it.Gb, scratch.gm, scratch.dgdt, trig)
    for k in range(gap.shape[0]):
        gap[k] = contact_rows_cached(q1, k, ma.ct_type, ma.ct_body, ma.ct_geom, wN, scratch.wT,
                                     trig)
        place_row(it.GN, k, wN, ct_body[k, 0], ct_body[k, 1])


@step_kernel
def _metric_product(Ap, fac, U, out):
    """out = Ap U, for an Ap that is diagonal but for the coupled block ``fac`` found when it
    was factorised (:func:`~.linalg.block_factor`)."""
    for i in range(U.shape[0]):
        out[i] = Ap[i, i] * U[i]
    idx = fac.idx
    kc = fac.info[0]
    for a in range(kc):
        i = idx[a]
        s = 0.0
        for b in range(kc):
            s += Ap[i, idx[b]] * U[idx[b]]
        out[i] = s


@step_kernel
def _contact_scale(k, nbil, metric):
    """The augmentation r_k = 1 / (G_k A^-1 G_k^T) of contact k (after ``nbil`` joint rows),
    from its row at the predicted configuration (``metric.GN0``), computed when first needed
    (``metric.r_c[k]`` is 0 until then): only a contact that is loaded or penetrates, or
    becomes active, needs it."""
    r_c = metric.r_c
    if r_c[k] == 0.0:
        row0 = np.int64(0)  # (a literal 0 would compile a second specialisation)
        d = block_gram_entry(metric.facA, metric.GN0, k, metric.ys, row0, metric.cols,
                             nbil + k, metric.ncols[nbil + k])
        r_c[k] = 1.0 / d if d > 0.0 else 1.0
    return r_c[k]


@step_kernel
def _position_residual(it, ma, metric):
    """Scaled residual [m] of the position problem at the iterate ``it`` (its rows from
    :func:`_position_rows`): joints, complementarity in the augmented-Lagrangian form
    (nu - max(0, nu - r g))/r, and equilibrium M^-1 (Ap U - G^T nu). The metric's factor
    tells which indices have off-diagonal entries; ``it.AU`` receives Ap U (the Newton step
    needs it)."""
    mdiag = ma.mdiag
    U = it.U
    nu_b = it.nu_b
    nu_c = it.nu_c
    gb = it.gb
    Gb = it.Gb
    gap = it.gap
    GN = it.GN
    eq = metric.eq
    cols = metric.cols
    ncols = metric.ncols
    n = U.shape[0]
    nbil = gb.shape[0]
    res = 0.0
    for r in range(nbil):
        res = max(res, abs(gb[r]))
    for k in range(gap.shape[0]):
        if nu_c[k] == 0.0 and gap[k] >= 0.0:
            continue  # an open contact without multiplier: its term is 0 whatever r_k
        rk = _contact_scale(k, nbil, metric)
        val = nu_c[k] - max(0.0, nu_c[k] - rk * gap[k])
        res = max(res, abs(val) / rk)
    _metric_product(metric.Ap, metric.facA, U, it.AU)
    for i in range(n):
        eq[i] = it.AU[i]
    for r in range(nbil):
        if nu_b[r] != 0.0:
            for t in range(ncols[r]):
                i = cols[r, t]
                eq[i] -= Gb[r, i] * nu_b[r]
    for k in range(gap.shape[0]):
        if nu_c[k] != 0.0:
            for t in range(ncols[nbil + k]):
                i = cols[nbil + k, t]
                eq[i] -= GN[k, i] * nu_c[k]
    for i in range(n):
        res = max(res, abs(eq[i]) / mdiag[i])
    return res


@stage
def _prepare_position(q_t, t1, h, ma, Ks_t, it, metric, scratch, rows):
    """Everything the Newton iteration starts from: the rows' supports, the metric
    Ap = M + h^2 Ks factorised, U = 0, the warm start's multipliers made admissible, the rows
    at the predicted configuration q_t (kept in ``GN0`` for the contacts' Delassus scaling,
    cleared for recomputation); ``rows``: the linearised problem's rows, whose first are the
    joints'."""
    mdiag = ma.mdiag
    ct_body = ma.ct_body
    U = it.U
    nu_b = it.nu_b
    nu_c = it.nu_c
    n = q_t.shape[0]
    nbil = nu_b.shape[0]
    nc = ma.ct_type.shape[0]
    # the support of every row (joints first, then contacts): products with rows visit it only
    cols = metric.cols
    ncols = metric.ncols
    joint_support(ma.jt_type, ma.jt_body, cols, ncols)
    for k in range(nc):
        ncols[nbil + k] = pair_support(ct_body[k, 0], ct_body[k, 1], cols, nbil + k)
    for r in range(nbil):
        rows[r] = r  # the joints' rows, always in the linearised problem
    # Ap = M + h^2 Ks: Ks is zero outside the springs' body-pair blocks (smooth_forces), and so
    # is Ap but for its diagonal, from the start
    Ap = metric.Ap
    scale_pair_blocks(Ap, Ks_t, h * h, ma.sp_body)
    for i in range(n):
        Ap[i, i] = h * h * Ks_t[i, i] + mdiag[i]
        U[i] = 0.0
    block_factor(Ap, n, metric.facA, SYMMETRIC)
    # warm start from the previous step's multipliers (a loaded contact, a pinched ball,
    # carries about the same from one step to the next): its Newton matrix then has the
    # contacts' geometric stiffness from the first iteration, and its active set is right
    # from the start (docs/method.md). A value a failed step may have left (not finite, or a
    # negative contact multiplier) starts from zero.
    for r in range(nbil):
        if not np.isfinite(nu_b[r]):
            nu_b[r] = 0.0
    for k in range(nc):
        if not (nu_c[k] > 0.0 and np.isfinite(nu_c[k])):
            nu_c[k] = 0.0
    # the rows at the predicted configuration; the Delassus scaling r_k of a contact comes
    # from them, on first need (_contact_scale)
    _position_rows(q_t, t1, ma, it, scratch)
    GN = it.GN
    GN0 = metric.GN0
    r_c = metric.r_c
    for k in range(nc):
        r_c[k] = 0.0
        for t in range(ncols[nbil + k]):
            i = cols[nbil + k, t]
            GN0[k, i] = GN[k, i]


@stage
def _guess_active_set(it, metric, active):
    """The active set the iterate's multipliers and gaps give: nu_k - r_k g_k > 0 (an open
    contact without multiplier is inactive whatever r_k)."""
    nu_c = it.nu_c
    gap = it.gap
    nbil = it.gb.shape[0]
    for k in range(nu_c.shape[0]):
        active[k] = (nu_c[k] != 0.0 or gap[k] < 0.0) and (
            nu_c[k] - _contact_scale(k, nbil, metric) * gap[k] > 0.0)


@stage
def _factor_newton_matrix(it, ma, Ap, lin):
    """Factorise the Newton matrix of the equilibrium, Ap - sum nu_k d2g_k (the contacts'
    geometric stiffness), into ``lin.facH``. Returns False (nothing done: the matrix is Ap,
    already factorised) when no contact carries a multiplier."""
    ct_body = ma.ct_body
    nu_c = it.nu_c
    n = it.U.shape[0]
    nc = nu_c.shape[0]
    loaded = False
    for k in range(nc):
        if nu_c[k] > 0.0:
            loaded = True
    if not loaded:
        return False
    Hm = lin.Hm
    Hloc = lin.Hloc
    copy_matrix(Hm, Ap, n, n)
    for k in range(nc):
        if nu_c[k] > 0.0:
            contact_hessian_into(it.q, k, ma, Hloc, lin.P)
            for a in range(6):
                ba = ct_body[k, 0] if a < 3 else ct_body[k, 1]
                if ba < 0:
                    continue
                for c in range(6):
                    bc = ct_body[k, 0] if c < 3 else ct_body[k, 1]
                    if bc < 0:
                        continue
                    Hm[3 * ba + a % 3, 3 * bc + c % 3] -= nu_c[k] * Hloc[a, c]
    block_factor(Hm, n, lin.facH, SYMMETRIC)
    return True


@stage
def _linearise(fac, it, metric, lin):
    """The linearised problem of the iterate, for all rows (joints first, then contacts): row i
    of the new iterate reads (D nu)_i = ball_i (+ the proximal term on contacts), with
    D = Gall H^-1 Gall^T and ball = -g + G H^-1 A U. ``fac``: the factor of H."""
    gb = it.gb
    Gb = it.Gb
    gap = it.gap
    GN = it.GN
    n = it.U.shape[0]
    nbil = gb.shape[0]
    HAU = lin.HAU
    Gall = lin.Gall
    ball = lin.ball
    cols = metric.cols
    ncols = metric.ncols
    copy_vector(HAU, it.AU, n)
    block_solve(fac, n, HAU)
    # (Gall is zero outside the rows' supports from the start)
    for r in range(nbil):
        s = -gb[r]
        for t in range(ncols[r]):
            i = cols[r, t]
            Gall[r, i] = Gb[r, i]
            s += Gb[r, i] * HAU[i]
        ball[r] = s
    for k in range(gap.shape[0]):
        s = -gap[k]
        for t in range(ncols[nbil + k]):
            i = cols[nbil + k, t]
            Gall[nbil + k, i] = GN[k, i]
            s += GN[k, i] * HAU[i]
        ball[nbil + k] = s


@stage
def _solve_on_active_set(fac, it, eta_k, metric, lin):
    """Solve the linearised problem with the joints and the active contacts as equalities:
    ``lin.rows[:m]`` the rows, ``lin.sol[:m]`` their multipliers, ``lin.x`` = H^-1 G^T sol.
    Returns m. Only the Delassus entries among these rows are formed, each once per Newton
    iteration (block_gram_rows adds a newly active row)."""
    nu_c = it.nu_c
    n = it.U.shape[0]
    nbil = it.gb.shape[0]
    nc = nu_c.shape[0]
    active = lin.active
    rows = lin.rows
    sol = lin.sol
    Dall = lin.Dall
    Gall = lin.Gall
    ball = lin.ball
    x = lin.x
    piv = lin.piv
    cols = metric.cols
    ncols = metric.ncols
    m = nbil  # rows[:nbil] are the joints, always present
    for k in range(nc):
        if active[k]:
            rows[m] = nbil + k
            m += 1
    block_gram_rows(fac, Gall, rows, m, lin.Y, lin.first, lin.have, Dall, cols, ncols)
    D = lin.Dbuf  # its leading m x m block
    for a in range(m):
        ra = rows[a]
        for c in range(m):
            D[a, c] = Dall[ra, rows[c]]
        sol[a] = ball[ra]
        if ra >= nbil:
            # proximal term on the contacts, (eta / r_k)(nu - nu_k)
            k = ra - nbil
            reg = eta_k / _contact_scale(k, nbil, metric)
            D[a, a] += reg
            sol[a] += reg * nu_c[k]
    lu_factor(D, m, piv)
    lu_solve(D, m, piv, sol)
    for i in range(n):
        x[i] = 0.0
    for a in range(m):
        ra = rows[a]
        for t in range(ncols[ra]):
            i = cols[ra, t]
            x[i] += Gall[ra, i] * sol[a]
    block_solve(fac, n, x)
    return m


@stage
def _first_violator(m, nbil, target, metric, lin):
    """Murty's least-index rule on the solution of :func:`_solve_on_active_set` (``nbil`` joint
    rows, then m - nbil contacts): the first contact whose multiplier is negative or, before
    it, the first inactive contact whose linearised gap G_k x - ball_k is below -0.1 target
    [m]; -1 if there is none."""
    active = lin.active
    sol = lin.sol
    rows = lin.rows
    Gall = lin.Gall
    ball = lin.ball
    x = lin.x
    cols = metric.cols
    ncols = metric.ncols
    nc = active.shape[0]
    flip = -1
    for a in range(nbil, m):
        if sol[a] < 0.0:
            flip = rows[a] - nbil
            break
    for k in range(nc):
        if flip >= 0 and k >= flip:
            break
        if not active[k]:
            # G_k x over the row's support (written out: a call of support_dot costs more
            # than its six products)
            s = 0.0
            for t in range(ncols[nbil + k]):
                i = cols[nbil + k, t]
                s += Gall[nbil + k, i] * x[i]
            lin_gap = -ball[nbil + k] + s
            if lin_gap < -0.1 * target:
                return k
    return flip


@stage
def _pivot_active_set(fac, it, eta_k, target, metric, lin):
    """The exact active set of the linearised problem (primal-dual active set): drop contacts
    whose multiplier turns negative, add those whose linearised gap turns negative, one at a
    time by Murty's least-index rule, which is finite for this positive definite (P-matrix)
    problem, where flipping every violator at once can cycle among redundant contacts. One
    geometric Newton step then never cycles on a degenerate contact. Returns the number of
    rows m of the solution left in ``lin.rows``, ``lin.sol``, ``lin.x``."""
    nbil = it.gb.shape[0]
    nc = it.gap.shape[0]
    active = lin.active
    have = lin.have
    for r in range(have.shape[0]):
        have[r] = False
    m = nbil
    for _pivot in range(PIVOTS_PER_CONTACT2 * nc * nc + 8):
        m = _solve_on_active_set(fac, it, eta_k, metric, lin)
        flip = _first_violator(m, nbil, target, metric, lin)
        if flip < 0:
            break
        active[flip] = not active[flip]
    return m


@stage
def _newton_point(m, it, lin, new):
    """The Newton point of the iterate: U_new = U + H^-1 (G_active^T sol - Ap U), and the
    multipliers of the solution (zero on inactive contacts)."""
    U = it.U
    U_new = new.U
    HAU = lin.HAU
    x = lin.x
    sol = lin.sol
    nuc_new = new.nu_c
    nbil = it.gb.shape[0]
    for i in range(U.shape[0]):
        U_new[i] = U[i] - HAU[i] + x[i]
    for r in range(nbil):
        new.nu_b[r] = sol[r]
    nuc_new[:] = 0.0
    for a in range(nbil, m):
        nuc_new[lin.rows[a] - nbil] = sol[a]


@stage
def _position_line_search(q_t, t1, res, it, ma, tr, new, scratch, metric):
    """Backtracking line search on the scaled residual from the iterate ``it`` (residual
    ``res``) towards the Newton point ``new``, the trials in ``tr``. Returns (theta of the
    smallest residual, theta of the last trial, that smallest residual)."""
    U, nu_b, nu_c = it.U, it.nu_b, it.nu_c
    U_try, nub_try, nuc_try = tr.U, tr.nu_b, tr.nu_c
    U_new, nub_new, nuc_new = new.U, new.nu_b, new.nu_c
    n = U.shape[0]
    nbil = nu_b.shape[0]
    nc = nu_c.shape[0]
    theta = 1.0
    best = -1.0
    best_theta = 1.0
    best_res = 0.0
    for _ls in range(LINE_SEARCH_TRIALS):
        for i in range(n):
            U_try[i] = U[i] + theta * (U_new[i] - U[i])
        for r in range(nbil):
            nub_try[r] = nu_b[r] + theta * (nub_new[r] - nu_b[r])
        for k in range(nc):
            nuc_try[k] = nu_c[k] + theta * (nuc_new[k] - nu_c[k])
        _position_rows(q_t, t1, ma, tr, scratch)
        res_try = _position_residual(tr, ma, metric)
        if best < 0.0 or res_try < best:
            best = res_try
            best_theta = theta
            best_res = res_try
        if res_try <= (1.0 - 1e-4 * theta) * res:
            break
        theta *= 0.5
    return best_theta, theta, best_res


@stage
def _take_position_step(q_t, t1, theta, last_theta, best_res, it, ma, tr, new, scratch,
                        metric):
    """Move the iterate by ``theta`` towards the Newton point ``new``; returns its residual.
    When ``theta`` was the line search's last trial, the trial ``tr`` is the new iterate: its
    rows and residual are taken as they are."""
    if theta == last_theta:
        n = tr.U.shape[0]
        nbil = tr.nu_b.shape[0]
        nc = tr.nu_c.shape[0]
        copy_vector(it.U, tr.U, n)
        copy_vector(it.nu_b, tr.nu_b, nbil)
        copy_vector(it.nu_c, tr.nu_c, nc)
        copy_vector(it.q, tr.q, n)
        copy_vector(it.gb, tr.gb, nbil)
        copy_matrix(it.Gb, tr.Gb, nbil, n)
        copy_vector(it.gap, tr.gap, nc)
        copy_matrix(it.GN, tr.GN, nc, n)
        copy_vector(it.AU, tr.AU, n)
        return best_res
    U, nu_b, nu_c = it.U, it.nu_b, it.nu_c
    U_new, nub_new, nuc_new = new.U, new.nu_b, new.nu_c
    for i in range(U.shape[0]):
        U[i] += theta * (U_new[i] - U[i])
    for r in range(nu_b.shape[0]):
        nu_b[r] += theta * (nub_new[r] - nu_b[r])
    for k in range(nu_c.shape[0]):
        nu_c[k] += theta * (nuc_new[k] - nu_c[k])
    _position_rows(q_t, t1, ma, it, scratch)
    return _position_residual(it, ma, metric)


@step_kernel
def position_step(q_t, t1, h, st, ma, Ks_t, q1, nu_c, gap, wk):
    """Position correction: M U = G^T nu (with the springs' elastic stiffness h^2 Ks in the
    metric, symmetric positive semi-definite so that the metric stays positive definite),
    joints g(q_t + U) = 0 and 0 <= g_N ⊥ nu_N >= 0 for every contact.

    Semismooth Newton with Delassus-scaled augmentation r_j = 1/(G_j A^-1 G_j^T), a proximal
    term (eta/r)(nu - nu_k) on active rows for redundant (pinched) contacts, and a backtracking
    line search on the scaled residual.

    Parameters
    ----------
    q_t : ndarray
        Predicted coordinates q~ of the smooth stage [m, rad].
    t1 : float
        Time at the end of the step [s] (the prescribed rotation's angle).
    h : float
        Step [s].
    st : StepSettings
        ``tol`` [m/s] (the gaps and joints to tol * h [m]), ``max_iter``, ``eta`` [-].
    ma : ModelArrays
        The model.
    Ks_t : ndarray
        The springs' elastic stiffness at q~ [N/m].
    q1 : ndarray
        Receives q~ + U [m, rad].
    nu_c, gap : ndarray
        The contacts' multipliers [kg m] (the previous step's on entry: the iteration starts
        from them, as from ``wk.nu_b`` for the joints; zeros at a run's start) and gaps [m] at
        q1, on exit.
    wk : PositionWork
        Work arrays (:func:`position_work`).

    Returns
    -------
    (int, bool)
        Newton iterations, converged.
    """
    it = PositionIterate(wk.U, wk.nu_b, nu_c, q1, wk.gb, wk.Gb, gap, wk.GN, wk.AU)
    metric = wk.metric
    scratch = wk.scratch
    lin = wk.lin
    tr = wk.trial
    new = wk.new
    _prepare_position(q_t, t1, h, ma, Ks_t, it, metric, scratch, lin.rows)
    res = _position_residual(it, ma, metric)
    target = st.tol * h
    eta = st.eta
    eta_k = eta
    iters = 0
    converged = res <= target
    # at least one Newton step, so that every step restores the joints (a drift below tol*h
    # would otherwise accumulate up to that level): what is left is the quadratic remainder
    # of one Newton step (docs/method.md)
    while (not converged or iters == 0) and iters < st.max_iter:
        iters += 1
        _guess_active_set(it, metric, lin.active)
        fac = lin.facH if _factor_newton_matrix(it, ma, metric.Ap, lin) else metric.facA
        _linearise(fac, it, metric, lin)
        m = _pivot_active_set(fac, it, eta_k, target, metric, lin)
        _newton_point(m, it, lin, new)
        theta, last_theta, best_res = _position_line_search(q_t, t1, res, it, ma, tr, new,
                                                            scratch, metric)
        if theta < 0.125:
            # the active set cycles (the full step does not reduce the residual): stiffen the
            # proximal term so that the multipliers move less per iteration
            eta_k = min(100.0 * eta_k, 1e-1)
        elif theta == 1.0:
            eta_k = max(eta, 0.01 * eta_k)  # back towards plain Newton once steps go through
        res = _take_position_step(q_t, t1, theta, last_theta, best_res, it, ma, tr, new,
                                  scratch, metric)
        converged = res <= target
    return iters, converged
